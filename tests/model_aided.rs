//! Seed 000's model-aided velocity filter on the 6-DOF simulator's logs, against `/truth`,
//! and what it does with a wrong vehicle, no fins, or an unknown vehicle.

use crate::common;
use hindsight::align::latest_at;
use hindsight::config::Section;
use hindsight::contract::Truth;
use hindsight::filters::velocity::model_aided::{self, AttitudeAt, Mode, ModelAidedFilter};
use hindsight::ingest::{read_log, IngestOptions};
use hindsight::recon::config::Config;
use hindsight::recon::score::scores;
use hindsight::recon::{run_configured, Streams};
use hindsight::sim::scenario::Scenario;

use common::output_errors as errors;
use hindsight::vehicle::six_dof::description::Vehicle;
use hindsight::vehicle::six_dof::model::SixDof;
use nalgebra::{UnitQuaternion, Vector3};

/// Diagnostic: `HINDSIGHT_LOG=file cargo test --release --test all model_aided:: -- --ignored --nocapture`.
#[test]
#[ignore]
fn velocity_errors_of_a_log() {
    let path = std::env::var("HINDSIGHT_LOG").expect("HINDSIGHT_LOG");
    let log = read_log(std::path::Path::new(&path), &IngestOptions::default()).unwrap();
    let streams = Streams::of(&log);
    let attitude: Vec<AttitudeAt> = streams
        .truth
        .iter()
        .map(|t| AttitudeAt {
            stamp_ns: t.stamp_ns,
            ned_from_body: UnitQuaternion::from_euler_angles(
                t.attitude[0],
                t.attitude[1],
                t.attitude[2],
            ),
            lat_rad: t.latitude_deg.to_radians(),
        })
        .collect();
    let model = SixDof::new(Vehicle::built_in("nps-auv-ii").unwrap().unwrap()).unwrap();
    let dvl: Vec<_> = streams
        .dvl
        .iter()
        .filter(|d| d.valid && d.altitude.is_none_or(|a| a <= 500.0))
        .map(|d| model_aided::BodyVelocityReading {
            stamp_ns: d.stamp_ns,
            v_body_m_s: Vector3::from(d.velocity),
        })
        .collect();
    for mode in [Mode::Proposed, Mode::VirtualSensor] {
        let inputs = model_aided::Inputs {
            fins: streams.fins,
            propeller: streams.rpm,
            attitude: &attitude,
            imu: streams.imu,
            depth: streams.depth,
            eml: streams.eml,
            dvl: &dvl,
        };
        let settings = ModelAidedFilter {
            mode,
            ..ModelAidedFilter::default()
        };
        let started = std::time::Instant::now();
        let run = model_aided::run(&settings, &model, &inputs).unwrap();
        println!("{mode:?}: {:.2} s", started.elapsed().as_secs_f64());
        let t0 = run.velocities[0].stamp_ns;
        println!(
            "{mode:?}: dvl {:?} eml {:?} depth {:?}",
            run.dvl.mean_per_dim(),
            run.eml.mean_per_dim(),
            run.depth.mean_per_dim()
        );
        let mut bins = vec![
            (
                Vector3::<f64>::zeros(),
                Vector3::<f64>::zeros(),
                Vector3::<f64>::zeros(),
                0usize
            );
            12
        ];
        for v in &run.velocities {
            let Some((t, _)) = latest_at::<Truth>(streams.truth, v.stamp_ns) else {
                continue;
            };
            let e = v.v_body_m_s - Vector3::from(t.velocity_body);
            let k = (((v.stamp_ns - t0) as f64 * 1e-9) / 1800.0) as usize;
            if k < bins.len() {
                let b = &mut bins[k];
                b.0 += e;
                b.1 += e.component_mul(&e);
                b.2 += Vector3::new(v.cov[(0, 0)], v.cov[(1, 1)], v.cov[(2, 2)]);
                b.3 += 1;
            }
        }
        for (k, b) in bins.iter().enumerate().filter(|(_, b)| b.3 > 0) {
            let n = b.3 as f64;
            let mean = b.0 / n;
            let rms = (b.1 / n).map(f64::sqrt);
            let sig = (b.2 / n).map(f64::sqrt);
            println!(
                "  {:4.1} h: mean [{:+.4} {:+.4} {:+.4}] rms [{:.4} {:.4} {:.4}] sigma [{:.4} {:.4} {:.4}]",
                k as f64 * 0.5, mean.x, mean.y, mean.z, rms.x, rms.y, rms.z, sig.x, sig.y, sig.z
            );
        }
    }
}

fn seed000_config() -> Config {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/configs/seed000-proposed.toml"
    ))
    .unwrap();
    Config::from_toml(&text).unwrap()
}

/// Forward horizontal RMS against `/truth`, and what the aids said.
fn forward_rms(log: &hindsight::ingest::Log, config: &Config) -> (f64, Vec<String>) {
    let streams = Streams::of(log);
    let r = run_configured(&streams, &log.mission().unwrap(), config).unwrap();
    let notes = r.aid_notes.iter().map(|n| n.to_string()).collect();
    (
        scores(&errors(streams.truth, &r).0)
            .unwrap()
            .horizontal_rms_m,
        notes,
    )
}

