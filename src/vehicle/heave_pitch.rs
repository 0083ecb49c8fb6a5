//! Seed 004's heave-pitch model, as `docs/methods/heave-pitch-model.md` fixes it.
//!
//! State `[w, theta, q, z]` (heave velocity m/s body z down, pitch rad nose up, pitch rate
//! rad/s, depth m down); input the stern-plane angle `delta_s` (rad); forward speed `U`
//! constant. Ten nondimensional coefficients, each made dimensional by `(rho/2) L^k U^j`
//! ([`SCALE_POWERS`]):
//!
//! ```text
//! (m - Z_wdot) w' - Z_qdot q'    = Z_w w + (Z_q + m U) q + m z_G q^2 + (W - B) cos(theta) + Z_d delta_s
//! -M_wdot w' + (I_y - M_qdot) q' = M_w w + M_q q - m z_G w q - W z_G sin(theta) + M_d delta_s
//! theta' = q
//! z'     = -U sin(theta) + w cos(theta)
//! ```
//!
//! The model is linear in the coefficients once the accelerations are known: the derivative
//! of `[w', q']` by a dimensional coefficient `D` is `A^-1 v` with `A` the mass matrix and
//! `v` the coefficient's regressor (`w`, `w'`, `q`, `q'` or `delta_s`) in its row
//! ([`HeavePitch::coefficient_jacobian`]).

use nalgebra::{Matrix2, SMatrix, SVector, Vector2};

/// State `[w, theta, q, z]`.
pub type State = SVector<f64, 4>;
/// Nondimensional coefficients, in [`NAMES`] order.
pub type Coefficients = SVector<f64, 10>;

/// The coefficients' names, in state order.
pub const NAMES: [&str; 10] = [
    "Z_w", "Z_wdot", "Z_q", "Z_qdot", "Z_delta", "M_w", "M_wdot", "M_q", "M_qdot", "M_delta",
];

/// Powers `(k, j)` of `L` and `U` in each coefficient's scale `(rho/2) L^k U^j`.
pub const SCALE_POWERS: [(i32, i32); 10] = [
    (2, 1),
    (3, 0),
    (3, 1),
    (4, 0),
    (2, 2),
    (3, 1),
    (4, 0),
    (4, 1),
    (5, 0),
    (3, 2),
];

/// SI unit of each dimensional coefficient.
pub const UNITS: [&str; 10] = [
    "kg/s", "kg", "kg m/s", "kg m", "N/rad", "kg m/s", "kg m", "kg m^2/s", "kg m^2", "N m/rad",
];

/// Seed 004's true values (Tables 5.2-5.3 "True Value"; the spec's table).
pub const TRUE_COEFFICIENTS: [f64; 10] = [
    -0.01991, -0.01258, -0.006371, -0.000016, -0.008791, 0.004059, -0.004970, -0.002995, -0.005198,
    -0.003663,
];

crate::config::with_defaults! {
    /// The model's constants (the spec's "State, input, constants").
    #[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
    pub struct Constants {
        /// Forward speed, m/s.
        pub speed_m_s: f64 = 3.084,
        pub length_m: f64 = 63.955,
        pub water_density_kg_m3: f64 = 1025.9,
        pub gravity_m_s2: f64 = 9.8,
        pub mass_kg: f64 = 293_160.0 * 9.8,
        /// Weight minus buoyancy, N (0: neutral).
        pub weight_minus_buoyancy_n: f64 = 0.0,
        /// Nondimensional pitch inertia I_y'.
        pub pitch_inertia_nd: f64 = 0.0006088,
        /// Centre of gravity below the origin, m.
        pub z_g_m: f64 = 0.27414,
    }
}

/// Seed 004's initial state.
pub const INITIAL_STATE: [f64; 4] = [0.028, 0.0, 0.0, 20.0];

/// The model at one forward speed, with its dimensional scale factors.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeavePitch {
    pub constants: Constants,
    scale: Coefficients,
    pitch_inertia: f64,
}

impl HeavePitch {
    pub fn new(constants: Constants) -> HeavePitch {
        let half_rho = constants.water_density_kg_m3 / 2.0;
        let (l, u) = (constants.length_m, constants.speed_m_s);
        let scale = Coefficients::from_fn(|i, _| {
            half_rho * l.powi(SCALE_POWERS[i].0) * u.powi(SCALE_POWERS[i].1)
        });
        HeavePitch {
            constants,
            scale,
            pitch_inertia: constants.pitch_inertia_nd * half_rho * l.powi(5),
        }
    }

