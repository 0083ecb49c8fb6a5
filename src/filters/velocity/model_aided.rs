//! Seed 000's model-aided velocity filter (eq. 5-12, Fig. 4), and Koifman and
//! Bar-Itzhack's virtual sensor it is compared with.
//!
//! A simulator, the vehicle's 6-DOF model driven by the logged fins and propeller and by the
//! navigation's roll and pitch, runs open loop beside the vehicle and gives
//! `xi_bar = [d_bar, V_bar, w_bar]` (depth, body velocity, body rate). Its error
//! `dxi = xi_bar - xi` follows the model's own linearisation (eq. 6-7),
//!
//! ```text
//! dxi' = A(xi) dxi,   A = [0  g_d  0;  0  A_v2  A_v3;  0  A_w2  A_w3]
//! ```
//!
//! (`g_d` the depth rate's gradient by the body velocity, the other blocks the model's
//! Jacobian `d nu' / d nu`), and a 7-state EKF estimates it (eq. 8-12) from the depth sensor
//! (`d_bar - d`), the EM log (`|V_bar| - speed`), the gyro (`w_bar - w`) and, while it is
//! in range, the DVL (`V_bar - V`). The estimate is taken off the simulator's output, not fed
//! back into it (the indirect feed-forward of Fig. 4): `V_hat = V_bar - dV_hat`, with the
//! filter's covariance as its uncertainty.
//!
//! The virtual sensor ([`Mode::VirtualSensor`]) hands on `V_bar` itself with a fixed
//! uncertainty: the earlier method, which the model's coefficient errors go straight into.
//!
//! Discretisation: `Phi = I + T A`, `Q = diag(q^2) T` with Table 3's rates `q`. The current
//! is not modelled (the EM log's speed through water is taken as the body speed).

use crate::contract::{ControlSurfaces, Depth, Imu, Propeller, SpeedLog};
use crate::filters::kalman::{self, chi_square_quantile, Gaussian};
use crate::geodesy;
use crate::growing_series::Feed;
use crate::vehicle::six_dof::model::{Attitude, SixDof};
use crate::vehicle::six_dof::terms::{Inputs as Actuation, Nu};
use nalgebra::{Matrix3, SMatrix, SVector, UnitQuaternion, Vector3};

/// Size of the error state `[d, V(3), w(3)]`.
pub const STATES: usize = 7;
type State = SVector<f64, STATES>;
type Cov = SMatrix<f64, STATES, STATES>;

/// Which velocity the filter hands on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// Seed 000's filter: the simulator's output less its estimated error.
    Proposed,
    /// Koifman and Bar-Itzhack: the simulator's output as it is.
    VirtualSensor,
}

/// Settings of the filter (seed 000's Table 3 by default).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModelAidedFilter {
    pub mode: Mode,
    /// Filter step `T`, s.
    pub step_s: f64,
    /// Initial 1-sigma of the depth, velocity and rate errors: m, m/s, rad/s.
    pub initial_sigma: [f64; STATES],
    /// Process noise rates: m/s, m/s^2, rad/s^2.
    pub process_sigma: [f64; STATES],
    pub depth_sigma_m: f64,
    pub eml_sigma_m_s: f64,
    /// The gyro's rate against the model's, rad/s (sensor noise and what the model's rate
    /// leaves out).
    pub gyro_sigma_rad_s: f64,
    pub dvl_sigma_m_s: f64,
    /// The virtual sensor's 1-sigma per axis, m/s.
    pub virtual_sigma_m_s: f64,
    /// Gate probability of the updates.
    pub gate_probability: f64,
}

impl Default for ModelAidedFilter {
    fn default() -> Self {
        let deg = 1f64.to_radians();
        ModelAidedFilter {
            mode: Mode::Proposed,
            step_s: 0.1,
            // Table 3: P0 1 m, 1 m/s, 1 deg/s; Q 0.1 m/s, [200, 0.5, 0.125] mm/s^2,
            // 0.1 deg/s^2.
            initial_sigma: [1.0, 1.0, 1.0, 1.0, deg, deg, deg],
            process_sigma: [0.1, 0.2, 0.5e-3, 0.125e-3, 0.1 * deg, 0.1 * deg, 0.1 * deg],
            depth_sigma_m: 0.5,
            eml_sigma_m_s: 0.03,
            gyro_sigma_rad_s: 0.01 * deg,
            dvl_sigma_m_s: 0.03,
            virtual_sigma_m_s: 0.05,
            gate_probability: 1.0 - 1e-6,
        }
    }
}

