//! The 26-state error model of the strapdown mechanization (seed 000 eq. 13-15) with the
//! DVL's calibration, the water's, the z gyro's scale factor and the speed of sound's.
//!
//! Error state `dx = [dp, dv, psi, dbg, dba, dvl, water, sgz, ssc]`:
//! - `dp`: position correction in metres along local north, east, down;
//! - `dv`: NED velocity correction, m/s;
//! - `psi`: attitude correction, a small rotation of the NED frame, rad;
//! - `dbg`, `dba`: gyro and accelerometer bias corrections, rad/s and m/s^2;
//! - `dvl`: the DVL's calibration corrections ([`DvlCalibration`]): scale factor error,
//!   mounting misalignment about the DVL's y and z axes (pitch, heading), rad, and bias in
//!   the DVL's axes, m/s. Constants: zero rows in `F`, no process noise;
//! - `water` ([`WaterState`]): the EM log's scale factor error, and the water current north
//!   and east, m/s (the EM log reads speed through the water, the DVL over the ground). The
//!   current is a random walk.
//! - `sgz`: the z (yaw) gyro's scale factor correction, a constant: true rate about body z
//!   = the mechanization's `(1 - sgz)`. Each turn leaves a heading error of the scale error
//!   times the angle turned; on a survey whose turns alternate left and right, the lanes
//!   alternate their heading errors and the cross-track errors add up lane after lane.
//! - `ssc`: the speed of sound's scale correction, a constant: the true speed is the one the
//!   acoustic ranges were converted with times `(1 + ssc)` (an LBL range then reads
//!   `true range / (1 + ssc)`). Only acoustic ranges see it.
//!
//! Corrections are what to add to the nominal (mechanized) solution to get the truth:
//! `truth = nominal (+) dx` ([`inject`]), with `C_b^n(true) = exp([psi x]) C_b^n(nominal)`,
//! and true IMU = mechanization input minus the bias corrections.
//!
//! [`continuous_matrix`] is the exact first-order linearisation of the mechanization's ODE
//! (`filters::ins::mechanization`) about the nominal state, including Earth-rate, transport
//! rate, radius-of-curvature and gravity terms; a test checks it against finite differences
//! of the mechanization itself:
//!
//! dp'  = F_pp dp + dv
//! dv'  = F_vp dp + F_vv dv - [f^n x] psi - C dba
//! psi' = F_ψp dp - B dv - [omega_in^n x] psi - C dbg - C e_z omega_z sgz
//! dbg' = dba' = 0 (random walks through Q), sgz' = ssc' = 0
//! dvl' = 0, water' = 0 (the current a random walk through Q)

use super::mechanization::NavState;
use crate::geodesy;
use crate::small_matrix;
use nalgebra::{Matrix3, SMatrix, SVector, UnitQuaternion, Vector3};

/// Size of the error state.
pub const N: usize = 26;
/// Error state vector.
pub type ErrorState = SVector<f64, N>;
/// Error-state matrix.
pub type ErrorMatrix = SMatrix<f64, N, N>;

/// Index of the first element of each block.
pub mod idx {
    pub const POS: usize = 0;
    pub const VEL: usize = 3;
    pub const ATT: usize = 6;
    pub const GYRO_BIAS: usize = 9;
    pub const ACCEL_BIAS: usize = 12;
    /// DVL scale factor error (1), misalignment pitch and heading (2), bias (3).
    pub const DVL: usize = 15;
    pub const DVL_SCALE: usize = 15;
    pub const DVL_MISALIGNMENT: usize = 16;
    pub const DVL_BIAS: usize = 18;
    /// EM-log scale factor error (1), water current north and east (2).
    pub const WATER: usize = 21;
    pub const EML_SCALE: usize = 21;
    pub const CURRENT: usize = 22;
    /// The z gyro's scale factor correction (1).
    pub const GYRO_SCALE_Z: usize = 24;
    /// The speed of sound's scale correction (1).
    pub const SOUND_SPEED_SCALE: usize = 25;
}

/// Number of water states.
pub const WATER_STATES: usize = 3;

/// `[EM-log scale error, current north, current east (m/s)]`: the EM log reads
/// `(1 + k) e_x^T C^T (v - c)`.
pub type WaterState = SVector<f64, WATER_STATES>;

