//! The DVL's stamp delay and lever arm, from the IMU and the DVL alone, before any filter
//! runs.
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
//!
//! The DVL reads the velocity of its own point, `v_b + omega x l`: between two readings that
//! adds `(omega_2 - omega_1) x l`, and the body velocity in `omega x v_b` is the reading less
//! `omega x l`. The lever arm `l` is common to every window: it is solved out of each
//! window's own unknowns (see `Reduced`) and fitted at each delay of the grid, when it
//! explains the windows clearly better than the configured arm alone.

use crate::contract::Imu;
use crate::filters::velocity::model_aided::BodyVelocityReading;
use nalgebra::{Matrix3, SMatrix, SVector, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::Serialize;

/// Length of a window with its own gravity and drift, s.
pub const WINDOW_S: f64 = 20.0;
/// Delays searched: -SEARCH_S ..= SEARCH_S, s.
pub const SEARCH_S: f64 = 3.0;
/// Step of the grid of delays, s.
const GRID_STEP_S: f64 = 0.05;
/// Two readings further apart than this are not paired, s.
const MAX_PAIR_GAP_S: f64 = 3.0;
/// Readings paired are at least this far apart, s (a 1 Hz DVL's consecutive ones).
const PAIR_SPACING_S: f64 = 0.9;
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
/// The gyro's rate in the lever arm's term is its mean over this span about a reading, s.
const RATE_MEAN_S: f64 = 0.2;
/// The lever arm's prior sigma per axis, m: it keeps an axis the motion does not show near
/// the configured lever arm.
pub const LEVER_PRIOR_M: f64 = 2.0;
/// An axis of the lever arm is used when its correction is this many sigmas from zero.
pub const LEVER_AXIS_SIGMAS: f64 = 3.0;
/// The lever arm is fitted when it explains the windows this much better than the configured
/// one (a chi-square of 3 degrees: 25 is about 4.3 sigmas' worth).
pub const LEVER_MIN_CHI_SQUARE: f64 = 25.0;
/// Unknowns per window: gravity in the window's first body axes, its drift and its curvature,
/// and the gyro's bias (which turns the gravity the integrated attitude sees).
const UNKNOWNS: usize = 12;
/// With the lever arm's three, global to the windows.
const ALL: usize = UNKNOWNS + 3;

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
    /// The DVL's lever arm the same differences show.
    pub lever_arm: LeverArm,
}

/// The DVL's position from the IMU as its readings show it: in a turn or a pitch change the
/// DVL's point moves with `omega x l` on top of the body's velocity.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LeverArm {
    /// The lever arm, body FRD, m: the configured one plus `correction_m`.
    pub lever_arm_m: [f64; 3],
    pub correction_m: [f64; 3],
    /// 1-sigma per axis, m (an axis the motion does not show keeps about its prior's
    /// [`LEVER_PRIOR_M`]).
    pub sigma_m: [f64; 3],
    /// The configured arm with only the corrections of [`LEVER_AXIS_SIGMAS`] or more: what
    /// the plan uses.
    pub clear_lever_arm_m: [f64; 3],
    /// How much those corrections move the DVL's readings about each window's mean rate
    /// (RMS of `(omega - mean) x correction`), m/s: in a steady turn a lever arm changes
    /// nothing, and what "shows" one there is something else.
    pub clear_effect_m_s: f64,
    /// How much better the correction explains the differences than the configured lever arm
    /// alone (a chi-square of 3 degrees, were the errors white).
    pub chi_square_vs_configured: f64,
    /// Whether the delay was searched with the lever arm fitted (its chi-square over every
    /// window reached [`LEVER_MIN_CHI_SQUARE`], and the rates are not biased).
    pub fitted: bool,
    /// The gyro's bias is among the delay's unknowns (a MEMS gyro): it is in the rates the
    /// lever arm's term multiplies, and the lever arm is not fitted.
    pub rates_biased: bool,
}

/// What is integrated over time, summed (zero by default).
#[derive(Debug, Clone, Copy, Default)]
struct Integrals {
    /// The specific force.
    f: Vector3<f64>,
    /// `C^T`, the body from the window's first axes.
    c: Matrix3<f64>,
    /// `omega x v`.
    w: Vector3<f64>,
    /// How gravity in the body moves with a gyro bias error (per rad/s).
    b: Matrix3<f64>,
    /// `[omega x][omega x]`: how `omega x v` moves with the lever arm (`v` is the DVL's
    /// reading less `omega x l`).
    ww: Matrix3<f64>,
    /// The rate itself (for its mean about a reading).
    r: Vector3<f64>,
}

/// A sample's [`Integrals`] per unit time; `ww` is made from the rate where it is summed (an
/// hour's samples hold 72 bytes less each).
#[derive(Debug, Clone, Copy)]
struct Integrands {
    f: Vector3<f64>,
    c: Matrix3<f64>,
    w: Vector3<f64>,
    b: Matrix3<f64>,
    r: Vector3<f64>,
}

impl Integrals {
    /// `self + rate * dt`.
    fn plus(&self, rate: &Integrands, dt: f64) -> Integrals {
        let ww = rate.r.cross_matrix() * rate.r.cross_matrix();
        Integrals {
            f: self.f + rate.f * dt,
            c: self.c + rate.c * dt,
            w: self.w + rate.w * dt,
            b: self.b + rate.b * dt,
            ww: self.ww + ww * dt,
            r: self.r + rate.r * dt,
        }
    }
}

