//! Products of small fixed-size matrices, the inner loop of the filters and the smoother.
//!
//! Each column of a product is a sum of scaled columns, `out[:, j] = sum_k a[:, k] b[k, j]`:
//! contiguous runs the compiler turns into vector instructions. On x86-64 the same loops are
//! compiled a second time for AVX2 (four numbers per instruction instead of two) and chosen
//! at run time where the processor has it. The sums are taken in the same order either way,
//! and no multiply-add is fused, so both give the same numbers to the last bit.

use nalgebra::{ArrayStorage, SMatrix};

/// `a b`.
pub fn mul<const R: usize, const K: usize, const C: usize>(
    a: &SMatrix<f64, R, K>,
    b: &SMatrix<f64, K, C>,
) -> SMatrix<f64, R, C> {
    let (a, b) = (&a.data.0, &b.data.0);
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: `mul_avx2` needs AVX2, which the processor was just seen to have.
        return from_columns(unsafe { mul_avx2(a, b) });
    }
    from_columns(mul_columns(a, b))
}

/// `a b^T`.
pub fn mul_transpose<const R: usize, const K: usize, const C: usize>(
    a: &SMatrix<f64, R, K>,
    b: &SMatrix<f64, C, K>,
) -> SMatrix<f64, R, C> {
    let (a, b) = (&a.data.0, &b.data.0);
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: as in `mul`.
        return from_columns(unsafe { mul_transpose_avx2(a, b) });
    }
    from_columns(mul_transpose_columns(a, b))
}

/// `x` with `x L L^T = g`, for the lower Cholesky factor `L` of a symmetric matrix (only its
/// lower triangle is read): `g` times the matrix's inverse from the right, in place.
///
/// Solved in two triangular sweeps over whole columns, `W L^T = g` then `x L = W`: each step
/// subtracts a multiple of one contiguous column from another (a general solve goes column by
/// right-hand side through dot products of varying length, several times slower at this size).
pub fn right_divide_by_factor<const N: usize>(g: &mut SMatrix<f64, N, N>, l: &SMatrix<f64, N, N>) {
    let (columns, l) = (&mut g.data.0, &l.data.0);
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: as in `mul`.
        return unsafe { right_divide_avx2(columns, l) };
    }
    right_divide(columns, l)
}

/// Factors a symmetric positive definite matrix in place into its lower Cholesky factor `L`
/// (`L L^T` = the matrix; only the lower triangle is read, and the upper triangle is left as
/// it was). False, with the matrix part-way, when a pivot is not positive.
pub fn cholesky_in_place<const N: usize>(m: &mut SMatrix<f64, N, N>) -> bool {
    let columns = &mut m.data.0;
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: as in `mul`.
        return unsafe { cholesky_avx2(columns) };
    }
    cholesky(columns)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn right_divide_avx2<const N: usize>(columns: &mut [[f64; N]; N], l: &[[f64; N]; N]) {
    right_divide(columns, l)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn cholesky_avx2<const N: usize>(columns: &mut [[f64; N]; N]) -> bool {
    cholesky(columns)
}

/// [`right_divide_by_factor`] on the columns of `g`. Each column is accumulated in a local
/// copy (kept in registers) and stored once.
#[inline(always)]
fn right_divide<const N: usize>(cols: &mut [[f64; N]; N], l_columns: &[[f64; N]; N]) {
    // Columns of g, then of W, then of x.
    for i in 0..N {
        let mut column = cols[i];
        for (j, w_j) in cols[..i].iter().enumerate() {
            add_scaled_nonzero(&mut column, w_j, -l_columns[j][i]);
        }
        scale(&mut column, 1.0 / l_columns[i][i]);
        cols[i] = column;
    }
    for i in (0..N).rev() {
        let mut column = cols[i];
        for (j, x_j) in cols.iter().enumerate().skip(i + 1) {
            add_scaled_nonzero(&mut column, x_j, -l_columns[i][j]);
        }
        scale(&mut column, 1.0 / l_columns[i][i]);
        cols[i] = column;
    }
}

/// [`cholesky_in_place`] on the columns: column j less the multiples of the columns before
/// it (over the rows from j down), then scaled by its pivot's root.
#[inline(always)]
fn cholesky<const N: usize>(cols: &mut [[f64; N]; N]) -> bool {
    for j in 0..N {
        let (done, rest) = cols.split_at_mut(j);
        let column = &mut rest[0];
        for l_k in done.iter() {
            let s = -l_k[j];
            if s != 0.0 {
                for (y, x) in column[j..].iter_mut().zip(&l_k[j..]) {
                    *y += x * s;
                }
            }
        }
        let pivot = column[j];
        // Not positive, or not a number.
        if pivot.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            return false;
        }
        let root = pivot.sqrt();
        let inverse = 1.0 / root;
        for y in column[j + 1..].iter_mut() {
            *y *= inverse;
        }
        column[j] = root;
    }
    true
}

/// `y += x s`, skipped when `s` is zero (factors of matrices with held states are sparse).
#[inline(always)]
fn add_scaled_nonzero<const R: usize>(y: &mut [f64; R], x: &[f64; R], s: f64) {
    if s != 0.0 {
        add_scaled(y, x, s);
    }
}

#[inline(always)]
fn scale<const R: usize>(y: &mut [f64; R], s: f64) {
    for y in y.iter_mut() {
        *y *= s;
    }
}

