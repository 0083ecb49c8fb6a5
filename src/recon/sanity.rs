//! What can be checked of a reconstruction without a reference (a real log has no `/truth`):
//! the share of the DVL's readings the gate rejected, the smoothed track's length against
//! the DVL's own path, and the top speed. A filter that rejects most of its only velocity
//! sensor has lost the vehicle, and a diverging one draws a track several times longer than
//! the DVL's path, whatever else it prints.

use super::Reconstruction;
use crate::contract::Dvl;
use crate::filters::ins::aid_table::Sensor;
use serde::Serialize;

/// The longest interval between two valid DVL readings over which their path is summed, s.
pub const DVL_PATH_MAX_GAP_S: f64 = 1.0;

/// A reconstruction's figures that need no reference.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Sanity {
    /// DVL readings the filter applied or rejected, and how many it rejected.
    pub dvl_readings: usize,
    pub dvl_rejected: usize,
    /// The smoothed track's length (3-D) through its output epochs (the trajectory table's
    /// rows at the output rate: the epochs of measurements between them add the filter's
    /// millimetre steps at each update, not the vehicle's path), m.
    pub track_length_m: f64,
    /// The integral of the DVL's speed over its valid readings (trapezoids over intervals
    /// under [`DVL_PATH_MAX_GAP_S`]), m: it does not depend on the heading.
    pub dvl_path_m: f64,
    /// The smoothed solution's top speed over ground at its output epochs, m/s.
    pub max_speed_m_s: f64,
}

impl Sanity {
    /// The rejected share of the DVL's readings (0 without any).
    pub fn dvl_rejected_share(&self) -> f64 {
        self.dvl_rejected as f64 / self.dvl_readings.max(1) as f64
    }

    /// The track's length over the DVL's path (`None` without a DVL path).
    pub fn track_over_dvl_path(&self) -> Option<f64> {
        (self.dvl_path_m > 0.0).then(|| self.track_length_m / self.dvl_path_m)
    }
}

/// The figures of `r`, the DVL's path from `dvl` (the log's readings).
pub fn of(r: &Reconstruction, dvl: &[Dvl]) -> std::io::Result<Sanity> {
    let (dvl_readings, dvl_rejected) = r
        .run
        .residuals
        .iter()
        .filter(|x| x.sensor == Sensor::Dvl)
        .fold((0, 0), |(n, k), x| (n + 1, k + usize::from(!x.accepted)));
    let mut track_length_m = 0.0;
    let mut max_speed_m_s: f64 = 0.0;
    let mut previous: Option<(f64, f64, f64)> = None;
    for (s, output) in r.smoothed.iter().zip(r.output.iter()) {
        let s = s?;
        if !output {
            continue;
        }
        let nav = &s.point.nav;
        let here = (nav.lat_rad, nav.lon_rad, nav.height_m);
        if let Some(p) = previous {
            track_length_m += step_m(p, here);
        }
        previous = Some(here);
        max_speed_m_s = max_speed_m_s.max(nav.vel_ned_m_s.norm());
    }
    Ok(Sanity {
        dvl_readings,
        dvl_rejected,
        track_length_m,
        dvl_path_m: dvl_path_m(dvl),
        max_speed_m_s,
    })
}

/// The distance between two nearby positions (latitude, longitude in rad, height in m): the
/// horizontal leg as the distance travelled takes it ([`crate::geodesy::local_north_east_m`]),
/// with the change of height.
fn step_m(a: (f64, f64, f64), b: (f64, f64, f64)) -> f64 {
    let (north, east) = crate::geodesy::local_north_east_m(a.0, a.1, b.0, b.1);
    (north * north + east * east + (b.2 - a.2).powi(2)).sqrt()
}

/// The DVL's own path: the integral of its speed over valid readings.
pub fn dvl_path_m(dvl: &[Dvl]) -> f64 {
    let speed = |d: &Dvl| {
        let [x, y, z] = d.velocity;
        (x * x + y * y + z * z).sqrt()
    };
    dvl.windows(2)
        .filter(|w| w[0].valid && w[1].valid)
        .map(|w| {
            let dt = (w[1].stamp_ns - w[0].stamp_ns) as f64 * 1e-9;
            if dt > 0.0 && dt < DVL_PATH_MAX_GAP_S {
                0.5 * (speed(&w[0]) + speed(&w[1])) * dt
            } else {
                0.0
            }
        })
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn reading(t_s: f64, v: [f64; 3], valid: bool) -> Dvl {
        Dvl {
            stamp_ns: (t_s * 1e9) as i64,
            velocity: v,
            valid,
            altitude: None,
        }
    }

    /// The path sums trapezoids of the speed between valid readings less than a second apart.
    #[test]
    fn the_dvl_path_is_the_integral_of_its_speed_over_valid_readings() {
        let dvl = [
            reading(0.0, [0.3, 0.4, 0.0], true),  // 0.5 m/s
            reading(0.5, [0.0, 0.0, 1.0], true),  // 1 m/s: 0.375 m
            reading(1.0, [1.0, 0.0, 0.0], false), // invalid: nothing either side
            reading(1.5, [1.0, 0.0, 0.0], true),
            reading(3.0, [1.0, 0.0, 0.0], true), // 1.5 s gap: nothing
            reading(3.25, [2.0, 0.0, 0.0], true), // 0.375 m
        ];
        assert!(
            (dvl_path_m(&dvl) - 0.75).abs() < 1e-12,
            "{}",
            dvl_path_m(&dvl)
        );
        assert_eq!(dvl_path_m(&[]), 0.0);
    }
}
