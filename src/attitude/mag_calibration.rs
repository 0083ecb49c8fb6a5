//! Magnetometer calibration from the log itself: hard iron (an offset) and soft iron (a
//! symmetric distortion) by fitting an ellipsoid to the readings, which lie on a sphere once
//! corrected.
//!
//! A reading is `m = D b_body + h` (D the soft iron, near identity; h the hard iron); the
//! calibration is `W (m - h)` with `W` symmetric, `W ~ D^-1` up to scale (a symmetric fit
//! cannot tell a rotation of the sensor from a distortion, and the scale is set to keep the
//! field's mean magnitude). The fit is linear least squares on the conic's coefficients
//! (readings scaled to order one first).
//!
//! A pool run turns mostly about the vertical: the readings then cover a circle, not a
//! sphere, and the vertical parts of `h` and `D` cannot be found. When the readings' spread
//! along their least-spread direction is under [`MIN_SPREAD_RATIO`] of the largest, the fit
//! is made in the plane of the two others (an ellipse) and leaves the third axis alone:
//! heading, which is what the dead reckoning needs, depends on the horizontal part.
//!
//! Quality: the scatter (standard deviation over mean) of the field's magnitude (3-D), or of
//! its in-plane magnitude (2-D), before and after; and the heading coverage of the readings.

use crate::contract::MagneticField;
use nalgebra::{Matrix2, Matrix3, SMatrix, SVector, SymmetricEigen, Vector2, Vector3};

/// Below this ratio of the least to the largest spread of the readings, the fit is 2-D.
pub const MIN_SPREAD_RATIO: f64 = 0.25;
/// The in-plane directions must cover at least this many of 36 ten-degree sectors.
pub const MIN_SECTORS: usize = 27;
/// A calibration is applied by default only if it takes the magnitude scatter to at most
/// this fraction of what it was (a sensor already calibrated gains nothing worth the risk)...
pub const MAX_SCATTER_RATIO: f64 = 0.8;
/// ... to at most this scatter (more means readings a fixed hard and soft iron do not
/// explain: a field disturbed by magnets or steel near the sensor)...
pub const MAX_SCATTER_AFTER: f64 = 0.05;
/// ... and with a hard iron no larger than this many times the readings' mean magnitude (a
/// larger centre is a fit to a small cap of the sphere, not a calibration).
pub const MAX_HARD_IRON_RATIO: f64 = 1.0;

/// Which fit was made.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum FitKind {
    /// Ellipsoid: all three axes.
    Ellipsoid,
    /// Ellipse in the plane of the readings' two largest spreads; the third axis untouched.
    Ellipse,
}

/// A calibration and how good it is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MagCalibration {
    pub kind: FitKind,
    pub hard_iron: Vector3<f64>,
    /// `W`: calibrated = `W (m - hard_iron)`.
    pub correction: Matrix3<f64>,
    /// Scatter of the (in-plane, for an ellipse) field magnitude, std / mean, before and after.
    pub scatter_before: f64,
    pub scatter_after: f64,
    /// Ten-degree sectors of in-plane direction the readings cover (of 36).
    pub sectors_covered: usize,
    pub readings: usize,
    /// The readings' mean magnitude, T.
    pub mean_magnitude_t: f64,
}

impl MagCalibration {
    pub fn apply(&self, field: &Vector3<f64>) -> Vector3<f64> {
        self.correction * (field - self.hard_iron)
    }

    /// Whether the calibration can be trusted to be applied without being asked for: it
    /// clearly lowers the magnitude scatter, to a small one, with a plausible hard iron.
    pub fn trusted(&self) -> Result<(), Untrusted> {
        if self.scatter_after > MAX_SCATTER_RATIO * self.scatter_before {
            return Err(Untrusted::LittleGain {
                before: self.scatter_before,
                after: self.scatter_after,
            });
        }
        if self.scatter_after > MAX_SCATTER_AFTER {
            return Err(Untrusted::Disturbed(self.scatter_after));
        }
        let ratio = self.hard_iron.norm() / self.mean_magnitude_t;
        if ratio > MAX_HARD_IRON_RATIO {
            return Err(Untrusted::ImplausibleHardIron(ratio));
        }
        Ok(())
    }

