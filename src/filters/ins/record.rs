//! What the forward pass keeps per filter epoch for the smoother, stored compactly: a
//! 5.5-hour mission at 10 Hz has about 200 000 epochs, and three full 26x26 matrices per
//! epoch would need 3 GB (these records take 4.6 kB each, and go to a temporary file).
//!
//! - Covariances are symmetric: only the upper triangle is kept (351 of 676 numbers).
//! - The predicted covariance is not kept: one covariance step separates two epochs, so it
//!   is `Phi P Phi^T + Q` again, and `Q` is diagonal (26 numbers).
//! - The transition matrix's rows below the navigation errors are always `[0 I]` (biases,
//!   calibrations and current are constants or random walks, so the rows of `F` for them are
//!   zero and every power of `F` keeps them so): only the top nine rows are kept, and of
//!   them only the 16 columns that can be non-zero ([`TRANSITION_COLUMNS`]): 144 of 676 numbers.

use super::error_state::{
    self, idx, DvlCalibration, ErrorMatrix, ErrorState, TransitionRows, WaterState, DVL_STATES, N,
    NAV_ROWS, TRANSITION_COLUMNS, WATER_STATES,
};
use super::forward::Estimate;
use super::mechanization::NavState;
use crate::disk_backed::{Decoder, Encoder, Fixed};
use nalgebra::{Matrix3, Quaternion, UnitQuaternion, Vector3};

/// Number of numbers in the upper triangle of an N x N matrix.
const PACKED: usize = N * (N + 1) / 2;

/// A symmetric N x N matrix, upper triangle row by row.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PackedCov([f64; PACKED]);

impl PackedCov {
    pub fn pack(m: &ErrorMatrix) -> Self {
        let mut out = [0.0; PACKED];
        let mut k = 0;
        for i in 0..N {
            for j in i..N {
                out[k] = 0.5 * (m[(i, j)] + m[(j, i)]);
                k += 1;
            }
        }
        PackedCov(out)
    }

    pub fn unpack(&self) -> ErrorMatrix {
        let mut m = ErrorMatrix::zeros();
        self.unpack_into(&mut m);
        m
    }

    /// [`PackedCov::unpack`] into `m` (every element is written).
    pub fn unpack_into(&self, m: &mut ErrorMatrix) {
        let mut k = 0;
        for i in 0..N {
            for j in i..N {
                m[(i, j)] = self.0[k];
                m[(j, i)] = self.0[k];
                k += 1;
            }
        }
    }

    fn index(i: usize, j: usize) -> usize {
        let (i, j) = if i <= j { (i, j) } else { (j, i) };
        i * N - i * (i + 1) / 2 + j
    }

    /// One element.
    pub fn get(&self, i: usize, j: usize) -> f64 {
        self.0[Self::index(i, j)]
    }

    /// One-sigma of every error-state element.
    pub fn sigma(&self) -> ErrorState {
        ErrorState::from_fn(|i, _| self.get(i, i).max(0.0).sqrt())
    }

    /// The 3x3 block starting at `at` on the diagonal.
    pub fn block3(&self, at: usize) -> Matrix3<f64> {
        Matrix3::from_fn(|i, j| self.get(at + i, at + j))
    }
}

/// A transition matrix whose bias rows are `[0 I]` but for a Gauss-Markov DVL bias's decay,
/// stored as its top nine rows and that decay.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PackedTransition {
    top: TransitionRows,
    /// The DVL bias's diagonal entry (1: a random walk or a constant).
    dvl_bias_decay: f64,
}

impl PackedTransition {
    /// Packs `phi`; its bias rows must be `[0 I]` but for the DVL bias's equal diagonal
    /// entries (true of every transition of the model).
    pub fn pack(phi: &ErrorMatrix) -> Self {
        let dvl_bias_decay = phi[(idx::DVL_BIAS, idx::DVL_BIAS)];
        debug_assert!(
            (phi.fixed_view::<{ N - NAV_ROWS }, N>(NAV_ROWS, 0)
                - Self::bottom_rows(dvl_bias_decay).fixed_view::<{ N - NAV_ROWS }, N>(NAV_ROWS, 0))
            .amax()
                == 0.0,
            "transition's bias rows are not [0 D]"
        );
        Self::from_top_rows(
            phi.fixed_view::<NAV_ROWS, N>(0, 0).into_owned(),
            dvl_bias_decay,
        )
    }

