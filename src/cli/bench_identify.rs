//! `hindsight bench --identify`: both of seed 004's 200 s zig-zag logs (simulated, seed 0)
//! identified jointly, both stages, from 20 % off.

use anyhow::Result;
use hindsight::identify::record::Record;
use hindsight::identify::settings::Settings;
use hindsight::identify::{ekf, identify, output_error, perturbed};
use hindsight::ingest::{read_log_from, IngestOptions};
use hindsight::sim::writer::{to_bytes, WriterOptions};
use hindsight::sim::zigzag::{self, ZigzagSpec};
use hindsight::vehicle::heave_pitch::{Coefficients, TRUE_COEFFICIENTS};

pub fn run(repeat: usize) -> Result<()> {
    let mut records = Vec::new();
    for name in zigzag::BUILT_IN {
        let spec = ZigzagSpec::built_in(name).expect("built-in");
        let bytes = to_bytes(WriterOptions::default(), |w| {
            zigzag::run(&spec, 0, w)?;
            Ok(())
        })?;
        let log = read_log_from(bytes.as_slice(), &IngestOptions::default())?;
        records.push(Record::from_log(name, &log, None)?);
    }
    let settings = Settings::default();
    let start = perturbed(&Coefficients::from(TRUE_COEFFICIENTS), 0.2);
    let time = |f: &dyn Fn()| super::bench::median_seconds(repeat, f);
    let ekf_s = time(&|| {
        std::hint::black_box(ekf::run(&records, &start, &settings));
    });
    let e = ekf::run(&records, &start, &settings);
    let refine_s = time(&|| {
        std::hint::black_box(output_error::refine(&records, &e.coefficients, &settings));
    });
    let all_s = time(&|| {
        std::hint::black_box(identify(&records, &start, &settings));
    });
    println!(
        "zigzag-5-5 + zigzag-10-5 (2 x 20 001 samples), median of {repeat}: EKF stage {ekf_s:.3} s, \
         output-error stage {refine_s:.3} s, whole identification (with assessment and fits) \
         {all_s:.3} s (target < 2 s)"
    );
    Ok(())
}
