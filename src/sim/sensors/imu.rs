//! Gyro and accelerometer triads (seed 002 eq. 6-7), per axis:
//! `out = b + (1 + s)(in + misalignment terms) + noise`, i.e. in matrix form
//! `out = b(t) + (I + S)(I + M) in + n`, with
//! - `b(t) = b0 + g(t)`: a turn-on bias `b0 ~ N(0, bias)` drawn once per run, plus a
//!   first-order Gauss-Markov bias instability `g` (1-sigma `bias_instability`, correlation
//!   time `bias_correlation_s`);
//! - `S = diag(s)`, `s ~ N(0, scale_ppm 1e-6)`; `M` off-diagonal, each `~ N(0, misalignment)`;
//! - `n`: white noise of density `noise_density` (per sample `noise_density * sqrt(rate)`).

use super::normal;
use nalgebra::{Matrix3, Vector3};
use rand_chacha::ChaCha8Rng;

/// Error parameters of one triad, SI units of its measurement (rad/s or m/s^2).
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TriadSpec {
    /// 1-sigma turn-on bias.
    pub bias: f64,
    /// 1-sigma of the Gauss-Markov bias instability.
    pub bias_instability: f64,
    /// Correlation time of the bias instability, s.
    pub bias_correlation_s: f64,
    /// 1-sigma scale-factor error, ppm.
    pub scale_ppm: f64,
    /// 1-sigma misalignment, rad.
    pub misalignment_rad: f64,
    /// White noise density, units per sqrt(Hz).
    pub noise_density: f64,
    /// Readings rounded to multiples of this (0: not quantised); the remainder is carried to
    /// the next reading, so the quantisation does not accumulate.
    pub quantum: f64,
}

/// One triad in one run: its drawn constants and its Gauss-Markov state.
#[derive(Debug, Clone)]
pub struct Triad {
    spec: TriadSpec,
    /// Drawn turn-on bias.
    pub turn_on_bias: Vector3<f64>,
    /// Drawn (I + S)(I + M).
    pub gain: Matrix3<f64>,
    markov: Vector3<f64>,
    /// What rounding has left out so far (carried into the next reading).
    carry: Vector3<f64>,
    rng: ChaCha8Rng,
}

impl Triad {
    /// Draws the run constants.
    pub fn new(spec: TriadSpec, mut rng: ChaCha8Rng) -> Self {
        let mut draw3 = |sigma: f64| Vector3::from_fn(|_, _| sigma * normal(&mut rng));
        let turn_on_bias = draw3(spec.bias);
        let scale = draw3(spec.scale_ppm * 1e-6);
        let markov = draw3(spec.bias_instability);
        let mut m = Matrix3::identity();
        for (i, j) in [(0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1)] {
            m[(i, j)] = spec.misalignment_rad * normal(&mut rng);
        }
        let gain = Matrix3::from_diagonal(&(Vector3::repeat(1.0) + scale)) * m;
        Triad {
            spec,
            turn_on_bias,
            gain,
            markov,
            carry: Vector3::zeros(),
            rng,
        }
    }

    /// The bias at this moment (turn-on plus instability).
    pub fn bias(&self) -> Vector3<f64> {
        self.turn_on_bias + self.markov
    }

    /// Measures `truth`, `dt_s` after the previous sample (the sample interval, for the noise
    /// and the Gauss-Markov step).
    pub fn measure(&mut self, truth: &Vector3<f64>, dt_s: f64) -> Vector3<f64> {
        let s = &self.spec;
        if s.bias_instability > 0.0 && s.bias_correlation_s > 0.0 {
            let phi = (-dt_s / s.bias_correlation_s).exp();
            let q = s.bias_instability * (1.0 - phi * phi).sqrt();
            for k in 0..3 {
                self.markov[k] = phi * self.markov[k] + q * normal(&mut self.rng);
            }
        }
        let sigma = if dt_s > 0.0 {
            s.noise_density / dt_s.sqrt()
        } else {
            0.0
        };
        let noise = Vector3::from_fn(|_, _| sigma * normal(&mut self.rng));
        let reading = self.bias() + self.gain * truth + noise;
        self.quantised(reading)
    }

