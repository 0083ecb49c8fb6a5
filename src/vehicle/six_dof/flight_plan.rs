//! Flight plans: timed phases the autopilot flies (seed 000's Table 1 mission, zig-zags,
//! turning circles, a dropped entry's recovery).
//!
//! Each phase lasts its `duration_s`. Depth and heading are flown along references that
//! move toward the phase's targets no faster than the plan's limits, so a phase that asks
//! more than the vehicle can do (Table 1 dives 300 m in 288 s; NPS AUV II descends about
//! 0.5 m/s) carries on into the next one, and tracking is judged against the references,
//! which are what the vehicle was commanded. Open-loop phases (rudder or plane zig-zags,
//! turning circles) hand back to the references at the attitude and depth they end with.

use super::autopilot::{Autopilot, AutopilotState, Command, Gains};
use super::model::SixDof;
use super::motion::{Actuators, MotionState};
use crate::angle::wrap_pi;
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// One phase. Angles in degrees; headings clockwise from north; depth positive down.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "kebab-case", deny_unknown_fields)]
pub enum Phase {
    /// Straight flight toward a heading and depth (each, when absent, held where it is).
    Cruise {
        duration_s: f64,
        heading_deg: Option<f64>,
        depth_m: Option<f64>,
    },
    /// The heading reference turning at `rate_deg_s` (positive to starboard) with the depth
    /// held or changed: a horizontal spiral, or a turn of a given angle over the duration.
    Spiral {
        duration_s: f64,
        rate_deg_s: f64,
        depth_m: Option<f64>,
    },
    /// The heading reference alternating `angle_deg` either side of the phase's first
    /// heading every `leg_s` (the autopilot steers).
    HeadingZigzag {
        duration_s: f64,
        angle_deg: f64,
        leg_s: f64,
        depth_m: Option<f64>,
    },
    /// Rudder at `rudder_deg`, reversed each time the heading passes `trigger_deg` from the
    /// phase's first heading in the direction it turns (an ITTC zig-zag); depth held.
    RudderZigzag {
        duration_s: f64,
        rudder_deg: f64,
        trigger_deg: f64,
    },
    /// Stern planes at `plane_deg`, reversed each time the pitch passes `trigger_deg` from
    /// level in the direction they drive; heading held.
    PlaneZigzag {
        duration_s: f64,
        plane_deg: f64,
        trigger_deg: f64,
    },
    /// Rudder held at `rudder_deg` (default: the vehicle's limit), depth held.
    TurningCircle {
        duration_s: f64,
        rudder_deg: Option<f64>,
    },
}

impl Phase {
    pub fn duration_s(&self) -> f64 {
        match *self {
            Phase::Cruise { duration_s, .. }
            | Phase::Spiral { duration_s, .. }
            | Phase::HeadingZigzag { duration_s, .. }
            | Phase::RudderZigzag { duration_s, .. }
            | Phase::PlaneZigzag { duration_s, .. }
            | Phase::TurningCircle { duration_s, .. } => duration_s,
        }
    }

    /// The phase's `type` name in the scenario file.
    pub fn kind(&self) -> &'static str {
        match self {
            Phase::Cruise { .. } => "cruise",
            Phase::Spiral { .. } => "spiral",
            Phase::HeadingZigzag { .. } => "heading-zigzag",
            Phase::RudderZigzag { .. } => "rudder-zigzag",
            Phase::PlaneZigzag { .. } => "plane-zigzag",
            Phase::TurningCircle { .. } => "turning-circle",
        }
    }

    fn depth_target(&self) -> Option<f64> {
        match *self {
            Phase::Cruise { depth_m, .. }
            | Phase::Spiral { depth_m, .. }
            | Phase::HeadingZigzag { depth_m, .. } => depth_m,
            _ => None,
        }
    }

    /// What makes the phase unflyable, if anything (numbers are checked finite elsewhere).
    pub fn problem(&self) -> Option<String> {
        let positive =
            |name: &str, v: f64| (v <= 0.0).then(|| format!("{name} {v} must be above 0"));
        match *self {
            _ if self.duration_s() <= 0.0 => positive("duration_s", self.duration_s()),
            Phase::HeadingZigzag {
                leg_s, angle_deg, ..
            } => positive("leg_s", leg_s).or_else(|| positive("angle_deg", angle_deg)),
            Phase::RudderZigzag {
                rudder_deg,
                trigger_deg,
                ..
            } => {
                positive("rudder_deg", rudder_deg).or_else(|| positive("trigger_deg", trigger_deg))
            }
            Phase::PlaneZigzag {
                plane_deg,
                trigger_deg,
                ..
            } => positive("plane_deg", plane_deg).or_else(|| positive("trigger_deg", trigger_deg)),
            _ => None,
        }
    }
}

