//! Runs a scenario: truth at the IMU rate, every sensor on its schedule, one MCAP log.

use super::dynamic;
use super::inertial::perfect_imu;
use super::scenario::{Scenario, ScenarioError};
use super::sensors::dvl::DvlSensor;
use super::sensors::imu::Triad;
use super::sensors::lbl::{Beacon, Lbl};
use super::sensors::mag::MagSensor;
use super::sensors::scalar::{Propeller as PropellerModel, ScalarSensor};
use super::sensors::usbl::{Fix, ShipTruth, Usbl, UsblForm, UsblStamp};
use super::sensors::{normal, rng_for, stream};
use super::truth::{KinematicTruth, TruthSample, TruthSource};
use super::vibration::RealMotion;
use super::writer::{LogWriter, WriteError};
use crate::contract::*;
use crate::geodesy;
use crate::ingest::Mission;
use std::collections::BTreeMap;
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
    write_mission(scenario, seed, w)?;
    if let Some(lbl) = &scenario.lbl {
        let origin = &scenario.mission;
        let origin_rad = (origin.origin_latitude_deg, origin.origin_longitude_deg);
        let origin_rad = (origin_rad.0.to_radians(), origin_rad.1.to_radians());
        w.write_metadata("beacons", lbl.record(origin_rad))?;
    }
    let mut sensors = Sensors::new(scenario, seed);
    let end_ns = secs_ns(truth.duration_s());
    let (written_before, mut t_ns) = (w.messages(), 0i64);
    let progress_every_ns = (end_ns / 100).max(1);
    let mut next_progress_ns = 0;
    loop {
        if t_ns >= next_progress_ns {
            progress(t_ns as f64 / end_ns.max(1) as f64);
            next_progress_ns += progress_every_ns;
        }
        let tick = Tick {
            t_ns,
            dt_ns,
            last: t_ns + dt_ns > end_ns,
            ..sensors.tick(scenario, truth, t_ns)
        };
        sensors.write(scenario, &tick, w)?;
        if tick.last {
            break;
        }
        t_ns += dt_ns;
    }
    if let Some(record) = sensors.usbl_truth() {
        w.write_metadata("usbl_truth", record)?;
    }
    Ok(RunSummary {
        messages: w.messages() - written_before,
        duration_s: t_ns as f64 * 1e-9,
    })
}

/// The mission record of a simulated log.
fn write_mission<W: Write + Seek>(
    scenario: &Scenario,
    seed: u64,
    w: &mut LogWriter<W>,
) -> Result<(), WriteError> {
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
    })
}

/// The truth at one IMU tick, as the sensors read it.
struct Tick {
    t_ns: i64,
    dt_ns: i64,
    /// The run's last tick.
    last: bool,
    sample: TruthSample,
    /// The stamp of the tick (the scenario's start plus `t_ns`).
    stamp_ns: i64,
    north_m: f64,
    east_m: f64,
    depth_m: f64,
    vel_body: nalgebra::Vector3<f64>,
    altitude_m: f64,
}

impl Tick {
    /// The log time of a reading `latency_s` after the tick.
    fn log_ns(&self, latency_s: f64) -> u64 {
        (self.stamp_ns + secs_ns(latency_s)).max(0) as u64
    }
}

/// A scalar sensor, its schedule and its latency.
type Scalar = (ScalarSensor, Schedule, f64);

