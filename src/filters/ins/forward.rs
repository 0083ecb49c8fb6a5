//! Forward error-state filter: the mechanization at IMU rate, the error covariance carried
//! along with the 26-state model, and aiding updates that correct the state (with reset).
//!
//! Pure: `predict` and `update` take an [`Estimate`] and return a new one with what the step
//! did, so a smoother can replay the forward pass from its records.
//!
//! After each update the error estimate is injected into the navigation state and the bias
//! estimates, and the error mean is reset to zero. The reset's Jacobian is taken as the
//! identity (first order: the attitude correction is small), so the covariance carries over;
//! the driver then keeps the heading's unobservable direction where body-frame velocities
//! are read ([`super::heading_reset`]).

use super::error_state::{
    self, idx, DvlCalibration, ErrorMatrix, ErrorState, WaterState, DVL_STATES, N, WATER_STATES,
};
use super::mechanization::{propagate, HeightDamping, ImuSample, NavState};
use crate::filters::ins::record::PackedTransition;
use crate::filters::kalman::{self, KalmanError, UpdateRecord};
use crate::geodesy;
use nalgebra::{Matrix3, Rotation3, SMatrix, SVector, Vector3};

/// Noise densities of the IMU (continuous-time, one sigma).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImuNoise {
    /// Angle random walk, rad/s/sqrt(Hz).
    pub gyro_noise_density: f64,
    /// Velocity random walk, m/s^2/sqrt(Hz).
    pub accel_noise_density: f64,
    /// Gyro bias random walk, rad/s/sqrt(s).
    pub gyro_bias_walk: f64,
    /// Accelerometer bias random walk, m/s^2/sqrt(s).
    pub accel_bias_walk: f64,
}

/// The navigation estimate at one time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimate {
    pub nav: NavState,
    /// Estimated gyro bias, rad/s (subtracted from the gyro).
    pub gyro_bias: Vector3<f64>,
    /// Estimated accelerometer bias, m/s^2.
    pub accel_bias: Vector3<f64>,
    /// Estimated DVL calibration (zero: the nominal mounting, no scale or bias error).
    pub dvl: DvlCalibration,
    /// Estimated EM-log scale error and water current.
    pub water: WaterState,
    /// Estimated scale factor error of the z gyro: its bias-corrected rate is multiplied by
    /// `1 - gyro_scale_z`.
    pub gyro_scale_z: f64,
    /// Estimated scale correction of the speed of sound: the true speed is the acoustic
    /// ranges' own times `1 + sound_speed_scale`.
    pub sound_speed_scale: f64,
    /// Covariance of the error state.
    pub cov: ErrorMatrix,
}

/// Where the DVL sits and how it is turned relative to the body frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DvlMounting {
    /// Rotation from body axes to the DVL's axes (the DVL reports in its own axes).
    pub dvl_from_body: Rotation3<f64>,
    /// Position of the DVL relative to the reference point, body frame, m.
    pub lever_arm_body_m: Vector3<f64>,
}

impl DvlMounting {
    /// From a configuration's lever arm (body FRD, m) and the rotation of the DVL's axes
    /// from the body's (roll, pitch, yaw, Z-Y-X, deg).
    pub fn from_config(lever_arm_m: [f64; 3], rotation_deg: [f64; 3]) -> DvlMounting {
        let [r, p, y] = rotation_deg.map(f64::to_radians);
        DvlMounting {
            // The DVL's axes are the body's turned by (roll, pitch, yaw): body_from_dvl.
            dvl_from_body: Rotation3::from_euler_angles(r, p, y).inverse(),
            lever_arm_body_m: Vector3::from(lever_arm_m),
        }
    }
}

impl Default for DvlMounting {
    fn default() -> Self {
        DvlMounting {
            dvl_from_body: Rotation3::identity(),
            lever_arm_body_m: Vector3::zeros(),
        }
    }
}

/// The filter's models.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Filter {
    pub noise: ImuNoise,
    /// Vertical-channel damping on the depth, when aided by depth.
    pub height_damping: Option<HeightDamping>,
    /// Random walk of the water current, per horizontal axis, m/s/sqrt(s).
    pub current_walk: f64,
    /// Random walk of the DVL's bias, per axis, m/s/sqrt(s) (0: a constant).
    pub dvl_bias_walk: f64,
    /// Correlation time of the DVL's bias, s: with it the bias is a first-order Gauss-Markov
    /// process whose driving noise is `dvl_bias_walk` (its steady sigma `walk sqrt(tau / 2)`);
    /// without it, a random walk.
    pub dvl_bias_correlation_s: Option<f64>,
    /// Error states carried as consider states: in the covariance, never corrected.
    pub considered: [bool; N],
}

impl Estimate {
    /// The estimate with the correction `dx` injected (the covariance unchanged).
    pub fn corrected_by(&self, dx: &ErrorState) -> Estimate {
        let mut corrected = *self;
        corrected.correct(dx);
        corrected
    }