/// A plan: the phases, the commanded speed and the references' limits.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    pub speed_m_s: f64,
    /// Fastest change of the depth reference, m/s.
    pub max_vertical_rate_m_s: f64,
    /// Fastest turn of the heading reference toward a target heading, rad/s.
    pub max_turn_rate_rad_s: f64,
    /// Fastest change of the references' rates: rad/s^2 and m/s^2 (turns and depth
    /// changes start and end smoothly).
    pub turn_accel_rad_s2: f64,
    pub vertical_accel_m_s2: f64,
    pub phases: Vec<Phase>,
}

impl Plan {
    /// A plan with the default rate changes: 0.2 deg/s^2 (a 3 deg/s turn starts in 15 s)
    /// and 0.01 m/s^2 (0.4 m/s of descent in 40 s).
    pub fn new(
        speed_m_s: f64,
        max_vertical_rate_m_s: f64,
        max_turn_rate_rad_s: f64,
        phases: Vec<Phase>,
    ) -> Plan {
        Plan {
            speed_m_s,
            max_vertical_rate_m_s,
            max_turn_rate_rad_s,
            turn_accel_rad_s2: 0.2f64.to_radians(),
            vertical_accel_m_s2: 0.01,
            phases,
        }
    }
}

impl Plan {
    pub fn duration_s(&self) -> f64 {
        self.phases.iter().map(Phase::duration_s).sum()
    }
}

/// Why a plan cannot be flown by this vehicle.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PlanError {
    #[error(
        "the vehicle cannot hold {speed_m_s} m/s in straight, level flight within its propeller limit (or a fin has no effect)"
    )]
    Speed { speed_m_s: f64 },
}

/// What the vehicle was asked to follow at one instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reference {
    /// Index of the phase in the plan.
    pub phase: usize,
    pub depth_m: f64,
    /// Depth is under closed-loop control (not a plane zig-zag).
    pub depth_held: bool,
    /// The heading reference, rad, when the autopilot steers (not during open-loop rudder).
    pub heading_rad: Option<f64>,
}

/// A reference moved toward its target with its rate and the rate's change limited, braking
/// so as to arrive without overshoot (a time-optimal second-order profile).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Slew {
    value: f64,
    rate: f64,
}

impl Slew {
    fn at(value: f64) -> Slew {
        Slew { value, rate: 0.0 }
    }

    /// One step toward the target `error` away (target - value), or, with `rate`, turning
    /// at that rate; returns the reference's rate.
    fn step(&mut self, goal: Goal, max_rate: f64, max_accel: f64, dt: f64) -> f64 {
        let wanted = match goal {
            Goal::Error(e) => {
                // The fastest rate that still stops at the target braking step by step:
                // v^2 / (2 a) + v dt / 2 = |e|.
                let braking =
                    max_accel * (-dt / 2.0 + (dt * dt / 4.0 + 2.0 * e.abs() / max_accel).sqrt());
                (braking.min(e.abs() / dt) * e.signum()).clamp(-max_rate, max_rate)
            }
            Goal::Rate(r) => r,
        };
        self.rate += (wanted - self.rate).clamp(-max_accel * dt, max_accel * dt);
        self.value += self.rate * dt;
        self.rate
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Goal {
    /// Target minus value.
    Error(f64),
    Rate(f64),
}

/// Open-loop fin state of a zig-zag: the deflection's sign and the reference it reverses
/// about.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Zigzag {
    sign: f64,
    base_rad: f64,
    reversals: u32,
}

/// Flies a plan: phase by phase, references moved within their limits, the autopilot's
/// fin and propeller commands.
#[derive(Debug, Clone)]
pub struct PlanPilot {
    plan: Plan,
    autopilot: Autopilot,
    memory: AutopilotState,
    phase: usize,
    phase_start_s: f64,
    depth: Slew,
    depth_target: f64,
    heading: Slew,
    zigzag: Zigzag,
    fin_limit_rad: f64,
}

impl PlanPilot {
    /// A pilot starting from `start` (its depth and heading are the first references).
    pub fn new(model: &SixDof, plan: Plan, start: &MotionState) -> Result<PlanPilot, PlanError> {
        let autopilot =
            Autopilot::new(model, plan.speed_m_s, Gains::default()).ok_or(PlanError::Speed {
                speed_m_s: plan.speed_m_s,
            })?;
        let (_, _, yaw) = start.euler();
        let mut pilot = PlanPilot {
            phase_start_s: 0.0,
            phase: usize::MAX,
            plan,
            autopilot,
            memory: AutopilotState::default(),
            depth: Slew::at(start.position_m.z),
            depth_target: start.position_m.z,
            heading: Slew::at(yaw),
            zigzag: Zigzag {
                sign: 1.0,
                base_rad: yaw,
                reversals: 0,
            },
            fin_limit_rad: model.vehicle.fin_limit_rad,
        };
        pilot.enter(0, 0.0, start);
        Ok(pilot)
    }

