//! WGS-84: the ellipsoid, Earth rate, radii of curvature, normal gravity, transport rate.
//!
//! Heights are ellipsoidal, positive up (`height_m = -depth_m` for a vehicle at a surface
//! of zero height). Vectors are in the local NED frame.

use nalgebra::Vector3;

/// Semi-major axis, m.
pub const A_M: f64 = 6_378_137.0;
/// Flattening.
pub const F: f64 = 1.0 / 298.257_223_563;
/// First eccentricity squared.
pub const E2: f64 = F * (2.0 - F);
/// Earth rotation rate, rad/s.
pub const OMEGA_IE_RAD_S: f64 = 7.292_115e-5;
/// Normal gravity at the equator, m/s^2 (Somigliana).
pub const GAMMA_EQUATOR_M_S2: f64 = 9.780_325_335_9;
/// Somigliana's constant k = (b gamma_p - a gamma_e) / (a gamma_e).
pub const SOMIGLIANA_K: f64 = 0.001_931_852_652_41;
/// m = omega^2 a^2 b / GM.
pub const M_RATIO: f64 = 0.003_449_786_506_84;
/// Standard gravity, m/s^2 (for unit conversions only, not for navigation).
pub const G0_M_S2: f64 = 9.806_65;

/// What the navigation equations need at one latitude and height, with the trigonometry
/// and square root done once: the mechanization evaluates Earth rate, transport rate, gravity
/// and position rates four times per IMU sample, and each alone took its own sines.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Local {
    pub lat_rad: f64,
    pub sin_lat: f64,
    pub cos_lat: f64,
    pub height_m: f64,
    /// `sqrt(1 - e^2 sin^2 lat)`.
    root: f64,
    /// Meridian radius of curvature R_N, m.
    pub meridian_radius_m: f64,
    /// Prime-vertical radius of curvature R_E, m.
    pub prime_vertical_radius_m: f64,
    /// `1 / root`, `1 / (R_N + h)`, `1 / (R_E + h)` and `1 / cos lat`: the rates multiply by
    /// these (four divisions here instead of eight across the rates and gravity).
    inverse_root: f64,
    inverse_meridian_plus_height: f64,
    inverse_prime_vertical_plus_height: f64,
    inverse_cos_lat: f64,
}

impl Local {
    pub fn at(lat_rad: f64, height_m: f64) -> Local {
        let (sin_lat, cos_lat) = lat_rad.sin_cos();
        Self::from_sin_cos(lat_rad, sin_lat, cos_lat, height_m)
    }

    fn from_sin_cos(lat_rad: f64, sin_lat: f64, cos_lat: f64, height_m: f64) -> Local {
        let w = 1.0 - E2 * sin_lat * sin_lat;
        let root = w.sqrt();
        let inverse_root = 1.0 / root;
        let meridian_radius_m = A_M * (1.0 - E2) * inverse_root * inverse_root * inverse_root;
        let prime_vertical_radius_m = A_M * inverse_root;
        Local {
            lat_rad,
            sin_lat,
            cos_lat,
            height_m,
            root,
            meridian_radius_m,
            prime_vertical_radius_m,
            inverse_root,
            inverse_meridian_plus_height: 1.0 / (meridian_radius_m + height_m),
            inverse_prime_vertical_plus_height: 1.0 / (prime_vertical_radius_m + height_m),
            inverse_cos_lat: 1.0 / cos_lat,
        }
    }

    /// R_N + h and R_E + h, m.
    pub fn radii_plus_height_m(&self) -> (f64, f64) {
        (
            self.meridian_radius_m + self.height_m,
            self.prime_vertical_radius_m + self.height_m,
        )
    }

    /// d R_N / d latitude, m/rad.
    pub fn meridian_radius_derivative(&self) -> f64 {
        let (s, c) = (self.sin_lat, self.cos_lat);
        3.0 * A_M * (1.0 - E2) * E2 * s * c / self.root.powi(5)
    }

    /// d R_E / d latitude, m/rad.
    pub fn prime_vertical_radius_derivative(&self) -> f64 {
        let (s, c) = (self.sin_lat, self.cos_lat);
        A_M * E2 * s * c / self.root.powi(3)
    }