/// Every sensor of a scenario with its own random stream and schedule.
struct Sensors {
    origin_rad: (f64, f64),
    real_motion: Option<RealMotion>,
    gyro: Triad,
    accel: Triad,
    host: HostStamps,
    mag: Option<(MagSensor, Schedule)>,
    dvl: Option<(DvlSensor, Schedule, f64)>,
    dvl_delay_ns: i64,
    dvl_until_ns: i64,
    eml: Option<Scalar>,
    eml_phase_s: f64,
    /// The previous tick's time and speed through water, for readings between ticks.
    previous_speed: Option<(i64, f64)>,
    depth: Option<Scalar>,
    altimeter: Option<Scalar>,
    rpm: Option<(PropellerModel, Schedule)>,
    gnss: Option<(super::scenario::GnssSpec, Schedule)>,
    gnss_rng: rand_chacha::ChaCha8Rng,
    fix_rng: rand_chacha::ChaCha8Rng,
    usbl: Option<Schedule>,
    /// The ship's USBL (`/acoustic_fix`).
    acoustic: Option<Usbl>,
    /// The receipt stamps of the USBL's outliers, for the `usbl_truth` record.
    acoustic_outliers_ns: Vec<i64>,
    usbl_stamp: Option<UsblStamp>,
    /// The seabed beacons (`/lbl`).
    lbl: Option<Lbl>,
    fins: Option<Schedule>,
    truth: Schedule,
}

impl Sensors {
    fn new(scenario: &Scenario, seed: u64) -> Self {
        // Only the EM log keeps its own clock's phase.
        let scalar = |spec: Option<super::scenario::RatedScalar>, id, own_clock: bool| {
            spec.map(|s| {
                let sensor = ScalarSensor::new(s.errors, rng_for(seed, id));
                let phase_s = if own_clock { s.phase_s } else { 0.0 };
                (
                    sensor,
                    Schedule::with_phase(s.rate_hz, phase_s),
                    s.latency_s,
                )
            })
        };
        Sensors {
            origin_rad: (
                scenario.mission.origin_latitude_deg.to_radians(),
                scenario.mission.origin_longitude_deg.to_radians(),
            ),
            real_motion: RealMotion::new(&scenario.motion, rng_for(seed, stream::MOTION)),
            gyro: Triad::new(scenario.imu.gyro.triad(), rng_for(seed, stream::GYRO)),
            accel: Triad::new(scenario.imu.accel.triad(), rng_for(seed, stream::ACCEL)),
            host: HostStamps {
                burst_ns: secs_ns(scenario.imu.host_burst_s),
                rng: rng_for(seed, stream::HOST),
                arrival_ns: scenario.start_stamp_ns,
                in_burst: 0,
            },
            mag: (scenario.mag).map(|s| {
                let sensor = MagSensor::new(s, rng_for(seed, stream::MAG));
                (sensor, Schedule::new(s.rate_hz))
            }),
            dvl: (scenario.dvl).map(|s| {
                let sensor = DvlSensor::new(s, rng_for(seed, stream::DVL));
                (sensor, Schedule::new(s.rate_hz), s.latency_s)
            }),
            dvl_delay_ns: scenario.dvl.map_or(0, |s| secs_ns(s.stamp_delay_s)),
            dvl_until_ns: (scenario.dvl.and_then(|s| s.until_s)).map_or(i64::MAX, secs_ns),
            eml: scalar(scenario.eml, stream::EML, true),
            eml_phase_s: scenario.eml.map_or(0.0, |s| s.phase_s),
            previous_speed: None,
            depth: scalar(scenario.depth, stream::DEPTH, false),
            altimeter: scalar(scenario.altimeter, stream::ALTIMETER, false),
            rpm: (scenario.rpm).map(|s| {
                let model = PropellerModel::new(s.model, rng_for(seed, stream::RPM));
                (model, Schedule::new(s.rate_hz))
            }),
            gnss: scenario.gnss.map(|s| (s, Schedule::new(s.rate_hz))),
            gnss_rng: rng_for(seed, stream::GNSS),
            fix_rng: rng_for(seed, stream::FIX),
            usbl: (scenario.fixes)
                .filter(|f| f.usbl_every_s > 0.0)
                .map(|f| Schedule::new(1.0 / f.usbl_every_s)),
            acoustic: (scenario.usbl).map(|u| Usbl::new(u, rng_for(seed, stream::USBL))),
            acoustic_outliers_ns: Vec::new(),
            usbl_stamp: scenario.usbl.map(|u| u.stamp),
            lbl: (scenario.lbl.clone()).map(|l| Lbl::new(l, rng_for(seed, stream::LBL))),
            fins: scenario.fins.map(|f| Schedule::new(f.rate_hz)),
            truth: Schedule::new(scenario.truth_rate_hz),
        }
    }

