//! Forward error-state filter: the mechanization at IMU rate, the error covariance carried
//! along with the 15-state model, and aiding updates that correct the state (with reset).
//!
//! Pure: `predict` and `update` take an [`Estimate`] and return a new one with what the step
//! did, so a smoother can replay the forward pass from its records.
//!
//! After each update the error estimate is injected into the navigation state and the bias
//! estimates, and the error mean is reset to zero. The reset's Jacobian is taken as the
//! identity (first order: the attitude correction is small), so the covariance carries over.

use super::error_state::{self, idx, ErrorMatrix, ErrorState, N};
use super::mechanization::{propagate, HeightDamping, ImuSample, NavState};
use crate::filters::kalman::{self, Gaussian, KalmanError, UpdateRecord};
use crate::geodesy;
use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

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
    /// Covariance of the error state.
    pub cov: ErrorMatrix,
}

/// The filter's models.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Filter {
    pub noise: ImuNoise,
    /// Vertical-channel damping on the depth, when aided by depth.
    pub height_damping: Option<HeightDamping>,
}

impl Estimate {
    fn corrected(&self, imu: &ImuSample) -> ImuSample {
        ImuSample {
            omega_ib_body: imu.omega_ib_body - self.gyro_bias,
            specific_force_body: imu.specific_force_body - self.accel_bias,
        }
    }

    /// One-sigma of the error state.
    pub fn sigma(&self) -> ErrorState {
        self.cov.diagonal().map(|v| v.max(0.0).sqrt())
    }
}

impl Filter {
    /// Propagates over one IMU interval from raw sample `imu0` to `imu1`; returns the new
    /// estimate and the transition matrix used. `height_ref_m` (ellipsoidal height of a depth
    /// reading) damps the vertical channel.
    pub fn predict(
        &self,
        est: &Estimate,
        imu0: &ImuSample,
        imu1: &ImuSample,
        dt_s: f64,
        height_ref_m: Option<f64>,
    ) -> (Estimate, ErrorMatrix) {
        let (i0, i1) = (est.corrected(imu0), est.corrected(imu1));
        let damping = self.height_damping.zip(height_ref_m);
        let nav = propagate(&est.nav, &i0, &i1, dt_s, damping);
        let f_mid = (i0.specific_force_body + i1.specific_force_body) * 0.5;
        let f = (error_state::continuous_matrix(&est.nav, &f_mid)
            + error_state::continuous_matrix(&nav, &f_mid))
            * 0.5;
        let phi = error_state::transition(&f, dt_s);
        let q = self.process_noise(&est.nav, dt_s);
        let prior = Gaussian {
            mean: ErrorState::zeros(),
            cov: est.cov,
        };
        let cov = kalman::predict(&prior, &phi, &q).cov;
        (Estimate { nav, cov, ..*est }, phi)
    }

    /// Discrete process noise over `dt_s` (white noise integrated over the step).
    fn process_noise(&self, nav: &NavState, dt_s: f64) -> ErrorMatrix {
        let n = &self.noise;
        let c = nav.ned_from_body.to_rotation_matrix().into_inner();
        let mut q = ErrorMatrix::zeros();
        let block = |m: &mut ErrorMatrix, at: usize, value: Matrix3<f64>| {
            m.fixed_view_mut::<3, 3>(at, at).copy_from(&value)
        };
        block(
            &mut q,
            idx::VEL,
            c * c.transpose() * n.accel_noise_density.powi(2) * dt_s,
        );
        block(
            &mut q,
            idx::ATT,
            c * c.transpose() * n.gyro_noise_density.powi(2) * dt_s,
        );
        block(
            &mut q,
            idx::GYRO_BIAS,
            Matrix3::identity() * n.gyro_bias_walk.powi(2) * dt_s,
        );
        block(
            &mut q,
            idx::ACCEL_BIAS,
            Matrix3::identity() * n.accel_bias_walk.powi(2) * dt_s,
        );
        q
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
        let prior = Gaussian {
            mean: ErrorState::zeros(),
            cov: est.cov,
        };
        let (post, record) = kalman::update(&prior, y, h, r, gate)?;
        let dx = post.mean;
        let next = Estimate {
            nav: error_state::inject(&est.nav, &dx),
            // dbg = true bias - estimate: the estimate moves by the correction.
            gyro_bias: est.gyro_bias + dx.fixed_rows::<3>(idx::GYRO_BIAS),
            accel_bias: est.accel_bias + dx.fixed_rows::<3>(idx::ACCEL_BIAS),
            cov: post.cov,
        };
        Ok((next, record))
    }
}

/// What the forward pass keeps at one epoch.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EpochRecord {
    pub stamp_ns: i64,
    /// Transition from the previous epoch to this one (identity at the first epoch).
    pub phi_from_previous: ErrorMatrix,
    /// Covariance predicted to this epoch, before its updates.
    pub prior_cov: ErrorMatrix,
    /// Correction the updates at this epoch applied, prior to posterior (position, velocity,
    /// attitude as in the error state, then the two bias changes).
    pub correction: ErrorState,
    /// Estimate after this epoch's updates.
    pub posterior: Estimate,
}

