//! Vehicle description files (`shared/vehicles/*.json`) read into the 6-DOF model's terms:
//! the one place where a file's coefficient names meet the model.
//!
//! Two forms: NPS AUV II's nondimensional "prime" coefficients in sections (surge, sway,
//! heave, roll, pitch, yaw), made dimensional by `(rho/2) L^k`; and REMUS 100's dimensional
//! coefficients. Each known name maps to an axis and a list of factors; the scale power `k`
//! follows from the factors (units checked: every term must be a force or moment, that is
//! two velocity-or-rate factors, `k = 4 - velocities` for forces, one more for moments), and
//! a name absent from a file is zero. Added-mass names fill the added-mass matrix
//! (`M_A = -[X_udot ...]`, scaled by `(rho/2) L^(3 + angular row + angular column)`).

use super::terms::{Factor, Term};
use nalgebra::{Matrix3, Matrix6, Vector3};
use serde_json::Value;

/// Everything the model needs from a file, in SI units.
#[derive(Debug, Clone, PartialEq)]
pub struct Vehicle {
    pub name: String,
    pub length_m: f64,
    pub water_density_kg_m3: f64,
    pub gravity_m_s2: f64,
    pub weight_n: f64,
    pub buoyancy_n: f64,
    pub mass_kg: f64,
    pub centre_of_gravity_m: Vector3<f64>,
    pub centre_of_buoyancy_m: Vector3<f64>,
    /// Inertia about the origin, kg m^2.
    pub inertia_kg_m2: Matrix3<f64>,
    /// Added mass (positive-definite part of the mass matrix), SI.
    pub added_mass: Matrix6<f64>,
    pub terms: Vec<Term>,
    pub propulsion: Propulsion,
    pub crossflow: Option<Crossflow>,
    pub fin_limit_rad: f64,
    pub fin_rate_limit_rad_s: f64,
    pub actuator_time_constant_s: f64,
    pub propeller_limit_rad_s: f64,
}

/// Propeller force and moment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Propulsion {
    /// NPS AUV II: `X = (rho/2) L^2 Cd0 (k_t 0.012^2 n|n| sign(u) - u|u|)` (the file's
    /// `Cd0 (|prop| prop - 1)` times `u^2`, with drag taken as `u|u|` so that it opposes the
    /// motion astern too). `k_t` (`thrust_factor`) is 1 in the file; a perturbed vehicle
    /// draws it apart from `Cd0`, so that its thrust and its drag are wrong independently.
    Nps { cd0: f64, thrust_factor: f64 },
    /// REMUS 100: thrust `X = kt n|n|`, torque `K = kq n|n|` (n in rad/s).
    Quadratic { thrust: f64, torque: f64 },
}

/// Strip-theory cross-flow drag.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Crossflow {
    pub cd_y: f64,
    pub cd_z: f64,
    pub height_m: f64,
    pub width_m: f64,
}

/// What is wrong with a vehicle file.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum VehicleError {
    #[error("not a vehicle description (JSON): {0}")]
    Json(String),
    #[error("`{0}` is missing")]
    Missing(String),
    #[error("`{key}` = {value}: {reason}")]
    Bad {
        key: String,
        value: f64,
        reason: &'static str,
    },
    #[error(
        "unknown coefficient `{name}` in `{section}` (the names this file form knows: {known})"
    )]
    UnknownCoefficient {
        name: String,
        section: String,
        known: String,
    },
    #[error("`{key}`: {reason}")]
    Malformed { key: String, reason: String },
}

use Factor::*;
const U: Factor = Nu(0);
const V: Factor = Nu(1);
const W: Factor = Nu(2);
const P: Factor = Nu(3);
const Q: Factor = Nu(4);
const R: Factor = Nu(5);

