//! Fixed-interval Rauch-Tung-Striebel smoother for the error-state filter with resets.
//!
//! Derivation. The forward filter keeps a nominal state `x` and an error state `dx` whose mean
//! is reset to zero after every update (the correction is injected into `x`). Between two
//! recorded epochs k and k+1 there are no updates, only prediction:
//! `dx_{k+1|k} = Phi_k dx_{k|k} = 0` and `P_{k+1|k} = Phi_k P_{k|k} Phi_k^T + Q_k`
//! (`Phi_k` is the product of the transitions the forward pass used between the two epochs,
//! `Q_k` what they added).
//! At epoch k+1 the updates move the nominal from its prior `x-_{k+1}` to its posterior
//! `x+_{k+1} = x-_{k+1} (+) D_{k+1}`, and the smoothed error relative to the posterior is
//! `dx_{k+1|N}`. Relative to the prior nominal (the one `Phi_k` propagated to) it is, to first
//! order, `dx_{k+1|N} + D_{k+1}`. The RTS recursion on the error state then reads
//!
//!   C_k       = P_{k|k} Phi_k^T P_{k+1|k}^-1
//!   dx_{k|N}  = C_k (dx_{k+1|N} + D_{k+1} - dx_{k+1|k}),   dx_{k+1|k} = 0
//!   P_{k|N}   = P_{k|k} + C_k (P_{k+1|N} - P_{k+1|k}) C_k^T
//!
//! starting from `dx_{N|N} = 0`, `P_{N|N}` at the last epoch, and the smoothed state is
//! `x+_k (+) dx_{k|N}`. Where the forward filter's reset keeps the heading's unobservable
//! direction (`filters::ins::heading_reset`), `dx+ = J (dx- - D)`:
//! the smoothed error and covariance at k+1 are then carried back to the prior's coordinates
//! by `J^-1` before the step above (`dx_{k+1|N}` read as `J^-1 dx_{k+1|N}`, `P_{k+1|N}` as
//! `J^-1 P_{k+1|N} J^-T`); elsewhere the reset Jacobian is the identity.
//!
//! Memory: the forward pass keeps one compact record per filter epoch (measurement or output
//! time), never per IMU sample (`filters::ins::record`), on a temporary file beyond a block
//! (`spill`); the backward pass reads them back a block at a time, holds one full covariance,
//! and hands each compact solution on as it is made.

use super::error_rts::{backward_from_last, ForwardEpoch};
use crate::disk_backed::Spilled;
use crate::filters::ins::error_state::{self, idx, ErrorMatrix, ErrorState};
use crate::filters::ins::record::{EpochRecord, NavPoint, Solution};

/// Why smoothing failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SmoothError {
    #[error("predicted covariance at epoch {epoch} is not invertible")]
    SingularPrior { epoch: usize },
    #[error("reading the forward records back: {0}")]
    Records(String),
}

impl ForwardEpoch<{ error_state::N }> for EpochRecord {
    fn posterior_cov(&self) -> ErrorMatrix {
        self.posterior_cov.unpack()
    }
    fn phi(&self) -> ErrorMatrix {
        self.phi_from_previous.unpack()
    }
    fn phi_times(&self, m: &ErrorMatrix) -> ErrorMatrix {
        self.phi_from_previous.times(m)
    }
    fn prior_cov(&self, previous_posterior: &ErrorMatrix) -> ErrorMatrix {
        EpochRecord::prior_cov(self, previous_posterior)
    }
    fn posterior_cov_into(&self, out: &mut ErrorMatrix) {
        self.posterior_cov.unpack_into(out);
    }
    fn prior_cov_and_p_phi_t(
        &self,
        previous_posterior: &ErrorMatrix,
        prior: &mut ErrorMatrix,
        p_phi_t: &mut ErrorMatrix,
    ) {
        self.phi_from_previous.predicted_cov_and_p_phi_t_into(
            previous_posterior,
            &self.process_noise,
            prior,
            p_phi_t,
        );
    }
    fn correction(&self) -> ErrorState {
        self.correction
    }
    fn to_prior_coordinates(&self, dx: &mut ErrorState, p: &mut ErrorMatrix) {
        crate::filters::ins::heading_reset::to_prior_coordinates(dx, p, &self.heading_turn);
    }
}

/// Smoothed solutions, one per record, in time order.
pub fn smooth(records: &Spilled<EpochRecord>) -> Result<Vec<Solution>, SmoothError> {
    let mut out = Vec::with_capacity(records.len());
    smooth_each(records, None, |_, _, s| out.push(s))?;
    out.reverse();
    Ok(out)
}

/// Runs the smoother, calling `each(k, record_k, smoothed_k)` from the last record to the
/// first and telling `progress` the fraction done. The records are read back a block at a
/// time, so memory does not grow with the mission.
pub fn smooth_each(
    records: &Spilled<EpochRecord>,
    progress: crate::progress::Progress<'_>,
    mut each: impl FnMut(usize, &EpochRecord, Solution),
) -> Result<(), SmoothError> {
    let n = records.len();
    let last_first = records
        .iter_rev()
        .map(|r| r.map_err(|e| SmoothError::Records(e.to_string())));
    backward_from_last(n, last_first, |k, rec: &EpochRecord, dx, p| {
        crate::progress::tell(progress, n - k, n, 1 << 14);
        let post = &rec.posterior;
        let point = NavPoint {
            nav: error_state::inject(&post.nav, dx),
            gyro_bias: post.gyro_bias + dx.fixed_rows::<3>(idx::GYRO_BIAS),
            accel_bias: post.accel_bias + dx.fixed_rows::<3>(idx::ACCEL_BIAS),
            dvl: post.dvl + dx.fixed_rows::<{ error_state::DVL_STATES }>(idx::DVL),
            water: post.water + dx.fixed_rows::<{ error_state::WATER_STATES }>(idx::WATER),
            gyro_scale_z: post.gyro_scale_z + dx[idx::GYRO_SCALE_Z],
            sound_speed_scale: post.sound_speed_scale + dx[idx::SOUND_SPEED_SCALE],
        };
        each(k, rec, Solution::from_cov(rec.stamp_ns, point, p));
    })
}