    /// [`Estimate::corrected_by`] in place.
    fn correct(&mut self, dx: &ErrorState) {
        self.nav = error_state::inject(&self.nav, dx);
        // dbg = true bias - estimate: the estimate moves by the correction.
        self.gyro_bias += dx.fixed_rows::<3>(idx::GYRO_BIAS);
        self.accel_bias += dx.fixed_rows::<3>(idx::ACCEL_BIAS);
        self.dvl += dx.fixed_rows::<DVL_STATES>(idx::DVL);
        self.water += dx.fixed_rows::<WATER_STATES>(idx::WATER);
        self.gyro_scale_z += dx[idx::GYRO_SCALE_Z];
        self.sound_speed_scale += dx[idx::SOUND_SPEED_SCALE];
    }

    /// The IMU sample with the bias and scale estimates removed: what the mechanization
    /// integrates.
    pub fn corrected(&self, imu: &ImuSample) -> ImuSample {
        let mut omega = imu.omega_ib_body - self.gyro_bias;
        omega.z *= 1.0 - self.gyro_scale_z;
        ImuSample {
            omega_ib_body: omega,
            specific_force_body: imu.specific_force_body - self.accel_bias,
        }
    }

    /// One-sigma of the error state.
    pub fn sigma(&self) -> ErrorState {
        self.cov.diagonal().map(|v| v.max(0.0).sqrt())
    }
}

impl Filter {
    /// Propagates over one IMU interval from raw sample `imu0` to `imu1`: the nominal state
    /// and the covariance together; returns the new estimate and the transition matrix used.
    /// `height_ref_m` (ellipsoidal height of a depth reading) damps the vertical channel.
    pub fn predict(
        &self,
        est: &Estimate,
        imu0: &ImuSample,
        imu1: &ImuSample,
        dt_s: f64,
        height_ref_m: Option<f64>,
    ) -> (Estimate, ErrorMatrix) {
        let nav = self.propagate_nominal(est, imu0, imu1, dt_s, height_ref_m);
        let mid = est.corrected(&ImuSample::mean(imu0, imu1));
        let (cov, phi, _) = self.propagate_covariance(&est.cov, &est.nav, &nav, &mid, dt_s);
        (Estimate { nav, cov, ..*est }, phi)
    }

    /// The nominal state over one IMU interval (the mechanization with the bias estimates
    /// removed from the IMU); the covariance is left for [`Filter::propagate_covariance`].
    pub fn propagate_nominal(
        &self,
        est: &Estimate,
        imu0: &ImuSample,
        imu1: &ImuSample,
        dt_s: f64,
        height_ref_m: Option<f64>,
    ) -> NavState {
        let damping = self.height_damping.zip(height_ref_m);
        propagate(
            &est.nav,
            &est.corrected(imu0),
            &est.corrected(imu1),
            dt_s,
            damping,
        )
    }

    /// The error covariance over an interval of `dt_s` in which the nominal state went from
    /// `nav_from` to `nav_to` under the mean corrected specific force and rate `imu_mean`:
    /// `F` averaged over the two ends (trapezoid), `Phi = exp(F dt)`, white process noise.
    /// The interval may span many IMU samples (the driver propagates the covariance at its
    /// epochs, at most `covariance_interval_s` apart); returns the covariance, `Phi` and the
    /// diagonal of the process noise `Q` (which is diagonal).
    pub fn propagate_covariance(
        &self,
        cov: &ErrorMatrix,
        nav_from: &NavState,
        nav_to: &NavState,
        imu_mean: &ImuSample,
        dt_s: f64,
    ) -> (ErrorMatrix, ErrorMatrix, ErrorState) {
        self.propagate_covariance_with(cov, nav_from, nav_to, imu_mean, dt_s, &self.noise)
    }

    /// [`Filter::propagate_covariance`] with other noise densities (an IMU gap adds the
    /// uncertainty of the motion nobody measured).
    pub fn propagate_covariance_with(
        &self,
        cov: &ErrorMatrix,
        nav_from: &NavState,
        nav_to: &NavState,
        imu_mean: &ImuSample,
        dt_s: f64,
        noise: &ImuNoise,
    ) -> (ErrorMatrix, ErrorMatrix, ErrorState) {
        let (mut cov, mut phi) = (*cov, PackedTransition::identity());
        let q = self.propagate_covariance_in_place(
            &mut cov, &mut phi, nav_from, nav_to, imu_mean, dt_s, noise,
        );
        (cov, phi.unpack(), q)
    }

    /// [`Filter::propagate_covariance_with`] in place: `cov` is propagated and `phi` set to
    /// the transition (the forward pass keeps both, and copies neither); returns the
    /// diagonal of `Q`. Only the transition's top rows are made (the others are `[0 D]`).
    #[allow(clippy::too_many_arguments)]
    pub fn propagate_covariance_in_place(
        &self,
        cov: &mut ErrorMatrix,
        phi: &mut PackedTransition,
        nav_from: &NavState,
        nav_to: &NavState,
        imu_mean: &ImuSample,
        dt_s: f64,
        noise: &ImuNoise,
    ) -> ErrorState {
        let (f_body, w_body) = (&imu_mean.specific_force_body, &imu_mean.omega_ib_body);
        let mut f = error_state::continuous_rows(nav_from, f_body, w_body);
        f += error_state::continuous_rows(nav_to, f_body, w_body);
        f *= 0.5;
        let top = error_state::transition_rows(&f, dt_s);
        let mut q = process_noise(noise, self.current_walk, self.dvl_bias_walk, dt_s);
        let decay = match self.dvl_bias_markov_step(dt_s) {
            Some((decay, variance)) => {
                error_state::decay_dvl_bias(cov, decay);
                for k in 0..3 {
                    q[idx::DVL_BIAS + k] = variance;
                }
                decay
            }
            None => 1.0,
        };
        error_state::predict_cov_in_place(&top, cov, &q);
        *phi = PackedTransition::from_top_rows(top, decay);
        q
    }