/// A hydrodynamic term's mapping: name, axis, factors, multiplier (2 for the NPS bow-plane
/// pair deflected together).
type Mapping = (&'static str, usize, &'static [Factor], f64);
/// An added-mass entry: name, row, column.
type AddedMass = (&'static str, usize, usize);

/// NPS AUV II (prime coefficients; MSS names: `Mw`, `Mq` multiply `u w`, `u q`).
const NPS_TERMS: &[Mapping] = &[
    ("Xpp", 0, &[P, P], 1.0),
    ("Xqq", 0, &[Q, Q], 1.0),
    ("Xrr", 0, &[R, R], 1.0),
    ("Xpr", 0, &[P, R], 1.0),
    ("Xwq", 0, &[W, Q], 1.0),
    ("Xvp", 0, &[V, P], 1.0),
    ("Xvr", 0, &[V, R], 1.0),
    ("Xqds", 0, &[U, Q, Stern], 1.0),
    ("Xqdb2", 0, &[U, Q, Bow], 2.0),
    ("Xrdr", 0, &[U, R, Rudder], 1.0),
    ("Xvv", 0, &[V, V], 1.0),
    ("Xww", 0, &[W, W], 1.0),
    ("Xvdr", 0, &[U, V, Rudder], 1.0),
    ("Xwds", 0, &[U, W, Stern], 1.0),
    ("Xwdb2", 0, &[U, W, Bow], 2.0),
    ("Xdsds", 0, &[U, U, Stern, Stern], 1.0),
    ("Xdrdr", 0, &[U, U, Rudder, Rudder], 1.0),
    ("Xqdsn", 0, &[U, Q, Stern, Wake], 1.0),
    ("Xwdsn", 0, &[U, W, Stern, Wake], 1.0),
    ("Xdsdsn", 0, &[U, U, Stern, Stern, Wake], 1.0),
    ("Ypq", 1, &[P, Q], 1.0),
    ("Yqr", 1, &[Q, R], 1.0),
    ("Yp", 1, &[U, P], 1.0),
    ("Yr", 1, &[U, R], 1.0),
    ("Yvq", 1, &[V, Q], 1.0),
    ("Ywp", 1, &[W, P], 1.0),
    ("Ywr", 1, &[W, R], 1.0),
    ("Yv", 1, &[U, V], 1.0),
    ("Yvw", 1, &[V, W], 1.0),
    ("Ydr", 1, &[U, U, Rudder], 1.0),
    ("Zpp", 2, &[P, P], 1.0),
    ("Zpr", 2, &[P, R], 1.0),
    ("Zrr", 2, &[R, R], 1.0),
    ("Zq", 2, &[U, Q], 1.0),
    ("Zvp", 2, &[V, P], 1.0),
    ("Zvr", 2, &[V, R], 1.0),
    ("Zw", 2, &[U, W], 1.0),
    ("Zvv", 2, &[V, V], 1.0),
    ("Zds", 2, &[U, U, Stern], 1.0),
    ("Zdb2", 2, &[U, U, Bow], 2.0),
    ("Zqn", 2, &[U, Q, Wake], 1.0),
    ("Zwn", 2, &[U, W, Wake], 1.0),
    ("Zdsn", 2, &[U, U, Stern, Wake], 1.0),
    ("Kpq", 3, &[P, Q], 1.0),
    ("Kqr", 3, &[Q, R], 1.0),
    ("Kp", 3, &[U, P], 1.0),
    ("Kr", 3, &[U, R], 1.0),
    ("Kvq", 3, &[V, Q], 1.0),
    ("Kwp", 3, &[W, P], 1.0),
    ("Kwr", 3, &[W, R], 1.0),
    ("Kv", 3, &[U, V], 1.0),
    ("Kvw", 3, &[V, W], 1.0),
    ("Kdb2", 3, &[U, U, Bow], 2.0),
    ("Kpn", 3, &[U, P, Wake], 1.0),
    // MSS multiplies Kprop by u^3, which is not a moment; u^2 here (the file's value is 0).
    ("Kprop", 3, &[U, U], 1.0),
    ("Mpp", 4, &[P, P], 1.0),
    ("Mpr", 4, &[P, R], 1.0),
    ("Mrr", 4, &[R, R], 1.0),
    ("Mq", 4, &[U, Q], 1.0),
    ("Mvp", 4, &[V, P], 1.0),
    ("Mvr", 4, &[V, R], 1.0),
    ("Mw", 4, &[U, W], 1.0),
    ("Mvv", 4, &[V, V], 1.0),
    ("Mds", 4, &[U, U, Stern], 1.0),
    ("Mdb2", 4, &[U, U, Bow], 2.0),
    ("Mqn", 4, &[U, Q, Wake], 1.0),
    ("Mwn", 4, &[U, W, Wake], 1.0),
    ("Mdsn", 4, &[U, U, Stern, Wake], 1.0),
    ("Npq", 5, &[P, Q], 1.0),
    ("Nqr", 5, &[Q, R], 1.0),
    ("Np", 5, &[U, P], 1.0),
    ("Nr", 5, &[U, R], 1.0),
    ("Nvq", 5, &[V, Q], 1.0),
    ("Nwp", 5, &[W, P], 1.0),
    ("Nwr", 5, &[W, R], 1.0),
    ("Nv", 5, &[U, V], 1.0),
    ("Nvw", 5, &[V, W], 1.0),
    ("Ndr", 5, &[U, U, Rudder], 1.0),
    ("Nprop", 5, &[U, U], 1.0),
];

const NPS_ADDED_MASS: &[AddedMass] = &[
    ("Xudot", 0, 0),
    ("Yvdot", 1, 1),
    ("Ypdot", 1, 3),
    ("Yrdot", 1, 5),
    ("Zwdot", 2, 2),
    ("Zqdot", 2, 4),
    ("Kvdot", 3, 1),
    ("Kpdot", 3, 3),
    ("Krdot", 3, 5),
    ("Mwdot", 4, 2),
    ("Mqdot", 4, 4),
    ("Nvdot", 5, 1),
    ("Npdot", 5, 3),
    ("Nrdot", 5, 5),
];

const NPS_SECTIONS: [&str; 6] = ["surge", "sway", "heave", "roll", "pitch", "yaw"];

/// REMUS 100 (dimensional, Prestero 2001).
const REMUS_TERMS: &[Mapping] = &[
    ("Xuu", 0, &[U, AbsNu(0)], 1.0),
    ("Xwq", 0, &[W, Q], 1.0),
    ("Xqq", 0, &[Q, Q], 1.0),
    ("Xvr", 0, &[V, R], 1.0),
    ("Xrr", 0, &[R, R], 1.0),
    ("Yvv", 1, &[V, AbsNu(1)], 1.0),
    ("Yrr", 1, &[R, AbsNu(5)], 1.0),
    ("Yuv", 1, &[U, V], 1.0),
    ("Ywp", 1, &[W, P], 1.0),
    ("Yur", 1, &[U, R], 1.0),
    ("Ypq", 1, &[P, Q], 1.0),
    ("Yuudr", 1, &[U, U, Rudder], 1.0),
    ("Zww", 2, &[W, AbsNu(2)], 1.0),
    ("Zqq", 2, &[Q, AbsNu(4)], 1.0),
    ("Zuw", 2, &[U, W], 1.0),
    ("Zuq", 2, &[U, Q], 1.0),
    ("Zvp", 2, &[V, P], 1.0),
    ("Zrp", 2, &[R, P], 1.0),
    ("Zuuds", 2, &[U, U, Stern], 1.0),
    ("Kpp", 3, &[P, AbsNu(3)], 1.0),
    ("Mww", 4, &[W, AbsNu(2)], 1.0),
    ("Mqq", 4, &[Q, AbsNu(4)], 1.0),
    ("Muw", 4, &[U, W], 1.0),
    ("Muq", 4, &[U, Q], 1.0),
    ("Mvp", 4, &[V, P], 1.0),
    ("Mrp", 4, &[R, P], 1.0),
    ("Muuds", 4, &[U, U, Stern], 1.0),
    ("Nvv", 5, &[V, AbsNu(1)], 1.0),
    ("Nrr", 5, &[R, AbsNu(5)], 1.0),
    ("Nuv", 5, &[U, V], 1.0),
    ("Nur", 5, &[U, R], 1.0),
    ("Nwp", 5, &[W, P], 1.0),
    ("Npq", 5, &[P, Q], 1.0),
    ("Nuudr", 5, &[U, U, Rudder], 1.0),
];

const REMUS_ADDED_MASS: &[AddedMass] = &[
    ("Xudot", 0, 0),
    ("Yvdot", 1, 1),
    ("Yrdot", 1, 5),
    ("Zwdot", 2, 2),
    ("Zqdot", 2, 4),
    ("Kpdot", 3, 3),
    ("Mwdot", 4, 2),
    ("Mqdot", 4, 4),
    ("Nvdot", 5, 1),
    ("Nrdot", 5, 5),
];

/// Velocity factors (u, v, w and their magnitudes) and rate factors of a term.
fn dimensions(factors: &[Factor]) -> (usize, usize) {
    factors.iter().fold((0, 0), |(v, r), f| match f {
        Nu(i) | AbsNu(i) if *i < 3 => (v + 1, r),
        Nu(_) | AbsNu(_) => (v, r + 1),
        _ => (v, r),
    })
}

/// The `(rho/2) L^k` power of a prime term, after checking it is a force or moment.
fn prime_power(name: &str, axis: usize, factors: &[Factor]) -> Result<i32, VehicleError> {
    let (velocities, rates) = dimensions(factors);
    if velocities + rates != 2 {
        return Err(VehicleError::Malformed {
            key: name.to_string(),
            reason: format!(
                "maps to {velocities} velocities and {rates} rates: not a force or moment"
            ),
        });
    }
    Ok(4 - velocities as i32 + i32::from(axis >= 3))
}

fn number(v: &Value, key: &str) -> Result<Option<f64>, VehicleError> {
    match v.get(key) {
        None | Some(Value::Null) => Ok(None),
        Some(Value::Number(n)) => Ok(n.as_f64()),
        Some(other) => Err(VehicleError::Malformed {
            key: key.to_string(),
            reason: format!("expected a number, found {other}"),
        }),
    }
}

fn required(v: &Value, section: &str, key: &str) -> Result<f64, VehicleError> {
    number(v, key)?.ok_or_else(|| VehicleError::Missing(format!("{section}.{key}")))
}

fn vector(v: &Value, section: &str, key: &str) -> Result<Vector3<f64>, VehicleError> {
    let full = format!("{section}.{key}");
    match v.get(key) {
        None => Ok(Vector3::zeros()),
        Some(Value::Array(a)) if a.len() == 3 => {
            let x: Option<Vec<f64>> = a.iter().map(Value::as_f64).collect();
            x.map(|x| Vector3::new(x[0], x[1], x[2]))
                .ok_or(VehicleError::Malformed {
                    key: full,
                    reason: "expected three numbers".into(),
                })
        }
        Some(_) => Err(VehicleError::Malformed {
            key: full,
            reason: "expected three numbers".into(),
        }),
    }
}

/// The leading number of a formula string such as `"1.569759e-4 * n |n| ..."`.
fn leading_number(v: &Value, key: &str) -> Result<f64, VehicleError> {
    let text = v.as_str().unwrap_or_default();
    text.split_whitespace()
        .next()
        .and_then(|t| t.parse().ok())
        .ok_or_else(|| VehicleError::Malformed {
            key: key.to_string(),
            reason: format!("expected a formula starting with its coefficient, found `{text}`"),
        })
}

/// The rigid body of a vehicle file's `physical` section, checked.
struct Physical {
    length_m: f64,
    gravity_m_s2: f64,
    water_density_kg_m3: f64,
    weight_n: f64,
    buoyancy_n: f64,
    mass_kg: f64,
    inertia_kg_m2: Matrix3<f64>,
}

/// The hydrodynamic terms, the added mass and the propulsion of a vehicle file.
struct Hydrodynamics {
    terms: Vec<Term>,
    added_mass: Matrix6<f64>,
    propulsion: Propulsion,
}

/// The mass: a number, `"W/g"`, or (absent) the weight over gravity.
fn mass_kg(phys: &Value, weight_n: f64, gravity_m_s2: f64) -> Result<f64, VehicleError> {
    match phys.get("mass_kg") {
        Some(Value::String(s)) if s.replace(' ', "") == "W/g" => Ok(weight_n / gravity_m_s2),
        Some(Value::Number(n)) => Ok(n.as_f64().unwrap_or(f64::NAN)),
        None if weight_n > 0.0 => Ok(weight_n / gravity_m_s2),
        _ => Err(VehicleError::Missing(
            "physical.mass_kg (a number or \"W/g\")".into(),
        )),
    }
}

/// The inertia tensor from its moments (`Ix_kgm2` or `Ixx_kgm2`) and products; returns the
/// moments too, for their checks.
fn inertia(phys: &Value) -> Result<(Matrix3<f64>, [f64; 3]), VehicleError> {
    let moment = |keys: [&str; 2]| -> Result<f64, VehicleError> {
        number(phys, keys[0])?
            .or(number(phys, keys[1])?)
            .ok_or_else(|| VehicleError::Missing(format!("physical.{}", keys[0])))
    };
    let ix = moment(["Ix_kgm2", "Ixx_kgm2"])?;
    let iy = moment(["Iy_kgm2", "Iyy_kgm2"])?;
    let iz = moment(["Iz_kgm2", "Izz_kgm2"])?;
    let ixy = number(phys, "Ixy_kgm2")?.unwrap_or(0.0);
    let iyz = number(phys, "Iyz_kgm2")?.unwrap_or(0.0);
    let ixz = number(phys, "Ixz_kgm2")?.unwrap_or(0.0);
    // Products of inertia as the usual tensor: off-diagonals are minus the products.
    let tensor = Matrix3::new(ix, -ixy, -ixz, -ixy, iy, -iyz, -ixz, -iyz, iz);
    Ok((tensor, [ix, iy, iz]))
}

impl Physical {
    fn from(phys: &Value) -> Result<Physical, VehicleError> {
        let length_m = required(phys, "physical", "L_m")?;
        let gravity_m_s2 = number(phys, "g_m_s2")?.unwrap_or(9.81);
        let water_density_kg_m3 = number(phys, "rho_kg_m3")?.unwrap_or(1025.0);
        let weight_n = required(phys, "physical", "W_N")?;
        let buoyancy_n = required(phys, "physical", "B_N")?;
        let mass_kg = mass_kg(phys, weight_n, gravity_m_s2)?;
        let (inertia_kg_m2, [ix, iy, iz]) = inertia(phys)?;
        for (key, value) in [
            ("physical.L_m", length_m),
            ("physical.W_N", weight_n),
            ("physical.B_N", buoyancy_n),
            ("physical.mass_kg", mass_kg),
            ("physical.Ix_kgm2", ix),
            ("physical.Iy_kgm2", iy),
            ("physical.Iz_kgm2", iz),
            ("physical.rho_kg_m3", water_density_kg_m3),
            ("physical.g_m_s2", gravity_m_s2),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return Err(VehicleError::Bad {
                    key: key.to_string(),
                    value,
                    reason: "must be a positive number",
                });
            }
        }
        if inertia_kg_m2.cholesky().is_none() {
            return Err(VehicleError::Malformed {
                key: "physical.I*_kgm2".into(),
                reason: "the inertia tensor is not positive definite".into(),
            });
        }
        Ok(Physical {
            length_m,
            gravity_m_s2,
            water_density_kg_m3,
            weight_n,
            buoyancy_n,
            mass_kg,
            inertia_kg_m2,
        })
    }
}