    /// The transition with these top rows and the DVL bias's `decay` (1: none) on the
    /// diagonal of its bias rows, which are `[0 I]` otherwise.
    pub fn from_top_rows(top: TransitionRows, dvl_bias_decay: f64) -> Self {
        debug_assert!(
            (idx::DVL..idx::GYRO_SCALE_Z)
                .chain([idx::SOUND_SPEED_SCALE])
                .all(|c| top.column(c).amax() == 0.0),
            "transition's top rows involve the DVL, water or speed of sound states"
        );
        PackedTransition {
            top,
            dvl_bias_decay,
        }
    }

    /// The identity with `decay` on the DVL bias's diagonal.
    fn bottom_rows(decay: f64) -> ErrorMatrix {
        let mut m = ErrorMatrix::identity();
        for k in 0..3 {
            m[(idx::DVL_BIAS + k, idx::DVL_BIAS + k)] = decay;
        }
        m
    }

    pub fn identity() -> Self {
        Self::pack(&ErrorMatrix::identity())
    }

    pub fn unpack(&self) -> ErrorMatrix {
        let mut m = Self::bottom_rows(self.dvl_bias_decay);
        m.fixed_view_mut::<NAV_ROWS, N>(0, 0).copy_from(&self.top);
        m
    }

    /// The DVL bias's decay over the transition (1: none).
    pub fn dvl_bias_decay(&self) -> f64 {
        self.dvl_bias_decay
    }

    /// `Phi P` (`P` symmetric): the top rows `[T M] P` (`M` has no DVL column, so the decay
    /// does not enter them), the bias rows `P`'s with the DVL bias's scaled by the decay.
    pub fn times(&self, p: &ErrorMatrix) -> ErrorMatrix {
        let mut out = error_state::transition_times(&self.top, p);
        if self.dvl_bias_decay != 1.0 {
            error_state::decay_dvl_bias_rows(&mut out, self.dvl_bias_decay);
        }
        out
    }

    /// `Phi P Phi^T + diag(q)`.
    pub fn predicted_cov(&self, p: &ErrorMatrix, q: &ErrorState) -> ErrorMatrix {
        let mut dpd = *p;
        error_state::decay_dvl_bias(&mut dpd, self.dvl_bias_decay);
        error_state::predicted_cov(&self.top, &dpd, q)
    }

    /// [`PackedTransition::predicted_cov`] and the transpose of [`PackedTransition::times`]
    /// (`P Phi^T`, `P` symmetric) together, into `prior` and `p_phi_t` (sharing their work
    /// when there is no decay).
    pub fn predicted_cov_and_p_phi_t_into(
        &self,
        p: &ErrorMatrix,
        q: &ErrorState,
        prior: &mut ErrorMatrix,
        p_phi_t: &mut ErrorMatrix,
    ) {
        if self.dvl_bias_decay == 1.0 {
            error_state::predicted_cov_and_p_phi_t_into(&self.top, p, q, prior, p_phi_t);
        } else {
            *prior = self.predicted_cov(p, q);
            p_phi_t.tr_copy_from(&self.times(p));
        }
    }
}

/// The navigation state and bias estimates without their covariance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NavPoint {
    pub nav: NavState,
    pub gyro_bias: Vector3<f64>,
    pub accel_bias: Vector3<f64>,
    pub dvl: DvlCalibration,
    pub water: WaterState,
    pub gyro_scale_z: f64,
    pub sound_speed_scale: f64,
}