/// The navigation's attitude at a time (what drives the simulator's weight and buoyancy and
/// turns the Earth's rate into the body).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AttitudeAt {
    pub stamp_ns: i64,
    pub ned_from_body: UnitQuaternion<f64>,
    pub lat_rad: f64,
}

/// The attitude that drives the model, looked up by time: a whole track, or a [`Feed`] that
/// a pass beside this filter is still making (a lookup then waits for the part it needs).
pub trait AttitudeSource: Sync {
    /// The first attitude.
    fn first(&self) -> Option<AttitudeAt>;
    /// The latest attitude at or before `t_ns`, else the first.
    fn latest_at(&self, t_ns: i64) -> Option<AttitudeAt>;
    /// Whether the track reaches `t_ns` (has an attitude stamped at or after it).
    fn reaches(&self, t_ns: i64) -> bool;
}

/// The latest at or before `t_ns`, else the first.
fn latest_or_first(track: &[AttitudeAt], t_ns: i64) -> Option<AttitudeAt> {
    latest(track, t_ns, |a| a.stamp_ns)
        .or(track.first())
        .copied()
}

impl AttitudeSource for Vec<AttitudeAt> {
    fn first(&self) -> Option<AttitudeAt> {
        self.as_slice().first().copied()
    }

    fn latest_at(&self, t_ns: i64) -> Option<AttitudeAt> {
        latest_or_first(self, t_ns)
    }

    fn reaches(&self, t_ns: i64) -> bool {
        self.last().is_some_and(|a| a.stamp_ns >= t_ns)
    }
}

impl AttitudeSource for Feed<AttitudeAt> {
    fn first(&self) -> Option<AttitudeAt> {
        self.read_when(|track| !track.is_empty(), |track| track.first().copied())
    }

    fn latest_at(&self, t_ns: i64) -> Option<AttitudeAt> {
        // Settled once an attitude after `t_ns` has come (or none will).
        self.read_when(
            |track| track.last().is_some_and(|a| a.stamp_ns > t_ns),
            |track| latest_or_first(track, t_ns),
        )
    }

    fn reaches(&self, t_ns: i64) -> bool {
        let reached = |track: &[AttitudeAt]| track.last().is_some_and(|a| a.stamp_ns >= t_ns);
        self.read_when(reached, reached)
    }
}

/// A DVL reading in range: velocity over ground in the body axes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BodyVelocityReading {
    pub stamp_ns: i64,
    pub v_body_m_s: Vector3<f64>,
}

/// What the filter reads, each time-sorted.
#[derive(Clone, Copy)]
pub struct Inputs<'a> {
    pub fins: &'a [ControlSurfaces],
    pub propeller: &'a [Propeller],
    pub attitude: &'a dyn AttitudeSource,
    pub imu: &'a [Imu],
    pub depth: &'a [Depth],
    pub eml: &'a [SpeedLog],
    pub dvl: &'a [BodyVelocityReading],
}

/// The filter's body velocity at one step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModelVelocity {
    pub stamp_ns: i64,
    pub v_body_m_s: Vector3<f64>,
    pub cov: Matrix3<f64>,
}

/// NIS of one sensor's updates.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct NisTally {
    pub updates: usize,
    pub rejected: usize,
    /// Sum of the NIS of the accepted updates.
    pub nis_sum: f64,
    /// Dimension of one update.
    pub dims: usize,
}

impl NisTally {
    fn add(&mut self, dims: usize, nis: f64, accepted: bool) {
        self.dims = dims;
        self.updates += 1;
        if accepted {
            self.nis_sum += nis;
        } else {
            self.rejected += 1;
        }
    }

    /// Mean NIS of the accepted updates per dimension (1 when consistent).
    pub fn mean_per_dim(&self) -> Option<f64> {
        let accepted = self.updates - self.rejected;
        (accepted > 0 && self.dims > 0).then(|| self.nis_sum / (accepted * self.dims) as f64)
    }
}

/// The filter's run.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ModelRun {
    pub velocities: Vec<ModelVelocity>,
    pub depth: NisTally,
    pub eml: NisTally,
    pub gyro: NisTally,
    pub dvl: NisTally,
}

