//! The DVL's stamp delay, from the IMU and the DVL alone, before any filter runs.
//!
//! A DVL stamps a reading some time after it measured it (its ping, its processing, a 1 Hz
//! clock of its own). Between two readings the body velocity changes by what the IMU says:
//!
//! `v_b(t2) - v_b(t1) = integral over [t1, t2] of (f_b + g_b - omega_ib x v_b) dt`
//!
//! (the Earth-rate term, 1e-4 of these, is left out). A reading stamped `t` was measured at
//! `t - delay`, so the right delay makes the DVL's differences match the IMU's integrals over
//! the shifted intervals. Gravity in the body, `g_b`, is what is not known without a filter:
//! within a window of [`WINDOW_S`] it is the gyro-integrated attitude's projection of one
//! unknown vector, turned by an unknown gyro bias (linearised: a MEMS gyro's 1000 deg/h
//! turns it by degrees in a window, and through every turn), plus a linear and a quadratic
//! drift in time. Those twelve unknowns are fitted by least squares per window; the
//! delay is the one that leaves the smallest residual over every window (a grid, refined by a
//! parabola), and its sigma the bootstrap's over the windows.
//!
//! What makes the delay observable is a change of acceleration (a turn starting or ending,
//! a speed or depth change): a vehicle that cruises straight shows none, and the sigma says so.

use crate::contract::Imu;
use crate::filters::velocity::model_aided::BodyVelocityReading;
use nalgebra::{Matrix3, SMatrix, SVector, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

/// Length of a window with its own gravity and drift, s.
pub const WINDOW_S: f64 = 20.0;
/// Delays searched: -SEARCH_S ..= SEARCH_S, s.
pub const SEARCH_S: f64 = 3.0;
/// Step of the grid of delays, s.
const GRID_STEP_S: f64 = 0.05;
/// Two readings further apart than this are not paired, s.
const MAX_PAIR_GAP_S: f64 = 3.0;
/// Readings paired in a window, at least (twelve unknowns, three equations a pair).
const MIN_PAIRS: usize = 8;
/// Windows needed, at least (the bootstrap resamples them).
pub const MIN_WINDOWS: usize = 5;
/// How far above the median window's residual variance a window may fit, in sigmas of a
/// variance's scatter (`sqrt(2 / dof)`), before it is left out as one the model does not
/// explain.
const MISFIT_SIGMAS: f64 = 4.0;
/// The F ratio above which the gyro bias is fitted (see [`with_gyro_bias`]).
const GYRO_BIAS_F: f64 = 4.0;
/// Bootstrap draws, and their seed.
const BOOTSTRAP_DRAWS: usize = 200;
const BOOTSTRAP_SEED: u64 = 0x0d71_de1a;
/// Seconds of DVL readings used, at most (the first ones): a delay does not change in a log.
const MAX_SPAN_S: f64 = 3600.0;
/// Unknowns per window: gravity in the window's first body axes, its drift and its curvature,
/// and the gyro's bias (which turns the gravity the integrated attitude sees).
const UNKNOWNS: usize = 12;

/// The estimated delay: a reading stamped `t` was measured at `t - delay_s`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct StampDelay {
    pub delay_s: f64,
    /// 1-sigma of `delay_s`, s.
    pub sigma_s: f64,
    /// Pairs of readings and windows used.
    pub pairs: usize,
    pub windows: usize,
    /// How much better the delay explains the differences than none: the drop of their
    /// residual sum of squares over its variance (a chi-square of 1 degree, were the
    /// differences' errors white).
    pub chi_square_vs_zero: f64,
    /// RMS of the velocity differences left unexplained at `delay_s`, per axis, m/s.
    pub residual_m_s: f64,
}

/// One IMU sample's integrands over the interval before it, and where that interval starts.
struct Sample {
    start_s: f64,
    end_s: f64,
    specific_force: Vector3<f64>,
    body_from_first: Matrix3<f64>,
    rate_cross_velocity: Vector3<f64>,
    /// How gravity in the body moves with a gyro bias error (per rad/s).
    gravity_by_gyro_bias: Matrix3<f64>,
}