/// Makes `m` symmetric in place: each pair of entries across the diagonal becomes their
/// mean (the same numbers as `(m + m^T) / 2`, without the two temporaries).
pub fn symmetrise<const N: usize>(m: &mut SMatrix<f64, N, N>) {
    for j in 0..N {
        for i in 0..j {
            let mean = (m[(i, j)] + m[(j, i)]) * 0.5;
            m[(i, j)] = mean;
            m[(j, i)] = mean;
        }
    }
}

fn from_columns<const R: usize, const C: usize>(columns: [[f64; R]; C]) -> SMatrix<f64, R, C> {
    SMatrix::from_data(ArrayStorage(columns))
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn mul_avx2<const R: usize, const K: usize, const C: usize>(
    a: &[[f64; R]; K],
    b: &[[f64; K]; C],
) -> [[f64; R]; C] {
    mul_columns(a, b)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn mul_transpose_avx2<const R: usize, const K: usize, const C: usize>(
    a: &[[f64; R]; K],
    b: &[[f64; C]; K],
) -> [[f64; R]; C] {
    mul_transpose_columns(a, b)
}

/// `a b` for matrices given by their columns.
#[inline(always)]
fn mul_columns<const R: usize, const K: usize, const C: usize>(
    a: &[[f64; R]; K],
    b: &[[f64; K]; C],
) -> [[f64; R]; C] {
    let mut out = [[0.0; R]; C];
    for (column, b_j) in out.iter_mut().zip(b) {
        for (a_k, &b_kj) in a.iter().zip(b_j) {
            add_scaled(column, a_k, b_kj);
        }
    }
    out
}

/// `a b^T` for matrices given by their columns.
#[inline(always)]
fn mul_transpose_columns<const R: usize, const K: usize, const C: usize>(
    a: &[[f64; R]; K],
    b: &[[f64; C]; K],
) -> [[f64; R]; C] {
    let mut out = [[0.0; R]; C];
    for (j, column) in out.iter_mut().enumerate() {
        for (a_k, b_k) in a.iter().zip(b) {
            add_scaled(column, a_k, b_k[j]);
        }
    }
    out
}

/// `y += x s`.
#[inline(always)]
fn add_scaled<const R: usize>(y: &mut [f64; R], x: &[f64; R], s: f64) {
    for (y, x) in y.iter_mut().zip(x) {
        *y += x * s;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn random<const R: usize, const C: usize>(rng: &mut ChaCha8Rng) -> SMatrix<f64, R, C> {
        SMatrix::from_fn(|_, _| rng.random_range(-1.0..1.0))
    }

    #[test]
    fn cholesky_matches_nalgebra_and_refuses_what_is_not_positive_definite() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        for _ in 0..20 {
            let a = random::<25, 25>(&mut rng);
            let spd = a * a.transpose() + SMatrix::<f64, 25, 25>::identity() * 0.01;
            let want = spd.cholesky().unwrap().unpack();
            let mut got = spd;
            assert!(cholesky_in_place(&mut got));
            let lower = got.lower_triangle();
            assert!(
                (lower - want).amax() < 1e-10 * want.amax(),
                "{}",
                (lower - want).amax()
            );
            for j in 0..25 {
                for i in 0..j {
                    assert_eq!(
                        got[(i, j)],
                        spd[(i, j)],
                        "above the diagonal: left as it was"
                    );
                }
            }
            let mut plain = spd.data.0;
            assert!(cholesky(&mut plain));
            assert_eq!(got.data.0, plain);
        }
        let mut not_pd = SMatrix::<f64, 3, 3>::identity();
        not_pd[(2, 2)] = -1e-9;
        assert!(!cholesky_in_place(&mut not_pd.clone()));
        not_pd[(2, 2)] = f64::NAN;
        assert!(!cholesky_in_place(&mut not_pd));
    }

    #[test]
    fn symmetrise_gives_the_mean_with_its_transpose() {
        let mut rng = ChaCha8Rng::seed_from_u64(6);
        let m = random::<25, 25>(&mut rng);
        let mut s = m;
        symmetrise(&mut s);
        assert_eq!(s, (m + m.transpose()) * 0.5);
    }

    #[test]
    fn products_match_nalgebra() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let (a, b) = (random::<25, 16>(&mut rng), random::<16, 9>(&mut rng));
        assert!((mul(&a, &b) - a * b).amax() < 1e-13);
        let c = random::<9, 16>(&mut rng);
        assert!((mul_transpose(&a, &c) - a * c.transpose()).amax() < 1e-13);
        let (p, q) = (random::<25, 25>(&mut rng), random::<25, 25>(&mut rng));
        assert!((mul(&p, &q) - p * q).amax() < 1e-13);
        assert!((mul_transpose(&p, &q) - p * q.transpose()).amax() < 1e-13);
    }

    /// The vector path and the plain one take their sums in the same order.
    #[test]
    fn both_paths_give_the_same_bits() {
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        let (p, q) = (random::<25, 25>(&mut rng), random::<25, 25>(&mut rng));
        assert_eq!(mul(&p, &q).data.0, mul_columns(&p.data.0, &q.data.0));
        let plain = mul_transpose_columns(&p.data.0, &q.data.0);
        assert_eq!(mul_transpose(&p, &q).data.0, plain);
    }
}