/// Why the filter could not run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ModelRefused {
    #[error("no /fins readings (the model needs the control surfaces)")]
    NoFins,
    #[error("no /rpm readings (the model needs the propeller)")]
    NoPropeller,
    #[error("no attitude to drive the model")]
    NoAttitude,
    #[error("the covariance lost positive definiteness at {stamp_ns} ns")]
    Numerics { stamp_ns: i64 },
}

/// Depth rate by body velocity: `d' = g_d V`, `g_d = [-sin pitch, cos pitch sin roll,
/// cos pitch cos roll]` (seed 000's `G_h` for the height, negated).
pub fn depth_rate_gradient(roll_rad: f64, pitch_rad: f64) -> Vector3<f64> {
    let (sr, cr) = roll_rad.sin_cos();
    let (sp, cp) = pitch_rad.sin_cos();
    Vector3::new(-sp, cp * sr, cp * cr)
}

/// The error model's matrix `A` of eq. 7 at the (corrected) state `nu`.
pub fn error_dynamics(
    model: &SixDof,
    nu: &Nu,
    at: &Attitude,
    actuation: &Actuation,
) -> SMatrix<f64, STATES, STATES> {
    let mut a = SMatrix::<f64, STATES, STATES>::zeros();
    let g = depth_rate_gradient(at.roll_rad, at.pitch_rad);
    for j in 0..3 {
        a[(0, 1 + j)] = g[j];
    }
    a.fixed_view_mut::<6, 6>(1, 1)
        .copy_from(&model.jacobian(nu, at, actuation));
    a
}

/// One RK4 step of the body velocities with the attitude and the actuation held.
fn rk4(model: &SixDof, nu: &Nu, at: &Attitude, act: &Actuation, dt: f64) -> Nu {
    let f = |x: &Nu| model.acceleration(x, at, act);
    let k1 = f(nu);
    let k2 = f(&(nu + k1 * (dt / 2.0)));
    let k3 = f(&(nu + k2 * (dt / 2.0)));
    let k4 = f(&(nu + k3 * dt));
    nu + (k1 + k2 * 2.0 + k3 * 2.0 + k4) * (dt / 6.0)
}

/// Latest element at or before `t_ns` of a stamped, sorted slice.
fn latest<T>(items: &[T], t_ns: i64, stamp: impl Fn(&T) -> i64) -> Option<&T> {
    let i = items.partition_point(|x| stamp(x) <= t_ns);
    items.get(i.checked_sub(1)?)
}

/// Elements stamped in `(from_ns, to_ns]`.
fn within<T>(items: &[T], from_ns: i64, to_ns: i64, stamp: impl Fn(&T) -> i64 + Copy) -> &[T] {
    let a = items.partition_point(|x| stamp(x) <= from_ns);
    let b = items.partition_point(|x| stamp(x) <= to_ns);
    &items[a..b.max(a)]
}

fn actuation_at(inputs: &Inputs<'_>, t_ns: i64) -> Actuation {
    let fins = latest(inputs.fins, t_ns, |f| f.stamp_ns).or(inputs.fins.first());
    let prop = latest(inputs.propeller, t_ns, |p| p.stamp_ns).or(inputs.propeller.first());
    Actuation {
        rudder_rad: fins.map_or(0.0, |f| f.rudder),
        stern_rad: fins.map_or(0.0, |f| f.stern_plane),
        bow_rad: fins.map_or(0.0, |f| f.bow_plane),
        propeller_rad_s: prop.map_or(0.0, |p| p.rpm * std::f64::consts::TAU / 60.0),
    }
}

/// The model's attitude inputs (roll, pitch, Earth's rate in the body) at `t_ns`.
fn attitude_at(a: &AttitudeAt) -> Attitude {
    let (roll_rad, pitch_rad, _) = a.ned_from_body.euler_angles();
    let earth_rate_body = a.ned_from_body.inverse() * geodesy::earth_rate_ned(a.lat_rad);
    Attitude {
        roll_rad,
        pitch_rad,
        earth_rate_body,
    }
}

/// Runs the filter over the inputs, one step of `T` from the first attitude to the last.
pub fn run(
    settings: &ModelAidedFilter,
    model: &SixDof,
    inputs: &Inputs<'_>,
) -> Result<ModelRun, ModelRefused> {
    run_handing_on(settings, model, inputs, &mut |_| {})
}

/// Steps between two hand-overs of [`run_handing_on`].
const HAND_ON_STEPS: usize = 256;