/// Running integrals at a time: specific force, `C^T`, `omega x v`, gravity's sensitivity to
/// the gyro bias.
type Integrals = (Vector3<f64>, Matrix3<f64>, Vector3<f64>, Matrix3<f64>);

/// Integrals from the window's first IMU stamp, sample by sample (running sums at each end).
struct Window {
    samples: Vec<Sample>,
    /// Running integrals at each sample's end: f, C^T, omega x v.
    sum_f: Vec<Vector3<f64>>,
    sum_c: Vec<Matrix3<f64>>,
    sum_w: Vec<Vector3<f64>>,
    sum_b: Vec<Matrix3<f64>>,
    /// Pairs: the two stamps (s from the window's origin) and the DVL's velocity change.
    pairs: Vec<(f64, f64, Vector3<f64>)>,
    mid_s: f64,
    half_s: f64,
    /// Whether the gyro bias is among the unknowns (see [`with_gyro_bias`]).
    gyro_bias: bool,
}

impl Window {
    /// Integrals from the first sample's start to `t` (clamped to the samples' span).
    fn integrals(&self, t: f64) -> Integrals {
        let i = self.samples.partition_point(|s| s.end_s < t);
        if i >= self.samples.len() {
            let n = self.samples.len() - 1;
            return (self.sum_f[n], self.sum_c[n], self.sum_w[n], self.sum_b[n]);
        }
        let s = &self.samples[i];
        let part = (t - s.start_s).max(0.0);
        let (f0, c0, w0, b0) = if i == 0 {
            (
                Vector3::zeros(),
                Matrix3::zeros(),
                Vector3::zeros(),
                Matrix3::zeros(),
            )
        } else {
            (
                self.sum_f[i - 1],
                self.sum_c[i - 1],
                self.sum_w[i - 1],
                self.sum_b[i - 1],
            )
        };
        (
            f0 + s.specific_force * part,
            c0 + s.body_from_first * part,
            w0 + s.rate_cross_velocity * part,
            b0 + s.gravity_by_gyro_bias * part,
        )
    }

    /// The least-squares residual (sum of squares) of the window with the given delay.
    fn residual(&self, delay_s: f64) -> Option<f64> {
        let e = self.fitted_residuals(delay_s)?;
        Some(e.iter().map(|r| r.norm_squared()).sum())
    }

    /// The velocity differences left unexplained by the best gravity and drift, per pair.
    fn fitted_residuals(&self, delay_s: f64) -> Option<Vec<Vector3<f64>>> {
        let mut normal = SMatrix::<f64, UNKNOWNS, UNKNOWNS>::zeros();
        let mut rhs = SVector::<f64, UNKNOWNS>::zeros();
        let mut rows = Vec::with_capacity(self.pairs.len());
        // Integrals of the normalised time and its square over [a, b].
        let poly = |a: f64, b: f64, power: i32| {
            let (x, y) = (
                (a - self.mid_s) / self.half_s,
                (b - self.mid_s) / self.half_s,
            );
            (y.powi(power + 1) - x.powi(power + 1)) / (power + 1) as f64 * self.half_s
        };
        for &(t1, t2, dv) in &self.pairs {
            let (a, b) = (t1 - delay_s, t2 - delay_s);
            let (fa, ca, wa, ba) = self.integrals(a);
            let (fb, cb, wb, bb) = self.integrals(b);
            let r = dv - (fb - fa) + (wb - wa);
            let mut design = SMatrix::<f64, 3, UNKNOWNS>::zeros();
            design.fixed_view_mut::<3, 3>(0, 0).copy_from(&(cb - ca));
            let identity = Matrix3::identity();
            design
                .fixed_view_mut::<3, 3>(0, 3)
                .copy_from(&(identity * poly(a, b, 1)));
            design
                .fixed_view_mut::<3, 3>(0, 6)
                .copy_from(&(identity * poly(a, b, 2)));
            if self.gyro_bias {
                design.fixed_view_mut::<3, 3>(0, 9).copy_from(&(bb - ba));
            }
            normal += design.transpose() * design;
            rhs += design.transpose() * r;
            rows.push((design, r));
        }
        // Some columns coincide for a level vehicle that does not turn (a gyro bias then
        // turns gravity as the linear drift does, and not at all about the vertical): a
        // ridge of 1e-9 of the largest diagonal term keeps the system solvable.
        let ridge = 1e-9 * normal.diagonal().max();
        normal += SMatrix::<f64, UNKNOWNS, UNKNOWNS>::identity() * ridge.max(1e-300);
        let solved = normal.cholesky()?.solve(&rhs);
        Some(rows.iter().map(|(a, r)| r - a * solved).collect())
    }