    /// A Gauss-Markov DVL bias's step over `dt_s`: the factor its mean decays by,
    /// `exp(-dt / tau)`, and the variance its driving noise adds, `walk^2 tau / 2 (1 -
    /// decay^2)` (which tends to a walk's `walk^2 dt` as tau grows). `None` for a random walk.
    fn dvl_bias_markov_step(&self, dt_s: f64) -> Option<(f64, f64)> {
        let tau = self
            .dvl_bias_correlation_s
            .filter(|t| *t > 0.0 && t.is_finite())?;
        let decay = (-dt_s / tau).exp();
        Some((
            decay,
            self.dvl_bias_walk.powi(2) * tau / 2.0 * (1.0 - decay * decay),
        ))
    }

    /// Applies a measurement with innovation `y` and matrix `h` (in the error state), then
    /// injects the correction and resets. A gated-out measurement leaves the estimate as is.
    pub fn update<const M: usize>(
        &self,
        est: &Estimate,
        y: &SVector<f64, M>,
        h: &SMatrix<f64, M, N>,
        r: &SMatrix<f64, M, M>,
        gate: Option<f64>,
    ) -> Result<(Estimate, UpdateRecord<M>), KalmanError> {
        let mut next = *est;
        let record = self.update_in_place(&mut next, y, h, r, gate)?;
        Ok((next, record))
    }

    /// [`Filter::update`] in place (the forward pass's estimate is kilobytes, copied per
    /// measurement otherwise). On an error the estimate is left as it was.
    pub fn update_in_place<const M: usize>(
        &self,
        est: &mut Estimate,
        y: &SVector<f64, M>,
        h: &SMatrix<f64, M, N>,
        r: &SMatrix<f64, M, M>,
        gate: Option<f64>,
    ) -> Result<UpdateRecord<M>, KalmanError> {
        let considered = self
            .considered
            .iter()
            .any(|&c| c)
            .then_some(&self.considered);
        // The error state's mean is zero before the update: only its covariance goes in.
        let (correction, record) =
            kalman::correct_considering(&mut est.cov, y, h, r, gate, considered)?;
        if let Some(dx) = correction {
            est.correct(&dx);
        }
        Ok(record)
    }
}

/// Discrete process noise over `dt_s` (white noise integrated over the step). The noise
/// enters along body axes, but `C C^T = I`, so in the NED frame it is isotropic: `Q` is
/// diagonal: this is its diagonal (all the filter and the smoother's records keep).
fn process_noise(n: &ImuNoise, current_walk: f64, dvl_bias_walk: f64, dt_s: f64) -> ErrorState {
    let mut q = ErrorState::zeros();
    let mut block = |at: usize, count: usize, density: f64| {
        q.rows_mut(at, count).fill(density.powi(2) * dt_s);
    };
    block(idx::VEL, 3, n.accel_noise_density);
    block(idx::ATT, 3, n.gyro_noise_density);
    block(idx::GYRO_BIAS, 3, n.gyro_bias_walk);
    block(idx::ACCEL_BIAS, 3, n.accel_bias_walk);
    block(idx::CURRENT, 2, current_walk);
    block(idx::DVL_BIAS, 3, dvl_bias_walk);
    q
}

/// Measurement models: innovation and error-state matrix for each aiding sensor.
pub mod measure {
    use super::*;

    /// `C^T`, the body-from-NED rotation of the estimate's attitude.
    fn body_from_ned(est: &Estimate) -> Matrix3<f64> {
        est.nav
            .ned_from_body
            .inverse()
            .to_rotation_matrix()
            .into_inner()
    }