/// Number of DVL calibration states.
pub const DVL_STATES: usize = 6;

/// The DVL's calibration, as estimated: `[scale error, misalignment pitch, misalignment
/// heading (rad), bias x, y, z (m/s)]`. The DVL reads `(1 + s) (I - [m x]) d + b`, with `d`
/// the velocity its nominal mounting predicts and `m = (0, pitch, heading)`.
pub type DvlCalibration = SVector<f64, DVL_STATES>;

fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    v.cross_matrix()
}

/// Continuous-time error dynamics `F` at a nominal state, for the corrected specific force
/// `f_body` and body rate `omega_body` (inertial) the mechanization is using.
pub fn continuous_matrix(
    nav: &NavState,
    f_body: &Vector3<f64>,
    omega_body: &Vector3<f64>,
) -> ErrorMatrix {
    let mut f = ErrorMatrix::zeros();
    f.fixed_rows_mut::<NAV_ROWS>(0)
        .copy_from(&continuous_rows(nav, f_body, omega_body));
    f
}

/// The rows of [`continuous_matrix`] that are not zero: the navigation errors'
/// ([`NAV_ROWS`]).
pub fn continuous_rows(
    nav: &NavState,
    f_body: &Vector3<f64>,
    omega_body: &Vector3<f64>,
) -> TransitionRows {
    use idx::*;
    let (lat, h) = (nav.lat_rad, nav.height_m);
    let v = nav.vel_ned_m_s;
    let (vn, ve, vd) = (v.x, v.y, v.z);
    let local = geodesy::Local::at(lat, h);
    let (s, c) = (local.sin_lat, local.cos_lat);
    let t = s / c;
    let (rho_n, rho_e) = local.radii_plus_height_m();
    let dr_n = local.meridian_radius_derivative();
    let dr_e = local.prime_vertical_radius_derivative();
    let omega = geodesy::OMEGA_IE_RAD_S;
    let w_ie = local.earth_rate_ned();
    let w_en = local.transport_rate_ned(&v);
    let ned_from_body = nav.ned_from_body.to_rotation_matrix().into_inner();
    let f_ned = ned_from_body * f_body;
    let (dg_dlat, dg_dh) = local.normal_gravity_partials();

    // Partial derivatives of the transport rate.
    let den_dlat = Vector3::new(
        -ve * dr_e / (rho_e * rho_e),
        vn * dr_n / (rho_n * rho_n),
        -ve * (1.0 / (c * c * rho_e) - t * dr_e / (rho_e * rho_e)),
    );
    let den_dh = Vector3::new(
        -ve / (rho_e * rho_e),
        vn / (rho_n * rho_n),
        ve * t / (rho_e * rho_e),
    );
    #[rustfmt::skip]
    let b = Matrix3::new(
        0.0, 1.0 / rho_e, 0.0,
        -1.0 / rho_n, 0.0, 0.0,
        0.0, -t / rho_e, 0.0,
    );
    let die_dlat = Vector3::new(-omega * s, 0.0, -omega * c);

    let mut f = TransitionRows::zeros();
    // Position (dlat = dN / rho_n, dh = -dD).
    f[(POS, POS)] = -vd / rho_n;
    f[(POS, POS + 2)] = vn / rho_n;
    f[(POS + 1, POS)] = -ve * dr_e / (rho_e * rho_n) + ve * t / rho_n;
    f[(POS + 1, POS + 1)] = vn * dr_e / (rho_e * rho_n) - vn * t / rho_n - vd / rho_e;
    f[(POS + 1, POS + 2)] = ve / rho_e;
    f.fixed_view_mut::<3, 3>(POS, VEL)
        .copy_from(&Matrix3::identity());

    // Velocity.
    let v_cross = skew(&v);
    let a_lat = 2.0 * die_dlat + den_dlat;
    let col_n = v_cross * a_lat / rho_n + Vector3::new(0.0, 0.0, dg_dlat / rho_n);
    let col_d = -v_cross * den_dh + Vector3::new(0.0, 0.0, -dg_dh);
    f.fixed_view_mut::<3, 1>(VEL, POS).copy_from(&col_n);
    f.fixed_view_mut::<3, 1>(VEL, POS + 2).copy_from(&col_d);
    f.fixed_view_mut::<3, 3>(VEL, VEL)
        .copy_from(&(-skew(&(2.0 * w_ie + w_en)) + v_cross * b));
    f.fixed_view_mut::<3, 3>(VEL, ATT)
        .copy_from(&(-skew(&f_ned)));
    f.fixed_view_mut::<3, 3>(VEL, ACCEL_BIAS)
        .copy_from(&(-ned_from_body));

    // Attitude.
    let att_n = -(die_dlat + den_dlat) / rho_n;
    f.fixed_view_mut::<3, 1>(ATT, POS).copy_from(&att_n);
    f.fixed_view_mut::<3, 1>(ATT, POS + 2).copy_from(&den_dh);
    f.fixed_view_mut::<3, 3>(ATT, VEL).copy_from(&(-b));
    f.fixed_view_mut::<3, 3>(ATT, ATT)
        .copy_from(&(-skew(&(w_ie + w_en))));
    f.fixed_view_mut::<3, 3>(ATT, GYRO_BIAS)
        .copy_from(&(-ned_from_body));
    f.fixed_view_mut::<3, 1>(ATT, GYRO_SCALE_Z)
        .copy_from(&(-ned_from_body.column(2) * omega_body.z));
    f
}