    /// The propeller speed that holds the commanded speed (to start the vehicle at it).
    pub fn cruise_propeller_rad_s(&self) -> f64 {
        self.autopilot.propeller_rad_s()
    }

    pub fn plan(&self) -> &Plan {
        &self.plan
    }

    /// Fin reversals of the current (or last) zig-zag phase.
    pub fn reversals(&self) -> u32 {
        self.zigzag.reversals
    }

    fn current(&self) -> Option<&Phase> {
        self.plan.phases.get(self.phase)
    }

    fn enter(&mut self, phase: usize, t_s: f64, s: &MotionState) {
        let (_, _, yaw) = s.euler();
        let descent = (s.ned_from_body * Vector3::new(s.nu[0], s.nu[1], s.nu[2])).z;
        // Leaving open loop (or starting): the references take over where the vehicle is.
        let heading_free = |p: Option<&Phase>| {
            matches!(
                p,
                None | Some(Phase::RudderZigzag { .. } | Phase::TurningCircle { .. })
            )
        };
        let depth_free = |p: Option<&Phase>| matches!(p, None | Some(Phase::PlaneZigzag { .. }));
        let next = self.plan.phases.get(phase);
        if heading_free(self.current()) || heading_free(next) {
            self.heading = Slew {
                value: yaw,
                rate: s.nu[5],
            };
        }
        if depth_free(self.current()) || depth_free(next) {
            self.depth = Slew {
                value: s.position_m.z,
                rate: descent,
            };
            self.depth_target = s.position_m.z;
        }
        if let Some(d) = next.and_then(Phase::depth_target) {
            self.depth_target = d;
        }
        self.zigzag = Zigzag {
            sign: 1.0,
            base_rad: self.heading.value,
            reversals: 0,
        };
        self.phase = phase;
        self.phase_start_s = t_s;
    }