    /// DVL velocity over ground, measured in the DVL's axes at the DVL's position:
    /// `z = A d + b` with `d = R (C^T v + omega_nb x l)` what the nominal mounting predicts
    /// (`R` the DVL-from-body rotation, `l` the lever arm in the body frame, `omega_nb` the
    /// bias-corrected body rate relative to NED), `A = (1 + s)(I - [m x])` the calibration's
    /// scale and misalignment `m = (0, pitch, heading)`, and `b` its bias. Then
    /// `H_v = A R C^T`, `H_psi = A R C^T [v x]`, and, as the true rate is the corrected rate
    /// minus the gyro bias correction, `H_bg = A R [l x]` (and `H_sgz = A R [l x] e_z
    /// omega_z`, the rate about z standing for the gyro's, which differs from it by the
    /// Earth and transport rates, 1e-4 rad/s, in a lever-arm term); for the calibration,
    /// `H_s = (I - [m x]) d`, `H_m = (1 + s) [d x]` (its y and z columns), `H_b = I`.
    pub fn dvl_velocity(
        est: &Estimate,
        v_measured: &Vector3<f64>,
        mounting: &DvlMounting,
        omega_nb_body: &Vector3<f64>,
    ) -> (SVector<f64, 3>, SMatrix<f64, 3, N>) {
        let c_t = body_from_ned(est);
        let r = mounting.dvl_from_body.matrix();
        let l = mounting.lever_arm_body_m;
        let v = est.nav.vel_ned_m_s;
        let cal = &est.dvl;
        let scale = 1.0 + cal[0];
        let m = Vector3::new(0.0, cal[1], cal[2]);
        let bias = Vector3::new(cal[3], cal[4], cal[5]);
        let turn = Matrix3::identity() - m.cross_matrix();
        let a = turn * scale;
        let d = r * (c_t * v + omega_nb_body.cross(&l));
        let y = v_measured - (a * d + bias);
        let mut h = SMatrix::<f64, 3, N>::zeros();
        h.fixed_view_mut::<3, 3>(0, idx::VEL)
            .copy_from(&(a * r * c_t));
        h.fixed_view_mut::<3, 3>(0, idx::ATT)
            .copy_from(&(a * r * c_t * v.cross_matrix()));
        let h_bg = a * r * l.cross_matrix();
        h.fixed_view_mut::<3, 3>(0, idx::GYRO_BIAS).copy_from(&h_bg);
        h.fixed_view_mut::<3, 1>(0, idx::GYRO_SCALE_Z)
            .copy_from(&(h_bg.column(2) * omega_nb_body.z));
        h.fixed_view_mut::<3, 1>(0, idx::DVL_SCALE)
            .copy_from(&(turn * d));
        h.fixed_view_mut::<3, 2>(0, idx::DVL_MISALIGNMENT)
            .copy_from(&(d.cross_matrix() * scale).fixed_view::<3, 2>(0, 1));
        h.fixed_view_mut::<3, 3>(0, idx::DVL_BIAS)
            .copy_from(&Matrix3::identity());
        (y, h)
    }

    /// DVL at the reference point with its axes along the body's (no lever arm, no
    /// rotation).
    pub fn body_velocity(
        est: &Estimate,
        v_body: &Vector3<f64>,
    ) -> (SVector<f64, 3>, SMatrix<f64, 3, N>) {
        dvl_velocity(est, v_body, &DvlMounting::default(), &Vector3::zeros())
    }

    /// Velocity over ground in the body axes from a source with no calibration states (a
    /// propeller's speed along x, with sway and heave taken as zero): `z = C^T v`, so
    /// `H_v = C^T`, `H_psi = C^T [v x]`.
    pub fn body_velocity_uncalibrated(
        est: &Estimate,
        v_body: &Vector3<f64>,
    ) -> (SVector<f64, 3>, SMatrix<f64, 3, N>) {
        let c_t = body_from_ned(est);
        let v = est.nav.vel_ned_m_s;
        let y = v_body - c_t * v;
        let mut h = SMatrix::<f64, 3, N>::zeros();
        h.fixed_view_mut::<3, 3>(0, idx::VEL).copy_from(&c_t);
        h.fixed_view_mut::<3, 3>(0, idx::ATT)
            .copy_from(&(c_t * v.cross_matrix()));
        (y, h)
    }

    /// Depth (positive down): `z = -h`, so `H_D = 1`.
    pub fn depth(est: &Estimate, depth_m: f64) -> (SVector<f64, 1>, SMatrix<f64, 1, N>) {
        let y = SVector::<f64, 1>::new(depth_m - (-est.nav.height_m));
        let mut h = SMatrix::<f64, 1, N>::zeros();
        h[(0, idx::POS + 2)] = 1.0;
        (y, h)
    }

