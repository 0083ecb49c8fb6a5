//! A plausible (not physically exact) survey log for tests, benchmarks and `sample-logs/`.
//!
//! The vehicle cruises at constant speed with slowly weaving heading, depth and attitude; every
//! contract stream is written at its usual rate with seeded white noise. The IMU here is a
//! simple kinematic approximation (no Earth rate, no transport rate): logs for exact inertial
//! work come from the mission simulator, not from this module.

use super::writer::{LogWriter, WriteError};
use crate::angle::wrap_pi;
use crate::contract::*;
use crate::ingest::Mission;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use std::f64::consts::TAU;
use std::io::{Seek, Write};

crate::config::with_defaults! {
    /// What to generate.
    #[derive(Debug, Clone, PartialEq)]
    pub struct SurveySpec {
        pub duration_s: f64 = 60.0,
        pub seed: u64 = 1,
        /// Stamp of the first IMU sample.
        pub start_stamp_ns: i64 = 1_700_000_000_000_000_000,
        /// IMU rate; other streams run at fixed divisions of it.
        pub imu_rate_hz: u32 = 100,
        /// Write `/truth` (10 Hz).
        pub truth: bool = true,
    }
}

/// Rates in Hz of the other streams (each must divide the IMU rate).
const MAG_HZ: u32 = 50;
const DVL_HZ: u32 = 5;
const EML_HZ: u32 = 2;
const DEPTH_HZ: u32 = 2;
const ALTIMETER_HZ: u32 = 2;
const RPM_HZ: u32 = 1;
const FINS_HZ: u32 = 10;
const ATTITUDE_HZ: u32 = 10;
const TRUTH_HZ: u32 = 10;
const SPEED_M_S: f64 = 1.5;
const GRAVITY_M_S2: f64 = 9.81;
const SEABED_M: f64 = 60.0;

/// Vehicle state at time `t` seconds.
struct Kinematics {
    roll: f64,
    pitch: f64,
    yaw: f64,
    rates: [f64; 3],
    depth: f64,
    heave_m_s: f64,
}

fn kinematics(t: f64) -> Kinematics {
    let w = |period: f64| TAU / period;
    let (ar, ap, ay, ad) = (0.03, 0.04, 0.6, 8.0);
    let (wr, wp, wy, wd) = (w(25.0), w(140.0), w(400.0), w(900.0));
    Kinematics {
        roll: ar * (wr * t).sin(),
        pitch: ap * (wp * t).sin(),
        yaw: 0.3 + ay * (wy * t).sin(),
        rates: [
            ar * wr * (wr * t).cos(),
            ap * wp * (wp * t).cos(),
            ay * wy * (wy * t).cos(),
        ],
        depth: 20.0 - ad * (wd * t).cos(),
        heave_m_s: ad * wd * (wd * t).sin(),
    }
}

/// The white noise of each stream, drawn from one generator in the log's order.
struct Noise {
    rng: ChaCha8Rng,
    gyro: Normal<f64>,
    acc: Normal<f64>,
    mag: Normal<f64>,
    dvl: Normal<f64>,
    depth: Normal<f64>,
    speed: Normal<f64>,
}

impl Noise {
    fn new(seed: u64) -> Self {
        let noise = |sigma: f64| Normal::new(0.0, sigma).expect("sigma is a positive constant");
        Noise {
            rng: ChaCha8Rng::seed_from_u64(seed),
            gyro: noise(1e-3),
            acc: noise(2e-2),
            mag: noise(2e-7),
            dvl: noise(5e-3),
            depth: noise(2e-2),
            speed: noise(2e-2),
        }
    }

    fn draw(&mut self, d: Normal<f64>) -> f64 {
        d.sample(&mut self.rng)
    }

    fn draw3(&mut self, d: Normal<f64>) -> [f64; 3] {
        [self.draw(d), self.draw(d), self.draw(d)]
    }
}

/// One IMU tick of the survey.
struct SurveyTick {
    k: i64,
    t: f64,
    stamp_ns: i64,
    kin: Kinematics,
    /// Metres from the origin.
    north: f64,
    east: f64,
}

impl SurveyTick {
    fn log_ns(&self, latency_ms: i64) -> u64 {
        (self.stamp_ns + latency_ms * 1_000_000) as u64
    }

