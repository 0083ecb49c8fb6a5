//! `hindsight vehicle check FILE`: a vehicle description's derived properties.

use anyhow::{Context, Result};
use hindsight::vehicle::six_dof::description::Vehicle;
use hindsight::vehicle::six_dof::model::SixDof;
use hindsight::vehicle::six_dof::properties::{PlaneStability, Properties};
use std::path::PathBuf;

/// Vehicle descriptions (6-DOF model files, e.g. shared/vehicles/nps-auv-ii.json).
#[derive(Debug, clap::Args)]
pub struct VehicleArgs {
    #[command(subcommand)]
    pub command: VehicleCommand,
}

#[derive(Debug, clap::Subcommand)]
pub enum VehicleCommand {
    /// Read a vehicle file and print its derived properties: mass and displacement, net
    /// buoyancy, metacentric height, added mass, full-propeller speed, and the straight-line
    /// stability indices of both planes. Fails, naming the key, on a missing mass, a
    /// negative inertia, an unknown coefficient or a singular mass matrix.
    Check {
        /// Vehicle description (JSON).
        file: PathBuf,
    },
}

/// The mass matrix of a vehicle file is singular.
#[derive(Debug, thiserror::Error)]
#[error("the mass matrix (rigid body plus added mass) is singular")]
pub struct SingularMass;

pub fn run(args: VehicleArgs) -> Result<()> {
    let VehicleCommand::Check { file } = args.command;
    let text =
        std::fs::read_to_string(&file).with_context(|| format!("reading {}", file.display()))?;
    let vehicle = Vehicle::from_json(&text).with_context(|| format!("in {}", file.display()))?;
    let terms = vehicle.terms.len();
    let model = SixDof::new(vehicle)
        .ok_or(SingularMass)
        .with_context(|| format!("in {}", file.display()))?;
    if model.mass_matrix().cholesky().is_none() {
        return Err(SingularMass).with_context(|| {
            format!(
                "in {}: the mass matrix is not positive definite",
                file.display()
            )
        });
    }
    let p = Properties::of(&model);
    print_body(&model, &p, terms);
    print_stability(&p);
    Ok(())
}

/// The rigid body, the added mass, the actuators and the full-propeller speed.
fn print_body(model: &SixDof, p: &Properties, terms: usize) {
    let v = &model.vehicle;
    println!("{}: {} hydrodynamic terms", v.name, terms);
    println!("  length                 {:10.3} m", v.length_m);
    println!("  mass                   {:10.2} kg", p.mass_kg);
    println!(
        "  displaced mass         {:10.2} kg (buoyancy / g)",
        p.displaced_mass_kg
    );
    println!(
        "  net buoyancy           {:10.2} N ({})",
        p.net_buoyancy_n,
        if p.net_buoyancy_n > 0.0 {
            "floats up"
        } else if p.net_buoyancy_n < 0.0 {
            "sinks"
        } else {
            "neutral"
        }
    );
    println!(
        "  metacentric height BG  {:10.4} m ({})",
        p.metacentric_height_m,
        if p.metacentric_height_m > 0.0 {
            "G below B: stable in roll and pitch"
        } else {
            "G not below B: unstable in roll and pitch"
        }
    );
    let a = p.added_mass_diagonal;
    println!(
        "  added mass             surge {:.1} kg, sway {:.1} kg, heave {:.1} kg, roll {:.1}, pitch {:.1}, yaw {:.1} kg m^2",
        a[0], a[1], a[2], a[3], a[4], a[5]
    );
    println!(
        "  actuators              fins +-{:.1} deg at up to {:.1} deg/s (actuator_rate_deg_s; 20 when the file \
         gives none), time constant {:.2} s; propeller up to {:.0} rpm",
        v.fin_limit_rad.to_degrees(),
        v.fin_rate_limit_rad_s.to_degrees(),
        v.actuator_time_constant_s,
        v.propeller_limit_rad_s * 60.0 / std::f64::consts::TAU
    );
    match p.full_speed_m_s {
        Some(u) => println!(
            "  full-propeller speed   {u:10.3} m/s ({:.0} rpm, straight and level)",
            v.propeller_limit_rad_s * 60.0 / std::f64::consts::TAU
        ),
        None => println!("  full-propeller speed          n/a (thrust never balances drag)"),
    }
}

/// The straight-line stability indices of the horizontal and vertical planes.
fn print_stability(p: &Properties) {
    let show = |name: &str, labels: [&str; 4], s: &PlaneStability| {
        let c = s.coefficients;
        println!(
            "  {name:<22} {:+.5} ({}) from {} {:+.5}, {} {:+.5}, {} {:+.5}, {} {:+.5}",
            s.index,
            if s.stable() {
                "straight-line stable"
            } else {
                "straight-line UNSTABLE"
            },
            labels[0],
            c[0],
            labels[1],
            c[1],
            labels[2],
            c[2],
            labels[3],
            c[3]
        );
    };
    println!(
        "  stability indices at {:.3} m/s (linearised, Coriolis included):",
        p.index_speed_m_s
    );
    show(
        "horizontal C_H",
        ["Y_v'", "Y_r'", "N_v'", "N_r'"],
        &p.horizontal,
    );
    show(
        "vertical C_V",
        ["Z_w'", "Z_q'", "M_w'", "M_q'"],
        &p.vertical,
    );
}
