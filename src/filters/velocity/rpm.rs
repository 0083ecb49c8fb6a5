//! Seed 003's velocity Kalman filter: the forward speed from the propeller, `V = sf rpm + b`,
//! with the scale `sf` and bias `b` learnt from the DVL while it is in range, and the speed
//! handed on while it is not.
//!
//! State `x = [V, sf, b]`. At each propeller reading `V` is predicted from it,
//! `F = [[0, rpm, 1], [0, 1, 0], [0, 0, 1]]`, `Q = diag(q_V^2, q_sf^2 dt, q_b^2 dt)` (`q_V`
//! how far the speed strays from the propeller's relation, the walks of `sf` and `b`); at
//! each DVL reading in range its forward speed updates `V` (`H = [1, 0, 0]`, `R` the DVL's
//! variance), behind a chi-square gate. The filter runs forward only: in an outage it uses
//! what it learnt before it.
//!
//! `q_V` is learnt from the log: a first pass with the configured floor gives the
//! innovations, whose variance less the DVL's is the speed's scatter about the relation; the
//! second pass uses it (never below the floor).

use crate::filters::kalman::{self, chi_square_quantile, Gaussian};
use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

crate::config::with_defaults! {
    /// Settings of the velocity filter.
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct RpmFilter {
        /// Least scatter of the speed about the propeller's relation, m/s (`q_V`'s floor).
        pub speed_sigma_floor_m_s: f64 = 0.02,
        /// A larger learnt scatter means the propeller does not tell the speed: refused, m/s.
        pub max_speed_sigma_m_s: f64 = 0.25,
        /// Random walk of the scale, (m/s per rev/min) per sqrt(s).
        pub scale_walk: f64 = 1e-7,
        /// Random walk of the bias, m/s per sqrt(s).
        pub bias_walk_m_s: f64 = 1e-4,
        /// The DVL's forward-speed 1-sigma, m/s.
        pub dvl_sigma_m_s: f64 = 0.02,
        /// DVL readings in range the filter needs before its speed is used.
        pub min_dvl_updates: usize = 50,
        /// Without a DVL reading in range for this long, the DVL is out, s.
        pub dvl_timeout_s: f64 = 1.0,
        /// At most one speed handed on per interval, s.
        pub min_interval_s: f64 = 1.0,
    }
}

/// One input of the filter, in time order.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Reading {
    /// A propeller reading, rev/min.
    Rpm { stamp_ns: i64, rpm: f64 },
    /// A DVL reading in range: its forward speed in the body, m/s.
    DvlForward { stamp_ns: i64, speed_m_s: f64 },
}

impl Reading {
    pub fn stamp_ns(&self) -> i64 {
        match *self {
            Reading::Rpm { stamp_ns, .. } | Reading::DvlForward { stamp_ns, .. } => stamp_ns,
        }
    }
}

/// The forward speed the filter hands on while the DVL is out.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RpmSpeed {
    pub stamp_ns: i64,
    pub speed_m_s: f64,
    /// Its 1-sigma (the relation's scatter and what the filter does not know of `sf`, `b`).
    pub sigma_m_s: f64,
}

/// What the filter did over a log.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RpmRun {
    pub speeds: Vec<RpmSpeed>,
    /// The learnt scatter of the speed about the propeller's relation, m/s.
    pub speed_sigma_m_s: f64,
    /// DVL readings used (accepted by the gate) and rejected.
    pub dvl_used: usize,
    pub dvl_rejected: usize,
    /// Mean NIS of the DVL updates (1 expected).
    pub mean_nis: f64,
    /// The last scale and bias, with their 1-sigma.
    pub scale: (f64, f64),
    pub bias_m_s: (f64, f64),
}

/// Why the propeller cannot stand in for the DVL.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum RpmRefused {
    #[error("too few DVL readings in range with propeller readings to learn the relation from")]
    NothingToLearn,
    #[error(
        "the propeller read zero at {0:.0} % of the DVL readings while the vehicle moved \
         (over 0.3 m/s): a stuck or disconnected sensor"
    )]
    StuckAtZero(f64),
    #[error(
        "the speed scatters by {0:.2} m/s about the propeller's relation (at most {1:.2}): \
         the propeller does not tell the speed"
    )]
    PoorRelation(f64, f64),
}

/// Runs the filter over `readings` (time-sorted), learning its scatter first.
pub fn run(filter: &RpmFilter, readings: &[Reading]) -> Result<RpmRun, RpmRefused> {
    check_moving_propeller(readings)?;
    let first = pass(filter, readings, filter.speed_sigma_floor_m_s);
    if first.run.dvl_used <= filter.min_dvl_updates {
        return Err(RpmRefused::NothingToLearn);
    }
    let scatter = (first.innovation_var - filter.dvl_sigma_m_s.powi(2))
        .max(filter.speed_sigma_floor_m_s.powi(2))
        .sqrt();
    if scatter > filter.max_speed_sigma_m_s {
        return Err(RpmRefused::PoorRelation(
            scatter,
            filter.max_speed_sigma_m_s,
        ));
    }
    Ok(pass(filter, readings, scatter).run)
}

