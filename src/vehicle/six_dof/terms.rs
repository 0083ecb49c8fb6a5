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

/// Kinds of factor: six velocities, their six magnitudes, three fins and the wake.
const KINDS: usize = 16;

impl Factor {
    /// Where the factor's value sits in a [`Factors`] table.
    fn slot(self) -> usize {
        match self {
            Factor::Nu(i) => i,
            Factor::AbsNu(i) => 6 + i,
            Factor::Rudder => 12,
            Factor::Stern => 13,
            Factor::Bow => 14,
            Factor::Wake => 15,
        }
    }
}

/// Every kind of factor evaluated once at one `nu` and actuation (the wake factor's square
/// roots above all), with the one component of `nu` each depends on and its derivative by it
/// (a fin angle depends on none).
pub struct Factors {
    value: [f64; KINDS],
    derivative: [Option<(usize, f64)>; KINDS],
}

impl Factors {
    pub fn at(nu: &Nu, inputs: &Inputs, length_m: f64) -> Self {
        let mut value = [0.0; KINDS];
        let mut derivative = [None; KINDS];
        for i in 0..6 {
            value[i] = nu[i];
            derivative[i] = Some((i, 1.0));
            value[6 + i] = nu[i].abs();
            derivative[6 + i] = Some((i, nu[i].signum()));
        }
        value[12] = inputs.rudder_rad;
        value[13] = inputs.stern_rad;
        value[14] = inputs.bow_rad;
        let (wake_value, wake_derivative) = wake(nu[0], inputs.propeller_rad_s, length_m);
        value[15] = wake_value;
        derivative[15] = Some((0, wake_derivative));
        Factors { value, derivative }
    }

    fn value(&self, f: Factor) -> f64 {
        self.value[f.slot()]
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
    pub fn value(&self, f: &Factors) -> f64 {
        self.factors
            .iter()
            .fold(self.coefficient, |p, &k| p * f.value(k))
    }

    /// The term's value per unit coefficient (the product of its factors): its derivative by
    /// the coefficient.
    pub fn regressor(&self, f: &Factors) -> f64 {
        self.factors.iter().fold(1.0, |p, &k| p * f.value(k))
    }

    /// The term's value and gradient by `nu`.
    pub fn eval(&self, f: &Factors) -> (f64, Nu) {
        // The product rule one factor at a time, (p g)' = p' g + p g', where g' has at most
        // one non-zero component.
        let mut value = self.coefficient;
        let mut grad = Nu::zeros();
        for &k in &self.factors {
            let slot = k.slot();
            let v = f.value[slot];
            grad *= v;
            if let Some((i, dv)) = f.derivative[slot] {
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