impl EpochRecord {
    /// The correction that takes `prior` to `posterior` (both at one epoch).
    pub fn correction_between(prior: &Estimate, posterior: &Estimate) -> ErrorState {
        let mut d = ErrorState::zeros();
        d.fixed_rows_mut::<9>(0)
            .copy_from(&error_state::difference(&posterior.nav, &prior.nav));
        d.fixed_rows_mut::<3>(idx::GYRO_BIAS)
            .copy_from(&(posterior.gyro_bias - prior.gyro_bias));
        d.fixed_rows_mut::<3>(idx::ACCEL_BIAS)
            .copy_from(&(posterior.accel_bias - prior.accel_bias));
        d
    }
}

/// Measurement models: innovation and error-state matrix for each aiding sensor.
pub mod measure {
    use super::*;

    /// DVL velocity over ground in the body frame (DVL at the reference point, aligned with
    /// the body axes). `z = C^T v`: `H_v = C^T`, `H_psi = C^T [v x]`.
    pub fn body_velocity(
        est: &Estimate,
        v_body: &Vector3<f64>,
    ) -> (SVector<f64, 3>, SMatrix<f64, 3, N>) {
        let c_t = est
            .nav
            .ned_from_body
            .inverse()
            .to_rotation_matrix()
            .into_inner();
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

    /// Speed through water from an EM log, taken as the speed over ground (no current):
    /// `z = |C^T v| = |v|`, so `H_v = v^T / |v|`. `None` below 0.1 m/s, where the direction
    /// of the velocity is not defined well enough to linearise.
    pub fn speed(est: &Estimate, speed_m_s: f64) -> Option<(SVector<f64, 1>, SMatrix<f64, 1, N>)> {
        let v = est.nav.vel_ned_m_s;
        let norm = v.norm();
        if norm < 0.1 {
            return None;
        }
        let mut h = SMatrix::<f64, 1, N>::zeros();
        h.fixed_view_mut::<1, 3>(0, idx::VEL)
            .copy_from(&(v.transpose() / norm));
        Some((SVector::<f64, 1>::new(speed_m_s - norm), h))
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
            cov: ErrorMatrix::identity() * 1e-4,
        }
    }

    /// The measurement matrices are the Jacobians of the predicted measurement with respect
    /// to the error state, checked by injecting small corrections.
    #[test]
    fn measurement_jacobians_match_finite_differences() {
        let est = estimate();
        let v_body = Vector3::new(1.0, -0.3, 0.2);
        let (y0, h) = measure::body_velocity(&est, &v_body);
        for i in 0..N {
            let eps = 1e-6;
            let mut dx = ErrorState::zeros();
            dx[i] = eps;
            let moved = Estimate {
                nav: error_state::inject(&est.nav, &dx),
                ..est
            };
            let (y1, _) = measure::body_velocity(&moved, &v_body);
            // y = z - predicted, so the predicted measurement moves by y0 - y1.
            let numeric = (y0 - y1) / eps;
            assert!(
                (numeric - h.column(i)).amax() < 1e-6,
                "DVL column {i}: {numeric} vs {}",
                h.column(i)
            );
        }
        let (s0, hs) = measure::speed(&est, 1.5).unwrap();
        for i in 0..N {
            let mut dx = ErrorState::zeros();
            dx[i] = 1e-6;
            let moved = Estimate {
                nav: error_state::inject(&est.nav, &dx),
                ..est
            };
            let (s1, _) = measure::speed(&moved, 1.5).unwrap();
            assert!(
                ((s0 - s1)[0] / 1e-6 - hs[(0, i)]).abs() < 1e-6,
                "speed column {i}"
            );
        }
        let slow = Estimate {
            nav: NavState {
                vel_ned_m_s: Vector3::new(0.05, 0.0, 0.0),
                ..est.nav
            },
            ..est
        };
        assert!(measure::speed(&slow, 0.0).is_none());
        let (d0, hd) = measure::depth(&est, 21.0);
        let mut dx = ErrorState::zeros();
        dx[idx::POS + 2] = 0.5;
        let (d1, _) = measure::depth(
            &Estimate {
                nav: error_state::inject(&est.nav, &dx),
                ..est
            },
            21.0,
        );
        assert!(((d0 - d1)[0] / 0.5 - hd[(0, idx::POS + 2)]).abs() < 1e-9);
        let (p0, hp) = measure::horizontal_position(&est, 0.6 + 1e-6, 0.1 - 1e-6);
        for i in [idx::POS, idx::POS + 1] {
            let mut dx = ErrorState::zeros();
            dx[i] = 1.0;
            let (p1, _) = measure::horizontal_position(
                &Estimate {
                    nav: error_state::inject(&est.nav, &dx),
                    ..est
                },
                0.6 + 1e-6,
                0.1 - 1e-6,
            );
            assert!(((p0 - p1) - hp.column(i)).amax() < 1e-6);
        }
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
}