/// A coefficient's value, which must be a number.
fn coefficient_value(value: &Value, section: &str, key: &str) -> Result<f64, VehicleError> {
    value.as_f64().ok_or_else(|| VehicleError::Malformed {
        key: format!("{section}.{key}"),
        reason: "expected a number".into(),
    })
}

/// Dimensional coefficients (REMUS form): one `coefficients` table, quadratic propulsion.
fn dimensional(root: &Value, coefficients: &Value) -> Result<Hydrodynamics, VehicleError> {
    let table = coefficients
        .as_object()
        .ok_or_else(|| VehicleError::Malformed {
            key: "coefficients".into(),
            reason: "expected an object of NAME: value".into(),
        })?;
    let (mut terms, mut added_mass) = (Vec::new(), Matrix6::zeros());
    for (key, value) in table {
        let v = coefficient_value(value, "coefficients", key)?;
        if let Some(&(_, row, col)) = REMUS_ADDED_MASS.iter().find(|m| m.0 == key) {
            added_mass[(row, col)] = -v;
        } else if let Some(&(n, axis, factors, k)) = REMUS_TERMS.iter().find(|m| m.0 == key) {
            prime_power(n, axis, factors)?;
            terms.push(Term {
                axis,
                coefficient: v * k,
                factors: factors.to_vec(),
                name: n.to_string(),
            });
        } else {
            return Err(unknown(key, "coefficients", REMUS_TERMS, REMUS_ADDED_MASS));
        }
    }
    let prop = root
        .get("propulsion")
        .ok_or_else(|| VehicleError::Missing("propulsion".into()))?;
    let formula = |key: &str| {
        let full = format!("propulsion.{key}");
        leading_number(prop.get(key).unwrap_or(&Value::Null), &full)
    };
    let propulsion = Propulsion::Quadratic {
        thrust: formula("thrust_N")?,
        torque: formula("torque_Nm")?,
    };
    Ok(Hydrodynamics {
        terms,
        added_mass,
        propulsion,
    })
}

