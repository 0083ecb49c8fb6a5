//! The backward pass of a fixed-interval RTS smoother for any error-state filter with
//! resets (the derivation is in `smooth::rts`): given, per forward epoch, the posterior
//! covariance, the transition from the previous epoch, the predicted covariance and the
//! correction the epoch's updates applied, it yields the smoothed error `dx_k|N` (relative to
//! the forward posterior) and its covariance `P_k|N`, last epoch first. Each filter injects
//! `dx` into its own nominal state.

use super::rts::SmoothError;
use nalgebra::{SMatrix, SVector};

/// What the backward pass needs from one forward epoch.
pub trait ForwardEpoch<const N: usize> {
    /// Covariance after this epoch's updates.
    fn posterior_cov(&self) -> SMatrix<f64, N, N>;
    /// Transition from the previous epoch to this one.
    fn phi(&self) -> SMatrix<f64, N, N>;
    /// `Phi m` (a filter whose transition has structure can skip its zeros).
    fn phi_times(&self, m: &SMatrix<f64, N, N>) -> SMatrix<f64, N, N> {
        self.phi() * m
    }
    /// Covariance predicted to this epoch from the previous epoch's posterior.
    fn prior_cov(&self, previous_posterior: &SMatrix<f64, N, N>) -> SMatrix<f64, N, N>;
    /// Correction this epoch's updates applied, prior to posterior.
    fn correction(&self) -> SVector<f64, N>;
}

/// Runs the backward pass, calling `emit(k, dx_k|N, P_k|N)` for k from the last epoch down
/// to 0.
/// `cov` with a unit variance in place of each exactly zero one. A state held at its value
/// (zero prior variance, no process noise) has a zero row and column, which would make the
/// covariance singular; its gain row, `P Phi^T` times the inverse, is zero either way, so the
/// unit stands in for the inverse of nothing.
fn held_states_unit<const N: usize>(cov: &SMatrix<f64, N, N>) -> SMatrix<f64, N, N> {
    let mut c = *cov;
    for i in 0..N {
        if c[(i, i)] == 0.0 && c.row(i).iter().all(|v| *v == 0.0) {
            c[(i, i)] = 1.0;
        }
    }
    c
}

pub fn backward<const N: usize, E: ForwardEpoch<N>>(
    epochs: &[E],
    mut emit: impl FnMut(usize, &SVector<f64, N>, &SMatrix<f64, N, N>),
) -> Result<(), SmoothError> {
    let Some(last) = epochs.last() else {
        return Ok(());
    };
    let n = epochs.len();
    let mut dx_next = SVector::<f64, N>::zeros();
    let mut p_next = last.posterior_cov();
    emit(n - 1, &dx_next, &p_next);
    for k in (0..n - 1).rev() {
        let next = &epochs[k + 1];
        let p = epochs[k].posterior_cov();
        let prior_cov = next.prior_cov(&p);
        let chol = held_states_unit(&prior_cov)
            .cholesky()
            .ok_or(SmoothError::SingularPrior { epoch: k + 1 })?;
        // C = P Phi^T Pp^-1  =>  C^T = Pp^-1 Phi P.
        let gain = chol.solve(&next.phi_times(&p)).transpose();
        let dx = gain * (dx_next + next.correction());
        let p_smooth = p + gain * (p_next - prior_cov) * gain.transpose();
        let p_smooth = (p_smooth + p_smooth.transpose()) * 0.5;
        emit(k, &dx, &p_smooth);
        dx_next = dx;
        p_next = p_smooth;
    }
    Ok(())
}
