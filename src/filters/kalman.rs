//! The Kalman core every filter shares: prediction, Joseph-form update with chi-square
//! gating, and chi-square quantiles.
//!
//! Glossary (textbook symbols, used only in this module and the filters' models):
//! `x` state mean, `P` its covariance, `F` state transition, `Q` process noise,
//! `H` measurement matrix, `R` measurement noise, `y` innovation (measured minus predicted),
//! `S = H P H^T + R` its covariance, `K = P H^T S^-1` the gain, `NIS = y^T S^-1 y` the
//! normalised innovation squared. `N` is the state size, `M` the measurement size.
//!
//! Pure functions: an estimate goes in, an estimate (and a record of the step) comes out.

use crate::small_matrix;
use nalgebra::{SMatrix, SVector};

/// A Gaussian estimate: mean and covariance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gaussian<const N: usize> {
    pub mean: SVector<f64, N>,
    pub cov: SMatrix<f64, N, N>,
}

/// Why an update could not be made.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum KalmanError {
    #[error("innovation covariance is not positive definite (check R and P)")]
    InnovationNotPositiveDefinite,
}

/// What one measurement update did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UpdateRecord<const M: usize> {
    /// Innovation `y`.
    pub innovation: SVector<f64, M>,
    /// Its predicted covariance `S`.
    pub innovation_cov: SMatrix<f64, M, M>,
    /// Normalised innovation squared.
    pub nis: f64,
    /// `ln det S`.
    pub log_det_innovation_cov: f64,
    /// False when the gate rejected the measurement (the estimate is then unchanged).
    pub accepted: bool,
}

/// `x = F x`, `P = F P F^T + Q` (symmetrised).
pub fn predict<const N: usize>(
    prior: &Gaussian<N>,
    f: &SMatrix<f64, N, N>,
    q: &SMatrix<f64, N, N>,
) -> Gaussian<N> {
    let cov = f * prior.cov * f.transpose() + q;
    Gaussian {
        mean: f * prior.mean,
        cov: symmetrised(&cov),
    }
}

/// Measurement update with innovation `y` (measured minus predicted from the prior mean),
/// in Joseph form `P = (I - K H) P (I - K H)^T + K R K^T`, which keeps `P` symmetric positive
/// definite whatever the rounding. With `gate = Some(g)`, a measurement whose NIS exceeds
/// `g` is rejected: the prior comes back unchanged and the record says so.
pub fn update<const N: usize, const M: usize>(
    prior: &Gaussian<N>,
    y: &SVector<f64, M>,
    h: &SMatrix<f64, M, N>,
    r: &SMatrix<f64, M, M>,
    gate: Option<f64>,
) -> Result<(Gaussian<N>, UpdateRecord<M>), KalmanError> {
    update_considering(prior, y, h, r, gate, None)
}

/// [`update`] with consider states (a Schmidt-Kalman update): the gain's rows for the states
/// where `considered[i]` is true are zero, so their estimates never move, while their
/// uncertainty still enters the innovation covariance and the other states' gains. The Joseph
/// form is the right covariance for any gain, so `P` stays honest: a parameter the data
/// cannot tell (a DVL scale factor without fixes) widens the uncertainty it causes instead
/// of being fitted to whatever else is mis-modelled.
pub fn update_considering<const N: usize, const M: usize>(
    prior: &Gaussian<N>,
    y: &SVector<f64, M>,
    h: &SMatrix<f64, M, N>,
    r: &SMatrix<f64, M, M>,
    gate: Option<f64>,
    considered: Option<&[bool; N]>,
) -> Result<(Gaussian<N>, UpdateRecord<M>), KalmanError> {
    let mut cov = prior.cov;
    let (correction, record) = correct_considering(&mut cov, y, h, r, gate, considered)?;
    let posterior = match correction {
        Some(dx) => Gaussian {
            mean: prior.mean + dx,
            cov,
        },
        None => *prior,
    };
    Ok((posterior, record))
}

