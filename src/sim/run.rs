//! Runs a scenario: truth at the IMU rate, every sensor on its schedule, one MCAP log.

use super::dynamic;
use super::inertial::perfect_imu;
use super::scenario::{Scenario, ScenarioError};
use super::sensors::dvl::DvlSensor;
use super::sensors::imu::Triad;
use super::sensors::mag::MagSensor;
use super::sensors::scalar::{Propeller as PropellerModel, ScalarSensor};
use super::sensors::{normal, rng_for, stream};
use super::truth::{KinematicTruth, TruthSource};
use super::vibration::RealMotion;
use super::writer::{LogWriter, WriteError};
use crate::contract::*;
use crate::geodesy;
use crate::ingest::Mission;
use std::io::{Seek, Write};

/// Error of a simulation run.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    #[error(transparent)]
    Scenario(#[from] ScenarioError),
    #[error(transparent)]
    Write(#[from] WriteError),
}

/// What a run wrote.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunSummary {
    pub messages: u64,
    pub duration_s: f64,
}

/// A sensor's sampling times: every `1/rate`, starting at 0.
struct Schedule {
    period_ns: i64,
    next_ns: i64,
}

impl Schedule {
    fn new(rate_hz: f64) -> Self {
        Self::with_phase(rate_hz, 0.0)
    }

    /// Samples due at `phase_s + k / rate_hz`.
    fn with_phase(rate_hz: f64, phase_s: f64) -> Self {
        Schedule {
            period_ns: (1e9 / rate_hz).round() as i64,
            next_ns: secs_ns(phase_s),
        }
    }

    /// The scheduled time of the sample due at tick `t_ns`, if one is.
    fn due_at(&mut self, t_ns: i64) -> Option<i64> {
        let at = self.next_ns;
        self.due(t_ns).then_some(at)
    }

    /// Whether a sample is due at `t_ns` (each IMU tick; a due sample is taken on the first
    /// tick at or after its time).
    fn due(&mut self, t_ns: i64) -> bool {
        if t_ns >= self.next_ns {
            self.next_ns += self.period_ns;
            true
        } else {
            false
        }
    }
}

/// The host's stamps of an IMU whose samples reach it in bursts: each burst arrives after a
/// random wait of 1 ms to `burst_s`, and its samples are stamped on arrival, 2 us apart.
struct HostStamps {
    burst_ns: i64,
    rng: rand_chacha::ChaCha8Rng,
    arrival_ns: i64,
    in_burst: i64,
}

impl HostStamps {
    const SPACING_NS: i64 = 2_000;
    const MIN_WAIT_NS: i64 = 1_000_000;

    /// The stamp of a sample measured at `measured_ns` (itself when there are no bursts).
    fn stamp(&mut self, measured_ns: i64) -> i64 {
        use rand::Rng;
        if self.burst_ns <= 0 {
            return measured_ns;
        }
        while measured_ns > self.arrival_ns {
            let wait = self
                .rng
                .random_range(Self::MIN_WAIT_NS..=self.burst_ns.max(Self::MIN_WAIT_NS));
            self.arrival_ns += wait;
            self.in_burst = 0;
        }
        self.in_burst += 1;
        self.arrival_ns + (self.in_burst - 1) * Self::SPACING_NS
    }
}

fn secs_ns(s: f64) -> i64 {
    (s * 1e9).round() as i64
}

/// Simulates `scenario` with `seed` into `w`. Deterministic: the same scenario and seed give
/// the same messages, bit for bit.
pub fn run<W: Write + Seek>(
    scenario: &Scenario,
    seed: u64,
    w: &mut LogWriter<W>,
) -> Result<RunSummary, SimError> {
    run_with_progress(scenario, seed, w, |_| {})
}

