//! Seed 001's complementary filter (Table 3) with its gains (Table 8) as the defaults.
//!
//! The Euler angles are turned by the gyro less an estimated rate bias; the bias is the PI
//! controller of the difference between the estimate and the eq. 1-3 attitude:
//! `b_k = b_(k-1) - kp d_(k-1) + (kp + ki dt) d_k` (Table 3 line 6), that is
//! `b = kp d + ki sum(d dt)`. With `kp = 4.35 sqrt(2)` and `ki = 0.415` (Table 8) the
//! estimate follows the measurement with a time constant of about 0.16 s.

use super::euler::{self, Euler, EulerFilter};
use nalgebra::Vector3;

/// Gains of the paper's complementary filter.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CfSettings {
    /// Proportional gain, 1/s.
    pub kp: f64,
    /// Integral gain, 1/s^2.
    pub ki: f64,
}

impl Default for CfSettings {
    fn default() -> Self {
        CfSettings {
            kp: 4.35 * std::f64::consts::SQRT_2,
            ki: 0.415,
        }
    }
}

/// The filter's state (Table 3's arguments).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CfState {
    pub attitude: Euler,
    /// Estimated bias of the Euler-angle rates, rad/s.
    pub rate_bias: Euler,
    /// The last difference between the estimate and the measurement, rad.
    pub difference: Euler,
}

impl EulerFilter for CfSettings {
    type State = CfState;

    fn start(&self, z: &Euler) -> CfState {
        CfState {
            attitude: *z,
            rate_bias: Euler::zeros(),
            difference: Euler::zeros(),
        }
    }

    fn step(&self, prior: &CfState, w_body: &Vector3<f64>, dt: f64, z: &Euler) -> CfState {
        // Lines 1-4: turned by the gyro, less the bias.
        let attitude =
            euler::wrapped(&(euler::propagate(&prior.attitude, w_body, dt) - prior.rate_bias * dt));
        // Lines 5-6.
        let difference = euler::difference(&attitude, z);
        let rate_bias =
            prior.rate_bias - prior.difference * self.kp + difference * (self.kp + self.ki * dt);
        CfState {
            attitude,
            rate_bias,
            difference,
        }
    }

    fn attitude(state: &CfState) -> Euler {
        state.attitude
    }
}
