//! Heading, depth/pitch and speed control, enough to fly the papers' manoeuvres.
//!
//! Each loop asks for an angular acceleration of a second-order response
//! (`omega^2 error - 2 zeta omega rate`) and turns it into a fin angle through the model's
//! own effective inertia, rate damping and fin effectiveness at the commanded speed (so the
//! same gains fly any vehicle file); depth is an outer loop that commands pitch. Speed: the
//! propeller speed that holds it in straight, level flight, plus an integral on the error.

use super::model::{Attitude, SixDof};
use super::motion::{Actuators, MotionState};
use super::properties::steady_speed;
use super::terms::{Inputs, Nu};
use crate::angle::wrap_pi;
use nalgebra::Vector3;

/// What the vehicle is asked to do.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Command {
    pub speed_m_s: f64,
    /// Heading, rad; `None`: rudder held at `rudder_rad`.
    pub heading_rad: Option<f64>,
    /// The heading reference's rate, rad/s (feed-forward of a turning reference).
    pub heading_rate_rad_s: f64,
    /// Depth, m; `None`: pitch held by `pitch_rad` (or the planes held at `stern_rad`).
    pub depth_m: Option<f64>,
    pub pitch_rad: Option<f64>,
    /// The depth reference's rate, m/s, positive down (feed-forward of a moving reference).
    pub depth_rate_m_s: f64,
    pub rudder_rad: f64,
    pub stern_rad: f64,
}

impl Command {
    /// Speed alone: rudder and planes held at zero, nothing else steered (set the fields
    /// that matter with struct update syntax).
    pub fn at_speed(speed_m_s: f64) -> Command {
        Command {
            speed_m_s,
            heading_rad: None,
            heading_rate_rad_s: 0.0,
            depth_m: None,
            pitch_rad: None,
            depth_rate_m_s: 0.0,
            rudder_rad: 0.0,
            stern_rad: 0.0,
        }
    }
}

crate::config::with_defaults! {
    /// Gains and limits.
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct Gains {
        /// Heading loop bandwidth, rad/s, and damping ratio.
        pub heading_omega: f64 = 0.3,
        pub pitch_omega: f64 = 0.5,
        pub zeta: f64 = 0.9,
        /// Pitch command per metre of depth error, rad/m, and its limit, rad.
        pub depth_gain: f64 = 0.05,
        pub max_pitch_rad: f64 = 20f64.to_radians(),
        /// Integral gain on the speed error, (rad/s) per (m/s) per s.
        pub speed_integral: f64 = 2.0,
    }
}

/// The controller's memory (the speed integral).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct AutopilotState {
    pub speed_integral: f64,
}

/// The autopilot of one vehicle at one commanded speed.
#[derive(Debug, Clone, PartialEq)]
pub struct Autopilot {
    pub gains: Gains,
    speed_m_s: f64,
    propeller_rad_s: f64,
    /// Inertia, rate damping and fin effectiveness: yaw (rudder; sway eliminated, as in a
    /// steady turn), pitch (stern).
    yaw: (f64, f64, f64),
    pitch: (f64, f64, f64),
}

impl Autopilot {
    /// Tuned on the model at `speed_m_s`; `None` if no propeller speed holds it or a fin
    /// has no effect.
    pub fn new(model: &SixDof, speed_m_s: f64, gains: Gains) -> Option<Autopilot> {
        let propeller_rad_s = propeller_for(model, speed_m_s)?;
        let nu = Nu::new(speed_m_s, 0.0, 0.0, 0.0, 0.0, 0.0);
        let level = Attitude {
            roll_rad: 0.0,
            pitch_rad: 0.0,
            earth_rate_body: Vector3::zeros(),
        };
        let inputs = |rudder_rad: f64, stern_rad: f64| Inputs {
            rudder_rad,
            stern_rad,
            bow_rad: 0.0,
            propeller_rad_s,
        };
        let (tau0, d) = model.forces(&nu, &level, &inputs(0.0, 0.0));
        let h = 0.01;
        let rudder = (model.forces(&nu, &level, &inputs(h, 0.0)).0 - tau0) / h;
        let stern = (model.forces(&nu, &level, &inputs(0.0, h)).0 - tau0) / h;
        // A steady turn brings sway with it, whose yaw moment adds to the rate damping and
        // whose force takes from the rudder's: eliminate it. (In pitch the restoring moment
        // dominates and the plain terms serve better: eliminating heave there makes the
        // depth loop overshoot 13 m on Table 1's climbs.)
        let k = d[(5, 1)] / d[(1, 1)];
        let (yaw_damping, n_rudder) = (d[(5, 5)] - k * d[(1, 5)], rudder[5] - k * rudder[1]);
        let (pitch_damping, m_stern) = (d[(4, 4)], stern[4]);
        if !(n_rudder.abs() > 1e-9 && m_stern.abs() > 1e-9) {
            return None;
        }
        let m = model.mass_matrix();
        Some(Autopilot {
            gains,
            speed_m_s,
            propeller_rad_s,
            yaw: (m[(5, 5)], yaw_damping, n_rudder),
            pitch: (m[(4, 4)], pitch_damping, m_stern),
        })
    }

