//! Seed 004's vertical zig-zags flown by the heave-pitch model
//! ([`crate::vehicle::heave_pitch`]), written as a log with the contents the spec lists:
//! `/fins` (achieved stern plane), `/imu` (q on y; specific force from the motion; no Earth
//! rate: the model's world is flat and non-rotating, g = 9.8), `/attitude` (pitch),
//! `/dvl` (body velocity `[U, 0, w]`), `/depth`, `/truth`, and a `mission` record whose
//! `vehicle` names the model. The true coefficients and constants go in a separate metadata
//! record, `heave_pitch_truth`, which `identify` never reads.
//!
//! Zig-zag "a-b": the plane starts at +a deg (nose down, M_delta being negative) and reverses
//! to -a once theta passes -b, to +a once theta passes +b again, moving at a finite rate.

use super::sensors::{normal, rng_for, stream};
use super::writer::{LogWriter, WriteError};
use crate::contract::*;
use crate::ingest::Mission;
use crate::vehicle::heave_pitch::{
    Coefficients, Constants, HeavePitch, State, INITIAL_STATE, NAMES, TRUE_COEFFICIENTS,
};
use std::collections::BTreeMap;
use std::io::{Seek, Write};

/// A zig-zag run and its sensors.
#[derive(Debug, Clone, PartialEq)]
pub struct ZigzagSpec {
    pub name: String,
    /// Plane deflection a, deg.
    pub plane_deg: f64,
    /// Pitch that triggers a reversal, b, deg.
    pub trigger_deg: f64,
    pub duration_s: f64,
    pub plane_rate_deg_s: f64,
    /// Integration step, s (RK4).
    pub step_s: f64,
    pub coefficients: Coefficients,
    pub constants: Constants,
    pub initial_state: State,
    pub noise: ZigzagNoise,
}

/// Sensor noise (1 sigma, white) and rates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ZigzagNoise {
    /// IMU and attitude rate, Hz.
    pub imu_rate_hz: f64,
    pub gyro_deg_s: f64,
    pub accel_m_s2: f64,
    pub pitch_deg: f64,
    pub dvl_rate_hz: f64,
    pub dvl_m_s: f64,
    pub depth_rate_hz: f64,
    pub depth_m: f64,
}

impl ZigzagNoise {
    /// The realistic sensors: DVL w 0.003 m/s at 5 Hz, pitch 0.02 deg and gyro
    /// 0.01 deg/s at 100 Hz; depth 0.01 m at 10 Hz, accelerometer 0.01 m/s^2.
    pub fn realistic() -> Self {
        ZigzagNoise {
            imu_rate_hz: 100.0,
            gyro_deg_s: 0.01,
            accel_m_s2: 0.01,
            pitch_deg: 0.02,
            dvl_rate_hz: 5.0,
            dvl_m_s: 0.003,
            depth_rate_hz: 10.0,
            depth_m: 0.01,
        }
    }

    /// The same rates, no noise.
    pub fn none() -> Self {
        ZigzagNoise {
            gyro_deg_s: 0.0,
            accel_m_s2: 0.0,
            pitch_deg: 0.0,
            dvl_m_s: 0.0,
            depth_m: 0.0,
            ..Self::realistic()
        }
    }
}

/// The built-in zig-zag scenarios.
pub const BUILT_IN: [&str; 2] = ["zigzag-5-5", "zigzag-10-5"];

