//! Experiment design (`identify --suggest`): which coefficients the logs leave poorly
//! determined, and which manoeuvre or known quantity would determine them, with the sigma
//! predicted after it.
//!
//! The prediction is the Cramer-Rao bound of the logs together with the addition:
//! `inv(F_logs + F_addition)`, with `F_logs` the Fisher information of the identification
//! (initial states marginalised out) and `F_addition` that of a noise-free simulation of the
//! candidate manoeuvre with the identified coefficients, sampled at the logs' sensor rates
//! and weighted by the learnt noise (its own initial state marginalised out too). A
//! coefficient known from elsewhere is held, as `--fix` holds it: its row and column leave
//! the information before the inversion.
//!
//! Why the candidates: the heave equation can be multiplied through by a common factor
//! (`m - Z_wdot`, `Z_w`, `Z_q + m U`, `Z_qdot`, `Z_delta` together) without changing the
//! motion, at every speed alike; only the known terms break that, the small `m z_G q^2`,
//! and `(W - B) cos(theta)` when the weight and buoyancy differ by a known amount. The pitch
//! group is nearly collinear in one zig-zag; another speed changes the balance of its
//! regressors (the plane's moment goes with `U^2`, the damping with `U`, the hydrostatic
//! moment not at all).

use super::identifiability::{assess, Determination};
use super::output_error::information;
use super::record::Record;
use super::settings::Settings;
use super::Identification;
use crate::sim::zigzag::{fly, ZigzagNoise, ZigzagSpec};
use crate::vehicle::heave_pitch::{Coefficients, State, NAMES};
use nalgebra::{DMatrix, SMatrix};

crate::config::with_defaults! {
    /// The candidate manoeuvres' shape and the vehicle's limits (`[design]` of identify's config).
    #[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
    #[serde(deny_unknown_fields, default)]
    pub struct DesignSettings {
        /// The zig-zag flown in each candidate: plane deflection, deg.
        pub plane_deg: f64 = 10.0,
        /// Pitch that triggers a reversal, deg.
        pub trigger_deg: f64 = 5.0,
        pub duration_s: f64 = 200.0,
        /// Plane rate limit, deg/s.
        pub plane_rate_deg_s: f64 = 10.0,
        /// Other speeds to try, as multiples of the logs' mean speed.
        pub speed_factors: Vec<f64> = vec![0.5, 1.5],
        /// A known ballast change to try: weight minus buoyancy as a fraction of the weight
        /// (positive: heavy).
        pub ballast_fraction: f64 = 5e-4,
    }
}

/// A zig-zag to fly.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Manoeuvre {
    pub plane_deg: f64,
    pub trigger_deg: f64,
    pub duration_s: f64,
    pub plane_rate_deg_s: f64,
    pub speed_m_s: f64,
    /// Weight minus buoyancy during the run, N.
    pub weight_minus_buoyancy_n: f64,
}

/// What could be added to the logs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Addition {
    /// One more zig-zag.
    Zigzag(Manoeuvre),
    /// A coefficient (index in [`NAMES`]) known from elsewhere, e.g. an added-mass estimate
    /// or a captive-model test, and held at that value.
    Known(usize),
}

/// A candidate and what it is predicted to give.
#[derive(Debug, Clone, PartialEq)]
pub struct Suggestion {
    pub addition: Addition,
    /// In words, e.g. "zig-zag 10-5 at 1.54 m/s (0.5 U)".
    pub description: String,
    /// Plane reversals the candidate zig-zag makes (0 for a known coefficient).
    pub reversals: usize,
    /// Predicted covariance of the coefficients after it (zero rows for held ones).
    pub covariance: SMatrix<f64, 10, 10>,
    /// Predicted determination of every estimated coefficient.
    pub assessment: Vec<Determination>,
    /// Coefficients poorly determined now whose predicted 1-sigma is within the threshold
    /// (`max_relative_sigma` of the value) and at most half of their sigma now.
    pub determines: Vec<&'static str>,
}

impl Suggestion {
    /// Predicted 1-sigma of coefficient `i` (0 when held).
    pub fn sigma(&self, i: usize) -> f64 {
        self.covariance[(i, i)].max(0.0).sqrt()
    }
}

