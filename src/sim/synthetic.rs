//! A plausible (not physically exact) survey log for tests, benchmarks and `sample-logs/`.
//!
//! The vehicle cruises at constant speed with slowly weaving heading, depth and attitude; every
//! contract stream is written at its usual rate with seeded white noise (the acoustic
//! additions exact, at 1 Hz). The IMU here is a
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
const ACOUSTIC_HZ: u32 = 1;
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
        if tick.k % i64::from(rate / ACOUSTIC_HZ) == 0 {
            write_acoustic(w, &tick, &mission)?;
        }
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

/// The ship's mean heading, rad, and an LBL beacon's place (north, east, down, m).
const SHIP_YAW_RAD: f64 = 0.3;
const BEACON_NED_M: [f64; 3] = [200.0, -100.0, 60.0];
const SOUND_SPEED_M_S: f64 = 1500.0;

/// The acoustic positioning of the tick: a USBL observation from a ship held at the origin
/// (level, yawing 0.02 rad about [`SHIP_YAW_RAD`] over a minute) with the ship's pose, the fix positioned from it
/// (stamped on receipt, 1.5 s late), and a range to one LBL beacon. Exact, without noise.
fn write_acoustic<W: Write + Seek>(
    w: &mut LogWriter<W>,
    tick: &SurveyTick,
    mission: &Mission,
) -> Result<(), WriteError> {
    let stamp_ns = tick.stamp_ns;
    let depth_m = tick.kin.depth;
    let ship_yaw_rad = SHIP_YAW_RAD + 0.02 * (TAU * tick.t / 60.0).sin();
    let ship = ShipPose {
        stamp_ns,
        latitude_deg: mission.origin_latitude_deg,
        longitude_deg: mission.origin_longitude_deg,
        roll: 0.0,
        pitch: 0.0,
        yaw: ship_yaw_rad,
        horizontal_sigma_m: Some(1.0),
        heading_sigma_rad: Some(0.002),
    };
    w.write("/ship_pose", &ship, tick.log_ns(5))?;
    let (sin, cos) = ship_yaw_rad.sin_cos();
    let x = cos * tick.north + sin * tick.east;
    let y = -sin * tick.north + cos * tick.east;
    let usbl = UsblObservation {
        stamp_ns,
        stamp_is_validity: true,
        received_after_s: Some(1.5),
        range_m: (x * x + y * y + depth_m * depth_m).sqrt(),
        bearing_rad: y.atan2(x),
        elevation_rad: depth_m.atan2(x.hypot(y)),
        range_sigma_m: Some(0.1),
        bearing_sigma_rad: Some(0.005),
        elevation_sigma_rad: Some(0.005),
        sound_speed_m_s: Some(SOUND_SPEED_M_S),
        beacon_id: String::new(),
    };
    w.write("/usbl", &usbl, tick.log_ns(1500))?;
    let (latitude_deg, longitude_deg) = tick.lat_lon_deg(mission);
    let fix = AcousticFix {
        stamp_ns: stamp_ns + 1_500_000_000,
        stamp_is_validity: false,
        received_after_s: None,
        latitude_deg,
        longitude_deg,
        depth_m: Some(depth_m),
        horizontal_sigma_m: None,
        depth_sigma_m: Some(0.2),
        beacon_id: String::new(),
    };
    w.write("/acoustic_fix", &fix, tick.log_ns(1500))?;
    let [n, e, d] = BEACON_NED_M;
    let range_m =
        ((tick.north - n).powi(2) + (tick.east - e).powi(2) + (depth_m - d).powi(2)).sqrt();
    let two_way_s = 2.0 * range_m / SOUND_SPEED_M_S;
    let lbl = LblRange {
        stamp_ns: stamp_ns + (two_way_s * 1e9).round() as i64,
        beacon_id: "A".into(),
        two_way_travel_time_s: Some(two_way_s),
        range_m: Some(range_m),
        sound_speed_m_s: Some(SOUND_SPEED_M_S),
        range_sigma_m: Some(0.3),
    };
    w.write("/lbl", &lbl, tick.log_ns(10))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::writer::{to_bytes, WriterOptions};

    /// The USBL observation turned by the ship's heading, the LBL range and the positioned
    /// fix each give back the truth: the contract's conventions as the additions state them.
    #[test]
    fn the_acoustic_messages_agree_with_the_truth() {
        let spec = SurveySpec {
            duration_s: 30.0,
            ..SurveySpec::default()
        };
        let bytes = to_bytes(WriterOptions::default(), |w| write_survey(w, &spec)).unwrap();
        let log = crate::ingest::read_log_from(&bytes[..], &Default::default()).unwrap();
        let truth = |stamp_ns: i64| {
            let all = log.messages::<Truth>("/truth").unwrap();
            all.iter().find(|t| t.stamp_ns == stamp_ns).unwrap().clone()
        };
        let ships = log.messages::<ShipPose>("/ship_pose").unwrap();
        let observations = log.messages::<UsblObservation>("/usbl").unwrap();
        assert_eq!(observations.len(), 31);
        for (u, ship) in observations.iter().zip(ships) {
            let t = truth(u.stamp_ns);
            let (b, e) = (u.bearing_rad, u.elevation_rad);
            let [x, y, z] = [e.cos() * b.cos(), e.cos() * b.sin(), e.sin()].map(|c| c * u.range_m);
            let (sin, cos) = ship.yaw.sin_cos();
            let ned = [cos * x - sin * y, sin * x + cos * y, z];
            for (got, want) in ned.iter().zip([t.north_m, t.east_m, t.down_m]) {
                assert!((got - want).abs() < 1e-9, "{ned:?} vs {t:?}");
            }
        }
        for r in log.messages::<LblRange>("/lbl").unwrap() {
            let interrogation_ns =
                r.stamp_ns - (r.two_way_travel_time_s.unwrap() * 1e9).round() as i64;
            let t = truth(interrogation_ns);
            let [n, e, d] = BEACON_NED_M;
            let range =
                ((t.north_m - n).powi(2) + (t.east_m - e).powi(2) + (t.down_m - d).powi(2)).sqrt();
            assert!((r.range_m.unwrap() - range).abs() < 1e-9);
            let from_time = r.two_way_travel_time_s.unwrap() * r.sound_speed_m_s.unwrap() / 2.0;
            assert!((from_time - range).abs() < 1e-9);
        }
        for f in log.messages::<AcousticFix>("/acoustic_fix").unwrap() {
            assert!(!f.stamp_is_validity, "stamped on receipt");
            let t = truth(f.stamp_ns - 1_500_000_000);
            assert_eq!(
                (f.latitude_deg, f.longitude_deg),
                (t.latitude_deg, t.longitude_deg)
            );
            assert_eq!(f.depth_m, Some(t.down_m));
        }
    }
}
