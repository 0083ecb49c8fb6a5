//! Identification with seed 000's 6-DOF model ([`crate::vehicle::six_dof`]): a subset of a
//! vehicle file's hydrodynamic coefficients (the horizontal-plane one from a rudder zig-zag,
//! the vertical-plane one from a plane zig-zag), everything else held at the file's values.
//!
//! Output-error maximum likelihood, as for heave-pitch ([`super::output_error`]), on the
//! shared Levenberg-Marquardt core ([`super::levenberg`]): the model is simulated over each
//! log from its fins and propeller (`/fins`, `/rpm`, monotone cubic between readings), state
//! `[u, v, w, p, q, r, roll, pitch, yaw]` (body velocities and rates, the attitude that sets
//! weight and buoyancy and turns the Earth's rate into body axes; RK4 on the IMU's clock),
//! with its sensitivities by the variational equations; compared with the gyro (p, q, r: the
//! model's rate plus the Earth's, through the gyro's scale errors and misalignments, plus a
//! bias per axis and log) and the DVL
//! (u, v, w: with a bias per axis and a scale error per log). Parameters: the free
//! coefficients (SI, as in the model), and each log's initial state (but yaw) and sensor
//! errors. Each channel's noise is learnt from its residuals.
//!
//! At this precision the gyro's errors matter: on the simulator's rudder zig-zag, leaving out
//! its bias and scale, then its 0.1 mrad misalignment, made the reported sigma of Nv, then
//! of Nr and Ydr, half the Monte Carlo spread. Left out: the transport rate (`v / R`,
//! 2e-7 rad/s), the DVL's lever arm and mounting angles.

use super::identifiability::{assess_named, Determination};
use super::levenberg::{self, Normal};
use super::record::{imu_grid, latest, nearest, RecordError, MIN_PLANE_RANGE_DEG};
use super::settings::Thresholds;
use super::{channel_fit, residual_warning, ChannelFit, NOT_CONVERGED};
use crate::contract::{ControlSurfaces, Dvl, Imu, Propeller};
use crate::ingest::Log;
use crate::vehicle::six_dof::description::Vehicle;
use crate::vehicle::six_dof::model::{Attitude, SixDof};
use crate::vehicle::six_dof::terms::{Factors, Inputs, Nu};
use nalgebra::{DMatrix, DVector, Matrix3, Rotation3, SMatrix, SVector, Vector3};

/// `[u, v, w, p, q, r, roll, pitch, yaw]`.
pub type State = SVector<f64, 9>;

/// The horizontal-plane coefficients a rudder zig-zag determines (NPS AUV II's names).
pub const HORIZONTAL: [&str; 6] = ["Yv", "Yr", "Ydr", "Nv", "Nr", "Ndr"];
/// The vertical-plane coefficients a plane zig-zag determines.
pub const VERTICAL: [&str; 6] = ["Zw", "Zq", "Zds", "Mw", "Mq", "Mds"];

/// Measurement channels: gyro p, q, r; DVL u, v, w.
pub const CHANNELS: [&str; 6] = ["p", "q", "r", "u", "v", "w"];