    /// How fast the fitted residuals change with the delay: sum of squares of their
    /// derivative (the information on the delay per unit noise variance, without the noise's
    /// own wiggles that a second difference of the residual would carry).
    fn sensitivity(&self, delay_s: f64, h: f64) -> Option<f64> {
        let plus = self.fitted_residuals(delay_s + h)?;
        let minus = self.fitted_residuals(delay_s - h)?;
        Some(
            plus.iter()
                .zip(&minus)
                .map(|(p, m)| ((p - m) / (2.0 * h)).norm_squared())
                .sum(),
        )
    }
}

/// The body velocity at `t_ns`, linear between readings (the nearest one outside them).
fn velocity_at(dvl: &[BodyVelocityReading], t_ns: i64) -> Vector3<f64> {
    let i = dvl.partition_point(|d| d.stamp_ns < t_ns);
    match (i.checked_sub(1).map(|j| &dvl[j]), dvl.get(i)) {
        (Some(a), Some(b)) if b.stamp_ns > a.stamp_ns => {
            let w = (t_ns - a.stamp_ns) as f64 / (b.stamp_ns - a.stamp_ns) as f64;
            a.v_body_m_s * (1.0 - w) + b.v_body_m_s * w
        }
        (Some(a), _) => a.v_body_m_s,
        (None, Some(b)) => b.v_body_m_s,
        (None, None) => Vector3::zeros(),
    }
}