/// [`run`], handing the velocities made so far to `hand_on` as it goes (every
/// [`HAND_ON_STEPS`] steps, and the rest at the end), for a filter that takes them as they
/// come.
pub fn run_handing_on(
    settings: &ModelAidedFilter,
    model: &SixDof,
    inputs: &Inputs<'_>,
    hand_on: &mut dyn FnMut(&[ModelVelocity]),
) -> Result<ModelRun, ModelRefused> {
    if inputs.fins.is_empty() {
        return Err(ModelRefused::NoFins);
    }
    if inputs.propeller.is_empty() {
        return Err(ModelRefused::NoPropeller);
    }
    let Some(first) = inputs.attitude.first() else {
        return Err(ModelRefused::NoAttitude);
    };
    let step_ns = (settings.step_s * 1e9).round() as i64;
    let dt = step_ns as f64 * 1e-9;
    let t0 = first.stamp_ns;

    // The simulator starts level in speed with the EM log (or the model's own at rest) and
    // at the depth sensor's first reading.
    let speed0 = latest(inputs.eml, t0, |e| e.stamp_ns)
        .or(inputs.eml.first())
        .map_or(0.0, |e| e.speed);
    let mut nu_bar = Nu::zeros();
    nu_bar[0] = speed0;
    let mut depth_bar = inputs.depth.first().map_or(0.0, |d| d.depth);

    let mut est = Gaussian {
        mean: State::zeros(),
        cov: Cov::from_diagonal(&State::from_fn(|i, _| settings.initial_sigma[i].powi(2))),
    };
    let q = Cov::from_diagonal(&State::from_fn(|i, _| {
        settings.process_sigma[i].powi(2) * dt
    }));
    let proposed = settings.mode == Mode::Proposed;
    let updates = Updates::new(settings, inputs);
    let mut out = ModelRun {
        velocities: Vec::with_capacity(capacity(inputs.imu, t0, step_ns)),
        ..ModelRun::default()
    };

    let mut t_ns = t0;
    let mut handed = 0;
    while inputs.attitude.reaches(t_ns + step_ns) {
        let at = attitude_at(&inputs.attitude.latest_at(t_ns).unwrap_or(first));
        let act = actuation_at(inputs, t_ns);
        // Simulator and the error's prediction over [t, t + T].
        let g = depth_rate_gradient(at.roll_rad, at.pitch_rad);
        let v_before = nu_bar.fixed_rows::<3>(0).into_owned();
        if proposed {
            let corrected = nu_bar - est.mean.fixed_rows::<6>(1);
            let phi = Cov::identity() + error_dynamics(model, &corrected, &at, &act) * dt;
            est = kalman::predict(&est, &phi, &q);
        }
        nu_bar = rk4(model, &nu_bar, &at, &act, dt);
        let v_after = nu_bar.fixed_rows::<3>(0).into_owned();
        depth_bar += g.dot(&(v_before + v_after)) * (dt / 2.0);
        let next_ns = t_ns + step_ns;
        let step = Step {
            from_ns: t_ns,
            to_ns: next_ns,
            nu_bar: &nu_bar,
            depth_bar,
            earth_rate_body: at.earth_rate_body,
        };
        if proposed {
            est = updates.apply_all(&step, est, &mut out)?;
        }
        out.velocities.push(handed_on(settings, &step, &est));
        if out.velocities.len() - handed >= HAND_ON_STEPS {
            hand_on(&out.velocities[handed..]);
            handed = out.velocities.len();
        }
        t_ns = next_ns;
    }
    hand_on(&out.velocities[handed..]);
    Ok(out)
}

/// Steps from `t0` to the IMU's last sample (the attitude's track ends there, or sooner).
fn capacity(imu: &[Imu], t0: i64, step_ns: i64) -> usize {
    imu.last().map_or(0, |last| {
        ((last.stamp_ns - t0).max(0) / step_ns.max(1)) as usize + 1
    })
}

/// One step of the filter, `(from_ns, to_ns]`, with the simulator's state at its end.
struct Step<'a> {
    from_ns: i64,
    to_ns: i64,
    nu_bar: &'a Nu,
    depth_bar: f64,
    earth_rate_body: Vector3<f64>,
}

impl Step<'_> {
    fn v_bar(&self) -> Vector3<f64> {
        self.nu_bar.fixed_rows::<3>(0).into_owned()
    }
}

