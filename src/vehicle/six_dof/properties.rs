//! Derived properties of a vehicle: masses, centres, metacentric height, the straight-line
//! speed at full propeller, and the straight-line stability indices of both planes.
//!
//! The indices come from the model's own linearisation about straight, level flight at
//! speed `U` (so Coriolis and every linear-in-velocity term count), made nondimensional
//! (`Y_v' = dY/dv / ((rho/2) L^2 U)`, `Y_r' = dY/dr / ((rho/2) L^3 U)`, ...):
//! `C_H = Y_v' N_r' - N_v' Y_r'` (horizontal) and `C_V = Z_w' M_q' - M_w' Z_q'` (vertical,
//! without the hydrostatic pitch moment). Positive: straight-line stable.

use super::model::{Attitude, SixDof};
use super::terms::{Inputs, Nu};
use nalgebra::Vector3;

/// One plane's linear coefficients (nondimensional) and index.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlaneStability {
    /// Force by velocity, force by rate, moment by velocity, moment by rate.
    pub coefficients: [f64; 4],
    pub index: f64,
}

impl PlaneStability {
    pub fn stable(&self) -> bool {
        self.index > 0.0
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct Properties {
    pub mass_kg: f64,
    pub displaced_mass_kg: f64,
    /// Buoyancy minus weight, N (positive: floats up).
    pub net_buoyancy_n: f64,
    /// Vertical distance of the centre of gravity below the centre of buoyancy, m: the
    /// submerged vehicle's metacentric height.
    pub metacentric_height_m: f64,
    /// Added mass diagonal (surge, sway, heave kg; roll, pitch, yaw kg m^2).
    pub added_mass_diagonal: [f64; 6],
    /// Straight-line speed with the propeller at its limit, m/s.
    pub full_speed_m_s: Option<f64>,
    pub horizontal: PlaneStability,
    pub vertical: PlaneStability,
    /// Speed the indices are computed at, m/s.
    pub index_speed_m_s: f64,
}

/// Straight, level flight at `u` with the propeller at `n`: the surge force.
fn surge_force(model: &SixDof, u: f64, n: f64) -> f64 {
    let nu = Nu::new(u, 0.0, 0.0, 0.0, 0.0, 0.0);
    model.force_values(&nu, &level(), &inputs(n))[0]
}

fn level() -> Attitude {
    Attitude {
        roll_rad: 0.0,
        pitch_rad: 0.0,
        earth_rate_body: Vector3::zeros(),
    }
}

fn inputs(n: f64) -> Inputs {
    Inputs {
        rudder_rad: 0.0,
        stern_rad: 0.0,
        bow_rad: 0.0,
        propeller_rad_s: n,
    }
}

/// The speed at which thrust balances drag (bisection), if there is one below 30 m/s.
pub fn steady_speed(model: &SixDof, n: f64) -> Option<f64> {
    let (mut lo, mut hi) = (1e-3, 30.0);
    if surge_force(model, lo, n) <= 0.0 || surge_force(model, hi, n) >= 0.0 {
        return None;
    }
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if surge_force(model, mid, n) > 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Some(0.5 * (lo + hi))
}

/// The stability indices at speed `u` (propeller at the speed that holds it, if any).
pub fn stability(model: &SixDof, u: f64, n: f64) -> (PlaneStability, PlaneStability) {
    let v = &model.vehicle;
    let nu = Nu::new(u, 0.0, 0.0, 0.0, 0.0, 0.0);
    let d = model.forces(&nu, &level(), &inputs(n)).1;
    let half_rho = v.water_density_kg_m3 / 2.0;
    let l = v.length_m;
    let plane = |force: usize, moment: usize, vel: usize, rate: usize| {
        let c = [
            d[(force, vel)] / (half_rho * l.powi(2) * u),
            d[(force, rate)] / (half_rho * l.powi(3) * u),
            d[(moment, vel)] / (half_rho * l.powi(3) * u),
            d[(moment, rate)] / (half_rho * l.powi(4) * u),
        ];
        PlaneStability {
            coefficients: c,
            index: c[0] * c[3] - c[2] * c[1],
        }
    };
    // Sway-yaw (Y, N by v, r) and heave-pitch (Z, M by w, q).
    (plane(1, 5, 1, 5), plane(2, 4, 2, 4))
}

impl Properties {
    pub fn of(model: &SixDof) -> Properties {
        let v = &model.vehicle;
        let n_max = v.propeller_limit_rad_s;
        let full_speed_m_s = steady_speed(model, n_max);
        let index_speed_m_s = full_speed_m_s.unwrap_or(1.0);
        let (horizontal, vertical) = stability(model, index_speed_m_s, n_max);
        Properties {
            mass_kg: v.mass_kg,
            displaced_mass_kg: v.buoyancy_n / v.gravity_m_s2,
            net_buoyancy_n: v.buoyancy_n - v.weight_n,
            metacentric_height_m: v.centre_of_gravity_m.z - v.centre_of_buoyancy_m.z,
            added_mass_diagonal: std::array::from_fn(|i| v.added_mass[(i, i)]),
            full_speed_m_s,
            horizontal,
            vertical,
            index_speed_m_s,
        }
    }
}
