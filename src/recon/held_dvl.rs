//! The uncertainty a held DVL calibration leaves in the position.
//!
//! Without absolute positions far enough apart the DVL's scale factor and heading
//! misalignment cannot be estimated, and the plan holds them at zero (`[dvl]
//! scale_misalignment`). They are still unknown: a real AUV's DVL reads 0.3-0.8 % long or
//! short and 0.2 deg askew (`real-sensor-figures.md`), and neither shows in its innovations.
//! Their prior uncertainty belongs in the reported position sigma, or the NEES against a
//! reference is not honest. They are added as a consider term after the passes, where the
//! estimate is left as it is:
//!
//! a velocity read `(1 + s)` times too long moves the dead-reckoned position by `s` times the
//! horizontal displacement `d` from the start; a heading misalignment `m` by `m` times `d`
//! turned 90 deg about the vertical (`k x d`). With the priors' sigmas, uncorrelated, the
//! horizontal position's covariance gains `sigma_s^2 d d^T + sigma_m^2 (k x d)(k x d)^T`.
//!
//! The DVL's pitch misalignment moves the depth (held by the depth sensor), not the
//! horizontal position, and is left out. So is a run that took an absolute position (GNSS,
//! a fix): it bounds the error after it, and the smoother before it, which a displacement
//! from the start does not describe (`survey`, GNSS at both ends: widened from the start,
//! the smoothed NEES fell inside its bounds at 87.5 % of the epochs, from over 90 %).

use crate::filters::ins::record::Solution;
use crate::geodesy;
use nalgebra::{Matrix2, Vector2};

/// A held scale factor and heading misalignment, their prior sigmas, and where the run
/// started.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeldDvlCalibration {
    pub start_lat_rad: f64,
    pub start_lon_rad: f64,
    /// 1-sigma of the scale factor error (a fraction).
    pub scale_sigma: f64,
    /// 1-sigma of the heading misalignment, rad.
    pub heading_sigma_rad: f64,
}

impl HeldDvlCalibration {
    /// The horizontal covariance the held calibration adds at `(lat_rad, lon_rad)`, m^2.
    pub fn covariance_at(&self, lat_rad: f64, lon_rad: f64) -> Matrix2<f64> {
        let (north, east) =
            geodesy::local_north_east_m(self.start_lat_rad, self.start_lon_rad, lat_rad, lon_rad);
        let d = Vector2::new(north, east);
        let turned = Vector2::new(-east, north);
        self.scale_sigma.powi(2) * d * d.transpose()
            + self.heading_sigma_rad.powi(2) * turned * turned.transpose()
    }

    /// Widens a solution's horizontal position covariance and sigmas by [`Self::covariance_at`].
    pub fn widen(&self, s: &mut Solution) {
        let nav = &s.point.nav;
        let added = self.covariance_at(nav.lat_rad, nav.lon_rad);
        let mut horizontal = s.position_cov.fixed_view_mut::<2, 2>(0, 0);
        horizontal += added;
        s.sigma[0] = s.position_cov[(0, 0)].sqrt();
        s.sigma[1] = s.position_cov[(1, 1)].sqrt();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn held() -> HeldDvlCalibration {
        HeldDvlCalibration {
            start_lat_rad: 0.57,
            start_lon_rad: -2.05,
            scale_sigma: 0.005,
            heading_sigma_rad: 0.3_f64.to_radians(),
        }
    }

    /// At the start nothing is added; 800 m east of it, the along-track sigma is the scale's
    /// share of 800 m (4 m) and the across-track one the misalignment's (4.2 m), and the
    /// covariance stays symmetric positive semi-definite.
    #[test]
    fn the_added_sigma_grows_with_the_distance_along_and_across_the_track() {
        let h = held();
        assert!(h.covariance_at(h.start_lat_rad, h.start_lon_rad).amax() < 1e-18);
        let r = geodesy::prime_vertical_radius_m(h.start_lat_rad) * h.start_lat_rad.cos();
        let p = h.covariance_at(h.start_lat_rad, h.start_lon_rad + 800.0 / r);
        let east_sigma = p[(1, 1)].sqrt();
        let north_sigma = p[(0, 0)].sqrt();
        assert!((east_sigma - 4.0).abs() < 0.01, "{east_sigma}");
        assert!(
            (north_sigma - 800.0 * 0.3_f64.to_radians()).abs() < 0.01,
            "{north_sigma}"
        );
        assert!((p - p.transpose()).amax() < 1e-12);
        assert!(p.symmetric_eigenvalues().min() > -1e-9);
    }
}