/// One log's measurements on the IMU's clock.
#[derive(Debug, Clone, PartialEq)]
pub struct SixDofRecord {
    pub name: String,
    pub t_s: Vec<f64>,
    /// Fins and propeller at each sample (linear between readings).
    pub inputs: Vec<Inputs>,
    /// Gyro, rad/s.
    pub rates_rad_s: Vec<Vector3<f64>>,
    /// DVL body velocity at the grid index of each valid reading, m/s.
    pub velocity_m_s: Vec<(usize, Vector3<f64>)>,
    /// Roll and pitch from the accelerometer over the first second, rad.
    pub initial_roll_pitch_rad: (f64, f64),
    /// The fin that moves most, and by how much (deg).
    pub manoeuvre: (&'static str, f64),
    /// Earth's rotation in NED where the log was recorded (the mission's origin; zero
    /// without one), rad/s.
    pub earth_rate_ned: Vector3<f64>,
    /// The mission's initial yaw, else 0, rad.
    pub initial_yaw_rad: f64,
}

/// `value` (stamped) onto each grid stamp by monotone cubic (Fritsch-Carlson) interpolation,
/// held outside the readings. A fin follows its command through a lag and a rate limit: its
/// angle bends between readings, and a straight line between 10 Hz readings misplaces the
/// bends enough to bias the coefficients it drives (by 0.3 % on the simulator's rudder
/// zig-zag); the cubic takes the bends through the readings without overshooting them.
fn interpolated<T>(
    samples: &[T],
    stamp: impl Fn(&T) -> i64,
    value: impl Fn(&T) -> f64,
    grid: &[i64],
) -> Vec<f64> {
    let t: Vec<f64> = samples.iter().map(|m| stamp(m) as f64 * 1e-9).collect();
    let y: Vec<f64> = samples.iter().map(&value).collect();
    let slopes = monotone_slopes(&t, &y);
    let at = latest(samples, &stamp, grid);
    grid.iter()
        .zip(at)
        .map(|(&g, j)| {
            let x = g as f64 * 1e-9;
            match (t.get(j + 1), y.get(j + 1)) {
                (Some(&t1), Some(&y1)) if x >= t[j] && t1 > t[j] => {
                    let h = t1 - t[j];
                    let u = ((x - t[j]) / h).min(1.0);
                    let (u2, u3) = (u * u, u * u * u);
                    (2.0 * u3 - 3.0 * u2 + 1.0) * y[j]
                        + (u3 - 2.0 * u2 + u) * h * slopes[j]
                        + (-2.0 * u3 + 3.0 * u2) * y1
                        + (u3 - u2) * h * slopes[j + 1]
                }
                _ => y[j],
            }
        })
        .collect()
}

/// Fritsch-Carlson slopes at each reading: zero at a local extremum or a flat segment, so
/// that the cubic between two readings stays between them.
fn monotone_slopes(t: &[f64], y: &[f64]) -> Vec<f64> {
    let n = y.len();
    let secant: Vec<f64> = (0..n.saturating_sub(1))
        .map(|i| {
            let h = t[i + 1] - t[i];
            if h > 0.0 {
                (y[i + 1] - y[i]) / h
            } else {
                0.0
            }
        })
        .collect();
    (0..n)
        .map(
            |i| match (i.checked_sub(1).map(|k| secant[k]), secant.get(i)) {
                (Some(a), Some(&b)) if a * b > 0.0 => {
                    // Weighted harmonic mean of the neighbouring secants.
                    let (h0, h1) = (t[i] - t[i - 1], t[i + 1] - t[i]);
                    let (w0, w1) = (2.0 * h1 + h0, h1 + 2.0 * h0);
                    (w0 + w1) / (w0 / a + w1 / b)
                }
                (Some(_), Some(_)) => 0.0,
                (Some(a), None) => a,
                (None, Some(&b)) => b,
                (None, None) => 0.0,
            },
        )
        .collect()
}

impl SixDofRecord {
    pub fn from_log(name: &str, log: &Log) -> Result<SixDofRecord, RecordError> {
        let log_name = name.to_string();
        let imu: &[Imu] = log.role();
        let fins: &[ControlSurfaces] = log.role();
        let rpm: &[Propeller] = log.role();
        let dvl: Vec<&Dvl> = log.role::<Dvl>().iter().filter(|d| d.valid).collect();
        if imu.len() < 2 {
            return Err(RecordError::NoImu { log: log_name });
        }
        if fins.is_empty() {
            return Err(RecordError::NoFins { log: log_name });
        }
        if rpm.is_empty() {
            return Err(RecordError::NoRpm { log: log_name });
        }
        if dvl.is_empty() {
            return Err(RecordError::NoDvl { log: log_name });
        }
        let grid = imu_grid(&log_name, imu)?;
        let t0 = grid[0];
        let fin = |f: fn(&ControlSurfaces) -> f64| interpolated(fins, |m| m.stamp_ns, f, &grid);
        let (rudder, stern, bow) = (
            fin(|m| m.rudder),
            fin(|m| m.stern_plane),
            fin(|m| m.bow_plane),
        );
        let propeller = interpolated(
            rpm,
            |m| m.stamp_ns,
            |m| m.rpm * std::f64::consts::TAU / 60.0,
            &grid,
        );
        let range = |v: &[f64]| {
            let (lo, hi) = v
                .iter()
                .fold((f64::MAX, f64::MIN), |(lo, hi), &x| (lo.min(x), hi.max(x)));
            (hi - lo).to_degrees()
        };
        let manoeuvre = [
            ("rudder", range(&rudder)),
            ("stern plane", range(&stern)),
            ("bow plane", range(&bow)),
        ]
        .into_iter()
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .unwrap_or(("rudder", 0.0));
        if manoeuvre.1 < MIN_PLANE_RANGE_DEG {
            return Err(RecordError::NoManoeuvre {
                log: log_name,
                fin: "fins",
                range_deg: manoeuvre.1,
            });
        }
        // Level from the mean specific force over the first second.
        let first: Vec<&Imu> = imu
            .iter()
            .take_while(|m| m.stamp_ns - t0 <= 1_000_000_000)
            .collect();
        let f = first
            .iter()
            .fold(Vector3::zeros(), |a, m| a + Vector3::from(m.specific_force))
            / first.len() as f64;
        let initial_roll_pitch_rad = (
            (-f.y).atan2(-f.z),
            f.x.atan2((f.y * f.y + f.z * f.z).sqrt()),
        );
        Ok(SixDofRecord {
            name: log_name,
            t_s: grid.iter().map(|&t| (t - t0) as f64 * 1e-9).collect(),
            inputs: (0..grid.len())
                .map(|k| Inputs {
                    rudder_rad: rudder[k],
                    stern_rad: stern[k],
                    bow_rad: bow[k],
                    propeller_rad_s: propeller[k],
                })
                .collect(),
            rates_rad_s: imu
                .iter()
                .map(|m| Vector3::from(m.angular_velocity))
                .collect(),
            velocity_m_s: dvl
                .iter()
                .map(|d| (nearest(&grid, d.stamp_ns), Vector3::from(d.velocity)))
                .collect(),
            initial_roll_pitch_rad,
            manoeuvre,
            earth_rate_ned: log.mission().map_or(Vector3::zeros(), |m| {
                crate::geodesy::earth_rate_ned(m.origin_latitude_deg.to_radians())
            }),
            initial_yaw_rad: log
                .mission()
                .ok()
                .and_then(|m| m.initial_yaw_rad)
                .unwrap_or(0.0),
        })
    }

