//! Seed 000's 6-DOF model on the shared vehicle files: loading (and refusing bad files),
//! Jacobians against finite differences, and energy conservation without hydrodynamics.
//!
//! `cargo test --release --test all vehicle_model:: -- --nocapture`

use crate::common;
use hindsight::vehicle::six_dof::description::{Propulsion, Vehicle, VehicleError};
use hindsight::vehicle::six_dof::model::{Attitude, SixDof};
use hindsight::vehicle::six_dof::terms::{Inputs, Nu};
use nalgebra::{Matrix6, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};

fn text(name: &str) -> String {
    std::fs::read_to_string(common::shared_dir("vehicles", "nps-auv-ii.json").join(name)).unwrap()
}

fn load(name: &str) -> Vehicle {
    Vehicle::from_json(&text(name)).unwrap()
}

#[test]
fn both_vehicle_files_load() {
    let nps = load("nps-auv-ii.json");
    assert!((nps.mass_kg - 53400.0 / 9.81).abs() < 1e-9);
    // Every coefficient of the file is a term or added mass (93 names, 14 of them added mass).
    assert_eq!(nps.terms.len(), 79, "{}", nps.terms.len());
    // Z_w' = -0.3 scaled by (rho/2) L^2 (a velocity product).
    let zw = nps.coefficient("Zw");
    assert!((zw - -0.3 * 512.5 * 5.3f64.powi(2)).abs() < 1e-9, "{zw}");
    // Z_wdot' = -0.24 by (rho/2) L^3, as added mass +.
    assert!((nps.added_mass[(2, 2)] - 0.24 * 512.5 * 5.3f64.powi(3)).abs() < 1e-6);
    assert!(matches!(nps.propulsion, Propulsion::Nps { .. }));
    let remus = load("remus-100.json");
    assert!((remus.mass_kg - 299.0 / 9.81).abs() < 1e-9);
    assert_eq!(remus.coefficient("Yuudr"), 9.64);
    assert!(matches!(remus.propulsion, Propulsion::Quadratic { .. }));
    for v in [nps, remus] {
        assert!(SixDof::new(v).unwrap().mass_matrix().cholesky().is_some());
    }
}

#[test]
fn bad_files_are_named() {
    let nps = text("nps-auv-ii.json");
    let mut no_mass: serde_json::Value = serde_json::from_str(&text("remus-100.json")).unwrap();
    no_mass["physical"].as_object_mut().unwrap().remove("W_N");
    let e = Vehicle::from_json(&no_mass.to_string()).unwrap_err();
    assert_eq!(e, VehicleError::Missing("physical.W_N".into()), "{e}");
    let negative = nps.replace("\"Iy_kgm2\": 13587.0", "\"Iy_kgm2\": -13587.0");
    assert_ne!(negative, nps);
    let e = Vehicle::from_json(&negative).unwrap_err();
    assert!(e.to_string().contains("physical.Iy_kgm2"), "{e}");
    let unknown = nps.replace("\"Zw\":", "\"Zwq_typo\":");
    assert_ne!(unknown, nps);
    let e = Vehicle::from_json(&unknown).unwrap_err();
    assert!(
        e.to_string()
            .starts_with("unknown coefficient `Zwq_typo` in `heave`"),
        "{e}"
    );
    assert!(matches!(
        Vehicle::from_json("{"),
        Err(VehicleError::Json(_))
    ));
}

fn random_state(rng: &mut impl Rng) -> (Nu, Attitude, Inputs) {
    let nu = Nu::new(
        rng.random_range(0.3..3.0),
        rng.random_range(-0.5..0.5),
        rng.random_range(-0.5..0.5),
        rng.random_range(-0.3..0.3),
        rng.random_range(-0.3..0.3),
        rng.random_range(-0.3..0.3),
    );
    let at = Attitude {
        roll_rad: rng.random_range(-0.5..0.5),
        pitch_rad: rng.random_range(-0.5..0.5),
        earth_rate_body: Vector3::new(5e-5, -2e-5, 3e-5),
    };
    let inputs = Inputs {
        rudder_rad: rng.random_range(-0.3..0.3),
        stern_rad: rng.random_range(-0.3..0.3),
        bow_rad: rng.random_range(-0.3..0.3),
        propeller_rad_s: rng.random_range(20.0..150.0),
    };
    (nu, at, inputs)
}

