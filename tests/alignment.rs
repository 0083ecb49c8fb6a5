//! Acceptance: the reconstruction finds its own heading. From any start heading
//! (the in-motion alignment), after a dropped entry (the start carried by the gyro, the
//! magnetometer as an aid), and without any heading source. Scored against `/truth`.

use crate::common;
use hindsight::config::Section;
use hindsight::contract::Truth;
use hindsight::ingest::Log;
use hindsight::recon::alignment::heading::HeadingSource;
use hindsight::recon::config::{Config, HeadingChoice};
use hindsight::recon::score::{scores, Scores};
use hindsight::recon::{run_configured as reconstruct, Reconstruction, Streams};
use hindsight::sim::scenario::Scenario;

use common::output_errors as errors;

fn run(log: &Log, config: &Config) -> (Reconstruction, Scores, Scores) {
    let streams = Streams::of(log);
    let r = reconstruct(&streams, &log.mission().unwrap(), config).unwrap();
    let (f, s) = errors(streams.truth, &r);
    (r, scores(&f).unwrap(), scores(&s).unwrap())
}

/// `--heading given --initial-yaw X` for X = 0, 45, ..., 315 deg away from the truth: the
/// smoothed horizontal RMS within 10 % of the truth-started run's, the forward within 2x. On
/// the short survey (GNSS at the surface, DVL, EM log), with the magnetometer and without it
/// (then only the GNSS track and the DVL tell the heading).
#[test]
fn any_start_heading_converges() {
    let log = common::simulated_log(&Scenario::built_in("survey-short").unwrap(), 1);
    let truth_yaw_deg = log.messages::<Truth>("/truth").unwrap()[0].attitude[2].to_degrees();
    for mag in [true, false] {
        let given = |offset_deg: f64| {
            let mut c = Config::default();
            c.mag.enabled = mag;
            c.initial.heading = HeadingChoice::Given;
            c.initial.yaw_deg = Some(truth_yaw_deg + offset_deg);
            c
        };
        let (_, fwd0, smo0) = run(&log, &given(0.0));
        println!(
            "mag {mag}: truth-started forward {:.2} m, smoothed {:.2} m",
            fwd0.horizontal_rms_m, smo0.horizontal_rms_m
        );
        for k in 1..8 {
            let offset = 45.0 * k as f64;
            let (r, fwd, smo) = run(&log, &given(offset));
            println!(
                "  start {offset:>3} deg off: heading from {}, forward {:.2} m, smoothed {:.2} m",
                r.init.heading.name(),
                fwd.horizontal_rms_m,
                smo.horizontal_rms_m
            );
            assert_eq!(r.init.heading, HeadingSource::InMotion, "{offset}");
            assert!(
                smo.horizontal_rms_m <= 1.1 * smo0.horizontal_rms_m,
                "mag {mag}, {offset} deg: smoothed {} vs {}",
                smo.horizontal_rms_m,
                smo0.horizontal_rms_m
            );
            assert!(
                fwd.horizontal_rms_m <= 2.0 * fwd0.horizontal_rms_m,
                "mag {mag}, {offset} deg: forward {} vs {}",
                fwd.horizontal_rms_m,
                fwd0.horizontal_rms_m
            );
        }
    }
}

/// Seed 002's dropped entry with the default settings: rolling and pitching 10 deg at the
/// start. Over seeds 1-5: the start's roll and pitch within 3 sigma and 0.3 deg, the final
/// horizontal error <= 10 m. (The yaw criterion is [`dropped_entry_yaw_after_30_s`].)
#[test]
fn dropped_entry_with_default_settings() {
    for seed in 1..=5 {
        let (tilt_error, tilt_sigma, yaw_rms, final_m) = drop_entry(seed);
        println!(
            "drop-entry seed {seed}: start tilt error {tilt_error:.2} deg (1-sigma {tilt_sigma:.2}); \
             yaw RMS after 30 s {yaw_rms:.3} deg; final horizontal {final_m:.2} m"
        );
        assert!(
            tilt_error < 3.0 * tilt_sigma && tilt_error < 0.3,
            "seed {seed}"
        );
        assert!(final_m <= 10.0, "seed {seed}: {final_m}");
    }
}

/// The yaw criterion on the dropped entry: yaw RMS after 30 s <= 1 deg on every seed.
/// It was 1.008 deg on seed 1 before the 25-state model (0.968 deg since the EM log became a speed along
/// the body through a current); seed 1 stays the hardest, because over 300 s a tactical
/// gyro's bias and a heading error tilt the vehicle alike through the Earth rate and the
/// magnetometer's default (a real compass: 2 deg, 60 s correlated) holds the heading loosely.
#[test]
fn dropped_entry_yaw_after_30_s() {
    for seed in 1..=5 {
        let (_, _, yaw_rms, _) = drop_entry(seed);
        println!("drop-entry seed {seed}: yaw RMS after 30 s {yaw_rms:.3} deg");
        assert!(yaw_rms <= 1.0, "seed {seed}: {yaw_rms}");
    }
}

