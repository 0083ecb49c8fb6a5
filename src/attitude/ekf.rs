//! Seed 001's EKF (Table 1) with its parameters (Table 6) as the defaults.
//!
//! State: Euler angles; prediction by the gyro ([`super::euler`]), measurement the
//! "no filtering" attitude of eq. 1-3 (`H = I`), yaw innovation wrapped. The update is the
//! shared Kalman core's (Joseph form).
//!
//! **Naming**: the paper calls the process noise `R` and the measurement noise `Q`, the
//! reverse of the usual convention. Here, as everywhere in hindsight, `process_noise` is the
//! noise added to the state's covariance at every step (the paper's `R`) and
//! `measurement_noise` that of the eq. 1-3 attitude (the paper's `Q`). Both are per filter
//! step (the paper's AHRS rate is not printed), rad^2, full 3x3 (the paper found its
//! off-diagonal terms mattered).
//!
//! Table 6 as decoded from the seed's text (the print is garbled; the decoding assumes
//! symmetric matrices): `P0 = 0.15 I`,
//! `R(paper) = [[0.1, 0.08, 0.08], [0.08, 0.1, 0.08], [0.08, 0.08, 0.1]]`,
//! `Q(paper) = [[0.1, 0.08, 0.15], [0.08, 0.1, 0.15], [0.15, 0.15, 0.2]]`. That measurement
//! covariance is not positive definite (eigenvalues -0.022, 0.020, 0.402): hindsight raises
//! its eigenvalues to a floor and says so (see [`super::config`]).

use super::euler::{self, Euler, EulerFilter};
use crate::filters::kalman::{self, Gaussian};
use nalgebra::{Matrix3, Vector3};

/// Parameters of the paper's EKF (usual naming; see the module's note).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct EkfSettings {
    /// Initial covariance of the Euler angles, rad^2 (the paper's P0).
    pub initial_cov: [[f64; 3]; 3],
    /// Added to the covariance at every step, rad^2 (the paper's R).
    pub process_noise: [[f64; 3]; 3],
    /// Covariance of the eq. 1-3 attitude, rad^2 (the paper's Q).
    pub measurement_noise: [[f64; 3]; 3],
}

/// hindsight's defaults: seed 001's matrices with the measurement covariance made positive
/// definite by keeping its diagonal (the paper's printed one is indefinite).
impl Default for EkfSettings {
    fn default() -> Self {
        EkfSettings {
            measurement_noise: [[0.1, 0.0, 0.0], [0.0, 0.1, 0.0], [0.0, 0.0, 0.2]],
            ..EkfSettings::seed001()
        }
    }
}

impl EkfSettings {
    /// Seed 001 Table 1 with the parameters of its Table 6, as printed.
    pub fn seed001() -> Self {
        EkfSettings {
            initial_cov: diagonal(0.15),
            process_noise: [[0.1, 0.08, 0.08], [0.08, 0.1, 0.08], [0.08, 0.08, 0.1]],
            measurement_noise: [[0.1, 0.08, 0.15], [0.08, 0.1, 0.15], [0.15, 0.15, 0.2]],
        }
    }
}

pub(crate) fn diagonal(v: f64) -> [[f64; 3]; 3] {
    [[v, 0.0, 0.0], [0.0, v, 0.0], [0.0, 0.0, v]]
}

pub(crate) fn matrix(m: &[[f64; 3]; 3]) -> Matrix3<f64> {
    Matrix3::from_fn(|i, j| m[i][j])
}

/// The filter, its matrices checked (see [`super::config`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ekf {
    pub initial_cov: Matrix3<f64>,
    pub process_noise: Matrix3<f64>,
    pub measurement_noise: Matrix3<f64>,
}

impl EulerFilter for Ekf {
    type State = Gaussian<3>;

    fn start(&self, z: &Euler) -> Gaussian<3> {
        // Table 6 starts from zero angles; starting from the first measurement removes the
        // initial transient (the pool runs start level, where the two agree).
        Gaussian {
            mean: *z,
            cov: self.initial_cov,
        }
    }

    fn step(&self, prior: &Gaussian<3>, w_body: &Vector3<f64>, dt: f64, z: &Euler) -> Gaussian<3> {
        // Table 1 lines 1-6.
        let a = euler::transition(&prior.mean, w_body, dt);
        let cov = a * prior.cov * a.transpose() + self.process_noise;
        let predicted = Gaussian {
            mean: euler::propagate(&prior.mean, w_body, dt),
            cov: (cov + cov.transpose()) * 0.5,
        };
        // Lines 7-9, H = I, the innovation wrapped.
        let y = euler::difference(z, &predicted.mean);
        match kalman::update(
            &predicted,
            &y,
            &Matrix3::identity(),
            &self.measurement_noise,
            None,
        ) {
            Ok((mut posterior, _)) => {
                posterior.mean = euler::wrapped(&posterior.mean);
                posterior
            }
            // Cannot happen with a positive definite measurement noise; keep the prediction.
            Err(_) => predicted,
        }
    }

    fn attitude(state: &Gaussian<3>) -> Euler {
        state.mean
    }
}
