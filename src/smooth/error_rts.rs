//! The backward pass of a fixed-interval RTS smoother for any error-state filter with
//! resets (the derivation is in `smooth::rts`): given, per forward epoch, the posterior
//! covariance, the transition from the previous epoch, the predicted covariance and the
//! correction the epoch's updates applied, it yields the smoothed error `dx_k|N` (relative to
//! the forward posterior) and its covariance `P_k|N`, last epoch first. Each filter injects
//! `dx` into its own nominal state.

use super::rts::SmoothError;
use crate::small_matrix;
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
    /// [`ForwardEpoch::posterior_cov`] into `out` (a filter that keeps it packed unpacks it
    /// in place).
    fn posterior_cov_into(&self, out: &mut SMatrix<f64, N, N>) {
        *out = self.posterior_cov();
    }
    /// [`ForwardEpoch::prior_cov`] of the previous posterior `P` into `prior`, and `P Phi^T`
    /// (the transpose of [`ForwardEpoch::phi_times`], `P` symmetric) into `p_phi_t` (a filter
    /// can share the work of the two, and write the second in place).
    fn prior_cov_and_p_phi_t(
        &self,
        previous_posterior: &SMatrix<f64, N, N>,
        prior: &mut SMatrix<f64, N, N>,
        p_phi_t: &mut SMatrix<f64, N, N>,
    ) {
        *prior = self.prior_cov(previous_posterior);
        p_phi_t.tr_copy_from(&self.phi_times(previous_posterior));
    }
    /// Correction this epoch's updates applied, prior to posterior.
    fn correction(&self) -> SVector<f64, N>;
    /// A smoothed error and its covariance at this epoch, carried from the posterior's error
    /// coordinates to the prior's: the inverse of the filter's reset. The identity (the
    /// default) for a filter that carries its covariance over unchanged.
    fn to_prior_coordinates(&self, _dx: &mut SVector<f64, N>, _p: &mut SMatrix<f64, N, N>) {}
}

/// `cov` with a unit variance in place of each exactly zero one. A state held at its value
/// (zero prior variance, no process noise) has a zero row and column, which would make the
/// covariance singular; its gain row, `P Phi^T` times the inverse, is zero either way, so the
/// unit stands in for the inverse of nothing.
fn held_states_unit<const N: usize>(c: &mut SMatrix<f64, N, N>) {
    for i in 0..N {
        if c[(i, i)] == 0.0 && c.row(i).iter().all(|v| *v == 0.0) {
            c[(i, i)] = 1.0;
        }
    }
}

/// The RTS gain `C = P Phi^T Pp^-1` in place of `P Phi^T` (`gain`), given the lower Cholesky
/// factor `L` of `Pp` (only its lower triangle is read): divided by `L L^T` from the right.
fn rts_gain<const N: usize>(gain: &mut SMatrix<f64, N, N>, l: &SMatrix<f64, N, N>) {
    small_matrix::right_divide_by_factor(gain, l);
}

/// Runs the backward pass, calling `emit(k, dx_k|N, P_k|N)` for k from the last epoch down
/// to 0.
pub fn backward<const N: usize, E: ForwardEpoch<N> + Sync>(
    epochs: &[E],
    mut emit: impl FnMut(usize, &SVector<f64, N>, &SMatrix<f64, N, N>),
) -> Result<(), SmoothError> {
    backward_from_last(
        epochs.len(),
        epochs.iter().rev().map(Ok),
        |k, _: &E, dx, p| emit(k, dx, p),
    )
}

/// Below this many states the backward pass runs on the calling thread alone: handing the
/// epochs between threads would cost more than the work it shares.
const TWO_THREADS_FROM_STATES: usize = 9;

/// Epochs handed from the preparing thread to the recursion at a time.
const BATCH: usize = 64;