    /// The truth at `t_ns`, with the hull's real motion on it.
    fn tick(&mut self, scenario: &Scenario, truth: &mut dyn TruthSource, t_ns: i64) -> Tick {
        let t_s = t_ns as f64 * 1e-9;
        let mut sample = truth.sample(t_s);
        if let Some(m) = self.real_motion.as_mut() {
            m.apply(t_s, &mut sample);
        }
        let (origin_lat, origin_lon) = self.origin_rad;
        let (north_m, east_m) =
            geodesy::local_north_east_m(origin_lat, origin_lon, sample.lat_rad, sample.lon_rad);
        let depth_m = -sample.height_m;
        let motion = &sample.motion;
        Tick {
            t_ns,
            dt_ns: 0,
            last: false,
            stamp_ns: scenario.start_stamp_ns + t_ns,
            north_m,
            east_m,
            depth_m,
            vel_body: motion.ned_from_body.inverse() * motion.vel_ned,
            altitude_m: scenario.seabed.depth_m(north_m, east_m) - depth_m,
            sample,
        }
    }

    /// Every reading due at the tick, in the log's order.
    fn write<W: Write + Seek>(
        &mut self,
        scenario: &Scenario,
        tick: &Tick,
        w: &mut LogWriter<W>,
    ) -> Result<(), WriteError> {
        self.imu(scenario, tick, w)?;
        self.mag(tick, w)?;
        self.dvl(tick, w)?;
        self.eml(scenario, tick, w)?;
        self.previous_speed = Some((tick.t_ns, tick.sample.speed_m_s));
        Self::scalar(&mut self.depth, "/depth", tick, tick.depth_m, w)?;
        Self::scalar(&mut self.altimeter, "/altimeter", tick, tick.altitude_m, w)?;
        self.rpm(tick, w)?;
        self.fins(tick, w)?;
        self.gnss(tick, w)?;
        self.fixes(scenario, tick, w)?;
        self.acoustic(tick, w)?;
        self.lbl(tick, w)?;
        self.truth(tick, w)?;
        Ok(())
    }

    fn imu<W: Write + Seek>(
        &mut self,
        scenario: &Scenario,
        tick: &Tick,
        w: &mut LogWriter<W>,
    ) -> Result<(), WriteError> {
        let dt_s = tick.dt_ns as f64 * 1e-9;
        let s = &tick.sample;
        let ideal = perfect_imu(&s.motion, s.lat_rad, s.height_m);
        let host_ns = self.host.stamp(tick.stamp_ns);
        let imu = Imu {
            stamp_ns: host_ns,
            angular_velocity: self.gyro.measure(&ideal.omega_ib_body, dt_s).into(),
            specific_force: self.accel.measure(&ideal.specific_force_body, dt_s).into(),
        };
        let log_ns = (host_ns + secs_ns(scenario.imu.latency_s)).max(0) as u64;
        w.write("/imu", &imu, log_ns)
    }

    fn mag<W: Write + Seek>(
        &mut self,
        tick: &Tick,
        w: &mut LogWriter<W>,
    ) -> Result<(), WriteError> {
        let Some((m, sched)) = self.mag.as_mut() else {
            return Ok(());
        };
        if !sched.due(tick.t_ns) {
            return Ok(());
        }
        let ned_from_body = &tick.sample.motion.ned_from_body;
        let msg = MagneticField {
            stamp_ns: tick.stamp_ns,
            magnetic_field: m
                .measure_at(ned_from_body, tick.north_m, tick.east_m)
                .into(),
        };
        w.write("/mag", &msg, tick.log_ns(0.0))
    }