    /// The first readings as the initial state.
    fn first_state(&self) -> State {
        let v = self.velocity_m_s.first().map_or(Vector3::zeros(), |d| d.1);
        let w = self.rates_rad_s[0];
        let (roll, pitch) = self.initial_roll_pitch_rad;
        State::from_column_slice(&[
            v.x,
            v.y,
            v.z,
            w.x,
            w.y,
            w.z,
            roll,
            pitch,
            self.initial_yaw_rad,
        ])
    }
}

crate::config::with_defaults! {
    /// Settings of a 6-DOF identification.
    #[derive(Debug, Clone, PartialEq)]
    pub struct SixDofSettings {
        /// The coefficients to identify (the vehicle file's names).
        pub free: Vec<String> = HORIZONTAL.iter().map(|s| s.to_string()).collect(),
        /// Starting noise, 1 sigma: gyro rad/s, DVL m/s.
        pub gyro_rad_s: f64 = 0.01f64.to_radians(),
        pub dvl_m_s: f64 = 0.01,
        pub learn_noise: bool = true,
        pub noise_rounds: usize = 8,
        pub max_iterations: usize = 50,
        pub thresholds: Thresholds = Thresholds::default(),
    }
}

/// Why a 6-DOF identification cannot be set up.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SixDofError {
    #[error(
        "the vehicle `{vehicle}` has no coefficient `{name}` to identify (its terms: {known})"
    )]
    UnknownCoefficient {
        vehicle: String,
        name: String,
        known: String,
    },
    #[error("the vehicle `{0}`: the mass matrix (rigid body + added mass) is singular")]
    Singular(String),
}

/// The identified subset.
#[derive(Debug, Clone, PartialEq)]
pub struct SixDofIdentification {
    pub names: Vec<String>,
    /// The file's values, the start, and the estimates (SI, as the model uses them).
    pub file: Vec<f64>,
    pub start: Vec<f64>,
    pub coefficients: Vec<f64>,
    pub covariance: DMatrix<f64>,
    /// Each log's initial state and sensor errors.
    pub logs: Vec<LogEstimate>,
    /// Noise per channel (p, q, r, u, v, w) the refinement ended with.
    pub sigma: [f64; 6],
    pub noise_rounds: usize,
    /// Per log and channel.
    pub fits: Vec<[ChannelFit; 6]>,
    pub iterations: usize,
    pub converged: bool,
    pub assessment: Vec<Determination>,
}

impl SixDofIdentification {
    /// What makes the fit doubtful: residuals correlated from sample to sample (a wrong
    /// structure: a coefficient held at a wrong value), a refinement that did not converge.
    pub fn fit_warnings(&self, thresholds: &Thresholds) -> Vec<String> {
        let channels = self
            .fits
            .iter()
            .flat_map(|f| CHANNELS.iter().copied().zip(f.iter()));
        let mut warnings: Vec<String> =
            residual_warning(channels, thresholds).into_iter().collect();
        if !self.converged {
            warnings.push(NOT_CONVERGED.to_string());
        }
        warnings
    }
}

/// One log's initial state and sensor errors, estimated with the coefficients.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LogEstimate {
    pub initial_state: State,
    /// DVL bias (u, v, w), m/s, and scale-factor error (all axes).
    pub dvl_bias_m_s: Vector3<f64>,
    pub dvl_scale_error: f64,
    /// Gyro bias (p, q, r), rad/s.
    pub gyro_bias_rad_s: Vector3<f64>,
    /// The gyro's axes and scale: it reads `(I + E) omega`, with the scale-factor errors on
    /// `E`'s diagonal and the misalignments (small angles, rad) off it.
    pub gyro_axes_error: Matrix3<f64>,
}