/// [`backward`] over `n` epochs handed over last first (read back from a file, say), calling
/// `emit(k, epoch_k, dx_k|N, P_k|N)`. An epoch that cannot be had ends the pass with its error.
///
/// The work splits in two: each epoch's link to the next (its posterior covariance, the
/// predicted covariance and the gain) depends on the forward records alone ([`Prepare`]),
/// and only the recursion through the smoothed estimates is sequential. With
/// [`TWO_THREADS_FROM_STATES`] states or more, the links are prepared on a second thread
/// while the calling thread runs the recursion; the result is the same either way. The
/// prepared epochs (kilobytes each) travel in boxes the recursion hands back for reuse, so
/// nothing that size is allocated or copied per epoch.
pub fn backward_from_last<const N: usize, E, B>(
    n: usize,
    last_first: impl IntoIterator<Item = Result<B, SmoothError>, IntoIter: Send>,
    emit: impl FnMut(usize, &E, &SVector<f64, N>, &SMatrix<f64, N, N>),
) -> Result<(), SmoothError>
where
    E: ForwardEpoch<N>,
    B: Borrow<E> + Send,
{
    let (recycle, recycled) = std::sync::mpsc::channel();
    let prepared = Prepare::<_, _, E, N>::new(n, last_first.into_iter(), recycled);
    let hand_back = |used| {
        // The preparing side has finished: the box is simply dropped.
        let _ = recycle.send(used);
    };
    if N < TWO_THREADS_FROM_STATES {
        return recursion(n, prepared, emit, hand_back);
    }
    std::thread::scope(|scope| {
        let (to_recursion, from_prepare) = std::sync::mpsc::sync_channel::<Vec<_>>(4);
        scope.spawn(move || {
            let mut batch = Vec::with_capacity(BATCH);
            for item in prepared {
                let failed = item.is_err();
                batch.push(item);
                if batch.len() == BATCH || failed {
                    let full = std::mem::replace(&mut batch, Vec::with_capacity(BATCH));
                    // The recursion hung up (it failed): nothing more to do.
                    if to_recursion.send(full).is_err() || failed {
                        return;
                    }
                }
            }
            let _ = to_recursion.send(batch);
        });
        recursion(n, from_prepare.into_iter().flatten(), emit, hand_back)
    })
}

/// One epoch with what the recursion needs from the forward records alone.
struct Prepared<B, const N: usize> {
    epoch: B,
    /// What links this epoch to the next one; `None` at the last epoch.
    link: Option<Link<N>>,
}

/// What links epoch k to epoch k+1, from the forward records alone.
struct Link<const N: usize> {
    /// The posterior covariance `P_k` (unpacked once, here).
    posterior_cov: SMatrix<f64, N, N>,
    /// The predicted covariance `P_{k+1|k}`.
    prior_cov: SMatrix<f64, N, N>,
    /// The RTS gain `C_k = P_k Phi^T P_{k+1|k}^-1`.
    gain: SMatrix<f64, N, N>,
}

impl<const N: usize> Link<N> {
    fn zeros() -> Self {
        Link {
            posterior_cov: SMatrix::zeros(),
            prior_cov: SMatrix::zeros(),
            gain: SMatrix::zeros(),
        }
    }

    /// Fills the link from epoch k (`epoch`) to epoch k+1 (`after`, at index `k_after`) in
    /// place; `scratch` is room for the Cholesky factor of the predicted covariance.
    fn fill<E: ForwardEpoch<N>>(
        &mut self,
        epoch: &E,
        after: &E,
        k_after: usize,
        scratch: &mut Scratch<N>,
    ) -> Result<(), SmoothError> {
        epoch.posterior_cov_into(&mut self.posterior_cov);
        after.prior_cov_and_p_phi_t(&self.posterior_cov, &mut self.prior_cov, &mut self.gain);
        let factor = &mut scratch.factor;
        factor.copy_from(&self.prior_cov);
        held_states_unit(factor);
        if !small_matrix::cholesky_in_place(factor) {
            return Err(SmoothError::SingularPrior { epoch: k_after });
        }
        rts_gain(&mut self.gain, factor);
        Ok(())
    }
}

