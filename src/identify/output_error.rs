//! The second stage: output-error maximum likelihood over the whole record of every log
//! (Levenberg-Marquardt), started from the EKF's answer.
//!
//! Parameters: the ten coefficients, and each log's initial state `[w, theta, q, z]`. The
//! model is simulated over each log (RK4 on the IMU's clock, plane linear over a step) with
//! its sensitivities to every parameter (the variational equations `S' = F_x S + F_p`,
//! integrated with the state), and compared with q, theta, w and depth, each weighted by its
//! noise. The normal matrix `J^T W J` at the optimum is the Fisher information: its inverse
//! gives the estimates' covariance (the Cramer-Rao bound when the model is right), their
//! standard deviations and correlations.

use super::ekf::{first_state, model_for};
use super::levenberg::{self, Normal};
use super::record::Record;
use super::settings::Settings;
use crate::vehicle::heave_pitch::{Coefficients, HeavePitch, State};
use nalgebra::{DMatrix, DVector, SMatrix};

/// The refined estimate.
#[derive(Debug, Clone, PartialEq)]
pub struct Refined {
    pub coefficients: Coefficients,
    /// Covariance of the coefficients (from the Fisher information, scaled by the
    /// normalised residual variance when that exceeds one).
    pub covariance: SMatrix<f64, 10, 10>,
    /// Each log's fitted initial state.
    pub initial_states: Vec<State>,
    /// Normalised residual RMS per channel (q, theta, w, depth) over all logs: about 1 when
    /// the model fits to the sensor noise.
    pub normalised_rms: [f64; 4],
    /// The coefficients' Fisher information, the logs' initial states marginalised out (the
    /// inverse of `covariance` where that is invertible; zero rows for fixed coefficients).
    pub information: SMatrix<f64, 10, 10>,
    pub iterations: usize,
    pub converged: bool,
}

/// Whether the model can be simulated over every log from `c` (finite all the way).
pub fn simulates(records: &[Record], c: &Coefficients, settings: &Settings) -> bool {
    records.iter().all(|r| {
        let model = model_for(r, &settings.constants);
        simulate(&model, r, &first_state(r), c)
            .iter()
            .all(|x| x.iter().all(|v| v.is_finite()))
    })
}

/// A log simulated with given parameters: the state at every sample.
pub fn simulate(model: &HeavePitch, record: &Record, x0: &State, c: &Coefficients) -> Vec<State> {
    let mut x = *x0;
    let mut out = Vec::with_capacity(record.t_s.len());
    out.push(x);
    for k in 1..record.t_s.len() {
        let dt = record.t_s[k] - record.t_s[k - 1];
        x = model.rk4_varying(&x, record.plane_rad[k - 1], record.plane_rad[k], c, dt);
        out.push(x);
    }
    out
}

/// Sensitivity of the state to `[c (10), x0 (4)]`.
pub type Sens = SMatrix<f64, 4, 14>;

/// State and sensitivity derivative: `x' = f`, `S' = F_x S + [F_c, 0]`.
fn augmented(
    model: &HeavePitch,
    x: &State,
    s: &Sens,
    plane: f64,
    c: &Coefficients,
) -> (State, Sens) {
    let fx = model.state_jacobian(x, c);
    let mut ds = fx * s;
    let fc = model.coefficient_jacobian(x, plane, c);
    let mut head = ds.fixed_view_mut::<4, 10>(0, 0);
    head += fc;
    (model.derivative(x, plane, c), ds)
}

