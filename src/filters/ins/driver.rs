//! The forward pass over a whole mission: IMU-rate prediction, the aiding measurements at
//! their times, and the epoch records the smoother needs (one per IMU tick that carries a
//! measurement or an output time, never one per IMU sample).
//!
//! Takes the contract's typed messages as time-sorted slices (what ingest and align hand
//! over), so it imports no I/O.

use super::error_state::ErrorMatrix;
use super::forward::{measure, EpochRecord, Estimate, Filter};
use super::mechanization::ImuSample;
use crate::contract::{Depth, Dvl, GnssFix, Imu, PositionFix, SpeedLog};
use crate::filters::kalman::{chi_square_quantile, KalmanError, UpdateRecord};
use crate::geodesy;
use nalgebra::{SMatrix, SVector, Vector3};

/// Measurement noise and gating of the aiding sensors.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aiding {
    /// DVL velocity 1-sigma per axis, m/s.
    pub dvl_sigma_m_s: f64,
    /// DVL readings above this altitude are not used (out of range), m.
    pub dvl_max_altitude_m: f64,
    /// Depth 1-sigma, m.
    pub depth_sigma_m: f64,
    /// EM-log speed 1-sigma, m/s (`None`: the EM log is not used).
    pub eml_sigma_m_s: Option<f64>,
    /// Probability of the chi-square gate (a consistent measurement passes it with this
    /// probability); `None` disables gating.
    pub gate_probability: Option<f64>,
}