/// What the forward pass keeps at one epoch (an IMU tick with a measurement or an output
/// time).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EpochRecord {
    pub stamp_ns: i64,
    /// An output time fell on this epoch (else only measurements did).
    pub output: bool,
    /// Transition from the previous epoch to this one (identity at the first epoch).
    pub phi_from_previous: PackedTransition,
    /// Diagonal of the process noise added from the previous epoch (one covariance step per
    /// epoch): the predicted covariance is `Phi P Phi^T + diag(q)` ([`EpochRecord::prior_cov`]).
    pub process_noise: ErrorState,
    /// Correction the updates at this epoch applied, prior to posterior (position, velocity,
    /// attitude as in the error state, then the two bias changes).
    pub correction: ErrorState,
    /// Estimate after this epoch's updates.
    pub posterior: NavPoint,
    pub posterior_cov: PackedCov,
    /// How this epoch's resets turned the velocity's error with the heading's (the sum of
    /// their `heading_reset::heading_turn`s; zero where the reset was the identity).
    pub heading_turn: Vector3<f64>,
}

impl EpochRecord {
    /// The record of an epoch whose prior estimate was `prior` (its covariance is not
    /// needed) and whose updates gave `posterior`.
    pub fn new(
        stamp_ns: i64,
        output: bool,
        phi_from_previous: &PackedTransition,
        process_noise: &ErrorState,
        prior: &NavPoint,
        posterior: &Estimate,
        heading_turn: &Vector3<f64>,
    ) -> Self {
        let posterior_point = NavPoint::from(posterior);
        EpochRecord {
            stamp_ns,
            output,
            phi_from_previous: *phi_from_previous,
            process_noise: *process_noise,
            correction: correction_between(prior, &posterior_point),
            posterior: posterior_point,
            posterior_cov: PackedCov::pack(&posterior.cov),
            heading_turn: *heading_turn,
        }
    }

    /// The covariance predicted to this epoch from the previous epoch's posterior covariance
    /// (what the forward pass had before this epoch's updates).
    pub fn prior_cov(&self, previous_posterior: &ErrorMatrix) -> ErrorMatrix {
        self.phi_from_previous
            .predicted_cov(previous_posterior, &self.process_noise)
    }
}

impl From<&Estimate> for NavPoint {
    fn from(e: &Estimate) -> Self {
        NavPoint {
            nav: e.nav,
            gyro_bias: e.gyro_bias,
            accel_bias: e.accel_bias,
            dvl: e.dvl,
            water: e.water,
            gyro_scale_z: e.gyro_scale_z,
            sound_speed_scale: e.sound_speed_scale,
        }
    }
}

/// A solution at one epoch as the outputs need it: the state, the one-sigma of every
/// error-state element and the full position covariance (for the NEES), without the rest of
/// the covariance (a 5.5-hour mission has 200 000 of these, twice).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Solution {
    pub stamp_ns: i64,
    pub point: NavPoint,
    pub sigma: ErrorState,
    /// Covariance of the north/east/down position error, m^2.
    pub position_cov: Matrix3<f64>,
    /// Covariance of the attitude error (small rotation of the NED frame), rad^2.
    pub attitude_cov: Matrix3<f64>,
}

/// The Jacobian of the Z-Y-X Euler angles (roll, pitch, yaw) by a small rotation of the NED
/// frame (`ned_from_body` turned to `R(d) ned_from_body`), at `pitch` and `yaw` (rad): the
/// inverse of the map from Euler rates to the angular rate in NED,
/// `[[cy cp, -sy, 0], [sy cp, cy, 0], [-sp, 0, 1]]`. The cosine of the pitch is kept off zero
/// (at +-90 deg roll and yaw are one angle).
pub fn euler_from_ned_rotation(pitch: f64, yaw: f64) -> Matrix3<f64> {
    let (sy, cy) = yaw.sin_cos();
    let (sp, cp) = pitch.sin_cos();
    let cp = if cp.abs() < 1e-9 { 1e-9 } else { cp };
    let tp = sp / cp;
    Matrix3::new(cy / cp, sy / cp, 0.0, -sy, cy, 0.0, cy * tp, sy * tp, 1.0)
}

impl Solution {
    pub fn new(stamp_ns: i64, point: NavPoint, cov: &PackedCov) -> Self {
        Solution {
            stamp_ns,
            point,
            sigma: cov.sigma(),
            position_cov: cov.block3(idx::POS),
            attitude_cov: cov.block3(idx::ATT),
        }
    }

