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

/// What to generate.
#[derive(Debug, Clone, PartialEq)]
pub struct SurveySpec {
    pub duration_s: f64,
    pub seed: u64,
    /// Stamp of the first IMU sample.
    pub start_stamp_ns: i64,
    /// IMU rate; other streams run at fixed divisions of it.
    pub imu_rate_hz: u32,
    /// Write `/truth` (10 Hz).
    pub truth: bool,
}

impl Default for SurveySpec {
    fn default() -> Self {
        SurveySpec {
            duration_s: 60.0,
            seed: 1,
            start_stamp_ns: 1_700_000_000_000_000_000,
            imu_rate_hz: 100,
            truth: true,
        }
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

/// Writes the survey; returns the number of messages written.
pub fn write_survey<W: Write + Seek>(
    w: &mut LogWriter<W>,
    spec: &SurveySpec,
) -> Result<u64, WriteError> {
    let mut rng = ChaCha8Rng::seed_from_u64(spec.seed);
    let noise = |sigma: f64| Normal::new(0.0, sigma).expect("sigma is a positive constant");
    let (gyro_n, acc_n, mag_n) = (noise(1e-3), noise(2e-2), noise(2e-7));
    let (dvl_n, depth_n, speed_n) = (noise(5e-3), noise(2e-2), noise(2e-2));

    let mission = Mission {
        origin_latitude_deg: 35.1,
        origin_longitude_deg: 129.05,
        vehicle: "nps-auv-ii".into(),
        description: format!(
            "synthetic survey, {} s, seed {}",
            spec.duration_s, spec.seed
        ),
        initial_yaw_rad: None,
        magnetic_declination_deg: None,
    };
    w.write_mission(&mission)?;

    let rate = spec.imu_rate_hz.max(100);
    let period_ns = 1_000_000_000 / i64::from(rate);
    let ticks = (spec.duration_s * f64::from(rate)).round() as i64;
    let every = |hz: u32| i64::from(rate / hz);
    let (mut north, mut east) = (0.0f64, 0.0f64);
    let dt = 1.0 / f64::from(rate);
    let mut count = 0u64;
    // DVL loses bottom lock over the middle tenth of the run.
    let lock_lost = (0.45 * spec.duration_s, 0.55 * spec.duration_s);
    let m_per_deg_lat = 111_000.0;
    let m_per_deg_lon = m_per_deg_lat * mission.origin_latitude_deg.to_radians().cos();

    for k in 0..=ticks {
        let t = k as f64 * dt;
        let stamp_ns = spec.start_stamp_ns + k * period_ns;
        let log_ns = |latency_ms: i64| (stamp_ns + latency_ms * 1_000_000) as u64;
        let kin = kinematics(t);
        let (sr, cr) = kin.roll.sin_cos();
        let (sp, cp) = kin.pitch.sin_cos();
        let v_ned = [
            SPEED_M_S * kin.yaw.cos(),
            SPEED_M_S * kin.yaw.sin(),
            kin.heave_m_s,
        ];
        // Gravity in the body frame: C_n^b [0, 0, g]; specific force is its negative at rest.
        let g_body = [
            -sp * GRAVITY_M_S2,
            sr * cp * GRAVITY_M_S2,
            cr * cp * GRAVITY_M_S2,
        ];
        let mut draw3 =
            |d: &Normal<f64>| [d.sample(&mut rng), d.sample(&mut rng), d.sample(&mut rng)];

        let gyro_noise = draw3(&gyro_n);
        let acc_noise = draw3(&acc_n);
        let imu = Imu {
            stamp_ns,
            angular_velocity: std::array::from_fn(|i| kin.rates[i] + gyro_noise[i]),
            specific_force: std::array::from_fn(|i| -g_body[i] + acc_noise[i]),
        };
        w.write("/imu", &imu, log_ns(1))?;
        count += 1;

        if k % every(MAG_HZ) == 0 {
            // Earth field about 50 uT, dipping 50 deg, seen in the body (heading only).
            let (h, z) = (3.2e-5, 3.8e-5);
            let n = draw3(&mag_n);
            let m = MagneticField {
                stamp_ns,
                magnetic_field: [
                    h * kin.yaw.cos() + n[0],
                    -h * kin.yaw.sin() + n[1],
                    z + n[2],
                ],
            };
            w.write("/mag", &m, log_ns(1))?;
            count += 1;
        }
        if k % every(DVL_HZ) == 0 {
            let locked = !(lock_lost.0..lock_lost.1).contains(&t);
            let n = draw3(&dvl_n);
            let altitude = SEABED_M - kin.depth;
            let dvl = Dvl {
                stamp_ns,
                velocity: if locked {
                    [SPEED_M_S + n[0], n[1], n[2]]
                } else {
                    [0.0; 3]
                },
                valid: locked,
                altitude: locked.then_some(altitude),
            };
            w.write("/dvl", &dvl, log_ns(50))?;
            count += 1;
        }
        if k % every(EML_HZ) == 0 {
            let speed = (SPEED_M_S + 0.1 + speed_n.sample(&mut rng)).max(0.0);
            w.write("/eml", &SpeedLog { stamp_ns, speed }, log_ns(5))?;
            count += 1;
        }
        if k % every(DEPTH_HZ) == 0 {
            let depth = kin.depth + depth_n.sample(&mut rng);
            w.write("/depth", &Depth { stamp_ns, depth }, log_ns(5))?;
            count += 1;
        }
        if k % every(ALTIMETER_HZ) == 0 {
            let altitude = SEABED_M - kin.depth + depth_n.sample(&mut rng);
            w.write("/altimeter", &Altimeter { stamp_ns, altitude }, log_ns(20))?;
            count += 1;
        }
        if k % every(RPM_HZ) == 0 {
            let rpm = 1200.0 + 5.0 * speed_n.sample(&mut rng);
            w.write("/rpm", &Propeller { stamp_ns, rpm }, log_ns(2))?;
            count += 1;
        }
        if k % every(FINS_HZ) == 0 {
            let fins = ControlSurfaces {
                stamp_ns,
                rudder: -0.5 * kin.rates[2],
                bow_plane: 0.0,
                stern_plane: -2.0 * kin.rates[1],
            };
            w.write("/fins", &fins, log_ns(2))?;
            count += 1;
        }
        if k % every(ATTITUDE_HZ) == 0 {
            let att = Attitude {
                stamp_ns,
                roll: kin.roll,
                pitch: kin.pitch,
                yaw: wrap_pi(kin.yaw),
            };
            w.write("/attitude", &att, log_ns(3))?;
            count += 1;
        }
        let surfaced_fix = |w: &mut LogWriter<W>, label: &str| -> Result<u64, WriteError> {
            let lat = mission.origin_latitude_deg + north / m_per_deg_lat;
            let lon = mission.origin_longitude_deg + east / m_per_deg_lon;
            w.write(
                "/gnss",
                &GnssFix {
                    stamp_ns,
                    latitude_deg: lat,
                    longitude_deg: lon,
                    horizontal_sigma_m: 2.5,
                },
                log_ns(100),
            )?;
            let fix = PositionFix {
                stamp_ns,
                north_m: north,
                east_m: east,
                down_m: None,
                sigma_m: 0.5,
                label: label.into(),
            };
            w.write("/position_fix", &fix, log_ns(100))?;
            Ok(2)
        };
        if k == 0 {
            count += surfaced_fix(w, "start")?;
        } else if k == ticks {
            count += surfaced_fix(w, "end")?;
        }
        if spec.truth && k % every(TRUTH_HZ) == 0 {
            let truth = Truth {
                stamp_ns,
                latitude_deg: mission.origin_latitude_deg + north / m_per_deg_lat,
                longitude_deg: mission.origin_longitude_deg + east / m_per_deg_lon,
                north_m: north,
                east_m: east,
                down_m: kin.depth,
                velocity_body: [SPEED_M_S, 0.0, 0.0],
                velocity_ned: v_ned,
                attitude: [kin.roll, kin.pitch, wrap_pi(kin.yaw)],
                angular_velocity: kin.rates,
            };
            w.write("/truth", &truth, log_ns(0))?;
            count += 1;
        }
        north += v_ned[0] * dt;
        east += v_ned[1] * dt;
    }
    Ok(count)
}
