//! Does the reported uncertainty tell the truth? Every run's normalised innovations, and,
//! when the log has `/truth`, the NEES of both solutions, judged and summarised.
//!
//! - a sensor's innovations: mean NIS per component above 2 is over-confident (the filter
//!   or the sensor's noise setting claims too little), below 0.25 conservative;
//! - the horizontal NEES: consistent when at least 70 % of the epochs lie inside the
//!   two-sided 95 % chi-square bounds (95 % for a perfect filter; errors that are
//!   correlated in time and a finite run leave less); otherwise over-confident when more lie
//!   above the upper bound than below the lower one, else conservative.

use crate::filters::ins::aid_table::Sensor;
use crate::recon::score::Scores;
use crate::recon::stats::SensorStats;
use serde::Serialize;

/// Least fraction of epochs inside the NEES bounds for the solution to count as consistent.
pub const NEES_INSIDE_MIN: f64 = 0.70;
/// Fewest measurements for a sensor's innovations to be judged.
const MIN_MEASUREMENTS: usize = 20;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    Consistent,
    /// Errors larger than claimed.
    OverConfident,
    /// Errors smaller than claimed.
    Conservative,
}

impl std::fmt::Display for Verdict {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Verdict::Consistent => "consistent",
            Verdict::OverConfident => "over-confident",
            Verdict::Conservative => "conservative",
        })
    }
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct InnovationCheck {
    pub sensor: Sensor,
    /// Mean NIS over the components of one measurement (1 when consistent).
    pub mean_nis_per_component: f64,
    pub verdict: Verdict,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NeesCheck {
    pub solution: &'static str,
    pub horizontal_inside_95: f64,
    pub horizontal_above_95: f64,
    pub verdict: Verdict,
}

/// The verdicts of one run.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Consistency {
    /// No over-confident verdict.
    pub consistent: bool,
    pub innovations: Vec<InnovationCheck>,
    /// Empty without `/truth`.
    pub nees: Vec<NeesCheck>,
}

fn innovation_check(s: &SensorStats) -> Option<InnovationCheck> {
    if s.count < MIN_MEASUREMENTS || s.count == s.rejected {
        return None;
    }
    let per = s.mean_nis / s.dims as f64;
    let verdict = if per > 2.0 {
        Verdict::OverConfident
    } else if per < 0.25 {
        Verdict::Conservative
    } else {
        Verdict::Consistent
    };
    Some(InnovationCheck {
        sensor: s.sensor,
        mean_nis_per_component: per,
        verdict,
    })
}

fn nees_check(solution: &'static str, s: &Scores) -> NeesCheck {
    let inside = s.nees_horizontal_inside_95;
    let above = s.nees_horizontal_above_95;
    let below = 1.0 - inside - above;
    let verdict = if inside >= NEES_INSIDE_MIN {
        Verdict::Consistent
    } else if above > below {
        Verdict::OverConfident
    } else {
        Verdict::Conservative
    };
    NeesCheck {
        solution,
        horizontal_inside_95: inside,
        horizontal_above_95: above,
        verdict,
    }
}

/// Judges a run's innovations and, with truth, its NEES.
pub fn assess(
    sensors: &[SensorStats],
    forward: Option<&Scores>,
    smoothed: Option<&Scores>,
) -> Consistency {
    let innovations: Vec<InnovationCheck> = sensors.iter().filter_map(innovation_check).collect();
    let nees: Vec<NeesCheck> = [("forward", forward), ("smoothed", smoothed)]
        .into_iter()
        .filter_map(|(name, s)| s.map(|s| nees_check(name, s)))
        .collect();
    let consistent = innovations
        .iter()
        .map(|c| c.verdict)
        .chain(nees.iter().map(|c| c.verdict))
        .all(|v| v != Verdict::OverConfident);
    Consistency {
        consistent,
        innovations,
        nees,
    }
}

impl Consistency {
    /// The verdicts in one line: `uncertainty consistent: dvl consistent, ..., NEES forward
    /// consistent` (or `NOT consistent`).
    pub fn verdict_line(&self) -> String {
        let judged: Vec<String> = self
            .innovations
            .iter()
            .map(|i| format!("{} {}", i.sensor, i.verdict))
            .chain(
                self.nees
                    .iter()
                    .map(|n| format!("NEES {} {}", n.solution, n.verdict)),
            )
            .collect();
        format!(
            "uncertainty {}: {}",
            if self.consistent {
                "consistent"
            } else {
                "NOT consistent"
            },
            judged.join(", ")
        )
    }

    /// The solutions whose NEES against the truth says their sigmas are too small.
    pub fn over_confident(&self) -> impl Iterator<Item = &NeesCheck> {
        self.nees
            .iter()
            .filter(|c| c.verdict == Verdict::OverConfident)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stats(sensor: Sensor, dims: usize, mean_nis: f64) -> SensorStats {
        SensorStats {
            sensor,
            count: 100,
            rejected: 0,
            dims,
            mean_nis,
            normalised_mean: 0.0,
            normalised_variance: 1.0,
        }
    }

    fn scores(inside: f64, above: f64) -> Scores {
        Scores {
            epochs: 100,
            horizontal_rms_m: 1.0,
            horizontal_max_m: 1.0,
            horizontal_final_m: 1.0,
            nees_horizontal_inside_95: inside,
            nees_horizontal_above_95: above,
            nees_position_inside_95: inside,
            yaw_rms_deg: 0.1,
        }
    }

    #[test]
    fn verdicts_follow_the_bounds() {
        let c = assess(
            &[
                stats(Sensor::Dvl, 3, 3.3),
                stats(Sensor::Depth, 1, 2.5),
                stats(Sensor::Magnetometer, 1, 0.01),
            ],
            Some(&scores(0.9, 0.05)),
            Some(&scores(0.4, 0.1)),
        );
        let v: Vec<Verdict> = c.innovations.iter().map(|i| i.verdict).collect();
        assert_eq!(
            v,
            [
                Verdict::Consistent,
                Verdict::OverConfident,
                Verdict::Conservative
            ]
        );
        assert_eq!(c.nees[0].verdict, Verdict::Consistent);
        assert_eq!(c.nees[1].verdict, Verdict::Conservative);
        assert!(!c.consistent);
        assert_eq!(c.over_confident().count(), 0);

        let c = assess(&[stats(Sensor::Dvl, 3, 3.0)], Some(&scores(0.3, 0.6)), None);
        assert!(!c.consistent);
        assert_eq!(c.nees[0].verdict, Verdict::OverConfident);
        let flagged: Vec<_> = c.over_confident().map(|c| c.solution).collect();
        assert_eq!(flagged, ["forward"]);
        assert!(assess(&[stats(Sensor::Dvl, 3, 3.0)], None, None).consistent);
    }
}