impl ZigzagSpec {
    /// `zigzag-5-5` or `zigzag-10-5` (seed 004's runs), or any `zigzag-A-B` with A and B
    /// positive numbers of degrees: 200 s, realistic sensors, the published coefficients.
    pub fn built_in(name: &str) -> Option<ZigzagSpec> {
        let (plane, trigger) = name.strip_prefix("zigzag-")?.split_once('-')?;
        let degrees = |s: &str| s.parse::<f64>().ok().filter(|v| v.is_finite() && *v > 0.0);
        let (plane_deg, trigger_deg) = (degrees(plane)?, degrees(trigger)?);
        Some(ZigzagSpec {
            name: name.to_string(),
            plane_deg,
            trigger_deg,
            duration_s: 200.0,
            plane_rate_deg_s: 10.0,
            step_s: 1e-3,
            coefficients: Coefficients::from(TRUE_COEFFICIENTS),
            constants: Constants::default(),
            initial_state: State::from(INITIAL_STATE),
            noise: ZigzagNoise::realistic(),
        })
    }

    pub fn description(&self) -> String {
        let k = &self.constants;
        let mut s = format!(
            "vertical zig-zag {}-{} of seed 004's heave-pitch model, {} s at {} m/s",
            self.plane_deg, self.trigger_deg, self.duration_s, k.speed_m_s
        );
        if k.weight_minus_buoyancy_n != 0.0 {
            s += &format!(", weight minus buoyancy {} N", k.weight_minus_buoyancy_n);
        }
        s
    }
}

/// What a run did.
#[derive(Debug, Clone, PartialEq)]
pub struct ZigzagRun {
    /// Times of the plane reversals, s.
    pub reversals_s: Vec<f64>,
    pub messages: u64,
}

const START_STAMP_NS: i64 = 1_700_000_000_000_000_000;
/// Stream of the attitude sensor's noise (the others use the shared streams).
const PITCH_STREAM: u64 = stream::AHRS;

/// The truth at every IMU sample: stamp offset (s), state, plane angle, accelerations.
pub struct TruthSample {
    pub t_s: f64,
    pub state: State,
    pub plane_rad: f64,
    pub derivative: State,
}

/// Flies the zig-zag: the truth at every `1 / imu_rate_hz`, and the reversal times.
pub fn fly(spec: &ZigzagSpec) -> (Vec<TruthSample>, Vec<f64>) {
    let model = HeavePitch::new(spec.constants);
    let (a, b) = (spec.plane_deg.to_radians(), spec.trigger_deg.to_radians());
    let rate = spec.plane_rate_deg_s.to_radians();
    let steps_per_sample = (1.0 / (spec.noise.imu_rate_hz * spec.step_s))
        .round()
        .max(1.0) as usize;
    let dt = 1.0 / (spec.noise.imu_rate_hz * steps_per_sample as f64);
    let samples = (spec.duration_s * spec.noise.imu_rate_hz).round() as usize;
    let (mut x, mut plane, mut command) = (spec.initial_state, a, a);
    let mut reversals = Vec::new();
    let mut out = Vec::with_capacity(samples + 1);
    for k in 0..=samples {
        let t = k as f64 / spec.noise.imu_rate_hz;
        out.push(TruthSample {
            t_s: t,
            state: x,
            plane_rad: plane,
            derivative: model.derivative(&x, plane, &spec.coefficients),
        });
        if k == samples {
            break;
        }
        for s in 0..steps_per_sample {
            // Reverse once theta is b past zero in the direction the plane drives it.
            if command > 0.0 && x[1] < -b || command < 0.0 && x[1] > b {
                command = -command;
                reversals.push(t + s as f64 * dt);
            }
            // The plane moves toward the command at the rate limit, linearly over the step.
            let next = plane + (command - plane).clamp(-rate * dt, rate * dt);
            x = model.rk4_varying(&x, plane, next, &spec.coefficients, dt);
            plane = next;
        }
    }
    (out, reversals)
}

/// Simulates the run into `w` with `seed` for the sensor noise.
pub fn run<W: Write + Seek>(
    spec: &ZigzagSpec,
    seed: u64,
    w: &mut LogWriter<W>,
) -> Result<ZigzagRun, WriteError> {
    let (truth, reversals_s) = fly(spec);
    write_records(spec, seed, w)?;
    let mut sensors = Sensors::new(spec, seed);
    let written_before = w.messages();
    for (i, s) in truth.iter().enumerate() {
        sensors.write(spec, i, s, w)?;
    }
    Ok(ZigzagRun {
        reversals_s,
        messages: w.messages() - written_before,
    })
}

