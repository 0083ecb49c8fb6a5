//! The forward pass over a whole mission: the nominal state at IMU rate, the covariance at
//! the filter's epochs, the aiding measurements at their times, and the epoch records the
//! smoother needs.
//!
//! - An *epoch* is an IMU tick that carries a measurement or an output time. The covariance
//!   is propagated at epochs and at least every `covariance_interval_s` (one `Phi` per
//!   interval, from `F` at both ends), never per IMU sample: the cost and the memory follow
//!   the epochs, not the IMU rate.
//! - A measurement is applied at the first IMU tick at or after its stamp (at 100 Hz, at
//!   most 10 ms late).
//! - An IMU interval longer than the gap threshold is bridged: the nominal state is carried
//!   through at the IMU's usual step with the samples on either side interpolated, and the
//!   covariance grows with extra noise for the motion nobody measured; measurements inside
//!   the gap are applied at their times.
//!
//! - The aiding sources are the rows of one table ([`super::aid_table`]): at each epoch every
//!   row's readings due are applied, row by row in the table's order, through one Kalman
//!   update with gating, rejection counts and the innovations' log-likelihood.
//!
//! Takes the IMU's time-sorted messages and the aiding table, so it imports no I/O.

use super::aid_table::{
    first_after, Aid, Aiding, Epoch, Measurement, PerSensor, Sensor, SensorReading, Update,
};
use super::error_state::{ErrorMatrix, ErrorState};
use super::forward::{Estimate, Filter, ImuNoise};
use super::heading_reset;
use super::mechanization::{ImuSample, NavState};
use super::record::{EpochRecord, NavPoint};
use super::reopen::{RecentRejections, Rejected};
use crate::contract::Imu;
use crate::disk_backed::Spilled;
use crate::filters::ins::record::PackedTransition;
use crate::filters::kalman::{chi_square_quantile, KalmanError, UpdateRecord};
use crate::geodesy;
use nalgebra::Vector3;

/// How the covariance is carried between epochs and across IMU gaps.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Propagation {
    /// Longest interval over which the covariance is propagated in one step, s.
    pub covariance_interval_s: f64,
    /// An IMU interval longer than this (and longer than three usual intervals) is a gap, s.
    pub imu_gap_s: f64,
    /// Noise added while bridging a gap (on top of the IMU's), same units as [`ImuNoise`].
    pub gap_noise: ImuNoise,
}

/// The settings of one forward run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    pub filter: Filter,
    pub propagation: Propagation,
    pub aiding: Aiding,
}

/// Time-sorted inputs of one mission.
#[derive(Clone, Copy)]
pub struct Inputs<'a> {
    pub imu: &'a [Imu],
    /// The aiding table ([`Aiding::table`]), in the order its updates are applied within an
    /// epoch.
    pub aids: &'a [Box<dyn Aid + 'a>],
    /// Times at which the solution is wanted (an epoch is recorded at the first IMU sample at
    /// or after each).
    pub output_stamps_ns: &'a [i64],
    /// Told the fraction of the IMU samples integrated, now and then.
    pub progress: crate::progress::Progress<'a>,
    /// What the pass keeps of each epoch beyond its residuals and likelihood.
    pub keep: Keep,
}

/// What a pass keeps of each epoch.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum Keep {
    /// Nothing: a pass that is only scored (its residuals and likelihood).
    Nothing,
    /// The epoch records, for a smoother.
    #[default]
    Records,
    /// The navigation state after each epoch's updates, and no covariance: the track that
    /// drives another filter (seed 000's model aid), at a small part of the records' cost.
    Navigation,
}

/// The navigation state after one epoch's updates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NavAt {
    pub stamp_ns: i64,
    pub nav: NavState,
}