/// The velocity the filter hands on at the end of a step: the simulator's less its
/// estimated error, or, as a virtual sensor, the simulator's as it is.
fn handed_on(
    settings: &ModelAidedFilter,
    step: &Step<'_>,
    est: &Gaussian<STATES>,
) -> ModelVelocity {
    let v_bar = step.v_bar();
    let (v_body_m_s, cov) = match settings.mode {
        Mode::Proposed => (
            v_bar - est.mean.fixed_rows::<3>(1),
            est.cov.fixed_view::<3, 3>(1, 1).into_owned(),
        ),
        Mode::VirtualSensor => (
            v_bar,
            Matrix3::identity() * settings.virtual_sigma_m_s.powi(2),
        ),
    };
    ModelVelocity {
        stamp_ns: step.to_ns,
        v_body_m_s,
        cov,
    }
}

/// The measurement updates of eq. 8-12: depth, EM log, gyro and DVL.
struct Updates<'a> {
    settings: &'a ModelAidedFilter,
    inputs: &'a Inputs<'a>,
    /// Gates of one- and three-dimensional updates.
    gate_1: Option<f64>,
    gate_3: Option<f64>,
}

impl<'a> Updates<'a> {
    fn new(settings: &'a ModelAidedFilter, inputs: &'a Inputs<'a>) -> Self {
        let gate = |m| Some(chi_square_quantile(m, settings.gate_probability));
        Updates {
            settings,
            inputs,
            gate_1: gate(1),
            gate_3: gate(3),
        }
    }

    /// Every reading of the step, in the order depth, EM log, gyro, DVL.
    fn apply_all(
        &self,
        step: &Step<'_>,
        est: Gaussian<STATES>,
        out: &mut ModelRun,
    ) -> Result<Gaussian<STATES>, ModelRefused> {
        let est = self.depth(step, est, &mut out.depth)?;
        let est = self.eml(step, est, &mut out.eml)?;
        let est = self.gyro(step, est, &mut out.gyro)?;
        self.dvl(step, est, &mut out.dvl)
    }

    /// `d_bar - d`: the step's last depth reading.
    fn depth(
        &self,
        step: &Step<'_>,
        est: Gaussian<STATES>,
        tally: &mut NisTally,
    ) -> Result<Gaussian<STATES>, ModelRefused> {
        let stamp = |x: &Depth| x.stamp_ns;
        let Some(d) = within(self.inputs.depth, step.from_ns, step.to_ns, stamp).last() else {
            return Ok(est);
        };
        let mut h = SMatrix::<f64, 1, STATES>::zeros();
        h[0] = 1.0;
        let y = SVector::<f64, 1>::new(step.depth_bar - d.depth - est.mean[0]);
        let r = SMatrix::<f64, 1, 1>::new(self.settings.depth_sigma_m.powi(2));
        apply(&est, &y, &h, &r, self.gate_1, tally, step.to_ns)
    }

    /// `|V_bar| - speed`, `c(dxi) = |V_bar| - |V_bar - dV|`: each EM-log reading.
    fn eml(
        &self,
        step: &Step<'_>,
        mut est: Gaussian<STATES>,
        tally: &mut NisTally,
    ) -> Result<Gaussian<STATES>, ModelRefused> {
        for e in within(self.inputs.eml, step.from_ns, step.to_ns, |x| x.stamp_ns) {
            let v_hat = step.v_bar() - est.mean.fixed_rows::<3>(1);
            let norm = v_hat.norm();
            if norm < 0.1 {
                continue; // an EM log near rest reads nothing useful
            }
            let mut h = SMatrix::<f64, 1, STATES>::zeros();
            for j in 0..3 {
                h[1 + j] = v_hat[j] / norm;
            }
            let y = SVector::<f64, 1>::new(norm - e.speed);
            let r = SMatrix::<f64, 1, 1>::new(self.settings.eml_sigma_m_s.powi(2));
            est = apply(&est, &y, &h, &r, self.gate_1, tally, step.to_ns)?;
        }
        Ok(est)
    }

