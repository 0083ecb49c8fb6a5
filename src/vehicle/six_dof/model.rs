//! The 6-DOF equations of motion of seed 000 (eq. 1-4): rigid body about the body origin
//! (centre of gravity at `r_G`, Earth-rate Coriolis term), added mass, the file's
//! hydrodynamic terms, strip-theory cross-flow drag, propulsion, and weight and buoyancy:
//!
//! ```text
//! (M_RB + M_A) nu' = tau_rb(nu) + tau_earth(nu) + tau_h(nu, fins, n) + tau_cf(nu)
//!                    + tau_prop(nu, n) + tau_restoring(roll, pitch)
//! ```
//!
//! with `tau_rb = -[m (w x v + w x (w x r_G)); w x (I w) + m r_G x (w x v)]` and
//! `tau_earth = [-2 m (w_ie^b x v); 0]`. [`SixDof::jacobian`] is `d nu' / d nu`, the
//! appendix's `A_v2, A_v3, A_w2, A_w3` blocks, analytic term by term.

use super::description::{Propulsion, Vehicle};
use super::terms::{Factors, Inputs, Nu};
use nalgebra::{Matrix3, Matrix6, SMatrix, SVector, Vector3};

/// Sections of the strip-theory cross-flow integral.
pub const CROSSFLOW_SECTIONS: usize = 10;

fn add3(tau: &mut Nu, at: usize, v: &Vector3<f64>) {
    for i in 0..3 {
        tau[at + i] += v[i];
    }
}

fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// The model of one vehicle.
#[derive(Debug, Clone, PartialEq)]
pub struct SixDof {
    pub vehicle: Vehicle,
    mass_matrix: Matrix6<f64>,
    mass_inverse: Matrix6<f64>,
}

/// Where the vehicle is, for the forces that depend on it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Attitude {
    pub roll_rad: f64,
    pub pitch_rad: f64,
    /// Earth's rotation in body axes, rad/s (zero for a flat, non-rotating world).
    pub earth_rate_body: Vector3<f64>,
}