/// Prime coefficients (NPS form), in sections, made dimensional with the length and the
/// water's density; the propulsion from its drag coefficient.
fn prime(root: &Value, body: &Physical) -> Result<Hydrodynamics, VehicleError> {
    let half_rho = body.water_density_kg_m3 / 2.0;
    let length_m = body.length_m;
    let (mut terms, mut added_mass) = (Vec::new(), Matrix6::zeros());
    for section in NPS_SECTIONS {
        let Some(table) = root.get(section).and_then(Value::as_object) else {
            continue;
        };
        for (key, value) in table {
            let v = coefficient_value(value, section, key)?;
            if let Some(&(_, row, col)) = NPS_ADDED_MASS.iter().find(|m| m.0 == key) {
                let k = 3 + i32::from(row >= 3) + i32::from(col >= 3);
                added_mass[(row, col)] = -v * half_rho * length_m.powi(k);
            } else if let Some(&(n, axis, factors, mult)) = NPS_TERMS.iter().find(|m| m.0 == key) {
                let k = prime_power(n, axis, factors)?;
                terms.push(Term {
                    axis,
                    coefficient: v * mult * half_rho * length_m.powi(k),
                    factors: factors.to_vec(),
                    name: n.to_string(),
                });
            } else {
                return Err(unknown(key, section, NPS_TERMS, NPS_ADDED_MASS));
            }
        }
    }
    let cd0 = root
        .get("propulsion")
        .and_then(|p| number(p, "Cd0").transpose())
        .transpose()?
        .ok_or_else(|| VehicleError::Missing("propulsion.Cd0".into()))?;
    let propulsion = Propulsion::Nps {
        cd0,
        thrust_factor: 1.0,
    };
    Ok(Hydrodynamics {
        terms,
        added_mass,
        propulsion,
    })
}