    /// The reading rounded to the quantum, with the remainder carried.
    fn quantised(&mut self, reading: Vector3<f64>) -> Vector3<f64> {
        let q = self.spec.quantum;
        if q <= 0.0 {
            return reading;
        }
        let wanted = reading + self.carry;
        let out = wanted.map(|x| (x / q).round() * q);
        self.carry = wanted - out;
        out
    }
}

#[cfg(test)]
mod tests {
    use super::super::{rng_for, stream};
    use super::*;

    const DT: f64 = 0.01;

    #[test]
    fn recovers_bias_and_noise_from_a_long_stream() {
        let spec = TriadSpec {
            bias: 1e-3,
            noise_density: 2e-4,
            ..TriadSpec::default()
        };
        let mut t = Triad::new(spec, rng_for(5, stream::GYRO));
        let n = 200_000;
        let truth = Vector3::new(0.1, -0.2, 0.05);
        let samples: Vec<Vector3<f64>> = (0..n).map(|_| t.measure(&truth, DT)).collect();
        let mean = samples.iter().sum::<Vector3<f64>>() / n as f64;
        let expected_sigma = spec.noise_density / DT.sqrt();
        // Mean = truth + drawn bias, to within 5 standard errors.
        let tol = 5.0 * expected_sigma / (n as f64).sqrt();
        assert!(
            ((mean - truth) - t.turn_on_bias).amax() < tol,
            "{mean} vs {}",
            t.turn_on_bias
        );
        for k in 0..3 {
            let var = samples
                .iter()
                .map(|s| (s[k] - mean[k]).powi(2))
                .sum::<f64>()
                / (n - 1) as f64;
            assert!(
                (var.sqrt() / expected_sigma - 1.0).abs() < 0.01,
                "axis {k}: {}",
                var.sqrt()
            );
        }
    }

    #[test]
    fn turn_on_bias_scale_and_misalignment_have_their_sigmas_across_runs() {
        let spec = TriadSpec {
            bias: 0.02,
            scale_ppm: 300.0,
            misalignment_rad: 1e-3,
            ..TriadSpec::default()
        };
        let runs = 4000;
        let (mut b2, mut s2, mut m2) = (0.0, 0.0, 0.0);
        for seed in 0..runs {
            let t = Triad::new(spec, rng_for(seed, stream::ACCEL));
            b2 += t.turn_on_bias.norm_squared() / 3.0;
            s2 += (0..3).map(|k| (t.gain[(k, k)] - 1.0).powi(2)).sum::<f64>() / 3.0;
            m2 += t.gain[(0, 1)].powi(2); // (1 + s_x) m_xy ~ m_xy
        }
        let rms = |x: f64| (x / runs as f64).sqrt();
        assert!((rms(b2) / 0.02 - 1.0).abs() < 0.03, "{}", rms(b2));
        assert!((rms(s2) / 300e-6 - 1.0).abs() < 0.03, "{}", rms(s2));
        assert!((rms(m2) / 1e-3 - 1.0).abs() < 0.05, "{}", rms(m2));
    }

    #[test]
    fn gauss_markov_bias_has_its_sigma_and_correlation_time() {
        let spec = TriadSpec {
            bias_instability: 1e-4,
            bias_correlation_s: 10.0,
            ..TriadSpec::default()
        };
        let mut t = Triad::new(spec, rng_for(9, stream::GYRO));
        let n = 400_000; // 4000 s = 400 correlation times
        let mut xs = Vec::with_capacity(n);
        for _ in 0..n {
            t.measure(&Vector3::zeros(), DT);
            xs.push(t.bias().x);
        }
        let var = xs.iter().map(|x| x * x).sum::<f64>() / n as f64;
        assert!((var.sqrt() / 1e-4 - 1.0).abs() < 0.1, "{}", var.sqrt());
        // Autocorrelation at one correlation time: exp(-1).
        let lag = 1000;
        let cov = xs.windows(lag + 1).map(|w| w[0] * w[lag]).sum::<f64>() / (n - lag) as f64;
        assert!((cov / var - (-1f64).exp()).abs() < 0.1, "{}", cov / var);
    }
}