    fn dvl<W: Write + Seek>(
        &mut self,
        tick: &Tick,
        w: &mut LogWriter<W>,
    ) -> Result<(), WriteError> {
        let Some((d, sched, latency)) = self.dvl.as_mut() else {
            return Ok(());
        };
        if !(sched.due(tick.t_ns) && tick.t_ns <= self.dvl_until_ns) {
            return Ok(());
        }
        let omega = &tick.sample.motion.omega_nb_body;
        let r = d.measure(&tick.vel_body, omega, tick.altitude_m);
        // Measured now, stamped late by the DVL's own clock.
        let msg = Dvl {
            stamp_ns: tick.stamp_ns + self.dvl_delay_ns,
            velocity: r.velocity_body_m_s.into(),
            valid: r.valid,
            altitude: r.altitude_m,
        };
        w.write(
            "/dvl",
            &msg,
            tick.log_ns(*latency) + self.dvl_delay_ns as u64,
        )
    }

    fn eml<W: Write + Seek>(
        &mut self,
        scenario: &Scenario,
        tick: &Tick,
        w: &mut LogWriter<W>,
    ) -> Result<(), WriteError> {
        let Some((s, sched, latency)) = self.eml.as_mut() else {
            return Ok(());
        };
        let Some(at_ns) = sched.due_at(tick.t_ns) else {
            return Ok(());
        };
        let speed_now = tick.sample.speed_m_s;
        // On the sensor's own clock: the truth between the last tick and this one.
        let (stamp_ns, true_speed) = match self.previous_speed {
            Some((t0, v0)) if self.eml_phase_s != 0.0 && at_ns < tick.t_ns => {
                let f = (at_ns - t0) as f64 / (tick.t_ns - t0) as f64;
                (scenario.start_stamp_ns + at_ns, v0 + f * (speed_now - v0))
            }
            _ => (tick.stamp_ns, speed_now),
        };
        let speed = s.measure(true_speed).max(0.0);
        w.write("/eml", &SpeedLog { stamp_ns, speed }, tick.log_ns(*latency))
    }

    /// A depth sensor's or an altimeter's reading of `value`, when due.
    fn scalar<W: Write + Seek>(
        sensor: &mut Option<Scalar>,
        topic: &str,
        tick: &Tick,
        value: f64,
        w: &mut LogWriter<W>,
    ) -> Result<(), WriteError> {
        let Some((s, sched, latency)) = sensor.as_mut() else {
            return Ok(());
        };
        if !sched.due(tick.t_ns) {
            return Ok(());
        }
        let stamp_ns = tick.stamp_ns;
        let log_ns = tick.log_ns(*latency);
        if topic == "/depth" {
            let depth = s.measure(value);
            w.write(topic, &Depth { stamp_ns, depth }, log_ns)
        } else {
            let altitude = s.measure(value).max(0.0);
            w.write(topic, &Altimeter { stamp_ns, altitude }, log_ns)
        }
    }

    fn rpm<W: Write + Seek>(
        &mut self,
        tick: &Tick,
        w: &mut LogWriter<W>,
    ) -> Result<(), WriteError> {
        let Some((prop, sched)) = self.rpm.as_mut() else {
            return Ok(());
        };
        if !sched.due(tick.t_ns) {
            return Ok(());
        }
        // Dynamic: the propeller's own speed; kinematic: from the speed (seed 002).
        let rpm = match tick.sample.actuators {
            Some(a) => a.propeller_rad_s * 60.0 / std::f64::consts::TAU,
            None => prop.measure(tick.sample.speed_m_s),
        };
        let stamp_ns = tick.stamp_ns;
        w.write("/rpm", &Propeller { stamp_ns, rpm }, tick.log_ns(0.0))
    }

