//! CSV import: the survey sample log written out as CSV files in the layout of the shipped
//! map `sample-logs/csv/vehicle-computer.toml` (IMU and magnetometer in FLU, g, deg/s, uT;
//! sensors of other rates interleaved in one file), imported with that map, holds the
//! original's values and reconstructs within 1 mm of it. A cell that does not parse fails
//! the import naming its file, line and column, and writes nothing.

use crate::common;
use hindsight::contract::{Message, Streams};
use hindsight::ingest::{read_log, IngestOptions, Log};
use hindsight::recon::config::Config;
use hindsight::recon::run_configured as reconstruct;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

fn repo(path: &str) -> PathBuf {
    common::repo_path(path)
}

/// A stamp as the vehicle computer writes it: seconds with nine decimals.
fn seconds(stamp_ns: i64) -> String {
    format!(
        "{}.{:09}",
        stamp_ns.div_euclid(1_000_000_000),
        stamp_ns.rem_euclid(1_000_000_000)
    )
}

fn messages<T: Message>(log: &Log) -> &[T] {
    log.role_topic::<T>()
        .and_then(|t| log.messages::<T>(t))
        .unwrap_or(&[])
}

/// Writes imu.csv, dvl.csv and nav.csv of `log` into `dir`, in the map's layout.
fn write_csv(log: &Log, dir: &Path) -> Vec<PathBuf> {
    use hindsight::contract::*;
    let (deg, g) = (180.0 / std::f64::consts::PI, 9.80665);
    let mut imu = String::from("time,acc_x,acc_y,acc_z,gyro_x,gyro_y,gyro_z\n");
    for m in messages::<Imu>(log) {
        let (f, w) = (m.specific_force, m.angular_velocity);
        // FLU: y and z change sign.
        let _ = writeln!(
            imu,
            "{},{:?},{:?},{:?},{:?},{:?},{:?}",
            seconds(m.stamp_ns),
            f[0] / g,
            -f[1] / g,
            -f[2] / g,
            w[0] * deg,
            -w[1] * deg,
            -w[2] * deg
        );
    }
    let mut dvl = String::from("time,vel_x,vel_y,vel_z,bottom_lock,altitude\n");
    for m in messages::<Dvl>(log) {
        let v = m.velocity;
        let altitude = m.altitude.map(|a| format!("{a:?}")).unwrap_or_default();
        let lock = u8::from(m.valid);
        let _ = writeln!(
            dvl,
            "{},{:?},{:?},{:?},{lock},{altitude}",
            seconds(m.stamp_ns),
            v[0],
            v[1],
            v[2]
        );
    }
    // The slower sensors interleaved: one row per stamp, empty cells for the others.
    const COLUMNS: usize = 10;
    let mut rows: BTreeMap<i64, [String; COLUMNS]> = BTreeMap::new();
    let mut put = |stamp: i64, cells: &[(usize, f64)]| {
        let row = rows.entry(stamp).or_default();
        for &(i, x) in cells {
            row[i] = format!("{x:?}");
        }
    };
    for m in messages::<Depth>(log) {
        put(m.stamp_ns, &[(0, m.depth)]);
    }
    for m in messages::<Altimeter>(log) {
        put(m.stamp_ns, &[(1, m.altitude)]);
    }
    for m in messages::<MagneticField>(log) {
        let b = m.magnetic_field;
        put(
            m.stamp_ns,
            &[(2, b[0] * 1e6), (3, -b[1] * 1e6), (4, -b[2] * 1e6)],
        );
    }
    for m in messages::<SpeedLog>(log) {
        put(m.stamp_ns, &[(5, m.speed)]);
    }
    for m in messages::<Propeller>(log) {
        put(m.stamp_ns, &[(6, m.rpm)]);
    }
    for m in messages::<GnssFix>(log) {
        put(
            m.stamp_ns,
            &[
                (7, m.latitude_deg),
                (8, m.longitude_deg),
                (9, m.horizontal_sigma_m),
            ],
        );
    }
    let mut nav = String::from(
        "time,depth,altitude,mag_x,mag_y,mag_z,water_speed,prop_rpm,lat,lon,fix_sigma\n",
    );
    for (stamp, cells) in rows {
        let _ = writeln!(nav, "{},{}", seconds(stamp), cells.join(","));
    }
    [("imu.csv", imu), ("dvl.csv", dvl), ("nav.csv", nav)]
        .into_iter()
        .map(|(name, text)| {
            let path = dir.join(name);
            std::fs::write(&path, text).unwrap();
            path
        })
        .collect()
}

fn import(files: &[PathBuf], out: &Path) -> std::process::Output {
    let map = repo("sample-logs/csv/vehicle-computer.toml");
    let mut args = vec![
        "import".to_string(),
        "csv".into(),
        "--map".into(),
        map.display().to_string(),
    ];
    args.extend(files.iter().map(|f| f.display().to_string()));
    args.extend(["--out".into(), out.display().to_string()]);
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    common::hindsight(&args)
}

fn close(a: &[f64], b: &[f64], tol: f64, what: &str) {
    for (x, y) in a.iter().zip(b) {
        assert!(
            (x - y).abs() <= tol * x.abs().max(1.0),
            "{what}: {x} against {y}"
        );
    }
}