/// Builds the window of the readings `dvl[first..=last]`.
fn window(
    imu: &[Imu],
    dvl: &[BodyVelocityReading],
    first: usize,
    last: usize,
    lever_arm_body_m: &Vector3<f64>,
) -> Option<Window> {
    let margin_ns = ((SEARCH_S + 1.0) * 1e9) as i64;
    let from = imu.partition_point(|m| m.stamp_ns < dvl[first].stamp_ns - margin_ns);
    let to = imu.partition_point(|m| m.stamp_ns <= dvl[last].stamp_ns + margin_ns);
    let slice = imu.get(from.saturating_sub(1)..to)?;
    let origin_ns = slice.first()?.stamp_ns;
    let seconds = |ns: i64| (ns - origin_ns) as f64 * 1e-9;
    let mut attitude = UnitQuaternion::identity();
    let mut samples = Vec::with_capacity(slice.len());
    // The attitude's integral (for a gyro bias's effect) and gravity in the first axes, from
    // the mean specific force (the vehicle's own accelerations average out).
    let mut attitude_integral = Matrix3::zeros();
    let mut integrals_at = Vec::with_capacity(slice.len());
    let mut force_first = Vector3::zeros();
    for w in slice.windows(2) {
        let (start_s, end_s) = (seconds(w[0].stamp_ns), seconds(w[1].stamp_ns));
        let rate = Vector3::from(w[1].angular_velocity);
        attitude *= UnitQuaternion::from_scaled_axis(rate * (end_s - start_s));
        let first_from_body = *attitude.to_rotation_matrix().matrix();
        attitude_integral += first_from_body * (end_s - start_s);
        integrals_at.push(attitude_integral);
        force_first += first_from_body * Vector3::from(w[1].specific_force) * (end_s - start_s);
        samples.push(Sample {
            start_s,
            end_s,
            specific_force: Vector3::from(w[1].specific_force),
            body_from_first: first_from_body.transpose(),
            rate_cross_velocity: rate.cross(&velocity_at(dvl, w[1].stamp_ns)),
            gravity_by_gyro_bias: Matrix3::zeros(),
        });
    }
    let span_s = samples.last()?.end_s - samples.first()?.start_s;
    if span_s <= 0.0 {
        return None;
    }
    // A gyro bias error b turns the body's attitude by phi(t) = -C(t)^T M(t) b (M the
    // attitude's integral), and gravity in the body by g_b x phi.
    let gravity_first = -force_first / span_s;
    for (s, m) in samples.iter_mut().zip(&integrals_at) {
        let gravity_body = s.body_from_first * gravity_first;
        s.gravity_by_gyro_bias = -gravity_body.cross_matrix() * s.body_from_first * m;
    }
    let mut sums = (
        Vector3::zeros(),
        Matrix3::zeros(),
        Vector3::zeros(),
        Matrix3::zeros(),
    );
    let (mut sum_f, mut sum_c, mut sum_w, mut sum_b) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for s in &samples {
        let dt = s.end_s - s.start_s;
        sums.0 += s.specific_force * dt;
        sums.1 += s.body_from_first * dt;
        sums.2 += s.rate_cross_velocity * dt;
        sums.3 += s.gravity_by_gyro_bias * dt;
        sum_f.push(sums.0);
        sum_c.push(sums.1);
        sum_w.push(sums.2);
        sum_b.push(sums.3);
    }
    // The DVL's point moves with omega x lever arm too: taken out of each reading.
    let rate_at = |ns: i64| {
        let i = slice
            .partition_point(|m| m.stamp_ns < ns)
            .min(slice.len() - 1);
        Vector3::from(slice[i].angular_velocity)
    };
    let at_reference =
        |d: &BodyVelocityReading| d.v_body_m_s - rate_at(d.stamp_ns).cross(lever_arm_body_m);
    let max_gap_ns = (MAX_PAIR_GAP_S * 1e9) as i64;
    let pairs: Vec<(f64, f64, Vector3<f64>)> = dvl[first..=last]
        .windows(2)
        .filter(|p| p[1].stamp_ns > p[0].stamp_ns && p[1].stamp_ns - p[0].stamp_ns <= max_gap_ns)
        .map(|p| {
            (
                seconds(p[0].stamp_ns),
                seconds(p[1].stamp_ns),
                at_reference(&p[1]) - at_reference(&p[0]),
            )
        })
        .collect();
    let (t_first, t_last) = (seconds(dvl[first].stamp_ns), seconds(dvl[last].stamp_ns));
    (pairs.len() >= MIN_PAIRS).then(|| Window {
        samples,
        sum_f,
        sum_c,
        sum_w,
        sum_b,
        pairs,
        mid_s: 0.5 * (t_first + t_last),
        half_s: (0.5 * (t_last - t_first)).max(1.0),
        gyro_bias: true,
    })
}

/// The windows: consecutive readings within [`WINDOW_S`], over the first [`MAX_SPAN_S`].
fn windows(
    imu: &[Imu],
    dvl: &[BodyVelocityReading],
    lever_arm_body_m: &Vector3<f64>,
) -> Vec<Window> {
    let Some(first) = dvl.first() else {
        return Vec::new();
    };
    let end_ns = first.stamp_ns + (MAX_SPAN_S * 1e9) as i64;
    let dvl = &dvl[..dvl.partition_point(|d| d.stamp_ns <= end_ns)];
    let window_ns = (WINDOW_S * 1e9) as i64;
    let mut out = Vec::new();
    let mut start = 0;
    while start < dvl.len() {
        let end = dvl.partition_point(|d| d.stamp_ns < dvl[start].stamp_ns + window_ns);
        let last = end.saturating_sub(1).max(start);
        if let Some(w) = window(imu, dvl, start, last, lever_arm_body_m) {
            out.push(w);
        }
        start = last + 1;
    }
    out
}