/// Refuses a propeller that reads zero while the DVL says the vehicle moves.
fn check_moving_propeller(readings: &[Reading]) -> Result<(), RpmRefused> {
    let mut rpm = None;
    let (mut moving, mut zero) = (0usize, 0usize);
    for r in readings {
        match *r {
            Reading::Rpm { rpm: value, .. } => rpm = Some(value),
            Reading::DvlForward { speed_m_s, .. } if speed_m_s.abs() > 0.3 => {
                if let Some(value) = rpm {
                    moving += 1;
                    zero += usize::from(value == 0.0);
                }
            }
            Reading::DvlForward { .. } => {}
        }
    }
    if moving > 0 && zero * 2 > moving {
        return Err(RpmRefused::StuckAtZero(100.0 * zero as f64 / moving as f64));
    }
    Ok(())
}

/// One pass and the variance of its accepted innovations.
struct Pass {
    run: RpmRun,
    innovation_var: f64,
}

/// DVL readings rejected in a row after which the next is taken ungated.
const REOPEN_AFTER: usize = 20;

fn transition(rpm: f64) -> Matrix3<f64> {
    Matrix3::new(0.0, rpm, 1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
}

fn pass(filter: &RpmFilter, readings: &[Reading], speed_sigma_m_s: f64) -> Pass {
    let gate = chi_square_quantile(1, 0.999);
    let h = SMatrix::<f64, 1, 3>::new(1.0, 0.0, 0.0);
    let r = SMatrix::<f64, 1, 1>::new(filter.dvl_sigma_m_s.powi(2));
    let timeout_ns = (filter.dvl_timeout_s * 1e9) as i64;
    let interval_ns = (filter.min_interval_s * 1e9) as i64;
    let mut est: Option<Gaussian<3>> = None;
    let mut last_rpm: Option<(i64, f64)> = None;
    let mut last_dvl_ns: Option<i64> = None;
    let mut last_out_ns: Option<i64> = None;
    let mut run = RpmRun {
        speed_sigma_m_s,
        ..RpmRun::default()
    };
    let (mut sum_nis, mut sum_y2, mut settled) = (0.0, 0.0, 0usize);
    let mut rejected_in_a_row = 0;
    for reading in readings {
        match *reading {
            Reading::Rpm { stamp_ns, rpm } => {
                if let (Some(e), Some((t_prev, _))) = (est.as_mut(), last_rpm) {
                    let dt = ((stamp_ns - t_prev) as f64 * 1e-9).max(0.0);
                    let q = Matrix3::from_diagonal(&Vector3::new(
                        speed_sigma_m_s.powi(2),
                        filter.scale_walk.powi(2) * dt,
                        filter.bias_walk_m_s.powi(2) * dt,
                    ));
                    *e = kalman::predict(e, &transition(rpm), &q);
                }
                last_rpm = Some((stamp_ns, rpm));
                let out = last_dvl_ns.is_none_or(|t| stamp_ns - t > timeout_ns);
                if let Some(e) = est.filter(|_| out && run.dvl_used >= filter.min_dvl_updates) {
                    if last_out_ns.is_none_or(|t| stamp_ns - t >= interval_ns) {
                        last_out_ns = Some(stamp_ns);
                        run.speeds.push(RpmSpeed {
                            stamp_ns,
                            speed_m_s: e.mean[0],
                            sigma_m_s: e.cov[(0, 0)].sqrt(),
                        });
                    }
                }
            }
            Reading::DvlForward {
                stamp_ns,
                speed_m_s,
            } => {
                let Some((_, rpm)) = last_rpm else {
                    continue;
                };
                last_dvl_ns = Some(stamp_ns);
                let e = est.get_or_insert_with(|| first_estimate(filter, rpm, speed_m_s));
                let y = SVector::<f64, 1>::new(speed_m_s - e.mean[0]);
                // Rejected this often in a row, the filter is more likely wrong than the DVL.
                let gate = (rejected_in_a_row < REOPEN_AFTER).then_some(gate);
                let Ok((post, rec)) = kalman::update(e, &y, &h, &r, gate) else {
                    continue;
                };
                if rec.accepted {
                    *e = post;
                    rejected_in_a_row = 0;
                    run.dvl_used += 1;
                    // The scatter and the NIS once the relation is learnt (the first
                    // innovations are the prior's error).
                    if run.dvl_used > filter.min_dvl_updates {
                        settled += 1;
                        sum_nis += rec.nis;
                        sum_y2 += y[0] * y[0];
                    }
                } else {
                    rejected_in_a_row += 1;
                    run.dvl_rejected += 1;
                }
            }
        }
    }
    let n = settled.max(1) as f64;
    run.mean_nis = sum_nis / n;
    if let Some(e) = est {
        run.scale = (e.mean[1], e.cov[(1, 1)].sqrt());
        run.bias_m_s = (e.mean[2], e.cov[(2, 2)].sqrt());
    }
    Pass {
        run,
        innovation_var: sum_y2 / n,
    }
}

/// The estimate at the first DVL reading: the speed measured; a scale and a bias that know
/// nothing yet (the scale 0 with a sigma that spans 2 m/s at this propeller speed, or at
/// 1 rev/min when it is still, the bias 0 +- 0.5 m/s).
fn first_estimate(filter: &RpmFilter, rpm: f64, speed_m_s: f64) -> Gaussian<3> {
    Gaussian {
        mean: Vector3::new(speed_m_s, 0.0, 0.0),
        cov: Matrix3::from_diagonal(&Vector3::new(
            filter.dvl_sigma_m_s.powi(2),
            (2.0 / rpm.abs().max(1.0)).powi(2),
            0.25,
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    /// A run at two propeller speeds (so scale and bias separate), 10 Hz propeller, 5 Hz
    /// DVL with 2 cm/s noise, out from 300 to 420 s. True relation: V = 0.004 rpm + 0.05,
    /// and the speed strays from it by 3 cm/s (white). Returns the readings and the true
    /// speed at each propeller reading.
    fn readings(zero_rpm: bool) -> (Vec<Reading>, Vec<(i64, f64)>) {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let (dvl_noise, stray) = (
            Normal::new(0.0, 0.02).unwrap(),
            Normal::new(0.0, 0.03).unwrap(),
        );
        let (mut out, mut truth) = (Vec::new(), Vec::new());
        for k in 0..6000 {
            let t = k as f64 * 0.1;
            let stamp_ns = (t * 1e9) as i64;
            let rpm = if (k / 1000) % 2 == 0 { 1000.0 } else { 1200.0 };
            let speed = 0.004 * rpm + 0.05 + stray.sample(&mut rng);
            truth.push((stamp_ns, speed));
            out.push(Reading::Rpm {
                stamp_ns,
                rpm: if zero_rpm { 0.0 } else { rpm },
            });
            if k % 2 == 0 && !(300.0..420.0).contains(&t) {
                out.push(Reading::DvlForward {
                    stamp_ns: stamp_ns + 1,
                    speed_m_s: speed + dvl_noise.sample(&mut rng),
                });
            }
        }
        (out, truth)
    }

    /// The speed handed on in the outage is the true one within its sigma (3.5 sigma, and
    /// its scatter about 1 sigma), the relation learnt, the scatter found from the log.
    #[test]
    fn the_propeller_bridges_an_outage_honestly() {
        let (readings, truth) = readings(false);
        let run = run(&RpmFilter::default(), &readings).unwrap();
        assert!(run.speeds.len() > 100, "{}", run.speeds.len());
        assert!(run
            .speeds
            .iter()
            .all(|s| (300.0..421.0).contains(&(s.stamp_ns as f64 * 1e-9))));
        let z: Vec<f64> = run
            .speeds
            .iter()
            .map(|s| {
                let true_speed = truth.iter().find(|t| t.0 == s.stamp_ns).unwrap().1;
                (s.speed_m_s - true_speed) / s.sigma_m_s
            })
            .collect();
        let rms = (z.iter().map(|v| v * v).sum::<f64>() / z.len() as f64).sqrt();
        assert!(z.iter().all(|v| v.abs() < 3.5), "{z:?}");
        assert!((0.7..1.3).contains(&rms), "normalised error rms {rms}");
        // The truth strays by 3 cm/s: the learnt scatter finds it.
        assert!(
            (0.025..0.035).contains(&run.speed_sigma_m_s),
            "{}",
            run.speed_sigma_m_s
        );
        assert!(
            (run.scale.0 - 0.004).abs() < 3.0 * run.scale.1,
            "{:?}",
            run.scale
        );
        assert!(
            (run.bias_m_s.0 - 0.05).abs() < 3.0 * run.bias_m_s.1,
            "{:?}",
            run.bias_m_s
        );
        assert!((0.8..1.2).contains(&run.mean_nis), "{}", run.mean_nis);
    }

    /// A propeller reading zero while the DVL says the vehicle moves is refused.
    #[test]
    fn a_stuck_propeller_is_refused() {
        let (readings, _) = readings(true);
        assert!(matches!(
            run(&RpmFilter::default(), &readings),
            Err(RpmRefused::StuckAtZero(p)) if p > 99.0
        ));
        assert_eq!(
            run(&RpmFilter::default(), &[]),
            Err(RpmRefused::NothingToLearn)
        );
    }
}