/// One IMU sample's integrands over the interval before it, and where that interval starts.
struct Sample {
    start_s: f64,
    end_s: f64,
    integrands: Integrands,
}

/// Integrals from the window's first IMU stamp, sample by sample.
struct Window {
    samples: Vec<Sample>,
    /// Running integrals at the end of every [`CHECKPOINT`]-th sample; the rest are summed
    /// from the one before (one at every sample would be 216 bytes more per IMU sample: 100
    /// MB over an hour of windows at 100 Hz).
    checkpoints: Vec<Integrals>,
    /// Pairs: the two stamps (s from the window's origin) and the DVL's velocity change.
    pairs: Vec<(f64, f64, Vector3<f64>)>,
    mid_s: f64,
    half_s: f64,
    /// Whether the gyro bias is among the unknowns (see [`with_gyro_bias`]).
    gyro_bias: bool,
}

/// Samples per stored running sum in a [`Window`].
const CHECKPOINT: usize = 4;

impl Window {
    /// Where `t` falls: its sample's index and the time into it (past the last sample, the
    /// number of samples and 0).
    fn locate(&self, t: f64) -> (usize, f64) {
        let i = self.samples.partition_point(|s| s.end_s < t);
        let dt = self
            .samples
            .get(i)
            .map_or(0.0, |s| (t - s.start_s).max(0.0));
        (i, dt)
    }

    /// The samples from the last checkpoint before sample `i` up to it, and that checkpoint
    /// (`None` before the first).
    fn since_checkpoint(&self, i: usize) -> (Option<&Integrals>, &[Sample]) {
        let chunk = i / CHECKPOINT;
        let at = chunk.checked_sub(1).map(|c| &self.checkpoints[c]);
        (at, &self.samples[chunk * CHECKPOINT..i])
    }

    /// The running integrals before sample `i`, summed in the order [`checkpoints`] sums
    /// them: exactly what a stored sum would be.
    fn sums_before(&self, i: usize) -> Integrals {
        let (at, rest) = self.since_checkpoint(i);
        rest.iter()
            .fold(at.copied().unwrap_or_else(Integrals::default), |sum, s| {
                sum.plus(&s.integrands, s.end_s - s.start_s)
            })
    }

    /// Integrals from the first sample's start to `t` (clamped to the samples' span).
    fn integrals(&self, t: f64) -> Integrals {
        let (i, dt) = self.locate(t);
        let before = self.sums_before(i);
        match self.samples.get(i) {
            Some(s) => before.plus(&s.integrands, dt),
            None => before,
        }
    }

    /// [`Window::integrals`]'s rate alone.
    fn rate_integral(&self, t: f64) -> Vector3<f64> {
        let (i, dt) = self.locate(t);
        let (at, rest) = self.since_checkpoint(i);
        let before = rest
            .iter()
            .fold(at.map_or_else(Vector3::zeros, |a| a.r), |sum, s| {
                sum + s.integrands.r * (s.end_s - s.start_s)
            });
        match self.samples.get(i) {
            Some(s) => before + s.integrands.r * dt,
            None => before,
        }
    }

    /// The gyro's mean rate over [`RATE_MEAN_S`] about `t`: a regressor of the lever arm,
    /// whose noise would draw the estimate towards zero (a MEMS gyro's sample is 0.003 rad/s
    /// of noise, as much as a pool vehicle's rate changes between readings).
    fn rate_at(&self, t: f64) -> Vector3<f64> {
        let half = 0.5 * RATE_MEAN_S;
        (self.rate_integral(t + half) - self.rate_integral(t - half)) / RATE_MEAN_S
    }

    /// Each pair's design row (the window's unknowns, then the lever arm's three) and the
    /// part of its velocity change the IMU's integrals leave, with the given delay.
    fn rows(&self, delay_s: f64) -> Vec<(SMatrix<f64, 3, ALL>, Vector3<f64>)> {
        // Integrals of the normalised time and its square over [a, b].
        let poly = |a: f64, b: f64, power: i32| {
            let (x, y) = (
                (a - self.mid_s) / self.half_s,
                (b - self.mid_s) / self.half_s,
            );
            (y.powi(power + 1) - x.powi(power + 1)) / (power + 1) as f64 * self.half_s
        };
        let identity = Matrix3::identity();
        self.pairs
            .iter()
            .map(|&(t1, t2, dv)| {
                let (a, b) = (t1 - delay_s, t2 - delay_s);
                let (at_a, at_b) = (self.integrals(a), self.integrals(b));
                let r = dv - (at_b.f - at_a.f) + (at_b.w - at_a.w);
                let mut design = SMatrix::<f64, 3, ALL>::zeros();
                design
                    .fixed_view_mut::<3, 3>(0, 0)
                    .copy_from(&(at_b.c - at_a.c));
                design
                    .fixed_view_mut::<3, 3>(0, 3)
                    .copy_from(&(identity * poly(a, b, 1)));
                design
                    .fixed_view_mut::<3, 3>(0, 6)
                    .copy_from(&(identity * poly(a, b, 2)));
                if self.gyro_bias {
                    design
                        .fixed_view_mut::<3, 3>(0, 9)
                        .copy_from(&(at_b.b - at_a.b));
                }
                // The DVL's point moves with omega x l: its change between the two
                // measurements is (omega_b - omega_a) x l; and the body's velocity, in
                // omega x v, is the reading less omega x l.
                let turned = self.rate_at(b) - self.rate_at(a);
                design
                    .fixed_view_mut::<3, 3>(0, UNKNOWNS)
                    .copy_from(&(turned.cross_matrix() + (at_b.ww - at_a.ww)));
                (design, r)
            })
            .collect()
    }

