//! Scores against `/truth` (simulated logs only): the error of a solution at each of its
//! epochs, and summary figures: horizontal RMS, maximum and final error, and the fraction
//! of epochs whose position NEES lies inside the two-sided 95 % chi-square bounds.

use crate::align::interpolate;
use crate::angle::wrap_pi;
use crate::contract::Truth;
use crate::disk_backed::{Decoder, Encoder, Fixed};
use crate::filters::ins::record::Solution;
use crate::filters::ins::solutions::Solutions;
use crate::filters::kalman::chi_square_quantile;
use crate::geodesy;
use nalgebra::{Matrix2, Vector2, Vector3};
use serde::Serialize;

/// Truth samples further apart than this are not interpolated across.
const MAX_TRUTH_INTERVAL_NS: i64 = 2_000_000_000;

/// The error (estimate minus truth) of a solution at one epoch.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EpochError {
    pub stamp_ns: i64,
    /// North, east, down, m.
    pub position_m: Vector3<f64>,
    pub velocity_m_s: Vector3<f64>,
    /// Roll, pitch, yaw (wrapped), rad.
    pub euler_rad: [f64; 3],
    pub position_sigma_m: Vector3<f64>,
    pub euler_sigma_rad: [f64; 3],
    /// NEES of the horizontal position (2 degrees of freedom) and of the 3-D position.
    pub nees_horizontal: f64,
    pub nees_position: f64,
}

impl EpochError {
    pub fn horizontal_m(&self) -> f64 {
        self.position_m.x.hypot(self.position_m.y)
    }
}

/// The truth can wait on a temporary file while the filter runs (`spill`): it is for the
/// scores only, and a day of it at 10 Hz is 140 MB.
impl Fixed for Truth {
    const BYTES: usize = 8 * 18;

    fn encode(&self, out: &mut Encoder) {
        out.i64(self.stamp_ns);
        out.f64s(&[
            self.latitude_deg,
            self.longitude_deg,
            self.north_m,
            self.east_m,
            self.down_m,
        ]);
        for v in [
            &self.velocity_body,
            &self.velocity_ned,
            &self.attitude,
            &self.angular_velocity,
        ] {
            out.f64s(v);
        }
    }

    fn decode(d: &mut Decoder<'_>) -> Self {
        let stamp_ns = d.i64();
        let [latitude_deg, longitude_deg, north_m, east_m, down_m] = d.f64s();
        Truth {
            stamp_ns,
            latitude_deg,
            longitude_deg,
            north_m,
            east_m,
            down_m,
            velocity_body: d.f64s(),
            velocity_ned: d.f64s(),
            attitude: d.f64s(),
            angular_velocity: d.f64s(),
        }
    }
}

/// The errors of the solutions whose `keep` flag is set (one flag per solution), in time
/// order, skipping epochs the truth does not cover.
pub fn errors(
    truth: &[Truth],
    solutions: &Solutions,
    keep: &[bool],
) -> std::io::Result<Vec<EpochError>> {
    let mut out = Vec::new();
    for (s, &kept) in solutions.iter().zip(keep) {
        let s = s?;
        if kept {
            out.extend(epoch_error(truth, &s));
        }
    }
    Ok(out)
}