/// Start tilt error and sigma (deg), forward yaw RMS after 30 s (deg), final horizontal
/// error (m) of `drop-entry` with the default settings.
fn drop_entry(seed: u64) -> (f64, f64, f64, f64) {
    let log = common::simulated_log(&Scenario::built_in("drop-entry").unwrap(), seed);
    let (r, fwd, _) = run(&log, &Config::default());
    let streams = Streams::of(&log);
    let (f, _) = errors(streams.truth, &r);
    let t0 = f[0].stamp_ns;
    let late: Vec<f64> = f
        .iter()
        .filter(|e| e.stamp_ns - t0 >= 30_000_000_000)
        .map(|e| e.euler_rad[2].to_degrees())
        .collect();
    let yaw_rms = (late.iter().map(|y| y * y).sum::<f64>() / late.len() as f64).sqrt();
    let (roll, pitch, _) = r.init.estimate.nav.ned_from_body.euler_angles();
    let tilt_error = (roll.to_degrees() - 10.0)
        .abs()
        .max((pitch.to_degrees() + 10.0).abs());
    (
        tilt_error,
        r.init.tilt_sigma_deg,
        yaw_rms,
        fwd.horizontal_final_m,
    )
}

/// A log from 2016 (before the World Magnetic Model's years) whose writer left the
/// declination out: the magnetometer's heading takes IGRF-14's declination for the start's
/// place and date, with a sigma under 0.5 deg, and no "declination unknown" warning. The
/// simulated field is IGRF-14's own at the origin, so the start heading is checked against
/// the truth.
#[test]
fn a_2016_log_without_a_declination_takes_igrfs() {
    use hindsight::recon::alignment::heading::DeclinationSource;
    let mut scenario = Scenario::built_in("survey-short").unwrap();
    let day = hindsight::time::days_from_civil(2016, 6, 15);
    scenario.start_stamp_ns = day * 86_400 * 1_000_000_000;
    scenario.mission.declination_in_log = false;
    let year = hindsight::geomag::decimal_year(scenario.start_stamp_ns);
    let (lat, lon) = (
        scenario.mission.origin_latitude_deg,
        scenario.mission.origin_longitude_deg,
    );
    let field = hindsight::geomag::igrf::field_geodetic(year, lat, lon, 0.0).unwrap();
    let mag = scenario.mag.as_mut().unwrap();
    mag.field_ned_nt = [field.north_nt, field.east_nt, field.down_nt];
    let log = common::simulated_log(&scenario, 1);
    assert_eq!(log.mission().unwrap().magnetic_declination_deg, None);

    let mut config = Config::default();
    config.initial.heading = HeadingChoice::Magnetometer;
    let (r, fwd, _) = run(&log, &config);
    let used = r.init.declination.unwrap();
    println!(
        "declination {:.3} deg (1-sigma {:.2}) from {:?}; the field's {:.3} deg; start heading \
         from {}; forward yaw RMS {:.3} deg",
        used.declination_deg,
        used.sigma_deg,
        used.source,
        field.declination_deg(),
        r.init.heading.name(),
        fwd.yaw_rms_deg
    );
    assert_eq!(used.source, DeclinationSource::Igrf);
    assert!((used.declination_deg - field.declination_deg()).abs() < 0.05);
    assert!(used.sigma_deg <= 0.5, "{}", used.sigma_deg);
    assert_eq!(r.init.heading, HeadingSource::Magnetometer);
    let truth_yaw = log.messages::<Truth>("/truth").unwrap()[0].attitude[2];
    let (_, _, yaw) = r.init.estimate.nav.ned_from_body.euler_angles();
    let error_deg = hindsight::angle::wrap_pi(yaw - truth_yaw).to_degrees();
    assert!(
        error_deg.abs() <= 3.0 * r.init.heading_sigma_deg,
        "start heading {error_deg} deg off, 1-sigma {}",
        r.init.heading_sigma_deg
    );
}

/// `long-dive-dynamic` (5.5 h, no magnetometer, no heading in the mission) with its sensors'
/// settings (`configs/long-dive.toml`): no heading source at all, the in-motion alignment
/// finds it, and the smoothed yaw RMS is <= 0.5 deg.
#[test]
fn long_dynamic_dive_without_a_heading_source() {
    let log = common::simulated_log(&Scenario::built_in("long-dive-dynamic").unwrap(), 1);
    let config = Config::from_toml(include_str!("../configs/long-dive.toml")).unwrap();
    let (r, fwd, smo) = run(&log, &config);
    println!(
        "long-dive-dynamic: start heading from {} ({:.2} deg, 1-sigma {:.2}), sources {:?}; \
         yaw RMS forward {:.3} deg, smoothed {:.3} deg; horizontal RMS forward {:.0} m, \
         smoothed {:.0} m",
        r.init.heading.name(),
        r.init
            .estimate
            .nav
            .ned_from_body
            .euler_angles()
            .2
            .to_degrees(),
        r.init.heading_sigma_deg,
        r.init.heading_sources,
        fwd.yaw_rms_deg,
        smo.yaw_rms_deg,
        fwd.horizontal_rms_m,
        smo.horizontal_rms_m
    );
    assert!(r.init.heading_sources.is_empty());
    assert_eq!(r.init.heading, HeadingSource::InMotion);
    assert!(smo.yaw_rms_deg <= 0.5, "{}", smo.yaw_rms_deg);
}

/// Bad input: a declination out of range is exit 2 naming the key, nothing written.
#[test]
fn a_declination_out_of_range_is_refused() {
    let sample = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/sample-logs/survey-short-seed1.mcap"
    );
    let out = common::scratch_dir("alignment-bad").join("out");
    let o = common::hindsight(&[
        "reconstruct",
        sample,
        "--out",
        out.to_str().unwrap(),
        "--declination",
        "250",
    ]);
    let text = common::stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{text}");
    assert!(text.contains("declination"), "{text}");
    assert!(!text.contains("panicked"), "{text}");
    assert!(!out.exists());
}