/// `nominal (+) dx`: the navigation state corrected by the position, velocity and attitude
/// parts of `dx` (the bias parts correct the IMU, not the state).
pub fn inject(nominal: &NavState, dx: &ErrorState) -> NavState {
    let (lat, h) = (nominal.lat_rad, nominal.height_m);
    let rho_n = geodesy::meridian_radius_m(lat) + h;
    let rho_e = geodesy::prime_vertical_radius_m(lat) + h;
    let psi = Vector3::new(dx[idx::ATT], dx[idx::ATT + 1], dx[idx::ATT + 2]);
    NavState {
        lat_rad: lat + dx[idx::POS] / rho_n,
        lon_rad: nominal.lon_rad + dx[idx::POS + 1] / (rho_e * lat.cos()),
        height_m: h - dx[idx::POS + 2],
        vel_ned_m_s: nominal.vel_ned_m_s
            + Vector3::new(dx[idx::VEL], dx[idx::VEL + 1], dx[idx::VEL + 2]),
        ned_from_body: UnitQuaternion::from_scaled_axis(psi) * nominal.ned_from_body,
    }
}

/// `truth (-) nominal`: the position, velocity and attitude corrections that take `nominal`
/// to `truth` (inverse of [`inject`]).
pub fn difference(truth: &NavState, nominal: &NavState) -> SVector<f64, 9> {
    let (lat, h) = (nominal.lat_rad, nominal.height_m);
    let rho_n = geodesy::meridian_radius_m(lat) + h;
    let rho_e = geodesy::prime_vertical_radius_m(lat) + h;
    let dv = truth.vel_ned_m_s - nominal.vel_ned_m_s;
    let psi = (truth.ned_from_body * nominal.ned_from_body.inverse()).scaled_axis();
    SVector::<f64, 9>::from_column_slice(&[
        (truth.lat_rad - lat) * rho_n,
        (truth.lon_rad - nominal.lon_rad) * rho_e * lat.cos(),
        -(truth.height_m - h),
        dv.x,
        dv.y,
        dv.z,
        psi.x,
        psi.y,
        psi.z,
    ])
}

/// Rows of `F` (and of every transition) that are not constants' or random walks': the
/// position, velocity and attitude errors. The other rows of `F` are zero, so those of a
/// transition are `[0 I]`, and the products below work on the top rows only.
pub const NAV_ROWS: usize = idx::GYRO_BIAS;
/// The other rows.
const HELD_ROWS: usize = N - NAV_ROWS;

/// The transition's rows that are not `[0 I]`.
pub type TransitionRows = SMatrix<f64, NAV_ROWS, N>;

/// Columns of a transition's top rows that can be non-zero: the navigation errors, the IMU
/// biases and the z gyro's scale. Nothing in the navigation errors' dynamics involves the
/// DVL's calibration, the water or the speed of sound (they enter the measurements only), so their columns of `F`
/// are zero, and so are they in every `Phi` and product of them (`[A B; 0 I]` keeps the zero
/// columns of `B`).
pub const TRANSITION_COLUMNS: [usize; MOVED_BY] = {
    let mut c = [0; MOVED_BY];
    let mut i = 0;
    while i < idx::DVL {
        c[i] = i;
        i += 1;
    }
    c[idx::DVL] = idx::GYRO_SCALE_Z;
    c
};
/// Number of [`TRANSITION_COLUMNS`].
pub const MOVED_BY: usize = 16;