/// The grid's minimum, refined by a parabola through it and its neighbours.
fn grid_minimum(delays: &[f64], ss: &[f64]) -> f64 {
    let k = (0..ss.len())
        .min_by(|&a, &b| ss[a].total_cmp(&ss[b]))
        .unwrap_or(0);
    if k == 0 || k + 1 == ss.len() {
        return delays[k];
    }
    let (a, b, c) = (ss[k - 1], ss[k], ss[k + 1]);
    let bend = a - 2.0 * b + c;
    let step = delays[k + 1] - delays[k];
    if bend > 0.0 {
        delays[k] + 0.5 * (a - c) / bend * step
    } else {
        delays[k]
    }
}

/// The delay of the DVL's stamps (`dvl`: its readings in range, body axes), or `None` when
/// fewer than [`MIN_WINDOWS`] windows of readings pair up. The IMU must be sorted by stamp,
/// as ingest leaves it.
///
/// The sigma is the larger of two: the bootstrap's over the windows (resampled with
/// replacement: it holds whatever the windows' errors are, white or not, modelled or not) and
/// the Gauss-Newton one from the residuals' sensitivity.
pub fn estimate(
    imu: &[Imu],
    dvl: &[BodyVelocityReading],
    lever_arm_body_m: &Vector3<f64>,
) -> Option<StampDelay> {
    if imu.len() < 2 {
        return None;
    }
    let mut windows = windows(imu, dvl, lever_arm_body_m);
    if windows.len() < MIN_WINDOWS {
        return None;
    }
    with_gyro_bias(&mut windows);
    let steps = (SEARCH_S / GRID_STEP_S).round() as i32;
    let delays: Vec<f64> = (-steps..=steps).map(|k| k as f64 * GRID_STEP_S).collect();
    // Each window's residual at each delay of the grid (a window that cannot be fitted at
    // some delay is left out).
    let fitted: Vec<(&Window, Vec<f64>)> = windows
        .iter()
        .filter_map(|w| {
            Some((
                w,
                delays
                    .iter()
                    .map(|&d| w.residual(d))
                    .collect::<Option<_>>()?,
            ))
        })
        .collect();
    let (windows, grid): (Vec<&Window>, Vec<Vec<f64>>) = consistent(fitted).into_iter().unzip();
    let n = grid.len();
    if n < MIN_WINDOWS {
        return None;
    }
    let all: Vec<f64> = (0..delays.len())
        .map(|k| grid.iter().map(|row| row[k]).sum())
        .collect();
    let delay_s = grid_minimum(&delays, &all);
    // The windows resampled with replacement, a seeded draw (the same log gives the same
    // answer).
    let mut rng = ChaCha8Rng::seed_from_u64(BOOTSTRAP_SEED);
    let resampled: Vec<f64> = (0..BOOTSTRAP_DRAWS)
        .map(|_| {
            let mut sum = vec![0.0; delays.len()];
            for _ in 0..n {
                let row = &grid[rng.random_range(0..n)];
                sum.iter_mut().zip(row).for_each(|(s, r)| *s += r);
            }
            grid_minimum(&delays, &sum)
        })
        .collect();
    let mean = resampled.iter().sum::<f64>() / resampled.len() as f64;
    let spread = (resampled.iter().map(|d| (d - mean).powi(2)).sum::<f64>()
        / (resampled.len() - 1) as f64)
        .sqrt();
    let pairs: usize = windows.iter().map(|w| w.pairs.len()).sum();
    let ss: f64 = windows
        .iter()
        .map(|w| w.residual(delay_s))
        .sum::<Option<f64>>()?;
    let dof: usize = windows.iter().map(|w| dof(w)).sum();
    let variance = ss / dof as f64;
    let information: f64 = windows
        .iter()
        .map(|w| w.sensitivity(delay_s, 0.01))
        .sum::<Option<f64>>()?;
    let gauss_newton = if information > 0.0 {
        (variance / information).sqrt()
    } else {
        f64::INFINITY
    };
    let at_zero = all[steps as usize];
    Some(StampDelay {
        delay_s,
        sigma_s: spread.max(gauss_newton),
        chi_square_vs_zero: (at_zero - ss).max(0.0) / variance,
        pairs,
        windows: windows.len(),
        residual_m_s: variance.sqrt(),
    })
}