/// Every candidate, best first: most coefficients newly determined, then the largest mean
/// (log) reduction of the poorly determined coefficients' sigma.
pub fn suggest(
    id: &Identification,
    records: &[Record],
    settings: &Settings,
    design: &DesignSettings,
) -> Vec<Suggestion> {
    let at = Settings {
        sigma: id.noise.sigma,
        ..*settings
    };
    let c = id.refined.coefficients;
    let poorly: Vec<usize> = id
        .assessment
        .iter()
        .filter(|d| d.poorly_determined)
        .filter_map(|d| NAMES.iter().position(|n| *n == d.name))
        .collect();
    let mut suggestions: Vec<Suggestion> = candidates(records, settings, design, &poorly)
        .into_iter()
        .filter_map(|addition| {
            let (extra, reversals, fixed) = match addition {
                Addition::Zigzag(m) => {
                    let (record, reversals) = flown(&m, records, &c, settings);
                    let x0 = super::ekf::first_state(&record);
                    let f = information(std::slice::from_ref(&record), &c, &[x0], &at);
                    (f, reversals, settings.fixed)
                }
                Addition::Known(i) => {
                    let mut fixed = settings.fixed;
                    fixed[i] = Some(c[i]);
                    (SMatrix::zeros(), 0, fixed)
                }
            };
            let covariance = predicted_covariance(&(id.refined.information + extra), &fixed)?;
            let assessment = assess(&c, &covariance, &fixed, &settings.thresholds);
            // Determined by the addition: a 1-sigma within the threshold, and at most half
            // of what it is now (a coefficient flagged only for a correlation may be inside
            // the threshold already; the sigma holds the correlation's effect).
            let determines = poorly
                .iter()
                .filter(|&&i| {
                    let after = covariance[(i, i)].sqrt();
                    fixed[i].is_none()
                        && after <= settings.thresholds.max_relative_sigma * c[i].abs()
                        && after <= 0.5 * id.refined.covariance[(i, i)].sqrt()
                })
                .map(|&i| NAMES[i])
                .collect();
            Some(Suggestion {
                description: describe(&addition, records),
                addition,
                reversals,
                covariance,
                assessment,
                determines,
            })
        })
        .collect();
    let sigma_now = |i: usize| id.refined.covariance[(i, i)].max(0.0).sqrt();
    let gain = |s: &Suggestion| {
        let held = |i: usize| matches!(s.addition, Addition::Known(k) if k == i);
        let logs: Vec<f64> = poorly
            .iter()
            .filter(|&&i| !held(i))
            .map(|&i| (sigma_now(i) / s.sigma(i).max(f64::MIN_POSITIVE)).ln())
            .collect();
        logs.iter().sum::<f64>() / logs.len().max(1) as f64
    };
    suggestions.sort_by(|a, b| {
        b.determines
            .len()
            .cmp(&a.determines.len())
            .then(gain(b).total_cmp(&gain(a)))
    });
    suggestions
}

/// The candidates: the zig-zag again as flown (the reference: more of the same), at other
/// speeds, with a known ballast change, and each poorly determined coefficient known.
fn candidates(
    records: &[Record],
    settings: &Settings,
    design: &DesignSettings,
    poorly: &[usize],
) -> Vec<Addition> {
    let speed = mean_speed(records);
    let k = &settings.constants;
    let zigzag = |speed_m_s: f64, weight_minus_buoyancy_n: f64| {
        Addition::Zigzag(Manoeuvre {
            plane_deg: design.plane_deg,
            trigger_deg: design.trigger_deg,
            duration_s: design.duration_s,
            plane_rate_deg_s: design.plane_rate_deg_s,
            speed_m_s,
            weight_minus_buoyancy_n,
        })
    };
    let mut out = vec![zigzag(speed, k.weight_minus_buoyancy_n)];
    out.extend(
        design
            .speed_factors
            .iter()
            .map(|f| zigzag(speed * f, k.weight_minus_buoyancy_n)),
    );
    if design.ballast_fraction != 0.0 {
        let weight_n = k.mass_kg * k.gravity_m_s2;
        out.push(zigzag(
            speed,
            k.weight_minus_buoyancy_n + design.ballast_fraction * weight_n,
        ));
    }
    out.extend(poorly.iter().map(|&i| Addition::Known(i)));
    out
}

fn mean_speed(records: &[Record]) -> f64 {
    records.iter().map(|r| r.speed_m_s).sum::<f64>() / records.len().max(1) as f64
}