/// The other built-in vehicle's model (REMUS 100 for an NPS AUV II): the filter's
/// innovations say it does not fit, the aid is left out with a warning, and the navigation
/// is the one without it (it does not diverge).
#[test]
fn a_wrong_vehicle_is_noticed_and_left_out() {
    let scenario = Scenario::built_in("long-dive-dynamic")
        .unwrap()
        .with_imu_rate(10.0)
        .unwrap();
    let log = common::simulated_log(&scenario, 3);
    let right = seed000_config();
    let mut wrong = right.clone();
    wrong.model_velocity.vehicle = "remus-100".into();
    let mut without = right.clone();
    without.model_velocity.enabled = hindsight::recon::on_off_auto::Switch::Off;
    let (rms_right, notes_right) = forward_rms(&log, &right);
    let (rms_wrong, notes_wrong) = forward_rms(&log, &wrong);
    let (rms_without, _) = forward_rms(&log, &without);
    eprintln!(
        "long-dive-dynamic (10 Hz) seed 3, forward RMS: nps-auv-ii {rms_right:.1} m, \
         remus-100 {rms_wrong:.1} m, without the model {rms_without:.1} m; notes {notes_wrong:?}"
    );
    assert!(notes_right.is_empty(), "{notes_right:?}");
    assert!(
        notes_wrong.iter().any(|n| n.contains("does not fit")),
        "{notes_wrong:?}"
    );
    assert_eq!(rms_wrong, rms_without);
    assert!(rms_right < rms_without);
}

/// A log without `/fins` (a kinematic survey with a propeller): the model aid is not used,
/// a note says why, and the reconstruction runs.
#[test]
fn without_fins_the_model_aid_is_left_out() {
    let log = common::simulated_log(&Scenario::built_in("trench-eml").unwrap(), 1);
    let mut config = Config::default();
    config.model_velocity.enabled = hindsight::recon::on_off_auto::Switch::On;
    config.model_velocity.vehicle = "nps-auv-ii".into();
    let (rms, notes) = forward_rms(&log, &config);
    assert!(rms.is_finite());
    assert!(notes.iter().any(|n| n.contains("no /fins")), "{notes:?}");
}

/// An unknown vehicle on the command line: exit 2, naming it.
#[test]
fn an_unknown_vehicle_is_refused_by_name() {
    let out = common::scratch_dir("unknown-vehicle");
    let o = common::hindsight(&[
        "reconstruct",
        common::SAMPLE,
        "--vehicle",
        "no-such-auv",
        "--out",
        out.join("run").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", common::stderr(&o));
    assert!(
        common::stderr(&o).contains("no-such-auv"),
        "{}",
        common::stderr(&o)
    );
    assert!(!out.join("run").exists());
}

/// Why the paper's -0.6 m/s mean body-x error of the virtual sensor (seed 000, Fig. 12) is
/// not reproduced: with the paper's draws (every coefficient off by a normal 10 %, 1-sigma),
/// the cruising speed the nominal model predicts for the true vehicle's propeller speed is
/// off by a spread of a few cm/s about a mean near zero, over 100 draws. A mean of -0.6 m/s
/// (40 % of the 1.5 m/s cruise) needs a bias in the draws or a model that drifts, neither of
/// which the paper states.
#[test]
fn the_virtual_sensors_cruise_speed_error_is_centred_over_the_papers_draws() {
    use hindsight::vehicle::six_dof::autopilot::propeller_for;
    use hindsight::vehicle::six_dof::properties::steady_speed;
    let nominal_vehicle = Vehicle::built_in("nps-auv-ii").unwrap().unwrap();
    let nominal = SixDof::new(nominal_vehicle.clone()).unwrap();
    let cruise_m_s = 1.5;
    let errors: Vec<f64> = (1..=100)
        .filter_map(|seed| {
            let (vehicle, _) = nominal_vehicle.perturbed(0.1, seed);
            let truth = SixDof::new(vehicle)?;
            let n = propeller_for(&truth, cruise_m_s)?;
            Some(steady_speed(&nominal, n)? - cruise_m_s)
        })
        .collect();
    assert!(errors.len() >= 95, "{} of 100 draws cruise", errors.len());
    let (mean, sd) = hindsight::study::mean_sigma(errors.iter().copied()).unwrap();
    println!(
        "virtual sensor's cruise speed error over {} draws: mean {mean:+.4} m/s, sd {sd:.4} m/s",
        errors.len()
    );
    // The draws do move the model's speed (case 2 is not case 1) ...
    assert!(sd > 0.01, "sd {sd}");
    // ... but about a centre far from the paper's -0.6 m/s: within 3 standard errors of
    // zero or a few cm/s.
    assert!(
        mean.abs() < (3.0 * sd / (errors.len() as f64).sqrt()).max(0.05),
        "mean {mean}"
    );
}