/// One aiding measurement as the filter saw it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Residual {
    pub stamp_ns: i64,
    pub sensor: Sensor,
    /// Innovation components (only the first `dims` are used).
    pub innovation: [f64; 3],
    /// Predicted 1-sigma of each component.
    pub sigma: [f64; 3],
    pub dims: u8,
    pub nis: f64,
    pub accepted: bool,
    /// This reading's term of the pass's log-likelihood ([`ForwardRun::log_likelihood`]).
    pub log_likelihood: f64,
    /// The reading repeated the ones before exactly (a stuck sensor's sign).
    pub repeats: bool,
    /// An acoustic reading's slant range from the ship or the beacon, m (single precision:
    /// a plot's axis, and the residual stays 88 bytes).
    pub slant_range_m: Option<f32>,
}

// A long dive keeps millions of residuals: the slant range came in without growing them.
const _: () = assert!(std::mem::size_of::<Residual>() <= 88);

impl Residual {
    fn from_record<const M: usize>(
        stamp_ns: i64,
        sensor: Sensor,
        rec: &UpdateRecord<M>,
        log_likelihood: f64,
        given: AsGiven,
    ) -> Self {
        let mut innovation = [0.0; 3];
        let mut sigma = [0.0; 3];
        for i in 0..M.min(3) {
            innovation[i] = rec.innovation[i];
            sigma[i] = rec.innovation_cov[(i, i)].sqrt();
        }
        Residual {
            stamp_ns,
            sensor,
            innovation,
            sigma,
            dims: M as u8,
            nis: rec.nis,
            accepted: rec.accepted,
            log_likelihood,
            repeats: given.repeats,
            slant_range_m: given.slant_range_m.map(|m| m as f32),
        }
    }
}

/// An interval without IMU data that the filter bridged.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ImuGap {
    pub from_ns: i64,
    pub to_ns: i64,
}

/// What the forward pass produced.
#[derive(Debug, Default)]
pub struct ForwardRun {
    /// One per epoch, on a temporary file beyond a block, when [`Keep::Records`].
    pub records: Spilled<EpochRecord>,
    /// One per epoch when [`Keep::Navigation`].
    pub navigation: Vec<NavAt>,
    pub residuals: Vec<Residual>,
    /// Readings the filter reached but did not use: a DVL without bottom lock or above its
    /// maximum altitude (its own or the echo sounder's), an EM log below 0.1 m/s forward
    /// (where it reads nothing useful), a field without a horizontal part.
    pub unused: PerSensor,
    /// Readings left out by a sensor's minimum interval (depth, magnetometer).
    pub by_interval: PerSensor,
    /// Magnetometer readings left out: the field's magnitude was disturbed.
    pub disturbed: PerSensor,
    /// Times the gate was reopened for a sensor after `gate_reset_after` rejections in a row.
    pub gate_resets: usize,
    /// The longest run of rejections in a row, per sensor.
    pub longest_rejected_run: PerSensor,
    /// Readings skipped because their innovation covariance was not positive definite.
    pub not_positive_definite: PerSensor,
    /// Rejected readings that repeated the readings before exactly: a stuck sensor.
    pub repeated_rejected: PerSensor,
    pub imu_gaps: Vec<ImuGap>,
    /// Log-likelihood of the innovations, `-1/2 sum (NIS + ln det S + m ln 2 pi)`, with each
    /// NIS capped at the gate's bound (so that an outlier counts as a rejection, not as a
    /// verdict on the noise): the score of the noise settings when they are tuned.
    pub log_likelihood: f64,
}

impl ForwardRun {
    /// The log-likelihood of the innovations of the sensors `counted` takes, from `from_ns`
    /// on: a score that leaves out the start's transient (there the start's uncertainty, not
    /// the noise, shapes the innovations).
    pub fn log_likelihood_of(&self, from_ns: i64, counted: impl Fn(Sensor) -> bool) -> f64 {
        self.residuals
            .iter()
            .filter(|r| r.stamp_ns >= from_ns && counted(r.sensor))
            .map(|r| r.log_likelihood)
            .sum()
    }
}

fn imu_sample(m: &Imu) -> ImuSample {
    ImuSample {
        omega_ib_body: m.angular_velocity.into(),
        specific_force_body: m.specific_force.into(),
    }
}

