//! A USBL on a support ship that follows the vehicle: positioned fixes whose error grows with
//! the slant range, stamped when the ship received them (late, by a delay the log does not
//! tell: one per run, the system's processing, with a small jitter), with runs of multipath
//! outliers, and none beyond the system's range.

use super::normal;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;

crate::config::with_defaults! {
    /// Parameters of the USBL (`[usbl]` in a scenario).
    #[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
    #[serde(deny_unknown_fields, default)]
    pub struct UsblSpec {
        /// Time between fixes, s: drawn evenly within `[min, max]` after each.
        pub every_s: [f64; 2] = [2.0, 5.0],
        /// 1-sigma of a fix per axis, as a fraction of the slant range (0.005: 0.5 %) ...
        pub range_fraction: f64 = 0.005,
        /// ... and at least this, m.
        pub sigma_floor_m: f64 = 0.1,
        /// The ship receives a fix this long after it was valid, s: drawn evenly within
        /// `[min, max]` once per run (the system's processing time); the fix is stamped on
        /// receipt ...
        pub receipt_delay_s: [f64; 2] = [1.0, 3.0],
        /// ... with this 1-sigma jitter per fix, s (the serial link's and the clock's).
        pub receipt_jitter_s: f64 = 0.02,
        /// What the fix's stamp says: the time of receipt alone, or the time of validity
        /// with the delay after it (`received_after_s`, as EvoLogics' two times give it).
        pub stamp: UsblStamp = UsblStamp::Receipt,
        /// Share of the fixes that are multipath outliers ...
        pub outlier_fraction: f64 = 0.0,
        /// ... their horizontal error, m, drawn evenly within `[min, max]` in a random
        /// direction ...
        pub outlier_m: [f64; 2] = [10.0, 50.0],
        /// ... and the mean length of a run of them, fixes.
        pub outlier_run: f64 = 1.0,
        /// No fix beyond this slant range, m.
        pub max_range_m: f64 = 1000.0,
        /// The ship holds the vehicle's horizontal position of this long before, s.
        pub ship_lag_s: f64 = 120.0,
    }
}

/// What a simulated USBL's stamps say.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum UsblStamp {
    /// Stamped when the ship received the fix; the delay is not told.
    Receipt,
    /// Stamped at the time of validity, the delay after it given.
    ValidityAndDelay,
}

impl UsblSpec {
    /// What makes the parameters unusable, if anything.
    pub fn problem(&self) -> Option<String> {
        let ordered = |[a, b]: [f64; 2]| a <= b;
        if !(self.every_s[0] > 0.0 && ordered(self.every_s)) {
            return Some("usbl.every_s must be [min, max] with 0 < min <= max".into());
        }
        if !(self.receipt_delay_s[0] >= 0.0 && ordered(self.receipt_delay_s)) {
            return Some("usbl.receipt_delay_s must be [min, max] with 0 <= min <= max".into());
        }
        if !(self.outlier_m[0] >= 0.0 && ordered(self.outlier_m)) {
            return Some("usbl.outlier_m must be [min, max] with 0 <= min <= max".into());
        }
        let fraction_ok = (0.0..1.0).contains(&self.outlier_fraction);
        if !(fraction_ok && self.outlier_run >= 1.0) {
            return Some(
                "usbl.outlier_fraction must be in [0, 1) and outlier_run at least 1".into(),
            );
        }
        let positive = [self.range_fraction, self.sigma_floor_m, self.max_range_m];
        let lags = [self.ship_lag_s, self.receipt_jitter_s];
        if positive.iter().chain(&lags).any(|&x| x < 0.0) {
            return Some(
                "usbl sigmas, max_range_m, ship_lag_s and receipt_jitter_s must not be negative"
                    .into(),
            );
        }
        None
    }
}