    /// The window's fit at the given delay with its own unknowns solved for any lever arm
    /// (see [`Reduced`]), and the solver that gives them.
    fn fit(&self, delay_s: f64) -> Option<(Reduced, WindowSolve)> {
        let rows = self.rows(delay_s);
        let mut normal = SMatrix::<f64, ALL, ALL>::zeros();
        let mut rhs = SVector::<f64, ALL>::zeros();
        for (a, r) in &rows {
            normal += a.transpose() * a;
            rhs += a.transpose() * r;
        }
        let mut own = normal.fixed_view::<UNKNOWNS, UNKNOWNS>(0, 0).into_owned();
        // Some columns coincide for a level vehicle that does not turn (a gyro bias then
        // turns gravity as the linear drift does, and not at all about the vertical): a
        // ridge of 1e-9 of the largest diagonal term keeps the system solvable.
        let ridge = 1e-9 * own.diagonal().max();
        own += SMatrix::<f64, UNKNOWNS, UNKNOWNS>::identity() * ridge.max(1e-300);
        let cholesky = own.cholesky()?;
        let through_cross = cholesky.solve(&normal.fixed_view::<UNKNOWNS, 3>(0, UNKNOWNS));
        let through_rhs = cholesky.solve(&rhs.fixed_rows::<UNKNOWNS>(0));
        // From the residuals themselves (not the normal equations, where the ridge would
        // add to them): each pair's residual is `e - G l`.
        let mut reduced = Reduced::default();
        for (a, r) in &rows {
            let own_part = a.fixed_view::<3, UNKNOWNS>(0, 0);
            let e = r - own_part * through_rhs;
            let g = a.fixed_view::<3, 3>(0, UNKNOWNS) - own_part * through_cross;
            reduced.ss += e.norm_squared();
            reduced.s += g.transpose() * e;
            reduced.big_s += g.transpose() * g;
        }
        Some((
            reduced,
            WindowSolve {
                rows,
                through_cross,
                through_rhs,
            },
        ))
    }

    /// How far a lever arm `l` moves the readings paired about the window's mean (its
    /// `omega x l` less the mean rate's): the sum of squares over the pairs' second readings,
    /// and their count.
    fn lever_effect(&self, delay_s: f64, l: &Vector3<f64>) -> (f64, usize) {
        let (first, last) = (&self.samples[0], &self.samples[self.samples.len() - 1]);
        let span_s = last.end_s - first.start_s;
        let mean = self.rate_integral(f64::INFINITY) / span_s;
        let sum = self
            .pairs
            .iter()
            .map(|&(_, t2, _)| (self.rate_at(t2 - delay_s) - mean).cross(l).norm_squared())
            .sum();
        (sum, self.pairs.len())
    }

    /// The least-squares residual (sum of squares) of the window with the given delay and
    /// lever arm.
    fn residual(&self, delay_s: f64, lever_arm_m: &Vector3<f64>) -> Option<f64> {
        Some(self.fit(delay_s)?.0.at(lever_arm_m))
    }

    /// The velocity differences left unexplained by the best gravity and drift, per pair.
    fn fitted_residuals(
        &self,
        delay_s: f64,
        lever_arm_m: &Vector3<f64>,
    ) -> Option<Vec<Vector3<f64>>> {
        Some(self.fit(delay_s)?.1.residuals(lever_arm_m))
    }

    /// How fast the fitted residuals change with the delay: sum of squares of their
    /// derivative (the information on the delay per unit noise variance, without the noise's
    /// own wiggles that a second difference of the residual would carry).
    fn sensitivity(&self, delay_s: f64, h: f64, lever_arm_m: &Vector3<f64>) -> Option<f64> {
        let plus = self.fitted_residuals(delay_s + h, lever_arm_m)?;
        let minus = self.fitted_residuals(delay_s - h, lever_arm_m)?;
        Some(
            plus.iter()
                .zip(&minus)
                .map(|(p, m)| ((p - m) / (2.0 * h)).norm_squared())
                .sum(),
        )
    }
}

/// A window's least squares with its own unknowns solved out, as a function of the lever
/// arm `l` (global to the windows): its residual sum of squares is `ss - 2 l.s + l^T S l`.
#[derive(Debug, Clone, Copy, Default)]
struct Reduced {
    ss: f64,
    s: Vector3<f64>,
    big_s: Matrix3<f64>,
}

impl Reduced {
    fn at(&self, l: &Vector3<f64>) -> f64 {
        self.ss - 2.0 * l.dot(&self.s) + l.dot(&(self.big_s * l))
    }

