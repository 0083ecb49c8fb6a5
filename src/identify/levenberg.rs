//! The Levenberg-Marquardt core shared by the output-error refinements (heave-pitch and
//! 6-DOF): weighted least squares over a parameter vector, given the normal equations at any
//! parameters.

use nalgebra::{DMatrix, DVector};

/// The normal equations at some parameters: `J^T W J`, `J^T W r` and `r^T W r`, with `r`
/// measured minus modelled; `extra` is whatever else the evaluation gives (residual sums per
/// channel, ...).
#[derive(Debug, Clone, PartialEq)]
pub struct Normal<E> {
    pub a: DMatrix<f64>,
    pub b: DVector<f64>,
    pub cost: f64,
    pub extra: E,
}

impl<E> Normal<E> {
    /// Holds parameter `i` where it is: its row and column leave the equations (a unit
    /// diagonal keeps the matrix invertible, and the step for it is zero).
    pub fn hold(&mut self, i: usize) {
        self.a.row_mut(i).fill(0.0);
        self.a.column_mut(i).fill(0.0);
        self.a[(i, i)] = 1.0;
        self.b[i] = 0.0;
    }
}

/// Where the minimisation ended.
#[derive(Debug, Clone, PartialEq)]
pub struct Minimum<E> {
    pub parameters: DVector<f64>,
    /// The normal equations there.
    pub normal: Normal<E>,
    pub iterations: usize,
    pub converged: bool,
}

/// Minimises `r^T W r` from `start`, with scale-free damping (lambda times the diagonal).
/// Converged: the cost falls by less than `1e-10` of itself in a step, or no step lowers it
/// (at the minimum to rounding). A `normal` whose cost is not finite (a model that cannot be
/// simulated there) is a refused step; from `start`, it ends the minimisation unconverged.
pub fn minimise<E>(
    start: DVector<f64>,
    max_iterations: usize,
    mut normal: impl FnMut(&DVector<f64>) -> Normal<E>,
) -> Minimum<E> {
    let mut at = Minimum {
        normal: normal(&start),
        parameters: start,
        iterations: 0,
        converged: false,
    };
    if !at.normal.cost.is_finite() {
        return at;
    }
    let mut lambda = 1e-3;
    while at.iterations < max_iterations {
        at.iterations += 1;
        let mut damped = at.normal.a.clone();
        for i in 0..damped.nrows() {
            damped[(i, i)] *= 1.0 + lambda;
        }
        let Some(step) = damped.cholesky().map(|ch| ch.solve(&at.normal.b)) else {
            lambda *= 10.0;
            continue;
        };
        let trial = &at.parameters + step;
        let n = normal(&trial);
        if n.cost.is_finite() && n.cost < at.normal.cost {
            let relative_drop = (at.normal.cost - n.cost) / at.normal.cost;
            at.parameters = trial;
            at.normal = n;
            lambda = (lambda / 10.0).max(1e-12);
            if relative_drop < 1e-10 {
                at.converged = true;
                break;
            }
        } else {
            lambda *= 10.0;
            if lambda > 1e12 {
                at.converged = true;
                break;
            }
        }
    }
    at
}

/// The inverse of the normal matrix (the parameters' covariance at unit noise): NaN where it
/// is not positive definite.
pub fn inverse(a: &DMatrix<f64>) -> DMatrix<f64> {
    let n = a.nrows();
    a.clone()
        .cholesky()
        .map(|ch| ch.inverse())
        .unwrap_or_else(|| DMatrix::from_element(n, n, f64::NAN))
}

/// The first `k` parameters' information with the rest (nuisance parameters: initial states,
/// biases) marginalised out: the Schur complement `A_kk - A_kn A_nn^-1 A_nk`, whose inverse
/// is their covariance.
pub fn marginal_information(a: &DMatrix<f64>, k: usize) -> DMatrix<f64> {
    let n = a.nrows() - k;
    let akk = a.view((0, 0), (k, k));
    let akn = a.view((0, k), (k, n));
    let ann = a.view((k, k), (n, n)).into_owned();
    match ann.cholesky() {
        Some(ch) => akk - akn * ch.solve(&akn.transpose()),
        None => DMatrix::from_element(k, k, f64::NAN),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A linear problem: the minimum is the least-squares solution, and the Schur complement
    /// inverts to the covariance's leading block.
    #[test]
    fn solves_a_linear_problem_and_marginalises() {
        let jac = DMatrix::from_row_slice(4, 3, &[1., 0., 1., 1., 1., 0., 0., 2., 1., 3., 1., 1.]);
        let y = DVector::from_row_slice(&[1.0, 2.0, 0.5, 4.0]);
        let m = minimise(DVector::zeros(3), 50, |p| {
            let r = &y - &jac * p;
            Normal {
                a: jac.transpose() * &jac,
                b: jac.transpose() * &r,
                cost: r.norm_squared(),
                extra: (),
            }
        });
        assert!(m.converged);
        let exact = (jac.transpose() * &jac)
            .cholesky()
            .unwrap()
            .solve(&(jac.transpose() * &y));
        assert!((&m.parameters - exact).norm() < 1e-9);
        let cov = inverse(&m.normal.a);
        let marginal = marginal_information(&m.normal.a, 2);
        let back = inverse(&marginal);
        for i in 0..2 {
            for j in 0..2 {
                assert!((back[(i, j)] - cov[(i, j)]).abs() < 1e-12);
            }
        }
    }
}