/// d nu' / d nu (seed 000 appendix) against central differences at many random states:
/// relative error under 1e-6 of the largest entry of its row.
#[test]
fn jacobians_match_finite_differences() {
    for file in ["nps-auv-ii.json", "remus-100.json"] {
        let model = SixDof::new(load(file)).unwrap();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(70);
        let mut worst: f64 = 0.0;
        for _ in 0..300 {
            let (nu, at, inputs) = random_state(&mut rng);
            let analytic = model.jacobian(&nu, &at, &inputs);
            // The simulator's value-only path is the same sum, term by term.
            let (with_gradient, alone) = (
                model.derivative(&nu, &at, &inputs).0,
                model.acceleration(&nu, &at, &inputs),
            );
            assert!(
                (with_gradient - alone).abs().max() <= 1e-12 * with_gradient.abs().max(),
                "{file}: {with_gradient} vs {alone}"
            );
            let mut numeric = Matrix6::zeros();
            for j in 0..6 {
                let h = 1e-6 * (1.0 + nu[j].abs());
                let (mut up, mut down) = (nu, nu);
                up[j] += h;
                down[j] -= h;
                let column = (model.derivative(&up, &at, &inputs).0
                    - model.derivative(&down, &at, &inputs).0)
                    / (2.0 * h);
                numeric.set_column(j, &column);
            }
            for i in 0..6 {
                let scale = analytic.row(i).abs().max().max(1e-12);
                let err = (analytic.row(i) - numeric.row(i)).abs().max() / scale;
                worst = worst.max(err);
                assert!(err < 1e-6, "{file} row {i}: {err:e}\n{analytic}\n{numeric}");
            }
        }
        println!("{file}: worst relative Jacobian error {worst:.1e}");
    }
}

/// With every hydrodynamic term, added mass, cross-flow and propulsion removed, kinetic plus
/// potential energy is conserved (to 1e-6 relative over 100 s).
#[test]
fn energy_is_conserved_without_hydrodynamics() {
    let mut v = load("nps-auv-ii.json");
    v.terms.clear();
    v.added_mass = Matrix6::zeros();
    v.crossflow = None;
    v.propulsion = Propulsion::Quadratic {
        thrust: 0.0,
        torque: 0.0,
    };
    let model = SixDof::new(v.clone()).unwrap();
    let inputs = Inputs {
        rudder_rad: 0.0,
        stern_rad: 0.0,
        bow_rad: 0.0,
        propeller_rad_s: 0.0,
    };
    // State: nu, attitude (ned_from_body), down position.
    let mut nu = Nu::new(1.5, 0.2, -0.1, 0.3, -0.2, 0.25);
    let mut q = UnitQuaternion::from_euler_angles(0.2, -0.1, 0.5);
    let mut down = 10.0;
    let energy = |nu: &Nu, q: &UnitQuaternion<f64>, down: f64| {
        let kinetic = 0.5 * nu.dot(&(model.mass_matrix() * nu));
        let g_world = q * v.centre_of_gravity_m;
        let b_world = q * v.centre_of_buoyancy_m;
        // Gravity does work moving down: potential -W z_G,down + B z_B,down.
        kinetic - v.weight_n * (down + g_world.z) + v.buoyancy_n * (down + b_world.z)
    };
    let e0 = energy(&nu, &q, down);
    let f = |nu: &Nu, q: &UnitQuaternion<f64>| {
        let (roll_rad, pitch_rad, _) = q.euler_angles();
        let at = Attitude {
            roll_rad,
            pitch_rad,
            earth_rate_body: Vector3::zeros(),
        };
        model.derivative(nu, &at, &inputs).0
    };
    let dt = 0.001;
    for _ in 0..100_000 {
        // RK4 on nu and down; the attitude turned exactly over each stage.
        let step = |nu: &Nu, q: &UnitQuaternion<f64>, h: f64, k: &Nu| {
            let n2 = nu + k * h;
            let w = Vector3::new(n2[3], n2[4], n2[5]);
            (n2, q * UnitQuaternion::from_scaled_axis(w * h))
        };
        let vel_down = |nu: &Nu, q: &UnitQuaternion<f64>| (q * Vector3::new(nu[0], nu[1], nu[2])).z;
        let k1 = f(&nu, &q);
        let z1 = vel_down(&nu, &q);
        let (n2, q2) = step(&nu, &q, dt / 2.0, &k1);
        let k2 = f(&n2, &q2);
        let z2 = vel_down(&n2, &q2);
        let (n3, q3) = step(&nu, &q, dt / 2.0, &k2);
        let k3 = f(&n3, &q3);
        let z3 = vel_down(&n3, &q3);
        let (n4, q4) = step(&nu, &q, dt, &k3);
        let k4 = f(&n4, &q4);
        let z4 = vel_down(&n4, &q4);
        let wbar = {
            let w = |n: &Nu| Vector3::new(n[3], n[4], n[5]);
            (w(&nu) + w(&n2) * 2.0 + w(&n3) * 2.0 + w(&n4)) / 6.0
        };
        nu += (k1 + k2 * 2.0 + k3 * 2.0 + k4) * (dt / 6.0);
        down += (z1 + z2 * 2.0 + z3 * 2.0 + z4) * (dt / 6.0);
        q *= UnitQuaternion::from_scaled_axis(wbar * dt);
    }
    let e1 = energy(&nu, &q, down);
    let drift = ((e1 - e0) / e0).abs();
    println!("energy {e0:.6} J -> {e1:.6} J over 100 s: relative drift {drift:.1e}");
    assert!(drift < 1e-6, "{drift:e}");
}

