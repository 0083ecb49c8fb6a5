//! The DVL calibration: the scale factor and the mounting's heading misalignment are
//! estimated with the trajectory, within 3 sigma of the simulated truth, with sigmas the log
//! supports (Delph INS calls a calibration good under 0.1 % and 0.1 deg). Without fixes they
//! are carried at their priors, and the position's uncertainty stays honest.

use crate::common;
use hindsight::config::Section;
use hindsight::filters::ins::error_state::idx;
use hindsight::recon::config::Config;
use hindsight::recon::score::scores;
use hindsight::recon::{run_configured as reconstruct, Streams};
use hindsight::sim::scenario::Scenario;
use hindsight::sim::sensors::dvl::DvlSensor;
use hindsight::sim::sensors::{rng_for, stream};

/// The survey's sensors (configs/survey.toml) with the DVL's calibration estimated from the
/// priors of an uncalibrated installation (0.5 %, 1 deg, 2 mm/s) and its white noise alone
/// (0.01 m/s).
fn survey_config() -> Config {
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/configs/survey.toml"))
        .unwrap();
    let mut c = Config::from_toml(&text).unwrap();
    c.dvl.scale_misalignment = hindsight::recon::on_off_auto::Switch::On;
    c.dvl.scale_sigma = 0.005;
    c.dvl.misalignment_sigma_deg = 1.0;
    c.dvl.bias_sigma_m_s = 0.002;
    c.dvl.sigma_m_s = 0.01;
    c
}

/// The survey with a 0.5 % scale error and a 1 deg heading misalignment, GNSS at both ends and
/// a USBL fix every 10 minutes: scale and misalignment within 3 sigma, sigma at most 0.1 % and
/// 0.1 deg; and the horizontal NEES inside its 95 % bounds for at least 70 % of the epochs.
#[test]
fn scale_and_misalignment_are_estimated() {
    let scenario = Scenario::built_in("survey-dvl-calibration").unwrap();
    let seed = 1;
    let log = common::simulated_log(&scenario, seed);
    let spec = scenario.dvl.unwrap();
    let true_scale = DvlSensor::new(spec, rng_for(seed, stream::DVL)).scale;
    let true_heading_deg = spec.misalignment_deg[1];
    let streams = Streams::of(&log);
    let r = reconstruct(&streams, &log.mission().unwrap(), &survey_config()).unwrap();
    let last = r.forward.last().unwrap().unwrap();
    let (scale, scale_sigma) = (last.point.dvl[0], last.sigma[idx::DVL_SCALE]);
    let (heading, heading_sigma) = (
        last.point.dvl[2].to_degrees(),
        last.sigma[idx::DVL_MISALIGNMENT + 1].to_degrees(),
    );
    eprintln!(
        "scale error {:.4} % +- {:.4} (truth {:.4} %); heading {heading:.3} +- {heading_sigma:.3} deg (truth {true_heading_deg})",
        100.0 * scale,
        100.0 * scale_sigma,
        100.0 * true_scale
    );
    assert!((scale - true_scale).abs() <= 3.0 * scale_sigma);
    assert!(scale_sigma <= 0.001);
    assert!((heading - true_heading_deg).abs() <= 3.0 * heading_sigma);
    assert!(heading_sigma <= 0.1);
    let (fwd, smo) = common::output_errors(streams.truth, &r);
    let (fwd, smo) = (scores(&fwd).unwrap(), scores(&smo).unwrap());
    eprintln!(
        "NEES inside: forward {:.3}, smoothed {:.3}; RMS {:.2} / {:.2} m",
        fwd.nees_horizontal_inside_95,
        smo.nees_horizontal_inside_95,
        fwd.horizontal_rms_m,
        smo.horizontal_rms_m
    );
    assert!(fwd.nees_horizontal_inside_95 >= 0.7 && smo.nees_horizontal_inside_95 >= 0.7);
}