/// Discrete transition `Phi = exp(F dt)` (Taylor series to fourth order: F dt is small at IMU
/// rate) for one interval. With `F dt = [A B; 0 0]`, `(F dt)^k = [A^k A^(k-1) B; 0 0]`, so
/// only the top rows are summed: `[sum A^k/k!  sum A^(k-1) B/k!; 0 I]`, in Horner's form:
/// with `T = I + A/2 (I + A/3 (I + A/4))`, the top rows are `[I + A T  T B]`.
pub fn transition(f: &ErrorMatrix, dt_s: f64) -> ErrorMatrix {
    debug_assert!(
        f.fixed_rows::<HELD_ROWS>(NAV_ROWS).amax() == 0.0,
        "F's rows below the attitude are not zero"
    );
    let mut phi = ErrorMatrix::identity();
    phi.fixed_rows_mut::<NAV_ROWS>(0)
        .copy_from(&transition_rows(
            &f.fixed_rows::<NAV_ROWS>(0).into_owned(),
            dt_s,
        ));
    phi
}

/// The top rows of [`transition`], from the top rows of `F` (the others are zero). Of `B`
/// only the [`TRANSITION_COLUMNS`] past the navigation errors' can be non-zero: `T B` is
/// made of them alone, and its other columns are left zero.
pub fn transition_rows(f_top: &TransitionRows, dt_s: f64) -> TransitionRows {
    type Square = SMatrix<f64, NAV_ROWS, NAV_ROWS>;
    const B_MOVED: usize = MOVED_BY - NAV_ROWS;
    let b_columns = &TRANSITION_COLUMNS[NAV_ROWS..];
    let a: Square = f_top.fixed_view::<NAV_ROWS, NAV_ROWS>(0, 0) * dt_s;
    let b = SMatrix::<f64, NAV_ROWS, B_MOVED>::from_fn(|r, k| f_top[(r, b_columns[k])] * dt_s);
    let i = Square::identity();
    let t = i + small_matrix::mul(
        &a,
        &(i + small_matrix::mul(&a, &(i + a * 0.25)) * (1.0 / 3.0)),
    ) * 0.5;
    let mut top = TransitionRows::zeros();
    top.fixed_view_mut::<NAV_ROWS, NAV_ROWS>(0, 0)
        .copy_from(&(i + small_matrix::mul(&a, &t)));
    let t_b = small_matrix::mul(&t, &b);
    for (k, &c) in b_columns.iter().enumerate() {
        top.column_mut(c).copy_from(&t_b.column(k));
    }
    top
}

/// `Phi P` for a transition whose rows below [`NAV_ROWS`] are `[0 I]`, given its top rows.
pub fn transition_times(phi_top: &TransitionRows, p: &ErrorMatrix) -> ErrorMatrix {
    with_top_rows(p, &top_rows_times(&moved_transition_columns(phi_top), p))
}

/// `[T M] P`, given the [`TRANSITION_COLUMNS`] of `[T M]` (the others are zero); `P` is
/// symmetric, so its rows are its columns.
fn top_rows_times(moved: &MovedColumns, p: &ErrorMatrix) -> TransitionRows {
    small_matrix::mul_transpose(&moved_columns(p), moved).transpose()
}

/// The [`TRANSITION_COLUMNS`] of a transition's top rows.
type MovedColumns = SMatrix<f64, NAV_ROWS, MOVED_BY>;

/// The [`TRANSITION_COLUMNS`] of `m`.
fn moved_columns<const R: usize>(m: &SMatrix<f64, R, N>) -> SMatrix<f64, R, MOVED_BY> {
    SMatrix::from_fn(|r, k| m[(r, TRANSITION_COLUMNS[k])])
}

/// The [`TRANSITION_COLUMNS`] of a transition's top rows, checked to hold all that is not
/// zero.
fn moved_transition_columns(phi_top: &TransitionRows) -> MovedColumns {
    debug_assert!(
        (0..N)
            .filter(|c| !TRANSITION_COLUMNS.contains(c))
            .all(|c| phi_top.column(c).amax() == 0.0),
        "the transition involves the DVL or water states"
    );
    moved_columns(phi_top)
}

