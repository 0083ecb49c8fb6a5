//! Truth trajectories built from manoeuvre segments, and their exact kinematics.
//!
//! A trajectory is three smooth channels ([`Profile`]): speed along the body x axis `U`,
//! turn rate `r = d(yaw)/dt` and pitch `theta`, plus an initial yaw. The velocity is along
//! the body x axis (no sideslip, no angle of attack, no current), so
//! `v_ned = U [cos(theta) cos(yaw), cos(theta) sin(yaw), -sin(theta)]`, and turns are
//! coordinated: `roll = atan(U r / g0)`. Every derivative the inertial synthesis needs is
//! analytic (chain rule over the channels' analytic derivatives); only the position
//! (latitude, longitude, height) is integrated, by RK4 with the exact velocity.

use super::profile::Profile;
use crate::geodesy;
use nalgebra::{Rotation3, Vector3};

/// Yaw, pitch, roll, speed and their first derivatives at one time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Kinematics {
    pub speed_m_s: f64,
    pub speed_rate_m_s2: f64,
    pub yaw_rad: f64,
    pub yaw_rate_rad_s: f64,
    pub pitch_rad: f64,
    pub pitch_rate_rad_s: f64,
    pub roll_rad: f64,
    pub roll_rate_rad_s: f64,
}

impl Kinematics {
    /// Attitude C_b^n = Rz(yaw) Ry(pitch) Rx(roll).
    pub fn ned_from_body(&self) -> Rotation3<f64> {
        Rotation3::from_euler_angles(self.roll_rad, self.pitch_rad, self.yaw_rad)
    }

    /// Velocity over ground in NED, m/s.
    pub fn vel_ned(&self) -> Vector3<f64> {
        let (sp, cp) = self.pitch_rad.sin_cos();
        let (sy, cy) = self.yaw_rad.sin_cos();
        self.speed_m_s * Vector3::new(cp * cy, cp * sy, -sp)
    }

    /// Time derivative of the NED velocity components, m/s^2.
    pub fn accel_ned(&self) -> Vector3<f64> {
        let (sp, cp) = self.pitch_rad.sin_cos();
        let (sy, cy) = self.yaw_rad.sin_cos();
        let (u, du) = (self.speed_m_s, self.speed_rate_m_s2);
        let (dp, dy) = (self.pitch_rate_rad_s, self.yaw_rate_rad_s);
        let dir = Vector3::new(cp * cy, cp * sy, -sp);
        let ddir = Vector3::new(
            -sp * dp * cy - cp * sy * dy,
            -sp * dp * sy + cp * cy * dy,
            -cp * dp,
        );
        du * dir + u * ddir
    }

    /// Body rate relative to NED, omega_nb^b, from the Euler angle rates, rad/s.
    pub fn omega_nb_body(&self) -> Vector3<f64> {
        let (sr, cr) = self.roll_rad.sin_cos();
        let (sp, cp) = self.pitch_rad.sin_cos();
        let (dr, dp, dy) = (
            self.roll_rate_rad_s,
            self.pitch_rate_rad_s,
            self.yaw_rate_rad_s,
        );
        Vector3::new(
            dr - dy * sp,
            dp * cr + dy * cp * sr,
            -dp * sr + dy * cp * cr,
        )
    }
}

/// A trajectory: channels and where it starts.
#[derive(Debug, Clone, PartialEq)]
pub struct Trajectory {
    speed: Profile,
    turn_rate: Profile,
    pitch: Profile,
    initial_yaw_rad: f64,
    duration_s: f64,
    start_lat_rad: f64,
    start_lon_rad: f64,
    start_height_m: f64,
}

impl Trajectory {
    pub fn duration_s(&self) -> f64 {
        self.duration_s
    }

    /// Latitude, longitude (rad) and height (m) at the start.
    pub fn start_position(&self) -> (f64, f64, f64) {
        (self.start_lat_rad, self.start_lon_rad, self.start_height_m)
    }

    /// Exact kinematics at `t_s` seconds from the start.
    pub fn kinematics(&self, t_s: f64) -> Kinematics {
        let u = self.speed.at(t_s);
        let r = self.turn_rate.at(t_s);
        let p = self.pitch.at(t_s);
        let x = u.value * r.value / geodesy::G0_M_S2;
        let dx = (u.rate * r.value + u.value * r.rate) / geodesy::G0_M_S2;
        Kinematics {
            speed_m_s: u.value,
            speed_rate_m_s2: u.rate,
            yaw_rad: self.initial_yaw_rad + self.turn_rate.integral(t_s),
            yaw_rate_rad_s: r.value,
            pitch_rad: p.value,
            pitch_rate_rad_s: p.rate,
            roll_rad: x.atan(),
            roll_rate_rad_s: dx / (1.0 + x * x),
        }
    }
}

