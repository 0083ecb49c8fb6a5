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
use nalgebra::{Rotation3, Vector3};

/// The motion an IMU senses at one instant, whatever produced it (a kinematic trajectory,
/// or a vehicle model's dynamics).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Motion {
    pub ned_from_body: Rotation3<f64>,
    /// Velocity over ground, NED, m/s.
    pub vel_ned: Vector3<f64>,
    /// Time derivative of the NED velocity components, m/s^2.
    pub accel_ned: Vector3<f64>,
    /// Body rate relative to the local NED frame, rad/s.
    pub omega_nb_body: Vector3<f64>,
}

impl Kinematics {
    /// The motion of this kinematic state.
    pub fn motion(&self) -> Motion {
        Motion {
            ned_from_body: self.ned_from_body(),
            vel_ned: self.vel_ned(),
            accel_ned: self.accel_ned(),
            omega_nb_body: self.omega_nb_body(),
        }
    }
}

impl Motion {
    /// The motion of a body moving at `v_body` (m/s) and turning at `omega_nb_body`
    /// (rad/s) relative to NED, with body-frame velocity derivative `v_body_dot`, neglecting
    /// the NED frame's own rotation over the Earth (the transport rate, below 1e-6 rad/s at
    /// the speeds of underwater vehicles): `d(v_ned)/dt = C (v_body_dot + omega x v_body)`.
    pub fn from_body(
        ned_from_body: Rotation3<f64>,
        v_body: Vector3<f64>,
        v_body_dot: Vector3<f64>,
        omega_nb_body: Vector3<f64>,
    ) -> Motion {
        Motion {
            ned_from_body,
            vel_ned: ned_from_body * v_body,
            accel_ned: ned_from_body * (v_body_dot + omega_nb_body.cross(&v_body)),
            omega_nb_body,
        }
    }
}

/// Error-free gyro and accelerometer output, body frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PerfectImu {
    pub omega_ib_body: Vector3<f64>,
    pub specific_force_body: Vector3<f64>,
}

/// What a perfect IMU measures in this motion (latitude and height in rad and m).
pub fn perfect_imu(motion: &Motion, lat_rad: f64, height_m: f64) -> PerfectImu {
    let v = motion.vel_ned;
    let w_ie = geodesy::earth_rate_ned(lat_rad);
    let w_en = geodesy::transport_rate_ned(lat_rad, height_m, &v);
    let body_from_ned = motion.ned_from_body.inverse();
    let g = geodesy::gravity_ned_m_s2(lat_rad, height_m);
    PerfectImu {
        omega_ib_body: motion.omega_nb_body + body_from_ned * (w_ie + w_en),
        specific_force_body: body_from_ned * (motion.accel_ned + (2.0 * w_ie + w_en).cross(&v) - g),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A body-frame description of a steady level turn gives the same motion (and so the
    /// same IMU output) as the kinematic trajectory's analytic one.
    #[test]
    fn body_frame_motion_matches_the_kinematic_one() {
        let kin = Kinematics {
            speed_m_s: 2.0,
            speed_rate_m_s2: 0.1,
            yaw_rad: 0.7,
            yaw_rate_rad_s: 0.05,
            pitch_rad: 0.0,
            pitch_rate_rad_s: 0.0,
            roll_rad: 0.0,
            roll_rate_rad_s: 0.0,
        };
        let analytic = kin.motion();
        let from_body = Motion::from_body(
            kin.ned_from_body(),
            Vector3::new(2.0, 0.0, 0.0),
            Vector3::new(0.1, 0.0, 0.0),
            kin.omega_nb_body(),
        );
        assert!((analytic.vel_ned - from_body.vel_ned).norm() < 1e-12);
        assert!((analytic.accel_ned - from_body.accel_ned).norm() < 1e-12);
        let lat = 0.6;
        let (a, b) = (
            perfect_imu(&analytic, lat, -20.0),
            perfect_imu(&from_body, lat, -20.0),
        );
        assert!((a.specific_force_body - b.specific_force_body).norm() < 1e-12);
        assert!((a.omega_ib_body - b.omega_ib_body).norm() < 1e-15);
    }
}