impl SixDof {
    /// The model; `None` if the mass matrix is singular.
    pub fn new(vehicle: Vehicle) -> Option<SixDof> {
        let m = vehicle.mass_kg;
        let s = skew(&vehicle.centre_of_gravity_m);
        let mut rb = Matrix6::zeros();
        rb.fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&(Matrix3::identity() * m));
        rb.fixed_view_mut::<3, 3>(0, 3).copy_from(&(-s * m));
        rb.fixed_view_mut::<3, 3>(3, 0).copy_from(&(s * m));
        rb.fixed_view_mut::<3, 3>(3, 3)
            .copy_from(&vehicle.inertia_kg_m2);
        let mass_matrix = rb + vehicle.added_mass;
        let mass_inverse = mass_matrix.try_inverse()?;
        Some(SixDof {
            vehicle,
            mass_matrix,
            mass_inverse,
        })
    }

    pub fn mass_matrix(&self) -> &Matrix6<f64> {
        &self.mass_matrix
    }

    pub fn mass_inverse(&self) -> &Matrix6<f64> {
        &self.mass_inverse
    }

    /// Generalised forces and their derivative by `nu`.
    pub fn forces(&self, nu: &Nu, at: &Attitude, inputs: &Inputs) -> (Nu, Matrix6<f64>) {
        let mut d = Matrix6::zeros();
        let tau = self.forces_into(nu, at, inputs, Some(&mut d));
        (tau, d)
    }

    /// Generalised forces alone (the simulator's path).
    pub fn force_values(&self, nu: &Nu, at: &Attitude, inputs: &Inputs) -> Nu {
        self.forces_into(nu, at, inputs, None)
    }

    /// The forces, adding their derivative by `nu` to `d` when it is given: one code path
    /// for the model and its Jacobian.
    fn forces_into(
        &self,
        nu: &Nu,
        at: &Attitude,
        inputs: &Inputs,
        mut d: Option<&mut Matrix6<f64>>,
    ) -> Nu {
        let mut tau = Nu::zeros();
        self.rigid_body_into(nu, at, &mut tau, d.as_deref_mut());
        self.terms_into(nu, inputs, &mut tau, d.as_deref_mut());
        self.crossflow_into(nu, &mut tau, d.as_deref_mut());
        self.propulsion_into(nu, inputs, &mut tau, d);
        tau + self.restoring(at.roll_rad, at.pitch_rad).0
    }

    /// Rigid body: Coriolis and centripetal, moved to the right-hand side, and the Earth
    /// rate's Coriolis on the translation (seed 000's f_v^RB).
    fn rigid_body_into(&self, nu: &Nu, at: &Attitude, tau: &mut Nu, d: Option<&mut Matrix6<f64>>) {
        let veh = &self.vehicle;
        let m = veh.mass_kg;
        let r = veh.centre_of_gravity_m;
        let v: Vector3<f64> = nu.fixed_rows::<3>(0).into_owned();
        let w: Vector3<f64> = nu.fixed_rows::<3>(3).into_owned();
        let wxv = w.cross(&v);
        let wxwxr = w.cross(&w.cross(&r));
        let iw = veh.inertia_kg_m2 * w;
        let f_rb = -(wxv + wxwxr) * m;
        let m_rb = -(w.cross(&iw)) - r.cross(&wxv) * m;
        add3(tau, 0, &f_rb);
        add3(tau, 3, &m_rb);
        let e = at.earth_rate_body;
        add3(tau, 0, &(-e.cross(&v) * (2.0 * m)));
        let Some(d) = d else {
            return;
        };
        let d_wxwxr = w * r.transpose() + Matrix3::identity() * w.dot(&r) - r * w.transpose() * 2.0;
        let mut block = |row: usize, col: usize, b: Matrix3<f64>| {
            let mut view = d.fixed_view_mut::<3, 3>(row, col);
            view += b;
        };
        block(0, 0, -skew(&w) * m);
        block(0, 3, (skew(&v) - d_wxwxr) * m);
        block(3, 3, -(skew(&w) * veh.inertia_kg_m2 - skew(&iw)));
        block(3, 0, -skew(&r) * skew(&w) * m);
        block(3, 3, skew(&r) * skew(&v) * m);
        block(0, 0, -skew(&e) * (2.0 * m));
    }

    /// The vehicle file's hydrodynamic terms.
    fn terms_into(&self, nu: &Nu, inputs: &Inputs, tau: &mut Nu, mut d: Option<&mut Matrix6<f64>>) {
        let veh = &self.vehicle;
        let factors = Factors::at(nu, inputs, veh.length_m);
        for term in &veh.terms {
            match d.as_deref_mut() {
                Some(d) => {
                    let (value, grad) = term.eval(&factors);
                    tau[term.axis] += value;
                    let mut row = d.row_mut(term.axis);
                    row += grad.transpose();
                }
                None => tau[term.axis] += term.value(&factors),
            }
        }
    }

    /// Cross-flow drag by strip theory.
    fn crossflow_into(&self, nu: &Nu, tau: &mut Nu, mut d: Option<&mut Matrix6<f64>>) {
        let veh = &self.vehicle;
        let Some(cf) = veh.crossflow else {
            return;
        };
        let half_rho = veh.water_density_kg_m3 / 2.0;
        let dx = veh.length_m / CROSSFLOW_SECTIONS as f64;
        for i in 0..CROSSFLOW_SECTIONS {
            let x = -veh.length_m / 2.0 + (i as f64 + 0.5) * dx;
            let a = nu[1] + x * nu[5];
            let b = nu[2] - x * nu[4];
            let s = (a * a + b * b).sqrt();
            if s < 1e-12 {
                continue;
            }
            let ky = -half_rho * cf.cd_y * cf.height_m * dx;
            let kz = -half_rho * cf.cd_z * cf.width_m * dx;
            let (fy, fz) = (ky * a * s, kz * b * s);
            tau[1] += fy;
            tau[2] += fz;
            tau[4] += -x * fz;
            tau[5] += x * fy;
            let Some(d) = d.as_deref_mut() else {
                continue;
            };
            // Derivatives of a s and b s by a and b.
            let (dfy_da, dfy_db) = (ky * (s + a * a / s), ky * a * b / s);
            let (dfz_da, dfz_db) = (kz * a * b / s, kz * (s + b * b / s));
            // a = v + x r, b = w - x q.
            let grad = |f_da: f64, f_db: f64| {
                let mut g = Nu::zeros();
                g[1] = f_da;
                g[5] = f_da * x;
                g[2] = f_db;
                g[4] = -f_db * x;
                g
            };
            let (gy, gz) = (grad(dfy_da, dfy_db), grad(dfz_da, dfz_db));
            for (axis, g) in [(1, gy), (2, gz), (4, -gz * x), (5, gy * x)] {
                let mut row = d.row_mut(axis);
                row += g.transpose();
            }
        }
    }

    /// The propeller's thrust (and the hull's drag, in the NPS form).
    fn propulsion_into(
        &self,
        nu: &Nu,
        inputs: &Inputs,
        tau: &mut Nu,
        d: Option<&mut Matrix6<f64>>,
    ) {
        let veh = &self.vehicle;
        let n = inputs.propeller_rad_s;
        match veh.propulsion {
            Propulsion::Nps { cd0, thrust_factor } => {
                let k = veh.water_density_kg_m3 / 2.0 * veh.length_m.powi(2) * cd0;
                let u = nu[0];
                tau[0] +=
                    k * (thrust_factor * 0.012f64.powi(2) * n * n.abs() * u.signum() - u * u.abs());
                if let Some(d) = d {
                    d[(0, 0)] += -2.0 * k * u.abs();
                }
            }
            Propulsion::Quadratic { thrust, torque } => {
                tau[0] += thrust * n * n.abs();
                tau[3] += torque * n * n.abs();
            }
        }
    }

    /// Weight and buoyancy as generalised forces, and their derivative by roll and pitch.
    pub fn restoring(&self, roll_rad: f64, pitch_rad: f64) -> (Nu, SMatrix<f64, 6, 2>) {
        let veh = &self.vehicle;
        let (sr, cr) = roll_rad.sin_cos();
        let (sp, cp) = pitch_rad.sin_cos();
        // Gravity's direction in the body, and its derivatives by roll and pitch.
        let down = Vector3::new(-sp, cp * sr, cp * cr);
        let d_roll = Vector3::new(0.0, cp * cr, -cp * sr);
        let d_pitch = Vector3::new(-cp, -sp * sr, -sp * cr);
        let (wt, bu) = (veh.weight_n, veh.buoyancy_n);
        let generalised = |g: &Vector3<f64>| {
            let f = g * (wt - bu);
            let m = veh.centre_of_gravity_m.cross(g) * wt - veh.centre_of_buoyancy_m.cross(g) * bu;
            nu(f, m)
        };
        let mut d = SMatrix::<f64, 6, 2>::zeros();
        d.set_column(0, &generalised(&d_roll));
        d.set_column(1, &generalised(&d_pitch));
        (generalised(&down), d)
    }

    /// `nu'` and its Jacobian `d nu' / d nu`.
    pub fn derivative(&self, nu: &Nu, at: &Attitude, inputs: &Inputs) -> (Nu, Matrix6<f64>) {
        let (tau, d) = self.forces(nu, at, inputs);
        (self.mass_inverse * tau, self.mass_inverse * d)
    }

    /// `nu'` alone (the simulator's path).
    pub fn acceleration(&self, nu: &Nu, at: &Attitude, inputs: &Inputs) -> Nu {
        self.mass_inverse * self.force_values(nu, at, inputs)
    }

    /// `d nu' / d nu` alone.
    pub fn jacobian(&self, nu: &Nu, at: &Attitude, inputs: &Inputs) -> Matrix6<f64> {
        self.derivative(nu, at, inputs).1
    }
}

/// A 6-vector from a velocity and a rate.
pub fn nu(v: Vector3<f64>, w: Vector3<f64>) -> Nu {
    SVector::<f64, 6>::new(v.x, v.y, v.z, w.x, w.y, w.z)
}
