//! `hindsight bench --simulate`: a scenario simulated and written to a log file on one
//! thread (default: the 5.5-hour `long-dive-dynamic`, the 6-DOF model at the IMU's 100 Hz),
//! its dynamics alone, and the kinematic `long-dive` of the same profile for the ratio.

use anyhow::{Context, Result};
use hindsight::sim::scenario::Scenario;
use hindsight::sim::truth::TruthSource;
use hindsight::sim::{dynamic, run, writer};
use std::path::Path;

/// Simulates `scenario` with seed 0 into a file at `path` (one thread), returning the
/// message count.
fn simulate_to_file(scenario: &Scenario, path: &Path) -> Result<u64> {
    let file =
        std::fs::File::create(path).with_context(|| format!("creating {}", path.display()))?;
    let mut w = writer::LogWriter::new(
        std::io::BufWriter::new(file),
        writer::WriterOptions::default(),
    )?;
    let summary = run::run(scenario, 0, &mut w)?;
    w.finish()?;
    Ok(summary.messages)
}

pub fn run(name: &str, repeat: usize, keep: Option<&Path>) -> Result<()> {
    let scenario = Scenario::built_in(name)?;
    let dir = std::env::temp_dir().join(format!("hindsight-bench-simulate-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let path = keep.map_or_else(|| dir.join(format!("{name}.mcap")), Path::to_path_buf);
    let dt_s = 1.0 / scenario.imu.rate_hz;
    let messages = simulate_to_file(&scenario, &path)?;
    let bytes = std::fs::metadata(&path)?.len();
    let time = |f: &dyn Fn()| super::bench::median_seconds(repeat, f);
    let whole_s = time(&|| {
        simulate_to_file(&scenario, &path).expect("simulated once already");
    });
    let dynamics_s = dynamic::from_scenario(&scenario, 0, dt_s)?.map(|_| {
        time(&|| {
            let mut truth = dynamic::from_scenario(&scenario, 0, dt_s)
                .expect("built above")
                .expect("dynamic")
                .truth;
            let steps = (truth.duration_s() / dt_s).round() as usize;
            for k in 0..=steps {
                std::hint::black_box(truth.sample(k as f64 * dt_s));
            }
        })
    });
    println!(
        "{name}: {:.1} h of mission, {messages} messages, {:.1} MB; median of {repeat}, one thread:",
        scenario_hours(&scenario)?,
        bytes as f64 / 1e6
    );
    println!("  simulated and written      {whole_s:7.2} s (target for long-dive-dynamic: < 60 s)");
    if let Some(d) = dynamics_s {
        let steps = scenario_hours(&scenario)? * 3600.0 * scenario.imu.rate_hz;
        println!(
            "  6-DOF dynamics alone       {d:7.2} s ({:.2} us per RK4 step at {} Hz, {:.0} % of the whole)",
            d / steps * 1e6,
            scenario.imu.rate_hz,
            100.0 * d / whole_s
        );
    }
    if name == "long-dive-dynamic" {
        let kinematic = Scenario::built_in("long-dive")?;
        let kinematic_path = dir.join("long-dive.mcap");
        let k = time(&|| {
            simulate_to_file(&kinematic, &kinematic_path).expect("kinematic long dive");
        });
        println!(
            "  kinematic long-dive        {k:7.2} s (dynamic / kinematic: {:.2})",
            whole_s / k
        );
    }
    if keep.is_none() {
        std::fs::remove_dir_all(&dir).ok();
    }
    Ok(())
}

fn scenario_hours(scenario: &Scenario) -> Result<f64> {
    let seconds = match dynamic::from_scenario(scenario, 0, 1.0 / scenario.imu.rate_hz)? {
        Some(flight) => flight.truth.duration_s(),
        None => scenario.trajectory()?.duration_s(),
    };
    Ok(seconds / 3600.0)
}