    /// Normal gravity magnitude (Somigliana's formula with the second-order free-air
    /// correction of NIMA TR8350.2 eq. 4-3), m/s^2.
    pub fn normal_gravity_m_s2(&self) -> f64 {
        let (s2, h) = (self.sin_lat * self.sin_lat, self.height_m);
        let gamma0 = GAMMA_EQUATOR_M_S2 * (1.0 + SOMIGLIANA_K * s2) * self.inverse_root;
        gamma0
            * (1.0 - 2.0 / A_M * (1.0 + F + M_RATIO - 2.0 * F * s2) * h + 3.0 * h * h / (A_M * A_M))
    }

    /// Partial derivatives of the normal gravity: (per rad of latitude, per m of height).
    pub fn normal_gravity_partials(&self) -> (f64, f64) {
        let (s, c, root) = (self.sin_lat, self.cos_lat, self.root);
        let s2 = s * s;
        let gamma0 = GAMMA_EQUATOR_M_S2 * (1.0 + SOMIGLIANA_K * s2) / root;
        let dgamma0 = GAMMA_EQUATOR_M_S2
            * (2.0 * SOMIGLIANA_K * s * c / root
                + (1.0 + SOMIGLIANA_K * s2) * E2 * s * c / root.powi(3));
        let c1 = 2.0 / A_M * (1.0 + F + M_RATIO - 2.0 * F * s2);
        let dc1 = -8.0 * F * s * c / A_M;
        let h = self.height_m;
        let factor = 1.0 - c1 * h + 3.0 * h * h / (A_M * A_M);
        (
            dgamma0 * factor - gamma0 * dc1 * h,
            gamma0 * (-c1 + 6.0 * h / (A_M * A_M)),
        )
    }

    /// Gravity (gravitation plus centrifugal) in NED: `[0, 0, gamma]`.
    pub fn gravity_ned_m_s2(&self) -> Vector3<f64> {
        Vector3::new(0.0, 0.0, self.normal_gravity_m_s2())
    }

    /// Earth rate in NED, omega_ie^n, rad/s.
    pub fn earth_rate_ned(&self) -> Vector3<f64> {
        Vector3::new(
            OMEGA_IE_RAD_S * self.cos_lat,
            0.0,
            -OMEGA_IE_RAD_S * self.sin_lat,
        )
    }

    /// Transport rate omega_en^n (rotation of NED over the ellipsoid), rad/s.
    pub fn transport_rate_ned(&self, vel_ned: &Vector3<f64>) -> Vector3<f64> {
        let east = vel_ned.y * self.inverse_prime_vertical_plus_height;
        Vector3::new(
            east,
            -vel_ned.x * self.inverse_meridian_plus_height,
            -east * self.sin_lat * self.inverse_cos_lat,
        )
    }

    /// Rates of latitude, longitude (rad/s) and height (m/s) for a NED velocity.
    pub fn position_rates(&self, vel_ned: &Vector3<f64>) -> Vector3<f64> {
        Vector3::new(
            vel_ned.x * self.inverse_meridian_plus_height,
            vel_ned.y * self.inverse_prime_vertical_plus_height * self.inverse_cos_lat,
            -vel_ned.z,
        )
    }
}

/// Meridian radius of curvature R_N (north-south), m.
pub fn meridian_radius_m(lat_rad: f64) -> f64 {
    Local::at(lat_rad, 0.0).meridian_radius_m
}

/// Prime-vertical radius of curvature R_E (east-west), m.
pub fn prime_vertical_radius_m(lat_rad: f64) -> f64 {
    Local::at(lat_rad, 0.0).prime_vertical_radius_m
}

/// Gravity (gravitation plus centrifugal) in NED: `[0, 0, gamma]`, along the ellipsoid normal.
pub fn gravity_ned_m_s2(lat_rad: f64, height_m: f64) -> Vector3<f64> {
    Local::at(lat_rad, height_m).gravity_ned_m_s2()
}

/// Earth rate in NED, omega_ie^n, rad/s.
pub fn earth_rate_ned(lat_rad: f64) -> Vector3<f64> {
    Local::at(lat_rad, 0.0).earth_rate_ned()
}