/// Time-sorted inputs of one mission.
#[derive(Debug, Clone, Copy)]
pub struct Inputs<'a> {
    pub imu: &'a [Imu],
    pub dvl: &'a [Dvl],
    pub depth: &'a [Depth],
    pub eml: &'a [SpeedLog],
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
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sensor {
    Dvl,
    Depth,
    Gnss,
    SpeedLog,
    PositionFix,
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

/// What the forward pass produced.
#[derive(Debug, Clone, Default)]
pub struct ForwardRun {
    pub records: Vec<EpochRecord>,
    pub residuals: Vec<Residual>,
    /// DVL readings not used: no bottom lock, or above the maximum altitude.
    pub dvl_out_of_range: usize,
}

fn imu_sample(m: &Imu) -> ImuSample {
    ImuSample {
        omega_ib_body: m.angular_velocity.into(),
        specific_force_body: m.specific_force.into(),
    }
}

/// Runs the forward filter from `initial` (the estimate at the first IMU sample).
pub fn run_forward(
    filter: &Filter,
    aiding: &Aiding,
    inputs: &Inputs<'_>,
    initial: Estimate,
) -> Result<ForwardRun, KalmanError> {
    let gate = |m: usize| aiding.gate_probability.map(|p| chi_square_quantile(m, p));
    let mut run = ForwardRun::default();
    let Some(first) = inputs.imu.first() else {
        return Ok(run);
    };
    let mut est = initial;
    run.records.push(EpochRecord {
        stamp_ns: first.stamp_ns,
        phi_from_previous: ErrorMatrix::identity(),
        prior_cov: est.cov,
        correction: SVector::zeros(),
        posterior: est,
    });
    let mut phi_acc = ErrorMatrix::identity();
    // Measurements at or before the first IMU sample predate the initial estimate.
    let t0 = first.stamp_ns;
    let mut i_dvl = inputs.dvl.partition_point(|m| m.stamp_ns <= t0);
    let mut i_depth = inputs.depth.partition_point(|m| m.stamp_ns <= t0);
    let mut i_gnss = inputs.gnss.partition_point(|m| m.stamp_ns <= t0);
    let mut i_eml = inputs.eml.partition_point(|m| m.stamp_ns <= t0);
    let mut i_fix = inputs.fixes.partition_point(|m| m.stamp_ns <= t0);
    let (origin_lat, origin_lon) = inputs.origin_rad;
    let origin_rn = geodesy::meridian_radius_m(origin_lat);
    let origin_re = geodesy::prime_vertical_radius_m(origin_lat) * origin_lat.cos();
    let mut i_out = inputs.output_stamps_ns.partition_point(|&s| s <= t0);

    for pair in inputs.imu.windows(2) {
        let (a, b) = (&pair[0], &pair[1]);
        let t = b.stamp_ns;
        let dt = (t - a.stamp_ns) as f64 * 1e-9;
        let (predicted, phi) = filter.predict(&est, &imu_sample(a), &imu_sample(b), dt, None);
        est = predicted;
        phi_acc = phi * phi_acc;
        let prior = est;
        let mut epoch = false;

        while i_dvl < inputs.dvl.len() && inputs.dvl[i_dvl].stamp_ns <= t {
            let d = &inputs.dvl[i_dvl];
            i_dvl += 1;
            epoch = true;
            let in_range = d.valid && d.altitude.is_none_or(|h| h <= aiding.dvl_max_altitude_m);
            if !in_range {
                run.dvl_out_of_range += 1;
                continue;
            }
            let (y, h) = measure::body_velocity(&est, &Vector3::from(d.velocity));
            let r = SMatrix::<f64, 3, 3>::identity() * aiding.dvl_sigma_m_s.powi(2);
            let (next, rec) = filter.update(&est, &y, &h, &r, gate(3))?;
            run.residuals
                .push(Residual::from_record(d.stamp_ns, Sensor::Dvl, &rec));
            est = next;
        }
        while i_depth < inputs.depth.len() && inputs.depth[i_depth].stamp_ns <= t {
            let d = &inputs.depth[i_depth];
            i_depth += 1;
            epoch = true;
            let (y, h) = measure::depth(&est, d.depth);
            let r = SMatrix::<f64, 1, 1>::new(aiding.depth_sigma_m.powi(2));
            let (next, rec) = filter.update(&est, &y, &h, &r, gate(1))?;
            run.residuals
                .push(Residual::from_record(d.stamp_ns, Sensor::Depth, &rec));
            est = next;
        }
        while i_gnss < inputs.gnss.len() && inputs.gnss[i_gnss].stamp_ns <= t {
            let g = &inputs.gnss[i_gnss];
            i_gnss += 1;
            epoch = true;
            let (y, h) = measure::horizontal_position(
                &est,
                g.latitude_deg.to_radians(),
                g.longitude_deg.to_radians(),
            );
            let r = SMatrix::<f64, 2, 2>::identity() * g.horizontal_sigma_m.powi(2);
            let (next, rec) = filter.update(&est, &y, &h, &r, gate(2))?;
            run.residuals
                .push(Residual::from_record(g.stamp_ns, Sensor::Gnss, &rec));
            est = next;
        }
        while i_fix < inputs.fixes.len() && inputs.fixes[i_fix].stamp_ns <= t {
            let f = &inputs.fixes[i_fix];
            i_fix += 1;
            epoch = true;
            // The mission frame's north/east back to latitude/longitude (the inverse of
            // `geodesy::local_north_east_m`).
            let (lat, lon) = (
                origin_lat + f.north_m / origin_rn,
                origin_lon + f.east_m / origin_re,
            );
            let (y, h) = measure::horizontal_position(&est, lat, lon);
            let r = SMatrix::<f64, 2, 2>::identity() * f.sigma_m.powi(2);
            let (next, rec) = filter.update(&est, &y, &h, &r, gate(2))?;
            run.residuals
                .push(Residual::from_record(f.stamp_ns, Sensor::PositionFix, &rec));
            est = next;
        }
        while i_eml < inputs.eml.len() && inputs.eml[i_eml].stamp_ns <= t {
            let e = &inputs.eml[i_eml];
            i_eml += 1;
            let Some(sigma) = aiding.eml_sigma_m_s else {
                continue;
            };
            epoch = true;
            if let Some((y, h)) = measure::speed(&est, e.speed) {
                let r = SMatrix::<f64, 1, 1>::new(sigma * sigma);
                let (next, rec) = filter.update(&est, &y, &h, &r, gate(1))?;
                run.residuals
                    .push(Residual::from_record(e.stamp_ns, Sensor::SpeedLog, &rec));
                est = next;
            }
        }
        while i_out < inputs.output_stamps_ns.len() && inputs.output_stamps_ns[i_out] <= t {
            i_out += 1;
            epoch = true;
        }
        if epoch {
            run.records.push(EpochRecord {
                stamp_ns: t,
                phi_from_previous: phi_acc,
                prior_cov: prior.cov,
                correction: EpochRecord::correction_between(&prior, &est),
                posterior: est,
            });
            phi_acc = ErrorMatrix::identity();
        }
    }
    Ok(run)
}