/// One fix: where the vehicle is said to be, and when the ship received it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fix {
    /// The error added to the true position, north, east and down, m.
    pub error_ned_m: [f64; 3],
    /// 1-sigma per axis, m.
    pub sigma_m: f64,
    /// Receipt after validity, s.
    pub delay_s: f64,
    pub outlier: bool,
}

/// The USBL of one run.
pub struct Usbl {
    spec: UsblSpec,
    rng: ChaCha8Rng,
    /// The run's receipt delay, s.
    delay_s: f64,
    next_s: f64,
    in_outlier_run: bool,
    /// The vehicle's horizontal track over the ship's lag: (s, north, east).
    track: VecDeque<(f64, f64, f64)>,
}

impl Usbl {
    /// The USBL; the run's receipt delay is the first draw of `rng`.
    pub fn new(spec: UsblSpec, mut rng: ChaCha8Rng) -> Self {
        let [lo, hi] = spec.receipt_delay_s;
        Usbl {
            delay_s: rng.random_range(lo..=hi),
            next_s: spec.every_s[0],
            spec,
            rng,
            in_outlier_run: false,
            track: VecDeque::new(),
        }
    }

    /// The fix of the vehicle at `t_s` (north, east, down m), when one is due and in range.
    pub fn fix(&mut self, t_s: f64, ned_m: [f64; 3]) -> Option<Fix> {
        self.track.push_back((t_s, ned_m[0], ned_m[1]));
        while self.track.len() > 1 && self.track[1].0 <= t_s - self.spec.ship_lag_s {
            self.track.pop_front();
        }
        if t_s < self.next_s {
            return None;
        }
        let [lo, hi] = self.spec.every_s;
        self.next_s = t_s + self.rng.random_range(lo..=hi);
        let ship = self.track[0];
        let slant_m = (ned_m[0] - ship.1).hypot(ned_m[1] - ship.2).hypot(ned_m[2]);
        if slant_m > self.spec.max_range_m {
            return None;
        }
        let sigma_m = (self.spec.range_fraction * slant_m).max(self.spec.sigma_floor_m);
        let mut error_ned_m: [f64; 3] = std::array::from_fn(|_| sigma_m * normal(&mut self.rng));
        let outlier = self.outlier_now();
        if outlier {
            let [lo, hi] = self.spec.outlier_m;
            let size = self.rng.random_range(lo..=hi);
            let bearing = self.rng.random_range(0.0..std::f64::consts::TAU);
            error_ned_m[0] += size * bearing.cos();
            error_ned_m[1] += size * bearing.sin();
        }
        let jitter_s = self.spec.receipt_jitter_s * normal(&mut self.rng);
        Some(Fix {
            error_ned_m,
            sigma_m,
            delay_s: (self.delay_s + jitter_s).max(0.0),
            outlier,
        })
    }

    /// The run's receipt delay, s (each fix's is this plus its jitter).
    pub fn receipt_delay_s(&self) -> f64 {
        self.delay_s
    }

