//! Arrow tables of a reconstruction: `trajectory`, `residuals` and `errors`. Column names
//! carry frame and unit (`north_m`, `yaw_rad`, `gyro_bias_x_rad_s`); units are also in each
//! field's metadata under `unit`, as in the export tables.

use super::columns::Columns;
use crate::filters::ins::driver::Residual;
use crate::filters::ins::record::Solution;
use crate::geodesy;
use crate::recon::score::EpochError;
use arrow_array::{BooleanArray, RecordBatch, UInt8Array};
use arrow_schema::{ArrowError, DataType, Field};
use std::sync::Arc;

/// One column per element of `f`'s output over `rows`.
fn column<T>(rows: &[T], f: impl Fn(&T) -> f64) -> Vec<f64> {
    rows.iter().map(f).collect()
}

/// One column per axis: `name` with `{}` replaced by each axis, the axis's index given to `f`.
fn per_axis<T>(
    c: &mut Columns,
    rows: &[T],
    (name, unit): (&str, &str),
    axes: &[&str],
    f: impl Fn(&T, usize) -> f64,
) {
    for (i, axis) in axes.iter().enumerate() {
        c.number(&name.replace("{}", axis), unit, column(rows, |s| f(s, i)));
    }
}

const NED: [&str; 3] = ["north", "east", "down"];
const BODY: [&str; 3] = ["x", "y", "z"];

/// Rows of `trajectory.parquet` for one solution (`forward` or `smoothed`): position
/// (geodetic and in the mission frame), NED velocity, Euler angles, their 1-sigma, the bias
/// estimates, the DVL's calibration and the water states.
pub fn trajectory_batch(
    solution: &str,
    rows: &[Solution],
    origin_rad: (f64, f64),
) -> Result<RecordBatch, ArrowError> {
    let mut c = Columns::default();
    c.stamps(rows.iter().map(|s| s.stamp_ns).collect());
    c.text("solution", vec![solution; rows.len()]);
    navigation_columns(&mut c, rows, origin_rad);
    sigma_columns(&mut c, rows);
    calibration_columns(&mut c, rows);
    c.finish()
}

/// Position (geodetic and in the mission frame), NED velocity and Euler angles.
fn navigation_columns(c: &mut Columns, rows: &[Solution], origin_rad: (f64, f64)) {
    let nav = |s: &Solution| s.point.nav;
    c.number(
        "latitude_deg",
        "deg",
        column(rows, |s| nav(s).lat_rad.to_degrees()),
    );
    c.number(
        "longitude_deg",
        "deg",
        column(rows, |s| nav(s).lon_rad.to_degrees()),
    );
    let local = |s: &Solution| {
        let n = nav(s);
        geodesy::local_north_east_m(origin_rad.0, origin_rad.1, n.lat_rad, n.lon_rad)
    };
    c.number("north_m", "m", column(rows, |s| local(s).0));
    c.number("east_m", "m", column(rows, |s| local(s).1));
    c.number("down_m", "m", column(rows, |s| -nav(s).height_m));
    per_axis(c, rows, ("vel_{}_m_s", "m/s"), &NED, |s, i| {
        nav(s).vel_ned_m_s[i]
    });
    let euler: Vec<[f64; 3]> = rows.iter().map(Solution::euler_rad).collect();
    per_axis(
        c,
        &euler,
        ("{}_rad", "rad"),
        &["roll", "pitch", "yaw"],
        |e, i| e[i],
    );
}

/// The 1-sigma of position, velocity and the Euler angles.
fn sigma_columns(c: &mut Columns, rows: &[Solution]) {
    per_axis(c, rows, ("{}_sigma_m", "m"), &NED, |s, i| s.sigma[i]);
    per_axis(c, rows, ("vel_{}_sigma_m_s", "m/s"), &NED, |s, i| {
        s.sigma[3 + i]
    });
    let euler_sigma: Vec<[f64; 3]> = rows.iter().map(Solution::euler_sigma_rad).collect();
    let angles = ["roll", "pitch", "yaw"];
    per_axis(c, &euler_sigma, ("{}_sigma_rad", "rad"), &angles, |e, i| {
        e[i]
    });
}