    /// Dimensional value of each coefficient.
    pub fn dimensional(&self, c: &Coefficients) -> Coefficients {
        c.component_mul(&self.scale)
    }

    /// The factor that makes coefficient `i` dimensional.
    pub fn scale(&self, i: usize) -> f64 {
        self.scale[i]
    }

    fn mass_matrix(&self, d: &Coefficients) -> Matrix2<f64> {
        let m = self.constants.mass_kg;
        Matrix2::new(m - d[1], -d[3], -d[6], self.pitch_inertia - d[8])
    }

    /// `x' = f(x, delta_s, c)`.
    pub fn derivative(&self, x: &State, delta_s: f64, c: &Coefficients) -> State {
        let d = self.dimensional(c);
        let acc = self.accelerations(x, delta_s, &d);
        let (theta, w) = (x[1], x[0]);
        State::new(
            acc.x,
            x[2],
            acc.y,
            -self.constants.speed_m_s * theta.sin() + w * theta.cos(),
        )
    }

    /// `[w', q']` with dimensional coefficients `d`.
    fn accelerations(&self, x: &State, delta_s: f64, d: &Coefficients) -> Vector2<f64> {
        let k = &self.constants;
        let (w, theta, q) = (x[0], x[1], x[2]);
        let (m, u, zg) = (k.mass_kg, k.speed_m_s, k.z_g_m);
        let weight = m * k.gravity_m_s2;
        let rhs = Vector2::new(
            d[0] * w
                + (d[2] + m * u) * q
                + m * zg * q * q
                + k.weight_minus_buoyancy_n * theta.cos()
                + d[4] * delta_s,
            d[5] * w + d[7] * q - m * zg * w * q - weight * zg * theta.sin() + d[9] * delta_s,
        );
        // The mass matrix is positive definite for any physical coefficients (added masses
        // are small against the body's); a singular one gives non-finite values, which the
        // callers check.
        self.mass_matrix(d)
            .try_inverse()
            .map_or(Vector2::repeat(f64::NAN), |inv| inv * rhs)
    }

    /// `df/dx` (4x4).
    pub fn state_jacobian(&self, x: &State, c: &Coefficients) -> SMatrix<f64, 4, 4> {
        let k = &self.constants;
        let d = self.dimensional(c);
        let (w, theta, q) = (x[0], x[1], x[2]);
        let (m, u, zg) = (k.mass_kg, k.speed_m_s, k.z_g_m);
        let weight = m * k.gravity_m_s2;
        // d(rhs)/d[w, theta, q] (the mass matrix does not depend on the state).
        let drhs = SMatrix::<f64, 2, 3>::new(
            d[0],
            -k.weight_minus_buoyancy_n * theta.sin(),
            d[2] + m * u + 2.0 * m * zg * q,
            d[5] - m * zg * q,
            -weight * zg * theta.cos(),
            d[7] - m * zg * w,
        );
        let inv = self
            .mass_matrix(&d)
            .try_inverse()
            .unwrap_or(Matrix2::repeat(f64::NAN));
        let dacc = inv * drhs;
        let mut j = SMatrix::<f64, 4, 4>::zeros();
        j.fixed_view_mut::<1, 3>(0, 0).copy_from(&dacc.row(0));
        j[(1, 2)] = 1.0;
        j.fixed_view_mut::<1, 3>(2, 0).copy_from(&dacc.row(1));
        j[(3, 0)] = theta.cos();
        j[(3, 1)] = -u * theta.cos() - w * theta.sin();
        j
    }

    /// `df/dc` (4x10), by the nondimensional coefficients.
    pub fn coefficient_jacobian(
        &self,
        x: &State,
        delta_s: f64,
        c: &Coefficients,
    ) -> SMatrix<f64, 4, 10> {
        let d = self.dimensional(c);
        let acc = self.accelerations(x, delta_s, &d);
        let inv = self
            .mass_matrix(&d)
            .try_inverse()
            .unwrap_or(Matrix2::repeat(f64::NAN));
        let (w, q) = (x[0], x[2]);
        // Regressors of Z_w, Z_wdot, Z_q, Z_qdot, Z_delta (row 0) and the M's (row 1).
        let regressors = [w, acc.x, q, acc.y, delta_s];
        let mut j = SMatrix::<f64, 4, 10>::zeros();
        for i in 0..10 {
            let v = if i < 5 {
                Vector2::new(regressors[i], 0.0)
            } else {
                Vector2::new(0.0, regressors[i - 5])
            };
            let dacc = inv * v * self.scale[i];
            j[(0, i)] = dacc.x;
            j[(2, i)] = dacc.y;
        }
        j
    }