    /// [`Solution::new`] from the whole covariance, symmetric (no packing on the way).
    pub fn from_cov(stamp_ns: i64, point: NavPoint, cov: &ErrorMatrix) -> Self {
        Solution {
            stamp_ns,
            point,
            sigma: cov.diagonal().map(|v| v.max(0.0).sqrt()),
            position_cov: cov.fixed_view::<3, 3>(idx::POS, idx::POS).into_owned(),
            attitude_cov: cov.fixed_view::<3, 3>(idx::ATT, idx::ATT).into_owned(),
        }
    }

    /// Roll, pitch and yaw, rad (Z-Y-X).
    pub fn euler_rad(&self) -> [f64; 3] {
        let (r, p, y) = self.point.nav.ned_from_body.euler_angles();
        [r, p, y]
    }

    /// One-sigma of roll, pitch and yaw, rad: the attitude-error covariance (a rotation of
    /// the NED frame) mapped through the Jacobian of the Euler angles
    /// ([`euler_from_ned_rotation`]).
    pub fn euler_sigma_rad(&self) -> [f64; 3] {
        let [_, pitch, yaw] = self.euler_rad();
        let jac = euler_from_ned_rotation(pitch, yaw);
        let cov = jac * self.attitude_cov * jac.transpose();
        [0, 1, 2].map(|i| cov[(i, i)].max(0.0).sqrt())
    }

    /// The forward solution of an epoch.
    pub fn forward(record: &EpochRecord) -> Self {
        Self::new(record.stamp_ns, record.posterior, &record.posterior_cov)
    }
}

/// The correction that takes `prior` to `posterior` (both at one epoch).
pub fn correction_between(prior: &NavPoint, posterior: &NavPoint) -> ErrorState {
    let mut d = ErrorState::zeros();
    d.fixed_rows_mut::<9>(0)
        .copy_from(&super::error_state::difference(&posterior.nav, &prior.nav));
    d.fixed_rows_mut::<3>(idx::GYRO_BIAS)
        .copy_from(&(posterior.gyro_bias - prior.gyro_bias));
    d.fixed_rows_mut::<3>(idx::ACCEL_BIAS)
        .copy_from(&(posterior.accel_bias - prior.accel_bias));
    d.fixed_rows_mut::<DVL_STATES>(idx::DVL)
        .copy_from(&(posterior.dvl - prior.dvl));
    d.fixed_rows_mut::<WATER_STATES>(idx::WATER)
        .copy_from(&(posterior.water - prior.water));
    d[idx::GYRO_SCALE_Z] = posterior.gyro_scale_z - prior.gyro_scale_z;
    d[idx::SOUND_SPEED_SCALE] = posterior.sound_speed_scale - prior.sound_speed_scale;
    d
}

/// NavPoint as numbers: position, velocity, attitude quaternion (i, j, k, w), biases, DVL
/// calibration, water states, z gyro scale, speed of sound scale.
const NAV_POINT_NUMBERS: usize = 3 + 3 + 4 + 3 + 3 + DVL_STATES + WATER_STATES + 2;

impl NavPoint {
    fn encode(&self, out: &mut Encoder) {
        let n = &self.nav;
        out.f64s(&[n.lat_rad, n.lon_rad, n.height_m]);
        out.f64s(n.vel_ned_m_s.as_slice());
        out.f64s(n.ned_from_body.as_ref().coords.as_slice());
        out.f64s(self.gyro_bias.as_slice());
        out.f64s(self.accel_bias.as_slice());
        out.f64s(self.dvl.as_slice());
        out.f64s(self.water.as_slice());
        out.f64(self.gyro_scale_z);
        out.f64(self.sound_speed_scale);
    }

    fn decode(d: &mut Decoder<'_>) -> Self {
        let [lat_rad, lon_rad, height_m] = d.f64s();
        let vel_ned_m_s = Vector3::from(d.f64s::<3>());
        let [i, j, k, w] = d.f64s();
        NavPoint {
            nav: NavState {
                lat_rad,
                lon_rad,
                height_m,
                vel_ned_m_s,
                ned_from_body: UnitQuaternion::new_unchecked(Quaternion::new(w, i, j, k)),
            },
            gyro_bias: Vector3::from(d.f64s::<3>()),
            accel_bias: Vector3::from(d.f64s::<3>()),
            dvl: DvlCalibration::from(d.f64s::<DVL_STATES>()),
            water: WaterState::from(d.f64s::<WATER_STATES>()),
            gyro_scale_z: d.f64(),
            sound_speed_scale: d.f64(),
        }
    }
}