/// The matrix [`Link::fill`] works in, kept from one epoch to the next.
struct Scratch<const N: usize> {
    factor: SMatrix<f64, N, N>,
}

/// The epochs, last first, prepared: an epoch goes out once the one before it has been read,
/// since its link needs that one's posterior covariance.
struct Prepare<I, B, E, const N: usize> {
    epochs: I,
    /// The type the epochs are borrowed as.
    epoch_type: std::marker::PhantomData<fn() -> E>,
    /// The epoch read last, not yet handed out.
    pending: Option<Result<Box<Prepared<B, N>>, SmoothError>>,
    /// Index of the pending epoch.
    k: usize,
    /// Boxes the recursion has finished with.
    recycled: std::sync::mpsc::Receiver<Box<Prepared<B, N>>>,
    /// Room for the links' intermediate matrices.
    scratch: Box<Scratch<N>>,
}

impl<I, B, E, const N: usize> Prepare<I, B, E, N> {
    fn new(
        n: usize,
        mut epochs: I,
        recycled: std::sync::mpsc::Receiver<Box<Prepared<B, N>>>,
    ) -> Self
    where
        I: Iterator<Item = Result<B, SmoothError>>,
        E: ForwardEpoch<N>,
        B: Borrow<E>,
    {
        let pending = epochs
            .next()
            .map(|last| last.map(|epoch| Box::new(Prepared { epoch, link: None })));
        Prepare {
            epochs,
            epoch_type: std::marker::PhantomData,
            pending,
            k: n.saturating_sub(1),
            recycled,
            scratch: Box::new(Scratch {
                factor: SMatrix::zeros(),
            }),
        }
    }

    /// A box for `epoch`: one handed back by the recursion, or a new one.
    fn boxed(&self, epoch: B) -> Box<Prepared<B, N>> {
        match self.recycled.try_recv() {
            Ok(mut used) => {
                used.epoch = epoch;
                used
            }
            Err(_) => Box::new(Prepared { epoch, link: None }),
        }
    }
}

impl<I, B, E, const N: usize> Iterator for Prepare<I, B, E, N>
where
    I: Iterator<Item = Result<B, SmoothError>>,
    E: ForwardEpoch<N>,
    B: Borrow<E>,
{
    type Item = Result<Box<Prepared<B, N>>, SmoothError>;

    fn next(&mut self) -> Option<Self::Item> {
        let pending = match self.pending.take()? {
            Ok(pending) => pending,
            Err(e) => return Some(Err(e)),
        };
        let Some(epoch) = self.epochs.next() else {
            return Some(Ok(pending));
        };
        let this_k = self.k.saturating_sub(1);
        self.pending = Some(epoch.and_then(|epoch| {
            let mut item = self.boxed(epoch);
            let link = item.link.get_or_insert_with(Link::zeros);
            link.fill(
                item.epoch.borrow(),
                pending.epoch.borrow(),
                self.k,
                &mut self.scratch,
            )?;
            Ok(item)
        }));
        self.k = this_k;
        Some(Ok(pending))
    }
}

