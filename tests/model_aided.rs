//! Seed 000's model-aided velocity filter on the 6-DOF simulator's logs, against `/truth`.

use hindsight::align::latest_at;
use hindsight::contract::Truth;
use hindsight::filters::velocity::model_aided::{self, AttitudeAt, Mode, ModelAidedFilter};
use hindsight::ingest::{read_log, IngestOptions};
use hindsight::recon::Streams;
use hindsight::vehicle::six_dof::description::Vehicle;
use hindsight::vehicle::six_dof::model::SixDof;
use nalgebra::{UnitQuaternion, Vector3};

/// Diagnostic: `HINDSIGHT_LOG=file cargo test --release --test model_aided -- --ignored --nocapture`.
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
