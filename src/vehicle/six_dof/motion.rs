//! Flying the 6-DOF model: the state (velocities, attitude, position, actuators), its
//! derivative and an RK4 step, in a flat, non-rotating world unless an Earth rate is given.
//!
//! Actuators: fins and propeller follow their commands with the file's time constant, fins
//! limited in angle and rate, the propeller in speed.

use super::model::{Attitude, SixDof};
use super::terms::{Inputs, Nu};
use nalgebra::{Quaternion, UnitQuaternion, Vector3};

/// Fin and propeller commands (or states).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Actuators {
    pub rudder_rad: f64,
    pub stern_rad: f64,
    pub bow_rad: f64,
    pub propeller_rad_s: f64,
}

/// The vehicle's state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotionState {
    pub nu: Nu,
    pub ned_from_body: UnitQuaternion<f64>,
    /// Position, NED, m.
    pub position_m: Vector3<f64>,
    pub actuators: Actuators,
}

impl MotionState {
    /// At rest, level, heading `yaw_rad`, at `position_m`.
    pub fn at(position_m: Vector3<f64>, yaw_rad: f64) -> MotionState {
        MotionState {
            nu: Nu::zeros(),
            ned_from_body: UnitQuaternion::from_euler_angles(0.0, 0.0, yaw_rad),
            position_m,
            actuators: Actuators::default(),
        }
    }

    /// Roll, pitch, yaw, rad.
    pub fn euler(&self) -> (f64, f64, f64) {
        self.ned_from_body.euler_angles()
    }
}

/// Time derivatives of everything but the attitude (turned by the body rate `nu[3..6]`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rates {
    /// `nu'`: body-frame accelerations, m/s^2 and rad/s^2.
    pub nu: Nu,
    /// Velocity in the world (NED) frame, m/s.
    pub position: Vector3<f64>,
    /// The attitude quaternion's derivative, `q' = q (0, omega) / 2`.
    pub attitude: Quaternion<f64>,
    pub actuators: Actuators,
}

/// How the fins and propeller move toward `command` from `state`.
pub fn actuator_rates(model: &SixDof, state: &Actuators, command: &Actuators) -> Actuators {
    let v = &model.vehicle;
    let tau = v.actuator_time_constant_s.max(1e-3);
    let fin = |actual: f64, cmd: f64| {
        let cmd = cmd.clamp(-v.fin_limit_rad, v.fin_limit_rad);
        ((cmd - actual) / tau).clamp(-v.fin_rate_limit_rad_s, v.fin_rate_limit_rad_s)
    };
    let n_cmd = command
        .propeller_rad_s
        .clamp(-v.propeller_limit_rad_s, v.propeller_limit_rad_s);
    Actuators {
        rudder_rad: fin(state.rudder_rad, command.rudder_rad),
        stern_rad: fin(state.stern_rad, command.stern_rad),
        bow_rad: fin(state.bow_rad, command.bow_rad),
        propeller_rad_s: (n_cmd - state.propeller_rad_s) / tau,
    }
}

/// The state's time derivatives under `command` (RK4's first stage; the simulator reads the
/// accelerations it needs from them).
pub fn rates(
    model: &SixDof,
    s: &MotionState,
    command: &Actuators,
    earth_rate_ned: &Vector3<f64>,
) -> Rates {
    let (roll_rad, pitch_rad, _) = s.euler();
    let at = Attitude {
        roll_rad,
        pitch_rad,
        earth_rate_body: s.ned_from_body.inverse() * earth_rate_ned,
    };
    let a = s.actuators;
    let inputs = Inputs {
        rudder_rad: a.rudder_rad,
        stern_rad: a.stern_rad,
        bow_rad: a.bow_rad,
        propeller_rad_s: a.propeller_rad_s,
    };
    Rates {
        nu: model.acceleration(&s.nu, &at, &inputs),
        position: s.ned_from_body * Vector3::new(s.nu[0], s.nu[1], s.nu[2]),
        attitude: s.ned_from_body.quaternion()
            * Quaternion::from_imag(Vector3::new(s.nu[3], s.nu[4], s.nu[5]))
            * 0.5,
        actuators: actuator_rates(model, &a, command),
    }
}

fn advanced(s: &MotionState, r: &Rates, h: f64) -> MotionState {
    let a = &s.actuators;
    let ra = &r.actuators;
    MotionState {
        nu: s.nu + r.nu * h,
        ned_from_body: UnitQuaternion::new_normalize(s.ned_from_body.into_inner() + r.attitude * h),
        position_m: s.position_m + r.position * h,
        actuators: Actuators {
            rudder_rad: a.rudder_rad + ra.rudder_rad * h,
            stern_rad: a.stern_rad + ra.stern_rad * h,
            bow_rad: a.bow_rad + ra.bow_rad * h,
            propeller_rad_s: a.propeller_rad_s + ra.propeller_rad_s * h,
        },
    }
}

/// One RK4 step of `dt` with constant commands. `earth_rate_ned`: Earth's rotation in NED
/// (zero for a flat, non-rotating world).
pub fn step(
    model: &SixDof,
    s: &MotionState,
    command: &Actuators,
    earth_rate_ned: &Vector3<f64>,
    dt: f64,
) -> MotionState {
    let k1 = rates(model, s, command, earth_rate_ned);
    step_from(model, s, &k1, command, earth_rate_ned, dt)
}

/// [`step`] with its first stage `k1 = rates(model, s, command, earth_rate_ned)` already
/// evaluated.
pub fn step_from(
    model: &SixDof,
    s: &MotionState,
    k1: &Rates,
    command: &Actuators,
    earth_rate_ned: &Vector3<f64>,
    dt: f64,
) -> MotionState {
    let k1 = *k1;
    let s2 = advanced(s, &k1, dt / 2.0);
    let k2 = rates(model, &s2, command, earth_rate_ned);
    let s3 = advanced(s, &k2, dt / 2.0);
    let k3 = rates(model, &s3, command, earth_rate_ned);
    let s4 = advanced(s, &k3, dt);
    let k4 = rates(model, &s4, command, earth_rate_ned);
    let mean = |f: &dyn Fn(&Rates) -> Nu| (f(&k1) + f(&k2) * 2.0 + f(&k3) * 2.0 + f(&k4)) / 6.0;
    let nu_rate = mean(&|r| r.nu);
    let attitude_rate = (k1.attitude + k2.attitude * 2.0 + k3.attitude * 2.0 + k4.attitude) / 6.0;
    let position_rate = (k1.position + k2.position * 2.0 + k3.position * 2.0 + k4.position) / 6.0;
    let act = |f: fn(&Actuators) -> f64| {
        (f(&k1.actuators) + 2.0 * f(&k2.actuators) + 2.0 * f(&k3.actuators) + f(&k4.actuators))
            / 6.0
    };
    let a = &s.actuators;
    let lim = model.vehicle.fin_limit_rad;
    MotionState {
        nu: s.nu + nu_rate * dt,
        ned_from_body: UnitQuaternion::new_normalize(
            s.ned_from_body.into_inner() + attitude_rate * dt,
        ),
        position_m: s.position_m + position_rate * dt,
        actuators: Actuators {
            rudder_rad: (a.rudder_rad + act(|x| x.rudder_rad) * dt).clamp(-lim, lim),
            stern_rad: (a.stern_rad + act(|x| x.stern_rad) * dt).clamp(-lim, lim),
            bow_rad: (a.bow_rad + act(|x| x.bow_rad) * dt).clamp(-lim, lim),
            propeller_rad_s: a.propeller_rad_s + act(|x| x.propeller_rad_s) * dt,
        },
    }
}