    fn add(&mut self, other: &Reduced) {
        self.ss += other.ss;
        self.s += other.s;
        self.big_s += other.big_s;
    }
}

/// What a window's residuals need once the lever arm is known.
struct WindowSolve {
    rows: Vec<(SMatrix<f64, 3, ALL>, Vector3<f64>)>,
    /// The window's normal matrix's inverse times its lever-arm columns and its right side.
    through_cross: SMatrix<f64, UNKNOWNS, 3>,
    through_rhs: SVector<f64, UNKNOWNS>,
}

impl WindowSolve {
    fn residuals(&self, l: &Vector3<f64>) -> Vec<Vector3<f64>> {
        let own = self.through_rhs - self.through_cross * l;
        self.rows
            .iter()
            .map(|(a, r)| {
                r - a.fixed_view::<3, UNKNOWNS>(0, 0) * own - a.fixed_view::<3, 3>(0, UNKNOWNS) * l
            })
            .collect()
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
    let (lo, referenced) = referenced_readings(slice, dvl, (first, last), lever_arm_body_m)?;
    let samples = integrated_samples(slice, &referenced, origin_ns)?;
    let checkpoints = checkpoints(&samples);
    let pairs = reading_pairs(&referenced[first - lo..=last - lo], seconds);
    let (t_first, t_last) = (seconds(dvl[first].stamp_ns), seconds(dvl[last].stamp_ns));
    (pairs.len() >= MIN_PAIRS).then(|| Window {
        samples,
        checkpoints,
        pairs,
        mid_s: 0.5 * (t_first + t_last),
        half_s: (0.5 * (t_last - t_first)).max(1.0),
        gyro_bias: true,
    })
}

/// The readings over the IMU's slice (the window's `first..=last`, and those its margins
/// reach), each moved to the reference point: the DVL's point moves with omega x lever arm
/// too. Returns the index in `dvl` of the first one with them.
fn referenced_readings(
    slice: &[Imu],
    dvl: &[BodyVelocityReading],
    (first, last): (usize, usize),
    lever_arm_body_m: &Vector3<f64>,
) -> Option<(usize, Vec<BodyVelocityReading>)> {
    let rate_at = |ns: i64| {
        let i = slice
            .partition_point(|m| m.stamp_ns < ns)
            .min(slice.len() - 1);
        Vector3::from(slice[i].angular_velocity)
    };
    let (slice_start, slice_end) = (slice.first()?.stamp_ns, slice.last()?.stamp_ns);
    let lo = dvl
        .partition_point(|d| d.stamp_ns < slice_start)
        .saturating_sub(1)
        .min(first);
    let hi = dvl
        .partition_point(|d| d.stamp_ns <= slice_end)
        .max(last + 1);
    let referenced = dvl[lo..hi]
        .iter()
        .map(|d| BodyVelocityReading {
            stamp_ns: d.stamp_ns,
            v_body_m_s: d.v_body_m_s - rate_at(d.stamp_ns).cross(lever_arm_body_m),
        })
        .collect();
    Some((lo, referenced))
}

/// The IMU's samples over the slice with their integrands, the attitude carried from the
/// slice's first axes by the gyro. `None` when the slice spans no time.
fn integrated_samples(
    slice: &[Imu],
    referenced: &[BodyVelocityReading],
    origin_ns: i64,
) -> Option<Vec<Sample>> {
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
            integrands: Integrands {
                f: Vector3::from(w[1].specific_force),
                c: first_from_body.transpose(),
                w: rate.cross(&velocity_at(referenced, w[1].stamp_ns)),
                b: Matrix3::zeros(),
                r: rate,
            },
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
        let body_from_first = s.integrands.c;
        let gravity_body = body_from_first * gravity_first;
        s.integrands.b = -gravity_body.cross_matrix() * body_from_first * m;
    }
    Some(samples)
}

/// The integrals from the slice's start to the end of every [`CHECKPOINT`]-th sample.
fn checkpoints(samples: &[Sample]) -> Vec<Integrals> {
    let mut running = Integrals::default();
    let mut out = Vec::with_capacity(samples.len() / CHECKPOINT);
    for (k, s) in samples.iter().enumerate() {
        running = running.plus(&s.integrands, s.end_s - s.start_s);
        if (k + 1) % CHECKPOINT == 0 {
            out.push(running);
        }
    }
    out
}