fn describe(addition: &Addition, records: &[Record]) -> String {
    match addition {
        Addition::Zigzag(m) => {
            let speed = mean_speed(records);
            let mut s = format!(
                "zig-zag {}-{} ({} s) at {:.2} m/s",
                m.plane_deg, m.trigger_deg, m.duration_s, m.speed_m_s
            );
            if (m.speed_m_s / speed - 1.0).abs() > 1e-6 {
                s += &format!(" ({:.2} U)", m.speed_m_s / speed);
            }
            if m.weight_minus_buoyancy_n != 0.0 {
                s += &format!(
                    ", with a known ballast change: W - B = {:+.0} N",
                    m.weight_minus_buoyancy_n
                );
            }
            s
        }
        Addition::Known(i) => format!(
            "{} known from elsewhere (an added-mass estimate, a captive-model test) and held",
            NAMES[*i]
        ),
    }
}

/// The candidate flown with coefficients `c` and sampled as the logs are (their IMU, DVL and
/// depth rates), without noise; and its plane reversals.
pub fn flown(
    m: &Manoeuvre,
    records: &[Record],
    c: &Coefficients,
    settings: &Settings,
) -> (Record, usize) {
    let spec = ZigzagSpec {
        name: "candidate".into(),
        plane_deg: m.plane_deg,
        trigger_deg: m.trigger_deg,
        duration_s: m.duration_s,
        plane_rate_deg_s: m.plane_rate_deg_s,
        step_s: 1e-3,
        coefficients: *c,
        constants: crate::vehicle::heave_pitch::Constants {
            speed_m_s: m.speed_m_s,
            weight_minus_buoyancy_n: m.weight_minus_buoyancy_n,
            ..settings.constants
        },
        initial_state: State::new(0.0, 0.0, 0.0, 20.0),
        noise: ZigzagNoise {
            imu_rate_hz: rate(records, |r| r.t_s.len()),
            dvl_rate_hz: rate(records, |r| r.w_m_s.len()),
            depth_rate_hz: rate(records, |r| r.depth_m.len()),
            ..ZigzagNoise::none()
        },
    };
    let (truth, reversals) = fly(&spec);
    let every = |hz: f64| ((spec.noise.imu_rate_hz / hz).round() as usize).max(1);
    let (dvl_every, depth_every) = (
        every(spec.noise.dvl_rate_hz),
        every(spec.noise.depth_rate_hz),
    );
    let record = Record {
        name: "candidate".into(),
        start_stamp_ns: 0,
        t_s: truth.iter().map(|s| s.t_s).collect(),
        plane_rad: truth.iter().map(|s| s.plane_rad).collect(),
        q_rad_s: truth.iter().map(|s| s.state[2]).collect(),
        theta_rad: truth.iter().map(|s| s.state[1]).collect(),
        w_m_s: (0..truth.len())
            .step_by(dvl_every)
            .map(|k| (k, truth[k].state[0]))
            .collect(),
        depth_m: (0..truth.len())
            .step_by(depth_every)
            .map(|k| (k, truth[k].state[3]))
            .collect(),
        speed_m_s: m.speed_m_s,
        theta_source: "simulated",
        weight_minus_buoyancy_n: Some(m.weight_minus_buoyancy_n),
    };
    (record, reversals.len())
}

/// Readings per second over all the logs.
fn rate(records: &[Record], count: impl Fn(&Record) -> usize) -> f64 {
    let n: usize = records.iter().map(&count).sum();
    let seconds: f64 = records
        .iter()
        .map(|r| r.t_s.last().copied().unwrap_or(0.0))
        .sum();
    if seconds > 0.0 {
        n as f64 / seconds
    } else {
        1.0
    }
}

/// `inv(information)` over the coefficients not held; zero rows and columns for held ones.
/// `None` when the information over them is not positive definite.
pub fn predicted_covariance(
    information: &SMatrix<f64, 10, 10>,
    fixed: &[Option<f64>; 10],
) -> Option<SMatrix<f64, 10, 10>> {
    let free: Vec<usize> = (0..10).filter(|&i| fixed[i].is_none()).collect();
    let f = DMatrix::from_fn(free.len(), free.len(), |a, b| {
        information[(free[a], free[b])]
    });
    // Scaled to unit diagonal first: the coefficients' information spans many decades.
    let d: Vec<f64> = (0..free.len()).map(|a| f[(a, a)].sqrt()).collect();
    if d.iter().any(|v| !(v.is_finite() && *v > 0.0)) {
        return None;
    }
    let scaled = DMatrix::from_fn(free.len(), free.len(), |a, b| f[(a, b)] / (d[a] * d[b]));
    let inverse = scaled.cholesky()?.inverse();
    let mut cov = SMatrix::zeros();
    for (a, &i) in free.iter().enumerate() {
        for (b, &j) in free.iter().enumerate() {
            cov[(i, j)] = inverse[(a, b)] / (d[a] * d[b]);
        }
    }
    Some(cov)
}
