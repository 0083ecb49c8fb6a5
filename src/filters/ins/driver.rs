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
//! Takes the contract's typed messages as time-sorted slices (what ingest and align hand
//! over), so it imports no I/O.

use super::error_state::{ErrorMatrix, ErrorState, N};
use super::forward::{measure, DvlMounting, Estimate, Filter, ImuNoise};
use super::mechanization::{ImuSample, NavState};
use super::record::EpochRecord;
use crate::align::latest_at;
use crate::contract::{Altimeter, Depth, Dvl, GnssFix, Imu, MagneticField, PositionFix, SpeedLog};
use crate::filters::kalman::{chi_square_quantile, KalmanError, UpdateRecord};
use crate::geodesy;
use nalgebra::{SMatrix, SVector, Vector3};

/// Measurement noise, validity and gating of the aiding sensors.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aiding {
    /// DVL velocity 1-sigma per axis, m/s.
    pub dvl_sigma_m_s: f64,
    /// DVL readings above this altitude are not used (out of range), m.
    pub dvl_max_altitude_m: f64,
    /// False: every DVL reading is used, even without bottom lock or out of range (only to
    /// show what trusting a bad DVL costs).
    pub dvl_check_range: bool,
    pub dvl_mounting: DvlMounting,
    /// When a DVL reading carries no altitude, the echo sounder's latest altitude within this
    /// age is used to check the range, s.
    pub altimeter_max_age_s: f64,
    /// Depth 1-sigma, m.
    pub depth_sigma_m: f64,
    /// Depth readings closer than this to the last one used are skipped (a 100 Hz depth
    /// sensor adds nothing over 10 Hz but epochs), s.
    pub depth_min_interval_s: f64,
    /// EM-log speed 1-sigma, m/s (`None`: the EM log is not used).
    pub eml_sigma_m_s: Option<f64>,
    /// Magnetic heading updates (`None`: the magnetometer is not used).
    pub mag: Option<MagAiding>,
    /// Probability of the chi-square gate (a consistent measurement passes it with this
    /// probability); `None` disables gating.
    pub gate_probability: Option<f64>,
    /// After this many rejections in a row of one sensor, its next measurement is applied
    /// ungated (a filter that has drifted must not lock its aiding out); 0: never.
    pub gate_reset_after: usize,
}

/// The magnetometer as a heading sensor.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MagAiding {
    /// Declination at the site, rad, east positive.
    pub declination_rad: f64,
    /// 1-sigma of one heading update, rad (the heading error's sigma, spread over the
    /// updates within its correlation time).
    pub sigma_rad: f64,
    /// Readings closer than this to the last one used are skipped, s.
    pub min_interval_s: f64,
    /// The undisturbed field's magnitude (of the calibrated readings), T.
    pub reference_norm_t: f64,
    /// A reading whose magnitude differs from the reference by more than this fraction is a
    /// disturbed field and is not used.
    pub max_norm_deviation: f64,
}

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
#[derive(Debug, Clone, Copy)]
pub struct Inputs<'a> {
    pub imu: &'a [Imu],
    pub dvl: &'a [Dvl],
    /// Echo-sounder altitudes, to check the DVL's range when it reports none.
    pub altimeter: &'a [Altimeter],
    pub depth: &'a [Depth],
    pub eml: &'a [SpeedLog],
    /// Magnetometer readings, calibrated, saturated readings taken out.
    pub mag: &'a [MagneticField],
    pub gnss: &'a [GnssFix],
    /// Known positions in the mission frame (USBL fixes, surveyed marks).
    pub fixes: &'a [PositionFix],
    /// Mission origin (latitude, longitude, rad): the frame of `fixes`.
    pub origin_rad: (f64, f64),
    /// Times at which the solution is wanted (an epoch is recorded at the first IMU sample at
    /// or after each).
    pub output_stamps_ns: &'a [i64],
}