/// Consecutive readings' velocity changes `(from s, to s, change)`, of readings at least
/// [`PAIR_SPACING_S`] apart (a faster DVL's neighbours differ by its noise more than by what a
/// delay or a lever arm changes in a fifth of a second) and at most [`MAX_PAIR_GAP_S`].
fn reading_pairs(
    readings: &[BodyVelocityReading],
    seconds: impl Fn(i64) -> f64,
) -> Vec<(f64, f64, Vector3<f64>)> {
    let max_gap_ns = (MAX_PAIR_GAP_S * 1e9) as i64;
    let spacing_ns = (PAIR_SPACING_S * 1e9) as i64;
    let mut chain: Vec<&BodyVelocityReading> = Vec::new();
    for d in readings {
        if chain
            .last()
            .is_none_or(|c| d.stamp_ns - c.stamp_ns >= spacing_ns)
        {
            chain.push(d);
        }
    }
    chain
        .windows(2)
        .filter(|p| p[1].stamp_ns > p[0].stamp_ns && p[1].stamp_ns - p[0].stamp_ns <= max_gap_ns)
        .map(|p| {
            (
                seconds(p[0].stamp_ns),
                seconds(p[1].stamp_ns),
                p[1].v_body_m_s - p[0].v_body_m_s,
            )
        })
        .collect()
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
    let mut spans = Vec::new();
    let mut start = 0;
    while start < dvl.len() {
        let end = dvl.partition_point(|d| d.stamp_ns < dvl[start].stamp_ns + window_ns);
        let last = end.saturating_sub(1).max(start);
        spans.push((start, last));
        start = last + 1;
    }
    // Each window integrates its own IMU slice: in parallel, kept in order.
    spans
        .into_par_iter()
        .filter_map(|(first, last)| window(imu, dvl, first, last, lever_arm_body_m))
        .collect()
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

/// The delay of the DVL's stamps and the DVL's lever arm (`dvl`: its readings in range, body
/// axes, at the configured lever arm `lever_arm_body_m`), or `None` when fewer than
/// [`MIN_WINDOWS`] windows of readings pair up. With `given_delay_s` the delay is held at it
/// and only the lever arm is estimated. The IMU must be sorted by stamp, as ingest leaves it.
///
/// The delay's sigma is the larger of two: the bootstrap's over the windows (resampled with
/// replacement: it holds whatever the windows' errors are, white or not, modelled or not) and
/// the Gauss-Newton one from the residuals' sensitivity; the lever arm's likewise per axis.
pub fn estimate(
    imu: &[Imu],
    dvl: &[BodyVelocityReading],
    lever_arm_body_m: &Vector3<f64>,
    given_delay_s: Option<f64>,
) -> Option<StampDelay> {
    if imu.len() < 2 {
        return None;
    }
    let mut windows = windows(imu, dvl, lever_arm_body_m);
    if windows.len() < MIN_WINDOWS {
        return None;
    }
    with_gyro_bias(&mut windows);
    let delays: Vec<f64> = match given_delay_s {
        Some(d) => vec![d],
        None => {
            let steps = (SEARCH_S / GRID_STEP_S).round() as i32;
            (-steps..=steps).map(|k| k as f64 * GRID_STEP_S).collect()
        }
    };
    let fitted = fit_grid(&windows, &delays);
    if fitted.len() < MIN_WINDOWS {
        return None;
    }
    let search = Search::new(delays, &fitted, windows.iter().any(|w| w.gyro_bias));
    let sums_all = summed(fitted.iter().map(|(_, row)| row), search.delays.len());
    let (windows, grid): (Vec<&Window>, Vec<Vec<Reduced>>) =
        consistent(fitted, &search.levers(&sums_all))
            .into_iter()
            .unzip();
    if grid.len() < MIN_WINDOWS {
        return None;
    }
    let all = search.totals(&summed(grid.iter(), search.delays.len()));
    let delay_s = grid_minimum(&search.delays, &all);
    let draws = search.bootstrap(&grid);
    // At the delay found: the windows' sum, the lever arm and the residual variance.
    let mut at_delay = Reduced::default();
    for w in &windows {
        at_delay.add(&w.fit(delay_s)?.0);
    }
    let lever_fit = solve_lever(&at_delay, search.prior_weight);
    let lever = if search.with_lever {
        lever_fit
    } else {
        Vector3::zeros()
    };
    let dof: usize =
        windows.iter().map(|w| dof(w)).sum::<usize>() - if search.with_lever { 3 } else { 0 };
    let ss = at_delay.at(&lever);
    let variance = ss / dof.max(1) as f64;
    let information: f64 = windows
        .iter()
        .map(|w| w.sensitivity(delay_s, 0.01, &lever))
        .sum::<Option<f64>>()?;
    let gauss_newton = if information > 0.0 {
        (variance / information).sqrt()
    } else {
        f64::INFINITY
    };
    let at_zero = search.delays.iter().position(|&d| d == 0.0).map(|k| all[k]);
    let fit = LeverFit {
        windows: &windows,
        delay_s,
        at_delay,
        lever_fit,
        variance,
        draws: &draws,
    };
    Some(StampDelay {
        delay_s,
        sigma_s: if given_delay_s.is_some() {
            0.0
        } else {
            spread(draws.iter().map(|d| d.delay_s)).max(gauss_newton)
        },
        chi_square_vs_zero: at_zero.map_or(0.0, |z| (z - ss).max(0.0) / variance),
        pairs: windows.iter().map(|w| w.pairs.len()).sum(),
        windows: windows.len(),
        residual_m_s: variance.sqrt(),
        lever_arm: fit.report(&search, lever_arm_body_m),
    })
}

/// Each window's fit at each delay of the grid (a window that cannot be fitted at some delay
/// is left out).
fn fit_grid<'a>(windows: &'a [Window], delays: &[f64]) -> Vec<(&'a Window, Vec<Reduced>)> {
    windows
        .par_iter()
        .filter_map(|w| {
            let row = delays
                .iter()
                .map(|&d| Some(w.fit(d)?.0))
                .collect::<Option<_>>()?;
            Some((w, row))
        })
        .collect()
}