/// The usual IMU interval: the median of the first thousand intervals, s.
pub fn usual_imu_interval_s(imu: &[Imu]) -> Option<f64> {
    let mut dts: Vec<f64> = imu
        .windows(2)
        .take(1000)
        .map(|w| (w[1].stamp_ns - w[0].stamp_ns) as f64 * 1e-9)
        .collect();
    if dts.is_empty() {
        return None;
    }
    dts.sort_by(f64::total_cmp);
    Some(dts[dts.len() / 2])
}

/// Next reading of each row of the aiding table, and the next output time.
#[derive(Debug, Clone)]
struct Cursor {
    aids: Vec<usize>,
    /// The stamp of each row's next reading (`i64::MAX` past its last), so that the check
    /// at every IMU sample asks no aid.
    due_ns: Vec<i64>,
    out: usize,
}

impl Cursor {
    /// Row `row`'s next stamp, read again from its aid.
    fn refresh(&mut self, row: usize, aid: &dyn Aid) {
        let next = self.aids[row];
        self.due_ns[row] = if next < aid.len() {
            aid.stamp_ns(next)
        } else {
            i64::MAX
        };
    }
}

struct Pass<'a> {
    settings: &'a Settings,
    inputs: &'a Inputs<'a>,
    gate: [Option<f64>; 4],
    /// Largest NIS a measurement adds to the log-likelihood, by dimension.
    nis_cap: [f64; 4],
    est: Estimate,
    /// Nominal state when the covariance was last propagated, and what has accumulated
    /// since: the sums of corrected specific force and body rate times dt, and the time.
    cov_nav: NavState,
    f_dt_sum: Vector3<f64>,
    w_dt_sum: Vector3<f64>,
    cov_dt_s: f64,
    gap_since_cov: bool,
    /// Transition and process-noise diagonal of the last covariance step (one per epoch).
    step_phi: PackedTransition,
    step_q: ErrorState,
    /// Bias-corrected body rate relative to NED at the current epoch.
    omega_nb_body: Vector3<f64>,
    at: Cursor,
    run: ForwardRun,
    /// Rejections in a row, per sensor.
    consecutive_rejections: PerSensor,
    /// The readings of those rejections, per sensor, to judge whether the gate may reopen.
    recent: [RecentRejections; Sensor::ALL.len()],
    /// A body-frame velocity has been read: from then on each reset keeps the heading's
    /// unobservable direction ([`heading_reset::keep_heading_unobservable`]).
    body_velocity_read: bool,
    /// The turns of this epoch's resets so far, for its record.
    heading_turn: Vector3<f64>,
    /// When each sensor's last reading was taken, ns.
    last_accepted_ns: [i64; Sensor::ALL.len()],
}

/// What the gate's reopening needs to know of a reading besides its update.
#[derive(Debug, Clone, Copy)]
struct AsGiven {
    reading: Option<SensorReading>,
    /// It repeats the readings before exactly.
    repeats: bool,
    /// Its slant range from its acoustic observer, m.
    slant_range_m: Option<f64>,
}

/// An update's attitude correction beyond which one linearisation does not hold, rad (1 deg).
const LINEAR_ATTITUDE_RAD: f64 = 0.017_453_292_519_943_295;

/// A reading this long after the sensor's last one taken comes back from a gap, ns (the
/// iterated update, [`Pass::iterate`]).
const AFTER_GAP_NS: i64 = 5_000_000_000;

/// The iterated update's passes at most.
const ITERATIONS: usize = 4;

/// An iterated pass that moves no element of the correction by more than this has settled.
const SETTLED_RAD_OR_M_S: f64 = 1e-6;