/// [`run`], calling `progress` with the fraction of mission time done, every 1 %.
pub fn run_with_progress<W: Write + Seek>(
    scenario: &Scenario,
    seed: u64,
    w: &mut LogWriter<W>,
    mut progress: impl FnMut(f64),
) -> Result<RunSummary, SimError> {
    let dt_ns = (1e9 / scenario.imu.rate_hz).round() as i64;
    let dt_s = dt_ns as f64 * 1e-9;
    // The truth: the vehicle's dynamics, or the kinematic trajectory of the segments.
    let trajectory;
    let mut kinematic;
    let mut dynamic;
    let truth: &mut dyn TruthSource = match dynamic::from_scenario(scenario, seed, dt_s)? {
        Some(flight) => {
            w.write_metadata("vehicle_truth", flight.vehicle_record)?;
            dynamic = flight.truth;
            &mut dynamic
        }
        None => {
            trajectory = scenario.trajectory()?;
            kinematic = KinematicTruth::new(&trajectory);
            &mut kinematic
        }
    };
    let origin_lat = scenario.mission.origin_latitude_deg.to_radians();
    let origin_lon = scenario.mission.origin_longitude_deg.to_radians();
    w.write_mission(&Mission {
        origin_latitude_deg: scenario.mission.origin_latitude_deg,
        origin_longitude_deg: scenario.mission.origin_longitude_deg,
        vehicle: scenario.mission.vehicle.clone(),
        description: format!(
            "simulated `{}` (seed {seed}): {}",
            scenario.name, scenario.description
        ),
        initial_yaw_rad: None,
        // What a field model (e.g. WMM) gives for the site: the declination of its field.
        magnetic_declination_deg: scenario
            .mag
            .filter(|_| scenario.mission.declination_in_log)
            .map(|m| m.field_ned_nt[1].atan2(m.field_ned_nt[0]).to_degrees()),
    })?;

    let mut real_motion = RealMotion::new(&scenario.motion, rng_for(seed, stream::MOTION));
    let mut gyro = Triad::new(scenario.imu.gyro.triad(), rng_for(seed, stream::GYRO));
    let mut accel = Triad::new(scenario.imu.accel.triad(), rng_for(seed, stream::ACCEL));
    let mut mag = scenario.mag.map(|s| {
        (
            MagSensor::new(s, rng_for(seed, stream::MAG)),
            Schedule::new(s.rate_hz),
        )
    });
    let mut dvl = scenario.dvl.map(|s| {
        (
            DvlSensor::new(s, rng_for(seed, stream::DVL)),
            Schedule::new(s.rate_hz),
            s.latency_s,
        )
    });
    let dvl_delay_ns = scenario.dvl.map_or(0, |s| secs_ns(s.stamp_delay_s));
    let mut host = HostStamps {
        burst_ns: secs_ns(scenario.imu.host_burst_s),
        rng: rng_for(seed, stream::HOST),
        arrival_ns: scenario.start_stamp_ns,
        in_burst: 0,
    };
    let dvl_until_ns = scenario
        .dvl
        .and_then(|s| s.until_s)
        .map_or(i64::MAX, secs_ns);
    let scalar = |spec: Option<super::scenario::RatedScalar>, id| {
        spec.map(|s| {
            (
                ScalarSensor::new(s.errors, rng_for(seed, id)),
                Schedule::new(s.rate_hz),
                s.latency_s,
            )
        })
    };
    let mut eml = scalar(scenario.eml, stream::EML);
    let eml_phase_s = scenario.eml.map_or(0.0, |s| s.phase_s);
    if let Some((_, sched, _)) = eml.as_mut() {
        *sched = Schedule::with_phase(scenario.eml.map_or(1.0, |s| s.rate_hz), eml_phase_s);
    }
    // The previous tick's time and speed through water, for readings between ticks.
    let mut previous_speed: Option<(i64, f64)> = None;
    let mut depth = scalar(scenario.depth, stream::DEPTH);
    let mut altimeter = scalar(scenario.altimeter, stream::ALTIMETER);
    let mut rpm = scenario.rpm.map(|s| {
        (
            PropellerModel::new(s.model, rng_for(seed, stream::RPM)),
            Schedule::new(s.rate_hz),
        )
    });
    let mut gnss = scenario.gnss.map(|s| (s, Schedule::new(s.rate_hz)));
    let mut gnss_rng = rng_for(seed, stream::GNSS);
    let mut fix_rng = rng_for(seed, stream::FIX);
    let mut usbl = scenario
        .fixes
        .filter(|f| f.usbl_every_s > 0.0)
        .map(|f| Schedule::new(1.0 / f.usbl_every_s));
    let mut fins = scenario.fins.map(|f| Schedule::new(f.rate_hz));
    let mut truth_schedule = Schedule::new(scenario.truth_rate_hz);

    let end_ns = secs_ns(truth.duration_s());
    let mut count = 0u64;
    let mut t_ns = 0i64;
    let progress_every_ns = (end_ns / 100).max(1);
    let mut next_progress_ns = 0;
    loop {
        if t_ns >= next_progress_ns {
            progress(t_ns as f64 / end_ns.max(1) as f64);
            next_progress_ns += progress_every_ns;
        }
        let t_s = t_ns as f64 * 1e-9;
        let mut sample = truth.sample(t_s);
        if let Some(m) = real_motion.as_mut() {
            m.apply(t_s, &mut sample);
        }
        let (lat, lon, height) = (sample.lat_rad, sample.lon_rad, sample.height_m);
        let motion = &sample.motion;
        let stamp_ns = scenario.start_stamp_ns + t_ns;
        let log_ns = |latency_s: f64| (stamp_ns + secs_ns(latency_s)).max(0) as u64;
        let (north, east) = geodesy::local_north_east_m(origin_lat, origin_lon, lat, lon);
        let depth_m = -height;
        let ned_from_body = motion.ned_from_body;
        let vel_body = ned_from_body.inverse() * motion.vel_ned;

        let ideal = perfect_imu(motion, lat, height);
        let host_ns = host.stamp(stamp_ns);
        let imu = Imu {
            stamp_ns: host_ns,
            angular_velocity: gyro.measure(&ideal.omega_ib_body, dt_s).into(),
            specific_force: accel.measure(&ideal.specific_force_body, dt_s).into(),
        };
        w.write(
            "/imu",
            &imu,
            (host_ns + secs_ns(scenario.imu.latency_s)).max(0) as u64,
        )?;
        count += 1;

        if let Some((m, sched)) = mag.as_mut() {
            if sched.due(t_ns) {
                let magnetic_field = m.measure_at(&ned_from_body, north, east).into();
                w.write(
                    "/mag",
                    &MagneticField {
                        stamp_ns,
                        magnetic_field,
                    },
                    log_ns(0.0),
                )?;
                count += 1;
            }
        }
        let altitude_m = scenario.seabed.depth_m(north, east) - depth_m;
        if let Some((d, sched, latency)) = dvl.as_mut() {
            if sched.due(t_ns) && t_ns <= dvl_until_ns {
                let r = d.measure(&vel_body, &motion.omega_nb_body, altitude_m);
                // Measured now, stamped late by the DVL's own clock.
                let msg = Dvl {
                    stamp_ns: stamp_ns + dvl_delay_ns,
                    velocity: r.velocity_body_m_s.into(),
                    valid: r.valid,
                    altitude: r.altitude_m,
                };
                w.write("/dvl", &msg, log_ns(*latency) + dvl_delay_ns as u64)?;
                count += 1;
            }
        }
        if let Some((s, sched, latency)) = eml.as_mut() {
            if let Some(at_ns) = sched.due_at(t_ns) {
                // On the sensor's own clock: the truth between the last tick and this one.
                let (stamp_ns, true_speed) = match previous_speed {
                    Some((t0, v0)) if eml_phase_s != 0.0 && at_ns < t_ns => {
                        let f = (at_ns - t0) as f64 / (t_ns - t0) as f64;
                        (
                            scenario.start_stamp_ns + at_ns,
                            v0 + f * (sample.speed_m_s - v0),
                        )
                    }
                    _ => (stamp_ns, sample.speed_m_s),
                };
                let speed = s.measure(true_speed).max(0.0);
                w.write("/eml", &SpeedLog { stamp_ns, speed }, log_ns(*latency))?;
                count += 1;
            }
        }
        previous_speed = Some((t_ns, sample.speed_m_s));
        if let Some((s, sched, latency)) = depth.as_mut() {
            if sched.due(t_ns) {
                w.write(
                    "/depth",
                    &Depth {
                        stamp_ns,
                        depth: s.measure(depth_m),
                    },
                    log_ns(*latency),
                )?;
                count += 1;
            }
        }
        if let Some((s, sched, latency)) = altimeter.as_mut() {
            if sched.due(t_ns) {
                let altitude = s.measure(altitude_m).max(0.0);
                w.write(
                    "/altimeter",
                    &Altimeter { stamp_ns, altitude },
                    log_ns(*latency),
                )?;
                count += 1;
            }
        }
        if let Some((prop, sched)) = rpm.as_mut() {
            if sched.due(t_ns) {
                // Dynamic: the propeller's own speed; kinematic: from the speed (seed 002).
                let rpm = match sample.actuators {
                    Some(a) => a.propeller_rad_s * 60.0 / std::f64::consts::TAU,
                    None => prop.measure(sample.speed_m_s),
                };
                w.write("/rpm", &Propeller { stamp_ns, rpm }, log_ns(0.0))?;
                count += 1;
            }
        }
        if let (Some(sched), Some(a)) = (fins.as_mut(), sample.actuators) {
            if sched.due(t_ns) {
                let msg = ControlSurfaces {
                    stamp_ns,
                    rudder: a.rudder_rad,
                    bow_plane: a.bow_rad,
                    stern_plane: a.stern_rad,
                };
                w.write("/fins", &msg, log_ns(0.0))?;
                count += 1;
            }
        }
        if let Some((g, sched)) = gnss.as_mut() {
            if sched.due(t_ns) && depth_m <= g.surface_depth_m {
                let dn = g.sigma_m * normal(&mut gnss_rng);
                let de = g.sigma_m * normal(&mut gnss_rng);
                let fix = GnssFix {
                    stamp_ns,
                    latitude_deg: (lat + dn / geodesy::meridian_radius_m(lat)).to_degrees(),
                    longitude_deg: (lon + de / (geodesy::prime_vertical_radius_m(lat) * lat.cos()))
                        .to_degrees(),
                    horizontal_sigma_m: g.sigma_m,
                };
                w.write("/gnss", &fix, log_ns(0.1))?;
                count += 1;
            }
        }
        if let Some(f) = scenario.fixes {
            let mut fix = |label: &str, sigma: f64, down: Option<f64>| {
                let msg = PositionFix {
                    stamp_ns,
                    north_m: north + sigma * normal(&mut fix_rng),
                    east_m: east + sigma * normal(&mut fix_rng),
                    down_m: down.map(|d| d + sigma * normal(&mut fix_rng)),
                    sigma_m: sigma,
                    label: label.into(),
                };
                w.write("/position_fix", &msg, log_ns(0.5))
            };
            if f.mark_sigma_m > 0.0 && (t_ns == 0 || t_ns + dt_ns > end_ns) {
                fix(
                    if t_ns == 0 { "start" } else { "end" },
                    f.mark_sigma_m,
                    None,
                )?;
                count += 1;
            }
            if let Some(sched) = usbl.as_mut() {
                if t_ns > 0 && sched.due(t_ns) {
                    fix("usbl", f.usbl_sigma_m, Some(depth_m))?;
                    count += 1;
                } else if t_ns == 0 {
                    sched.due(0);
                }
            }
        }
        if truth_schedule.due(t_ns) {
            let truth = Truth {
                stamp_ns,
                latitude_deg: lat.to_degrees(),
                longitude_deg: lon.to_degrees(),
                north_m: north,
                east_m: east,
                down_m: depth_m,
                velocity_body: vel_body.into(),
                velocity_ned: motion.vel_ned.into(),
                attitude: sample.euler_rad,
                angular_velocity: motion.omega_nb_body.into(),
            };
            w.write("/truth", &truth, log_ns(0.0))?;
            count += 1;
        }
        if t_ns + dt_ns > end_ns {
            break;
        }
        t_ns += dt_ns;
    }
    Ok(RunSummary {
        messages: count,
        duration_s: t_ns as f64 * 1e-9,
    })
}