    fn fins<W: Write + Seek>(
        &mut self,
        tick: &Tick,
        w: &mut LogWriter<W>,
    ) -> Result<(), WriteError> {
        let (Some(sched), Some(a)) = (self.fins.as_mut(), tick.sample.actuators) else {
            return Ok(());
        };
        if !sched.due(tick.t_ns) {
            return Ok(());
        }
        let msg = ControlSurfaces {
            stamp_ns: tick.stamp_ns,
            rudder: a.rudder_rad,
            bow_plane: a.bow_rad,
            stern_plane: a.stern_rad,
        };
        w.write("/fins", &msg, tick.log_ns(0.0))
    }

    fn gnss<W: Write + Seek>(
        &mut self,
        tick: &Tick,
        w: &mut LogWriter<W>,
    ) -> Result<(), WriteError> {
        let Some((g, sched)) = self.gnss.as_mut() else {
            return Ok(());
        };
        if !(sched.due(tick.t_ns) && tick.depth_m <= g.surface_depth_m) {
            return Ok(());
        }
        let (lat, lon) = (tick.sample.lat_rad, tick.sample.lon_rad);
        let dn = g.sigma_m * normal(&mut self.gnss_rng);
        let de = g.sigma_m * normal(&mut self.gnss_rng);
        let east_radius = geodesy::prime_vertical_radius_m(lat) * lat.cos();
        let fix = GnssFix {
            stamp_ns: tick.stamp_ns,
            latitude_deg: (lat + dn / geodesy::meridian_radius_m(lat)).to_degrees(),
            longitude_deg: (lon + de / east_radius).to_degrees(),
            horizontal_sigma_m: g.sigma_m,
        };
        w.write("/gnss", &fix, tick.log_ns(0.1))
    }

    /// The start and end marks, and the USBL-like fixes.
    fn fixes<W: Write + Seek>(
        &mut self,
        scenario: &Scenario,
        tick: &Tick,
        w: &mut LogWriter<W>,
    ) -> Result<(), WriteError> {
        let Some(f) = scenario.fixes else {
            return Ok(());
        };
        let rng = &mut self.fix_rng;
        let mut fix = |label: &str, sigma: f64, down: Option<f64>| {
            let msg = PositionFix {
                stamp_ns: tick.stamp_ns,
                north_m: tick.north_m + sigma * normal(rng),
                east_m: tick.east_m + sigma * normal(rng),
                down_m: down.map(|d| d + sigma * normal(rng)),
                sigma_m: sigma,
                label: label.into(),
            };
            w.write("/position_fix", &msg, tick.log_ns(0.5))
        };
        if f.mark_sigma_m > 0.0 && (tick.t_ns == 0 || tick.last) {
            let label = if tick.t_ns == 0 { "start" } else { "end" };
            fix(label, f.mark_sigma_m, None)?;
        }
        if let Some(sched) = self.usbl.as_mut() {
            if tick.t_ns > 0 && sched.due(tick.t_ns) {
                fix("usbl", f.usbl_sigma_m, Some(tick.depth_m))?;
            } else if tick.t_ns == 0 {
                sched.due(0);
            }
        }
        Ok(())
    }

    /// What the USBL did that its fixes do not say (a test's reference; the reconstruction
    /// never reads it): the run's receipt delay, s, and the receipt stamps of its outliers,
    /// ns, comma-separated.
    fn usbl_truth(&self) -> Option<BTreeMap<String, String>> {
        let usbl = self.acoustic.as_ref()?;
        let stamps: Vec<String> = self
            .acoustic_outliers_ns
            .iter()
            .map(i64::to_string)
            .collect();
        Some(BTreeMap::from([
            (
                "receipt_delay_s".to_string(),
                format!("{}", usbl.receipt_delay_s()),
            ),
            ("outlier_receipt_stamps_ns".to_string(), stamps.join(",")),
        ]))
    }