/// The IMU's biases and z gyro scale, the DVL's calibration and the water states (constant
/// where they are held).
fn calibration_columns(c: &mut Columns, rows: &[Solution]) {
    let p = |s: &Solution| s.point;
    per_axis(c, rows, ("gyro_bias_{}_rad_s", "rad/s"), &BODY, |s, i| {
        p(s).gyro_bias[i]
    });
    per_axis(c, rows, ("accel_bias_{}_m_s2", "m/s^2"), &BODY, |s, i| {
        p(s).accel_bias[i]
    });
    c.number(
        "gyro_scale_factor_z",
        "1",
        column(rows, |s| 1.0 + p(s).gyro_scale_z),
    );
    c.number("dvl_scale_factor", "1", column(rows, |s| 1.0 + p(s).dvl[0]));
    let misalignment = ("dvl_misalignment_{}_rad", "rad");
    per_axis(c, rows, misalignment, &["pitch", "heading"], |s, i| {
        p(s).dvl[1 + i]
    });
    per_axis(c, rows, ("dvl_bias_{}_m_s", "m/s"), &BODY, |s, i| {
        p(s).dvl[3 + i]
    });
    c.number(
        "eml_scale_factor",
        "1",
        column(rows, |s| 1.0 + p(s).water[0]),
    );
    let current = ("current_{}_m_s", "m/s");
    per_axis(c, rows, current, &["north", "east"], |s, i| {
        p(s).water[1 + i]
    });
}

/// Rows of `residuals.parquet`: one per aiding measurement the filter saw. Innovation
/// components are measured minus predicted, in the measurement's own axes (DVL: its x/y/z;
/// position: north/east; depth, speed: the one value); unused components are null.
pub fn residuals_batch(rows: &[Residual]) -> Result<RecordBatch, ArrowError> {
    let mut c = Columns::default();
    c.stamps(rows.iter().map(|r| r.stamp_ns).collect());
    c.text("sensor", rows.iter().map(|r| r.sensor.name()).collect());
    for i in 0..3 {
        c.optional(
            &format!("innovation_{i}"),
            "sensor unit",
            rows.iter()
                .map(|r| (i < usize::from(r.dims)).then_some(r.innovation[i]))
                .collect(),
        );
    }
    for i in 0..3 {
        c.optional(
            &format!("sigma_{i}"),
            "sensor unit",
            rows.iter()
                .map(|r| (i < usize::from(r.dims)).then_some(r.sigma[i]))
                .collect(),
        );
    }
    c.push(
        Field::new("dims", DataType::UInt8, false),
        Arc::new(UInt8Array::from(
            rows.iter().map(|r| r.dims).collect::<Vec<_>>(),
        )),
    );
    c.number("nis", "", rows.iter().map(|r| r.nis).collect());
    c.push(
        Field::new("accepted", DataType::Boolean, false),
        Arc::new(BooleanArray::from(
            rows.iter().map(|r| r.accepted).collect::<Vec<_>>(),
        )),
    );
    c.optional(
        "slant_range_m",
        "m",
        (rows.iter())
            .map(|r| r.slant_range_m.map(f64::from))
            .collect(),
    );
    c.finish()
}

/// Rows of `errors.parquet` for one solution: estimate minus truth, with the 1-sigma the
/// solution claims and the NEES.
pub fn errors_batch(solution: &str, rows: &[EpochError]) -> Result<RecordBatch, ArrowError> {
    let mut c = Columns::default();
    c.stamps(rows.iter().map(|e| e.stamp_ns).collect());
    c.text("solution", vec![solution; rows.len()]);
    for (i, axis) in ["north", "east", "down"].iter().enumerate() {
        c.number(
            &format!("{axis}_error_m"),
            "m",
            column(rows, |e| e.position_m[i]),
        );
    }
    c.number(
        "horizontal_error_m",
        "m",
        column(rows, EpochError::horizontal_m),
    );
    for (i, axis) in ["north", "east", "down"].iter().enumerate() {
        c.number(
            &format!("{axis}_sigma_m"),
            "m",
            column(rows, |e| e.position_sigma_m[i]),
        );
    }
    for (i, axis) in ["north", "east", "down"].iter().enumerate() {
        c.number(
            &format!("vel_{axis}_error_m_s"),
            "m/s",
            column(rows, |e| e.velocity_m_s[i]),
        );
    }
    for (i, angle) in ["roll", "pitch", "yaw"].iter().enumerate() {
        c.number(
            &format!("{angle}_error_rad"),
            "rad",
            column(rows, |e| e.euler_rad[i]),
        );
    }
    for (i, angle) in ["roll", "pitch", "yaw"].iter().enumerate() {
        c.number(
            &format!("{angle}_sigma_rad"),
            "rad",
            column(rows, |e| e.euler_sigma_rad[i]),
        );
    }
    c.number("nees_horizontal", "", column(rows, |e| e.nees_horizontal));
    c.number("nees_position", "", column(rows, |e| e.nees_position));
    c.finish()
}