/// Transport rate omega_en^n (rotation of NED over the ellipsoid), rad/s.
pub fn transport_rate_ned(lat_rad: f64, height_m: f64, vel_ned: &Vector3<f64>) -> Vector3<f64> {
    Local::at(lat_rad, height_m).transport_rate_ned(vel_ned)
}

/// Rates of latitude, longitude (rad/s) and height (m/s) for a NED velocity.
pub fn position_rates(lat_rad: f64, height_m: f64, vel_ned: &Vector3<f64>) -> Vector3<f64> {
    Local::at(lat_rad, height_m).position_rates(vel_ned)
}

/// North and east offsets (m) of a position from an origin, on the local tangent of the
/// origin's radii (good to millimetres over a few kilometres).
pub fn local_north_east_m(
    origin_lat_rad: f64,
    origin_lon_rad: f64,
    lat_rad: f64,
    lon_rad: f64,
) -> (f64, f64) {
    let rn = meridian_radius_m(origin_lat_rad);
    let re = prime_vertical_radius_m(origin_lat_rad);
    (
        (lat_rad - origin_lat_rad) * rn,
        (lon_rad - origin_lon_rad) * re * origin_lat_rad.cos(),
    )
}

/// Earth-centred, Earth-fixed coordinates of a WGS-84 latitude, longitude (rad) and height, m.
pub fn ecef_m(lat_rad: f64, lon_rad: f64, height_m: f64) -> Vector3<f64> {
    let n = prime_vertical_radius_m(lat_rad);
    let (sl, cl) = lat_rad.sin_cos();
    let (so, co) = lon_rad.sin_cos();
    Vector3::new(
        (n + height_m) * cl * co,
        (n + height_m) * cl * so,
        (n * (1.0 - E2) + height_m) * sl,
    )
}

/// The straight line from `from` to `to` (each latitude, longitude rad, height m) in the
/// north-east-down axes at `from`, m: exact (through ECEF), where [`local_north_east_m`]
/// flattens the Earth onto the origin's radii.
pub fn ned_offset_m(from: (f64, f64, f64), to: (f64, f64, f64)) -> Vector3<f64> {
    let d = ecef_m(to.0, to.1, to.2) - ecef_m(from.0, from.1, from.2);
    let (sl, cl) = from.0.sin_cos();
    let (so, co) = from.1.sin_cos();
    Vector3::new(
        -sl * co * d.x - sl * so * d.y + cl * d.z,
        -so * d.x + co * d.y,
        -cl * co * d.x - cl * so * d.y - sl * d.z,
    )
}