    /// The readings calibrated (stamps kept).
    pub fn applied(&self, mag: &[MagneticField]) -> Vec<MagneticField> {
        let mut out = mag.to_vec();
        self.apply_to(&mut out);
        out
    }

    /// Applies the calibration to `mag` in place (no copy of a long log's readings).
    pub fn apply_to(&self, mag: &mut [MagneticField]) {
        for m in mag {
            m.magnetic_field = self.apply(&Vector3::from(m.magnetic_field)).into();
        }
    }
}

/// Why no calibration could be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CalibrationError {
    #[error("{0} magnetometer readings: at least 50 are needed")]
    TooFew(usize),
    #[error(
        "the readings cover {0} of 36 ten-degree heading sectors (at least {MIN_SECTORS} \
         needed): the run does not turn enough to calibrate the magnetometer"
    )]
    NotEnoughTurning(usize),
    #[error("the readings do not fit an ellipsoid (the fitted quadric is not one)")]
    NotAnEllipsoid,
}

/// Why a calibration is not applied by default.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Untrusted {
    #[error(
        "it lowers the field magnitude scatter only from {:.2} % to {:.2} % (the readings look \
         calibrated already)",
        before * 100.0,
        after * 100.0
    )]
    LittleGain { before: f64, after: f64 },
    #[error(
        "the field magnitude still scatters by {:.1} % after it: the field is disturbed \
         (magnets or steel near the sensor), not just offset",
        .0 * 100.0
    )]
    Disturbed(f64),
    #[error("its hard iron is {0:.1} times the field's magnitude: not a plausible fit")]
    ImplausibleHardIron(f64),
}

/// Fits the calibration to the readings.
pub fn fit(mag: &[MagneticField]) -> Result<MagCalibration, CalibrationError> {
    if mag.len() < 50 {
        return Err(CalibrationError::TooFew(mag.len()));
    }
    // Every pass goes over the readings themselves: a day at 50 Hz is millions of them, and
    // no copy of them is made.
    let points = || mag.iter().map(|m| Vector3::from(m.magnetic_field));
    let n = mag.len() as f64;
    let mean = points().sum::<Vector3<f64>>() / n;
    let scatter: Matrix3<f64> = points()
        .map(|p| (p - mean) * (p - mean).transpose())
        .sum::<Matrix3<f64>>()
        / n;
    let eig = SymmetricEigen::new(scatter);
    let mut order = [0usize, 1, 2];
    order.sort_by(|&a, &b| eig.eigenvalues[b].total_cmp(&eig.eigenvalues[a]));
    let axes = Matrix3::from_columns(&order.map(|i| eig.eigenvectors.column(i).into_owned()));
    let spreads = order.map(|i| eig.eigenvalues[i].max(0.0).sqrt());
    // Express the readings in the spread axes (largest first), scaled to order one.
    let scale = points().map(|p| p.norm()).sum::<f64>() / n;
    let local = || points().map(|p| axes.transpose() * p / scale);
    let sectors = sectors_covered(local(), &(axes.transpose() * mean / scale));
    if sectors < MIN_SECTORS {
        return Err(CalibrationError::NotEnoughTurning(sectors));
    }
    let (kind, hard_local, correction_local) = if spreads[2] < MIN_SPREAD_RATIO * spreads[0] {
        let (centre, w) = fit_ellipse(local())?;
        let mut w3 = Matrix3::identity();
        w3.fixed_view_mut::<2, 2>(0, 0).copy_from(&w);
        (FitKind::Ellipse, Vector3::new(centre.x, centre.y, 0.0), w3)
    } else {
        let (centre, w) = fit_ellipsoid(local())?;
        (FitKind::Ellipsoid, centre, w)
    };
    let hard_iron = axes * hard_local * scale;
    let correction = axes * correction_local * axes.transpose();
    let magnitude = |v: &Vector3<f64>| match kind {
        FitKind::Ellipsoid => v.norm(),
        FitKind::Ellipse => (axes.transpose() * v).xy().norm(),
    };
    let before = || points().map(|p| magnitude(&p));
    let after = || points().map(|p| magnitude(&(correction * (p - hard_iron))));
    Ok(MagCalibration {
        kind,
        hard_iron,
        correction,
        scatter_before: relative_scatter(before),
        scatter_after: relative_scatter(after),
        sectors_covered: sectors,
        readings: mag.len(),
        mean_magnitude_t: scale,
    })
}