impl Fixed for EpochRecord {
    const BYTES: usize =
        8 * (3 + NAV_ROWS * TRANSITION_COLUMNS.len() + N + N + NAV_POINT_NUMBERS + PACKED + 3);

    fn encode(&self, out: &mut Encoder) {
        out.i64(self.stamp_ns);
        out.i64(i64::from(self.output));
        for c in TRANSITION_COLUMNS {
            out.f64s(self.phi_from_previous.top.column(c).as_slice());
        }
        out.f64(self.phi_from_previous.dvl_bias_decay);
        out.f64s(self.process_noise.as_slice());
        out.f64s(self.correction.as_slice());
        self.posterior.encode(out);
        out.f64s(&self.posterior_cov.0);
        out.f64s(self.heading_turn.as_slice());
    }

    fn decode(d: &mut Decoder<'_>) -> Self {
        EpochRecord {
            stamp_ns: d.i64(),
            output: d.i64() != 0,
            phi_from_previous: {
                let mut top = TransitionRows::zeros();
                for c in TRANSITION_COLUMNS {
                    top.set_column(c, &d.f64s::<NAV_ROWS>().into());
                }
                PackedTransition {
                    top,
                    dvl_bias_decay: d.f64(),
                }
            },
            process_noise: ErrorState::from(d.f64s::<N>()),
            correction: ErrorState::from(d.f64s::<N>()),
            posterior: NavPoint::decode(d),
            posterior_cov: PackedCov(d.f64s()),
            heading_turn: Vector3::from(d.f64s::<3>()),
        }
    }
}

impl Fixed for Solution {
    const BYTES: usize = 8 * (1 + NAV_POINT_NUMBERS + N + 9 + 9);

    fn encode(&self, out: &mut Encoder) {
        out.i64(self.stamp_ns);
        self.point.encode(out);
        out.f64s(self.sigma.as_slice());
        out.f64s(self.position_cov.as_slice());
        out.f64s(self.attitude_cov.as_slice());
    }

    fn decode(d: &mut Decoder<'_>) -> Self {
        Solution {
            stamp_ns: d.i64(),
            point: NavPoint::decode(d),
            sigma: ErrorState::from(d.f64s::<N>()),
            position_cov: Matrix3::from_column_slice(&d.f64s::<9>()),
            attitude_cov: Matrix3::from_column_slice(&d.f64s::<9>()),
        }
    }
}

#[cfg(test)]
mod tests {
    /// The Euler Jacobian against central differences of the angles themselves, at attitudes
    /// that cover every quadrant of yaw and pitches up to 85 deg.
    #[test]
    fn euler_jacobian_matches_finite_differences() {
        for (roll, pitch, yaw) in [
            (0.1, 0.2, 0.3),
            (-2.5, -1.2, 2.9),
            (3.0, 1.48, -1.7),
            (0.0, 0.0, -3.1),
            (1.0, -0.7, 1.6),
        ] {
            let q = UnitQuaternion::from_euler_angles(roll, pitch, yaw);
            let jac = euler_from_ned_rotation(pitch, yaw);
            let eps = 1e-6;
            for k in 0..3 {
                let mut d = Vector3::zeros();
                d[k] = eps;
                let (r1, p1, y1) = (UnitQuaternion::from_scaled_axis(d) * q).euler_angles();
                let (r0, p0, y0) = (UnitQuaternion::from_scaled_axis(-d) * q).euler_angles();
                let numeric = Vector3::new(
                    crate::angle::wrap_pi(r1 - r0),
                    p1 - p0,
                    crate::angle::wrap_pi(y1 - y0),
                ) / (2.0 * eps);
                let analytic = jac.column(k);
                assert!(
                    (numeric - analytic).norm() < 1e-6 * (1.0 + analytic.norm()),
                    "({roll}, {pitch}, {yaw}) column {k}: {analytic:?} vs {numeric:?}"
                );
            }
        }
    }