/// One pass of the iterated update: the prior's covariance `cov` updated by `m` (a reading's
/// innovation and row at `prior (+) dx`), with the innovation `y + H dx`; the new correction.
fn relinearised<const M: usize>(
    cov: &mut ErrorMatrix,
    m: &Measurement<M>,
    dx: &ErrorState,
    considered: Option<&[bool; super::error_state::N]>,
) -> Option<ErrorState> {
    let y = m.y + m.h * dx;
    crate::filters::kalman::correct_considering(cov, &y, &m.h, &m.r, None, considered)
        .ok()
        .and_then(|(dx, _)| dx)
}

/// Runs the forward filter from `initial` (the estimate at the first IMU sample).
pub fn run_forward(settings: &Settings, inputs: &Inputs<'_>, initial: Estimate) -> ForwardRun {
    match Running::start(settings, inputs, initial) {
        Some(mut running) => {
            running.run_until(i64::MAX);
            running.finish()
        }
        None => ForwardRun::default(),
    }
}

/// A forward pass that can be stopped at a time, looked at and carried on: a bank of
/// hypotheses drops the ones the data have ruled out without running them to the end.
pub struct Running<'a> {
    pass: Pass<'a>,
    /// The IMU interval to integrate next (from sample `next` to `next + 1`).
    next: usize,
    usual_dt: f64,
    gap_s: f64,
}

impl<'a> Running<'a> {
    /// The pass at the first IMU sample, its first epoch kept (`None`: no IMU samples).
    pub fn start(
        settings: &'a Settings,
        inputs: &'a Inputs<'a>,
        initial: Estimate,
    ) -> Option<Self> {
        let first = inputs.imu.first()?;
        let t0 = first.stamp_ns;
        let aiding = &settings.aiding;
        let gate = |m: usize| aiding.gate_probability.map(|p| chi_square_quantile(m, p));
        let cap = |m: usize| gate(m).unwrap_or_else(|| chi_square_quantile(m, 0.999));
        // Measurements at or before the first IMU sample predate the initial estimate.
        let mut at = Cursor {
            aids: inputs
                .aids
                .iter()
                .map(|aid| first_after(aid.as_ref(), t0))
                .collect(),
            due_ns: vec![i64::MAX; inputs.aids.len()],
            out: inputs.output_stamps_ns.partition_point(|&s| s <= t0),
        };
        for (row, aid) in inputs.aids.iter().enumerate() {
            at.refresh(row, aid.as_ref());
        }
        let mut pass = Pass {
            consecutive_rejections: PerSensor::default(),
            recent: Default::default(),
            body_velocity_read: false,
            heading_turn: Vector3::zeros(),
            last_accepted_ns: [t0; Sensor::ALL.len()],
            settings,
            inputs,
            gate: [None, gate(1), gate(2), gate(3)],
            nis_cap: [0.0, cap(1), cap(2), cap(3)],
            est: initial,
            cov_nav: initial.nav,
            f_dt_sum: Vector3::zeros(),
            w_dt_sum: Vector3::zeros(),
            cov_dt_s: 0.0,
            gap_since_cov: false,
            step_phi: PackedTransition::identity(),
            step_q: ErrorState::zeros(),
            omega_nb_body: Vector3::zeros(),
            at,
            run: ForwardRun::default(),
        };
        for aid in inputs.aids {
            let left = aid.left_out();
            pass.run.by_interval[aid.sensor()] += left.by_interval;
            pass.run.disturbed[aid.sensor()] += left.disturbed;
        }
        // The first epoch: the estimate is the initial one, its step the identity.
        pass.keep(t0, true, &NavPoint::from(&initial));
        let usual_dt = usual_imu_interval_s(inputs.imu).unwrap_or(0.01);
        Some(Running {
            pass,
            next: 0,
            usual_dt,
            gap_s: settings.propagation.imu_gap_s.max(3.0 * usual_dt),
        })
    }

