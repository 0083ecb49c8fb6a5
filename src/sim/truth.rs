//! Where a simulation's truth comes from: a kinematic trajectory (segments with analytic
//! derivatives) or a vehicle's dynamics flown by its autopilot ([`super::dynamic`]). The
//! runner samples either on the IMU's grid and synthesises every sensor from the sample.

use super::inertial::Motion;
use super::trajectory::{PositionIntegrator, Trajectory};
use crate::vehicle::six_dof::motion::Actuators;

/// The truth at one instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TruthSample {
    /// Latitude, longitude (rad) and height (m, positive up) on WGS-84.
    pub lat_rad: f64,
    pub lon_rad: f64,
    pub height_m: f64,
    pub motion: Motion,
    /// Roll, pitch, yaw, rad (yaw wrapped to (-pi, pi]).
    pub euler_rad: [f64; 3],
    /// Speed through the water along the body's x axis, m/s (what an EM log measures).
    pub speed_m_s: f64,
    /// Fin angles and propeller speed, when the truth is a vehicle's dynamics.
    pub actuators: Option<Actuators>,
}

/// A source of truth sampled at increasing times.
pub trait TruthSource {
    /// Length of the run, s.
    fn duration_s(&self) -> f64;
    /// The truth at `t_s` (called with non-decreasing times, on the IMU's grid).
    fn sample(&mut self, t_s: f64) -> TruthSample;
}

/// A kinematic trajectory, its position integrated on WGS-84.
pub struct KinematicTruth<'a> {
    trajectory: &'a Trajectory,
    position: PositionIntegrator<'a>,
}

impl<'a> KinematicTruth<'a> {
    pub fn new(trajectory: &'a Trajectory) -> Self {
        KinematicTruth {
            trajectory,
            position: PositionIntegrator::new(trajectory),
        }
    }
}

impl TruthSource for KinematicTruth<'_> {
    fn duration_s(&self) -> f64 {
        self.trajectory.duration_s()
    }

    fn sample(&mut self, t_s: f64) -> TruthSample {
        self.position.advance_to(t_s);
        let p = self.position.position;
        let kin = self.trajectory.kinematics(t_s);
        TruthSample {
            lat_rad: p.x,
            lon_rad: p.y,
            height_m: p.z,
            motion: kin.motion(),
            euler_rad: [
                kin.roll_rad,
                kin.pitch_rad,
                crate::angle::wrap_pi(kin.yaw_rad),
            ],
            speed_m_s: kin.speed_m_s,
            actuators: None,
        }
    }
}