/// `p` with its top rows replaced by `x`.
fn with_top_rows(p: &ErrorMatrix, x: &TransitionRows) -> ErrorMatrix {
    let mut out = *p;
    out.fixed_rows_mut::<NAV_ROWS>(0).copy_from(x);
    out
}

/// `D P D` in place, with `D` the identity but `decay` on the DVL bias's diagonal: a
/// Gauss-Markov DVL bias's part of a transition. Its rows are `decay e_i` and the navigation
/// rows have no DVL column, so a transition with it is `Phi_0 D = D Phi_0`, and
/// `Phi P Phi^T = Phi_0 (D P D) Phi_0^T`.
pub fn decay_dvl_bias(p: &mut ErrorMatrix, decay: f64) {
    decay_dvl_bias_rows(p, decay);
    for k in 0..3 {
        p.column_mut(idx::DVL_BIAS + k).scale_mut(decay);
    }
}

/// `D P` in place ([`decay_dvl_bias`]'s `D`): the DVL bias's rows scaled by `decay`.
pub fn decay_dvl_bias_rows(p: &mut ErrorMatrix, decay: f64) {
    for k in 0..3 {
        p.row_mut(idx::DVL_BIAS + k).scale_mut(decay);
    }
}

/// The predicted covariance `Phi P Phi^T + diag(q)`, symmetric, for a transition whose rows
/// below [`NAV_ROWS`] are `[0 I]`, given its top rows `[T M]`: with `X = [T M] P` (the top
/// rows of `Phi P`), the top-left block is `X [T M]^T`, the top-right `X`'s right block, and
/// the bottom-right `P`'s.
pub fn predicted_cov(phi_top: &TransitionRows, p: &ErrorMatrix, q: &ErrorState) -> ErrorMatrix {
    let mut out = *p;
    predict_cov_in_place(phi_top, &mut out, q);
    out
}

/// [`predicted_cov`] in place: the bottom-right block, the only one of `P` the prediction
/// keeps, is read from `p` itself, so no copy is made.
pub fn predict_cov_in_place(phi_top: &TransitionRows, p: &mut ErrorMatrix, q: &ErrorState) {
    let moved = moved_transition_columns(phi_top);
    let x = top_rows_times(&moved, p);
    predict_from_top_rows(&x, &moved, p, q);
}

/// [`predicted_cov`] and `P Phi^T` (the transpose of [`transition_times`], `P` symmetric)
/// together, sharing `X = [T M] P`, into `prior` and `p_phi_t`: `P Phi^T` is `P` with its
/// left columns `X^T`.
pub fn predicted_cov_and_p_phi_t_into(
    phi_top: &TransitionRows,
    p: &ErrorMatrix,
    q: &ErrorState,
    prior: &mut ErrorMatrix,
    p_phi_t: &mut ErrorMatrix,
) {
    let moved = moved_transition_columns(phi_top);
    let x = top_rows_times(&moved, p);
    prior.copy_from(p);
    predict_from_top_rows(&x, &moved, prior, q);
    p_phi_t.copy_from(p);
    p_phi_t.fixed_columns_mut::<NAV_ROWS>(0).tr_copy_from(&x);
}

/// Turns `p` into the predicted covariance, given `x = phi_top p` and the moving columns of
/// `phi_top`: its top rows and left columns are replaced, its diagonal gains `q`.
fn predict_from_top_rows(
    x: &TransitionRows,
    moved: &MovedColumns,
    p: &mut ErrorMatrix,
    q: &ErrorState,
) {
    let top_left = small_matrix::mul_transpose(&moved_columns(x), moved);
    p.fixed_view_mut::<NAV_ROWS, NAV_ROWS>(0, 0)
        .copy_from(&((top_left + top_left.transpose()) * 0.5));
    let top_right = x.fixed_view::<NAV_ROWS, HELD_ROWS>(0, NAV_ROWS);
    p.fixed_view_mut::<NAV_ROWS, HELD_ROWS>(0, NAV_ROWS)
        .copy_from(&top_right);
    p.fixed_view_mut::<HELD_ROWS, NAV_ROWS>(NAV_ROWS, 0)
        .copy_from(&top_right.transpose());
    for i in 0..N {
        p[(i, i)] += q[i];
    }
}