/// The position (latitude, longitude, rad) at north and east offsets (m) from an origin:
/// the inverse of [`local_north_east_m`].
pub fn position_of_local_m(
    origin_lat_rad: f64,
    origin_lon_rad: f64,
    north_m: f64,
    east_m: f64,
) -> (f64, f64) {
    let rn = meridian_radius_m(origin_lat_rad);
    let re = prime_vertical_radius_m(origin_lat_rad);
    (
        origin_lat_rad + north_m / rn,
        origin_lon_rad + east_m / (re * origin_lat_rad.cos()),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small offset is the local one; a kilometre's chord dips below the tangent plane by
    /// about d^2 / 2R; the line's length does not depend on the end it is seen from.
    #[test]
    fn ned_offsets_are_the_straight_line() {
        let (lat, lon) = (35.1f64.to_radians(), 129.05f64.to_radians());
        let (n, e) = (3.0, -4.0);
        let (lat2, lon2) = position_of_local_m(lat, lon, n, e);
        let d = ned_offset_m((lat, lon, -10.0), (lat2, lon2, -15.0));
        // (10-15 m below the ellipsoid the metres of a radian are 2e-6 fewer.)
        assert!((d - Vector3::new(n, e, 5.0)).amax() < 5e-5, "{d}");
        let (lat3, lon3) = position_of_local_m(lat, lon, 1000.0, 0.0);
        let far = ned_offset_m((lat, lon, 0.0), (lat3, lon3, 0.0));
        assert!((far.x - 1000.0).abs() < 1e-3 && far.y.abs() < 1e-6, "{far}");
        let dip = 1000f64.powi(2) / (2.0 * meridian_radius_m(lat));
        assert!((far.z - dip).abs() < 1e-3, "{far} {dip}");
        let back = ned_offset_m((lat3, lon3, 0.0), (lat, lon, 0.0));
        assert!((back.norm() - far.norm()).abs() < 1e-6);
    }

    fn normal_gravity_m_s2(lat_rad: f64, height_m: f64) -> f64 {
        Local::at(lat_rad, height_m).normal_gravity_m_s2()
    }

    #[test]
    fn local_offsets_and_positions_are_inverses() {
        let (lat0, lon0) = (35.1f64.to_radians(), 129.0f64.to_radians());
        let (lat, lon) = position_of_local_m(lat0, lon0, 1234.5, -678.9);
        let (n, e) = local_north_east_m(lat0, lon0, lat, lon);
        assert!(
            (n - 1234.5).abs() < 1e-9 && (e + 678.9).abs() < 1e-9,
            "{n} {e}"
        );
    }

    #[test]
    fn gravity_matches_published_values() {
        // NIMA TR8350.2: equator 9.7803253359, pole 9.8321849378 m/s^2.
        assert!((normal_gravity_m_s2(0.0, 0.0) - 9.780_325_335_9).abs() < 1e-10);
        let pole = normal_gravity_m_s2(std::f64::consts::FRAC_PI_2, 0.0);
        assert!((pole - 9.832_184_937_8).abs() < 1e-9, "{pole}");
        // Free-air gradient about -3.086e-6 s^-2 at mid latitudes.
        let lat = 45f64.to_radians();
        let gradient = (normal_gravity_m_s2(lat, 100.0) - normal_gravity_m_s2(lat, -100.0)) / 200.0;
        assert!((gradient + 3.086e-6).abs() < 0.01e-6, "{gradient}");
    }

    #[test]
    fn radii_at_equator_and_pole() {
        assert!((prime_vertical_radius_m(0.0) - A_M).abs() < 1e-6);
        assert!((meridian_radius_m(0.0) - A_M * (1.0 - E2)).abs() < 1e-6);
        let b = A_M * (1.0 - F);
        let polar = A_M * A_M / b;
        assert!((meridian_radius_m(std::f64::consts::FRAC_PI_2) - polar).abs() < 1e-4);
        assert!((prime_vertical_radius_m(std::f64::consts::FRAC_PI_2) - polar).abs() < 1e-4);
    }

    #[test]
    fn derivatives_match_finite_differences() {
        for lat_deg in [-70.0, -20.0, 0.0, 35.0, 80.0] {
            let lat = f64::to_radians(lat_deg);
            let h = -300.0;
            let d = 1e-6;
            let fd = |f: &dyn Fn(f64) -> f64| (f(lat + d) - f(lat - d)) / (2.0 * d);
            let local = Local::at(lat, h);
            assert!((local.meridian_radius_derivative() - fd(&meridian_radius_m)).abs() < 1e-3);
            assert!(
                (local.prime_vertical_radius_derivative() - fd(&prime_vertical_radius_m)).abs()
                    < 1e-3
            );
            let (dlat, dh) = local.normal_gravity_partials();
            let g_lat = fd(&|l| normal_gravity_m_s2(l, h));
            let g_h = (normal_gravity_m_s2(lat, h + 1.0) - normal_gravity_m_s2(lat, h - 1.0)) / 2.0;
            assert!((dlat - g_lat).abs() < 1e-8, "{dlat} {g_lat}");
            assert!((dh - g_h).abs() < 1e-12, "{dh} {g_h}");
        }
    }

    #[test]
    fn rates_of_a_northward_run() {
        let lat = 0.6;
        let v = Vector3::new(2.0, 0.0, 0.5);
        let r = position_rates(lat, -100.0, &v);
        assert!((r.x - 2.0 / (meridian_radius_m(lat) - 100.0)).abs() < 1e-18);
        assert_eq!(r.y, 0.0);
        assert_eq!(r.z, -0.5);
        let w = transport_rate_ned(lat, -100.0, &v);
        assert!((w.y + r.x).abs() < 1e-18);
    }
}