/// The state and its sensitivity to `[c (10), x0 (4)]` at every sample of a log, by RK4 on
/// the state and the variational equations together.
pub fn trajectory_with_sensitivities(
    model: &HeavePitch,
    record: &Record,
    x0: &State,
    c: &Coefficients,
    substeps: usize,
) -> Vec<(State, Sens)> {
    let mut x = *x0;
    let mut s = Sens::zeros();
    s.fixed_view_mut::<4, 4>(0, 10)
        .copy_from(&SMatrix::<f64, 4, 4>::identity());
    let mut out = Vec::with_capacity(record.t_s.len());
    out.push((x, s));
    let n = substeps.max(1);
    for k in 1..record.t_s.len() {
        let dt = (record.t_s[k] - record.t_s[k - 1]) / n as f64;
        let (a0, a1) = (record.plane_rad[k - 1], record.plane_rad[k]);
        let plane = |f: f64| a0 + (a1 - a0) * f;
        for j in 0..n {
            let (f0, f1) = (j as f64 / n as f64, (j + 1) as f64 / n as f64);
            let (p0, pm, p1) = (plane(f0), plane(0.5 * (f0 + f1)), plane(f1));
            let (k1x, k1s) = augmented(model, &x, &s, p0, c);
            let (k2x, k2s) = augmented(
                model,
                &(x + k1x * (dt / 2.0)),
                &(s + k1s * (dt / 2.0)),
                pm,
                c,
            );
            let (k3x, k3s) = augmented(
                model,
                &(x + k2x * (dt / 2.0)),
                &(s + k2s * (dt / 2.0)),
                pm,
                c,
            );
            let (k4x, k4s) = augmented(model, &(x + k3x * dt), &(s + k3s * dt), p1, c);
            x += (k1x + k2x * 2.0 + k3x * 2.0 + k4x) * (dt / 6.0);
            s += (k1s + k2s * 2.0 + k3s * 2.0 + k4s) * (dt / 6.0);
        }
        out.push((x, s));
    }
    out
}

/// Accumulates one log's normal equations: `(J^T W J, J^T W r, r^T W r)` over the
/// parameters `[c (10), x0 (4)]`, and the per-channel sums of squared normalised residuals.
fn accumulate(
    model: &HeavePitch,
    record: &Record,
    x0: &State,
    c: &Coefficients,
    settings: &Settings,
) -> (
    SMatrix<f64, 14, 14>,
    SMatrix<f64, 14, 1>,
    f64,
    [f64; 4],
    [usize; 4],
) {
    let sigma = settings.sigma.by_channel();
    let mut jtj = SMatrix::<f64, 14, 14>::zeros();
    let mut jtr = SMatrix::<f64, 14, 1>::zeros();
    let mut cost = 0.0;
    let mut sums = [0.0; 4];
    let mut counts = [0usize; 4];
    let (mut wi, mut di) = (0usize, 0usize);
    let mut add = |x: &State, s: &Sens, state_index: usize, channel: usize, measured: f64| {
        let r = (measured - x[state_index]) / sigma[channel];
        let row = s.row(state_index) / sigma[channel];
        jtj += row.transpose() * row;
        jtr += row.transpose() * r;
        cost += r * r;
        sums[channel] += r * r;
        counts[channel] += 1;
    };
    let trajectory = trajectory_with_sensitivities(model, record, x0, c, settings.substeps);
    for (k, (x, s)) in trajectory.iter().enumerate() {
        add(x, s, 2, 0, record.q_rad_s[k]);
        add(x, s, 1, 1, record.theta_rad[k]);
        while wi < record.w_m_s.len() && record.w_m_s[wi].0 <= k {
            if record.w_m_s[wi].0 == k {
                add(x, s, 0, 2, record.w_m_s[wi].1);
            }
            wi += 1;
        }
        while di < record.depth_m.len() && record.depth_m[di].0 <= k {
            if record.depth_m[di].0 == k {
                add(x, s, 3, 3, record.depth_m[di].1);
            }
            di += 1;
        }
    }
    (jtj, jtr, cost, sums, counts)
}