#[cfg(test)]
mod tests {
    use super::super::mechanization::{propagate, ImuSample};
    use super::*;

    fn nominal() -> (NavState, ImuSample) {
        nominal_at(Vector3::new(2.5, -1.7, 0.4))
    }

    fn nominal_at(vel_ned_m_s: Vector3<f64>) -> (NavState, ImuSample) {
        let att = UnitQuaternion::from_euler_angles(0.05, -0.08, 2.1);
        let nav = NavState {
            lat_rad: 35f64.to_radians(),
            lon_rad: 0.1, // near zero: the longitude's last bit is then 1e-11 m
            height_m: -150.0,
            vel_ned_m_s,
            ned_from_body: att,
        };
        let g = geodesy::gravity_ned_m_s2(nav.lat_rad, nav.height_m);
        let f_body = att.inverse() * (Vector3::new(0.2, 0.1, -0.05) - g);
        let imu = ImuSample {
            omega_ib_body: Vector3::new(0.005, -0.004, 0.008),
            specific_force_body: f_body,
        };
        (nav, imu)
    }

    /// Each column of Phi by a central difference of the mechanization itself: propagate a
    /// corrected state and the nominal over dt and take their difference.
    /// A continuous matrix of the model's shape (rows below the attitude zero, and the DVL
    /// and water columns) with entries of mixed sizes, and a covariance from it.
    fn structured_f_and_cov() -> (ErrorMatrix, ErrorMatrix) {
        let (nav, imu) = nominal();
        let mut f = continuous_matrix(&nav, &imu.specific_force_body, &imu.omega_ib_body);
        for r in 0..NAV_ROWS {
            for c in TRANSITION_COLUMNS {
                f[(r, c)] += 1e-3 * ((r * 31 + c * 17) % 13) as f64 - 6e-3;
            }
        }
        let l = ErrorMatrix::from_fn(|r, c| {
            if c <= r {
                1.0 + ((r * 7 + c * 3) % 5) as f64
            } else {
                0.0
            }
        });
        (f, l * l.transpose())
    }

    /// The block forms equal the plain Taylor series and products.
    #[test]
    fn structured_transition_and_prediction_match_the_full_products() {
        let (f, p) = structured_f_and_cov();
        let dt = 0.7;
        let a = f * dt;
        let (mut term, mut full_phi) = (ErrorMatrix::identity(), ErrorMatrix::identity());
        for k in 1..=4 {
            term = term * a / k as f64;
            full_phi += term;
        }
        let phi = transition(&f, dt);
        assert!(
            (phi - full_phi).amax() < 1e-12 * full_phi.amax(),
            "{}",
            (phi - full_phi).amax()
        );
        let top: TransitionRows = phi.fixed_rows::<NAV_ROWS>(0).into_owned();
        let full_phi_p = full_phi * p;
        assert!((transition_times(&top, &p) - full_phi_p).amax() < 1e-12 * full_phi_p.amax());
        let q = ErrorState::from_fn(|i, _| 0.1 * i as f64);
        let full = full_phi * p * full_phi.transpose() + ErrorMatrix::from_diagonal(&q);
        let got = predicted_cov(&top, &p, &q);
        let (mut prior, mut p_phi_t) = (ErrorMatrix::zeros(), ErrorMatrix::zeros());
        predicted_cov_and_p_phi_t_into(&top, &p, &q, &mut prior, &mut p_phi_t);
        assert_eq!(
            (prior, p_phi_t),
            (got, transition_times(&top, &p).transpose())
        );
        assert!(
            (got - full).amax() < 1e-12 * full.amax(),
            "{}",
            (got - full).amax()
        );
        assert_eq!(got, got.transpose());
    }

    #[test]
    fn matches_finite_differences_of_the_mechanization() {
        // A vehicle's speed, and an aircraft's, whose large velocity makes the small
        // transport-rate and Coriolis terms big enough to see.
        check_against_finite_differences(Vector3::new(2.5, -1.7, 0.4));
        check_against_finite_differences(Vector3::new(250.0, -170.0, 40.0));
    }