/// [`update_considering`] on a covariance in place (an error-state filter's mean is zero
/// before each update, so only its covariance goes in): `cov` becomes the posterior
/// covariance and the correction to the mean is returned, or, when the gate rejected the
/// measurement (or on an error), `cov` is left as it was and `None` returned.
pub fn correct_considering<const N: usize, const M: usize>(
    cov: &mut SMatrix<f64, N, N>,
    y: &SVector<f64, M>,
    h: &SMatrix<f64, M, N>,
    r: &SMatrix<f64, M, M>,
    gate: Option<f64>,
    considered: Option<&[bool; N]>,
) -> Result<(Option<SVector<f64, N>>, UpdateRecord<M>), KalmanError> {
    let pht = small_matrix::mul_transpose(cov, h);
    let s = symmetrised(&(small_matrix::mul(h, &pht) + r));
    let chol = s
        .cholesky()
        .ok_or(KalmanError::InnovationNotPositiveDefinite)?;
    let s_inv_y = chol.solve(y);
    let nis = y.dot(&s_inv_y);
    let accepted = gate.is_none_or(|g| nis <= g);
    let log_det_innovation_cov = 2.0
        * chol
            .l_dirty()
            .diagonal()
            .iter()
            .map(|d| d.ln())
            .sum::<f64>();
    let record = UpdateRecord {
        innovation: *y,
        innovation_cov: s,
        nis,
        log_det_innovation_cov,
        accepted,
    };
    if !accepted {
        return Ok((None, record));
    }
    // K = P H^T S^-1 = (S^-1 H P)^T, S symmetric.
    let mut k: SMatrix<f64, N, M> = chol.solve(&pht.transpose()).transpose();
    if let Some(considered) = considered {
        for (i, _) in considered.iter().enumerate().filter(|(_, &c)| c) {
            k.row_mut(i).fill(0.0);
        }
    }
    joseph_in_place(cov, &k, &pht, &s);
    Ok((Some(k * y), record))
}

/// The Joseph form `(I - K H) P (I - K H)^T + K R K^T` for any gain `K`, expanded: with
/// `G = P H^T` and `S = H P H^T + R`, it is `P - K G^T - G K^T + K S K^T`. Summed column by
/// column in one pass over `P`, in place (each column a contiguous run the compiler vectorises, with
/// no N x N temporaries), then made exactly symmetric.
fn joseph_in_place<const N: usize, const M: usize>(
    cov: &mut SMatrix<f64, N, N>,
    k: &SMatrix<f64, N, M>,
    g: &SMatrix<f64, N, M>,
    s: &SMatrix<f64, M, M>,
) {
    let w = k * s;
    let (k, g, w) = (k.as_slice(), g.as_slice(), w.as_slice());
    for (j, column) in cov.as_mut_slice().chunks_exact_mut(N).enumerate() {
        for m in 0..M {
            let (k_m, g_m, w_m) = (&k[m * N..][..N], &g[m * N..][..N], &w[m * N..][..N]);
            let (k_jm, g_jm) = (k_m[j], g_m[j]);
            for (((c, &w_i), &k_i), &g_i) in column.iter_mut().zip(w_m).zip(k_m).zip(g_m) {
                *c += w_i * k_jm - k_i * g_jm - g_i * k_jm;
            }
        }
    }
    small_matrix::symmetrise(cov);
}

fn symmetrised<const N: usize>(m: &SMatrix<f64, N, N>) -> SMatrix<f64, N, N> {
    (m + m.transpose()) * 0.5
}