    /// The ship's USBL fix, stamped and logged when the ship received it.
    fn acoustic<W: Write + Seek>(
        &mut self,
        tick: &Tick,
        w: &mut LogWriter<W>,
    ) -> Result<(), WriteError> {
        let t_s = tick.t_ns as f64 * 1e-9;
        let ned_m = [tick.north_m, tick.east_m, tick.depth_m];
        let Some(usbl) = self.acoustic.as_mut() else {
            return Ok(());
        };
        let fix = usbl.fix(t_s, ned_m);
        let raw = usbl.spec().form == UsblForm::Raw;
        if raw {
            if let Some(pose) = usbl.ship_pose(t_s) {
                let (heading_sigma_deg, position_sigma_m) = (
                    usbl.spec().ship_heading_sigma_deg,
                    usbl.spec().ship_position_sigma_m,
                );
                let msg = self.ship_pose_message(tick, &pose, position_sigma_m, heading_sigma_deg);
                w.write("/ship_pose", &msg, tick.log_ns(0.0))?;
            }
        }
        let Some(fix) = fix else {
            return Ok(());
        };
        let [dn, de, dd] = fix.error_ned_m;
        let (lat, lon) =
            geodesy::position_of_local_m(tick.sample.lat_rad, tick.sample.lon_rad, dn, de);
        let stamp_ns = tick.stamp_ns + secs_ns(fix.delay_s);
        if fix.outlier {
            self.acoustic_outliers_ns.push(stamp_ns);
        }
        let both = self.usbl_stamp == Some(UsblStamp::ValidityAndDelay);
        if raw {
            let msg = self.raw_observation(tick, &fix, stamp_ns, both);
            return w.write("/usbl", &msg, stamp_ns.max(0) as u64);
        }
        let msg = AcousticFix {
            stamp_ns: if both { tick.stamp_ns } else { stamp_ns },
            stamp_is_validity: both,
            received_after_s: both.then_some(fix.delay_s),
            latitude_deg: lat.to_degrees(),
            longitude_deg: lon.to_degrees(),
            depth_m: Some(tick.depth_m + dd),
            horizontal_sigma_m: Some(fix.sigma_m),
            depth_sigma_m: Some(fix.sigma_m),
            beacon_id: String::new(),
        };
        w.write("/acoustic_fix", &msg, stamp_ns.max(0) as u64)
    }

    /// The ship's pose as its sensors give it, placed on the mission's origin.
    fn ship_pose_message(
        &self,
        tick: &Tick,
        pose: &ShipTruth,
        position_sigma_m: f64,
        heading_sigma_deg: f64,
    ) -> ShipPose {
        let (lat, lon) = self.ship_geodetic(pose);
        let [roll, pitch, yaw] = pose.attitude_rad;
        ShipPose {
            stamp_ns: tick.stamp_ns,
            latitude_deg: lat.to_degrees(),
            longitude_deg: lon.to_degrees(),
            roll,
            pitch,
            yaw,
            horizontal_sigma_m: Some(position_sigma_m),
            heading_sigma_rad: Some(heading_sigma_deg.to_radians()),
        }
    }

    /// Where the ship is, latitude and longitude, rad.
    fn ship_geodetic(&self, ship: &ShipTruth) -> (f64, f64) {
        let (lat0, lon0) = self.origin_rad;
        geodesy::position_of_local_m(lat0, lon0, ship.north_m, ship.east_m)
    }