/// Which sensor a residual belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Sensor {
    Dvl = 0,
    Depth,
    Gnss,
    SpeedLog,
    PositionFix,
    Magnetometer,
}

impl Sensor {
    pub const ALL: [Sensor; 6] = [
        Sensor::Dvl,
        Sensor::Depth,
        Sensor::Gnss,
        Sensor::SpeedLog,
        Sensor::PositionFix,
        Sensor::Magnetometer,
    ];

    /// Name used in tables and summaries.
    pub fn name(self) -> &'static str {
        match self {
            Sensor::Dvl => "dvl",
            Sensor::Depth => "depth",
            Sensor::Gnss => "gnss",
            Sensor::SpeedLog => "eml",
            Sensor::PositionFix => "position_fix",
            Sensor::Magnetometer => "mag",
        }
    }

    /// Number of components of its innovation.
    pub fn dims(self) -> usize {
        match self {
            Sensor::Dvl => 3,
            Sensor::Depth | Sensor::SpeedLog | Sensor::Magnetometer => 1,
            Sensor::Gnss | Sensor::PositionFix => 2,
        }
    }
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
    pub dims: usize,
    pub nis: f64,
    pub accepted: bool,
}

impl Residual {
    fn from_record<const M: usize>(stamp_ns: i64, sensor: Sensor, rec: &UpdateRecord<M>) -> Self {
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
            dims: M,
            nis: rec.nis,
            accepted: rec.accepted,
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
#[derive(Debug, Clone, Default)]
pub struct ForwardRun {
    pub records: Vec<EpochRecord>,
    pub residuals: Vec<Residual>,
    /// DVL readings not used: no bottom lock, or above the maximum altitude (the DVL's own
    /// or the echo sounder's).
    pub dvl_out_of_range: usize,
    /// Depth readings skipped by the minimum interval.
    pub depth_skipped: usize,
    /// Times the gate was reopened for a sensor after `gate_reset_after` rejections in a row.
    pub gate_resets: usize,
    /// EM-log readings not used (forward speed below 0.1 m/s, where an EM log reads nothing useful).
    pub eml_too_slow: usize,
    /// Magnetometer readings skipped by the minimum interval.
    pub mag_skipped: usize,
    /// Magnetometer readings not used: the field's magnitude was disturbed.
    pub mag_disturbed: usize,
    pub imu_gaps: Vec<ImuGap>,
    /// Log-likelihood of the innovations, `-1/2 sum (NIS + ln det S + m ln 2 pi)`, with each
    /// NIS capped at the gate's bound (so that an outlier counts as a rejection, not as a
    /// verdict on the noise): the score of the noise settings when they are tuned.
    pub log_likelihood: f64,
}

/// Why the forward pass stopped.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[error("{} update at {stamp_ns} ns: {source}", sensor.name())]
pub struct ForwardError {
    pub stamp_ns: i64,
    pub sensor: Sensor,
    pub source: KalmanError,
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

/// Next index of each input.
#[derive(Debug, Clone, Copy)]
struct Cursor {
    dvl: usize,
    depth: usize,
    gnss: usize,
    eml: usize,
    fix: usize,
    mag: usize,
    out: usize,
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
    step_phi: ErrorMatrix,
    step_q: ErrorState,
    /// Bias-corrected body rate relative to NED at the current tick.
    omega_nb_body: Vector3<f64>,
    at: Cursor,
    run: ForwardRun,
    /// Rejections in a row, per sensor (indexed as `Sensor::ALL`).
    consecutive_rejections: [usize; Sensor::ALL.len()],
    origin_rn: f64,
    origin_re: f64,
}

/// Runs the forward filter from `initial` (the estimate at the first IMU sample).
pub fn run_forward(
    settings: &Settings,
    inputs: &Inputs<'_>,
    initial: Estimate,
) -> Result<ForwardRun, ForwardError> {
    let Some(first) = inputs.imu.first() else {
        return Ok(ForwardRun::default());
    };
    // Depth readings closer than the minimum interval to the last kept one are dropped here,
    // so that they do not make epochs.
    let min_ns = (settings.aiding.depth_min_interval_s * 1e9) as i64;
    let mut depth: Vec<Depth> = Vec::with_capacity(inputs.depth.len());
    for d in inputs.depth {
        if depth
            .last()
            .is_none_or(|last: &Depth| d.stamp_ns - last.stamp_ns >= min_ns)
        {
            depth.push(d.clone());
        }
    }
    let depth_skipped = inputs.depth.len() - depth.len();
    let (mag, mag_skipped, mag_disturbed) = usable_mag(inputs.mag, settings.aiding.mag);
    let inputs = &Inputs {
        depth: &depth,
        mag: &mag,
        ..*inputs
    };
    let t0 = first.stamp_ns;
    let aiding = &settings.aiding;
    let gate = |m: usize| aiding.gate_probability.map(|p| chi_square_quantile(m, p));
    let cap = |m: usize| gate(m).unwrap_or_else(|| chi_square_quantile(m, 0.999));
    let origin_lat = inputs.origin_rad.0;
    // Measurements at or before the first IMU sample predate the initial estimate.
    let at = Cursor {
        dvl: inputs.dvl.partition_point(|m| m.stamp_ns <= t0),
        depth: inputs.depth.partition_point(|m| m.stamp_ns <= t0),
        gnss: inputs.gnss.partition_point(|m| m.stamp_ns <= t0),
        eml: inputs.eml.partition_point(|m| m.stamp_ns <= t0),
        fix: inputs.fixes.partition_point(|m| m.stamp_ns <= t0),
        mag: inputs.mag.partition_point(|m| m.stamp_ns <= t0),
        out: inputs.output_stamps_ns.partition_point(|&s| s <= t0),
    };
    let mut pass = Pass {
        consecutive_rejections: [0; Sensor::ALL.len()],
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
        step_phi: ErrorMatrix::identity(),
        step_q: ErrorState::zeros(),
        omega_nb_body: Vector3::zeros(),
        at,
        run: ForwardRun::default(),
        origin_rn: geodesy::meridian_radius_m(origin_lat),
        origin_re: geodesy::prime_vertical_radius_m(origin_lat) * origin_lat.cos(),
    };
    pass.run.records.push(EpochRecord::new(
        t0,
        true,
        &ErrorMatrix::identity(),
        &ErrorState::zeros(),
        &initial,
        &initial,
    ));

    let usual_dt = usual_imu_interval_s(inputs.imu).unwrap_or(0.01);
    let gap_s = settings.propagation.imu_gap_s.max(3.0 * usual_dt);
    for pair in inputs.imu.windows(2) {
        let (a, b) = (&pair[0], &pair[1]);
        let dt = (b.stamp_ns - a.stamp_ns) as f64 * 1e-9;
        if dt <= 0.0 {
            continue; // ingest sorts and removes duplicates; nothing to integrate
        }
        let (sa, sb) = (imu_sample(a), imu_sample(b));
        if dt <= gap_s {
            pass.advance(&sa, &sb, dt, b.stamp_ns, false)?;
            continue;
        }
        pass.run.imu_gaps.push(ImuGap {
            from_ns: a.stamp_ns,
            to_ns: b.stamp_ns,
        });
        let steps = (dt / usual_dt).ceil().max(1.0) as i64;
        let span_ns = b.stamp_ns - a.stamp_ns;
        let mut prev = sa;
        for k in 1..=steps {
            let s = k as f64 / steps as f64;
            let t = a.stamp_ns + span_ns * k / steps;
            let next = ImuSample::lerp(&sa, &sb, s);
            pass.advance(&prev, &next, dt / steps as f64, t, true)?;
            prev = next;
        }
    }
    pass.run.depth_skipped = depth_skipped;
    pass.run.mag_skipped = mag_skipped;
    pass.run.mag_disturbed = mag_disturbed;
    Ok(pass.run)
}

/// The magnetometer readings the filter uses: none without [`MagAiding`]; otherwise those
/// with an undisturbed magnitude, at most one per `min_interval_s`. Also returns how many
/// were skipped by the interval and how many were disturbed.
fn usable_mag(
    mag: &[MagneticField],
    aiding: Option<MagAiding>,
) -> (Vec<MagneticField>, usize, usize) {
    let Some(a) = aiding else {
        return (Vec::new(), 0, 0);
    };
    let min_ns = (a.min_interval_s * 1e9) as i64;
    let (mut kept, mut skipped, mut disturbed) = (Vec::<MagneticField>::new(), 0, 0);
    for m in mag {
        if kept
            .last()
            .is_some_and(|last| m.stamp_ns - last.stamp_ns < min_ns)
        {
            skipped += 1;
            continue;
        }
        let norm = Vector3::from(m.magnetic_field).norm();
        if (norm / a.reference_norm_t - 1.0).abs() > a.max_norm_deviation {
            disturbed += 1;
            continue;
        }
        kept.push(m.clone());
    }
    (kept, skipped, disturbed)
}

impl Pass<'_> {
    /// One step of the nominal state to tick `t` (IMU `a` to `b` over `dt`), then the
    /// measurements and outputs due at `t`.
    fn advance(
        &mut self,
        a: &ImuSample,
        b: &ImuSample,
        dt: f64,
        t: i64,
        in_gap: bool,
    ) -> Result<(), ForwardError> {
        let filter = &self.settings.filter;
        self.est.nav = filter.propagate_nominal(&self.est, a, b, dt, None);
        let corrected = self.est.corrected(&ImuSample::mean(a, b));
        self.f_dt_sum += corrected.specific_force_body * dt;
        self.w_dt_sum += corrected.omega_ib_body * dt;
        self.cov_dt_s += dt;
        self.gap_since_cov |= in_gap;
        self.omega_nb_body = self.omega_nb(b);

        // Every covariance step is an epoch, so that each record holds one step (its Q is
        // then diagonal, and the record small).
        let epoch = self.due(t) || self.cov_dt_s >= self.settings.propagation.covariance_interval_s;
        if epoch {
            self.propagate_covariance();
            let prior = self.est;
            let output = self
                .inputs
                .output_stamps_ns
                .get(self.at.out)
                .is_some_and(|&s| s <= t);
            self.apply_measurements(t)?;
            self.run.records.push(EpochRecord::new(
                t,
                output,
                &self.step_phi,
                &self.step_q,
                &prior,
                &self.est,
            ));
            self.cov_nav = self.est.nav;
        }
        Ok(())
    }

    /// The corrected body rate relative to NED, `omega_ib (corrected) - C^T (omega_ie +
    /// omega_en)`.
    fn omega_nb(&self, imu: &ImuSample) -> Vector3<f64> {
        let nav = &self.est.nav;
        let w_in = geodesy::earth_rate_ned(nav.lat_rad)
            + geodesy::transport_rate_ned(nav.lat_rad, nav.height_m, &nav.vel_ned_m_s);
        self.est.corrected(imu).omega_ib_body - nav.ned_from_body.inverse() * w_in
    }

    /// Whether any measurement or output is due at or before `t`.
    fn due(&self, t: i64) -> bool {
        let (i, at) = (self.inputs, &self.at);
        let next = |stamp: Option<i64>| stamp.is_some_and(|s| s <= t);
        next(i.dvl.get(at.dvl).map(|m| m.stamp_ns))
            || next(i.depth.get(at.depth).map(|m| m.stamp_ns))
            || next(i.gnss.get(at.gnss).map(|m| m.stamp_ns))
            || next(i.eml.get(at.eml).map(|m| m.stamp_ns))
            || next(i.fixes.get(at.fix).map(|m| m.stamp_ns))
            || next(i.mag.get(at.mag).map(|m| m.stamp_ns))
            || next(i.output_stamps_ns.get(at.out).copied())
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
        let (cov, phi, q) = filter.propagate_covariance_with(
            &self.est.cov,
            &self.cov_nav,
            &self.est.nav,
            &mean,
            self.cov_dt_s,
            &noise,
        );
        self.est.cov = cov;
        self.step_phi = phi;
        self.step_q = q;
        self.cov_nav = self.est.nav;
        self.f_dt_sum = Vector3::zeros();
        self.w_dt_sum = Vector3::zeros();
        self.cov_dt_s = 0.0;
        self.gap_since_cov = false;
    }

    /// Applies an update and records its residual.
    fn apply<const M: usize>(
        &mut self,
        stamp_ns: i64,
        sensor: Sensor,
        y: &SVector<f64, M>,
        h: &SMatrix<f64, M, N>,
        r: &SMatrix<f64, M, M>,
    ) -> Result<(), ForwardError> {
        // A sensor rejected this many times in a row is more likely right than the filter
        // (which has drifted away from it): reopen its gate for one measurement.
        let slot = sensor as usize;
        let reset_after = self.settings.aiding.gate_reset_after;
        let reopen = reset_after > 0 && self.consecutive_rejections[slot] >= reset_after;
        let gate = if reopen { None } else { self.gate[M] };
        if reopen {
            self.run.gate_resets += 1;
        }
        let (next, rec) = self
            .settings
            .filter
            .update(&self.est, y, h, r, gate)
            .map_err(|source| ForwardError {
                stamp_ns,
                sensor,
                source,
            })?;
        self.consecutive_rejections[slot] = if rec.accepted {
            0
        } else {
            self.consecutive_rejections[slot] + 1
        };
        self.run.log_likelihood -= 0.5
            * (rec.nis.min(self.nis_cap[M])
                + rec.log_det_innovation_cov
                + M as f64 * (2.0 * std::f64::consts::PI).ln());
        self.run
            .residuals
            .push(Residual::from_record(stamp_ns, sensor, &rec));
        self.est = next;
        Ok(())
    }

    fn apply_measurements(&mut self, t: i64) -> Result<(), ForwardError> {
        let (inputs, aiding) = (self.inputs, self.settings.aiding);
        while let Some(d) = inputs.dvl.get(self.at.dvl).filter(|m| m.stamp_ns <= t) {
            self.at.dvl += 1;
            let max_age_ns = (aiding.altimeter_max_age_s * 1e9) as i64;
            let altitude = d.altitude.or_else(|| {
                latest_at(inputs.altimeter, d.stamp_ns)
                    .filter(|(_, age)| *age <= max_age_ns)
                    .map(|(a, _)| a.altitude)
            });
            let in_range = !aiding.dvl_check_range
                || (d.valid && altitude.is_none_or(|h| h <= aiding.dvl_max_altitude_m));
            if !in_range {
                self.run.dvl_out_of_range += 1;
                continue;
            }
            let (y, h) = measure::dvl_velocity(
                &self.est,
                &Vector3::from(d.velocity),
                &aiding.dvl_mounting,
                &self.omega_nb_body,
            );
            let r = SMatrix::<f64, 3, 3>::identity() * aiding.dvl_sigma_m_s.powi(2);
            self.apply(d.stamp_ns, Sensor::Dvl, &y, &h, &r)?;
        }
        while let Some(d) = inputs.depth.get(self.at.depth).filter(|m| m.stamp_ns <= t) {
            self.at.depth += 1;
            let (y, h) = measure::depth(&self.est, d.depth);
            let r = SMatrix::<f64, 1, 1>::new(aiding.depth_sigma_m.powi(2));
            self.apply(d.stamp_ns, Sensor::Depth, &y, &h, &r)?;
        }
        while let Some(g) = inputs.gnss.get(self.at.gnss).filter(|m| m.stamp_ns <= t) {
            self.at.gnss += 1;
            let (y, h) = measure::horizontal_position(
                &self.est,
                g.latitude_deg.to_radians(),
                g.longitude_deg.to_radians(),
            );
            let r = SMatrix::<f64, 2, 2>::identity() * g.horizontal_sigma_m.powi(2);
            self.apply(g.stamp_ns, Sensor::Gnss, &y, &h, &r)?;
        }
        while let Some(f) = inputs.fixes.get(self.at.fix).filter(|m| m.stamp_ns <= t) {
            self.at.fix += 1;
            // The mission frame's north/east back to latitude/longitude (the inverse of
            // `geodesy::local_north_east_m`).
            let (lat0, lon0) = inputs.origin_rad;
            let (lat, lon) = (
                lat0 + f.north_m / self.origin_rn,
                lon0 + f.east_m / self.origin_re,
            );
            let (y, h) = measure::horizontal_position(&self.est, lat, lon);
            let r = SMatrix::<f64, 2, 2>::identity() * f.sigma_m.powi(2);
            self.apply(f.stamp_ns, Sensor::PositionFix, &y, &h, &r)?;
        }
        while let Some(e) = inputs.eml.get(self.at.eml).filter(|m| m.stamp_ns <= t) {
            self.at.eml += 1;
            let Some(sigma) = aiding.eml_sigma_m_s else {
                continue;
            };
            match measure::speed(&self.est, e.speed) {
                Some((y, h, attitude_variance)) => {
                    let r = SMatrix::<f64, 1, 1>::new(sigma * sigma + attitude_variance);
                    self.apply(e.stamp_ns, Sensor::SpeedLog, &y, &h, &r)?;
                }
                None => self.run.eml_too_slow += 1,
            }
        }
        while let Some(m) = inputs.mag.get(self.at.mag).filter(|m| m.stamp_ns <= t) {
            self.at.mag += 1;
            let Some(a) = aiding.mag else {
                continue;
            };
            if let Some((y, h)) = measure::magnetic_heading(
                &self.est,
                &Vector3::from(m.magnetic_field),
                a.declination_rad,
            ) {
                let r = SMatrix::<f64, 1, 1>::new(a.sigma_rad * a.sigma_rad);
                self.apply(m.stamp_ns, Sensor::Magnetometer, &y, &h, &r)?;
            }
        }
        while self
            .inputs
            .output_stamps_ns
            .get(self.at.out)
            .is_some_and(|&s| s <= t)
        {
            self.at.out += 1;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The magnetometer readings the filter takes: one per interval, none whose magnitude is
    /// off the reference by more than the allowed fraction (a disturbed field), none at all
    /// without the aid.
    #[test]
    fn disturbed_and_too_frequent_mag_readings_are_skipped() {
        let mag: Vec<MagneticField> = (0..20)
            .map(|k| MagneticField {
                stamp_ns: k * 500_000_000,
                magnetic_field: if k == 4 {
                    [9e-5, 0.0, 0.0]
                } else {
                    [2e-5, 0.0, 4e-5]
                },
            })
            .collect();
        let aiding = MagAiding {
            declination_rad: 0.0,
            sigma_rad: 0.1,
            min_interval_s: 1.0,
            reference_norm_t: 2e-5f64.hypot(4e-5),
            max_norm_deviation: 0.15,
        };
        let (kept, skipped, disturbed) = usable_mag(&mag, Some(aiding));
        assert_eq!((kept.len(), skipped, disturbed), (10, 9, 1));
        assert!(kept.iter().all(|m| m.stamp_ns != 2_000_000_000));
        assert_eq!(usable_mag(&mag, None).0.len(), 0);
    }
}