/// Ten-degree sectors covered by the in-plane (first two axes) directions about `centre`.
fn sectors_covered(local: impl Iterator<Item = Vector3<f64>>, centre: &Vector3<f64>) -> usize {
    let mut hit = [false; 36];
    for p in local {
        let d = p - centre;
        let a = d.y.atan2(d.x).to_degrees().rem_euclid(360.0);
        hit[((a / 10.0) as usize).min(35)] = true;
    }
    hit.iter().filter(|&&h| h).count()
}

/// The spread of the values over their mean, from a pass that can be made twice.
fn relative_scatter<I: Iterator<Item = f64>>(values: impl Fn() -> I) -> f64 {
    let n = values().count() as f64;
    let mean = values().sum::<f64>() / n;
    let var = values().map(|v| (v - mean).powi(2)).sum::<f64>() / n;
    var.sqrt() / mean
}

/// Least squares for `rows * coefficients = 1`, through the normal equations summed row by
/// row (no design matrix: a day of readings is millions of rows).
fn least_squares<const K: usize>(
    rows: impl Iterator<Item = SVector<f64, K>>,
) -> Option<SVector<f64, K>> {
    let mut ata = SMatrix::<f64, K, K>::zeros();
    let mut atb = SVector::<f64, K>::zeros();
    for r in rows {
        ata += r * r.transpose();
        atb += r;
    }
    ata.cholesky().map(|c| c.solve(&atb))
}

/// The ellipse `x^T M x + 2 g^T x = 1` through the first two coordinates: its centre and
/// the symmetric `W` that maps it onto a circle of its mean radius.
fn fit_ellipse(
    local: impl Iterator<Item = Vector3<f64>>,
) -> Result<(Vector2<f64>, Matrix2<f64>), CalibrationError> {
    let rows = local.map(|p| {
        SVector::<f64, 5>::from([p.x * p.x, p.y * p.y, 2.0 * p.x * p.y, 2.0 * p.x, 2.0 * p.y])
    });
    let c = least_squares(rows).ok_or(CalibrationError::NotAnEllipsoid)?;
    let m = Matrix2::new(c[0], c[2], c[2], c[1]);
    let g = Vector2::new(c[3], c[4]);
    let centre = -m.try_inverse().ok_or(CalibrationError::NotAnEllipsoid)? * g;
    let k = 1.0 + centre.dot(&(m * centre));
    let shape = m / k;
    let eig = SymmetricEigen::new(shape);
    if eig.eigenvalues.min() <= 0.0 {
        return Err(CalibrationError::NotAnEllipsoid);
    }
    // W = sqrt(shape) scaled by the geometric-mean radius.
    let radius = eig.eigenvalues.product().powf(-0.25);
    let root = eig.eigenvectors
        * Matrix2::from_diagonal(&eig.eigenvalues.map(f64::sqrt))
        * eig.eigenvectors.transpose();
    Ok((centre, root * radius))
}

