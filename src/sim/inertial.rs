//! Exact inertial synthesis: what an error-free IMU measures along a truth trajectory on the
//! rotating WGS-84 Earth.
//!
//! omega_ib^b = omega_nb^b + C_n^b (omega_ie^n + omega_en^n)
//! f^b        = C_n^b (dv^n/dt + (2 omega_ie^n + omega_en^n) x v^n - g^n)
//!
//! with normal gravity from [`geodesy`]. The derivatives dv^n/dt and omega_nb^b are analytic
//! (see [`super::trajectory`]), not numerical.

use super::trajectory::Kinematics;
use crate::geodesy;
use nalgebra::Vector3;

/// Error-free gyro and accelerometer output, body frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PerfectImu {
    pub omega_ib_body: Vector3<f64>,
    pub specific_force_body: Vector3<f64>,
}

/// What a perfect IMU measures at this state (latitude and height in rad and m).
pub fn perfect_imu(kin: &Kinematics, lat_rad: f64, height_m: f64) -> PerfectImu {
    let v = kin.vel_ned();
    let w_ie = geodesy::earth_rate_ned(lat_rad);
    let w_en = geodesy::transport_rate_ned(lat_rad, height_m, &v);
    let body_from_ned = kin.ned_from_body().inverse();
    let g = geodesy::gravity_ned_m_s2(lat_rad, height_m);
    PerfectImu {
        omega_ib_body: kin.omega_nb_body() + body_from_ned * (w_ie + w_en),
        specific_force_body: body_from_ned * (kin.accel_ned() + (2.0 * w_ie + w_en).cross(&v) - g),
    }
}
