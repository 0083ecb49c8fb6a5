//! Seed 004's first stage: a continuous-discrete EKF on the state augmented with the ten
//! nondimensional coefficients, modelled as constants (Table 3.1).
//!
//! Between IMU samples the state is integrated by RK4 (plane interpolated linearly over the
//! step) and the covariance by the transition `I + F dt + (F dt)^2 / 2`, `F` the analytic
//! Jacobian of the model by state and coefficients. Every sample updates with q (gyro) and
//! theta; w and depth update when a reading falls on the sample. Scalar updates on the
//! shared Kalman core (Joseph form). Several logs: the coefficients and their covariance
//! carry from one log to the next; the dynamic state restarts from each log's first
//! readings.

use super::record::Record;
use super::settings::Settings;
use crate::filters::kalman::{self, Gaussian};
use crate::vehicle::heave_pitch::{Coefficients, Constants, HeavePitch, State};
use nalgebra::{SMatrix, SVector};

pub type Augmented = SVector<f64, 14>;
type Cov = SMatrix<f64, 14, 14>;

/// The coefficients at one moment of the pass.
#[derive(Debug, Clone, PartialEq)]
pub struct HistoryPoint {
    pub log: usize,
    pub t_s: f64,
    pub value: Coefficients,
    pub sigma: Coefficients,
}

/// The pass's result.
#[derive(Debug, Clone, PartialEq)]
pub struct EkfResult {
    pub coefficients: Coefficients,
    pub covariance: SMatrix<f64, 10, 10>,
    /// Every `history_interval_s`.
    pub history: Vec<HistoryPoint>,
    /// Updates the innovation covariance refused (should be none).
    pub failed_updates: usize,
}

/// The model of one log (its forward speed, and its weight minus buoyancy when known).
pub fn model_for(record: &Record, constants: &Constants) -> HeavePitch {
    HeavePitch::new(Constants {
        speed_m_s: record.speed_m_s,
        weight_minus_buoyancy_n: record
            .weight_minus_buoyancy_n
            .unwrap_or(constants.weight_minus_buoyancy_n),
        ..*constants
    })
}

/// The first readings of a log as its initial state.
pub fn first_state(record: &Record) -> State {
    State::new(
        record.w_m_s.first().map_or(0.0, |w| w.1),
        record.theta_rad[0],
        record.q_rad_s[0],
        record.depth_m.first().map_or(0.0, |d| d.1),
    )
}

/// The augmented derivative's Jacobian (14x14; the coefficients' rows are zero).
fn jacobian(model: &HeavePitch, x: &State, plane: f64, c: &Coefficients) -> Cov {
    let mut f = Cov::zeros();
    f.fixed_view_mut::<4, 4>(0, 0)
        .copy_from(&model.state_jacobian(x, c));
    f.fixed_view_mut::<4, 10>(0, 4)
        .copy_from(&model.coefficient_jacobian(x, plane, c));
    f
}

