//! Identification of hydrodynamic coefficients from sea-trial logs (`hindsight identify`):
//! seed 004's augmented-state EKF, then an output-error refinement over the whole record.
//!
//! - [`record`]: the measurements a log gives (q, theta, w, depth, plane, speed), with the
//!   checks that make identification possible (input present, a manoeuvre, long enough).
//! - [`ekf`]: the first stage, the continuous-discrete augmented EKF.
//! - [`settings`]: constants, sensor noise, tuning.

pub mod ekf;
pub mod identifiability;
pub mod output_error;
pub mod record;
pub mod settings;

use crate::vehicle::heave_pitch::Coefficients;

/// `c` with every coefficient moved by `fraction` of itself, alternately up and down
/// (`Z_w` up, `Z_wdot` down, ...): the start of the "20 % off" tests and of `--perturb`.
pub fn perturbed(c: &Coefficients, fraction: f64) -> Coefficients {
    Coefficients::from_fn(|i, _| c[i] * (1.0 + if i % 2 == 0 { fraction } else { -fraction }))
}
