//! Strapdown mechanization on WGS-84: attitude, velocity and position from gyro and
//! accelerometer samples, with Earth rate and transport rate.
//!
//! The IMU gives point samples of omega_ib^b and f^b (the log contract), not increments, so
//! coning and sculling corrections for increments do not apply. Instead the whole nonlinear
//! navigation ODE (attitude quaternion, NED velocity, latitude/longitude/height) is
//! integrated by classical RK4 over each IMU interval, with omega and f linear in time
//! between the two samples: the equivalent high-order scheme. The quaternion is
//! re-normalised after each step.
//!
//! q' = 1/2 q (x) [0, omega_ib^b] - 1/2 [0, omega_in^n] (x) q        (q = ned_from_body)
//! v' = C_b^n f^b - (2 omega_ie^n + omega_en^n) x v + g^n
//! lat' = v_N / (R_N + h),  lon' = v_E / ((R_E + h) cos lat),  h' = -v_D
//!
//! The vertical channel is unstable on its own; [`HeightDamping`] closes it on a height
//! (depth) reference with a second-order loop.

use crate::geodesy;
use nalgebra::{Quaternion, SVector, UnitQuaternion, Vector3};

/// Navigation state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NavState {
    pub lat_rad: f64,
    pub lon_rad: f64,
    /// Ellipsoidal height, m (negative under water at zero surface height).
    pub height_m: f64,
    pub vel_ned_m_s: Vector3<f64>,
    pub ned_from_body: UnitQuaternion<f64>,
}

/// One IMU sample: body rate relative to inertial space and specific force, body frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImuSample {
    pub omega_ib_body: Vector3<f64>,
    pub specific_force_body: Vector3<f64>,
}

impl ImuSample {
    /// The sample a fraction `s` of the way from `a` to `b` (linear interpolation).
    pub fn lerp(a: &ImuSample, b: &ImuSample, s: f64) -> ImuSample {
        ImuSample {
            omega_ib_body: a.omega_ib_body.lerp(&b.omega_ib_body, s),
            specific_force_body: a.specific_force_body.lerp(&b.specific_force_body, s),
        }
    }

    /// The mean of two samples.
    pub fn mean(a: &ImuSample, b: &ImuSample) -> ImuSample {
        Self::lerp(a, b, 0.5)
    }
}

/// Second-order damping of the vertical channel on a height reference:
/// h' = -v_D - k1 (h - h_ref), v_D' = ... + k2 (h - h_ref).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeightDamping {
    pub k1_per_s: f64,
    pub k2_per_s2: f64,
}

impl HeightDamping {
    /// Critically damped loop with natural frequency `omega_rad_s`.
    pub fn critical(omega_rad_s: f64) -> Self {
        HeightDamping {
            k1_per_s: 2.0 * omega_rad_s,
            k2_per_s2: omega_rad_s * omega_rad_s,
        }
    }
}

type Y = SVector<f64, 10>; // q (w, x, y, z), v (n, e, d), lat, lon, h

fn pack(s: &NavState) -> Y {
    let q = s.ned_from_body.quaternion();
    let v = s.vel_ned_m_s;
    Y::from_column_slice(&[
        q.w, q.i, q.j, q.k, v.x, v.y, v.z, s.lat_rad, s.lon_rad, s.height_m,
    ])
}

fn unpack(y: &Y) -> NavState {
    NavState {
        ned_from_body: UnitQuaternion::from_quaternion(Quaternion::new(y[0], y[1], y[2], y[3])),
        vel_ned_m_s: Vector3::new(y[4], y[5], y[6]),
        lat_rad: y[7],
        lon_rad: y[8],
        height_m: y[9],
    }
}

