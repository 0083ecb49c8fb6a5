//! The velocity filters on `trench-eml` (5-minute DVL outages over two trenches,
//! `/rpm` and `/eml` present): seed 003's propeller velocity filter against switching alone,
//! both from the default configuration otherwise, scored against `/truth`.

use crate::common;
use hindsight::contract::Propeller;
use hindsight::filters::ins::aid_table::Sensor;
use hindsight::ingest::Log;
use hindsight::recon::config::Config;
use hindsight::recon::score::{scores, Scores};
use hindsight::recon::{run_configured as reconstruct, Streams};
use hindsight::sim::scenario::Scenario;

use common::output_errors as errors;

fn with_rpm_velocity(used: bool) -> Config {
    let mut c = Config::default();
    c.rpm_velocity.enabled = hindsight::recon::on_off_auto::Switch::from_bool(used);
    c
}

fn run(log: &Log, config: &Config) -> (Scores, usize) {
    let streams = Streams::of(log);
    let r = reconstruct(&streams, &log.mission().unwrap(), config).unwrap();
    let used = r
        .run
        .residuals
        .iter()
        .filter(|x| x.sensor == Sensor::RpmVelocity && x.accepted)
        .count();
    (scores(&errors(streams.truth, &r).0).unwrap(), used)
}

/// With the propeller's speed through the outages, the forward solution's worst error is
/// smaller than with switching alone (the EM log and the INS), and its uncertainty stays
/// honest.
#[test]
fn the_propeller_bridges_the_trench_outages() {
    let log = common::simulated_log(&Scenario::built_in("trench-eml").unwrap(), 1);
    let (switching, none) = run(&log, &with_rpm_velocity(false));
    let (bridged, used) = run(&log, &with_rpm_velocity(true));
    eprintln!(
        "trench-eml seed 1, forward: switching alone RMS {:.2} m, max {:.2} m; with the \
         velocity filter RMS {:.2} m, max {:.2} m, NEES inside {:.1} % ({used} speeds used)",
        switching.horizontal_rms_m,
        switching.horizontal_max_m,
        bridged.horizontal_rms_m,
        bridged.horizontal_max_m,
        100.0 * bridged.nees_horizontal_inside_95
    );
    assert_eq!(none, 0);
    assert!(used > 500, "{used} propeller speeds used");
    assert!(bridged.horizontal_max_m < switching.horizontal_max_m);
    assert!(bridged.horizontal_rms_m < switching.horizontal_rms_m);
    assert!(bridged.nees_horizontal_inside_95 >= 0.7);
}

/// A propeller that reads zero while the vehicle moves is refused, with a note that says
/// so, and the rest runs.
#[test]
fn a_stuck_propeller_is_refused_and_the_rest_runs() {
    let log = common::simulated_log(&Scenario::built_in("trench-eml").unwrap(), 2);
    let streams = Streams::of(&log);
    let stuck: Vec<Propeller> = streams
        .rpm
        .iter()
        .map(|p| Propeller { rpm: 0.0, ..*p })
        .collect();
    let streams = Streams {
        rpm: &stuck,
        ..streams
    };
    let pass = reconstruct(&streams, &log.mission().unwrap(), &with_rpm_velocity(true)).unwrap();
    assert!(
        pass.aid_notes
            .iter()
            .any(|n| n.to_string().contains("read zero")),
        "{:?}",
        pass.aid_notes
    );
    assert!(pass
        .run
        .residuals
        .iter()
        .all(|x| x.sensor != Sensor::RpmVelocity));
    assert!(pass.run.residuals.iter().any(|x| x.sensor == Sensor::Dvl));
}