    fn v_ned(&self) -> [f64; 3] {
        let k = &self.kin;
        [
            SPEED_M_S * k.yaw.cos(),
            SPEED_M_S * k.yaw.sin(),
            k.heave_m_s,
        ]
    }

    /// Latitude and longitude, degrees, of the tick's place.
    fn lat_lon_deg(&self, mission: &Mission) -> (f64, f64) {
        let m_per_deg_lat = 111_000.0;
        let m_per_deg_lon = m_per_deg_lat * mission.origin_latitude_deg.to_radians().cos();
        (
            mission.origin_latitude_deg + self.north / m_per_deg_lat,
            mission.origin_longitude_deg + self.east / m_per_deg_lon,
        )
    }
}

fn survey_mission(spec: &SurveySpec) -> Mission {
    Mission {
        origin_latitude_deg: 35.1,
        origin_longitude_deg: 129.05,
        vehicle: "nps-auv-ii".into(),
        description: format!(
            "synthetic survey, {} s, seed {}",
            spec.duration_s, spec.seed
        ),
        initial_yaw_rad: None,
        magnetic_declination_deg: None,
    }
}

/// Writes the survey.
pub fn write_survey<W: Write + Seek>(
    w: &mut LogWriter<W>,
    spec: &SurveySpec,
) -> Result<(), WriteError> {
    let mut noise = Noise::new(spec.seed);
    let mission = survey_mission(spec);
    w.write_mission(&mission)?;
    let rate = spec.imu_rate_hz.max(100);
    let period_ns = 1_000_000_000 / i64::from(rate);
    let ticks = (spec.duration_s * f64::from(rate)).round() as i64;
    let dt = 1.0 / f64::from(rate);
    let (mut north, mut east) = (0.0f64, 0.0f64);
    for k in 0..=ticks {
        let t = k as f64 * dt;
        let tick = SurveyTick {
            k,
            t,
            stamp_ns: spec.start_stamp_ns + k * period_ns,
            kin: kinematics(t),
            north,
            east,
        };
        write_imu(w, &tick, &mut noise)?;
        write_aiding(w, spec, &tick, rate, &mut noise)?;
        write_vehicle(w, &tick, rate)?;
        write_references(w, spec, &tick, (rate, ticks), &mission)?;
        let v_ned = tick.v_ned();
        north += v_ned[0] * dt;
        east += v_ned[1] * dt;
    }
    Ok(())
}

fn write_imu<W: Write + Seek>(
    w: &mut LogWriter<W>,
    tick: &SurveyTick,
    noise: &mut Noise,
) -> Result<(), WriteError> {
    let kin = &tick.kin;
    let (sr, cr) = kin.roll.sin_cos();
    let (sp, cp) = kin.pitch.sin_cos();
    // Gravity in the body frame: C_n^b [0, 0, g]; specific force is its negative at rest.
    let g_body = [
        -sp * GRAVITY_M_S2,
        sr * cp * GRAVITY_M_S2,
        cr * cp * GRAVITY_M_S2,
    ];
    let gyro_noise = noise.draw3(noise.gyro);
    let acc_noise = noise.draw3(noise.acc);
    let imu = Imu {
        stamp_ns: tick.stamp_ns,
        angular_velocity: std::array::from_fn(|i| kin.rates[i] + gyro_noise[i]),
        specific_force: std::array::from_fn(|i| -g_body[i] + acc_noise[i]),
    };
    w.write("/imu", &imu, tick.log_ns(1))
}