    /// Integrates the IMU samples stamped up to `end_ns`, with the measurements and outputs
    /// due on the way. An aid may have grown since the last call (one filled as another
    /// filter runs): its readings up to `end_ns` must be in it by now.
    pub fn run_until(&mut self, end_ns: i64) {
        let pass = &mut self.pass;
        for (row, aid) in pass.inputs.aids.iter().enumerate() {
            pass.at.refresh(row, aid.as_ref());
        }
        let imu = self.pass.inputs.imu;
        let samples = imu.len();
        while self.next + 1 < samples && imu[self.next + 1].stamp_ns <= end_ns {
            let k = self.next;
            self.next += 1;
            crate::progress::tell(self.pass.inputs.progress, k, samples, 1 << 16);
            self.integrate(&imu[k], &imu[k + 1]);
        }
    }

    /// One IMU interval: a step, or interpolated steps over a gap (recorded as one).
    fn integrate(&mut self, a: &Imu, b: &Imu) {
        let pass = &mut self.pass;
        let dt = (b.stamp_ns - a.stamp_ns) as f64 * 1e-9;
        if dt <= 0.0 {
            return; // ingest sorts and removes duplicates; nothing to integrate
        }
        let (sa, sb) = (imu_sample(a), imu_sample(b));
        if dt <= self.gap_s {
            pass.advance(&sa, &sb, dt, b.stamp_ns, false);
            return;
        }
        pass.run.imu_gaps.push(ImuGap {
            from_ns: a.stamp_ns,
            to_ns: b.stamp_ns,
        });
        let steps = (dt / self.usual_dt).ceil().max(1.0) as i64;
        let span_ns = b.stamp_ns - a.stamp_ns;
        let mut prev = sa;
        for k in 1..=steps {
            let s = k as f64 / steps as f64;
            let t = a.stamp_ns + span_ns * k / steps;
            let next = ImuSample::lerp(&sa, &sb, s);
            pass.advance(&prev, &next, dt / steps as f64, t, true);
            prev = next;
        }
    }

    /// The navigation states kept since the last call (with [`Keep::Navigation`]), handed
    /// over.
    pub fn take_navigation(&mut self) -> Vec<NavAt> {
        std::mem::take(&mut self.pass.run.navigation)
    }

    /// What the pass kept.
    pub fn finish(self) -> ForwardRun {
        self.pass.run
    }
}