/// The ellipsoid `x^T M x + 2 g^T x = 1`: its centre and `W`, as [`fit_ellipse`].
fn fit_ellipsoid(
    local: impl Iterator<Item = Vector3<f64>>,
) -> Result<(Vector3<f64>, Matrix3<f64>), CalibrationError> {
    let rows = local.map(|p| {
        SVector::<f64, 9>::from([
            p.x * p.x,
            p.y * p.y,
            p.z * p.z,
            2.0 * p.x * p.y,
            2.0 * p.x * p.z,
            2.0 * p.y * p.z,
            2.0 * p.x,
            2.0 * p.y,
            2.0 * p.z,
        ])
    });
    let c = least_squares(rows).ok_or(CalibrationError::NotAnEllipsoid)?;
    let m = Matrix3::new(c[0], c[3], c[4], c[3], c[1], c[5], c[4], c[5], c[2]);
    let g = Vector3::new(c[6], c[7], c[8]);
    let centre = -m.try_inverse().ok_or(CalibrationError::NotAnEllipsoid)? * g;
    let k = 1.0 + centre.dot(&(m * centre));
    let shape = m / k;
    let eig = SymmetricEigen::new(shape);
    if eig.eigenvalues.min() <= 0.0 {
        return Err(CalibrationError::NotAnEllipsoid);
    }
    let radius = eig.eigenvalues.product().powf(-1.0 / 6.0);
    let root = eig.eigenvectors
        * Matrix3::from_diagonal(&eig.eigenvalues.map(f64::sqrt))
        * eig.eigenvectors.transpose();
    Ok((centre, root * radius))
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Rotation3, UnitQuaternion};
    use rand::{Rng, SeedableRng};
    use rand_distr::{Distribution, StandardNormal};

    fn reading(stamp_ns: i64, field: Vector3<f64>) -> MagneticField {
        MagneticField {
            stamp_ns,
            magnetic_field: field.into(),
        }
    }

    const FIELD_NED: [f64; 3] = [29_800e-9, -4_100e-9, 38_900e-9];

    fn distortion() -> (Matrix3<f64>, Vector3<f64>) {
        let soft = Matrix3::new(0.02, 0.005, 0.0, 0.005, -0.01, 0.0, 0.0, 0.0, 0.01);
        (
            Matrix3::identity() + soft,
            Vector3::new(600e-9, -300e-9, 200e-9),
        )
    }

    /// Readings at attitudes from all over the sphere: the ellipsoid fit recovers the hard
    /// iron to the noise and makes the magnitude constant.
    #[test]
    fn an_ellipsoid_from_tumbling_readings() {
        let (d, h) = distortion();
        let mag = tumbling(d, h, 50e-9, 0.0);
        let cal = fit(&mag).unwrap();
        assert_eq!(cal.kind, FitKind::Ellipsoid);
        assert!((cal.hard_iron - h).norm() < 10e-9, "{:?}", cal.hard_iron);
        // W D is a multiple of the identity (W undoes the symmetric distortion).
        let wd = cal.correction * d;
        assert!(
            (wd / wd[(0, 0)] - Matrix3::identity()).abs().max() < 2e-3,
            "{wd}"
        );
        assert!(
            cal.scatter_before > 0.01 && cal.scatter_after < 0.003,
            "{cal:?}"
        );
        assert_eq!(cal.trusted(), Ok(()));
    }

    /// Readings from all over the sphere with the given distortion and noise, and every
    /// 7th reading pulled by a magnet near the sensor (`magnet_t`, 0 for none).
    fn tumbling(
        d: Matrix3<f64>,
        h: Vector3<f64>,
        noise_t: f64,
        magnet_t: f64,
    ) -> Vec<MagneticField> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(63);
        let field = Vector3::from(FIELD_NED);
        (0..3000)
            .map(|k| {
                let q: UnitQuaternion<f64> =
                    UnitQuaternion::from_scaled_axis(Vector3::from_fn(|_, _| {
                        rng.random_range(-3.0..3.0)
                    }));
                let noise = Vector3::from_fn(|_, _| {
                    let n: f64 = StandardNormal.sample(&mut rng);
                    n * noise_t
                });
                let magnet = if k % 7 == 0 {
                    Vector3::new(magnet_t, 0.5 * magnet_t, 0.0)
                } else {
                    Vector3::zeros()
                };
                reading(k, d * (q.inverse() * field) + h + noise + magnet)
            })
            .collect()
    }

    /// What is applied without being asked for: a real hard iron, yes; a sensor already
    /// calibrated, or a field disturbed by a magnet, no.
    #[test]
    fn only_a_clear_gain_is_trusted() {
        let five_ut = Vector3::new(4000e-9, -3000e-9, 0.0);
        let cal = fit(&tumbling(Matrix3::identity(), five_ut, 300e-9, 0.0)).unwrap();
        assert_eq!(cal.trusted(), Ok(()), "{cal:?}");
        let calibrated = fit(&tumbling(
            Matrix3::identity(),
            Vector3::zeros(),
            300e-9,
            0.0,
        ));
        assert!(matches!(
            calibrated.unwrap().trusted(),
            Err(Untrusted::LittleGain { .. })
        ),);
        let disturbed = fit(&tumbling(Matrix3::identity(), five_ut, 300e-9, 30e-6)).unwrap();
        assert!(disturbed.trusted().is_err(), "{disturbed:?}");
    }

    /// A level vehicle turning about the vertical: an ellipse, the horizontal hard iron
    /// found, the heading error of the distortion removed.
    #[test]
    fn an_ellipse_from_turning_readings() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(62);
        let (d, h) = distortion();
        let field = Vector3::from(FIELD_NED);
        let attitudes: Vec<Rotation3<f64>> = (0..3000)
            .map(|k| {
                let yaw = k as f64 * 0.003;
                Rotation3::from_euler_angles(0.02 * (k as f64 * 0.05).sin(), 0.01, yaw)
            })
            .collect();
        let mag: Vec<MagneticField> = attitudes
            .iter()
            .enumerate()
            .map(|(k, r)| {
                let noise = Vector3::from_fn(|_, _| {
                    let n: f64 = StandardNormal.sample(&mut rng);
                    n * 100e-9
                });
                reading(k as i64, d * (r.inverse() * field) + h + noise)
            })
            .collect();
        let cal = fit(&mag).unwrap();
        assert_eq!(cal.kind, FitKind::Ellipse);
        assert!(
            (cal.hard_iron.xy() - h.xy()).norm() < 30e-9,
            "{:?}",
            cal.hard_iron
        );
        let heading_error = |m: &Vector3<f64>, r: &Rotation3<f64>| {
            let (roll, pitch, _) = r.euler_angles();
            let got = crate::recon::alignment::at_rest::magnetic_heading(m, roll, pitch, 0.0);
            let true_heading = crate::recon::alignment::at_rest::magnetic_heading(
                &(r.inverse() * field),
                roll,
                pitch,
                0.0,
            );
            crate::angle::wrap_pi(got - true_heading).abs()
        };
        let rms = |f: &dyn Fn(&Vector3<f64>) -> Vector3<f64>| {
            let sum: f64 = mag
                .iter()
                .zip(&attitudes)
                .map(|(m, r)| heading_error(&f(&Vector3::from(m.magnetic_field)), r).powi(2))
                .sum();
            (sum / mag.len() as f64).sqrt().to_degrees()
        };
        // The noise alone: 100 nT on a 30 uT horizontal field, about 0.19 deg.
        let (before, after) = (rms(&|m| *m), rms(&|m| cal.apply(m)));
        assert!(
            before > 1.0 && after < 0.25,
            "heading RMS {before} -> {after} deg"
        );
    }

    #[test]
    fn a_straight_run_is_refused() {
        let field = Vector3::from(FIELD_NED);
        let mag: Vec<MagneticField> = (0..500)
            .map(|k| {
                let r = Rotation3::from_euler_angles(0.0, 0.0, k as f64 * 1e-3);
                reading(k, r.inverse() * field)
            })
            .collect();
        assert!(matches!(
            fit(&mag),
            Err(CalibrationError::NotEnoughTurning(_))
        ));
    }
}