/// Marches the truth position along a trajectory (RK4 with the exact velocity).
#[derive(Debug, Clone)]
pub struct PositionIntegrator<'a> {
    trajectory: &'a Trajectory,
    pub t_s: f64,
    /// Latitude, longitude (rad), height (m).
    pub position: Vector3<f64>,
}

impl<'a> PositionIntegrator<'a> {
    pub fn new(trajectory: &'a Trajectory) -> Self {
        let (lat, lon, h) = trajectory.start_position();
        PositionIntegrator {
            trajectory,
            t_s: 0.0,
            position: Vector3::new(lat, lon, h),
        }
    }

    /// Advances to `t_s`.
    pub fn advance_to(&mut self, t_s: f64) {
        let dt = t_s - self.t_s;
        if dt == 0.0 {
            return;
        }
        let f = |t: f64, p: &Vector3<f64>| {
            let v = self.trajectory.kinematics(t).vel_ned();
            geodesy::position_rates(p.x, p.z, &v)
        };
        let p = self.position;
        let k1 = f(self.t_s, &p);
        let k2 = f(self.t_s + dt / 2.0, &(p + k1 * (dt / 2.0)));
        let k3 = f(self.t_s + dt / 2.0, &(p + k2 * (dt / 2.0)));
        let k4 = f(t_s, &(p + k3 * dt));
        self.position = p + (k1 + 2.0 * k2 + 2.0 * k3 + k4) * (dt / 6.0);
        self.t_s = t_s;
    }
}

/// Builds a trajectory segment by segment.
#[derive(Debug, Clone)]
pub struct TrajectoryBuilder {
    t_s: f64,
    speed: Profile,
    turn_rate: Profile,
    pitch: Profile,
    initial_yaw_rad: f64,
    depth_m: f64,
    initial_depth_m: f64,
    start: (f64, f64),
}

/// Why a segment cannot be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SegmentError {
    #[error("segment at t = {t_s:.1} s: {reason}")]
    Impossible { t_s: f64, reason: String },
}

impl TrajectoryBuilder {
    /// Starts at rest or cruising at `speed_m_s`, at a latitude/longitude (deg), depth and yaw.
    pub fn new(lat_deg: f64, lon_deg: f64, depth_m: f64, yaw_rad: f64, speed_m_s: f64) -> Self {
        TrajectoryBuilder {
            t_s: 0.0,
            speed: Profile::new(speed_m_s),
            turn_rate: Profile::new(0.0),
            pitch: Profile::new(0.0),
            initial_yaw_rad: yaw_rad,
            depth_m,
            initial_depth_m: depth_m,
            start: (lat_deg, lon_deg),
        }
    }

    /// Starts already turning at `rate_rad_s` (coordinated, so already banked).
    pub fn with_turn_rate(mut self, rate_rad_s: f64) -> Self {
        self.turn_rate = Profile::new(rate_rad_s);
        self
    }

    /// Time at the end of the segments so far.
    pub fn time_s(&self) -> f64 {
        self.t_s
    }

    /// Depth at the end of the segments so far (as planned).
    pub fn depth_m(&self) -> f64 {
        self.depth_m
    }

    fn fail(&self, reason: impl Into<String>) -> SegmentError {
        SegmentError::Impossible {
            t_s: self.t_s,
            reason: reason.into(),
        }
    }

    /// Straight and level for `duration_s`.
    pub fn cruise(&mut self, duration_s: f64) -> &mut Self {
        if duration_s.is_finite() {
            self.t_s += duration_s.max(0.0);
        }
        self
    }

    /// Changes speed over `ramp_s`.
    pub fn speed_to(&mut self, speed_m_s: f64, ramp_s: f64) -> Result<&mut Self, SegmentError> {
        if !(ramp_s > 0.0 && ramp_s.is_finite() && speed_m_s.is_finite() && speed_m_s >= 0.0) {
            return Err(self.fail(format!(
                "a speed change needs a positive ramp time and a speed of 0 or more (got {speed_m_s} m/s over {ramp_s} s)"
            )));
        }
        self.speed.ramp(self.t_s, ramp_s, speed_m_s);
        self.t_s += ramp_s;
        Ok(self)
    }

    /// Speed at the end of the segments so far.
    pub fn speed_m_s(&self) -> f64 {
        self.speed.final_value()
    }