    /// Speed through water from an EM log along the log's axis, the body's x axis, with its
    /// scale error `k` and the water current `c` (north, east): `z = (1 + k) u`, `u = e_x^T
    /// C^T (v - c)`, so `H_v = (1 + k) e_x^T C^T`, `H_k = u`, `H_c = -(1 + k) e_x^T C^T` (its
    /// north and east columns).
    /// Returns the innovation, the row, and the variance the attitude's uncertainty adds,
    /// `h_psi P_psi h_psi^T` with `h_psi = e_x^T C^T [v x]`: the attitude is considered, not
    /// corrected, by a speed. `None` below 0.1 m/s forward, where an EM log reads nothing
    /// useful. The contract's magnitude `|v|` equals `u` when the vehicle neither sideslips
    /// nor heaves (`|v| - u = (v^2 + w^2) / 2u`: 3 mm/s at 0.1 m/s of sway and 1.5 m/s).
    ///
    /// Why not the magnitude's own row, `v^T / |v|`: when no sensor holds the velocity across
    /// the track (the DVL out), its error there grows and the estimated velocity turns away
    /// from the true one. A row along the estimate turns with it, and successive readings,
    /// each informative along a slightly different direction, tell the filter the whole
    /// horizontal velocity, which a speed cannot (the inconsistency of an EKF linearised at
    /// drifting points). On a tactical IMU with 5-minute DVL outages the cross-track sigma
    /// fell to 9 mm/s while the error reached 1.2 m/s, and the DVL's return was read as a
    /// 29 deg heading error. The body's axis comes from the attitude, which drifts slowly: a
    /// straight run keeps one direction of information, and a turn rightly adds another.
    /// Why the attitude is only considered: with the velocity turned away from the body,
    /// `u` falls short of the speed, and an attitude row would turn the heading after the
    /// drifting velocity instead of turning the velocity back.
    pub fn speed(
        est: &Estimate,
        speed_m_s: f64,
    ) -> Option<(SVector<f64, 1>, SMatrix<f64, 1, N>, f64)> {
        let c_t = body_from_ned(est);
        let current = Vector3::new(est.water[1], est.water[2], 0.0);
        let through_water = est.nav.vel_ned_m_s - current;
        let forward = c_t.row(0);
        let u = (forward * through_water)[0];
        if u < 0.1 {
            return None;
        }
        let scale = 1.0 + est.water[0];
        let mut h = SMatrix::<f64, 1, N>::zeros();
        h.fixed_view_mut::<1, 3>(0, idx::VEL)
            .copy_from(&(forward * scale));
        h[(0, idx::EML_SCALE)] = u;
        h.fixed_view_mut::<1, 2>(0, idx::CURRENT)
            .copy_from(&(-forward.fixed_view::<1, 2>(0, 0) * scale));
        let h_att = forward * through_water.cross_matrix() * scale;
        let p_att = est.cov.fixed_view::<3, 3>(idx::ATT, idx::ATT);
        let attitude_variance = (h_att * p_att * h_att.transpose())[0];
        Some((
            SVector::<f64, 1>::new(speed_m_s - scale * u),
            h,
            attitude_variance,
        ))
    }

    /// Magnetic heading: the body field reading (calibrated) turned into NED by the attitude
    /// has the heading of the site's declination (rad). `y = declination - heading(C m)`, the
    /// row from [`crate::filters::heading::field_heading`] on the attitude block. `None` when
    /// the field has no horizontal part.
    pub fn magnetic_heading(
        est: &Estimate,
        field_body: &Vector3<f64>,
        declination_rad: f64,
    ) -> Option<(SVector<f64, 1>, SMatrix<f64, 1, N>)> {
        let (heading, row) =
            crate::filters::heading::field_heading(&(est.nav.ned_from_body * field_body))?;
        let y = SVector::<f64, 1>::new(crate::angle::wrap_pi(declination_rad - heading));
        let mut h = SMatrix::<f64, 1, N>::zeros();
        h.fixed_view_mut::<1, 3>(0, idx::ATT).copy_from(&row);
        Some((y, h))
    }

    /// Horizontal position (latitude, longitude in radians), e.g. a GNSS fix.
    pub fn horizontal_position(
        est: &Estimate,
        lat_rad: f64,
        lon_rad: f64,
    ) -> (SVector<f64, 2>, SMatrix<f64, 2, N>) {
        let (lat, h) = (est.nav.lat_rad, est.nav.height_m);
        let rho_n = geodesy::meridian_radius_m(lat) + h;
        let rho_e = geodesy::prime_vertical_radius_m(lat) + h;
        let y = SVector::<f64, 2>::new(
            (lat_rad - lat) * rho_n,
            (lon_rad - est.nav.lon_rad) * rho_e * lat.cos(),
        );
        let mut m = SMatrix::<f64, 2, N>::zeros();
        m[(0, idx::POS)] = 1.0;
        m[(1, idx::POS + 1)] = 1.0;
        (y, m)
    }

    /// The horizontal position of a point `lever_arm_body_m` from the reference point (an
    /// acoustic transponder): `z = p + C l`, so that `H_p = I` and `H_psi = -[(C l) x]`, their
    /// north and east rows.
    pub fn offset_horizontal_position(
        est: &Estimate,
        lat_rad: f64,
        lon_rad: f64,
        lever_arm_body_m: &Vector3<f64>,
    ) -> (SVector<f64, 2>, SMatrix<f64, 2, N>) {
        let (y, mut m) = horizontal_position(est, lat_rad, lon_rad);
        let arm_ned = est.nav.ned_from_body * lever_arm_body_m;
        let y = y - arm_ned.fixed_rows::<2>(0);
        m.fixed_view_mut::<2, 3>(0, idx::ATT)
            .copy_from(&(-arm_ned.cross_matrix()).fixed_rows::<2>(0));
        (y, m)
    }