/// The grid of delays and how the lever arm is fitted at each.
struct Search {
    delays: Vec<f64>,
    /// The lever arm's prior, weighed against the differences' variance without it.
    prior_weight: f64,
    /// Whether the lever arm is fitted at all.
    with_lever: bool,
    rates_biased: bool,
}

/// One bootstrap draw's delay and lever arm.
struct Draw {
    delay_s: f64,
    lever: Vector3<f64>,
}

impl Search {
    /// The lever arm is fitted when it explains every window clearly better than none, and
    /// the rates are not a MEMS gyro's (when its bias is among the unknowns it is in the
    /// rates the lever arm's term multiplies: the arm fitted would be the bias's; a pool
    /// run's "found" its z at -1.1 to -1.5 m with none there).
    fn new(delays: Vec<f64>, fitted: &[(&Window, Vec<Reduced>)], rates_biased: bool) -> Search {
        let dof: usize = fitted.iter().map(|(w, _)| dof(w)).sum();
        let sums = summed(fitted.iter().map(|(_, row)| row), delays.len());
        let without = sums.iter().map(|r| r.ss).fold(f64::INFINITY, f64::min) / dof as f64;
        let prior_weight = without / LEVER_PRIOR_M.powi(2);
        let levers: Vec<Vector3<f64>> = sums.iter().map(|r| solve_lever(r, prior_weight)).collect();
        let with_lever =
            !rates_biased && lever_chi_square(&sums, &levers, dof) >= LEVER_MIN_CHI_SQUARE;
        Search {
            delays,
            prior_weight,
            with_lever,
            rates_biased,
        }
    }

    /// The lever arm at each delay (zero when it is not fitted).
    fn levers(&self, sums: &[Reduced]) -> Vec<Vector3<f64>> {
        sums.iter()
            .map(|r| {
                if self.with_lever {
                    solve_lever(r, self.prior_weight)
                } else {
                    Vector3::zeros()
                }
            })
            .collect()
    }

    /// The residual sum of squares at each delay, with its lever arm.
    fn totals(&self, sums: &[Reduced]) -> Vec<f64> {
        sums.iter()
            .zip(self.levers(sums))
            .map(|(r, l)| r.at(&l))
            .collect()
    }

    /// The windows resampled with replacement, a seeded draw (the same log gives the same
    /// answer): the delay and the lever arm of each draw.
    fn bootstrap(&self, grid: &[Vec<Reduced>]) -> Vec<Draw> {
        let n = grid.len();
        let mut rng = ChaCha8Rng::seed_from_u64(BOOTSTRAP_SEED);
        (0..BOOTSTRAP_DRAWS)
            .map(|_| {
                let sums = summed(
                    (0..n).map(|_| &grid[rng.random_range(0..n)]),
                    self.delays.len(),
                );
                let delay_s = grid_minimum(&self.delays, &self.totals(&sums));
                let k = nearest(&self.delays, delay_s);
                Draw {
                    delay_s,
                    lever: solve_lever(&sums[k], self.prior_weight),
                }
            })
            .collect()
    }
}

/// The sample standard deviation.
fn spread(values: impl Iterator<Item = f64>) -> f64 {
    let values: Vec<f64> = values.collect();
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    (values.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0).max(1.0)).sqrt()
}

/// The lever arm fitted at the delay found.
struct LeverFit<'a> {
    windows: &'a [&'a Window],
    delay_s: f64,
    at_delay: Reduced,
    lever_fit: Vector3<f64>,
    variance: f64,
    draws: &'a [Draw],
}

impl LeverFit<'_> {
    /// Its sigmas (the larger of the bootstrap's and the least squares'), its clear axes and
    /// what they do to the readings.
    fn report(&self, search: &Search, configured: &Vector3<f64>) -> LeverArm {
        let covariance = (self.at_delay.big_s + Matrix3::identity() * search.prior_weight)
            .try_inverse()
            .map(|c| c * self.variance);
        let sigma_m = [0, 1, 2].map(|i| {
            let least_squares = covariance.map_or(f64::INFINITY, |c| c[(i, i)].max(0.0).sqrt());
            least_squares.max(spread(self.draws.iter().map(|d| d.lever[i])))
        });
        let l = self.lever_fit;
        let clear = Vector3::from_fn(|i, _| {
            if l[i].abs() >= LEVER_AXIS_SIGMAS * sigma_m[i] {
                l[i]
            } else {
                0.0
            }
        });
        let (effect, count) = self
            .windows
            .iter()
            .map(|w| w.lever_effect(self.delay_s, &clear))
            .fold((0.0, 0), |(s, n), (a, b)| (s + a, n + b));
        let dof = self
            .windows
            .iter()
            .map(|w| dof(w))
            .sum::<usize>()
            .saturating_sub(3)
            .max(1);
        LeverArm {
            lever_arm_m: (configured + l).into(),
            correction_m: l.into(),
            sigma_m,
            clear_lever_arm_m: (configured + clear).into(),
            clear_effect_m_s: (effect / count.max(1) as f64).sqrt(),
            chi_square_vs_configured: (self.at_delay.ss - self.at_delay.at(&l)).max(0.0)
                / (self.at_delay.at(&l) / dof as f64),
            fitted: search.with_lever,
            rates_biased: search.rates_biased,
        }
    }
}