/// The normal equations of all logs over `[c (10), x0 of log 0 (4), x0 of log 1 (4), ...]`.
fn normal_equations(
    records: &[Record],
    models: &[HeavePitch],
    c: &Coefficients,
    x0: &[State],
    settings: &Settings,
) -> (DMatrix<f64>, DVector<f64>, f64, [f64; 4]) {
    let n = 10 + 4 * records.len();
    let mut a = DMatrix::zeros(n, n);
    let mut b = DVector::zeros(n);
    let mut cost = 0.0;
    let (mut sums, mut counts) = ([0.0; 4], [0usize; 4]);
    for (l, record) in records.iter().enumerate() {
        let (jtj, jtr, cst, s, cnt) = accumulate(&models[l], record, &x0[l], c, settings);
        let index = |i: usize| if i < 10 { i } else { 10 + 4 * l + (i - 10) };
        for i in 0..14 {
            b[index(i)] += jtr[i];
            for j in 0..14 {
                a[(index(i), index(j))] += jtj[(i, j)];
            }
        }
        cost += cst;
        for ch in 0..4 {
            sums[ch] += s[ch];
            counts[ch] += cnt[ch];
        }
    }
    let rms = std::array::from_fn(|ch| (sums[ch] / counts[ch].max(1) as f64).sqrt());
    (a, b, cost, rms)
}

/// The coefficients' block of the information `a` over `[c (10), initial states...]`, the
/// initial states marginalised out; fixed coefficients' rows and columns are zero.
fn marginal_information(a: &DMatrix<f64>, fixed: &[Option<f64>; 10]) -> SMatrix<f64, 10, 10> {
    let schur = levenberg::marginal_information(a, 10);
    SMatrix::from_fn(|i, j| {
        if fixed[i].is_some() || fixed[j].is_some() {
            0.0
        } else {
            schur[(i, j)]
        }
    })
}

/// The coefficients' Fisher information from `records` at coefficients `c`, each log
/// started from its state in `x0` (marginalised out), at the settings' sensor noise:
/// what a manoeuvre would tell about the coefficients (the measurements themselves do not
/// enter, only when and what is measured).
pub fn information(
    records: &[Record],
    c: &Coefficients,
    x0: &[State],
    settings: &Settings,
) -> SMatrix<f64, 10, 10> {
    let models: Vec<HeavePitch> = records
        .iter()
        .map(|r| model_for(r, &settings.constants))
        .collect();
    let (a, ..) = normal_equations(records, &models, c, x0, settings);
    marginal_information(&a, &settings.fixed)
}

