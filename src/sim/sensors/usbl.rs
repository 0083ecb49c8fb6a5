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
        /// What the USBL writes: positioned fixes, or raw observations with the ship's pose.
        pub form: UsblForm = UsblForm::Positioned,
        /// Raw: 1-sigma of the range as a fraction of it (at least `sigma_floor_m`) ...
        pub range_sigma_fraction: f64 = 0.002,
        /// ... and of the bearing and the elevation, deg.
        pub angle_sigma_deg: f64 = 0.2,
        /// Raw: the ship's pose is logged this often, s ...
        pub ship_every_s: f64 = 0.5,
        /// ... its GNSS position with this 1-sigma per axis, white, m ...
        pub ship_position_sigma_m: f64 = 0.5,
        /// ... its heading with this 1-sigma, deg, correlated over `ship_heading_correlation_s`
        /// (a first-order Gauss-Markov error) ...
        pub ship_heading_sigma_deg: f64 = 0.1,
        pub ship_heading_correlation_s: f64 = 10.0,
        /// ... its roll and pitch with this 1-sigma, white, deg ...
        pub ship_tilt_sigma_deg: f64 = 0.05,
        /// ... while it rolls and pitches in the swell by these amplitudes, deg (periods of
        /// 8 s and 6 s).
        pub ship_roll_deg: f64 = 3.0,
        pub ship_pitch_deg: f64 = 1.5,
    }
}

/// What a simulated USBL writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum UsblForm {
    /// Fixes the ship positioned (`/acoustic_fix`).
    Positioned,
    /// Range, bearing and elevation in the axes of the ship's transducer (`/usbl`), with the
    /// ship's pose from its own GNSS and heading sensor (`/ship_pose`). The transducer is at
    /// the point the ship's position is of, in the ship's axes.
    Raw,
}

/// The ship when a pose or an observation is made: where (north and east of the mission's
/// origin, m) and how turned (roll, pitch, yaw, rad).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShipTruth {
    pub north_m: f64,
    pub east_m: f64,
    pub attitude_rad: [f64; 3],
}

/// The roll and pitch periods of the ship in the swell, s.
const SWELL_PERIODS_S: [f64; 2] = [8.0, 6.0];

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
        let raw = [
            self.range_sigma_fraction,
            self.angle_sigma_deg,
            self.ship_position_sigma_m,
            self.ship_heading_sigma_deg,
            self.ship_tilt_sigma_deg,
            self.ship_roll_deg,
            self.ship_pitch_deg,
        ];
        if raw.iter().any(|&x| x < 0.0) || self.ship_every_s <= 0.0 {
            return Some(
                "usbl's raw sigmas and swell must not be negative, ship_every_s must be positive"
                    .into(),
            );
        }
        if self.ship_heading_correlation_s <= 0.0 {
            return Some("usbl.ship_heading_correlation_s must be positive".into());
        }
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
    /// The outlier's part of the error, north and east, m (zero for a good fix).
    pub outlier_ne_m: [f64; 2],
    /// The ship when the fix was valid.
    pub ship: ShipTruth,
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
    /// The ship's heading: along its track once it moves, rad.
    ship_yaw_rad: f64,
    /// Raw: when the ship's next pose is due, s, and its heading sensor's error, rad.
    next_ship_pose_s: f64,
    ship_heading_error_rad: f64,
}

