//! The 6-DOF model flown by the autopilot (NPS AUV II, the default vehicle): heading and
//! depth steps, a turning circle at full rudder with depth held, a horizontal 20-20 zig-zag.
//!
//! `cargo test --release --test all vehicle_manoeuvres:: -- --nocapture`

use crate::common;
use hindsight::angle::wrap_pi;
use hindsight::vehicle::six_dof::autopilot::{Autopilot, AutopilotState, Command, Gains};
use hindsight::vehicle::six_dof::description::Vehicle;
use hindsight::vehicle::six_dof::model::SixDof;
use hindsight::vehicle::six_dof::motion::{step, MotionState};
use nalgebra::Vector3;

fn nps() -> SixDof {
    let file = common::shared_dir("vehicles", "nps-auv-ii.json").join("nps-auv-ii.json");
    SixDof::new(Vehicle::from_json(&std::fs::read_to_string(file).unwrap()).unwrap()).unwrap()
}

const DT: f64 = 0.01;

/// Flies `seconds` under `cmd`, calling `each` with the time and state every step.
fn fly(
    model: &SixDof,
    pilot: &Autopilot,
    s: &mut MotionState,
    cmd: &dyn Fn(f64, &MotionState) -> Command,
    seconds: f64,
    each: &mut dyn FnMut(f64, &MotionState),
) {
    let mut memory = AutopilotState::default();
    for k in 0..(seconds / DT) as usize {
        let t = k as f64 * DT;
        let c = cmd(t, s);
        let act = pilot.commands(model, s, &c, &mut memory, DT);
        *s = step(model, s, &act, &Vector3::zeros(), DT);
        each(t, s);
    }
}

fn cruise(speed: f64) -> (SixDof, Autopilot, MotionState) {
    let model = nps();
    let pilot = Autopilot::new(&model, speed, Gains::default()).unwrap();
    let mut s = MotionState::at(Vector3::new(0.0, 0.0, 20.0), 0.0);
    s.nu[0] = speed;
    s.actuators.propeller_rad_s = pilot.propeller_rad_s();
    (model, pilot, s)
}

#[test]
fn heading_and_depth_steps() {
    let (model, pilot, mut s) = cruise(1.5);
    let cmd = |_: f64, _: &MotionState| Command {
        heading_rad: Some(90f64.to_radians()),
        depth_m: Some(40.0),
        ..Command::at_speed(1.5)
    };
    let mut overshoot: f64 = 0.0;
    let mut late_heading: f64 = 0.0;
    let mut late_depth: f64 = 0.0;
    let mut max_depth: f64 = 0.0;
    fly(&model, &pilot, &mut s, &cmd, 300.0, &mut |t, s| {
        let (_, _, yaw) = s.euler();
        let e = wrap_pi(yaw - 90f64.to_radians()).to_degrees();
        overshoot = overshoot.max(e);
        max_depth = max_depth.max(s.position_m.z);
        if t > 200.0 {
            late_heading = late_heading.max(e.abs());
            late_depth = late_depth.max((s.position_m.z - 40.0).abs());
        }
    });
    println!(
        "heading step 0 -> 90 deg: overshoot {overshoot:.2} deg, after 200 s within {late_heading:.3} deg; \
         depth step 20 -> 40 m: deepest {max_depth:.2} m, after 200 s within {late_depth:.3} m; speed {:.3} m/s",
        s.nu[0]
    );
    assert!(late_heading < 1.0 && overshoot < 10.0);
    assert!(late_depth < 0.5 && max_depth < 45.0);
    assert!((s.nu[0] - 1.5).abs() < 0.02);
}

#[test]
fn turning_circle_at_full_rudder() {
    let (model, pilot, mut s) = cruise(1.5);
    let limit = model.vehicle.fin_limit_rad;
    let cmd = |_: f64, _: &MotionState| Command {
        depth_m: Some(20.0),
        rudder_rad: limit,
        ..Command::at_speed(1.5)
    };
    let (mut n, mut e) = (Vec::new(), Vec::new());
    let mut depth_error: f64 = 0.0;
    fly(&model, &pilot, &mut s, &cmd, 400.0, &mut |t, s| {
        if t > 200.0 {
            n.push(s.position_m.x);
            e.push(s.position_m.y);
            depth_error = depth_error.max((s.position_m.z - 20.0).abs());
        }
    });
    let span = |v: &[f64]| {
        v.iter().cloned().fold(f64::MIN, f64::max) - v.iter().cloned().fold(f64::MAX, f64::min)
    };
    let (_, _, _) = s.euler();
    println!(
        "turning circle, rudder {:.0} deg at 1.5 m/s commanded: diameter {:.1} x {:.1} m, speed in the turn {:.3} m/s, \
         yaw rate {:.4} rad/s, depth held within {depth_error:.2} m",
        limit.to_degrees(),
        span(&n),
        span(&e),
        s.nu[0],
        s.nu[5]
    );
    assert!((span(&n) - span(&e)).abs() < 1.0, "not a circle");
    assert!(depth_error < 2.0);
}