/// The hull's crossflow drag, when all four of its figures are given.
fn crossflow(phys: &Value) -> Result<Option<Crossflow>, VehicleError> {
    Ok(
        match (
            number(phys, "crossflow_Cdy")?,
            number(phys, "crossflow_Cdz")?,
            number(phys, "crossflow_height_m")?,
            number(phys, "crossflow_width_m")?,
        ) {
            (Some(cd_y), Some(cd_z), Some(height_m), Some(width_m)) => Some(Crossflow {
                cd_y,
                cd_z,
                height_m,
                width_m,
            }),
            _ => None,
        },
    )
}

impl Vehicle {
    /// Reads a vehicle description (JSON text).
    pub fn from_json(text: &str) -> Result<Vehicle, VehicleError> {
        let root: Value =
            serde_json::from_str(text).map_err(|e| VehicleError::Json(e.to_string()))?;
        let name = root
            .get("name")
            .and_then(Value::as_str)
            .unwrap_or("unnamed vehicle")
            .to_string();
        let phys = root
            .get("physical")
            .ok_or_else(|| VehicleError::Missing("physical".into()))?;
        let body = Physical::from(phys)?;
        let hydro = match root.get("coefficients") {
            Some(coefficients) => dimensional(&root, coefficients)?,
            None => prime(&root, &body)?,
        };
        let deg = |key: &str, default: f64| -> Result<f64, VehicleError> {
            Ok(number(phys, key)?.unwrap_or(default).to_radians())
        };
        Ok(Vehicle {
            name,
            length_m: body.length_m,
            water_density_kg_m3: body.water_density_kg_m3,
            gravity_m_s2: body.gravity_m_s2,
            weight_n: body.weight_n,
            buoyancy_n: body.buoyancy_n,
            mass_kg: body.mass_kg,
            centre_of_gravity_m: vector(phys, "physical", "r_G_m")?,
            centre_of_buoyancy_m: vector(phys, "physical", "r_B_m")?,
            inertia_kg_m2: body.inertia_kg_m2,
            added_mass: hydro.added_mass,
            terms: hydro.terms,
            propulsion: hydro.propulsion,
            crossflow: crossflow(phys)?,
            fin_limit_rad: deg("actuator_limit_deg", 20.0)?,
            fin_rate_limit_rad_s: deg("actuator_rate_deg_s", 20.0)?,
            actuator_time_constant_s: number(phys, "actuator_time_constant_s")?.unwrap_or(0.1),
            propeller_limit_rad_s: number(phys, "propeller_limit_rpm")?.unwrap_or(1500.0)
                * std::f64::consts::TAU
                / 60.0,
        })
    }