/// The straight-line stability indices agree with the simulated response to a small
/// disturbance: from straight flight at full-propeller speed, a yaw (or pitch) rate of
/// 0.01 rad/s dies out when the index is positive and does not when it is negative. The
/// test vehicles are made neutrally buoyant, without propeller torque, and (for the vertical
/// plane) with the centre of gravity at the centre of buoyancy, so that each plane's
/// straight-line dynamics are what is tested.
#[test]
fn stability_indices_agree_with_simulated_response() {
    use hindsight::vehicle::six_dof::motion::{step, Actuators, MotionState};
    use hindsight::vehicle::six_dof::properties::Properties;
    for file in ["nps-auv-ii.json", "remus-100.json"] {
        for (plane, rate_index) in [("horizontal", 5usize), ("vertical", 4)] {
            let mut v = load(file);
            v.buoyancy_n = v.weight_n;
            if let Propulsion::Quadratic { thrust, .. } = v.propulsion {
                v.propulsion = Propulsion::Quadratic {
                    thrust,
                    torque: 0.0,
                };
            }
            if plane == "vertical" {
                v.centre_of_gravity_m = v.centre_of_buoyancy_m;
            }
            let model = SixDof::new(v).unwrap();
            let p = Properties::of(&model);
            let index = if plane == "horizontal" {
                p.horizontal.index
            } else {
                p.vertical.index
            };
            let mut s = MotionState::at(Vector3::new(0.0, 0.0, 50.0), 0.0);
            s.nu[0] = p.full_speed_m_s.unwrap();
            s.nu[rate_index] = 0.01;
            let command = Actuators {
                propeller_rad_s: model.vehicle.propeller_limit_rad_s,
                ..Default::default()
            };
            s.actuators = command;
            for _ in 0..12_000 {
                s = step(&model, &s, &command, &Vector3::zeros(), 0.01);
            }
            let ratio = s.nu[rate_index].abs() / 0.01;
            println!(
                "{file} {plane}: index {index:+.5}, rate after 120 s {ratio:.3} of the disturbance"
            );
            assert_eq!(
                index > 0.0,
                ratio < 0.3,
                "{file} {plane}: index {index}, ratio {ratio}"
            );
        }
    }
}

/// `hindsight vehicle check` on both files, and on a broken one.
#[test]
fn vehicle_check_command() {
    let bin = env!("CARGO_BIN_EXE_hindsight");
    for (file, expect) in [
        (
            "nps-auv-ii.json",
            "horizontal C_H         +0.00129 (straight-line stable)",
        ),
        (
            "remus-100.json",
            "net buoyancy                11.00 N (floats up)",
        ),
    ] {
        let o = std::process::Command::new(bin)
            .args([
                "vehicle",
                "check",
                common::shared_dir("vehicles", "nps-auv-ii.json")
                    .join(file)
                    .to_str()
                    .unwrap(),
            ])
            .output()
            .unwrap();
        let out = String::from_utf8_lossy(&o.stdout);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        assert!(out.contains(expect), "{out}");
    }
    let dir = std::env::temp_dir().join(format!("hindsight-vehicle-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bad = dir.join("bad.json");
    std::fs::write(
        &bad,
        text("nps-auv-ii.json").replace("\"Ix_kgm2\": 2038.0", "\"Ix_kgm2\": -2038.0"),
    )
    .unwrap();
    let o = std::process::Command::new(bin)
        .args(["vehicle", "check", bad.to_str().unwrap()])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(3), "{err}");
    assert!(
        err.contains("physical.Ix_kgm2") && err.contains("must be a positive number"),
        "{err}"
    );
}

/// `--coef-uncertainty`'s draw (seed 000 case 2: normal, 1 sigma, cut at 3 sigma): seeded,
/// within its bounds, of the asked spread, and zero uncertainty changes
/// nothing.
#[test]
fn perturbed_vehicles_are_seeded_and_bounded() {
    let v = load("nps-auv-ii.json");
    let (a, fa) = v.perturbed(0.1, 7);
    let (b, fb) = v.perturbed(0.1, 7);
    let (c, _) = v.perturbed(0.1, 8);
    assert_eq!(a, b);
    assert_eq!(fa, fb);
    assert_ne!(a, c);
    // Every term, the 14 added-mass entries, the propulsion's Cd0 and thrust factor, and the
    // two cross-flow drag coefficients.
    assert_eq!(fa.len(), v.terms.len() + 14 + 4);
    assert!(fa.iter().all(|(_, k)| (0.7..=1.3).contains(k)));
    // Normal with 1-sigma 0.1: the sample's spread is near it (97 draws).
    let sd = (fa.iter().map(|(_, k)| (k - 1.0).powi(2)).sum::<f64>() / fa.len() as f64).sqrt();
    assert!((0.08..0.12).contains(&sd), "spread {sd}");
    assert!(SixDof::new(a).unwrap().mass_matrix().cholesky().is_some());
    assert_eq!(v.perturbed(0.0, 7).0, v);
}

/// The vehicles shipped in the binary are the shared reference files, unchanged.
#[test]
fn built_in_vehicles_are_the_shared_files() {
    for (name, text) in hindsight::vehicle::six_dof::description::BUILT_IN {
        assert_eq!(*text, self::text(&format!("{name}.json")), "{name}");
        assert!(Vehicle::built_in(name).unwrap().is_ok());
    }
    assert!(Vehicle::built_in("no-such-vehicle").is_none());
}