impl LogEstimate {
    /// From the log's parameters `[x0 (9), DVL bias (3), DVL scale (1), gyro bias (3), gyro
    /// axes error (9, row by row)]`.
    fn from_parameters(p: &[f64]) -> LogEstimate {
        let v = |at: usize| Vector3::new(p[at], p[at + 1], p[at + 2]);
        LogEstimate {
            initial_state: State::from_column_slice(&p[..NX]),
            dvl_bias_m_s: v(NX),
            dvl_scale_error: p[NX + 3],
            gyro_bias_rad_s: v(NX + 4),
            gyro_axes_error: Matrix3::from_row_slice(&p[NX + 7..NX + 16]),
        }
    }

    /// What the gyro reads at state `x`, the Earth's rate in body axes being `earth`.
    fn gyro(&self, x: &State, earth: &Vector3<f64>) -> Vector3<f64> {
        let rate = Vector3::new(x[3], x[4], x[5]) + earth;
        (Matrix3::identity() + self.gyro_axes_error) * rate + self.gyro_bias_rad_s
    }

    /// What the DVL reads at state `x`.
    fn dvl(&self, x: &State) -> Vector3<f64> {
        Vector3::new(x[0], x[1], x[2]) * (1.0 + self.dvl_scale_error) + self.dvl_bias_m_s
    }
}

/// The model with the free coefficients set, and where they are among its terms.
struct Problem<'a> {
    vehicle: &'a Vehicle,
    /// For each free coefficient, the indices of its terms.
    terms: Vec<Vec<usize>>,
    records: &'a [SixDofRecord],
}

const NX: usize = 9;
/// The yaw's index in the state. It enters only through the Earth's rate in body axes, and is
/// held at its start (the mission's initial yaw, else north): a wrong heading turns the
/// horizontal Earth rate (up to 7e-5 rad/s) into a nearly constant body rate, which the gyro
/// bias takes; the vertical Earth rate, which the Coriolis force and r see, does not depend
/// on it.
const YAW: usize = 8;

