//! The backward pass of a fixed-interval RTS smoother for any error-state filter with
//! resets (the derivation is in `smooth::rts`): given, per forward epoch, the posterior
//! covariance, the transition from the previous epoch, the predicted covariance and the
//! correction the epoch's updates applied, it yields the smoothed error `dx_k|N` (relative to
//! the forward posterior) and its covariance `P_k|N`, last epoch first. Each filter injects
//! `dx` into its own nominal state.

use super::rts::SmoothError;
use nalgebra::{SMatrix, SVector};
use std::borrow::Borrow;

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

/// Runs the backward pass, calling `emit(k, dx_k|N, P_k|N)` for k from the last epoch down
/// to 0.
pub fn backward<const N: usize, E: ForwardEpoch<N>>(
    epochs: &[E],
    mut emit: impl FnMut(usize, &SVector<f64, N>, &SMatrix<f64, N, N>),
) -> Result<(), SmoothError> {
    backward_from_last(
        epochs.len(),
        epochs.iter().rev().map(Ok),
        |k, _: &E, dx, p| emit(k, dx, p),
    )
}

/// [`backward`] over `n` epochs handed over last first (read back from a file, say), calling
/// `emit(k, epoch_k, dx_k|N, P_k|N)`. An epoch that cannot be had ends the pass with its error.
pub fn backward_from_last<const N: usize, E: ForwardEpoch<N>, B: Borrow<E>>(
    n: usize,
    last_first: impl IntoIterator<Item = Result<B, SmoothError>>,
    mut emit: impl FnMut(usize, &E, &SVector<f64, N>, &SMatrix<f64, N, N>),
) -> Result<(), SmoothError> {
    let mut epochs = last_first.into_iter();
    let Some(last) = epochs.next() else {
        return Ok(());
    };
    let mut next = last?;
    let mut k = n.saturating_sub(1);
    let mut dx_next = SVector::<f64, N>::zeros();
    let mut p_next = next.borrow().posterior_cov();
    emit(k, next.borrow(), &dx_next, &p_next);
    for epoch in epochs {
        let epoch = epoch?;
        k = k.saturating_sub(1);
        let (this, after) = (epoch.borrow(), next.borrow());
        let p = this.posterior_cov();
        let prior_cov = after.prior_cov(&p);
        let chol = held_states_unit(&prior_cov)
            .cholesky()
            .ok_or(SmoothError::SingularPrior { epoch: k + 1 })?;
        // C = P Phi^T Pp^-1  =>  C^T = Pp^-1 Phi P.
        let gain = chol.solve(&after.phi_times(&p)).transpose();
        let dx = gain * (dx_next + after.correction());
        let p_smooth = p + gain * (p_next - prior_cov) * gain.transpose();
        let p_smooth = (p_smooth + p_smooth.transpose()) * 0.5;
        emit(k, this, &dx, &p_smooth);
        dx_next = dx;
        p_next = p_smooth;
        next = epoch;
    }
    Ok(())
}
