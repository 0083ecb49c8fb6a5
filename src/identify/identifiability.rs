//! Which coefficients the data determine: relative standard deviation and correlation,
//! turned into warnings instead of confident wrong numbers.

use super::settings::Thresholds;
use crate::vehicle::heave_pitch::{Coefficients, NAMES};
use nalgebra::{DMatrix, SMatrix};

/// The correlation matrix of a covariance (zero rows for fixed coefficients).
pub fn correlation(cov: &SMatrix<f64, 10, 10>) -> SMatrix<f64, 10, 10> {
    SMatrix::from_fn(|i, j| {
        let d = (cov[(i, i)] * cov[(j, j)]).sqrt();
        if d > 0.0 {
            cov[(i, j)] / d
        } else if i == j {
            1.0
        } else {
            0.0
        }
    })
}

/// A coefficient's determination.
#[derive(Debug, Clone, PartialEq)]
pub struct Determination {
    pub name: String,
    pub relative_sigma: f64,
    /// The other coefficient it is most correlated with, and the correlation.
    pub most_correlated: Option<(String, f64)>,
    /// Its 1-sigma is above the threshold (`max_relative_sigma` of its value).
    pub poorly_determined: bool,
    /// Its correlation with another is above `max_correlation`: the data determine the two
    /// together (its 1-sigma, marginal, already holds that).
    pub correlated: bool,
}

/// Every estimated coefficient's determination (`fixed` ones are skipped): poorly determined
/// when its relative 1-sigma is above the threshold; correlated when another correlates with
/// it above `max_correlation`.
pub fn assess(
    c: &Coefficients,
    cov: &SMatrix<f64, 10, 10>,
    fixed: &[Option<f64>; 10],
    thresholds: &Thresholds,
) -> Vec<Determination> {
    let free: Vec<bool> = fixed.iter().map(Option::is_none).collect();
    let cov = DMatrix::from_fn(10, 10, |i, j| cov[(i, j)]);
    assess_named(&NAMES, c.as_slice(), &cov, &free, thresholds)
}

/// [`assess`] for any set of coefficients: names, values, covariance, which are estimated.
pub fn assess_named(
    names: &[&str],
    c: &[f64],
    cov: &DMatrix<f64>,
    free: &[bool],
    thresholds: &Thresholds,
) -> Vec<Determination> {
    let n = names.len();
    let corr = |i: usize, j: usize| {
        let d = (cov[(i, i)] * cov[(j, j)]).sqrt();
        if d > 0.0 {
            cov[(i, j)] / d
        } else {
            0.0
        }
    };
    (0..n)
        .filter(|&i| free[i])
        .map(|i| {
            let relative_sigma = cov[(i, i)].sqrt() / c[i].abs().max(f64::MIN_POSITIVE);
            let most_correlated = (0..n)
                .filter(|&j| j != i && free[j])
                .map(|j| (names[j].to_string(), corr(i, j)))
                .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()));
            Determination {
                name: names[i].to_string(),
                relative_sigma,
                poorly_determined: relative_sigma > thresholds.max_relative_sigma,
                correlated: most_correlated
                    .as_ref()
                    .is_some_and(|(_, r)| r.abs() > thresholds.max_correlation),
                most_correlated,
            }
        })
        .collect()
}

impl Determination {
    /// A warning for each of `assessment`'s poorly determined coefficients, and the notes of
    /// those determined only together with another.
    pub fn warnings_and_notes(assessment: &[Determination]) -> (Vec<String>, Vec<String>) {
        let warnings = assessment.iter().filter(|d| d.poorly_determined);
        let notes = assessment.iter().filter_map(|d| d.note());
        (warnings.map(|d| d.to_string()).collect(), notes.collect())
    }

    /// For a coefficient determined only together with another: says so (`None` otherwise,
    /// and for a poorly determined one, whose warning names the correlation).
    pub fn note(&self) -> Option<String> {
        let (other, r) = self.most_correlated.as_ref()?;
        (self.correlated && !self.poorly_determined).then(|| {
            format!(
                "{} is determined together with {other} (correlation {r:+.3}); its 1-sigma, \
                 {:.2} % of its value, holds that",
                self.name,
                self.relative_sigma * 100.0
            )
        })
    }
}

/// The warning for a poorly determined coefficient.
impl std::fmt::Display for Determination {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} is poorly determined: 1-sigma {:.1} % of its value",
            self.name,
            self.relative_sigma * 100.0
        )?;
        if let Some((other, r)) = &self.most_correlated {
            write!(f, ", correlation {r:+.3} with {other}")?;
        }
        Ok(())
    }
}