/// What the navigation ODE takes from the geodesy over one IMU interval, evaluated once at
/// its start. Across 10 ms the vehicle moves centimetres, which changes Earth rate, transport
/// rate and the radii by parts in 10^9 of themselves, far below any IMU's noise. Gravity is
/// the exception kept: its gradient (3e-6 s^-2 per metre of height) is what makes the
/// vertical channel unstable, and the error model carries it, so each stage moves gravity
/// along its partials from the start.
struct IntervalGeodesy {
    local: geodesy::Local,
    earth_rate_ned: Vector3<f64>,
    gravity_m_s2: f64,
    /// Partials of gravity, per rad of latitude and per m of height.
    gravity_partials: (f64, f64),
}

impl IntervalGeodesy {
    fn at(state: &NavState) -> Self {
        let local = geodesy::Local::at(state.lat_rad, state.height_m);
        IntervalGeodesy {
            earth_rate_ned: local.earth_rate_ned(),
            gravity_m_s2: local.normal_gravity_m_s2(),
            gravity_partials: local.normal_gravity_partials(),
            local,
        }
    }

    /// Gravity (down) at a latitude and height within the interval.
    fn gravity_ned_m_s2(&self, lat_rad: f64, height_m: f64) -> Vector3<f64> {
        let (per_lat, per_height) = self.gravity_partials;
        let down = self.gravity_m_s2
            + per_lat * (lat_rad - self.local.lat_rad)
            + per_height * (height_m - self.local.height_m);
        Vector3::new(0.0, 0.0, down)
    }
}

/// The navigation ODE's right-hand side at `y`, with the interval's geodesy `geo`.
fn derivative(
    y: &Y,
    imu: &ImuSample,
    damping: Option<(HeightDamping, f64)>,
    geo: &IntervalGeodesy,
) -> Y {
    let q = Quaternion::new(y[0], y[1], y[2], y[3]);
    let v = Vector3::new(y[4], y[5], y[6]);
    let (lat, h) = (y[7], y[9]);
    let w_ie = geo.earth_rate_ned;
    let w_en = geo.local.transport_rate_ned(&v);
    let w_in = w_ie + w_en;
    let wb = imu.omega_ib_body;
    let q_dot = (q * Quaternion::new(0.0, wb.x, wb.y, wb.z)
        - Quaternion::new(0.0, w_in.x, w_in.y, w_in.z) * q)
        * 0.5;
    // Rotate f by the (not yet unit) quaternion, normalised.
    let unit = UnitQuaternion::from_quaternion(q);
    let mut v_dot = unit * imu.specific_force_body - (2.0 * w_ie + w_en).cross(&v)
        + geo.gravity_ned_m_s2(lat, h);
    let mut p_dot = geo.local.position_rates(&v);
    if let Some((d, h_ref)) = damping {
        let e = h - h_ref;
        p_dot.z -= d.k1_per_s * e;
        v_dot.z += d.k2_per_s2 * e;
    }
    Y::from_column_slice(&[
        q_dot.w, q_dot.i, q_dot.j, q_dot.k, v_dot.x, v_dot.y, v_dot.z, p_dot.x, p_dot.y, p_dot.z,
    ])
}

/// Propagates `state` over `dt_s` from IMU sample `imu0` (at the start) to `imu1` (at the
/// end). `height_ref` (a depth or height fix at the end of the step) damps the vertical
/// channel when given with its loop gains.
pub fn propagate(
    state: &NavState,
    imu0: &ImuSample,
    imu1: &ImuSample,
    dt_s: f64,
    height_ref: Option<(HeightDamping, f64)>,
) -> NavState {
    let mid = ImuSample::mean(imu0, imu1);
    let y = pack(state);
    let start = IntervalGeodesy::at(state);
    let k1 = derivative(&y, imu0, height_ref, &start);
    let k2 = derivative(&(y + k1 * (dt_s / 2.0)), &mid, height_ref, &start);
    let k3 = derivative(&(y + k2 * (dt_s / 2.0)), &mid, height_ref, &start);
    let k4 = derivative(&(y + k3 * dt_s), imu1, height_ref, &start);
    unpack(&(y + (k1 + 2.0 * k2 + 2.0 * k3 + k4) * (dt_s / 6.0)))
}