    /// An acoustic range from a beacon at `beacon_lat_rad, beacon_lon_rad` and
    /// `beacon_depth_m` to the transponder `lever_arm_body_m` from the reference point, as
    /// the system converted it with a speed of sound the truth is `1 + k` times: `z = rho /
    /// (1 + k)` with `rho = |p + C l - b|`. With `u = (p + C l - b) / rho`: `H_p = u^T / (1 +
    /// k)`, `H_psi = -u^T [(C l) x] / (1 + k)`, `H_k = -rho / (1 + k)^2`. The line to the
    /// beacon is the straight one through the Earth ([`geodesy::ned_offset_m`]): the plane of
    /// the vehicle's radii would bend a kilometre's range by a decimetre.
    pub fn slant_range(
        est: &Estimate,
        beacon_lat_rad: f64,
        beacon_lon_rad: f64,
        beacon_depth_m: f64,
        lever_arm_body_m: &Vector3<f64>,
        range_m: f64,
    ) -> (SVector<f64, 1>, SMatrix<f64, 1, N>) {
        let nav = &est.nav;
        let to_beacon = geodesy::ned_offset_m(
            (nav.lat_rad, nav.lon_rad, nav.height_m),
            (beacon_lat_rad, beacon_lon_rad, -beacon_depth_m),
        );
        let arm_ned = nav.ned_from_body * lever_arm_body_m;
        let from_beacon = arm_ned - to_beacon;
        let rho = from_beacon.norm();
        let u = from_beacon / rho.max(1e-9);
        let scale = 1.0 + est.sound_speed_scale;
        let y = SVector::<f64, 1>::new(range_m - rho / scale);
        let mut m = SMatrix::<f64, 1, N>::zeros();
        m.fixed_view_mut::<1, 3>(0, idx::POS)
            .copy_from(&(u.transpose() / scale));
        m.fixed_view_mut::<1, 3>(0, idx::ATT)
            .copy_from(&(-u.transpose() * arm_ned.cross_matrix() / scale));
        m[(0, idx::SOUND_SPEED_SCALE)] = -rho / scale.powi(2);
        (y, m)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::UnitQuaternion;

    fn estimate() -> Estimate {
        Estimate {
            nav: NavState {
                lat_rad: 0.6,
                lon_rad: 0.1,
                height_m: -20.0,
                vel_ned_m_s: Vector3::new(1.2, 0.8, 0.1),
                ned_from_body: UnitQuaternion::from_euler_angles(0.02, -0.05, 0.7),
            },
            gyro_bias: Vector3::zeros(),
            accel_bias: Vector3::zeros(),
            dvl: DvlCalibration::from_column_slice(&[0.003, 0.01, -0.02, 0.01, -0.005, 0.002]),
            water: WaterState::new(0.01, 0.1, -0.05),
            gyro_scale_z: 2e-4,
            sound_speed_scale: -3e-3,
            cov: ErrorMatrix::identity() * 1e-4,
        }
    }

    /// Checks each column of `h` against the finite difference of `innovation` (y = z -
    /// predicted, so the predicted measurement moves by `y0 - y1`) under a correction `eps`
    /// of that error state.
    fn check_columns<const M: usize>(
        what: &str,
        h: &SMatrix<f64, M, N>,
        eps: f64,
        innovation: impl Fn(&ErrorState) -> SVector<f64, M>,
    ) {
        let y0 = innovation(&ErrorState::zeros());
        for i in 0..N {
            let mut dx = ErrorState::zeros();
            dx[i] = eps;
            let numeric = (y0 - innovation(&dx)) / eps;
            assert!(
                (numeric - h.column(i)).amax() < 1e-6,
                "{what} column {i}: {numeric} vs {}",
                h.column(i)
            );
        }
    }

    /// The measurement matrices are the Jacobians of the predicted measurement with respect
    /// to the error state, checked by injecting small corrections.
    #[test]
    fn measurement_jacobians_match_finite_differences() {
        let est = estimate();
        let v_body = Vector3::new(1.0, -0.3, 0.2);
        let (_, h) = measure::body_velocity(&est, &v_body);
        check_columns("DVL", &h, 1e-6, |dx| {
            measure::body_velocity(&est.corrected_by(dx), &v_body).0
        });
        let (_, h) = measure::body_velocity_uncalibrated(&est, &v_body);
        check_columns("uncalibrated body velocity", &h, 1e-6, |dx| {
            measure::body_velocity_uncalibrated(&est.corrected_by(dx), &v_body).0
        });
    }

    /// The mounted DVL's matrix, with the lever arm's rate term: a gyro-bias or scale
    /// correction changes the true body rate too.
    #[test]
    fn mounted_dvl_jacobian_matches_finite_differences() {
        let est = estimate();
        let v_body = Vector3::new(1.0, -0.3, 0.2);
        let mounting = DvlMounting {
            dvl_from_body: Rotation3::from_euler_angles(0.01, -0.02, 0.785),
            lever_arm_body_m: Vector3::new(0.8, -0.1, 0.3),
        };
        let w_nb = Vector3::new(0.02, -0.01, 0.05);
        let (_, h) = measure::dvl_velocity(&est, &v_body, &mounting, &w_nb);
        let eps = 1e-6;
        check_columns("mounted DVL", &h, eps, |dx| {
            // A gyro-bias or z-scale correction changes the true body rate too.
            let mut w_moved = w_nb;
            for axis in 0..3 {
                w_moved[axis] -= dx[idx::GYRO_BIAS + axis];
            }
            w_moved.z -= dx[idx::GYRO_SCALE_Z] * w_nb.z;
            measure::dvl_velocity(&est.corrected_by(dx), &v_body, &mounting, &w_moved).0
        });
    }

    /// The EM log's row: velocity columns as the finite differences; the attitude's, left out
    /// of the row, come back as the variance they add.
    #[test]
    fn em_log_jacobian_matches_finite_differences() {
        let est = estimate();
        let (s0, hs, attitude_variance) = measure::speed(&est, 1.5).unwrap();
        let mut h_att = SMatrix::<f64, 1, 3>::zeros();
        for i in 0..N {
            let mut dx = ErrorState::zeros();
            dx[i] = 1e-6;
            let moved = est.corrected_by(&dx);
            let (s1, _, _) = measure::speed(&moved, 1.5).unwrap();
            let numeric = (s0 - s1)[0] / 1e-6;
            if (idx::ATT..idx::ATT + 3).contains(&i) {
                h_att[i - idx::ATT] = numeric;
                assert_eq!(hs[(0, i)], 0.0);
            } else {
                assert!((numeric - hs[(0, i)]).abs() < 1e-6, "speed column {i}");
            }
        }
        let p_att = est.cov.fixed_view::<3, 3>(idx::ATT, idx::ATT);
        let expected = (h_att * p_att * h_att.transpose())[0];
        assert!(
            (attitude_variance - expected).abs() <= 1e-4 * expected.max(1e-12),
            "{attitude_variance} vs {expected}"
        );
        let slow = Estimate {
            nav: NavState {
                vel_ned_m_s: Vector3::new(0.05, 0.0, 0.0),
                ..est.nav
            },
            ..est
        };
        assert!(measure::speed(&slow, 0.0).is_none());
    }

    /// The magnetic heading's, the depth's and the horizontal position's matrices.
    #[test]
    fn heading_depth_and_position_jacobians_match_finite_differences() {
        let est = estimate();
        let field = Vector3::new(2.1e-5, 0.3e-5, 3.9e-5);
        let (_, hm) = measure::magnetic_heading(&est, &field, -0.13).unwrap();
        check_columns("magnetic heading", &hm, 1e-7, |dx| {
            measure::magnetic_heading(&est.corrected_by(dx), &field, -0.13)
                .unwrap()
                .0
        });
        let (d0, hd) = measure::depth(&est, 21.0);
        let mut dx = ErrorState::zeros();
        dx[idx::POS + 2] = 0.5;
        let (d1, _) = measure::depth(&est.corrected_by(&dx), 21.0);
        assert!(((d0 - d1)[0] / 0.5 - hd[(0, idx::POS + 2)]).abs() < 1e-9);
        let (p0, hp) = measure::horizontal_position(&est, 0.6 + 1e-6, 0.1 - 1e-6);
        for i in [idx::POS, idx::POS + 1] {
            let mut dx = ErrorState::zeros();
            dx[i] = 1.0;
            let (p1, _) =
                measure::horizontal_position(&est.corrected_by(&dx), 0.6 + 1e-6, 0.1 - 1e-6);
            assert!(((p0 - p1) - hp.column(i)).amax() < 1e-6);
        }
        let arm = Vector3::new(1.2, -0.4, -0.6);
        let offset =
            |est: &Estimate| measure::offset_horizontal_position(est, 0.6 + 1e-6, 0.1 - 1e-6, &arm);
        let (o0, ho) = offset(&est);
        // A position step of a metre (a micrometre's is lost in the latitude's rounding), an
        // attitude step of a microradian.
        for i in 0..N {
            let eps = if i < idx::ATT { 1.0 } else { 1e-6 };
            let mut dx = ErrorState::zeros();
            dx[i] = eps;
            let numeric = (o0 - offset(&est.corrected_by(&dx)).0) / eps;
            // (A metre of height changes the radii the 6 m between fix and estimate are
            // measured with by a millionth: left out of the row.)
            assert!(
                (numeric - ho.column(i)).amax() < 1e-5,
                "transponder column {i}: {numeric} vs {}",
                ho.column(i)
            );
        }
        assert!(ho.fixed_view::<2, 3>(0, idx::ATT).amax() > 0.1, "{ho}");
    }

    /// The LBL range's row: position, attitude through the lever arm, and the speed of
    /// sound's scale, by central differences (the range curves: 1/(2 rho) per metre).
    #[test]
    fn slant_range_jacobian_matches_finite_differences() {
        let est = estimate();
        let arm = Vector3::new(1.2, -0.4, -0.6);
        // A beacon 300 m south-west of the estimate and 60 m below it.
        let (lat_b, lon_b) = (0.6 - 300.0 / 6.36e6, 0.1 - 250.0 / 5.2e6);
        let range = |est: &Estimate| measure::slant_range(est, lat_b, lon_b, 80.0, &arm, 400.0);
        let (_, h) = range(&est);
        for i in 0..N {
            // A centimetre's step in position (a micrometre's is lost in the latitude's
            // rounding), a microradian's in attitude.
            let eps = if i < idx::ATT { 0.01 } else { 1e-6 };
            let mut dx = ErrorState::zeros();
            dx[i] = eps;
            let numeric =
                (range(&est.corrected_by(&-dx)).0 - range(&est.corrected_by(&dx)).0) / (2.0 * eps);
            // (A metre of height changes the radii the 300 m to the beacon are measured
            // with by 5e-5 m: left out of the row.)
            assert!(
                (numeric - h.column(i)).amax() < 1e-4,
                "slant range column {i}: {numeric} vs {}",
                h.column(i)
            );
        }
        assert!(h[(0, idx::SOUND_SPEED_SCALE)] < -300.0, "{h}");
        assert!(h.fixed_view::<1, 3>(0, idx::ATT).amax() > 0.1, "{h}");
    }

    #[test]
    fn update_moves_the_state_towards_the_measurement_and_shrinks_the_covariance() {
        let f = Filter {
            noise: ImuNoise {
                gyro_noise_density: 1e-5,
                accel_noise_density: 1e-4,
                gyro_bias_walk: 1e-7,
                accel_bias_walk: 1e-6,
            },
            height_damping: None,
            current_walk: 0.0,
            dvl_bias_walk: 0.0,
            dvl_bias_correlation_s: None,
            considered: [false; N],
        };
        let est = Estimate {
            cov: ErrorMatrix::identity() * 4.0,
            ..estimate()
        };
        let (y, h) = measure::depth(&est, 25.0);
        let r = SMatrix::<f64, 1, 1>::new(0.01);
        let (post, rec) = f.update(&est, &y, &h, &r, None).unwrap();
        assert!(rec.accepted);
        // Prior depth 20 m (variance 4), measured 25 m (variance 0.01): 20 + 5 * 4 / 4.01.
        assert!(
            (-post.nav.height_m - (20.0 + 5.0 * 4.0 / 4.01)).abs() < 1e-9,
            "{}",
            post.nav.height_m
        );
        assert!(post.cov[(idx::POS + 2, idx::POS + 2)] < 0.011);
        assert!(post.cov.cholesky().is_some());
    }

    /// A Gauss-Markov DVL bias: over many steps its variance tends to `walk^2 tau / 2` from
    /// any start, its correlation with another state decays as `exp(-t / tau)`, and the
    /// transition carries that decay; a random walk's variance grows as `walk^2 t`.
    #[test]
    fn a_gauss_markov_dvl_bias_settles_at_its_sigma_and_forgets_its_past() {
        let (walk, tau) = (0.0018, 60.0);
        let filter = |correlation| Filter {
            noise: ImuNoise {
                gyro_noise_density: 0.0,
                accel_noise_density: 0.0,
                gyro_bias_walk: 0.0,
                accel_bias_walk: 0.0,
            },
            height_damping: None,
            current_walk: 0.0,
            dvl_bias_walk: walk,
            dvl_bias_correlation_s: correlation,
            considered: [false; N],
        };
        let est = estimate();
        let b = idx::DVL_BIAS;
        let mut cov = ErrorMatrix::identity() * 1e-6;
        // The bias correlated with the current (a state with no dynamics).
        cov[(b, idx::CURRENT)] = 5e-7;
        cov[(idx::CURRENT, b)] = 5e-7;
        let imu = ImuSample {
            omega_ib_body: Vector3::zeros(),
            specific_force_body: Vector3::new(0.0, 0.0, -9.8),
        };
        let (dt, steps) = (0.5, 1200); // 600 s, ten correlation times
        let run = |f: &Filter| {
            let (mut c, mut phi) = (cov, PackedTransition::identity());
            for _ in 0..steps {
                f.propagate_covariance_in_place(
                    &mut c, &mut phi, &est.nav, &est.nav, &imu, dt, &f.noise,
                );
            }
            (c, phi)
        };
        let (gm, phi) = run(&filter(Some(tau)));
        let steady = walk * walk * tau / 2.0;
        let want = steady + (1e-6 - steady) * (-2.0 * 600.0 / tau).exp();
        assert!(
            (gm[(b, b)] / want - 1.0).abs() < 1e-9,
            "{} vs {want}",
            gm[(b, b)]
        );
        assert!((phi.dvl_bias_decay() - (-dt / tau).exp()).abs() < 1e-15);
        let cross_want = 5e-7 * (-600.0 / tau).exp();
        assert!(
            (gm[(b, idx::CURRENT)] / cross_want - 1.0).abs() < 1e-9,
            "{} vs {cross_want}",
            gm[(b, idx::CURRENT)]
        );
        assert_eq!(gm[(b, idx::CURRENT)], gm[(idx::CURRENT, b)]);
        let block = nalgebra::Matrix2::new(
            gm[(b, b)],
            gm[(b, idx::CURRENT)],
            gm[(idx::CURRENT, b)],
            gm[(idx::CURRENT, idx::CURRENT)],
        );
        assert!(block.cholesky().is_some());
        let (rw, phi) = run(&filter(None));
        assert!((rw[(b, b)] - (1e-6 + walk * walk * 600.0)).abs() < 1e-12);
        assert_eq!(phi.dvl_bias_decay(), 1.0);
    }
}