/// A raw observation: range (m), bearing and elevation (rad), and their sigmas.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RawObservation {
    pub range_bearing_elevation: [f64; 3],
    pub sigmas: [f64; 3],
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
            ship_yaw_rad: 0.0,
            next_ship_pose_s: 0.0,
            ship_heading_error_rad: 0.0,
        }
    }

    /// The ship's pose as its own sensors give it at `t_s` when one is due (after
    /// [`Usbl::fix`] has seen the vehicle at `t_s`): north and east with the GNSS's white
    /// error, the swell's roll and pitch with the tilt's, the heading with its correlated
    /// error.
    pub fn ship_pose(&mut self, t_s: f64) -> Option<ShipTruth> {
        if t_s < self.next_ship_pose_s {
            return None;
        }
        let dt_s = self.spec.ship_every_s;
        self.next_ship_pose_s = t_s + dt_s;
        let truth = self.ship(t_s)?;
        let spec = self.spec;
        let rng = &mut self.rng;
        let phi = (-dt_s / spec.ship_heading_correlation_s).exp();
        self.ship_heading_error_rad = phi * self.ship_heading_error_rad
            + (1.0 - phi * phi).sqrt() * spec.ship_heading_sigma_deg.to_radians() * normal(rng);
        let tilt = spec.ship_tilt_sigma_deg.to_radians();
        let [roll, pitch, yaw] = truth.attitude_rad;
        Some(ShipTruth {
            north_m: truth.north_m + spec.ship_position_sigma_m * normal(rng),
            east_m: truth.east_m + spec.ship_position_sigma_m * normal(rng),
            attitude_rad: [
                roll + tilt * normal(rng),
                pitch + tilt * normal(rng),
                crate::angle::wrap_pi(yaw + self.ship_heading_error_rad),
            ],
        })
    }

    /// The raw observation of the transponder at `d` in the transducer's axes (m), with the
    /// USBL's noise.
    pub fn observe(&mut self, d: [f64; 3]) -> RawObservation {
        let [x, y, z] = d;
        let horizontal = x.hypot(y);
        let range = horizontal.hypot(z);
        let angle = self.spec.angle_sigma_deg.to_radians();
        let sigmas = [
            (self.spec.range_sigma_fraction * range).max(self.spec.sigma_floor_m),
            angle,
            angle,
        ];
        let rng = &mut self.rng;
        RawObservation {
            range_bearing_elevation: [
                range + sigmas[0] * normal(rng),
                crate::angle::wrap_pi(y.atan2(x) + sigmas[1] * normal(rng)),
                z.atan2(horizontal) + sigmas[2] * normal(rng),
            ],
            sigmas,
        }
    }

    /// The parameters.
    pub fn spec(&self) -> &UsblSpec {
        &self.spec
    }

    /// The ship at `t_s` (after [`Usbl::fix`] has seen the vehicle at `t_s`): at the head of
    /// the lagged track, heading along it, rolling and pitching in the swell.
    pub fn ship(&self, t_s: f64) -> Option<ShipTruth> {
        let &(_, north_m, east_m) = self.track.front()?;
        let swell = |amplitude_deg: f64, period_s: f64| {
            amplitude_deg.to_radians() * (std::f64::consts::TAU * t_s / period_s).sin()
        };
        Some(ShipTruth {
            north_m,
            east_m,
            attitude_rad: [
                swell(self.spec.ship_roll_deg, SWELL_PERIODS_S[0]),
                swell(self.spec.ship_pitch_deg, SWELL_PERIODS_S[1]),
                self.ship_yaw_rad,
            ],
        })
    }

    /// The fix of the vehicle at `t_s` (north, east, down m), when one is due and in range.
    pub fn fix(&mut self, t_s: f64, ned_m: [f64; 3]) -> Option<Fix> {
        self.track.push_back((t_s, ned_m[0], ned_m[1]));
        while self.track.len() > 1 && self.track[1].0 <= t_s - self.spec.ship_lag_s {
            self.track.pop_front();
        }
        if let (Some(&(_, n0, e0)), Some(&(_, n1, e1))) = (self.track.front(), self.track.get(1)) {
            if (n1 - n0).hypot(e1 - e0) > 1e-3 {
                self.ship_yaw_rad = (e1 - e0).atan2(n1 - n0);
            }
        }
        let ship = self.ship(t_s)?;
        if t_s < self.next_s {
            return None;
        }
        let [lo, hi] = self.spec.every_s;
        self.next_s = t_s + self.rng.random_range(lo..=hi);
        let slant_m = (ned_m[0] - ship.north_m)
            .hypot(ned_m[1] - ship.east_m)
            .hypot(ned_m[2]);
        if slant_m > self.spec.max_range_m {
            return None;
        }
        let sigma_m = (self.spec.range_fraction * slant_m).max(self.spec.sigma_floor_m);
        let mut error_ned_m: [f64; 3] = std::array::from_fn(|_| sigma_m * normal(&mut self.rng));
        let outlier = self.outlier_now();
        let mut outlier_ne_m = [0.0; 2];
        if outlier {
            let [lo, hi] = self.spec.outlier_m;
            let size = self.rng.random_range(lo..=hi);
            let bearing = self.rng.random_range(0.0..std::f64::consts::TAU);
            outlier_ne_m = [size * bearing.cos(), size * bearing.sin()];
            error_ned_m[0] += outlier_ne_m[0];
            error_ned_m[1] += outlier_ne_m[1];
        }
        let jitter_s = self.spec.receipt_jitter_s * normal(&mut self.rng);
        Some(Fix {
            error_ned_m,
            sigma_m,
            delay_s: (self.delay_s + jitter_s).max(0.0),
            outlier,
            outlier_ne_m,
            ship,
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