/// The error of `solution` against the truth at its stamp (`None` outside the truth's span
/// or across a gap in it).
pub fn epoch_error(truth: &[Truth], solution: &Solution) -> Option<EpochError> {
    let t = interpolate(truth, solution.stamp_ns, MAX_TRUTH_INTERVAL_NS)?;
    let nav = &solution.point.nav;
    let (lat_t, lon_t) = (t.latitude_deg.to_radians(), t.longitude_deg.to_radians());
    let h_t = -t.down_m;
    let rn = geodesy::meridian_radius_m(lat_t) + h_t;
    let re = geodesy::prime_vertical_radius_m(lat_t) + h_t;
    let position_m = Vector3::new(
        (nav.lat_rad - lat_t) * rn,
        wrap_pi(nav.lon_rad - lon_t) * re * lat_t.cos(),
        -nav.height_m - t.down_m,
    );
    let euler = solution.euler_rad();
    let p = solution.position_cov;
    let nees_position = p
        .cholesky()
        .map_or(f64::INFINITY, |c| position_m.dot(&c.solve(&position_m)));
    let horizontal = Vector2::new(position_m.x, position_m.y);
    let nees_horizontal = Matrix2::new(p[(0, 0)], p[(0, 1)], p[(1, 0)], p[(1, 1)])
        .cholesky()
        .map_or(f64::INFINITY, |c| horizontal.dot(&c.solve(&horizontal)));
    Some(EpochError {
        stamp_ns: solution.stamp_ns,
        position_m,
        velocity_m_s: nav.vel_ned_m_s - Vector3::from(t.velocity_ned),
        euler_rad: [0, 1, 2].map(|i| wrap_pi(euler[i] - t.attitude[i])),
        position_sigma_m: Vector3::new(solution.sigma[0], solution.sigma[1], solution.sigma[2]),
        euler_sigma_rad: solution.euler_sigma_rad(),
        nees_horizontal,
        nees_position,
    })
}

/// Summary scores of one solution against the truth.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Scores {
    pub epochs: usize,
    pub horizontal_rms_m: f64,
    pub horizontal_max_m: f64,
    pub horizontal_final_m: f64,
    /// Fraction of epochs whose horizontal-position NEES (2 dof) lies inside the two-sided
    /// 95 % chi-square bounds.
    pub nees_horizontal_inside_95: f64,
    /// Fraction above the upper bound (the filter claims less uncertainty than it has).
    pub nees_horizontal_above_95: f64,
    /// The same for the 3-D position NEES (3 dof).
    pub nees_position_inside_95: f64,
    pub yaw_rms_deg: f64,
}

/// Two-sided 95 % bounds of a chi-square variable with `dof` degrees of freedom.
pub fn bounds_95(dof: usize) -> (f64, f64) {
    (
        chi_square_quantile(dof, 0.025),
        chi_square_quantile(dof, 0.975),
    )
}

/// Scores of a series of epoch errors (`None` when empty).
pub fn scores(errors: &[EpochError]) -> Option<Scores> {
    let mut sums = ScoreSums::default();
    errors.iter().for_each(|e| sums.add(e));
    sums.scores()
}

crate::config::with_defaults! {
    /// The running sums [`Scores`] are made from, taken an epoch at a time: a day's mission
    /// need not hold its million errors to be scored.
    #[derive(Debug, Clone, Copy)]
    pub struct ScoreSums {
        /// The two-sided 95 % bounds of the horizontal (2 dof) and 3-D (3 dof) NEES.
        bounds: [(f64, f64); 2] = [bounds_95(2), bounds_95(3)],
        epochs: usize = 0,
        horizontal_squares_m2: f64 = 0.0,
        horizontal_max_m: f64 = 0.0,
        last_horizontal_m: f64 = 0.0,
        nees_horizontal_inside: usize = 0,
        nees_horizontal_above: usize = 0,
        nees_position_inside: usize = 0,
        yaw_squares_rad2: f64 = 0.0,
    }
}

impl ScoreSums {
    /// Adds the next epoch's error (in time order).
    pub fn add(&mut self, e: &EpochError) {
        let [horizontal, position] = self.bounds;
        let inside = |(lo, hi): (f64, f64), nees: f64| usize::from((lo..=hi).contains(&nees));
        let h = e.horizontal_m();
        self.epochs += 1;
        self.horizontal_squares_m2 += h.powi(2);
        self.horizontal_max_m = self.horizontal_max_m.max(h);
        self.last_horizontal_m = h;
        self.nees_horizontal_inside += inside(horizontal, e.nees_horizontal);
        self.nees_horizontal_above += usize::from(e.nees_horizontal > horizontal.1);
        self.nees_position_inside += inside(position, e.nees_position);
        self.yaw_squares_rad2 += e.euler_rad[2].powi(2);
    }