/// The sequential part: `dx_k|N = C_k (dx_{k+1|N} + D_{k+1})` and
/// `P_k|N = P_k + C_k (P_{k+1|N} - P_{k+1|k}) C_k^T`, from the last epoch down, with epoch
/// k+1's smoothed error and covariance first carried to its prior's coordinates
/// ([`ForwardEpoch::to_prior_coordinates`]). Each epoch's
/// box goes to `hand_back` once the recursion is done with it.
fn recursion<const N: usize, E: ForwardEpoch<N>, B: Borrow<E>>(
    n: usize,
    prepared: impl IntoIterator<Item = Result<Box<Prepared<B, N>>, SmoothError>>,
    mut emit: impl FnMut(usize, &E, &SVector<f64, N>, &SMatrix<f64, N, N>),
    mut hand_back: impl FnMut(Box<Prepared<B, N>>),
) -> Result<(), SmoothError> {
    // The epoch after the current one, with its smoothed error and covariance.
    let mut next: Option<(Box<Prepared<B, N>>, SVector<f64, N>)> = None;
    let mut p_next = SMatrix::<f64, N, N>::zeros();
    for (item, k) in prepared.into_iter().zip((0..n).rev()) {
        let item = item?;
        let dx = match (&item.link, &next) {
            (Some(link), Some((after, dx_next))) => {
                let (after, gain) = (after.epoch.borrow(), &link.gain);
                let mut dx_after = *dx_next;
                after.to_prior_coordinates(&mut dx_after, &mut p_next);
                let dx = gain * (dx_after + after.correction());
                p_next -= &link.prior_cov;
                let spread = small_matrix::mul(gain, &p_next);
                p_next = small_matrix::mul_transpose(&spread, gain);
                p_next += &link.posterior_cov;
                small_matrix::symmetrise(&mut p_next);
                dx
            }
            _ => {
                p_next = item.epoch.borrow().posterior_cov();
                SVector::zeros()
            }
        };
        emit(k, item.epoch.borrow(), &dx, &p_next);
        if let Some((used, _)) = next.replace((item, dx)) {
            hand_back(used);
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DMatrix;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    type M<const N: usize> = SMatrix<f64, N, N>;
    type V<const N: usize> = SVector<f64, N>;

    fn random_matrix<const R: usize, const C: usize>(rng: &mut ChaCha8Rng) -> SMatrix<f64, R, C> {
        SMatrix::from_fn(|_, _| rng.random_range(-1.0..1.0))
    }

    fn random_spd<const K: usize>(rng: &mut ChaCha8Rng) -> SMatrix<f64, K, K> {
        let a = random_matrix::<K, K>(rng);
        a * a.transpose() + SMatrix::<f64, K, K>::identity() * 0.1
    }

    #[test]
    fn gain_matches_a_general_solve() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        for _ in 0..20 {
            let pp = random_spd::<25>(&mut rng);
            let phi_p = random_matrix::<25, 25>(&mut rng);
            let chol = pp.cholesky().unwrap();
            let want = chol.solve(&phi_p).transpose();
            let mut got = phi_p.transpose();
            rts_gain(&mut got, chol.l_dirty());
            assert!(
                (got - want).amax() < 1e-9 * want.amax(),
                "{}",
                (got - want).amax()
            );
        }
    }

    /// One epoch of a linear Kalman filter with a 2-D measurement, kept as the
    /// backward pass wants it (its mean is the nominal, the correction its update).
    struct Epoch<const N: usize> {
        phi: M<N>,
        q: M<N>,
        posterior: V<N>,
        posterior_cov: M<N>,
        correction: V<N>,
        /// The filter's reset after the update: posterior coordinates = `reset` times the
        /// prior's.
        reset: M<N>,
    }

    impl<const N: usize> ForwardEpoch<N> for Epoch<N> {
        fn posterior_cov(&self) -> M<N> {
            self.posterior_cov
        }
        fn phi(&self) -> M<N> {
            self.phi
        }
        fn prior_cov(&self, previous_posterior: &M<N>) -> M<N> {
            self.phi * previous_posterior * self.phi.transpose() + self.q
        }
        fn correction(&self) -> V<N> {
            self.correction
        }
        fn to_prior_coordinates(&self, dx: &mut V<N>, p: &mut M<N>) {
            let back = self.reset.try_inverse().unwrap();
            *dx = back * *dx;
            *p = back * *p * back.transpose();
        }
    }

    /// The backward pass over a linear model equals the batch solution: the joint posterior
    /// of all states given all measurements, from one information matrix.
    #[test]
    fn backward_pass_equals_the_batch_solution_of_a_linear_model() {
        // On the calling thread alone, and with the links prepared on a second thread.
        const { assert!(4 < TWO_THREADS_FROM_STATES && 10 >= TWO_THREADS_FROM_STATES) };
        equals_the_batch_solution::<4>(3, 25, false);
        equals_the_batch_solution::<10>(4, 2 * BATCH + 13, false);
    }

    /// With a reset after each update (the filter carries its covariance into new error
    /// coordinates, `filters::ins::heading_reset`), the pass undoes it at each epoch
    /// ([`ForwardEpoch::to_prior_coordinates`]) and still equals the batch solution, in each
    /// epoch's posterior coordinates.
    #[test]
    fn backward_pass_with_resets_equals_the_batch_solution() {
        equals_the_batch_solution::<4>(5, 25, true);
        equals_the_batch_solution::<10>(6, BATCH + 7, true);
    }

    fn equals_the_batch_solution<const N: usize>(seed: u64, epochs_n: usize, resets: bool) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let (m0, p0) = (V::<N>::from_fn(|i, _| i as f64), random_spd::<N>(&mut rng));
        let h = random_matrix::<2, N>(&mut rng);
        let r = random_spd::<2>(&mut rng);
        let (mut epochs, mut ys, mut phis, mut qs) =
            (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let (mut mean, mut cov) = (m0, p0);
        let mut resets_made: Vec<M<N>> = Vec::new();
        for k in 0..epochs_n {
            let (phi, q) = if k == 0 {
                (M::<N>::identity(), M::<N>::zeros())
            } else {
                (
                    M::<N>::identity() + random_matrix::<N, N>(&mut rng) * 0.2,
                    random_spd::<N>(&mut rng) * 0.05,
                )
            };
            let prior_mean = phi * mean;
            let prior_cov = phi * cov * phi.transpose() + q;
            let y = SVector::<f64, 2>::from_fn(|_, _| rng.random_range(-3.0..3.0));
            let s = h * prior_cov * h.transpose() + r;
            let gain = prior_cov * h.transpose() * s.try_inverse().unwrap();
            mean = prior_mean + gain * (y - h * prior_mean);
            cov = (M::<N>::identity() - gain * h) * prior_cov;
            cov = (cov + cov.transpose()) * 0.5;
            let reset = if resets {
                M::<N>::identity() + random_matrix::<N, N>(&mut rng) * 0.3
            } else {
                M::<N>::identity()
            };
            // The stored transition takes the previous epoch's posterior coordinates.
            let from_previous = match resets_made.last() {
                Some(before) => phi * before.try_inverse().unwrap(),
                None => phi,
            };
            epochs.push(Epoch {
                phi: from_previous,
                q,
                posterior: reset * mean,
                posterior_cov: reset * cov * reset.transpose(),
                correction: mean - prior_mean,
                reset,
            });
            resets_made.push(reset);
            ys.push(y);
            phis.push(phi);
            qs.push(q);
        }
        let mut smoothed = vec![(V::<N>::zeros(), M::<N>::zeros()); epochs_n];
        backward(&epochs, |k, dx, p| {
            smoothed[k] = (epochs[k].posterior + dx, *p)
        })
        .unwrap();

        let (joint_mean, joint_cov) = batch_solution((&m0, &p0), &h, &r, &ys, &phis, &qs);
        for (k, (mean, cov)) in smoothed.iter().enumerate() {
            let j = DMatrix::from_column_slice(N, N, resets_made[k].as_slice());
            let want_mean = &j * joint_mean.rows(k * N, N);
            let want_cov = &j * joint_cov.view((k * N, k * N), (N, N)) * j.transpose();
            assert!(
                (mean - &want_mean).amax() < 1e-8,
                "epoch {k}: mean {mean} against {want_mean}"
            );
            assert!(
                (cov - &want_cov).amax() < 1e-8,
                "epoch {k}: cov {cov} against {want_cov}"
            );
        }
    }

    /// The joint posterior of all states given all measurements (mean and covariance, the
    /// states stacked), from one information matrix: the batch solution the backward pass
    /// must equal. The prior `(m0, P0)`, each epoch's measurement `y_k = H x_k + v`, `v ~ R`,
    /// and transition `x_k = Phi_k x_{k-1} + w`, `w ~ Q_k`.
    fn batch_solution<const N: usize>(
        (m0, p0): (&V<N>, &M<N>),
        h: &SMatrix<f64, 2, N>,
        r: &M<2>,
        ys: &[SVector<f64, 2>],
        phis: &[M<N>],
        qs: &[M<N>],
    ) -> (nalgebra::DVector<f64>, DMatrix<f64>) {
        // Minimise the sum of the prior, process and measurement terms over all states.
        let epochs_n = ys.len();
        let dim = N * epochs_n;
        let (mut info, mut rhs) = (
            DMatrix::<f64>::zeros(dim, dim),
            nalgebra::DVector::<f64>::zeros(dim),
        );
        let mut add =
            |rows: &[(usize, DMatrix<f64>)], w: &DMatrix<f64>, z: &nalgebra::DVector<f64>| {
                // A term (sum_i A_i x_i - z)^T W (sum_i A_i x_i - z).
                for (bi, ai) in rows {
                    for (bj, aj) in rows {
                        let block = ai.transpose() * w * aj;
                        let mut view = info.view_mut((bi * N, bj * N), (N, N));
                        view += block;
                    }
                    let mut view = rhs.rows_mut(bi * N, N);
                    view += ai.transpose() * w * z;
                }
            };
        let dm = |m: &M<N>| DMatrix::from_column_slice(N, N, m.as_slice());
        let inv = |m: &M<N>| dm(&m.try_inverse().unwrap());
        add(
            &[(0, dm(&M::<N>::identity()))],
            &inv(p0),
            &nalgebra::DVector::from_column_slice(m0.as_slice()),
        );
        let h_d = DMatrix::from_column_slice(2, N, h.as_slice());
        let r_inv = DMatrix::from_column_slice(2, 2, r.try_inverse().unwrap().as_slice());
        for k in 0..epochs_n {
            if k > 0 {
                let z = nalgebra::DVector::zeros(N);
                add(
                    &[(k, dm(&M::<N>::identity())), (k - 1, -dm(&phis[k]))],
                    &inv(&qs[k]),
                    &z,
                );
            }
            add(
                &[(k, h_d.clone())],
                &r_inv,
                &nalgebra::DVector::from_column_slice(ys[k].as_slice()),
            );
        }
        let joint_cov = info.try_inverse().unwrap();
        let joint_mean = &joint_cov * &rhs;
        (joint_mean, joint_cov)
    }

    #[test]
    fn an_epoch_that_cannot_be_read_ends_the_pass_with_its_error() {
        fails_after_four_epochs::<4>();
        fails_after_four_epochs::<10>();
    }

    fn fails_after_four_epochs<const N: usize>() {
        let epoch = || Epoch::<N> {
            phi: M::<N>::identity(),
            q: M::<N>::identity(),
            posterior: V::<N>::zeros(),
            posterior_cov: M::<N>::identity(),
            correction: V::<N>::zeros(),
            reset: M::<N>::identity(),
        };
        let last_first = (0..2 * BATCH).map(|i| {
            if i == 4 {
                Err(SmoothError::Records("disk gone".into()))
            } else {
                Ok(epoch())
            }
        });
        let mut emitted = Vec::new();
        let result = backward_from_last(2 * BATCH, last_first, |k, _: &Epoch<N>, _, _| {
            emitted.push(k)
        });
        assert_eq!(result, Err(SmoothError::Records("disk gone".into())));
        let n = 2 * BATCH;
        assert_eq!(emitted, vec![n - 1, n - 2, n - 3, n - 4]);
    }
}
