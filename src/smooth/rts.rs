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
//! `x+_k (+) dx_{k|N}`. The reset Jacobian is taken as the identity, as in the forward filter.
//!
//! Memory: the forward pass keeps one compact record per filter epoch (measurement or output
//! time), never per IMU sample (`filters::ins::record`); the backward pass holds one full
//! covariance at a time and returns compact solutions.

use crate::filters::ins::error_state::{self, idx, ErrorState};
use crate::filters::ins::record::{EpochRecord, NavPoint, PackedCov, Solution};

/// Why smoothing failed.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum SmoothError {
    #[error("predicted covariance at epoch {epoch} is not invertible")]
    SingularPrior { epoch: usize },
}

/// Smoothed solutions, one per record.
pub fn smooth(records: &[EpochRecord]) -> Result<Vec<Solution>, SmoothError> {
    let n = records.len();
    let mut out = Vec::with_capacity(n);
    let Some(last) = records.last() else {
        return Ok(out);
    };
    let mut dx_next = ErrorState::zeros();
    let mut p_next = last.posterior_cov.unpack();
    out.push(Solution::forward(last));
    for k in (0..n - 1).rev() {
        let rec = &records[k];
        let next = &records[k + 1];
        let p = rec.posterior_cov.unpack();
        let prior_cov = next.prior_cov(&p);
        let prior_chol = prior_cov
            .cholesky()
            .ok_or(SmoothError::SingularPrior { epoch: k + 1 })?;
        // C = P Phi^T Pp^-1  =>  C^T = Pp^-1 Phi P.
        let gain = prior_chol
            .solve(&(next.phi_from_previous.unpack() * p))
            .transpose();
        let dx = gain * (dx_next + next.correction);
        let p_smooth = p + gain * (p_next - prior_cov) * gain.transpose();
        let p_smooth = (p_smooth + p_smooth.transpose()) * 0.5;
        let post = &rec.posterior;
        let point = NavPoint {
            nav: error_state::inject(&post.nav, &dx),
            gyro_bias: post.gyro_bias + dx.fixed_rows::<3>(idx::GYRO_BIAS),
            accel_bias: post.accel_bias + dx.fixed_rows::<3>(idx::ACCEL_BIAS),
        };
        out.push(Solution::new(
            rec.stamp_ns,
            point,
            &PackedCov::pack(&p_smooth),
        ));
        dx_next = dx;
        p_next = p_smooth;
    }
    out.reverse();
    Ok(out)
}