/// Quantile of the chi-square distribution with `dof` degrees of freedom: the NIS gate that
/// accepts a consistent measurement with probability `p`.
pub fn chi_square_quantile(dof: usize, p: f64) -> f64 {
    assert!(
        dof > 0 && p > 0.0 && p < 1.0,
        "chi-square quantile of dof {dof} at {p}"
    );
    let k = dof as f64 / 2.0;
    let (mut lo, mut hi) = (0.0, (dof as f64 + 10.0) * 10.0);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if regularized_lower_gamma(k, mid / 2.0) < p {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// P(a, x): series below a + 1, continued fraction above (Numerical Recipes 6.2).
fn regularized_lower_gamma(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    let ln_front = a * x.ln() - x - ln_gamma(a);
    if x < a + 1.0 {
        let (mut sum, mut term, mut n) = (1.0 / a, 1.0 / a, a);
        for _ in 0..1000 {
            n += 1.0;
            term *= x / n;
            sum += term;
            if term.abs() < sum.abs() * 1e-16 {
                break;
            }
        }
        sum * ln_front.exp()
    } else {
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut frac = d;
        for i in 1..1000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let delta = d * c;
            frac *= delta;
            if (delta - 1.0).abs() < 1e-16 {
                break;
            }
        }
        1.0 - ln_front.exp() * frac
    }
}

/// ln Gamma(x) for x > 0 (Lanczos, g = 7, 9 terms).
fn ln_gamma(x: f64) -> f64 {
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        let pi = std::f64::consts::PI;
        return (pi / (pi * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let t = x + 7.5;
    let sum = C[1..]
        .iter()
        .enumerate()
        .fold(C[0], |acc, (i, c)| acc + c / (x + i as f64 + 1.0));
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + sum.ln()
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix2, Matrix4, Vector1, Vector2, Vector4};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, StandardNormal};

    fn normal(rng: &mut ChaCha8Rng) -> f64 {
        StandardNormal.sample(rng)
    }

    #[test]
    fn chi_square_quantiles_match_tables() {
        // Standard tables: (dof, p, quantile).
        for (dof, p, q) in [
            (1, 0.95, 3.841),
            (1, 0.99, 6.635),
            (2, 0.95, 5.991),
            (3, 0.99, 11.345),
            (3, 0.999, 16.266),
            (6, 0.95, 12.592),
            (15, 0.975, 27.488),
        ] {
            let got = chi_square_quantile(dof, p);
            assert!((got - q).abs() < 1e-3, "dof {dof} p {p}: {got} vs {q}");
        }
        assert!((ln_gamma(5.0) - 24f64.ln()).abs() < 1e-12);
        assert!((ln_gamma(0.5) - std::f64::consts::PI.sqrt().ln()).abs() < 1e-12);
    }

    #[test]
    fn scalar_filter_averages_like_the_sample_mean() {
        // Estimating a constant from n measurements of variance r: P_n = r / n exactly
        // (from a diffuse prior).
        let r: f64 = 4.0;
        let mut est = Gaussian::<1> {
            mean: Vector1::new(0.0),
            cov: nalgebra::Matrix1::new(1e12),
        };
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let truth = 3.0;
        let mut sum = 0.0;
        for n in 1..=200 {
            let z = truth + r.sqrt() * normal(&mut rng);
            sum += z;
            let y = Vector1::new(z - est.mean[0]);
            let (post, rec) = update(
                &est,
                &y,
                &nalgebra::Matrix1::new(1.0),
                &nalgebra::Matrix1::new(r),
                None,
            )
            .unwrap();
            assert!(rec.accepted);
            est = post;
            assert!((est.cov[0] - r / n as f64).abs() < 1e-9 * r, "n {n}");
            assert!((est.mean[0] - sum / n as f64).abs() < 1e-6);
        }
    }

    #[test]
    fn joseph_update_stays_symmetric_positive_definite_and_consistent() {
        // A 4-state constant-velocity model in 2D observed in position: NIS averages M = 2
        // and P stays symmetric positive definite over many steps.
        let dt = 0.1;
        let f = Matrix4::new(
            1.0, 0.0, dt, 0.0, 0.0, 1.0, 0.0, dt, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
        );
        let q = Matrix4::from_diagonal(&Vector4::new(1e-4, 1e-4, 1e-3, 1e-3));
        let h = nalgebra::Matrix2x4::new(1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0);
        let r = Matrix2::new(0.25, 0.05, 0.05, 0.16);
        let r_chol = r.cholesky().unwrap().l();
        let q_chol = q.cholesky().unwrap().l();
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let mut truth = Vector4::new(0.0, 0.0, 1.0, -0.5);
        let mut est = Gaussian {
            mean: truth,
            cov: Matrix4::identity() * 0.01,
        };
        let (mut nis_sum, n) = (0.0, 5000);
        for _ in 0..n {
            truth = f * truth + q_chol * Vector4::from_fn(|_, _| normal(&mut rng));
            est = predict(&est, &f, &q);
            let z = h * truth + r_chol * Vector2::from_fn(|_, _| normal(&mut rng));
            let (post, rec) = update(&est, &(z - h * est.mean), &h, &r, None).unwrap();
            est = post;
            nis_sum += rec.nis;
            assert_eq!(est.cov, est.cov.transpose());
            assert!(est.cov.cholesky().is_some());
        }
        let mean_nis = nis_sum / n as f64;
        assert!((mean_nis - 2.0).abs() < 0.1, "{mean_nis}");
    }

    /// A consider state keeps its estimate; its uncertainty is kept too (only the cross terms
    /// move), and the other state's variance falls less than with the state estimated.
    #[test]
    fn a_consider_state_is_carried_not_corrected() {
        // x0 measured directly; x1 a bias on the same measurement (y = x0 + x1 + v).
        let prior = Gaussian::<2> {
            mean: Vector2::new(0.0, 0.0),
            cov: Matrix2::new(4.0, 0.0, 0.0, 1.0),
        };
        let h = SMatrix::<f64, 1, 2>::new(1.0, 1.0);
        let r = SMatrix::<f64, 1, 1>::new(0.5);
        let y = SVector::<f64, 1>::new(2.0);
        let (estimated, _) = update(&prior, &y, &h, &r, None).unwrap();
        let (considered, rec) =
            update_considering(&prior, &y, &h, &r, None, Some(&[false, true])).unwrap();
        assert_eq!(considered.mean[1], 0.0);
        assert!((considered.cov[(1, 1)] - 1.0).abs() < 1e-12);
        assert!(estimated.mean[1] != 0.0 && estimated.cov[(1, 1)] < 1.0);
        // x0's gain is the optimal one (S includes x1's variance): 4 / 5.5.
        assert!((considered.mean[0] - 2.0 * 4.0 / 5.5).abs() < 1e-12);
        assert!(considered.cov[(0, 0)] >= estimated.cov[(0, 0)] - 1e-12);
        assert!(considered.cov.cholesky().is_some());
        assert!((rec.innovation_cov[(0, 0)] - 5.5).abs() < 1e-12);
    }

    /// A random 4-state prior, 2-row measurement matrix and noise.
    fn random_problem(
        rng: &mut ChaCha8Rng,
    ) -> (
        Matrix4<f64>,
        nalgebra::Matrix2x4<f64>,
        Matrix2<f64>,
        Gaussian<4>,
    ) {
        let a = Matrix4::from_fn(|_, _| rng.random_range(-1.0..1.0));
        let p = a * a.transpose() + Matrix4::identity() * 0.1;
        let h = nalgebra::Matrix2x4::from_fn(|_, _| rng.random_range(-1.0..1.0));
        let r = Matrix2::new(0.3, 0.1, 0.1, 0.2);
        let prior = Gaussian {
            mean: Vector4::zeros(),
            cov: p,
        };
        (p, h, r, prior)
    }

    #[test]
    fn joseph_equals_the_textbook_form_for_the_optimal_gain() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for _ in 0..100 {
            let (p, h, r, prior) = random_problem(&mut rng);
            let (post, _) = update(&prior, &Vector2::new(0.5, -0.2), &h, &r, None).unwrap();
            let s = h * p * h.transpose() + r;
            let k = p * h.transpose() * s.try_inverse().unwrap();
            let textbook = (Matrix4::identity() - k * h) * p;
            assert!((post.cov - textbook).amax() < 1e-10);
            assert!((post.mean - k * Vector2::new(0.5, -0.2)).amax() < 1e-12);
        }
    }

    /// With a non-optimal gain (a considered state's row zeroed) the update is still the
    /// Joseph form's `(I - K H) P (I - K H)^T + K R K^T`, written out.
    #[test]
    fn update_with_considered_states_is_the_explicit_joseph_form() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        for _ in 0..100 {
            let (p, h, r, prior) = random_problem(&mut rng);
            let considered = [false, true, false, false];
            let y = Vector2::new(0.5, -0.2);
            let (post, _) =
                update_considering(&prior, &y, &h, &r, None, Some(&considered)).unwrap();
            let s = h * p * h.transpose() + r;
            let mut k = p * h.transpose() * s.try_inverse().unwrap();
            k.row_mut(1).fill(0.0);
            let i_kh = Matrix4::identity() - k * h;
            let joseph = i_kh * p * i_kh.transpose() + k * r * k.transpose();
            assert!(
                (post.cov - joseph).amax() < 1e-12,
                "{}",
                (post.cov - joseph).amax()
            );
            assert!((post.mean - k * y).amax() < 1e-12);
        }
    }

    #[test]
    fn gate_rejects_outliers_and_keeps_the_prior() {
        let prior = Gaussian {
            mean: Vector1::new(0.0),
            cov: nalgebra::Matrix1::new(1.0),
        };
        let (h, r) = (nalgebra::Matrix1::new(1.0), nalgebra::Matrix1::new(1.0));
        let gate = chi_square_quantile(1, 0.99);
        let (post, rec) = update(&prior, &Vector1::new(10.0), &h, &r, Some(gate)).unwrap();
        assert!(!rec.accepted);
        assert_eq!(post, prior);
        assert!((rec.nis - 50.0).abs() < 1e-12);
        let (_, rec) = update(&prior, &Vector1::new(1.0), &h, &r, Some(gate)).unwrap();
        assert!(rec.accepted);
        let bad_r = nalgebra::Matrix1::new(-5.0);
        assert_eq!(
            update(&prior, &Vector1::new(1.0), &h, &bad_r, None).unwrap_err(),
            KalmanError::InnovationNotPositiveDefinite
        );
    }
}
