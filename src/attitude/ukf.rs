//! Seed 001's UKF (Table 2) with its parameters (Table 7) as the defaults.
//!
//! Sigma points `x +- columns of chol((n + kappa) P)`, weights `kappa / (n + kappa)` and
//! `1 / (2 (n + kappa))`, each point turned by the gyro ([`super::euler::propagate`]); the
//! measurement is the state itself (Table 2 line 15: `hz = X_s`), so the predicted
//! measurement's spread is the propagated points' spread before the process noise is added
//! (lines 13-18), as the paper has it. Angles are averaged and differenced on the circle.
//!
//! Naming as in [`super::ekf`]: `process_noise` is the paper's `R`, `measurement_noise` its
//! `Q`. Table 7 as decoded (symmetric): `kappa = 1.7`, `P0 = 0.15 I`,
//! `R(paper) = [[0.2, 0.02, 0.02], [0.02, 0.2, 0.02], [0.02, 0.02, 0.15]]`,
//! `Q(paper) = [[0.07, 0.07, 0.07], [0.07, 0.1, 0.07], [0.07, 0.07, 0.02]]`, which is not
//! positive definite (eigenvalues -0.033, 0.015, 0.208): the posterior
//! `P = S (S + Q)^-1 Q + R` (S the points' spread) then holds only while the process noise
//! outweighs the negative part, and with a smaller process noise the Cholesky
//! factorisation fails, as the paper warns. hindsight raises the measurement covariance's
//! eigenvalues to a floor when it reads the settings and says so.
//!
//! Should a factorisation still fail (rounding), the covariance is repaired (symmetrised,
//! eigenvalues raised to a floor) and the repair counted in [`UkfState::repairs`], which
//! `hindsight attitude` reports and the tests require to be zero on every test log.

use super::euler::{self, Euler, EulerFilter};
use nalgebra::{Matrix3, Vector3};

/// Parameters of the paper's UKF (usual naming).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct UkfSettings {
    /// Spread of the sigma points (Table 7's kappa).
    pub kappa: f64,
    /// Initial covariance, rad^2 (the paper's P0).
    pub initial_cov: [[f64; 3]; 3],
    /// Added to the covariance at every step, rad^2 (the paper's R).
    pub process_noise: [[f64; 3]; 3],
    /// Covariance of the eq. 1-3 attitude, rad^2 (the paper's Q).
    pub measurement_noise: [[f64; 3]; 3],
}

/// hindsight's defaults: seed 001's matrices with the measurement covariance made positive
/// definite by keeping its diagonal (the paper's printed one is indefinite).
impl Default for UkfSettings {
    fn default() -> Self {
        UkfSettings {
            measurement_noise: [[0.07, 0.0, 0.0], [0.0, 0.1, 0.0], [0.0, 0.0, 0.02]],
            ..UkfSettings::seed001()
        }
    }
}

impl UkfSettings {
    /// Seed 001 Table 2 with the parameters of its Table 7, as printed.
    pub fn seed001() -> Self {
        UkfSettings {
            kappa: 1.7,
            initial_cov: super::ekf::diagonal(0.15),
            process_noise: [[0.2, 0.02, 0.02], [0.02, 0.2, 0.02], [0.02, 0.02, 0.15]],
            measurement_noise: [[0.07, 0.07, 0.07], [0.07, 0.1, 0.07], [0.07, 0.07, 0.02]],
        }
    }
}

/// The filter, its matrices checked (see [`super::config`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ukf {
    pub kappa: f64,
    pub initial_cov: Matrix3<f64>,
    pub process_noise: Matrix3<f64>,
    pub measurement_noise: Matrix3<f64>,
}

/// The filter's state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UkfState {
    pub mean: Euler,
    pub cov: Matrix3<f64>,
    /// How many times a covariance was not positive definite and had to be repaired.
    pub repairs: usize,
}

/// Eigenvalue floor of a repaired covariance, rad^2.
const REPAIR_FLOOR: f64 = 1e-12;

impl Ukf {
    /// The lower Cholesky factor of `m`, repairing `m` first if it has none.
    fn square_root(m: &Matrix3<f64>, repairs: &mut usize) -> Matrix3<f64> {
        if let Some(c) = m.cholesky() {
            return c.l();
        }
        *repairs += 1;
        let (fixed, _) = euler::positive_definite(m, REPAIR_FLOOR);
        fixed
            .cholesky()
            .map_or(Matrix3::identity() * REPAIR_FLOOR.sqrt(), |c| c.l())
    }
}