/// Degrees of freedom of a window's fit.
fn dof(w: &Window) -> usize {
    let unknowns = if w.gyro_bias { UNKNOWNS } else { UNKNOWNS - 3 };
    (3 * w.pairs.len()).saturating_sub(unknowns).max(1)
}

/// Whether the gyro bias must be among the unknowns: when fitting it explains the windows
/// clearly better (an F ratio above [`GYRO_BIAS_F`] over a coarse grid of delays), as a
/// MEMS gyro's does. Else it is left out: on a good gyro it would only take information from
/// the delay (a gyro bias turning gravity looks like a late DVL in a turn).
fn with_gyro_bias(windows: &mut [Window]) {
    let coarse: Vec<f64> = (-6..=6).map(|k| k as f64 * 0.5).collect();
    let mut best = |on: bool| -> (f64, usize) {
        windows.iter_mut().for_each(|w| w.gyro_bias = on);
        windows
            .iter()
            .filter_map(|w| {
                let ss = coarse
                    .iter()
                    .filter_map(|&d| w.residual(d))
                    .fold(f64::INFINITY, f64::min);
                ss.is_finite().then(|| (ss, dof(w)))
            })
            .fold((0.0, 0), |(s, n), (ss, d)| (s + ss, n + d))
    };
    let (off, _) = best(false);
    let (on, dof_on) = best(true);
    let added = 3.0 * windows.len() as f64;
    let f = ((off - on) / added) / (on / dof_on.max(1) as f64);
    let keep = f > GYRO_BIAS_F;
    windows.iter_mut().for_each(|w| w.gyro_bias = keep);
}