impl Pass<'_> {
    /// Keeps what the inputs ask of the epoch at `t` whose prior estimate was `prior`.
    fn keep(&mut self, t: i64, output: bool, prior: &NavPoint) {
        let turn = std::mem::take(&mut self.heading_turn);
        match self.inputs.keep {
            Keep::Nothing => {}
            Keep::Records => self.run.records.push(EpochRecord::new(
                t,
                output,
                &self.step_phi,
                &self.step_q,
                prior,
                &self.est,
                &turn,
            )),
            Keep::Navigation => self.run.navigation.push(NavAt {
                stamp_ns: t,
                nav: self.est.nav,
            }),
        }
    }

    /// One step of the nominal state to tick `t` (IMU `a` to `b` over `dt`), then the
    /// measurements and outputs due at `t`.
    fn advance(&mut self, a: &ImuSample, b: &ImuSample, dt: f64, t: i64, in_gap: bool) {
        let filter = &self.settings.filter;
        self.est.nav = filter.propagate_nominal(&self.est, a, b, dt, None);
        let corrected = self.est.corrected(&ImuSample::mean(a, b));
        self.f_dt_sum += corrected.specific_force_body * dt;
        self.w_dt_sum += corrected.omega_ib_body * dt;
        self.cov_dt_s += dt;
        self.gap_since_cov |= in_gap;

        // Every covariance step is an epoch, so that each record holds one step (its Q is
        // then diagonal, and the record small).
        let epoch = self.due(t) || self.cov_dt_s >= self.settings.propagation.covariance_interval_s;
        if epoch {
            // Only the measurements read it (a DVL's lever arm).
            self.omega_nb_body = self.omega_nb(b);
            self.propagate_covariance();
            let prior = NavPoint::from(&self.est);
            let output = self
                .inputs
                .output_stamps_ns
                .get(self.at.out)
                .is_some_and(|&s| s <= t);
            self.apply_measurements(t);
            self.keep(t, output, &prior);
            self.cov_nav = self.est.nav;
        }
    }

    /// The corrected body rate relative to NED, `omega_ib (corrected) - C^T (omega_ie +
    /// omega_en)`.
    fn omega_nb(&self, imu: &ImuSample) -> Vector3<f64> {
        let nav = &self.est.nav;
        let local = geodesy::Local::at(nav.lat_rad, nav.height_m);
        let w_in = local.earth_rate_ned() + local.transport_rate_ned(&nav.vel_ned_m_s);
        self.est.corrected(imu).omega_ib_body - nav.ned_from_body.inverse() * w_in
    }

    /// Whether any measurement or output is due at or before `t`.
    fn due(&self, t: i64) -> bool {
        let inputs = self.inputs;
        self.at.due_ns.iter().any(|&s| s <= t)
            || inputs
                .output_stamps_ns
                .get(self.at.out)
                .is_some_and(|&s| s <= t)
    }

    fn propagate_covariance(&mut self) {
        if self.cov_dt_s <= 0.0 {
            return;
        }
        let filter = &self.settings.filter;
        let mean = ImuSample {
            omega_ib_body: self.w_dt_sum / self.cov_dt_s,
            specific_force_body: self.f_dt_sum / self.cov_dt_s,
        };
        let noise = if self.gap_since_cov {
            let (n, g) = (filter.noise, self.settings.propagation.gap_noise);
            ImuNoise {
                gyro_noise_density: n.gyro_noise_density.hypot(g.gyro_noise_density),
                accel_noise_density: n.accel_noise_density.hypot(g.accel_noise_density),
                gyro_bias_walk: n.gyro_bias_walk.hypot(g.gyro_bias_walk),
                accel_bias_walk: n.accel_bias_walk.hypot(g.accel_bias_walk),
            }
        } else {
            filter.noise
        };
        self.step_q = filter.propagate_covariance_in_place(
            &mut self.est.cov,
            &mut self.step_phi,
            &self.cov_nav,
            &self.est.nav,
            &mean,
            self.cov_dt_s,
            &noise,
        );
        self.cov_nav = self.est.nav;
        self.f_dt_sum = Vector3::zeros();
        self.w_dt_sum = Vector3::zeros();
        self.cov_dt_s = 0.0;
        self.gap_since_cov = false;
    }

    /// Applies an update of any size.
    fn apply_any(
        &mut self,
        stamp_ns: i64,
        sensor: Sensor,
        u: &Update,
        given: AsGiven,
        remeasure: &dyn Fn(&Estimate) -> Option<Update>,
    ) {
        match u {
            Update::One(m) => self.apply(stamp_ns, sensor, m, given, remeasure),
            Update::Two(m) => self.apply(stamp_ns, sensor, m, given, remeasure),
            Update::Three(m) => self.apply(stamp_ns, sensor, m, given, remeasure),
        }
    }

    /// Whether the gate reopens for this reading: a sensor rejected `gate_reset_after` times
    /// in a row is more likely right than the filter (which has drifted away from it), when
    /// those readings agree with each other and this one is not a stuck sensor's repeat
    /// ([`super::reopen`]). A source that gives no reading reopens on the count alone.
    fn reopens(&self, sensor: Sensor, given: AsGiven) -> bool {
        let reset_after = self.settings.aiding.gate_reset_after;
        reset_after > 0
            && self.consecutive_rejections[sensor] >= reset_after
            && !given.repeats
            && (given.reading.is_none() || self.recent[sensor as usize].agree())
    }

    /// The first reading a sensor gives after a gap ([`AFTER_GAP_NS`]) whose update turned the
    /// attitude by more than [`LINEAR_ATTITUDE_RAD`] is taken again from `prior`, relinearised
    /// at each answer (the iterated EKF: each pass is an update of the prior with the
    /// innovation `y_i + H_i dx_i` of the reading at `prior (+) dx_i`), until the answer moves
    /// by less than [`SETTLED_RAD_OR_M_S`] or [`ITERATIONS`] passes. One linearisation cannot
    /// take a correction that large: after 48 s out of the water
    /// (`TEST_PISCINE_20160305_OUTOFWATER`) a single step left 0.27 m/s of vertical velocity
    /// behind against a 0.02 m/s sigma, and the gate then refused the next 22 readings (59 %
    /// of the run's DVL rejected; 5.8 % with this). Only after a gap: iterated on every large
    /// correction, it also acted in the in-motion alignment's 15 deg wide hypotheses and the
    /// tuning's passes, and `pool-rectangle` seed 6 went from 0.33 to 2.23 m.
    fn iterate(&mut self, prior: &Estimate, remeasure: &dyn Fn(&Estimate) -> Option<Update>) {
        let turned = super::error_state::difference(&self.est.nav, &prior.nav);
        if turned.fixed_rows::<3>(6).norm() <= LINEAR_ATTITUDE_RAD {
            return;
        }
        let considered = self
            .settings
            .filter
            .considered
            .iter()
            .any(|&c| c)
            .then_some(&self.settings.filter.considered);
        let mut dx =
            super::record::correction_between(&NavPoint::from(prior), &NavPoint::from(&self.est));
        for _ in 0..ITERATIONS {
            let Some(update) = remeasure(&prior.corrected_by(&dx)) else {
                return;
            };
            let mut cov = prior.cov;
            let next = match update {
                Update::One(m) => relinearised(&mut cov, &m, &dx, considered),
                Update::Two(m) => relinearised(&mut cov, &m, &dx, considered),
                Update::Three(m) => relinearised(&mut cov, &m, &dx, considered),
            };
            let Some(next) = next else { return };
            let settled = (next - dx).amax() < SETTLED_RAD_OR_M_S;
            dx = next;
            self.est = prior.corrected_by(&dx);
            self.est.cov = cov;
            if settled {
                return;
            }
        }
    }

    /// Applies an update and records its residual.
    fn apply<const M: usize>(
        &mut self,
        stamp_ns: i64,
        sensor: Sensor,
        m: &Measurement<M>,
        given: AsGiven,
        remeasure: &dyn Fn(&Estimate) -> Option<Update>,
    ) {
        let reopen = self.reopens(sensor, given);
        // Kept only where it may be needed: the estimate is kilobytes, and this runs per reading.
        let after_gap = stamp_ns - self.last_accepted_ns[sensor as usize] > AFTER_GAP_NS;
        let prior = after_gap.then_some(self.est);
        let gate = if reopen { None } else { self.gate[M] };
        if reopen {
            self.run.gate_resets += 1;
        }
        let v_before = self.est.nav.vel_ned_m_s;
        let velocity_variance = heading_reset::horizontal_velocity_variance(&self.est.cov);
        let rec = match self
            .settings
            .filter
            .update_in_place(&mut self.est, &m.y, &m.h, &m.r, gate)
        {
            Ok(rec) => rec,
            // Nothing was changed: the reading is skipped, counted and warned, and the run
            // (a day's, perhaps) goes on.
            Err(KalmanError::InnovationNotPositiveDefinite) => {
                self.run.not_positive_definite[sensor] += 1;
                return;
            }
        };
        if rec.accepted {
            self.last_accepted_ns[sensor as usize] = stamp_ns;
            if let Some(prior) = &prior {
                self.iterate(prior, remeasure);
            }
        }
        self.body_velocity_read |= sensor.reads_body_velocity();
        if rec.accepted && self.body_velocity_read {
            let moved = self.est.nav.vel_ned_m_s - v_before;
            if let Some(turn) = heading_reset::turn_of(&moved, velocity_variance) {
                heading_reset::keep_heading_unobservable(&mut self.est.cov, &turn);
                self.heading_turn += turn;
            }
        }
        self.remember(stamp_ns, sensor, m, rec.accepted, given);
        let longest = &mut self.run.longest_rejected_run[sensor];
        *longest = (*longest).max(self.consecutive_rejections[sensor]);
        // A stuck sensor's repeats are no measurements: they do not score the noise settings
        // (a capped NIS still rewards a small innovation covariance, reading after reading).
        let log_likelihood = if given.repeats {
            0.0
        } else {
            -0.5 * (rec.nis.min(self.nis_cap[M])
                + rec.log_det_innovation_cov
                + M as f64 * (2.0 * std::f64::consts::PI).ln())
        };
        self.run.log_likelihood += log_likelihood;
        self.run.residuals.push(Residual::from_record(
            stamp_ns,
            sensor,
            &rec,
            log_likelihood,
            given,
        ));
    }

    /// Counts the rejections in a row, and keeps their readings for [`Pass::reopens`].
    fn remember<const M: usize>(
        &mut self,
        stamp_ns: i64,
        sensor: Sensor,
        m: &Measurement<M>,
        accepted: bool,
        given: AsGiven,
    ) {
        let recent = &mut self.recent[sensor as usize];
        if accepted {
            self.consecutive_rejections[sensor] = 0;
            recent.clear();
            return;
        }
        self.consecutive_rejections[sensor] += 1;
        self.run.repeated_rejected[sensor] += usize::from(given.repeats);
        let Some(reading) = given.reading else {
            return;
        };
        let mut variance = [0.0; 3];
        for (c, v) in variance.iter_mut().enumerate().take(M.min(reading.dims)) {
            *v = m.r[(c, c)];
        }
        let rejected = Rejected {
            t_s: stamp_ns as f64 * 1e-9,
            value: reading.value,
            variance,
            dims: reading.dims,
        };
        recent.push(rejected, self.settings.aiding.gate_reset_after);
    }

    /// Every reading due at `t`, row by row of the aiding table.
    fn apply_measurements(&mut self, t: i64) {
        let inputs = self.inputs;
        for (row, aid) in inputs.aids.iter().enumerate() {
            while self.at.aids[row] < aid.len() && aid.stamp_ns(self.at.aids[row]) <= t {
                let i = self.at.aids[row];
                self.at.aids[row] += 1;
                let at = Epoch {
                    est: &self.est,
                    omega_nb_body: self.omega_nb_body,
                };
                match aid.measure(i, &at) {
                    Some(u) => {
                        let given = AsGiven {
                            reading: aid.reading(i),
                            repeats: aid.repeats(i),
                            slant_range_m: aid.slant_range_m(i),
                        };
                        let omega_nb_body = self.omega_nb_body;
                        let remeasure =
                            |est: &Estimate| aid.measure(i, &Epoch { est, omega_nb_body });
                        self.apply_any(aid.stamp_ns(i), aid.sensor(), &u, given, &remeasure)
                    }
                    None => self.run.unused[aid.sensor()] += 1,
                }
            }
            self.at.refresh(row, aid.as_ref());
        }
        while self
            .inputs
            .output_stamps_ns
            .get(self.at.out)
            .is_some_and(|&s| s <= t)
        {
            self.at.out += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_likelihood_after_a_time_sums_the_later_readings_terms() {
        let residual = |stamp_ns, log_likelihood| Residual {
            stamp_ns,
            sensor: Sensor::Dvl,
            innovation: [0.0; 3],
            sigma: [1.0; 3],
            dims: 3,
            nis: 0.0,
            accepted: true,
            log_likelihood,
            repeats: false,
            slant_range_m: None,
        };
        let run = ForwardRun {
            residuals: vec![residual(10, -1.0), residual(20, -2.0), residual(30, -4.0)],
            log_likelihood: -7.0,
            ..ForwardRun::default()
        };
        let all = |_| true;
        assert_eq!(run.log_likelihood_of(i64::MIN, all), run.log_likelihood);
        assert_eq!(run.log_likelihood_of(20, all), -6.0);
        assert_eq!(run.log_likelihood_of(31, all), 0.0);
        assert_eq!(run.log_likelihood_of(0, |s| s != Sensor::Dvl), 0.0);
    }
}
