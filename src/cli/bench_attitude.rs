//! `hindsight bench --attitude`: every attitude method on a 1-hour 100 Hz AHRS log (the
//! `pool-circle` scenario flown for an hour: IMU 100 Hz, magnetometer 50 Hz, DVL 5 Hz).

use anyhow::{Context, Result};
use hindsight::attitude::compare::{self, Method};
use hindsight::attitude::config::AttitudeConfig;
use hindsight::attitude::AhrsInputs;
use hindsight::contract::{Imu, MagneticField};
use hindsight::ingest::{self, IngestOptions};
use hindsight::sim::scenario::{Scenario, Segment};
use std::path::Path;

pub fn run(repeat: usize, keep: Option<&Path>) -> Result<()> {
    let mut scenario = Scenario::built_in("pool-circle").context("scenario `pool-circle`")?;
    scenario.segments = vec![Segment::Cruise { duration_s: 3600.0 }];
    eprintln!("simulating `pool-circle` for 1 hour (seed 0) ...");
    super::bench::with_log_file(
        keep,
        |w| Ok(hindsight::sim::run::run(&scenario, 0, w).map(|_| ())?),
        |path| measure(path, repeat),
    )
}

fn measure(path: &Path, repeat: usize) -> Result<()> {
    let log = ingest::read_log(path, &IngestOptions::default())?;
    let imu: &[Imu] = log.role();
    let mag: &[MagneticField] = log.role();
    let inputs = AhrsInputs {
        imu,
        mag,
        declination_rad: 0.0,
        initial_yaw_rad: None,
    };
    let filters = AttitudeConfig::default().filters()?;
    eprintln!(
        "{} IMU samples ({:.0} s), {} magnetometer readings; {} threads; median of {repeat}",
        imu.len(),
        (imu.last().map_or(0, |m| m.stamp_ns) - imu.first().map_or(0, |m| m.stamp_ns)) as f64
            * 1e-9,
        mag.len(),
        rayon::current_num_threads()
    );
    let time = |f: &dyn Fn()| super::bench::median_seconds(repeat, f);
    let mut one_by_one = 0.0;
    for m in Method::ALL {
        let s = time(&|| {
            std::hint::black_box(compare::run_method(m, &inputs, &filters));
        });
        one_by_one += s;
        println!("{:<14} {s:7.3} s (one thread)", m.name());
    }
    let all = time(&|| {
        std::hint::black_box(compare::run_methods(&Method::ALL, &inputs, &filters));
    });
    println!(
        "all methods in parallel: {all:.3} s (target < 2 s on 2 cores); one after the other \
         {one_by_one:.3} s; speed-up {:.2}",
        one_by_one / all
    );
    Ok(())
}