/// The mission record, and the true coefficients as metadata (for scoring only).
fn write_records<W: Write + Seek>(
    spec: &ZigzagSpec,
    seed: u64,
    w: &mut LogWriter<W>,
) -> Result<(), WriteError> {
    w.write_mission(&Mission {
        origin_latitude_deg: 0.0,
        origin_longitude_deg: 0.0,
        vehicle: "heave-pitch (seed 004)".to_string(),
        description: format!(
            "simulated `{}` (seed {seed}): {}",
            spec.name,
            spec.description()
        ),
        initial_yaw_rad: Some(0.0),
        magnetic_declination_deg: None,
    })?;
    let mut record: BTreeMap<String, String> = NAMES
        .iter()
        .zip(spec.coefficients.iter())
        .map(|(n, v)| (n.to_string(), format!("{v:e}")))
        .collect();
    record.insert(
        "constants".to_string(),
        serde_json::to_string(&spec.constants).unwrap_or_default(),
    );
    record.insert(
        "note".to_string(),
        "the true coefficients of this simulated log: for scoring, never read by identify"
            .to_string(),
    );
    w.write_metadata("heave_pitch_truth", record)
}

/// The sensors' random streams and rates.
struct Sensors {
    gyro: rand_chacha::ChaCha8Rng,
    accel: rand_chacha::ChaCha8Rng,
    pitch: rand_chacha::ChaCha8Rng,
    dvl: rand_chacha::ChaCha8Rng,
    depth: rand_chacha::ChaCha8Rng,
    /// Truth samples between DVL readings, and between depth readings.
    dvl_every: usize,
    depth_every: usize,
}

impl Sensors {
    fn new(spec: &ZigzagSpec, seed: u64) -> Self {
        let n = &spec.noise;
        let every = |rate: f64| ((n.imu_rate_hz / rate).round() as usize).max(1);
        Sensors {
            gyro: rng_for(seed, stream::GYRO),
            accel: rng_for(seed, stream::ACCEL),
            pitch: rng_for(seed, PITCH_STREAM),
            dvl: rng_for(seed, stream::DVL),
            depth: rng_for(seed, stream::DEPTH),
            dvl_every: every(n.dvl_rate_hz),
            depth_every: every(n.depth_rate_hz),
        }
    }

    /// The readings of truth sample `i`.
    fn write<W: Write + Seek>(
        &mut self,
        spec: &ZigzagSpec,
        i: usize,
        s: &TruthSample,
        w: &mut LogWriter<W>,
    ) -> Result<(), WriteError> {
        let (n, k) = (&spec.noise, &spec.constants);
        let stamp_ns = START_STAMP_NS + (s.t_s * 1e9).round() as i64;
        let log_ns = stamp_ns as u64;
        let (w_m_s, theta, z) = (s.state[0], s.state[1], s.state[3]);
        let u = k.speed_m_s;
        w.write("/imu", &self.imu(spec, s, stamp_ns), log_ns)?;
        let fins = ControlSurfaces {
            stamp_ns,
            rudder: 0.0,
            bow_plane: 0.0,
            stern_plane: s.plane_rad,
        };
        w.write("/fins", &fins, log_ns)?;
        let attitude = Attitude {
            stamp_ns,
            roll: 0.0,
            pitch: theta + n.pitch_deg.to_radians() * normal(&mut self.pitch),
            yaw: 0.0,
        };
        w.write("/attitude", &attitude, log_ns)?;
        if i.is_multiple_of(self.dvl_every) {
            let mut noise = || n.dvl_m_s * normal(&mut self.dvl);
            let velocity = [u + noise(), noise(), w_m_s + noise()];
            let dvl = Dvl {
                stamp_ns,
                velocity,
                valid: true,
                altitude: Some(50.0),
            };
            w.write("/dvl", &dvl, log_ns)?;
        }
        if i.is_multiple_of(self.depth_every) {
            let depth = z + n.depth_m * normal(&mut self.depth);
            w.write("/depth", &Depth { stamp_ns, depth }, log_ns)?;
        }
        w.write("/truth", &truth_of(spec, s, stamp_ns), log_ns)
    }

