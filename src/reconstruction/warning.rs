//! Every warning of a run, typed: the pipeline's, the consistency verdict's and the outputs'.
//! `summary.json` writes each as `{code, message, ...data}`, so that a program tells one from
//! another by its `code` and reads its figures as numbers.

use crate::recon::consistency::NeesCheck;
use crate::recon::pipeline;
use serde::ser::{Error as _, Serialize, Serializer};
use serde_json::{Map, Value};
use std::fmt;

/// What a navigation engineer should know of a run, with its data.
#[derive(Debug, Clone, PartialEq)]
pub enum Warning {
    /// From the pipeline: the plan, the start, the tuning, the forward pass.
    Pipeline(pipeline::Warning),
    /// A solution's NEES against the truth says its sigmas are too small.
    OverConfident(NeesCheck),
    /// The epoch records or solutions could not wait on a temporary file and were held in
    /// memory instead (the run went on).
    HeldInMemory { why: String },
}

impl fmt::Display for Warning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Warning::Pipeline(w) => write!(f, "{w}"),
            Warning::OverConfident(c) => write!(
                f,
                "{} solution over-confident against /truth: its horizontal NEES is inside \
                 the 95 % bounds for {:.0} % of the epochs and above them for {:.0} % (its \
                 sigmas are too small)",
                c.solution,
                100.0 * c.horizontal_inside_95,
                100.0 * c.horizontal_above_95
            ),
            Warning::HeldInMemory { why } => write!(
                f,
                "memory: the epoch records or solutions could not go to a temporary file \
                 ({why}); they were held in memory instead (set TMPDIR to a disk with room)"
            ),
        }
    }
}

impl Warning {
    /// The warning's data, with its code under `kind`.
    fn tagged(&self) -> serde_json::Result<Value> {
        match self {
            Warning::Pipeline(pipeline::Warning::Run(w)) => serde_json::to_value(w),
            Warning::Pipeline(pipeline::Warning::Tuning(w)) => serde_json::to_value(w),
            Warning::Pipeline(w) => serde_json::to_value(w),
            Warning::OverConfident(c) => {
                let mut v = serde_json::to_value(c)?;
                if let Value::Object(m) = &mut v {
                    m.insert("kind".into(), "over_confident".into());
                }
                Ok(v)
            }
            Warning::HeldInMemory { why } => Ok(serde_json::json!({
                "kind": "held_in_memory",
                "why": why,
            })),
        }
    }

    /// The warning's code: what a program matches on (`dvl_clock`, `rejected`, ...).
    pub fn code(&self) -> String {
        match self.tagged() {
            Ok(Value::Object(m)) => m
                .get("kind")
                .and_then(Value::as_str)
                .unwrap_or("unknown")
                .to_string(),
            _ => "unknown".into(),
        }
    }
}

impl Serialize for Warning {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let Value::Object(mut data) = self.tagged().map_err(S::Error::custom)? else {
            return Err(S::Error::custom("a warning's data is not a map"));
        };
        let code = data.remove("kind").unwrap_or(Value::Null);
        let mut out = Map::new();
        out.insert("code".into(), code);
        out.insert("message".into(), self.to_string().into());
        out.extend(data);
        out.serialize(s)
    }
}
