//! Writes the shipped sample log: `sample-logs/synthetic-survey-2min.mcap`.
//!
//!     cargo run --release --example make_sample_log -- sample-logs/synthetic-survey-2min.mcap
//!
//! A 2-minute synthetic survey (seed 7) with every contract stream; see
//! `hindsight::sim::synthetic` for what it holds. Same seed, same bytes.

use hindsight::sim::synthetic::{write_survey, SurveySpec};
use hindsight::sim::writer::{LogWriter, WriterOptions};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let path = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "sample-logs/synthetic-survey-2min.mcap".into());
    let spec = SurveySpec {
        duration_s: 120.0,
        seed: 7,
        ..SurveySpec::default()
    };
    let tmp = format!("{path}.tmp");
    let file = std::fs::File::create(&tmp)?;
    let mut w = LogWriter::new(std::io::BufWriter::new(file), WriterOptions::default())?;
    let n = write_survey(&mut w, &spec)?;
    w.finish()?;
    std::fs::rename(&tmp, &path)?;
    println!("{path}: {n} messages");
    Ok(())
}