    pub fn propeller_rad_s(&self) -> f64 {
        self.propeller_rad_s
    }

    /// Fin and propeller commands for the state.
    pub fn commands(
        &self,
        model: &SixDof,
        s: &MotionState,
        cmd: &Command,
        memory: &mut AutopilotState,
        dt: f64,
    ) -> Actuators {
        let g = &self.gains;
        let (_, pitch, yaw) = s.euler();
        let (q, r) = (s.nu[4], s.nu[5]);
        // `rate_error`: the reference's rate minus the body's.
        let fin = |(inertia, damping, effect): (f64, f64, f64),
                   omega: f64,
                   error: f64,
                   rate_error: f64,
                   rate: f64| {
            let wanted = omega * omega * error + 2.0 * g.zeta * omega * rate_error;
            (inertia * wanted - damping * rate) / effect
        };
        let rudder_rad = match cmd.heading_rad {
            Some(h) => fin(
                self.yaw,
                g.heading_omega,
                wrap_pi(h - yaw),
                cmd.heading_rate_rad_s - r,
                r,
            ),
            None => cmd.rudder_rad,
        };
        let pitch_command = match (cmd.depth_m, cmd.pitch_rad) {
            (Some(depth), _) => {
                let error = depth - s.position_m.z;
                let descent = (s.ned_from_body * Vector3::new(s.nu[0], s.nu[1], s.nu[2])).z;
                // Deeper wanted: nose down (negative pitch); the descent rate relative to the
                // reference's damps it, and the pitch that gives the reference's rate at the
                // commanded speed is fed forward.
                let feed_forward = -(cmd.depth_rate_m_s / self.speed_m_s)
                    .clamp(-1.0, 1.0)
                    .asin();
                Some(
                    (feed_forward - g.depth_gain * error
                        + 2.0 * g.depth_gain * (descent - cmd.depth_rate_m_s) / g.pitch_omega)
                        .clamp(-g.max_pitch_rad, g.max_pitch_rad),
                )
            }
            (None, p) => p,
        };
        let stern_rad = match pitch_command {
            Some(theta) => fin(self.pitch, g.pitch_omega, theta - pitch, -q, q),
            None => cmd.stern_rad,
        };
        memory.speed_integral += (cmd.speed_m_s - s.nu[0]) * dt;
        let limit = model.vehicle.fin_limit_rad;
        Actuators {
            rudder_rad: rudder_rad.clamp(-limit, limit),
            stern_rad: stern_rad.clamp(-limit, limit),
            bow_rad: 0.0,
            propeller_rad_s: self.propeller_rad_s + g.speed_integral * memory.speed_integral,
        }
    }

    pub fn speed_m_s(&self) -> f64 {
        self.speed_m_s
    }

    /// +1 if a positive rudder angle turns the vehicle to starboard (yaw increasing), -1 if
    /// to port: the file's sign convention, read from the model.
    pub fn rudder_yaw_sign(&self) -> f64 {
        self.yaw.2.signum()
    }

    /// +1 if a positive stern-plane angle pitches the nose up, -1 if down.
    pub fn stern_pitch_sign(&self) -> f64 {
        self.pitch.2.signum()
    }
}

/// The propeller speed that holds `speed_m_s` in straight, level flight (bisection).
pub fn propeller_for(model: &SixDof, speed_m_s: f64) -> Option<f64> {
    let max = model.vehicle.propeller_limit_rad_s;
    let (mut lo, mut hi) = (0.0, max);
    if steady_speed(model, max).is_none_or(|u| u < speed_m_s) {
        return None;
    }
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if steady_speed(model, mid).is_some_and(|u| u >= speed_m_s) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    Some(hi)
}