    /// The scores of the epochs added (`None` before the first).
    pub fn scores(&self) -> Option<Scores> {
        if self.epochs == 0 {
            return None;
        }
        let n = self.epochs as f64;
        Some(Scores {
            epochs: self.epochs,
            horizontal_rms_m: (self.horizontal_squares_m2 / n).sqrt(),
            horizontal_max_m: self.horizontal_max_m,
            horizontal_final_m: self.last_horizontal_m,
            nees_horizontal_inside_95: self.nees_horizontal_inside as f64 / n,
            nees_horizontal_above_95: self.nees_horizontal_above as f64 / n,
            nees_position_inside_95: self.nees_position_inside as f64 / n,
            yaw_rms_deg: (self.yaw_squares_rad2 / n).sqrt().to_degrees(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn error_at(stamp_ns: i64, north_m: f64, east_m: f64, nees_horizontal: f64) -> EpochError {
        EpochError {
            stamp_ns,
            position_m: Vector3::new(north_m, east_m, 0.0),
            velocity_m_s: Vector3::zeros(),
            euler_rad: [0.0, 0.0, 0.01 * stamp_ns as f64],
            position_sigma_m: Vector3::new(1.0, 1.0, 1.0),
            euler_sigma_rad: [0.01; 3],
            nees_horizontal,
            nees_position: nees_horizontal,
        }
    }

    #[test]
    fn running_scores_are_the_figures_of_the_errors() {
        // Horizontal errors 5, 0 and 1 m; NEES 1.0 (inside both bounds), 0.01 (below the
        // 2-dof lower bound 0.0506) and 20 (above both upper bounds).
        let errors = [
            error_at(0, 3.0, 4.0, 1.0),
            error_at(1, 0.0, 0.0, 0.01),
            error_at(2, 0.0, -1.0, 20.0),
        ];
        assert!(ScoreSums::default().scores().is_none());
        let s = scores(&errors).unwrap();
        assert_eq!(s.epochs, 3);
        assert!((s.horizontal_rms_m - (26.0f64 / 3.0).sqrt()).abs() < 1e-12);
        assert_eq!(s.horizontal_max_m, 5.0);
        assert_eq!(s.horizontal_final_m, 1.0);
        assert!((s.nees_horizontal_inside_95 - 1.0 / 3.0).abs() < 1e-12);
        assert!((s.nees_horizontal_above_95 - 1.0 / 3.0).abs() < 1e-12);
        // 3 dof: lower bound 0.216, so 0.01 is below it as well.
        assert!((s.nees_position_inside_95 - 1.0 / 3.0).abs() < 1e-12);
        let yaw_rms_rad = ((0.0f64 + 0.0001 + 0.0004) / 3.0).sqrt();
        assert!((s.yaw_rms_deg - yaw_rms_rad.to_degrees()).abs() < 1e-12);
    }

    #[test]
    fn truth_encodes_exactly() {
        let t = Truth {
            stamp_ns: 1_700_000_000_000_000_001,
            latitude_deg: 35.1,
            longitude_deg: 129.05,
            north_m: 1.5,
            east_m: -2.25,
            down_m: 30.125,
            velocity_body: [1.5, 0.01, -0.02],
            velocity_ned: [0.3, 1.4, 0.0],
            attitude: [0.01, -0.02, 2.5],
            angular_velocity: [1e-3, -2e-3, 3e-3],
        };
        let mut out = Encoder::default();
        t.encode(&mut out);
        let bytes = out.into_bytes();
        assert_eq!(bytes.len(), Truth::BYTES);
        assert_eq!(Truth::decode(&mut Decoder::new(&bytes)), t);
    }
}