impl Problem<'_> {
    fn model(&self, c: &[f64]) -> Option<SixDof> {
        let mut v = self.vehicle.clone();
        for (k, idx) in self.terms.iter().enumerate() {
            // A name that maps to several terms (none in the built-in files) shares the value.
            for &t in idx {
                v.terms[t].coefficient = c[k] / idx.len() as f64;
            }
        }
        SixDof::new(v)
    }

    /// `x'`, its Jacobian by `x`, and by the free coefficients.
    fn derivative(
        &self,
        model: &SixDof,
        x: &State,
        inputs: &Inputs,
        earth_rate_ned: &Vector3<f64>,
    ) -> (State, SMatrix<f64, NX, NX>, DMatrix<f64>) {
        let nu: Nu = x.fixed_rows::<6>(0).into_owned();
        let (roll, pitch, yaw) = (x[6], x[7], x[8]);
        let (earth_body, d_earth) = earth_rate_body(roll, pitch, yaw, earth_rate_ned);
        let at = Attitude {
            roll_rad: roll,
            pitch_rad: pitch,
            earth_rate_body: earth_body,
        };
        let (nu_dot, d_nu) = model.derivative(&nu, &at, inputs);
        let m_inv = model.mass_inverse();
        // Weight and buoyancy by roll and pitch; the Earth-rate Coriolis force
        // `-2 m Omega_b x v` by the attitude through `Omega_b`.
        let (_, d_rest) = model.restoring(roll, pitch);
        let v = Vector3::new(nu[0], nu[1], nu[2]);
        let d_coriolis = skew(&v) * d_earth * (2.0 * model.vehicle.mass_kg);
        let mut d_tau = SMatrix::<f64, 6, 3>::zeros();
        d_tau.fixed_view_mut::<6, 2>(0, 0).copy_from(&d_rest);
        let mut top = d_tau.fixed_view_mut::<3, 3>(0, 0);
        top += d_coriolis;
        let d_att = m_inv * d_tau;
        let (p, q, r) = (nu[3], nu[4], nu[5]);
        let (sr, cr) = roll.sin_cos();
        let (sp, cp) = pitch.sin_cos();
        let tp = sp / cp;
        let mut dx = State::zeros();
        dx.fixed_rows_mut::<6>(0).copy_from(&nu_dot);
        dx[6] = p + (q * sr + r * cr) * tp;
        dx[7] = q * cr - r * sr;
        dx[8] = (q * sr + r * cr) / cp;
        let mut f = SMatrix::<f64, NX, NX>::zeros();
        f.fixed_view_mut::<6, 6>(0, 0).copy_from(&d_nu);
        f.fixed_view_mut::<6, 3>(0, 6).copy_from(&d_att);
        f[(6, 3)] = 1.0;
        f[(6, 4)] = sr * tp;
        f[(6, 5)] = cr * tp;
        f[(6, 6)] = (q * cr - r * sr) * tp;
        f[(6, 7)] = (q * sr + r * cr) / (cp * cp);
        f[(7, 4)] = cr;
        f[(7, 5)] = -sr;
        f[(7, 6)] = -q * sr - r * cr;
        f[(8, 4)] = sr / cp;
        f[(8, 5)] = cr / cp;
        f[(8, 6)] = (q * cr - r * sr) / cp;
        f[(8, 7)] = (q * sr + r * cr) * sp / (cp * cp);
        let len = model.vehicle.length_m;
        let mut fc = DMatrix::zeros(NX, self.terms.len());
        let factors = Factors::at(&nu, inputs, len);
        for (k, idx) in self.terms.iter().enumerate() {
            let mut tau = Nu::zeros();
            for &t in idx {
                let term = &model.vehicle.terms[t];
                tau[term.axis] += term.regressor(&factors) / idx.len() as f64;
            }
            fc.view_mut((0, k), (6, 1)).copy_from(&(m_inv * tau));
        }
        (dx, f, fc)
    }

    /// The state and its sensitivity to `[c, x0]` at every sample, RK4 with the inputs linear
    /// over a step.
    fn trajectory(
        &self,
        model: &SixDof,
        record: &SixDofRecord,
        x0: &State,
    ) -> Vec<(State, DMatrix<f64>)> {
        let c_count = self.terms.len();
        let np = c_count + NX;
        let mut x = *x0;
        let mut s = DMatrix::zeros(NX, np);
        s.view_mut((0, c_count), (NX, NX)).fill_with_identity();
        let mut out = Vec::with_capacity(record.t_s.len());
        out.push((x, s.clone()));
        let stage = |x: &State, s: &DMatrix<f64>, inputs: &Inputs| -> (State, DMatrix<f64>) {
            let (dx, f, fc) = self.derivative(model, x, inputs, &record.earth_rate_ned);
            let mut ds = DMatrix::from_fn(NX, NX, |i, j| f[(i, j)]) * s;
            let mut head = ds.view_mut((0, 0), (NX, c_count));
            head += fc;
            (dx, ds)
        };
        for k in 1..record.t_s.len() {
            let dt = record.t_s[k] - record.t_s[k - 1];
            let (a, b) = (record.inputs[k - 1], record.inputs[k]);
            let mid = Inputs {
                rudder_rad: (a.rudder_rad + b.rudder_rad) / 2.0,
                stern_rad: (a.stern_rad + b.stern_rad) / 2.0,
                bow_rad: (a.bow_rad + b.bow_rad) / 2.0,
                propeller_rad_s: (a.propeller_rad_s + b.propeller_rad_s) / 2.0,
            };
            let (k1x, k1s) = stage(&x, &s, &a);
            let (k2x, k2s) = stage(&(x + k1x * (dt / 2.0)), &(&s + &k1s * (dt / 2.0)), &mid);
            let (k3x, k3s) = stage(&(x + k2x * (dt / 2.0)), &(&s + &k2s * (dt / 2.0)), &mid);
            let (k4x, k4s) = stage(&(x + k3x * dt), &(&s + &k3s * dt), &b);
            x += (k1x + k2x * 2.0 + k3x * 2.0 + k4x) * (dt / 6.0);
            s += (k1s + k2s * 2.0 + k3s * 2.0 + k4s) * (dt / 6.0);
            out.push((x, s.clone()));
        }
        out
    }

    /// Parameters `[c, then per log x0 (9), DVL bias (3), DVL scale error (1), gyro bias (3)
    /// and gyro axes error (9: scale factors and misalignments)]`. The initial yaw is held
    /// (see [`YAW`]).
    fn layout(&self) -> (usize, usize) {
        (self.terms.len(), NX + 16)
    }

    /// The normal equations; `extra`: per channel, the sum of squared normalised residuals
    /// and the count.
    fn normal(&self, p: &DVector<f64>, sigma: &[f64; 6]) -> Normal<[(f64, usize); 6]> {
        let (nc, per_log) = self.layout();
        let n = p.len();
        let mut a = DMatrix::zeros(n, n);
        let mut b = DVector::zeros(n);
        let mut cost = 0.0;
        let mut sums = [(0.0, 0usize); 6];
        let c: Vec<f64> = p.rows(0, nc).iter().copied().collect();
        let Some(model) = self.model(&c) else {
            return Normal {
                a,
                b,
                cost: f64::INFINITY,
                extra: sums,
            };
        };
        for (l, record) in self.records.iter().enumerate() {
            let base = nc + per_log * l;
            let est = LogEstimate::from_parameters(&p.as_slice()[base..base + per_log]);
            let scale = 1.0 + est.dvl_scale_error;
            let gyro_axes = Matrix3::identity() + est.gyro_axes_error;
            let trajectory = self.trajectory(&model, record, &est.initial_state);
            if trajectory
                .iter()
                .any(|(x, _)| !x.iter().all(|v| v.is_finite()))
            {
                return Normal {
                    a,
                    b,
                    cost: f64::INFINITY,
                    extra: sums,
                };
            }
            // Global index of the local parameter `j` (c, then this log's x0, then its bias).
            let global = |j: usize| if j < nc { j } else { base + (j - nc) };
            let mut add = |row: &DVector<f64>, residual: f64, channel: usize| {
                let (r, row) = (residual / sigma[channel], row / sigma[channel]);
                let nz: Vec<usize> = (0..row.len()).filter(|&j| row[j] != 0.0).collect();
                for &i in &nz {
                    b[global(i)] += row[i] * r;
                    for &j in &nz {
                        a[(global(i), global(j))] += row[i] * row[j];
                    }
                }
                cost += r * r;
                sums[channel].0 += r * r;
                sums[channel].1 += 1;
            };
            let np = nc + per_log;
            let mut dvl = record.velocity_m_s.iter().peekable();
            for (k, (x, s)) in trajectory.iter().enumerate() {
                // The gyro measures the body's rate over inertial space: the model's rate
                // over the local level plus the Earth's.
                let (earth, d_earth) = earth_rate_body(x[6], x[7], x[8], &record.earth_rate_ned);
                // Sensitivity of the rate the gyro sees (model's plus Earth's), then through
                // its axes.
                let d_rate = s.rows(3, 3) + d_earth * s.rows(6, 3);
                let d_gyro = gyro_axes * d_rate;
                let rate = Vector3::new(x[3], x[4], x[5]) + earth;
                let gyro = est.gyro(x, &earth);
                for i in 0..3 {
                    let mut row = DVector::zeros(np);
                    row.rows_mut(0, nc + NX)
                        .copy_from(&d_gyro.row(i).transpose());
                    row[nc + NX + 4 + i] = 1.0;
                    for j in 0..3 {
                        row[nc + NX + 7 + 3 * i + j] = rate[j];
                    }
                    add(&row, record.rates_rad_s[k][i] - gyro[i], i);
                }
                while let Some((_, v)) = dvl.next_if(|(idx, _)| *idx <= k) {
                    let modelled = est.dvl(x);
                    for i in 0..3 {
                        let mut row = DVector::zeros(np);
                        row.rows_mut(0, nc + NX)
                            .copy_from(&(s.row(i) * scale).transpose());
                        row[nc + NX + i] = 1.0;
                        row[nc + NX + 3] = x[i];
                        add(&row, v[i] - modelled[i], 3 + i);
                    }
                }
            }
        }
        let mut normal = Normal {
            a,
            b,
            cost,
            extra: sums,
        };
        // The initial yaw is held.
        for l in 0..self.records.len() {
            normal.hold(nc + per_log * l + YAW);
        }
        normal
    }
}