    /// Turns by `angle_rad` (positive to starboard) at `rate_rad_s`, entering and leaving the
    /// turn over `ramp_s` each.
    pub fn turn(
        &mut self,
        angle_rad: f64,
        rate_rad_s: f64,
        ramp_s: f64,
    ) -> Result<&mut Self, SegmentError> {
        let d = self.plan_turn(self.t_s, angle_rad, rate_rad_s, ramp_s)?;
        self.t_s += d;
        Ok(self)
    }

    /// Dives or climbs to `depth_m` at up to `pitch_rad` (magnitude), pitching over `ramp_s`,
    /// at the current speed.
    pub fn depth_to(
        &mut self,
        depth_m: f64,
        pitch_rad: f64,
        ramp_s: f64,
    ) -> Result<&mut Self, SegmentError> {
        let d = self.plan_depth(self.t_s, depth_m, pitch_rad, ramp_s)?;
        self.t_s += d;
        Ok(self)
    }

    /// A turn and a depth change at once (a spiral when the turn is several full circles).
    pub fn spiral(
        &mut self,
        angle_rad: f64,
        rate_rad_s: f64,
        depth_m: f64,
        pitch_rad: f64,
        ramp_s: f64,
    ) -> Result<&mut Self, SegmentError> {
        let turn = self.plan_turn(self.t_s, angle_rad, rate_rad_s, ramp_s)?;
        let dive = self.plan_depth(self.t_s, depth_m, pitch_rad, ramp_s)?;
        self.t_s += turn.max(dive);
        Ok(self)
    }

    /// Schedules a turn from `t0`; returns its duration.
    fn plan_turn(
        &mut self,
        t0: f64,
        angle_rad: f64,
        rate_rad_s: f64,
        ramp_s: f64,
    ) -> Result<f64, SegmentError> {
        if angle_rad == 0.0 {
            return Ok(0.0);
        }
        let rate = rate_rad_s.abs() * angle_rad.signum();
        // Each ramp turns rate * ramp / 2; the steady part turns the rest.
        let steady_s = angle_rad.abs() / rate.abs() - ramp_s;
        if !(steady_s >= 0.0 && steady_s.is_finite() && ramp_s > 0.0) {
            return Err(self.fail(format!(
                "a turn of {:.1} deg at {:.2} deg/s needs ramps shorter than {:.1} s",
                angle_rad.to_degrees(),
                rate_rad_s.to_degrees(),
                angle_rad.abs() / rate.abs()
            )));
        }
        self.turn_rate.ramp(t0, ramp_s, rate);
        self.turn_rate.ramp(t0 + ramp_s + steady_s, ramp_s, 0.0);
        Ok(2.0 * ramp_s + steady_s)
    }