/// The aiding sensors' readings due at the tick: magnetometer, DVL, EM log, depth,
/// altimeter, propeller.
fn write_aiding<W: Write + Seek>(
    w: &mut LogWriter<W>,
    spec: &SurveySpec,
    tick: &SurveyTick,
    rate: u32,
    noise: &mut Noise,
) -> Result<(), WriteError> {
    let (kin, stamp_ns, k) = (&tick.kin, tick.stamp_ns, tick.k);
    let due = |hz: u32| k % i64::from(rate / hz) == 0;
    if due(MAG_HZ) {
        // Earth field about 50 uT, dipping 50 deg, seen in the body (heading only).
        let (h, z) = (3.2e-5, 3.8e-5);
        let n = noise.draw3(noise.mag);
        let magnetic_field = [
            h * kin.yaw.cos() + n[0],
            -h * kin.yaw.sin() + n[1],
            z + n[2],
        ];
        let m = MagneticField {
            stamp_ns,
            magnetic_field,
        };
        w.write("/mag", &m, tick.log_ns(1))?;
    }
    if due(DVL_HZ) {
        // DVL loses bottom lock over the middle tenth of the run.
        let locked = !(0.45 * spec.duration_s..0.55 * spec.duration_s).contains(&tick.t);
        let n = noise.draw3(noise.dvl);
        let dvl = Dvl {
            stamp_ns,
            velocity: if locked {
                [SPEED_M_S + n[0], n[1], n[2]]
            } else {
                [0.0; 3]
            },
            valid: locked,
            altitude: locked.then_some(SEABED_M - kin.depth),
        };
        w.write("/dvl", &dvl, tick.log_ns(50))?;
    }
    if due(EML_HZ) {
        let speed = (SPEED_M_S + 0.1 + noise.draw(noise.speed)).max(0.0);
        w.write("/eml", &SpeedLog { stamp_ns, speed }, tick.log_ns(5))?;
    }
    if due(DEPTH_HZ) {
        let depth = kin.depth + noise.draw(noise.depth);
        w.write("/depth", &Depth { stamp_ns, depth }, tick.log_ns(5))?;
    }
    if due(ALTIMETER_HZ) {
        let altitude = SEABED_M - kin.depth + noise.draw(noise.depth);
        w.write(
            "/altimeter",
            &Altimeter { stamp_ns, altitude },
            tick.log_ns(20),
        )?;
    }
    if due(RPM_HZ) {
        let rpm = 1200.0 + 5.0 * noise.draw(noise.speed);
        w.write("/rpm", &Propeller { stamp_ns, rpm }, tick.log_ns(2))?;
    }
    Ok(())
}

/// The vehicle's own records due at the tick: fins and attitude.
fn write_vehicle<W: Write + Seek>(
    w: &mut LogWriter<W>,
    tick: &SurveyTick,
    rate: u32,
) -> Result<(), WriteError> {
    let (kin, stamp_ns) = (&tick.kin, tick.stamp_ns);
    let due = |hz: u32| tick.k % i64::from(rate / hz) == 0;
    if due(FINS_HZ) {
        let fins = ControlSurfaces {
            stamp_ns,
            rudder: -0.5 * kin.rates[2],
            bow_plane: 0.0,
            stern_plane: -2.0 * kin.rates[1],
        };
        w.write("/fins", &fins, tick.log_ns(2))?;
    }
    if due(ATTITUDE_HZ) {
        let att = Attitude {
            stamp_ns,
            roll: kin.roll,
            pitch: kin.pitch,
            yaw: wrap_pi(kin.yaw),
        };
        w.write("/attitude", &att, tick.log_ns(3))?;
    }
    Ok(())
}

/// The surfaced fixes at the start and the end, and the truth.
fn write_references<W: Write + Seek>(
    w: &mut LogWriter<W>,
    spec: &SurveySpec,
    tick: &SurveyTick,
    (rate, ticks): (u32, i64),
    mission: &Mission,
) -> Result<(), WriteError> {
    let stamp_ns = tick.stamp_ns;
    let (latitude_deg, longitude_deg) = tick.lat_lon_deg(mission);
    let label = match tick.k {
        0 => Some("start"),
        k if k == ticks => Some("end"),
        _ => None,
    };
    if let Some(label) = label {
        let gnss = GnssFix {
            stamp_ns,
            latitude_deg,
            longitude_deg,
            horizontal_sigma_m: 2.5,
        };
        w.write("/gnss", &gnss, tick.log_ns(100))?;
        let fix = PositionFix {
            stamp_ns,
            north_m: tick.north,
            east_m: tick.east,
            down_m: None,
            sigma_m: 0.5,
            label: label.into(),
        };
        w.write("/position_fix", &fix, tick.log_ns(100))?;
    }
    if spec.truth && tick.k % i64::from(rate / TRUTH_HZ) == 0 {
        let kin = &tick.kin;
        let truth = Truth {
            stamp_ns,
            latitude_deg,
            longitude_deg,
            north_m: tick.north,
            east_m: tick.east,
            down_m: kin.depth,
            velocity_body: [SPEED_M_S, 0.0, 0.0],
            velocity_ned: tick.v_ned(),
            attitude: [kin.roll, kin.pitch, wrap_pi(kin.yaw)],
            angular_velocity: kin.rates,
        };
        w.write("/truth", &truth, tick.log_ns(0))?;
    }
    Ok(())
}