/// Refines `start` (with each log's first readings as its initial state) by
/// Levenberg-Marquardt on the whole record of every log. If the model cannot be simulated
/// from `start`, the result says so: not converged, infinite residuals.
pub fn refine(records: &[Record], start: &Coefficients, settings: &Settings) -> Refined {
    let models: Vec<HeavePitch> = records
        .iter()
        .map(|r| model_for(r, &settings.constants))
        .collect();
    let c = settings.with_fixed(start);
    let x0: Vec<State> = records.iter().map(first_state).collect();
    // Parameters: `[c (10), x0 of log 0 (4), x0 of log 1 (4), ...]`.
    let unpack = |p: &DVector<f64>| -> (Coefficients, Vec<State>) {
        let c = Coefficients::from_fn(|i, _| p[i]);
        let x0 = (0..records.len())
            .map(|l| State::from_fn(|i, _| p[10 + 4 * l + i]))
            .collect();
        (c, x0)
    };
    let mut start_parameters = DVector::zeros(10 + 4 * records.len());
    start_parameters.rows_mut(0, 10).copy_from(&c);
    for (l, x) in x0.iter().enumerate() {
        start_parameters.rows_mut(10 + 4 * l, 4).copy_from(x);
    }
    // A fixed coefficient is held.
    let minimum = levenberg::minimise(start_parameters, settings.max_iterations, |p| {
        let (c, x0) = unpack(p);
        let (a, b, cost, rms) = normal_equations(records, &models, &c, &x0, settings);
        let mut normal = Normal {
            a,
            b,
            cost,
            extra: rms,
        };
        for i in (0..10).filter(|&i| settings.fixed[i].is_some()) {
            normal.hold(i);
        }
        normal
    });
    let (c, x0) = unpack(&minimum.parameters);
    let Normal {
        a,
        cost,
        extra: rms,
        ..
    } = minimum.normal;
    if !cost.is_finite() {
        // The model cannot even be simulated from here (e.g. a singular mass matrix).
        return Refined {
            coefficients: c,
            covariance: SMatrix::repeat(f64::NAN),
            initial_states: x0,
            normalised_rms: [f64::INFINITY; 4],
            information: SMatrix::repeat(f64::NAN),
            iterations: 0,
            converged: false,
        };
    }
    let (iterations, converged) = (minimum.iterations, minimum.converged);
    // Covariance of all parameters, then the coefficients' block; inflated by the residual
    // variance when the fit is worse than the noise (a model error or underestimated noise).
    let n = a.nrows();
    let inverse = levenberg::inverse(&a);
    let dof = records
        .iter()
        .map(|r| 2 * r.t_s.len() + r.w_m_s.len() + r.depth_m.len())
        .sum::<usize>()
        .saturating_sub(n)
        .max(1);
    let variance_factor = (cost / dof as f64).max(1.0);
    let covariance = SMatrix::<f64, 10, 10>::from_fn(|i, j| {
        if settings.fixed[i].is_some() || settings.fixed[j].is_some() {
            0.0
        } else {
            inverse[(i, j)] * variance_factor
        }
    });
    let information = marginal_information(&a, &settings.fixed) / variance_factor;
    Refined {
        coefficients: c,
        covariance,
        initial_states: x0,
        normalised_rms: rms,
        information,
        iterations,
        converged,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::vehicle::heave_pitch::{Constants, TRUE_COEFFICIENTS};

    /// A 60 s record of a plane doublet (only its clock and input matter here).
    fn record() -> Record {
        let t_s: Vec<f64> = (0..6001).map(|k| k as f64 * 0.01).collect();
        let plane_rad = t_s
            .iter()
            .map(|&t| {
                if t < 20.0 {
                    0.1
                } else if t < 40.0 {
                    -0.1
                } else {
                    0.0
                }
            })
            .collect();
        Record {
            name: "doublet".into(),
            start_stamp_ns: 0,
            plane_rad,
            q_rad_s: vec![0.0; t_s.len()],
            theta_rad: vec![0.0; t_s.len()],
            w_m_s: Vec::new(),
            depth_m: Vec::new(),
            speed_m_s: 3.084,
            theta_source: "test",
            weight_minus_buoyancy_n: None,
            t_s,
        }
    }

    /// The variational sensitivities against central differences of the simulation, for
    /// every parameter, at every second of the record.
    #[test]
    fn sensitivities_match_finite_differences() {
        let model = HeavePitch::new(Constants::default());
        let r = record();
        let c = Coefficients::from(TRUE_COEFFICIENTS) * 1.1;
        let x0 = State::new(0.028, 0.01, 0.001, 20.0);
        let analytic = trajectory_with_sensitivities(&model, &r, &x0, &c, 1);
        for p in 0..14 {
            let h = if p < 10 { 1e-5 * c[p].abs() } else { 1e-6 };
            let shifted = |sign: f64| {
                let (mut cc, mut xx) = (c, x0);
                if p < 10 {
                    cc[p] += sign * h;
                } else {
                    xx[p - 10] += sign * h;
                }
                simulate(&model, &r, &xx, &cc)
            };
            let (up, down) = (shifted(1.0), shifted(-1.0));
            for k in (0..r.t_s.len()).step_by(100) {
                let fd = (up[k] - down[k]) / (2.0 * h);
                let col = analytic[k].1.column(p);
                for i in 0..4 {
                    let scale = (0..r.t_s.len())
                        .step_by(100)
                        .map(|k| analytic[k].1[(i, p)].abs())
                        .fold(0.0, f64::max);
                    assert!(
                        (fd[i] - col[i]).abs() <= 1e-5 * scale + 1e-12,
                        "d x[{i}] / d p[{p}] at {k}: {} vs {}",
                        col[i],
                        fd[i]
                    );
                }
            }
        }
    }
}