/// Identifies `settings.free` of `vehicle` from the logs, starting from `start` (SI; the
/// file's values where `None`).
pub fn identify_six_dof(
    records: &[SixDofRecord],
    vehicle: &Vehicle,
    start: Option<&[f64]>,
    settings: &SixDofSettings,
) -> Result<SixDofIdentification, SixDofError> {
    let terms = free_terms(vehicle, &settings.free)?;
    SixDof::new(vehicle.clone()).ok_or_else(|| SixDofError::Singular(vehicle.name.clone()))?;
    let problem = Problem {
        vehicle,
        terms,
        records,
    };
    let file: Vec<f64> = settings
        .free
        .iter()
        .map(|n| vehicle.coefficient(n))
        .collect();
    let start: Vec<f64> = start.map_or_else(|| file.clone(), <[f64]>::to_vec);
    let (nc, per_log) = problem.layout();
    let mut p = DVector::zeros(nc + per_log * records.len());
    p.rows_mut(0, nc).copy_from_slice(&start);
    for (l, r) in records.iter().enumerate() {
        p.rows_mut(nc + per_log * l, NX).copy_from(&r.first_state());
    }
    let (minimum, sigma, rounds) = minimise_learning_noise(&problem, p, settings);
    let inverse = levenberg::inverse(&minimum.normal.a);
    let coefficients: Vec<f64> = minimum.parameters.rows(0, nc).iter().copied().collect();
    let logs: Vec<LogEstimate> = (0..records.len())
        .map(|l| {
            let base = nc + per_log * l;
            LogEstimate::from_parameters(&minimum.parameters.as_slice()[base..base + per_log])
        })
        .collect();
    let fits = fits(&problem, &coefficients, &logs, &sigma);
    let names: Vec<&str> = settings.free.iter().map(String::as_str).collect();
    let covariance = inverse.view((0, 0), (nc, nc)).into_owned();
    let assessment = assess_named(
        &names,
        &coefficients,
        &covariance,
        &vec![true; nc],
        &settings.thresholds,
    );
    Ok(SixDofIdentification {
        assessment,
        names: settings.free.clone(),
        file,
        start,
        coefficients,
        covariance,
        logs,
        sigma,
        noise_rounds: rounds,
        fits,
        iterations: minimum.iterations,
        converged: minimum.converged,
    })
}