    fn check_against_finite_differences(vel_ned_m_s: Vector3<f64>) {
        let (nav, imu) = nominal_at(vel_ned_m_s);
        // dt and steps trade rounding (positions carry 1e-16 of the latitude) against the
        // change of F over the step; F itself changes slowly at these rates.
        let dt = 2e-3;
        let nominal_end = propagate(&nav, &imu, &imu, dt, None);
        // F along the step: the mean of its ends (second-order Magnus), as a filter uses it.
        let (fb, wb) = (imu.specific_force_body, imu.omega_ib_body);
        let f =
            (continuous_matrix(&nav, &fb, &wb) + continuous_matrix(&nominal_end, &fb, &wb)) * 0.5;
        let phi = transition(&f, dt);
        let f2 = f * f;
        let steps = [
            1e4, 1e4, 1e4, 1.0, 1.0, 1.0, 1e-2, 1e-2, 1e-2, 1e-3, 1e-3, 1e-3, 0.1, 0.1, 0.1,
        ];
        let columns = steps
            .iter()
            .copied()
            .enumerate()
            .chain([(idx::GYRO_SCALE_Z, 0.1)]);
        for (i, eps) in columns {
            let column = |sign: f64| {
                let mut dx = ErrorState::zeros();
                dx[i] = sign * eps;
                let start = inject(&nav, &dx);
                // True IMU = mechanization input minus the bias corrections.
                let bg = Vector3::new(dx[9], dx[10], dx[11]);
                let ba = Vector3::new(dx[12], dx[13], dx[14]);
                let sgz = Vector3::new(0.0, 0.0, dx[idx::GYRO_SCALE_Z] * imu.omega_ib_body.z);
                let true_imu = ImuSample {
                    omega_ib_body: imu.omega_ib_body - bg - sgz,
                    specific_force_body: imu.specific_force_body - ba,
                };
                let end = propagate(&start, &true_imu, &true_imu, dt, None);
                let mut out = ErrorState::zeros();
                out.fixed_rows_mut::<9>(0)
                    .copy_from(&difference(&end, &nominal_end));
                out.fixed_rows_mut::<6>(9).copy_from(&dx.fixed_rows::<6>(9));
                out[idx::GYRO_SCALE_Z] = dx[idx::GYRO_SCALE_Z];
                out
            };
            let numeric = (column(1.0) - column(-1.0)) / (2.0 * eps);
            for r in 0..N {
                let (want, got) = (phi[(r, i)], numeric[r]);
                // Compare the rates (Phi - I) / dt: they span 1e-7 to 10.
                let (want_rate, got_rate) = (
                    (want - f64::from(u8::from(r == i))) / dt,
                    (got - f64::from(u8::from(r == i))) / dt,
                );
                // Position rows seen from the other columns hold F_pv = I (checked to 1e-4)
                // and second-order products such as F_pv F_vpsi dt / 2 (about 5e-4), whose
                // F changes over dt by a few 1e-7 as the specific force turns with the body;
                // positions also round to 1e-9 m (the latitude's last bit). The first-order
                // position terms (F_pp, about 1e-7) are checked by the 10 km position columns
                // with the tight floor.
                // First-order content must match to 1e-4. The second-order part of a rate,
                // (F^2)_ri dt / 2, carries third-order and F-varies-over-dt errors: 5 % of it.
                // Positions round to about 1e-9 m (the latitude's last bit): seen through a
                // step eps over dt, that is 1e-9 / eps / dt in a rate.
                let second_order = f2[(r, i)].abs() * dt / 2.0;
                let rounding = if r < 3 { 1e-9 / eps / dt } else { 0.0 };
                let tol = 1e-4 * want_rate.abs() + 0.05 * second_order + rounding + 2e-9;
                assert!(
                    (want_rate - got_rate).abs() <= tol,
                    "v {vel_ned_m_s}: F[{r}][{i}]: analytic {want_rate:e}, numeric {got_rate:e}"
                );
            }
        }
    }

    #[test]
    fn inject_and_difference_are_inverse() {
        let (nav, _) = nominal();
        let nav_part = [3.0, -2.0, 1.5, 0.1, -0.2, 0.05, 1e-3, -2e-3, 5e-3];
        let dx = ErrorState::from_fn(|i, _| nav_part.get(i).copied().unwrap_or(0.0));
        let back = difference(&inject(&nav, &dx), &nav);
        assert!((back - dx.fixed_rows::<9>(0)).amax() < 1e-9, "{back}");
    }
}