    use super::*;

    #[test]
    fn packing_round_trips() {
        let a = ErrorMatrix::from_fn(|i, j| (i * 31 + j * 7) as f64 * 0.01 - 1.0);
        let sym = a * a.transpose();
        let packed = PackedCov::pack(&sym);
        assert_eq!(packed.unpack(), sym);
        assert_eq!(packed.get(3, 11), sym[(3, 11)]);
        assert_eq!(packed.get(11, 3), sym[(11, 3)]);
        assert_eq!(packed.block3(6), sym.fixed_view::<3, 3>(6, 6).into_owned());
        let mut phi = ErrorMatrix::identity();
        phi.fixed_view_mut::<NAV_ROWS, N>(0, 0)
            .copy_from(&a.fixed_view::<NAV_ROWS, N>(0, 0));
        phi.view_mut((0, idx::DVL), (NAV_ROWS, idx::GYRO_SCALE_Z - idx::DVL))
            .fill(0.0);
        phi.view_mut((0, idx::SOUND_SPEED_SCALE), (NAV_ROWS, 1))
            .fill(0.0);
        assert_eq!(PackedTransition::pack(&phi).unpack(), phi);
    }

    /// A transition with a Gauss-Markov DVL bias's decay: packing keeps it, and its products
    /// equal the dense ones (`Phi P`, `Phi P Phi^T + Q`, and both together).
    #[test]
    fn a_decaying_dvl_bias_is_kept_and_multiplied_exactly() {
        let a = ErrorMatrix::from_fn(|i, j| ((i * 13 + j * 5) as f64 * 0.29).cos() * 0.1);
        let mut phi = ErrorMatrix::identity();
        phi.fixed_view_mut::<NAV_ROWS, N>(0, 0)
            .copy_from(&(ErrorMatrix::identity() + a).fixed_view::<NAV_ROWS, N>(0, 0));
        phi.view_mut((0, idx::DVL), (NAV_ROWS, idx::GYRO_SCALE_Z - idx::DVL))
            .fill(0.0);
        phi.view_mut((0, idx::SOUND_SPEED_SCALE), (NAV_ROWS, 1))
            .fill(0.0);
        let decay = (-0.1f64 / 60.0).exp();
        for k in 0..3 {
            phi[(idx::DVL_BIAS + k, idx::DVL_BIAS + k)] = decay;
        }
        let packed = PackedTransition::pack(&phi);
        assert_eq!(packed.unpack(), phi);
        assert_eq!(packed.dvl_bias_decay(), decay);
        let b = ErrorMatrix::from_fn(|i, j| ((i * 7 + j * 11) as f64 * 0.41).sin());
        let p = b * b.transpose();
        let q = ErrorState::from_fn(|i, _| 1e-3 * i as f64);
        let dense_phi_p = phi * p;
        let dense_prior = phi * p * phi.transpose() + ErrorMatrix::from_diagonal(&q);
        let close = |x: &ErrorMatrix, y: &ErrorMatrix| (x - y).amax() < 1e-12 * y.amax();
        assert!(close(&packed.times(&p), &dense_phi_p));
        assert!(close(&packed.predicted_cov(&p, &q), &dense_prior));
        let (mut prior, mut p_phi_t) = (ErrorMatrix::zeros(), ErrorMatrix::zeros());
        packed.predicted_cov_and_p_phi_t_into(&p, &q, &mut prior, &mut p_phi_t);
        assert!(close(&prior, &dense_prior) && close(&p_phi_t, &dense_phi_p.transpose()));
        // And through a record's encoding.
        let bytes = encoded(&EpochRecord::new(
            7,
            false,
            &PackedTransition::pack(&phi),
            &q,
            &NavPoint::from(&est_with(p)),
            &est_with(p),
            &Vector3::zeros(),
        ));
        let rec = EpochRecord::decode(&mut Decoder::new(&bytes));
        assert_eq!(rec.phi_from_previous.dvl_bias_decay(), decay);
    }