    /// Schedules a depth change from `t0`; returns its duration.
    fn plan_depth(
        &mut self,
        t0: f64,
        depth_m: f64,
        pitch_rad: f64,
        ramp_s: f64,
    ) -> Result<f64, SegmentError> {
        let change = depth_m - self.depth_m;
        if change == 0.0 {
            return Ok(0.0);
        }
        let speed = self.speed.at(t0).value;
        if speed <= 0.0 || ramp_s <= 0.0 || pitch_rad == 0.0 {
            return Err(self.fail("a depth change needs forward speed, a pitch and a ramp time"));
        }
        // Depth covered by one pitch ramp of magnitude p: speed * integral of sin(p s(x)).
        let ramp_depth = |p: f64| speed * ramp_s * ramp_sine_integral(p);
        let mut p = pitch_rad.abs();
        let mut steady_s = (change.abs() - 2.0 * ramp_depth(p)) / (speed * p.sin());
        if steady_s < 0.0 {
            // Too small a change for this pitch: find the pitch that makes it with no steady part.
            let (mut lo, mut hi) = (0.0, p);
            for _ in 0..100 {
                let mid = 0.5 * (lo + hi);
                if 2.0 * ramp_depth(mid) < change.abs() {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            p = 0.5 * (lo + hi);
            steady_s = 0.0;
        }
        let theta = -p * change.signum(); // nose down to go deeper
        self.pitch.ramp(t0, ramp_s, theta);
        self.pitch.ramp(t0 + ramp_s + steady_s, ramp_s, 0.0);
        self.depth_m = depth_m;
        Ok(2.0 * ramp_s + steady_s)
    }

    /// The trajectory, ending `tail_s` after the last segment.
    pub fn build(&self, tail_s: f64) -> Trajectory {
        Trajectory {
            speed: self.speed.clone(),
            turn_rate: self.turn_rate.clone(),
            pitch: self.pitch.clone(),
            initial_yaw_rad: self.initial_yaw_rad,
            duration_s: self.t_s + tail_s,
            start_lat_rad: self.start.0.to_radians(),
            start_lon_rad: self.start.1.to_radians(),
            start_height_m: -self.initial_depth_m,
        }
    }
}

/// Integral over x in [0, 1] of sin(p * smootherstep(x)) (composite Simpson, 2000 panels).
fn ramp_sine_integral(p: f64) -> f64 {
    let n = 2000;
    let h = 1.0 / n as f64;
    let f = |x: f64| {
        let x3 = x * x * x;
        (p * x3 * (10.0 - 15.0 * x + 6.0 * x * x)).sin()
    };
    let mut sum = f(0.0) + f(1.0);
    for i in 1..n {
        sum += f(i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
    }
    sum * h / 3.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    fn trajectory() -> Trajectory {
        let mut b = TrajectoryBuilder::new(35.0, 129.0, 5.0, 0.2, 0.0);
        b.speed_to(2.0, 15.0).unwrap();
        b.depth_to(40.0, 12f64.to_radians(), 6.0).unwrap();
        b.turn(PI / 2.0, 4f64.to_radians(), 5.0).unwrap();
        b.depth_to(38.0, 12f64.to_radians(), 6.0).unwrap();
        b.turn(-PI, 6f64.to_radians(), 4.0).unwrap();
        b.speed_to(0.5, 10.0).unwrap();
        b.build(30.0)
    }

    #[test]
    fn analytic_derivatives_match_finite_differences() {
        let traj = trajectory();
        let h = 1e-5;
        let mut t = 0.05;
        while t < traj.duration_s() - 0.1 {
            let k = traj.kinematics(t);
            let (a, b) = (traj.kinematics(t - h), traj.kinematics(t + h));
            let accel_fd = (b.vel_ned() - a.vel_ned()) / (2.0 * h);
            assert!((k.accel_ned() - accel_fd).norm() < 1e-7, "accel at {t}");
            // omega_nb^b from the attitude: C(t-h)^T C(t+h) = exp([omega] 2h); its
            // antisymmetric part is accurate for small angles (acos-based angles are not).
            let d = (a.ned_from_body().inverse() * b.ned_from_body()).into_inner();
            let omega_fd = Vector3::new(
                d[(2, 1)] - d[(1, 2)],
                d[(0, 2)] - d[(2, 0)],
                d[(1, 0)] - d[(0, 1)],
            ) / (4.0 * h);
            assert!(
                (k.omega_nb_body() - omega_fd).norm() < 1e-7,
                "omega at {t}: {} vs {omega_fd}",
                k.omega_nb_body()
            );
            t += 0.37;
        }
    }

    #[test]
    fn segments_reach_their_depth_and_heading() {
        let traj = trajectory();
        let mut p = PositionIntegrator::new(&traj);
        let mut t = 0.0;
        while t < traj.duration_s() {
            t = (t + 0.01).min(traj.duration_s());
            p.advance_to(t);
        }
        // Last depth planned: 38 m; all turns: +90 - 180 deg.
        assert!(
            (-p.position.z - 38.0).abs() < 1e-3,
            "depth {}",
            -p.position.z
        );
        let yaw = traj.kinematics(traj.duration_s()).yaw_rad;
        assert!((yaw - (0.2 + PI / 2.0 - PI)).abs() < 1e-9, "{yaw}");
        let k = traj.kinematics(traj.duration_s());
        assert!((k.speed_m_s - 0.5).abs() < 1e-12 && k.pitch_rad == 0.0 && k.roll_rad == 0.0);
    }

    #[test]
    fn coordinated_turn_banks_into_the_turn() {
        let traj = trajectory();
        // Mid-way through the starboard turn: positive roll, tan(roll) = U r / g0.
        let mut b = TrajectoryBuilder::new(0.0, 0.0, 10.0, 0.0, 2.0);
        b.turn(PI, 5f64.to_radians(), 5.0).unwrap();
        let t = b.build(0.0);
        let k = t.kinematics(t.duration_s() / 2.0);
        assert!(k.roll_rad > 0.0);
        assert!((k.roll_rad.tan() - 2.0 * 5f64.to_radians() / geodesy::G0_M_S2).abs() < 1e-12);
        assert!(
            b.turn(PI / 36.0, 5f64.to_radians(), 5.0).is_err(),
            "ramps longer than the turn"
        );
        let _ = traj;
    }
}