    /// The dimensional coefficient of a term by its file name (0 when absent).
    pub fn coefficient(&self, name: &str) -> f64 {
        self.terms
            .iter()
            .filter(|t| t.name == name)
            .map(|t| t.coefficient)
            .sum()
    }
}

fn unknown(key: &str, section: &str, terms: &[Mapping], added: &[AddedMass]) -> VehicleError {
    let mut known: Vec<&str> = terms
        .iter()
        .map(|t| t.0)
        .chain(added.iter().map(|a| a.0))
        .collect();
    known.sort_unstable();
    VehicleError::UnknownCoefficient {
        name: key.to_string(),
        section: section.to_string(),
        known: known.join(", "),
    }
}

/// The vehicles shipped in the binary (copies of `../shared/vehicles/`): (name, JSON text).
pub const BUILT_IN: &[(&str, &str)] = &[
    (
        "nps-auv-ii",
        include_str!("../../../assets/vehicles/nps-auv-ii.json"),
    ),
    (
        "remus-100",
        include_str!("../../../assets/vehicles/remus-100.json"),
    ),
];

impl Vehicle {
    /// A built-in vehicle by name (`None` if there is none of that name).
    pub fn built_in(name: &str) -> Option<Result<Vehicle, VehicleError>> {
        BUILT_IN
            .iter()
            .find(|(n, _)| *n == name)
            .map(|(_, text)| Vehicle::from_json(text))
    }