#[test]
fn the_survey_as_csv_files_imports_and_reconstructs_within_a_millimetre() {
    use hindsight::contract::*;
    let dir = common::scratch_dir("import-csv");
    let original = read_log(
        &repo("sample-logs/survey-short-seed1.mcap"),
        &IngestOptions::default(),
    )
    .unwrap();
    let files = write_csv(&original, &dir);
    let out = dir.join("survey-from-csv.mcap");
    let o = import(&files, &out);
    assert!(o.status.success(), "{}", common::stderr(&o));
    let imported = read_log(&out, &IngestOptions::default()).unwrap();
    assert!(imported.warnings().is_empty(), "{:?}", imported.warnings());

    // Every stream's stamps exactly, its values to the rounding of the unit conversions.
    let (a, b) = (Streams::of(&original), Streams::of(&imported));
    assert_eq!(a.imu.len(), b.imu.len());
    for (x, y) in a.imu.iter().zip(b.imu) {
        assert_eq!(x.stamp_ns, y.stamp_ns);
        close(
            &x.specific_force,
            &y.specific_force,
            1e-14,
            "specific force",
        );
        close(
            &x.angular_velocity,
            &y.angular_velocity,
            1e-14,
            "angular velocity",
        );
    }
    assert_eq!(
        a.dvl, b.dvl,
        "DVL: written and read in m/s and FRD, exactly"
    );
    assert_eq!(a.depth, b.depth);
    assert_eq!(a.altimeter, b.altimeter);
    assert_eq!(a.eml, b.eml);
    assert_eq!(a.rpm, b.rpm);
    assert_eq!(a.gnss, b.gnss);
    assert_eq!(a.mag.len(), b.mag.len());
    for (x, y) in a.mag.iter().zip(b.mag) {
        assert_eq!(x.stamp_ns, y.stamp_ns);
        close(
            &x.magnetic_field,
            &y.magnetic_field,
            1e-14,
            "magnetic field",
        );
    }

    // The same mission reconstructs within 1 mm (the CSV files carry no mission record:
    // the sample's is given, as a user would with --origin).
    let mission = original.mission().unwrap();
    let defaults = common::defaults_of(&mission);
    let config = Config::default();
    let reference = reconstruct(&Streams::of(&original), &mission, &config).unwrap();
    let from_csv = reconstruct(
        &Streams::of(&imported),
        &imported.mission_or(&defaults).unwrap(),
        &config,
    )
    .unwrap();
    assert!(reference.smoothed.len() > 1000);
    common::assert_within_a_millimetre("csv", &reference, &from_csv);
}

#[test]
fn a_cell_that_does_not_parse_is_named_and_nothing_is_written() {
    let dir = common::scratch_dir("import-csv-bad");
    let imu = dir.join("imu.csv");
    std::fs::write(
        &imu,
        "time,acc_x,acc_y,acc_z,gyro_x,gyro_y,gyro_z\n\
         1700000000.00,0,0,-1,0,0,0\n\
         1700000000.01,0,0,-1,0.1,0O2,0\n",
    )
    .unwrap();
    let out = dir.join("bad.mcap");
    let o = import(std::slice::from_ref(&imu), &out);
    assert_eq!(o.status.code(), Some(1), "{}", common::stderr(&o));
    let err = common::stderr(&o);
    assert!(
        err.contains(&format!(
            "{}, line 3, column `gyro_y`: `0O2` is not a number",
            imu.display()
        )),
        "{err}"
    );
    assert!(!out.exists(), "nothing is written");
    assert_eq!(
        std::fs::read_dir(&dir).unwrap().count(),
        1,
        "no staged file left"
    );

    // A file no [[file]] matches, and a column the map names but the file lacks.
    let other = dir.join("sonar.csv");
    std::fs::write(&other, "time,range\n1,2\n").unwrap();
    let err = common::stderr(&import(&[other], &out));
    assert!(
        err.contains("no [[file]] of the map matches its name"),
        "{err}"
    );
    let short = dir.join("dvl.csv");
    std::fs::write(&short, "time,vel_x,vel_y\n1,2,3\n").unwrap();
    let err = common::stderr(&import(&[short], &out));
    assert!(
        err.contains("no column `vel_z` (the header has: time, vel_x, vel_y)"),
        "{err}"
    );
    assert!(!out.exists());
}

#[test]
fn the_shipped_ins_export_map_reads_its_example() {
    let dir = common::scratch_dir("import-csv-ins");
    let out = dir.join("ins.mcap");
    let o = common::hindsight(&[
        "import",
        "csv",
        "--map",
        repo("sample-logs/csv/ins-export.toml").to_str().unwrap(),
        repo("sample-logs/csv/ins-example.csv").to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", common::stderr(&o));
    let log = read_log(&out, &IngestOptions::default()).unwrap();
    let s = Streams::of(&log);
    let attitude = log
        .messages::<hindsight::contract::Attitude>("/attitude")
        .unwrap();
    assert_eq!((attitude.len(), s.depth.len()), (50, 50));
    // 2016-05-03T10:00:00.100Z; heading 352 deg; pitch -1.19 deg; depth 5.01 m.
    assert_eq!(attitude[1].stamp_ns, 1_462_269_600_100_000_000);
    assert!((attitude[1].yaw.to_degrees() - 352.0).abs() < 1e-9);
    assert!((attitude[1].pitch.to_degrees() + 1.19).abs() < 1e-9);
    assert_eq!(s.depth[1].depth, 5.01);
}