/// The terms of `vehicle` each free coefficient names (a name may stand for several).
fn free_terms(vehicle: &Vehicle, free: &[String]) -> Result<Vec<Vec<usize>>, SixDofError> {
    free.iter()
        .map(|name| {
            let idx: Vec<usize> = (0..vehicle.terms.len())
                .filter(|&t| vehicle.terms[t].name == *name)
                .collect();
            if idx.is_empty() {
                Err(SixDofError::UnknownCoefficient {
                    vehicle: vehicle.name.clone(),
                    name: name.clone(),
                    known: vehicle
                        .terms
                        .iter()
                        .map(|t| t.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", "),
                })
            } else {
                Ok(idx)
            }
        })
        .collect()
}

/// An output-error minimum with each channel's residual sums.
type ChannelMinimum = levenberg::Minimum<[(f64, usize); 6]>;

/// The output-error minimum from `p`, each channel's noise learnt from its residuals between
/// rounds (when the settings learn it) until they agree; returns the minimum, the noise and
/// the rounds made.
fn minimise_learning_noise(
    problem: &Problem,
    mut p: DVector<f64>,
    settings: &SixDofSettings,
) -> (ChannelMinimum, [f64; 6], usize) {
    let mut sigma = [
        settings.gyro_rad_s,
        settings.gyro_rad_s,
        settings.gyro_rad_s,
        settings.dvl_m_s,
        settings.dvl_m_s,
        settings.dvl_m_s,
    ];
    let mut rounds = 0;
    loop {
        rounds += 1;
        let m = levenberg::minimise(p.clone(), settings.max_iterations, |q| {
            problem.normal(q, &sigma)
        });
        let ratios: [f64; 6] = std::array::from_fn(|ch| {
            let (sum, count) = m.normal.extra[ch];
            (sum / count.max(1) as f64).sqrt()
        });
        let done = !settings.learn_noise
            || rounds >= settings.noise_rounds.max(1)
            || !ratios.iter().all(|r| r.is_finite())
            || ratios.iter().all(|r| *r == 0.0 || (r - 1.0).abs() < 0.01);
        if done {
            return (m, sigma, rounds);
        }
        for ch in 0..6 {
            if ratios[ch] > 0.0 {
                sigma[ch] *= ratios[ch];
            }
        }
        p = m.parameters;
    }
}

/// Each log re-simulated with the estimates, channel by channel.
fn fits(
    problem: &Problem,
    c: &[f64],
    logs: &[LogEstimate],
    sigma: &[f64; 6],
) -> Vec<[ChannelFit; 6]> {
    let model = problem.model(c);
    problem
        .records
        .iter()
        .zip(logs)
        .map(|(r, est)| {
            let simulated: Vec<State> = match &model {
                Some(m) => problem
                    .trajectory(m, r, &est.initial_state)
                    .into_iter()
                    .map(|(x, _)| x)
                    .collect(),
                None => vec![State::repeat(f64::NAN); r.t_s.len()],
            };
            std::array::from_fn(|ch| {
                let pairs: Vec<(f64, f64)> = if ch < 3 {
                    r.rates_rad_s
                        .iter()
                        .zip(&simulated)
                        .map(|(m, x)| {
                            let earth = earth_rate_body(x[6], x[7], x[8], &r.earth_rate_ned).0;
                            (m[ch], est.gyro(x, &earth)[ch])
                        })
                        .collect()
                } else {
                    r.velocity_m_s
                        .iter()
                        .map(|(k, v)| (v[ch - 3], est.dvl(&simulated[*k])[ch - 3]))
                        .collect()
                };
                channel_fit(&pairs, sigma[ch])
            })
        })
        .collect()
}

fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// The Earth's rate in body axes, `C_bn Omega_n` with `C_nb = Rz(yaw) Ry(pitch) Rx(roll)`, and
/// its derivative by roll, pitch and yaw (columns).
fn earth_rate_body(
    roll: f64,
    pitch: f64,
    yaw: f64,
    earth_rate_ned: &Vector3<f64>,
) -> (Vector3<f64>, Matrix3<f64>) {
    let rx = Rotation3::from_axis_angle(&Vector3::x_axis(), roll);
    let ry = Rotation3::from_axis_angle(&Vector3::y_axis(), pitch);
    let rz = Rotation3::from_axis_angle(&Vector3::z_axis(), yaw);
    // C_bn = Rx^T Ry^T Rz^T; d(R^T)/d(angle) = -skew(axis) R^T for a rotation about `axis`.
    let (xt, yt, zt) = (rx.inverse(), ry.inverse(), rz.inverse());
    let w = earth_rate_ned;
    let value = xt * (yt * (zt * w));
    let d_roll = -skew(&Vector3::x()) * (xt * (yt * (zt * w)));
    let d_pitch = xt * (-skew(&Vector3::y()) * (yt * (zt * w)));
    let d_yaw = xt * (yt * (-skew(&Vector3::z()) * (zt * w)));
    (value, Matrix3::from_columns(&[d_roll, d_pitch, d_yaw]))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 60 s record of a rudder doublet at cruise (only its clock and inputs matter here).
    fn record() -> SixDofRecord {
        let t_s: Vec<f64> = (0..3001).map(|k| k as f64 * 0.02).collect();
        let inputs = t_s
            .iter()
            .map(|&t| Inputs {
                rudder_rad: if t < 20.0 {
                    0.2
                } else if t < 40.0 {
                    -0.2
                } else {
                    0.0
                },
                stern_rad: 0.05,
                bow_rad: 0.0,
                propeller_rad_s: 1500.0 * std::f64::consts::TAU / 60.0,
            })
            .collect();
        SixDofRecord {
            name: "doublet".into(),
            rates_rad_s: vec![Vector3::zeros(); t_s.len()],
            velocity_m_s: Vec::new(),
            initial_roll_pitch_rad: (0.0, 0.0),
            manoeuvre: ("rudder", 23.0),
            earth_rate_ned: crate::geodesy::earth_rate_ned(0.6),
            initial_yaw_rad: 0.0,
            inputs,
            t_s,
        }
    }

    /// The variational sensitivities (the model's Jacobians by state and coefficient, the
    /// restoring and Earth-rate terms by attitude) against central differences of the
    /// simulation, for every parameter, every second.
    #[test]
    fn sensitivities_match_finite_differences() {
        let vehicle = Vehicle::built_in("nps-auv-ii").unwrap().unwrap();
        let r = record();
        let records = [r.clone()];
        let terms: Vec<Vec<usize>> = HORIZONTAL
            .iter()
            .map(|n| {
                (0..vehicle.terms.len())
                    .filter(|&t| vehicle.terms[t].name == *n)
                    .collect()
            })
            .collect();
        let problem = Problem {
            vehicle: &vehicle,
            terms,
            records: &records,
        };
        let c: Vec<f64> = HORIZONTAL
            .iter()
            .map(|n| vehicle.coefficient(n) * 1.1)
            .collect();
        let x0 = State::from_column_slice(&[1.5, 0.05, 0.02, 0.01, -0.01, 0.03, 0.05, -0.04, 0.3]);
        let model = problem.model(&c).unwrap();
        let analytic = problem.trajectory(&model, &r, &x0);
        for p in 0..c.len() + NX {
            let h = if p < c.len() { 1e-5 * c[p].abs() } else { 1e-6 };
            let shifted = |sign: f64| {
                let (mut cc, mut xx) = (c.clone(), x0);
                if p < c.len() {
                    cc[p] += sign * h;
                } else {
                    xx[p - c.len()] += sign * h;
                }
                let m = problem.model(&cc).unwrap();
                problem.trajectory(&m, &r, &xx)
            };
            let (up, down) = (shifted(1.0), shifted(-1.0));
            for i in 0..NX {
                let scale = (0..r.t_s.len())
                    .step_by(50)
                    .map(|k| analytic[k].1[(i, p)].abs())
                    .fold(0.0, f64::max);
                for k in (0..r.t_s.len()).step_by(50) {
                    let fd = (up[k].0[i] - down[k].0[i]) / (2.0 * h);
                    let a = analytic[k].1[(i, p)];
                    assert!(
                        (fd - a).abs() <= 1e-4 * scale + 1e-9,
                        "d x[{i}] / d p[{p}] at {k}: {a} vs {fd}"
                    );
                }
            }
        }
    }
}