    fn imu(&mut self, spec: &ZigzagSpec, s: &TruthSample, stamp_ns: i64) -> Imu {
        let (n, k) = (&spec.noise, &spec.constants);
        let (w_m_s, theta, q) = (s.state[0], s.state[1], s.state[2]);
        let g = k.gravity_m_s2;
        // Specific force in the body: acceleration of the origin (u constant) less gravity.
        let f = [
            q * w_m_s + g * theta.sin(),
            0.0,
            s.derivative[0] - q * k.speed_m_s - g * theta.cos(),
        ];
        let gyro_sigma = n.gyro_deg_s.to_radians();
        let mut gyro = || gyro_sigma * normal(&mut self.gyro);
        let angular_velocity = [gyro(), q + gyro(), gyro()];
        let mut accel = || n.accel_m_s2 * normal(&mut self.accel);
        let specific_force = [f[0] + accel(), f[1] + accel(), f[2] + accel()];
        Imu {
            stamp_ns,
            angular_velocity,
            specific_force,
        }
    }
}

/// The truth of a sample: flat world, heading north; position integrated from the body
/// velocity.
fn truth_of(spec: &ZigzagSpec, s: &TruthSample, stamp_ns: i64) -> Truth {
    let u = spec.constants.speed_m_s;
    let (w_m_s, theta, q, z) = (s.state[0], s.state[1], s.state[2], s.state[3]);
    let (st, ct) = theta.sin_cos();
    Truth {
        stamp_ns,
        latitude_deg: 0.0,
        longitude_deg: 0.0,
        north_m: u * s.t_s, // along-track distance (approximate: level)
        east_m: 0.0,
        down_m: z,
        velocity_body: [u, 0.0, w_m_s],
        velocity_ned: [u * ct + w_m_s * st, 0.0, -u * st + w_m_s * ct],
        attitude: [0.0, theta, 0.0],
        angular_velocity: [0.0, q, 0.0],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The spec: with this model the 5-5 run reverses twice and the 10-5 run three times.
    #[test]
    fn reversals_as_the_spec_says() {
        for (name, count) in [("zigzag-5-5", 2), ("zigzag-10-5", 3)] {
            let spec = ZigzagSpec::built_in(name).unwrap();
            let (truth, reversals) = fly(&spec);
            assert_eq!(reversals.len(), count, "{name}: {reversals:?}");
            assert_eq!(truth.len(), 20_001);
        }
    }

    /// The 1 ms RK4 step agrees with seed 004's 0.1 ms to a tenth of the sensor noise.
    #[test]
    fn step_size_is_converged() {
        let coarse = ZigzagSpec::built_in("zigzag-10-5").unwrap();
        let fine = ZigzagSpec {
            step_s: 1e-4,
            ..coarse.clone()
        };
        let (a, _) = fly(&coarse);
        let (b, _) = fly(&fine);
        // Against the realistic noise of each channel: w, theta, q, depth.
        let n = ZigzagNoise::realistic();
        let sigma = State::new(
            n.dvl_m_s,
            n.pitch_deg.to_radians(),
            n.gyro_deg_s.to_radians(),
            n.depth_m,
        );
        let worst = a
            .iter()
            .zip(&b)
            .map(|(x, y)| (x.state - y.state).abs().component_div(&sigma).max())
            .fold(0.0, f64::max);
        assert!(worst < 0.1, "{worst} sigma");
    }
}