/// The windows the model explains: a window whose best fit over the grid leaves a residual
/// variance above the median window's by more than [`MISFIT_SIGMAS`] of its scatter is left
/// out. Such a window holds what the model lacks (a MEMS gyro's misalignment and bias turning
/// gravity in a turn, a lever arm): fitted, it would pull the delay wherever that misfit is
/// smallest, the same way in every such window.
fn consistent(fitted: Vec<(&Window, Vec<f64>)>) -> Vec<(&Window, Vec<f64>)> {
    let variance = |(w, row): &(&Window, Vec<f64>)| {
        row.iter().copied().fold(f64::INFINITY, f64::min) / dof(w) as f64
    };
    let mut variances: Vec<f64> = fitted.iter().map(variance).collect();
    variances.sort_by(f64::total_cmp);
    let Some(&median) = variances.get(variances.len() / 2) else {
        return fitted;
    };
    fitted
        .into_iter()
        .filter(|f| {
            let scatter = (2.0 / dof(f.0) as f64).sqrt();
            variance(f) <= median * (1.0 + MISFIT_SIGMAS * scatter)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand_distr::{Distribution, Normal};

    const G: f64 = 9.81;

    /// A level vehicle whose speed and turn rate vary (its body velocity changes), or that
    /// cruises straight at a constant speed: an exact IMU at 100 Hz and a DVL at 2 Hz with
    /// 5 mm/s of white noise, stamped `delay_s` late.
    fn log(delay_s: f64, manoeuvres: bool, seed: u64) -> (Vec<Imu>, Vec<BodyVelocityReading>) {
        log_with_gyro_bias(delay_s, manoeuvres, seed, 0.0)
    }

    /// [`log`] with a gyro bias on every axis, deg/h.
    fn log_with_gyro_bias(
        delay_s: f64,
        manoeuvres: bool,
        seed: u64,
        gyro_bias_deg_h: f64,
    ) -> (Vec<Imu>, Vec<BodyVelocityReading>) {
        let bias = (gyro_bias_deg_h / 3600.0).to_radians();
        let amplitude = if manoeuvres { 1.0 } else { 0.0 };
        let speed = |t: f64| 1.5 + amplitude * 0.3 * (t * std::f64::consts::TAU / 20.0).sin();
        let speed_rate = |t: f64| {
            amplitude * 0.3 * std::f64::consts::TAU / 20.0
                * (t * std::f64::consts::TAU / 20.0).cos()
        };
        let yaw_rate = |t: f64| amplitude * 0.1 * (t * std::f64::consts::TAU / 30.0).sin();
        let ns = |t: f64| (t * 1e9).round() as i64;
        let imu = (0..30_000)
            .map(|k| {
                let t = k as f64 * 0.01;
                Imu {
                    stamp_ns: ns(t),
                    angular_velocity: [bias, -bias, yaw_rate(t) + bias],
                    specific_force: [speed_rate(t), yaw_rate(t) * speed(t), -G],
                }
            })
            .collect();
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let noise = Normal::new(0.0, 0.005).unwrap();
        let dvl = (0..600)
            .map(|k| {
                let t = k as f64 * 0.5;
                let mut v = Vector3::new(speed(t), 0.0, 0.0);
                v.iter_mut().for_each(|x| *x += noise.sample(&mut rng));
                BodyVelocityReading {
                    stamp_ns: ns(t + delay_s),
                    v_body_m_s: v,
                }
            })
            .collect();
        (imu, dvl)
    }

    #[test]
    fn a_late_dvl_is_found_with_an_honest_sigma() {
        for seed in 1..=3 {
            let (imu, dvl) = log(0.4, true, seed);
            let d = estimate(&imu, &dvl, &Vector3::zeros()).unwrap();
            assert!((d.delay_s - 0.4).abs() < 3.0 * d.sigma_s, "{d:?}");
            assert!(d.sigma_s < 0.05, "{d:?}");
            assert!(d.chi_square_vs_zero > 25.0, "{d:?}");
        }
    }

    #[test]
    fn an_early_dvl_is_found_too() {
        let (imu, dvl) = log(-1.2, true, 4);
        let d = estimate(&imu, &dvl, &Vector3::zeros()).unwrap();
        assert!(
            (d.delay_s + 1.2).abs() < 3.0 * d.sigma_s && d.sigma_s < 0.05,
            "{d:?}"
        );
    }

    #[test]
    fn a_dvl_on_time_shows_no_clear_delay() {
        for seed in 1..=3 {
            let (imu, dvl) = log(0.0, true, seed);
            let d = estimate(&imu, &dvl, &Vector3::zeros()).unwrap();
            assert!(d.delay_s.abs() < 3.0 * d.sigma_s, "{d:?}");
        }
    }

    #[test]
    fn a_straight_cruise_cannot_tell_a_delay() {
        let (imu, dvl) = log(0.4, false, 5);
        let d = estimate(&imu, &dvl, &Vector3::zeros()).unwrap();
        assert!(
            d.chi_square_vs_zero < 25.0 || d.sigma_s > 0.4 / 3.0,
            "{d:?}"
        );
    }

    /// A MEMS gyro's bias (1000 deg/h) neither fakes a delay nor hides one on this motion.
    /// (Pool runs where it would, without the gyro bias among the unknowns, are
    /// `tests/tuning.rs`'s `pool-mems-host`: a 2 s delay "found" with a chi-square of 500.)
    #[test]
    fn a_mems_gyro_bias_does_not_fake_a_delay() {
        for seed in 1..=3 {
            let (imu, dvl) = log_with_gyro_bias(0.0, true, seed, 1000.0);
            let d = estimate(&imu, &dvl, &Vector3::zeros()).unwrap();
            assert!(d.delay_s.abs() < 3.0 * d.sigma_s, "{d:?}");
            let (imu, dvl) = log_with_gyro_bias(0.4, true, seed, 1000.0);
            let d = estimate(&imu, &dvl, &Vector3::zeros()).unwrap();
            assert!((d.delay_s - 0.4).abs() < 3.0 * d.sigma_s, "{d:?}");
        }
    }

    #[test]
    fn too_few_readings_give_no_estimate() {
        let (imu, dvl) = log(0.4, true, 6);
        assert_eq!(estimate(&imu, &dvl[..20], &Vector3::zeros()), None);
        assert_eq!(estimate(&imu[..1], &dvl, &Vector3::zeros()), None);
    }
}