    /// One RK4 step of `dt` with the plane moving linearly from `plane0` to `plane1`.
    pub fn rk4_varying(
        &self,
        x: &State,
        plane0: f64,
        plane1: f64,
        c: &Coefficients,
        dt: f64,
    ) -> State {
        let mid = 0.5 * (plane0 + plane1);
        let k1 = self.derivative(x, plane0, c);
        let k2 = self.derivative(&(x + k1 * (dt / 2.0)), mid, c);
        let k3 = self.derivative(&(x + k2 * (dt / 2.0)), mid, c);
        let k4 = self.derivative(&(x + k3 * dt), plane1, c);
        x + (k1 + k2 * 2.0 + k3 * 2.0 + k4) * (dt / 6.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    fn model() -> HeavePitch {
        HeavePitch::new(Constants::default())
    }

    fn random_point(rng: &mut impl Rng) -> (State, f64, Coefficients) {
        let x = State::new(
            rng.random_range(-0.5..0.5),
            rng.random_range(-0.5..0.5),
            rng.random_range(-0.05..0.05),
            rng.random_range(0.0..100.0),
        );
        let c = Coefficients::from_fn(|i, _| TRUE_COEFFICIENTS[i] * rng.random_range(0.7..1.3));
        (x, rng.random_range(-0.2..0.2), c)
    }

    #[test]
    fn jacobians_match_finite_differences() {
        let m = model();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(41);
        for _ in 0..200 {
            let (x, delta, c) = random_point(&mut rng);
            let js = m.state_jacobian(&x, &c);
            for j in 0..4 {
                let h = 1e-6 * (1.0 + x[j].abs());
                let (mut up, mut down) = (x, x);
                up[j] += h;
                down[j] -= h;
                let fd =
                    (m.derivative(&up, delta, &c) - m.derivative(&down, delta, &c)) / (2.0 * h);
                for i in 0..4 {
                    let err = (fd[i] - js[(i, j)]).abs();
                    assert!(
                        err <= 1e-5 * (js[(i, j)].abs() + 1e-6),
                        "dx[{i}]/dx[{j}]: {} vs {}",
                        js[(i, j)],
                        fd[i]
                    );
                }
            }
            let jc = m.coefficient_jacobian(&x, delta, &c);
            for j in 0..10 {
                let h = 1e-4 * c[j].abs();
                let (mut up, mut down) = (c, c);
                up[j] += h;
                down[j] -= h;
                let fd =
                    (m.derivative(&x, delta, &up) - m.derivative(&x, delta, &down)) / (2.0 * h);
                for i in 0..4 {
                    let err = (fd[i] - jc[(i, j)]).abs();
                    assert!(
                        err <= 1e-5 * jc[(i, j)].abs() + 1e-12,
                        "dx[{i}]/d{}: {} vs {}",
                        NAMES[j],
                        jc[(i, j)],
                        fd[i]
                    );
                }
            }
        }
    }

    /// Straight and level with the plane at zero is an equilibrium, and a small pitch
    /// disturbance dies out (z_G below the origin: pitch-stable).
    #[test]
    fn level_flight_is_an_equilibrium_and_pitch_is_stable() {
        let m = model();
        let c = Coefficients::from(TRUE_COEFFICIENTS);
        let level = State::new(0.0, 0.0, 0.0, 20.0);
        assert!(m.derivative(&level, 0.0, &c).norm() < 1e-12);
        let mut x = State::new(0.0, 0.02, 0.0, 20.0);
        let mut peak_late: f64 = 0.0;
        for k in 0..60_000 {
            x = m.rk4_varying(&x, 0.0, 0.0, &c, 0.01);
            if k > 50_000 {
                peak_late = peak_late.max(x[1].abs());
            }
        }
        assert!(peak_late < 0.002, "pitch still {peak_late} rad after 500 s");
    }
}