/// A zig-zag's fin at +-`a`: reversed once `angle` (heading or pitch) is `a` past zero in
/// the direction the fin drives it (a positive fin drives both negative on this vehicle).
fn reverse_past(fin: &std::cell::Cell<f64>, a: f64, angle: f64) {
    if fin.get() > 0.0 && angle < -a {
        fin.set(-a);
    } else if fin.get() < 0.0 && angle > a {
        fin.set(a);
    }
}

/// Counts a change of the fin since the last call.
fn count_reversal(fin: &std::cell::Cell<f64>, last: &mut f64, reversals: &mut u32) {
    if fin.get() != *last {
        *reversals += 1;
        *last = fin.get();
    }
}

#[test]
fn horizontal_zigzag_20_20() {
    let (model, pilot, mut s) = cruise(1.5);
    let a = 20f64.to_radians();
    let rudder = std::cell::Cell::new(a);
    let cmd = |_: f64, s: &MotionState| {
        let (_, _, yaw) = s.euler();
        // Reverse once the heading is 20 deg past the initial one in the rudder's direction
        // (positive rudder turns to port on this vehicle: negative yaw).
        reverse_past(&rudder, a, yaw);
        Command {
            depth_m: Some(20.0),
            rudder_rad: rudder.get(),
            ..Command::at_speed(1.5)
        }
    };
    let (mut reversals, mut last) = (0, a);
    let mut overshoot: f64 = 0.0;
    fly(&model, &pilot, &mut s, &cmd, 200.0, &mut |_, s| {
        count_reversal(&rudder, &mut last, &mut reversals);
        let (_, _, yaw) = s.euler();
        overshoot = overshoot.max(yaw.abs().to_degrees() - 20.0);
    });
    println!("zig-zag 20-20 at 1.5 m/s: {reversals} reversals in 200 s, heading overshoot {overshoot:.1} deg");
    assert!(reversals >= 3);
}

#[test]
fn vertical_zigzag_10_10() {
    let (model, pilot, mut s) = cruise(1.5);
    s.position_m.z = 50.0;
    let a = 10f64.to_radians();
    let planes = std::cell::Cell::new(a);
    let cmd = |_: f64, s: &MotionState| {
        let (_, pitch, _) = s.euler();
        // The plane reverses once the pitch is 10 deg past level in the direction it drives
        // (positive stern plane pitches this vehicle nose down).
        reverse_past(&planes, a, pitch);
        Command {
            heading_rad: Some(0.0),
            stern_rad: planes.get(),
            ..Command::at_speed(1.5)
        }
    };
    let (mut reversals, mut last) = (0, a);
    let (mut shallowest, mut deepest) = (f64::MAX, f64::MIN);
    fly(&model, &pilot, &mut s, &cmd, 200.0, &mut |_, s| {
        count_reversal(&planes, &mut last, &mut reversals);
        shallowest = shallowest.min(s.position_m.z);
        deepest = deepest.max(s.position_m.z);
    });
    println!(
        "vertical zig-zag 10-10 at 1.5 m/s: {reversals} reversals in 200 s, depth between {shallowest:.1} and {deepest:.1} m"
    );
    assert!(reversals >= 3);
}

/// Seed 002's dropped entry: the vehicle starts at speed with 10 deg roll and pitch errors;
/// the autopilot brings it level onto its depth and heading.
#[test]
fn dropped_entry_recovers() {
    let (model, pilot, mut s) = cruise(1.5);
    s.ned_from_body =
        nalgebra::UnitQuaternion::from_euler_angles(10f64.to_radians(), -10f64.to_radians(), 0.3);
    s.position_m.z = 5.0;
    let cmd = |_: f64, _: &MotionState| Command {
        heading_rad: Some(0.0),
        depth_m: Some(30.0),
        ..Command::at_speed(1.5)
    };
    let mut settled_roll: f64 = 0.0;
    let mut settled_depth: f64 = 0.0;
    fly(&model, &pilot, &mut s, &cmd, 300.0, &mut |t, s| {
        if t > 200.0 {
            let (roll, _, _) = s.euler();
            settled_roll = settled_roll.max(roll.abs().to_degrees());
            settled_depth = settled_depth.max((s.position_m.z - 30.0).abs());
        }
    });
    let (_, _, yaw) = s.euler();
    println!(
        "dropped entry (roll +10, pitch -10 deg at 5 m): after 200 s roll within {settled_roll:.3} deg, \
         depth within {settled_depth:.3} m of 30 m, heading {:.3} deg",
        yaw.to_degrees()
    );
    assert!(settled_roll < 0.5 && settled_depth < 0.5 && yaw.abs() < 1f64.to_radians());
}