/// The windows' fits summed per delay.
fn summed<'a>(rows: impl Iterator<Item = &'a Vec<Reduced>>, delays: usize) -> Vec<Reduced> {
    let mut sums = vec![Reduced::default(); delays];
    for row in rows {
        sums.iter_mut().zip(row).for_each(|(s, r)| s.add(r));
    }
    sums
}

/// The lever arm that minimises a sum's residual, drawn towards the configured one by its
/// prior (`weight`: the differences' variance over the prior's).
fn solve_lever(sum: &Reduced, weight: f64) -> Vector3<f64> {
    (sum.big_s + Matrix3::identity() * weight)
        .cholesky()
        .map_or(Vector3::zeros(), |c| c.solve(&sum.s))
}

/// How much better the best delay explains the windows with the lever arm fitted than
/// without: the residual's drop over the variance with it.
fn lever_chi_square(sums: &[Reduced], levers: &[Vector3<f64>], dof: usize) -> f64 {
    let without = sums.iter().map(|r| r.ss).fold(f64::INFINITY, f64::min);
    let with = sums
        .iter()
        .zip(levers)
        .map(|(r, l)| r.at(l))
        .fold(f64::INFINITY, f64::min);
    let variance = with / dof.saturating_sub(3).max(1) as f64;
    if variance > 0.0 {
        (without - with).max(0.0) / variance
    } else {
        0.0
    }
}