    /// Whether this fix is an outlier: runs of mean length `outlier_run`, entered so that
    /// `outlier_fraction` of the fixes are in one.
    fn outlier_now(&mut self) -> bool {
        let (f, run) = (self.spec.outlier_fraction, self.spec.outlier_run);
        let p = if self.in_outlier_run {
            1.0 - 1.0 / run
        } else {
            f / (run * (1.0 - f))
        };
        self.in_outlier_run = self.rng.random::<f64>() < p;
        self.in_outlier_run
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::sensors::rng_for;

    /// A vehicle 20 m deep running east at 1.5 m/s, a tick every 0.1 s for `seconds`.
    fn fixes(spec: UsblSpec, seconds: f64) -> Vec<(f64, f64, Fix)> {
        let mut usbl = Usbl::new(spec, rng_for(3, 99));
        let ticks = (seconds * 10.0) as usize;
        (0..ticks)
            .filter_map(|k| {
                let t = k as f64 * 0.1;
                let east = 1.5 * t;
                let ship_east = 1.5 * (t - spec.ship_lag_s).max(0.0);
                let slant = (east - ship_east).hypot(20.0);
                usbl.fix(t, [0.0, east, 20.0]).map(|f| (t, slant, f))
            })
            .collect()
    }

    #[test]
    fn fixes_have_their_rate_delay_sigma_and_outlier_runs() {
        let spec = UsblSpec {
            outlier_fraction: 0.03,
            outlier_run: 2.0,
            ..UsblSpec::default()
        };
        let all = fixes(spec, 100_000.0);
        assert!(all.len() > 25_000, "{}", all.len());
        for w in all.windows(2) {
            let gap = w[1].0 - w[0].0;
            assert!((2.0 - 1e-9..=5.1).contains(&gap), "{gap}");
        }
        let outliers = all.iter().filter(|f| f.2.outlier).count();
        let share = outliers as f64 / all.len() as f64;
        assert!((share - 0.03).abs() < 0.005, "{share}");
        let runs = all
            .windows(2)
            .filter(|w| w[1].2.outlier && !w[0].2.outlier)
            .count();
        let mean_run = outliers as f64 / runs as f64;
        assert!((mean_run - 2.0).abs() < 0.2, "{mean_run}");
        let mut normalised_sq = 0.0;
        let mut good = 0;
        let delay_s = Usbl::new(spec, rng_for(3, 99)).receipt_delay_s();
        assert!((1.0..=3.0).contains(&delay_s), "{delay_s}");
        let mut jitter_sq = 0.0;
        for (_, slant, f) in &all {
            jitter_sq += (f.delay_s - delay_s).powi(2);
            // The ship's place is the track's at a tick of the lag (a tick is 0.15 m here).
            let sigma = (0.005 * slant).max(0.1);
            assert!(
                (f.sigma_m - sigma).abs() < 0.005 * 0.16,
                "{} vs {sigma}",
                f.sigma_m
            );
            let horizontal = f.error_ned_m[0].hypot(f.error_ned_m[1]);
            if f.outlier {
                assert!(horizontal > 10.0 - 5.0 * sigma, "{horizontal}");
            } else {
                normalised_sq += f
                    .error_ned_m
                    .iter()
                    .map(|e| (e / f.sigma_m).powi(2))
                    .sum::<f64>();
                good += 3;
            }
        }
        let normalised_sigma = (normalised_sq / good as f64).sqrt();
        assert!((normalised_sigma - 1.0).abs() < 0.02, "{normalised_sigma}");
        let jitter_s = (jitter_sq / all.len() as f64).sqrt();
        assert!((jitter_s - 0.02).abs() < 0.001, "{jitter_s}");
    }

    #[test]
    fn no_fix_beyond_the_range() {
        let spec = UsblSpec {
            max_range_m: 150.0,
            ship_lag_s: 1000.0,
            ..UsblSpec::default()
        };
        let all = fixes(spec, 2000.0);
        assert!(!all.is_empty());
        assert!(all.iter().all(|(_, slant, _)| *slant <= 150.0));
        assert!(
            all.iter().all(|(t, _, _)| *t < 101.0),
            "1.5 m/s for 100 s reaches 150 m"
        );
    }

    #[test]
    fn bad_parameters_are_named() {
        let bad = |spec: UsblSpec, says: &str| {
            let problem = spec.problem().expect("a problem");
            assert!(problem.contains(says), "{problem}");
        };
        bad(
            UsblSpec {
                every_s: [5.0, 2.0],
                ..UsblSpec::default()
            },
            "every_s",
        );
        bad(
            UsblSpec {
                outlier_fraction: 1.0,
                ..UsblSpec::default()
            },
            "outlier_fraction",
        );
        bad(
            UsblSpec {
                max_range_m: -1.0,
                ..UsblSpec::default()
            },
            "max_range_m",
        );
        assert_eq!(UsblSpec::default().problem(), None);
    }
}
