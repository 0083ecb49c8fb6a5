//! Attitude errors against a reference, as BROAD scores them: with both attitudes as
//! nav-from-body quaternions, the error rotation `q_err = q_est * q_ref^-1` (in the earth
//! frame) splits into its whole angle (total), its part about the vertical (heading) and
//! the part that tilts the vertical (inclination). RMS in degrees over the scored samples.

use super::AttitudeSample;
use crate::contract::Truth;
use nalgebra::UnitQuaternion;

/// The attitude of `/truth` (Euler angles) as quaternions.
pub fn reference_from_truth(truth: &[Truth]) -> Vec<AttitudeSample> {
    truth
        .iter()
        .map(|t| AttitudeSample {
            stamp_ns: t.stamp_ns,
            ned_from_body: UnitQuaternion::from_euler_angles(
                t.attitude[0],
                t.attitude[1],
                t.attitude[2],
            ),
        })
        .collect()
}

/// The three parts of one attitude error, rad.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AttitudeError {
    pub total: f64,
    pub heading: f64,
    pub inclination: f64,
}

/// The error of `estimate` against `reference` (both nav-from-body).
pub fn attitude_error(
    estimate: &UnitQuaternion<f64>,
    reference: &UnitQuaternion<f64>,
) -> AttitudeError {
    let q = (estimate * reference.inverse()).into_inner();
    let (w, z) = (q.w.abs(), q.k);
    AttitudeError {
        total: 2.0 * w.min(1.0).acos(),
        heading: 2.0 * (z.abs() / w).atan(),
        inclination: 2.0 * (q.w * q.w + z * z).sqrt().min(1.0).acos(),
    }
}

/// RMS of the three errors, degrees.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct AttitudeRms {
    pub samples: usize,
    pub total_deg: f64,
    pub heading_deg: f64,
    pub inclination_deg: f64,
}

impl AttitudeRms {
    /// From `n` samples' sums of squared errors (total, heading, inclination), rad^2.
    pub fn of(n: usize, sums: [f64; 3]) -> AttitudeRms {
        let rms = |s: f64| (s / n as f64).sqrt().to_degrees();
        AttitudeRms {
            samples: n,
            total_deg: rms(sums[0]),
            heading_deg: rms(sums[1]),
            inclination_deg: rms(sums[2]),
        }
    }
}

/// RMS errors of `estimates` against `reference` at the stamps they share (both sorted by
/// stamp) and that `scored` accepts; `None` when no stamp is scored.
pub fn rms(
    estimates: &[AttitudeSample],
    reference: &[AttitudeSample],
    scored: impl Fn(i64) -> bool,
) -> Option<AttitudeRms> {
    let (mut i, mut n) = (0, 0usize);
    let mut sums = [0.0; 3];
    for r in reference {
        if !scored(r.stamp_ns) {
            continue;
        }
        while i < estimates.len() && estimates[i].stamp_ns < r.stamp_ns {
            i += 1;
        }
        let Some(e) = estimates.get(i).filter(|e| e.stamp_ns == r.stamp_ns) else {
            continue;
        };
        let err = attitude_error(&e.ned_from_body, &r.ned_from_body);
        sums[0] += err.total.powi(2);
        sums[1] += err.heading.powi(2);
        sums[2] += err.inclination.powi(2);
        n += 1;
    }
    (n > 0).then(|| AttitudeRms::of(n, sums))
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    #[test]
    fn splits_heading_and_inclination() {
        let reference = UnitQuaternion::from_euler_angles(2.9, 0.4, -1.0);
        // A pure turn about the vertical (earth frame) is all heading.
        let turned = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 0.1) * reference;
        let e = attitude_error(&turned, &reference);
        assert!((e.total - 0.1).abs() < 1e-12 && (e.heading - 0.1).abs() < 1e-12);
        assert!(e.inclination.abs() < 1e-7);
        // A tilt about a horizontal earth axis is all inclination.
        let tilted = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), 0.05) * reference;
        let e = attitude_error(&tilted, &reference);
        assert!((e.inclination - 0.05).abs() < 1e-12 && e.heading.abs() < 1e-12);
    }
}