/// Runs the EKF over the logs, from `initial` with a relative 1-sigma of
/// `settings.initial_coefficient_sigma` on each coefficient (none on a fixed one).
pub fn run(records: &[Record], initial: &Coefficients, settings: &Settings) -> EkfResult {
    let initial = settings.with_fixed(initial);
    // A fixed coefficient starts (and stays) certain.
    let mut coefficient_cov =
        SMatrix::<f64, 10, 10>::from_diagonal(&Coefficients::from_fn(|i, _| {
            if settings.fixed[i].is_some() {
                0.0
            } else {
                (initial[i] * settings.initial_coefficient_sigma).powi(2)
            }
        }));
    let mut coefficients = initial;
    let mut history = Vec::new();
    let mut failed_updates = 0;
    let s = &settings.sigma;
    for (log, record) in records.iter().enumerate() {
        let model = model_for(record, &settings.constants);
        let mut est = Gaussian::<14> {
            mean: Augmented::zeros(),
            cov: Cov::zeros(),
        };
        est.mean
            .fixed_rows_mut::<4>(0)
            .copy_from(&first_state(record));
        est.mean.fixed_rows_mut::<10>(4).copy_from(&coefficients);
        let initial_state_sigma = SVector::<f64, 4>::new(
            3.0 * s.w_m_s,
            3.0 * s.theta_rad,
            3.0 * s.q_rad_s,
            3.0 * s.depth_m,
        );
        est.cov
            .fixed_view_mut::<4, 4>(0, 0)
            .copy_from(&SMatrix::<f64, 4, 4>::from_diagonal(
                &initial_state_sigma.map(|v| v * v),
            ));
        est.cov
            .fixed_view_mut::<10, 10>(4, 4)
            .copy_from(&coefficient_cov);
        let (mut w_next, mut d_next) = (0usize, 0usize);
        let mut next_history = 0.0;
        for k in 0..record.t_s.len() {
            if k > 0 {
                let dt = record.t_s[k] - record.t_s[k - 1];
                if dt > 0.0 {
                    est = predict(
                        &model,
                        &est,
                        record.plane_rad[k - 1],
                        record.plane_rad[k],
                        dt,
                        settings,
                    );
                }
            }
            let mut update = |est: &mut Gaussian<14>, index: usize, measured: f64, sigma: f64| {
                let mut h = SMatrix::<f64, 1, 14>::zeros();
                h[index] = 1.0;
                let y = SVector::<f64, 1>::new(measured - est.mean[index]);
                let r = SMatrix::<f64, 1, 1>::new(sigma * sigma);
                match kalman::update(est, &y, &h, &r, None) {
                    Ok((posterior, _)) => *est = posterior,
                    Err(_) => failed_updates += 1,
                }
            };
            update(&mut est, 2, record.q_rad_s[k], s.q_rad_s);
            update(&mut est, 1, record.theta_rad[k], s.theta_rad);
            while w_next < record.w_m_s.len() && record.w_m_s[w_next].0 <= k {
                if record.w_m_s[w_next].0 == k {
                    update(&mut est, 0, record.w_m_s[w_next].1, s.w_m_s);
                }
                w_next += 1;
            }
            while d_next < record.depth_m.len() && record.depth_m[d_next].0 <= k {
                if record.depth_m[d_next].0 == k {
                    update(&mut est, 3, record.depth_m[d_next].1, s.depth_m);
                }
                d_next += 1;
            }
            if record.t_s[k] >= next_history {
                next_history += settings.history_interval_s;
                let cov = est.cov.fixed_view::<10, 10>(4, 4);
                history.push(HistoryPoint {
                    log,
                    t_s: record.t_s[k],
                    value: est.mean.fixed_rows::<10>(4).into_owned(),
                    sigma: cov.diagonal().map(f64::sqrt),
                });
            }
        }
        coefficients = est.mean.fixed_rows::<10>(4).into_owned();
        coefficient_cov = est.cov.fixed_view::<10, 10>(4, 4).into_owned();
    }
    EkfResult {
        coefficients,
        covariance: coefficient_cov,
        history,
        failed_updates,
    }
}

/// Mean by RK4 (plane linear over the step), covariance by the second-order transition.
fn predict(
    model: &HeavePitch,
    est: &Gaussian<14>,
    plane0: f64,
    plane1: f64,
    dt: f64,
    settings: &Settings,
) -> Gaussian<14> {
    let x: State = est.mean.fixed_rows::<4>(0).into_owned();
    let c: Coefficients = est.mean.fixed_rows::<10>(4).into_owned();
    let f = jacobian(model, &x, 0.5 * (plane0 + plane1), &c) * dt;
    let phi = Cov::identity() + f + f * f * 0.5;
    let mut q = Cov::zeros();
    q[(0, 0)] = settings.process_noise.w_accel_m_s2_rt_s.powi(2) * dt;
    q[(2, 2)] = settings.process_noise.q_accel_rad_s2_rt_s.powi(2) * dt;
    let cov = phi * est.cov * phi.transpose() + q;
    let mut mean = est.mean;
    mean.fixed_rows_mut::<4>(0)
        .copy_from(&model.rk4_varying(&x, plane0, plane1, &c, dt));
    Gaussian {
        mean,
        cov: (cov + cov.transpose()) * 0.5,
    }
}
