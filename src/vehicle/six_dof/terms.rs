//! Hydrodynamic terms as products of factors: one coefficient times velocities, rates,
//! fin angles and the propeller-wake factor. Each factor knows its derivative by the body
//! velocities `nu = [u, v, w, p, q, r]`, so every term's gradient is exact (product rule).

use nalgebra::SVector;

/// Body velocities and rates `[u, v, w, p, q, r]` (m/s, rad/s).
pub type Nu = SVector<f64, 6>;

/// What a term multiplies besides its coefficient.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Factor {
    /// A component of `nu` (0..6).
    Nu(usize),
    /// Its magnitude.
    AbsNu(usize),
    /// Rudder, stern plane, bow plane (rad).
    Rudder,
    Stern,
    Bow,
    /// The propeller-wake factor epsilon(n, u) of the NPS AUV II model.
    Wake,
}

/// What a factor is evaluated with besides `nu`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Inputs {
    pub rudder_rad: f64,
    pub stern_rad: f64,
    pub bow_rad: f64,
    /// Propeller speed, rad/s.
    pub propeller_rad_s: f64,
}

/// The propeller-wake factor and its derivative by `u` (NPS AUV II, Healey and Lienard):
/// `eps = -1 + sign(n)/sign(u) (sqrt(Ct + 1) - 1) / (sqrt(Ct1 + 1) - 1)`,
/// `Ct = 0.008 L^2 |prop| prop / 2`, `prop = 0.012 n / u`.
pub fn wake(u: f64, n: f64, length_m: f64) -> (f64, f64) {
    let u = if u.abs() < 1e-6 {
        1e-6f64.copysign(u)
    } else {
        u
    };
    let prop = 0.012 * n / u;
    let k = 0.008 * length_m * length_m / 2.0;
    let ct = k * prop.abs() * prop;
    let ct1 = k;
    let denom = (ct1 + 1.0).sqrt() - 1.0;
    let s = n.signum() / u.signum();
    let root = (ct + 1.0).sqrt();
    let value = -1.0 + s * (root - 1.0) / denom;
    // d ct / du = k * 2 |prop| * d prop / du, d prop / du = -prop / u.
    let dct = k * 2.0 * prop.abs() * (-prop / u);
    let derivative = s / denom * 0.5 / root * dct;
    (value, derivative)
}

impl Factor {
    /// The factor's value.
    fn value(self, nu: &Nu, inputs: &Inputs, length_m: f64) -> f64 {
        match self {
            Factor::Nu(i) => nu[i],
            Factor::AbsNu(i) => nu[i].abs(),
            Factor::Rudder => inputs.rudder_rad,
            Factor::Stern => inputs.stern_rad,
            Factor::Bow => inputs.bow_rad,
            Factor::Wake => wake(nu[0], inputs.propeller_rad_s, length_m).0,
        }
    }

    /// The factor's value, and the one component of `nu` it depends on with its derivative
    /// by it (a fin angle depends on none).
    fn eval(self, nu: &Nu, inputs: &Inputs, length_m: f64) -> (f64, Option<(usize, f64)>) {
        match self {
            Factor::Nu(i) => (nu[i], Some((i, 1.0))),
            Factor::AbsNu(i) => (nu[i].abs(), Some((i, nu[i].signum()))),
            Factor::Rudder | Factor::Stern | Factor::Bow => {
                (self.value(nu, inputs, length_m), None)
            }
            Factor::Wake => {
                let (value, derivative) = wake(nu[0], inputs.propeller_rad_s, length_m);
                (value, Some((0, derivative)))
            }
        }
    }
}

/// One term of a force or moment: `coefficient * product(factors)`, dimensional (N or N m).
#[derive(Debug, Clone, PartialEq)]
pub struct Term {
    /// 0..3 force X, Y, Z; 3..6 moment K, M, N.
    pub axis: usize,
    pub coefficient: f64,
    pub factors: Vec<Factor>,
    /// The file's name for it (for messages and `vehicle check`).
    pub name: String,
}

impl Term {
    /// The term's value (the simulator's path: no gradient, no allocation).
    pub fn value(&self, nu: &Nu, inputs: &Inputs, length_m: f64) -> f64 {
        self.factors
            .iter()
            .fold(self.coefficient, |p, f| p * f.value(nu, inputs, length_m))
    }

    /// The term's value per unit coefficient (the product of its factors): its derivative by
    /// the coefficient.
    pub fn regressor(&self, nu: &Nu, inputs: &Inputs, length_m: f64) -> f64 {
        self.factors
            .iter()
            .fold(1.0, |p, f| p * f.value(nu, inputs, length_m))
    }

    /// The term's value and gradient by `nu`.
    pub fn eval(&self, nu: &Nu, inputs: &Inputs, length_m: f64) -> (f64, Nu) {
        // The product rule one factor at a time, (p g)' = p' g + p g', where g' has at most
        // one non-zero component.
        let mut value = self.coefficient;
        let mut grad = Nu::zeros();
        for f in &self.factors {
            let (v, d) = f.eval(nu, inputs, length_m);
            grad *= v;
            if let Some((i, dv)) = d {
                grad[i] += dv * value;
            }
            value *= v;
        }
        (value, grad)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wake_derivative_matches_finite_differences() {
        for (u, n) in [(1.5, 100.0), (0.3, 50.0), (2.0, -80.0), (-1.0, 60.0)] {
            let h = 1e-6;
            let fd = (wake(u + h, n, 5.3).0 - wake(u - h, n, 5.3).0) / (2.0 * h);
            let (_, d) = wake(u, n, 5.3);
            assert!(
                (fd - d).abs() < 1e-6 * (1.0 + d.abs()),
                "{u} {n}: {d} vs {fd}"
            );
        }
    }
}
