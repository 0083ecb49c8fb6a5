//! Magnetometer: the site's Earth field seen in the body, distorted by the vehicle's soft
//! iron (a matrix) and offset by its hard iron (a vector), plus white noise:
//! `m = (I + soft) C_n^b B_n + hard + n`.

use super::normal;
use nalgebra::{Matrix3, Rotation3, Vector3};
use rand_chacha::ChaCha8Rng;

/// Parameters of the magnetometer, nanotesla.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MagSpec {
    pub rate_hz: f64,
    /// Earth field at the site in NED, nT (from a field model such as WMM for the site).
    pub field_ned_nt: [f64; 3],
    /// Hard-iron offset in the body, nT.
    #[serde(default)]
    pub hard_iron_nt: [f64; 3],
    /// Soft-iron distortion, rows of a matrix added to the identity.
    #[serde(default)]
    pub soft_iron: [[f64; 3]; 3],
    /// 1-sigma white noise per axis, nT.
    #[serde(default)]
    pub noise_nt: f64,
    /// Steel near the track (a pool's wall, a pier): its field added to the Earth's.
    #[serde(default)]
    pub steel: Option<SteelSpec>,
}

/// A local disturbance of the field: `field_ned_nt` at the point, fading as a Gaussian of
/// the horizontal distance from it with `radius_m`.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SteelSpec {
    pub north_m: f64,
    pub east_m: f64,
    pub radius_m: f64,
    pub field_ned_nt: [f64; 3],
}

impl SteelSpec {
    /// Its field at a point, tesla, NED.
    fn field_ned_t(&self, north_m: f64, east_m: f64) -> Vector3<f64> {
        let d2 = (north_m - self.north_m).powi(2) + (east_m - self.east_m).powi(2);
        let fade = (-0.5 * d2 / self.radius_m.powi(2).max(1e-6)).exp();
        Vector3::from(self.field_ned_nt) * 1e-9 * fade
    }
}

/// The magnetometer of one run.
#[derive(Debug, Clone)]
pub struct MagSensor {
    field_ned_t: Vector3<f64>,
    distortion: Matrix3<f64>,
    hard_iron_t: Vector3<f64>,
    noise_t: f64,
    steel: Option<SteelSpec>,
    rng: ChaCha8Rng,
}

impl MagSensor {
    pub fn new(spec: MagSpec, rng: ChaCha8Rng) -> Self {
        let nt = 1e-9;
        MagSensor {
            field_ned_t: Vector3::from(spec.field_ned_nt) * nt,
            distortion: Matrix3::identity() + Matrix3::from_fn(|i, j| spec.soft_iron[i][j]),
            hard_iron_t: Vector3::from(spec.hard_iron_nt) * nt,
            noise_t: spec.noise_nt * nt,
            steel: spec.steel,
            rng,
        }
    }

    /// Field measured in the body, tesla (away from any steel).
    pub fn measure(&mut self, ned_from_body: &Rotation3<f64>) -> Vector3<f64> {
        self.measure_at(ned_from_body, f64::INFINITY, f64::INFINITY)
    }

    /// Field measured in the body at a place (north, east from the origin, m), tesla.
    pub fn measure_at(
        &mut self,
        ned_from_body: &Rotation3<f64>,
        north_m: f64,
        east_m: f64,
    ) -> Vector3<f64> {
        let noise = Vector3::from_fn(|_, _| self.noise_t * normal(&mut self.rng));
        let steel = self
            .steel
            .filter(|_| north_m.is_finite() && east_m.is_finite())
            .map_or(Vector3::zeros(), |s| s.field_ned_t(north_m, east_m));
        let field = ned_from_body.inverse() * (self.field_ned_t + steel);
        self.distortion * field + self.hard_iron_t + noise
    }
}

#[cfg(test)]
mod tests {
    use super::super::{rng_for, stream};
    use super::*;

    #[test]
    fn recovers_hard_iron_and_noise() {
        let spec = MagSpec {
            steel: None,
            rate_hz: 50.0,
            field_ned_nt: [30_000.0, -4_000.0, 40_000.0],
            hard_iron_nt: [500.0, -200.0, 100.0],
            soft_iron: [[0.0; 3]; 3],
            noise_nt: 50.0,
        };
        let mut m = MagSensor::new(spec, rng_for(1, stream::MAG));
        // Headings all round: the mean of the rotated Earth field's horizontal part vanishes,
        // leaving the hard iron (and the vertical field on z).
        let n = 36_000;
        let mut sum = Vector3::zeros();
        let mut sq = 0.0;
        for k in 0..n {
            let yaw = k as f64 / n as f64 * std::f64::consts::TAU;
            let r = Rotation3::from_euler_angles(0.0, 0.0, yaw);
            let x = m.measure(&r);
            let clean = r.inverse() * Vector3::from(spec.field_ned_nt) * 1e-9
                + Vector3::from(spec.hard_iron_nt) * 1e-9;
            sq += (x - clean).x.powi(2);
            sum += x;
        }
        let mean_nt = sum / n as f64 * 1e9;
        assert!(
            (mean_nt.x - 500.0).abs() < 2.0 && (mean_nt.y + 200.0).abs() < 2.0,
            "{mean_nt}"
        );
        assert!((mean_nt.z - 40_100.0).abs() < 2.0, "{mean_nt}");
        assert!(((sq / n as f64).sqrt() * 1e9 / 50.0 - 1.0).abs() < 0.03);
    }
}