    /// The actuator commands at `t_s` for state `s` (called once per step of `dt`), and
    /// the references they follow.
    pub fn command(
        &mut self,
        model: &SixDof,
        t_s: f64,
        s: &MotionState,
        dt: f64,
    ) -> (Actuators, Reference) {
        while self.phase + 1 < self.plan.phases.len()
            && t_s >= self.phase_start_s + self.plan.phases[self.phase].duration_s()
        {
            let start = self.phase_start_s + self.plan.phases[self.phase].duration_s();
            self.enter(self.phase + 1, start, s);
        }
        let phase = self.current().copied();
        let (_, pitch, yaw) = s.euler();
        let mut cmd = Command::at_speed(self.plan.speed_m_s);
        // What the heading reference does: toward a target, turn at a rate, or none (the
        // rudder is open loop).
        let heading_goal = match phase {
            Some(Phase::Cruise { heading_deg, .. }) => Some(match heading_deg {
                Some(h) => Goal::Error(wrap_pi(h.to_radians() - self.heading.value)),
                None => Goal::Rate(0.0),
            }),
            Some(Phase::Spiral { rate_deg_s, .. }) => Some(Goal::Rate(rate_deg_s.to_radians())),
            Some(Phase::HeadingZigzag {
                angle_deg, leg_s, ..
            }) => {
                let leg = ((t_s - self.phase_start_s) / leg_s.max(1e-9)).floor() as i64;
                let side = if leg % 2 == 0 { 1.0 } else { -1.0 };
                let target = self.zigzag.base_rad + side * angle_deg.to_radians();
                Some(Goal::Error(wrap_pi(target - self.heading.value)))
            }
            Some(Phase::PlaneZigzag { .. }) | None => Some(Goal::Rate(0.0)),
            Some(Phase::RudderZigzag {
                rudder_deg,
                trigger_deg,
                ..
            }) => {
                // The rudder turns the vehicle by `rudder_yaw_sign` per positive angle.
                let turning = self.zigzag.sign * self.autopilot.rudder_yaw_sign();
                if turning * wrap_pi(yaw - self.zigzag.base_rad) > trigger_deg.to_radians() {
                    self.zigzag.sign = -self.zigzag.sign;
                    self.zigzag.reversals += 1;
                }
                cmd.rudder_rad = self.zigzag.sign * rudder_deg.to_radians();
                None
            }
            Some(Phase::TurningCircle { rudder_deg, .. }) => {
                cmd.rudder_rad = rudder_deg.map_or(self.fin_limit_rad, f64::to_radians);
                None
            }
        };
        if let Some(goal) = heading_goal {
            let rate = self.heading.step(
                goal,
                self.plan.max_turn_rate_rad_s,
                self.plan.turn_accel_rad_s2,
                dt,
            );
            self.heading.value = wrap_pi(self.heading.value);
            cmd.heading_rad = Some(self.heading.value);
            cmd.heading_rate_rad_s = rate;
        }
        if let Some(Phase::PlaneZigzag {
            plane_deg,
            trigger_deg,
            ..
        }) = phase
        {
            let pitching = self.zigzag.sign * self.autopilot.stern_pitch_sign();
            if pitching * pitch > trigger_deg.to_radians() {
                self.zigzag.sign = -self.zigzag.sign;
                self.zigzag.reversals += 1;
            }
            cmd.stern_rad = self.zigzag.sign * plane_deg.to_radians();
        } else {
            let rate = self.depth.step(
                Goal::Error(self.depth_target - self.depth.value),
                self.plan.max_vertical_rate_m_s,
                self.plan.vertical_accel_m_s2,
                dt,
            );
            cmd.depth_m = Some(self.depth.value);
            cmd.depth_rate_m_s = rate;
        }
        let actuators = self
            .autopilot
            .commands(model, s, &cmd, &mut self.memory, dt);
        let reference = Reference {
            phase: self.phase.min(self.plan.phases.len().saturating_sub(1)),
            depth_m: self.depth.value,
            depth_held: cmd.depth_m.is_some(),
            heading_rad: cmd.heading_rad,
        };
        (actuators, reference)
    }
}

/// The state a plan starts from: at `position_m`, heading `yaw_rad`, with roll and pitch
/// (a dropped vehicle's), moving ahead at `speed_m_s` with the propeller at `propeller_rad_s`.
pub fn start_state(
    position_m: Vector3<f64>,
    roll_rad: f64,
    pitch_rad: f64,
    yaw_rad: f64,
    speed_m_s: f64,
    propeller_rad_s: f64,
) -> MotionState {
    let mut s = MotionState::at(position_m, yaw_rad);
    s.ned_from_body = nalgebra::UnitQuaternion::from_euler_angles(roll_rad, pitch_rad, yaw_rad);
    s.nu[0] = speed_m_s;
    s.actuators.propeller_rad_s = propeller_rad_s;
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::vehicle::six_dof::description::Vehicle;
    use crate::vehicle::six_dof::motion::step;

    #[test]
    fn slew_respects_its_limits_and_arrives_without_overshoot() {
        let (max_rate, max_accel, dt) = (1.0, 0.1, 0.01);
        let mut s = Slew::at(0.0);
        let mut previous_rate = 0.0;
        let mut arrived_s = None;
        for k in 0..4000 {
            let rate = s.step(Goal::Error(10.0 - s.value), max_rate, max_accel, dt);
            assert!(rate.abs() <= max_rate + 1e-12);
            assert!((rate - previous_rate).abs() <= max_accel * dt + 1e-12);
            assert!(s.value <= 10.0 + 1e-9, "overshoot to {}", s.value);
            previous_rate = rate;
            if arrived_s.is_none() && (10.0 - s.value).abs() < 1e-3 {
                arrived_s = Some(k as f64 * dt);
            }
        }
        // Time-optimal: 10 s to reach 1/s, 10 s to stop, 0 m ... 10 m at 1/s in between:
        // 10 + 10 = 20 s (within 1 mm a little before).
        let t = arrived_s.expect("arrives");
        assert!((19.5..21.0).contains(&t), "{t}");
        // A rate goal is followed at the acceleration limit.
        let mut s = Slew::at(0.0);
        for _ in 0..100 {
            s.step(Goal::Rate(0.5), max_rate, max_accel, dt);
        }
        assert!((s.rate - 0.1).abs() < 1e-9);
    }

    fn nps() -> SixDof {
        SixDof::new(Vehicle::built_in("nps-auv-ii").unwrap().unwrap()).unwrap()
    }

    /// Flies `phases` from 30 m, heading 0, at 1.5 m/s; returns the references and states
    /// every step.
    fn fly(phases: Vec<Phase>) -> (PlanPilot, Vec<(f64, Reference, MotionState)>) {
        let model = nps();
        let plan = Plan::new(1.5, 0.4, 3f64.to_radians(), phases);
        let duration = plan.duration_s();
        let mut s = start_state(Vector3::new(0.0, 0.0, 30.0), 0.0, 0.0, 0.0, 1.5, 0.0);
        let mut pilot = PlanPilot::new(&model, plan, &s).unwrap();
        s.actuators.propeller_rad_s = pilot.cruise_propeller_rad_s();
        let dt = 0.01;
        let mut out = Vec::new();
        for k in 0..(duration / dt).round() as usize {
            let t = k as f64 * dt;
            let (act, reference) = pilot.command(&model, t, &s, dt);
            s = step(&model, &s, &act, &Vector3::zeros(), dt);
            out.push((t, reference, s));
        }
        (pilot, out)
    }

    #[test]
    fn phases_switch_on_time_and_hand_back_where_the_vehicle_is() {
        let (pilot, run) = fly(vec![
            Phase::Cruise {
                duration_s: 30.0,
                heading_deg: None,
                depth_m: None,
            },
            Phase::PlaneZigzag {
                duration_s: 120.0,
                plane_deg: 10.0,
                trigger_deg: 10.0,
            },
            Phase::Cruise {
                duration_s: 60.0,
                heading_deg: Some(30.0),
                depth_m: None,
            },
        ]);
        let phase_at = |t: f64| run.iter().find(|r| r.0 >= t).unwrap().1.phase;
        assert_eq!(
            (phase_at(29.99), phase_at(30.0), phase_at(150.0)),
            (0, 1, 2)
        );
        // The plane zig-zag reversed at its trigger and left depth to the vehicle.
        assert!(run.iter().all(|r| r.1.phase != 1 || !r.1.depth_held));
        // The cruise after it holds the depth it ended at (no jump back to 30 m) ...
        let handed_over = run.iter().find(|r| r.1.phase == 2).unwrap();
        let depth_then = handed_over.2.position_m.z;
        assert!((handed_over.1.depth_m - depth_then).abs() < 0.05);
        let last = run.last().unwrap();
        assert!(
            (last.1.depth_m - depth_then).abs() < 2.0,
            "{} vs {depth_then}",
            last.1.depth_m
        );
        // ... and turns to its heading.
        let (_, _, yaw) = last.2.euler();
        assert!(
            (yaw.to_degrees() - 30.0).abs() < 1.0,
            "{}",
            yaw.to_degrees()
        );
        assert_eq!(
            pilot.reversals(),
            0,
            "counted per phase: the cruise made none"
        );
        let reversals_in_zigzag = run
            .windows(2)
            .filter(|w| w[0].1.phase == 1 && w[1].1.phase == 1)
            .filter(|w| w[0].2.actuators.stern_rad.signum() != w[1].2.actuators.stern_rad.signum())
            .count();
        assert!(reversals_in_zigzag >= 3, "{reversals_in_zigzag}");
    }

    #[test]
    fn heading_zigzag_alternates_about_the_first_heading() {
        let (_, run) = fly(vec![Phase::HeadingZigzag {
            duration_s: 240.0,
            angle_deg: 20.0,
            leg_s: 60.0,
            depth_m: None,
        }]);
        let heading_at = |t: f64| {
            let r = run.iter().find(|r| r.0 >= t).unwrap();
            r.2.euler().2.to_degrees()
        };
        // Each leg ends near its side: +20, -20, +20, -20 deg.
        for (t, side) in [(59.0, 20.0), (119.0, -20.0), (179.0, 20.0), (239.0, -20.0)] {
            assert!((heading_at(t) - side).abs() < 2.0, "{t}: {}", heading_at(t));
        }
    }
}