    /// The USBL's raw observation of the vehicle at `tick` from the true ship (the
    /// transducer at its reference point, in its axes): the straight line through the Earth
    /// turned into the ship's axes, an outlier's offset added, then the USBL's noise.
    fn raw_observation(
        &mut self,
        tick: &Tick,
        fix: &Fix,
        receipt_ns: i64,
        both: bool,
    ) -> UsblObservation {
        let (lat, lon) = self.ship_geodetic(&fix.ship);
        let mut d_ned = geodesy::ned_offset_m(
            (lat, lon, 0.0),
            (tick.sample.lat_rad, tick.sample.lon_rad, -tick.depth_m),
        );
        d_ned.x += fix.outlier_ne_m[0];
        d_ned.y += fix.outlier_ne_m[1];
        let [roll, pitch, yaw] = fix.ship.attitude_rad;
        let d = nalgebra::Rotation3::from_euler_angles(roll, pitch, yaw).inverse() * d_ned;
        let usbl = self.acoustic.as_mut().expect("a raw USBL observes");
        let o = usbl.observe(d.into());
        let [range, bearing, elevation] = o.range_bearing_elevation;
        let half_pi = std::f64::consts::FRAC_PI_2;
        UsblObservation {
            stamp_ns: if both { tick.stamp_ns } else { receipt_ns },
            stamp_is_validity: both,
            received_after_s: both.then_some(fix.delay_s),
            range_m: range.max(0.0),
            bearing_rad: bearing,
            elevation_rad: elevation.clamp(-half_pi, half_pi),
            range_sigma_m: Some(o.sigmas[0]),
            bearing_sigma_rad: Some(o.sigmas[1]),
            elevation_sigma_rad: Some(o.sigmas[2]),
            sound_speed_m_s: None,
            beacon_id: String::new(),
        }
    }

    /// The beacons' replies to an interrogation, each stamped and logged when it was received.
    fn lbl<W: Write + Seek>(
        &mut self,
        tick: &Tick,
        w: &mut LogWriter<W>,
    ) -> Result<(), WriteError> {
        let Some(lbl) = self.lbl.as_mut() else {
            return Ok(());
        };
        let t_s = tick.t_ns as f64 * 1e-9;
        let range_sigma_m = Some(lbl.spec().range_sigma_m);
        let sound_speed_m_s = Some(lbl.spec().sound_speed_m_s);
        let vel = tick.sample.motion.vel_ned;
        // The straight line through the Earth, not the plane of the mission origin's radii
        // (over a kilometre that plane stretches east-west distances by 1e-4).
        let s = &tick.sample;
        let vehicle = (s.lat_rad, s.lon_rad, s.height_m);
        let origin = self.origin_rad;
        let from_beacon = |b: &Beacon| (-geodesy::ned_offset_m(vehicle, b.geodetic(origin))).into();
        let mut replies = lbl.replies(t_s, from_beacon, [vel.x, vel.y, vel.z]);
        replies.sort_by(|a, b| a.two_way_travel_time_s.total_cmp(&b.two_way_travel_time_s));
        for reply in replies {
            let received_ns = tick.stamp_ns + secs_ns(reply.two_way_travel_time_s);
            let msg = LblRange {
                stamp_ns: received_ns,
                beacon_id: reply.beacon.id.clone(),
                two_way_travel_time_s: Some(reply.two_way_travel_time_s),
                range_m: Some(reply.range_m),
                sound_speed_m_s,
                range_sigma_m,
            };
            w.write("/lbl", &msg, received_ns.max(0) as u64)?;
        }
        Ok(())
    }

    fn truth<W: Write + Seek>(
        &mut self,
        tick: &Tick,
        w: &mut LogWriter<W>,
    ) -> Result<(), WriteError> {
        if !self.truth.due(tick.t_ns) {
            return Ok(());
        }
        let s = &tick.sample;
        let truth = Truth {
            stamp_ns: tick.stamp_ns,
            latitude_deg: s.lat_rad.to_degrees(),
            longitude_deg: s.lon_rad.to_degrees(),
            north_m: tick.north_m,
            east_m: tick.east_m,
            down_m: tick.depth_m,
            velocity_body: tick.vel_body.into(),
            velocity_ned: s.motion.vel_ned.into(),
            attitude: s.euler_rad,
            angular_velocity: s.motion.omega_nb_body.into(),
        };
        w.write("/truth", &truth, tick.log_ns(0.0))
    }
}