    fn est_with(cov: ErrorMatrix) -> Estimate {
        Estimate {
            nav: NavState {
                lat_rad: 0.6,
                lon_rad: 0.1,
                height_m: -10.0,
                vel_ned_m_s: Vector3::new(1.0, 0.5, 0.0),
                ned_from_body: UnitQuaternion::identity(),
            },
            gyro_bias: Vector3::zeros(),
            accel_bias: Vector3::zeros(),
            dvl: DvlCalibration::zeros(),
            water: WaterState::zeros(),
            gyro_scale_z: 0.0,
            sound_speed_scale: 0.0,
            cov,
        }
    }

    fn encoded<T: Fixed>(r: &T) -> Vec<u8> {
        let mut out = Encoder::default();
        r.encode(&mut out);
        out.into_bytes()
    }

    #[test]
    fn records_and_solutions_encode_exactly() {
        let a = ErrorMatrix::from_fn(|i, j| ((i * 31 + j * 7) as f64 * 0.37).sin());
        let mut phi = ErrorMatrix::identity();
        phi.fixed_view_mut::<NAV_ROWS, N>(0, 0)
            .copy_from(&a.fixed_view::<NAV_ROWS, N>(0, 0));
        phi.view_mut((0, idx::DVL), (NAV_ROWS, idx::GYRO_SCALE_Z - idx::DVL))
            .fill(0.0);
        phi.view_mut((0, idx::SOUND_SPEED_SCALE), (NAV_ROWS, 1))
            .fill(0.0);
        let est = Estimate {
            nav: NavState {
                lat_rad: 0.61,
                lon_rad: 2.25,
                height_m: -31.5,
                vel_ned_m_s: Vector3::new(1.5, -0.2, 0.01),
                ned_from_body: UnitQuaternion::from_euler_angles(0.1, -0.2, 2.9),
            },
            gyro_bias: Vector3::new(1e-6, -2e-6, 3e-6),
            accel_bias: Vector3::new(-1e-4, 2e-4, 5e-5),
            dvl: DvlCalibration::from_fn(|i, _| i as f64 * 1e-3),
            water: WaterState::new(0.01, 0.2, -0.1),
            gyro_scale_z: 1e-4,
            sound_speed_scale: -3e-3,
            cov: a * a.transpose(),
        };
        let mut prior = est;
        prior.nav.lat_rad += 1e-7;
        let q = ErrorState::from_fn(|i, _| i as f64 * 1e-9);
        let prior = NavPoint::from(&prior);
        let rec = EpochRecord::new(
            1_700_000_000_123_456_789,
            true,
            &PackedTransition::pack(&phi),
            &q,
            &prior,
            &est,
            &Vector3::new(1e-3, -2e-3, 0.0),
        );
        let bytes = encoded(&rec);
        assert_eq!(bytes.len(), EpochRecord::BYTES);
        assert_eq!(EpochRecord::decode(&mut Decoder::new(&bytes)), rec);
        let sol = Solution::forward(&rec);
        let bytes = encoded(&sol);
        assert_eq!(bytes.len(), Solution::BYTES);
        assert_eq!(Solution::decode(&mut Decoder::new(&bytes)), sol);
    }

    /// The columns the records leave out are zero in the model's transitions, over one
    /// interval and over several.
    #[test]
    fn transitions_never_involve_the_dvl_or_water_states() {
        let nav = NavState {
            lat_rad: 0.61,
            lon_rad: 2.25,
            height_m: -31.5,
            vel_ned_m_s: Vector3::new(1.5, -0.2, 0.01),
            ned_from_body: UnitQuaternion::from_euler_angles(0.1, -0.2, 2.9),
        };
        let f = error_state::continuous_matrix(
            &nav,
            &Vector3::new(0.1, -0.3, -9.8),
            &Vector3::new(0.01, -0.02, 0.05),
        );
        let phi = error_state::transition(&f, 0.1);
        let phi3 = phi * phi * phi;
        for m in [phi, phi3] {
            for c in 0..N {
                let zero = m.column(c).rows(0, NAV_ROWS).amax() == 0.0;
                assert_eq!(zero, !TRANSITION_COLUMNS.contains(&c), "column {c}");
            }
        }
    }
}