impl EulerFilter for Ukf {
    type State = UkfState;

    fn start(&self, z: &Euler) -> UkfState {
        UkfState {
            mean: *z,
            cov: self.initial_cov,
            repairs: 0,
        }
    }

    fn step(&self, prior: &UkfState, w_body: &Vector3<f64>, dt: f64, z: &Euler) -> UkfState {
        const N: usize = 3;
        let mut repairs = prior.repairs;
        let spread = N as f64 + self.kappa;
        let (w0, w) = (self.kappa / spread, 0.5 / spread);
        // Lines 1-11: sigma points, each turned by the gyro.
        let root = Self::square_root(&(prior.cov * spread), &mut repairs);
        let mut points = [prior.mean; 2 * N + 1];
        for j in 0..N {
            let column: Euler = root.column(j).into_owned();
            points[1 + j] = prior.mean + column;
            points[1 + N + j] = prior.mean - column;
        }
        let points = points.map(|x| euler::propagate(&x, w_body, dt));
        // Lines 12-14: their mean (on the circle, about the central point) and spread.
        let weight = |j: usize| if j == 0 { w0 } else { w };
        let offset: Euler = (0..points.len())
            .map(|j| euler::difference(&points[j], &points[0]) * weight(j))
            .sum();
        let mean = euler::wrapped(&(points[0] + offset));
        let deviations = points.map(|x| euler::difference(&x, &mean));
        let spread_cov: Matrix3<f64> = (0..points.len())
            .map(|j| deviations[j] * deviations[j].transpose() * weight(j))
            .sum();
        let predicted_cov = spread_cov + self.process_noise;
        // Lines 15-24 with hz = X_s: the predicted measurement is the mean, its covariance
        // the spread plus the measurement noise, the cross covariance the spread.
        let innovation_cov = spread_cov + self.measurement_noise;
        let Some(chol) = innovation_cov.cholesky() else {
            repairs += 1;
            return UkfState {
                mean,
                cov: predicted_cov,
                repairs,
            };
        };
        let gain = chol.solve(&spread_cov).transpose(); // P_xz P_z^-1, both symmetric
        let y = euler::difference(z, &mean);
        let cov = predicted_cov - gain * innovation_cov * gain.transpose();
        let mut cov = (cov + cov.transpose()) * 0.5;
        if cov.cholesky().is_none() {
            repairs += 1;
            cov = euler::positive_definite(&cov, REPAIR_FLOOR).0;
        }
        UkfState {
            mean: euler::wrapped(&(mean + gain * y)),
            cov,
            repairs,
        }
    }

    fn attitude(state: &UkfState) -> Euler {
        state.mean
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// With the paper's Table 7 measurement covariance as printed (indefinite) and a
    /// process noise smaller than the paper's, the UKF's covariances stop being positive
    /// definite within a few steps (counted as repairs): why hindsight checks the settings.
    #[test]
    fn the_printed_measurement_noise_breaks_the_covariance() {
        let printed = UkfSettings::seed001();
        let ukf = Ukf {
            kappa: printed.kappa,
            initial_cov: super::super::ekf::matrix(&printed.initial_cov),
            process_noise: Matrix3::identity() * 1e-4,
            measurement_noise: super::super::ekf::matrix(&printed.measurement_noise),
        };
        let mut state = ukf.start(&Euler::zeros());
        for _ in 0..50 {
            state = ukf.step(&state, &Vector3::new(0.0, 0.0, 0.01), 0.01, &Euler::zeros());
        }
        assert!(state.repairs > 0);
        // Raised to positive definite, no repair is needed.
        let fixed = Ukf {
            measurement_noise: euler::positive_definite(&ukf.measurement_noise, 1e-4).0,
            ..ukf
        };
        let mut state = fixed.start(&Euler::zeros());
        for _ in 0..50 {
            state = fixed.step(&state, &Vector3::new(0.0, 0.0, 0.01), 0.01, &Euler::zeros());
        }
        assert_eq!(state.repairs, 0);
    }
}