/// The grid point nearest `x`.
fn nearest(grid: &[f64], x: f64) -> usize {
    (0..grid.len())
        .min_by(|&a, &b| (grid[a] - x).abs().total_cmp(&(grid[b] - x).abs()))
        .unwrap_or(0)
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
        // Each window's best fit in parallel; summed in order (the same sum every run).
        let fits: Vec<(f64, usize)> = windows
            .par_iter()
            .filter_map(|w| {
                let ss = coarse
                    .iter()
                    .filter_map(|&d| w.residual(d, &Vector3::zeros()))
                    .fold(f64::INFINITY, f64::min);
                ss.is_finite().then(|| (ss, dof(w)))
            })
            .collect();
        fits.into_iter()
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
fn consistent<'a>(
    fitted: Vec<(&'a Window, Vec<Reduced>)>,
    levers: &[Vector3<f64>],
) -> Vec<(&'a Window, Vec<Reduced>)> {
    let variance = |(w, row): &(&Window, Vec<Reduced>)| {
        row.iter()
            .zip(levers)
            .map(|(r, l)| r.at(l))
            .fold(f64::INFINITY, f64::min)
            / dof(w) as f64
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

    #[test]
    fn integrals_from_checkpoints_equal_a_running_sum_at_every_sample() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let mut v3 = || Vector3::from_fn(|_, _| rng.random_range(-1.0..1.0));
        let samples: Vec<Sample> = (0..37)
            .map(|k| {
                let start_s = k as f64 * 0.01;
                let m = Matrix3::from_columns(&[v3(), v3(), v3()]);
                Sample {
                    start_s,
                    end_s: start_s + 0.01,
                    integrands: Integrands {
                        f: v3(),
                        c: m,
                        w: v3(),
                        b: m.transpose(),
                        r: v3(),
                    },
                }
            })
            .collect();
        let mut every = vec![Integrals::default()];
        for s in &samples {
            let last = every[every.len() - 1];
            every.push(last.plus(&s.integrands, s.end_s - s.start_s));
        }
        let window = Window {
            checkpoints: checkpoints(&samples),
            samples,
            pairs: Vec::new(),
            mid_s: 0.0,
            half_s: 1.0,
            gyro_bias: false,
        };
        for (s, before) in window.samples.iter().zip(&every) {
            let t = s.start_s + 0.3 * (s.end_s - s.start_s);
            let want = before.plus(&s.integrands, t - s.start_s);
            let got = window.integrals(t);
            // Bit for bit: the same additions in the same order.
            assert_eq!(
                (got.f, got.c, got.b, got.ww, got.r),
                (want.f, want.c, want.b, want.ww, want.r)
            );
            assert_eq!(window.rate_integral(t), want.r);
        }
        let end = window.integrals(1e9);
        assert_eq!(end.c, every[every.len() - 1].c);
        assert_eq!(window.rate_integral(1e9), every[every.len() - 1].r);
    }

    /// A level vehicle whose speed and turn rate vary (its body velocity changes), or that
    /// cruises straight at a constant speed: an exact IMU at 100 Hz and a DVL at 2 Hz with
    /// 5 mm/s of white noise, stamped `delay_s` late.
    fn log(delay_s: f64, manoeuvres: bool, seed: u64) -> (Vec<Imu>, Vec<BodyVelocityReading>) {
        log_with(delay_s, manoeuvres, seed, 0.0, Vector3::zeros())
    }

    /// [`log`] with a gyro bias on every axis (deg/h) and the DVL at `lever_arm_m` from the
    /// IMU (body FRD).
    fn log_with(
        delay_s: f64,
        manoeuvres: bool,
        seed: u64,
        gyro_bias_deg_h: f64,
        lever_arm_m: Vector3<f64>,
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
                let rate = Vector3::new(0.0, 0.0, yaw_rate(t));
                let mut v = Vector3::new(speed(t), 0.0, 0.0) + rate.cross(&lever_arm_m);
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
            let d = estimate(&imu, &dvl, &Vector3::zeros(), None).unwrap();
            assert!((d.delay_s - 0.4).abs() < 3.0 * d.sigma_s, "{d:?}");
            assert!(d.sigma_s < 0.05, "{d:?}");
            assert!(d.chi_square_vs_zero > 25.0, "{d:?}");
        }
    }

    #[test]
    fn an_early_dvl_is_found_too() {
        let (imu, dvl) = log(-1.2, true, 4);
        let d = estimate(&imu, &dvl, &Vector3::zeros(), None).unwrap();
        assert!(
            (d.delay_s + 1.2).abs() < 3.0 * d.sigma_s && d.sigma_s < 0.05,
            "{d:?}"
        );
    }

    #[test]
    fn a_dvl_on_time_shows_no_clear_delay() {
        for seed in 1..=3 {
            let (imu, dvl) = log(0.0, true, seed);
            let d = estimate(&imu, &dvl, &Vector3::zeros(), None).unwrap();
            assert!(d.delay_s.abs() < 3.0 * d.sigma_s, "{d:?}");
        }
    }

    #[test]
    fn a_straight_cruise_cannot_tell_a_delay() {
        let (imu, dvl) = log(0.4, false, 5);
        let d = estimate(&imu, &dvl, &Vector3::zeros(), None).unwrap();
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
            let (imu, dvl) = log_with(0.0, true, seed, 1000.0, Vector3::zeros());
            let d = estimate(&imu, &dvl, &Vector3::zeros(), None).unwrap();
            assert!(d.delay_s.abs() < 3.0 * d.sigma_s, "{d:?}");
            let (imu, dvl) = log_with(0.4, true, seed, 1000.0, Vector3::zeros());
            let d = estimate(&imu, &dvl, &Vector3::zeros(), None).unwrap();
            assert!((d.delay_s - 0.4).abs() < 3.0 * d.sigma_s, "{d:?}");
        }
    }

    /// In the turns the DVL's point moves with `omega x l`: the arm's x and y are found
    /// within 3 sigmas with the delay, and z, which a level vehicle's yaw cannot show, keeps
    /// about its prior's sigma.
    #[test]
    fn a_lever_arm_is_found_with_the_delay_and_an_honest_sigma() {
        let truth = Vector3::new(1.0, -0.3, 0.5);
        for seed in 1..=3 {
            let (imu, dvl) = log_with(0.4, true, seed, 0.0, truth);
            let d = estimate(&imu, &dvl, &Vector3::zeros(), None).unwrap();
            let l = d.lever_arm;
            assert!(l.fitted && l.chi_square_vs_configured > 25.0, "{d:?}");
            for i in 0..2 {
                assert!(
                    (l.lever_arm_m[i] - truth[i]).abs() < 3.0 * l.sigma_m[i] && l.sigma_m[i] < 0.2,
                    "axis {i}: {d:?}"
                );
            }
            assert!(l.sigma_m[2] > 0.5 * LEVER_PRIOR_M, "{d:?}");
            assert!((d.delay_s - 0.4).abs() < 3.0 * d.sigma_s, "{d:?}");
            // A configured arm is a starting point: the estimate is its correction.
            let given = Vector3::new(0.8, 0.0, 0.0);
            let from_given = estimate(&imu, &dvl, &given, None).unwrap().lever_arm;
            assert!((from_given.lever_arm_m[0] - truth[0]).abs() < 3.0 * from_given.sigma_m[0]);
            assert!((from_given.correction_m[0] - 0.2).abs() < 3.0 * from_given.sigma_m[0]);
        }
    }

    /// No lever arm is fitted where there is none, nor on a straight cruise, where no turn
    /// shows one; and a held delay leaves the search to the lever arm.
    #[test]
    fn no_lever_arm_is_fitted_where_none_shows() {
        for seed in 1..=3 {
            let (imu, dvl) = log(0.4, true, seed);
            let d = estimate(&imu, &dvl, &Vector3::zeros(), None).unwrap();
            assert!(!d.lever_arm.fitted, "{d:?}");
        }
        let (imu, dvl) = log_with(0.0, false, 4, 0.0, Vector3::new(1.0, 0.0, 0.0));
        let d = estimate(&imu, &dvl, &Vector3::zeros(), None).unwrap();
        assert!(!d.lever_arm.fitted, "{d:?}");
        let (imu, dvl) = log_with(0.4, true, 5, 0.0, Vector3::new(1.0, 0.0, 0.0));
        let d = estimate(&imu, &dvl, &Vector3::zeros(), Some(0.4)).unwrap();
        assert_eq!(d.delay_s, 0.4);
        let l = d.lever_arm;
        assert!(
            l.fitted && (l.lever_arm_m[0] - 1.0).abs() < 3.0 * l.sigma_m[0],
            "{d:?}"
        );
    }

    #[test]
    fn too_few_readings_give_no_estimate() {
        let (imu, dvl) = log(0.4, true, 6);
        assert_eq!(estimate(&imu, &dvl[..20], &Vector3::zeros(), None), None);
        assert_eq!(estimate(&imu[..1], &dvl, &Vector3::zeros(), None), None);
    }
}