    /// `w_bar - w`: the mean of the step's gyro samples, less the Earth's rate.
    fn gyro(
        &self,
        step: &Step<'_>,
        est: Gaussian<STATES>,
        tally: &mut NisTally,
    ) -> Result<Gaussian<STATES>, ModelRefused> {
        let gyro = within(self.inputs.imu, step.from_ns, step.to_ns, |x| x.stamp_ns);
        if gyro.is_empty() {
            return Ok(est);
        }
        let mean = gyro.iter().fold(Vector3::zeros(), |s, m| {
            s + Vector3::from(m.angular_velocity)
        }) / gyro.len() as f64;
        let w_eb = mean - step.earth_rate_body;
        let w_bar = step.nu_bar.fixed_rows::<3>(3).into_owned();
        let mut h = SMatrix::<f64, 3, STATES>::zeros();
        h.fixed_view_mut::<3, 3>(0, 4)
            .copy_from(&Matrix3::identity());
        let y = w_bar - w_eb - est.mean.fixed_rows::<3>(4);
        let r = Matrix3::identity() * self.settings.gyro_sigma_rad_s.powi(2);
        apply(&est, &y, &h, &r, self.gate_3, tally, step.to_ns)
    }

    /// `V_bar - V`: each DVL reading in range.
    fn dvl(
        &self,
        step: &Step<'_>,
        mut est: Gaussian<STATES>,
        tally: &mut NisTally,
    ) -> Result<Gaussian<STATES>, ModelRefused> {
        for d in within(self.inputs.dvl, step.from_ns, step.to_ns, |x| x.stamp_ns) {
            let mut h = SMatrix::<f64, 3, STATES>::zeros();
            h.fixed_view_mut::<3, 3>(0, 1)
                .copy_from(&Matrix3::identity());
            let y = step.v_bar() - d.v_body_m_s - est.mean.fixed_rows::<3>(1);
            let r = Matrix3::identity() * self.settings.dvl_sigma_m_s.powi(2);
            est = apply(&est, &y, &h, &r, self.gate_3, tally, step.to_ns)?;
        }
        Ok(est)
    }
}

/// One gated update, tallied.
fn apply<const M: usize>(
    est: &Gaussian<STATES>,
    y: &SVector<f64, M>,
    h: &SMatrix<f64, M, STATES>,
    r: &SMatrix<f64, M, M>,
    gate: Option<f64>,
    tally: &mut NisTally,
    stamp_ns: i64,
) -> Result<Gaussian<STATES>, ModelRefused> {
    let (post, rec) =
        kalman::update(est, y, h, r, gate).map_err(|_| ModelRefused::Numerics { stamp_ns })?;
    tally.add(M, rec.nis, rec.accepted);
    Ok(post)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::vehicle::six_dof::description::Vehicle;

    fn nps() -> SixDof {
        SixDof::new(Vehicle::built_in("nps-auv-ii").unwrap().unwrap()).unwrap()
    }

    /// `A`'s velocity and rate blocks are the model's `d nu' / d nu` and its depth row the
    /// depth rate's gradient: both checked against central differences of the simulator's
    /// own functions.
    #[test]
    fn error_dynamics_match_finite_differences() {
        let model = nps();
        let nu = Nu::from_column_slice(&[1.4, 0.05, -0.03, 0.01, -0.02, 0.03]);
        let at = Attitude {
            roll_rad: 0.1,
            pitch_rad: -0.2,
            earth_rate_body: Vector3::new(5e-5, 1e-5, -3e-5),
        };
        let act = Actuation {
            rudder_rad: 0.1,
            stern_rad: -0.05,
            bow_rad: 0.02,
            propeller_rad_s: 150.0,
        };
        let a = error_dynamics(&model, &nu, &at, &act);
        let rate = |x: &SVector<f64, 7>| {
            let n = Nu::from_iterator(x.iter().skip(1).copied());
            let v = n.fixed_rows::<3>(0).into_owned();
            let mut out = SVector::<f64, 7>::zeros();
            out[0] = depth_rate_gradient(at.roll_rad, at.pitch_rad).dot(&v);
            out.fixed_rows_mut::<6>(1)
                .copy_from(&model.acceleration(&n, &at, &act));
            out
        };
        let mut x = SVector::<f64, 7>::zeros();
        x[0] = 20.0;
        x.fixed_rows_mut::<6>(1).copy_from(&nu);
        for j in 0..STATES {
            let h = 1e-6;
            let mut up = x;
            let mut down = x;
            up[j] += h;
            down[j] -= h;
            let fd = (rate(&up) - rate(&down)) / (2.0 * h);
            for i in 0..STATES {
                let tol = 1e-6 * (1.0 + fd[i].abs());
                assert!(
                    (a[(i, j)] - fd[i]).abs() < tol,
                    "A[{i},{j}] = {} against {} by differences",
                    a[(i, j)],
                    fd[i]
                );
            }
        }
    }
}