    /// A "true" vehicle drawn around this one (seed 000's case 2): every hydrodynamic term,
    /// added-mass entry, propulsion and cross-flow coefficient multiplied by `1 + f z`, `z`
    /// standard normal cut at +-3, seeded. Returns the vehicle and the factors by name, to
    /// record in the log.
    pub fn perturbed(&self, fraction: f64, seed: u64) -> (Vehicle, Vec<(String, f64)>) {
        use rand::SeedableRng;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        // A stream of its own, apart from the sensors' streams of the same seed.
        rng.set_stream(1000);
        // Seed 000 case 2: normal with 1-sigma `fraction`, cut at 3 sigma so that no term
        // changes sign.
        let mut draw = || {
            let z: f64 = rand_distr::Distribution::sample(&rand_distr::StandardNormal, &mut rng);
            1.0 + fraction * z.clamp(-3.0, 3.0)
        };
        let mut v = self.clone();
        let mut factors = Vec::new();
        for t in &mut v.terms {
            let k = draw();
            t.coefficient *= k;
            factors.push((t.name.clone(), k));
        }
        for i in 0..6 {
            for j in 0..6 {
                if v.added_mass[(i, j)] != 0.0 {
                    let k = draw();
                    v.added_mass[(i, j)] *= k;
                    factors.push((format!("added_mass[{i}][{j}]"), k));
                }
            }
        }
        // The propulsion's and the cross-flow drag's coefficients too: the balance of
        // thrust and drag sets the cruising speed.
        let mut scale = |name: &str, x: &mut f64| {
            let k = draw();
            *x *= k;
            factors.push((name.to_string(), k));
        };
        match &mut v.propulsion {
            Propulsion::Nps { cd0, thrust_factor } => {
                scale("propulsion.Cd0", cd0);
                scale("propulsion.thrust_factor", thrust_factor);
            }
            Propulsion::Quadratic { thrust, torque } => {
                scale("propulsion.thrust", thrust);
                scale("propulsion.torque", torque);
            }
        }
        if let Some(cf) = &mut v.crossflow {
            scale("crossflow_Cdy", &mut cf.cd_y);
            scale("crossflow_Cdz", &mut cf.cd_z);
        }
        (v, factors)
    }
}
