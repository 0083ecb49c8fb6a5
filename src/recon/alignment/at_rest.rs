//! Coarse alignment from sensors at rest: roll and pitch by levelling the accelerometers,
//! heading by gyrocompassing or from the magnetometer.
//!
//! At rest, `f^b = C_n^b (-g^n)` and `omega_ib^b = C_n^b omega_ie^n`. Rotating the body
//! vectors by roll and pitch only (`Ry(theta) Rx(phi)`) gives them in the level frame, where
//! the heading is the remaining rotation about the vertical.

use crate::geodesy;
use nalgebra::{Rotation3, Vector3};

/// Roll and pitch (rad) from the mean specific force at rest, body FRD.
pub fn level(mean_specific_force_body: &Vector3<f64>) -> (f64, f64) {
    let f = mean_specific_force_body;
    let roll = (-f.y).atan2(-f.z);
    let pitch = f.x.atan2(f.y.hypot(f.z));
    (roll, pitch)
}

/// A body vector expressed in the level frame (north-aligned but for the heading).
fn levelled(v_body: &Vector3<f64>, roll: f64, pitch: f64) -> Vector3<f64> {
    Rotation3::from_euler_angles(roll, pitch, 0.0) * v_body
}

/// Heading (rad) from the mean gyro output at rest: the Earth rate's horizontal part points
/// north. Needs a gyro whose bias is well below the horizontal Earth rate
/// (15 deg/h times the cosine of the latitude).
pub fn gyrocompass(mean_omega_ib_body: &Vector3<f64>, roll: f64, pitch: f64) -> f64 {
    let w = levelled(mean_omega_ib_body, roll, pitch);
    (-w.y).atan2(w.x)
}

/// Heading (rad) from the magnetometer, with the site's declination (rad, east positive).
pub fn magnetic_heading(
    field_body: &Vector3<f64>,
    roll: f64,
    pitch: f64,
    declination_rad: f64,
) -> f64 {
    let m = levelled(field_body, roll, pitch);
    crate::angle::wrap_pi(declination_rad - m.y.atan2(m.x))
}

/// The horizontal Earth rate at a latitude, rad/s (what gyrocompassing measures).
pub fn horizontal_earth_rate(lat_rad: f64) -> f64 {
    geodesy::OMEGA_IE_RAD_S * lat_rad.cos()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::angle::wrap_pi;
    use rand::{Rng, SeedableRng};

    #[test]
    fn recovers_attitude_from_perfect_sensors_at_rest() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(8);
        let lat = 35f64.to_radians();
        let g = geodesy::gravity_ned_m_s2(lat, -10.0);
        let w_ie = geodesy::earth_rate_ned(lat);
        let declination = -7.8f64.to_radians();
        let field_ned = Vector3::new(
            30_500.0 * declination.cos(),
            30_500.0 * declination.sin(),
            36_000.0,
        ) * 1e-9;
        for _ in 0..500 {
            let roll = rng.random_range(-1.2..1.2);
            let pitch = rng.random_range(-1.3..1.3);
            let yaw = rng.random_range(-3.1..3.1);
            let body_from_ned = Rotation3::from_euler_angles(roll, pitch, yaw).inverse();
            let (r, p) = level(&(body_from_ned * -g));
            assert!(
                (r - roll).abs() < 1e-12 && (p - pitch).abs() < 1e-12,
                "{roll} {pitch}"
            );
            let y = gyrocompass(&(body_from_ned * w_ie), r, p);
            assert!(wrap_pi(y - yaw).abs() < 1e-9, "{yaw} vs {y}");
            let m = magnetic_heading(&(body_from_ned * field_ned), r, p, declination);
            assert!(wrap_pi(m - yaw).abs() < 1e-9, "{yaw} vs {m}");
        }
    }

    #[test]
    fn gyrocompass_error_follows_the_east_gyro_bias() {
        // A bias b on the levelled east axis turns the heading by about b / (Omega cos lat).
        let lat = 35f64.to_radians();
        let w_ie = geodesy::earth_rate_ned(lat);
        let bias = 1e-6; // rad/s, about 0.2 deg/h
        let y = gyrocompass(&(w_ie + Vector3::new(0.0, bias, 0.0)), 0.0, 0.0);
        let expected = -(bias / horizontal_earth_rate(lat));
        assert!(
            (y - expected).abs() < 1e-3 * expected.abs(),
            "{y} vs {expected}"
        );
    }
}
