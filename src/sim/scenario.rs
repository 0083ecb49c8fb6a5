//! Scenario definitions: data (TOML), not code paths. A scenario gives the mission, the start,
//! the manoeuvre segments and the sensors with their error parameters in the units data
//! sheets use; [`Scenario::trajectory`] and the runner turn it into a log.

use super::sensors::dvl::DvlSpec;
use super::sensors::imu::TriadSpec;
use super::sensors::mag::MagSpec;
use super::sensors::scalar::{PropellerSpec, ScalarSpec};
use super::trajectory::{SegmentError, Trajectory, TrajectoryBuilder};
use crate::geodesy;
use crate::vehicle::six_dof::flight_plan::Phase;
use serde::{Deserialize, Serialize};

/// `(name, text)` of each `scenarios/<name>.toml`.
macro_rules! shipped {
    ($($name:literal),* $(,)?) => {
        &[$(($name, include_str!(concat!("../../scenarios/", $name, ".toml")))),*]
    };
}

/// The scenarios shipped in the binary: (name, TOML text). `long-dive-dynamic` to
/// `drop-no-dvl` are flown by the 6-DOF vehicle model and its autopilot.
pub const BUILT_IN: &[(&str, &str)] = shipped![
    "survey",
    "survey-short",
    "pool-circle",
    "pool-rectangle",
    "pool-mems-host",
    "dive-27min",
    "long-dive",
    "survey-dvl-calibration",
    "trench-eml",
    "trench-turn",
    "auv-at-sea",
    "auv-at-sea-straight",
    "survey-27h",
    "survey-hard-iron",
    "long-dive-dynamic",
    "zigzag-rudder-20-20",
    "zigzag-planes-10-10",
    "turning-circle",
    "drop-entry",
    "drop-no-dvl",
    "usbl-survey",
    "usbl-raw-survey",
    "usbl-no-dvl",
    "usbl-raw-no-dvl",
    "lbl-box",
];

/// Why a scenario cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum ScenarioError {
    #[error("unknown scenario `{name}` (built in: {known}); or a scenario file")]
    Unknown { name: String, known: String },
    #[error("scenario file: {}", crate::config::toml_one_line(&.0.to_string()))]
    Parse(#[from] toml::de::Error),
    #[error("scenario `{name}`: {reason}")]
    Invalid { name: String, reason: String },
    #[error("scenario `{name}`: {source}")]
    Segment {
        name: String,
        #[source]
        source: SegmentError,
    },
}

/// A whole scenario.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    pub name: String,
    pub description: String,
    /// Time after the last segment, s.
    #[serde(default)]
    pub tail_s: f64,
    /// UTC stamp of the start, ns since the epoch.
    #[serde(default = "default_start_stamp")]
    pub start_stamp_ns: i64,
    pub mission: MissionSpec,
    pub start: StartSpec,
    /// Kinematic flight: the trajectory's segments.
    #[serde(default, rename = "segment")]
    pub segments: Vec<Segment>,
    /// Dynamic flight: the vehicle model and its pilot's settings ...
    pub dynamics: Option<DynamicsSpec>,
    /// ... and the phases it flies.
    #[serde(default, rename = "phase")]
    pub phases: Vec<Phase>,
    pub imu: ImuSpec,
    /// Real motion on the flight: vibration and the sea's oscillation (none by default).
    #[serde(default)]
    pub motion: super::vibration::MotionSpec,
    pub mag: Option<MagSpec>,
    pub dvl: Option<DvlSpec>,
    pub eml: Option<RatedScalar>,
    pub depth: Option<RatedScalar>,
    pub altimeter: Option<RatedScalar>,
    pub rpm: Option<RatedPropeller>,
    /// Fin angles (`/fins`): dynamic scenarios only.
    pub fins: Option<Rate>,
    pub gnss: Option<GnssSpec>,
    pub fixes: Option<FixSpec>,
    /// A USBL on a support ship (`/acoustic_fix`).
    pub usbl: Option<super::sensors::usbl::UsblSpec>,
    /// A long-baseline network of seabed beacons (`/lbl`, the `beacons` record).
    pub lbl: Option<super::sensors::lbl::LblSpec>,
    #[serde(default)]
    pub seabed: SeabedSpec,
    #[serde(default = "default_truth_rate")]
    pub truth_rate_hz: f64,
}

fn default_start_stamp() -> i64 {
    1_700_000_000_000_000_000
}

fn default_truth_rate() -> f64 {
    10.0
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MissionSpec {
    pub origin_latitude_deg: f64,
    pub origin_longitude_deg: f64,
    pub vehicle: String,
    /// Whether the log's mission record gives the declination of the simulated field (true);
    /// false leaves it out, as many real logs do, so that a field model must give it.
    #[serde(default = "declination_in_log")]
    pub declination_in_log: bool,
}

fn declination_in_log() -> bool {
    true
}

/// The start (every number 0 unless given).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct StartSpec {
    pub north_m: f64,
    pub east_m: f64,
    pub depth_m: f64,
    pub yaw_deg: f64,
    pub speed_m_s: f64,
    /// Turn rate at the start, deg/s (a run that starts already turning, e.g. a circle).
    pub turn_rate_deg_s: f64,
    /// Roll and pitch at the start, deg (a dropped vehicle's; dynamic scenarios only).
    pub roll_deg: f64,
    pub pitch_deg: f64,
}

/// Flight by the 6-DOF vehicle model and its autopilot instead of kinematic segments.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DynamicsSpec {
    /// A built-in vehicle (`nps-auv-ii`, `remus-100`) or a vehicle JSON file.
    pub vehicle: String,
    /// Commanded speed through the water, m/s.
    pub speed_m_s: f64,
    /// Fastest change of the depth reference, m/s.
    #[serde(default = "default_vertical_rate")]
    pub max_vertical_rate_m_s: f64,
    /// Fastest turn of the heading reference toward a new heading, deg/s.
    #[serde(default = "default_turn_rate")]
    pub max_turn_rate_deg_s: f64,
    /// 1-sigma relative uncertainty of the true vehicle's coefficients (seed 000 case 2:
    /// the log is flown by a seeded draw around the file, recorded in its metadata); 0: the
    /// file's own.
    #[serde(default)]
    pub coef_uncertainty: f64,
    /// The vehicle file's text when `vehicle` is a file (read by the command line).
    #[serde(skip)]
    pub vehicle_json: Option<String>,
}

fn default_vertical_rate() -> f64 {
    0.4
}

fn default_turn_rate() -> f64 {
    3.0
}

/// A sampling rate alone.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Rate {
    pub rate_hz: f64,
}

/// One manoeuvre. Angles in degrees, positive yaw change to starboard.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "kebab-case", deny_unknown_fields)]
pub enum Segment {
    /// Straight and level.
    Cruise { duration_s: f64 },
    /// Change speed.
    Speed { to_m_s: f64, ramp_s: f64 },
    /// Coordinated turn by an angle.
    Turn {
        angle_deg: f64,
        rate_deg_s: f64,
        ramp_s: f64,
    },
    /// Dive or climb to a depth.
    Depth {
        to_m: f64,
        pitch_deg: f64,
        ramp_s: f64,
    },
    /// Climb to the surface (depth 0).
    Surface { pitch_deg: f64, ramp_s: f64 },
    /// A horizontal spiral: turns of `angle_deg` in all while changing depth to `to_m`.
    Spiral {
        angle_deg: f64,
        rate_deg_s: f64,
        to_m: f64,
        pitch_deg: f64,
        ramp_s: f64,
    },
    /// Alternating turns of +-`angle_deg` with `leg_s` straight between, `legs` times.
    Zigzag {
        legs: u32,
        angle_deg: f64,
        leg_s: f64,
        rate_deg_s: f64,
        ramp_s: f64,
    },
    /// Survey lanes: `lanes` straight runs of `lane_s` joined by alternating 180 deg turns.
    Lawnmower {
        lanes: u32,
        lane_s: f64,
        rate_deg_s: f64,
        ramp_s: f64,
    },
    /// Stop, hold still for `duration_s`, and resume the previous speed.
    Hold { duration_s: f64, ramp_s: f64 },
}

/// IMU rate and error grades in data-sheet units.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImuSpec {
    pub rate_hz: f64,
    #[serde(default)]
    pub latency_s: f64,
    /// Host stamping: the IMU's samples reach the host in bursts, each burst after a random
    /// wait of up to this many seconds, and are stamped on arrival, 2 us apart (0: each
    /// sample stamped when it was measured).
    #[serde(default)]
    pub host_burst_s: f64,
    #[serde(default)]
    pub gyro: GyroGrade,
    #[serde(default)]
    pub accel: AccelGrade,
}

/// Gyro errors: deg/h, ppm, mrad, deg/sqrt(h).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GyroGrade {
    pub bias_deg_h: f64,
    pub bias_instability_deg_h: f64,
    pub bias_correlation_s: f64,
    pub scale_ppm: f64,
    pub misalignment_mrad: f64,
    pub arw_deg_rt_h: f64,
    /// Readings rounded to this step, rad/s (0: not quantised); the remainder is carried to
    /// the next reading, as an integrating sensor's counter does.
    pub quantum_rad_s: f64,
}

/// Accelerometer errors: micro-g, ppm, mrad, micro-g/sqrt(Hz).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct AccelGrade {
    pub bias_ug: f64,
    pub bias_instability_ug: f64,
    pub bias_correlation_s: f64,
    pub scale_ppm: f64,
    pub misalignment_mrad: f64,
    pub vrw_ug_rt_hz: f64,
    /// Readings rounded to this step, m/s^2 (0: not quantised), the remainder carried.
    pub quantum_m_s2: f64,
}

const DEG_H: f64 = std::f64::consts::PI / 180.0 / 3600.0;
const UG: f64 = geodesy::G0_M_S2 * 1e-6;

impl GyroGrade {
    /// In SI (rad/s; ARW deg/sqrt(h) = (pi/180)/60 rad/sqrt(s)).
    pub fn triad(&self) -> TriadSpec {
        TriadSpec {
            bias: self.bias_deg_h * DEG_H,
            bias_instability: self.bias_instability_deg_h * DEG_H,
            bias_correlation_s: self.bias_correlation_s,
            scale_ppm: self.scale_ppm,
            misalignment_rad: self.misalignment_mrad * 1e-3,
            noise_density: self.arw_deg_rt_h.to_radians() / 60.0,
            quantum: self.quantum_rad_s,
        }
    }
}

impl AccelGrade {
    /// In SI (m/s^2; noise density m/s^2/sqrt(Hz)).
    pub fn triad(&self) -> TriadSpec {
        TriadSpec {
            bias: self.bias_ug * UG,
            bias_instability: self.bias_instability_ug * UG,
            bias_correlation_s: self.bias_correlation_s,
            scale_ppm: self.scale_ppm,
            misalignment_rad: self.misalignment_mrad * 1e-3,
            noise_density: self.vrw_ug_rt_hz * UG,
            quantum: self.quantum_m_s2,
        }
    }
}

/// A one-number sensor with its rate.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RatedScalar {
    pub rate_hz: f64,
    #[serde(default)]
    pub latency_s: f64,
    /// Stamps on the sensor's own clock (EM log only): readings at `phase_s + k / rate_hz`,
    /// between IMU ticks (the truth interpolated), instead of on the first tick at or after
    /// each period. 0: on the ticks.
    #[serde(default)]
    pub phase_s: f64,
    #[serde(flatten)]
    pub errors: ScalarSpec,
}

/// The propeller with its rate.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RatedPropeller {
    pub rate_hz: f64,
    /// Kinematic scenarios: the speed-RPM relation that makes RPM from the speed. Dynamic
    /// scenarios log the propeller's own speed and need none.
    #[serde(flatten)]
    pub model: PropellerSpec,
}

/// GNSS: fixes only within `surface_depth_m` of the surface.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GnssSpec {
    pub rate_hz: f64,
    pub sigma_m: f64,
    #[serde(default = "default_surface_depth")]
    pub surface_depth_m: f64,
}

fn default_surface_depth() -> f64 {
    0.5
}

/// Known positions: surveyed start/end marks and periodic USBL-like fixes.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FixSpec {
    /// 1-sigma of the start and end marks, m (0: no marks).
    #[serde(default)]
    pub mark_sigma_m: f64,
    /// Period of USBL-like fixes, s (0: none).
    #[serde(default)]
    pub usbl_every_s: f64,
    #[serde(default)]
    pub usbl_sigma_m: f64,
}

/// Seabed depth along a bearing: piecewise linear in the distance along it, constant beyond.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SeabedSpec {
    #[serde(default)]
    pub bearing_deg: f64,
    /// (distance along the bearing from the origin m, seabed depth m), increasing distance.
    pub profile: Vec<[f64; 2]>,
}

impl Default for SeabedSpec {
    fn default() -> Self {
        SeabedSpec {
            bearing_deg: 0.0,
            profile: vec![[0.0, 100.0]],
        }
    }
}

impl SeabedSpec {
    /// Seabed depth below the point (north, east) of the mission frame, m.
    pub fn depth_m(&self, north_m: f64, east_m: f64) -> f64 {
        let b = self.bearing_deg.to_radians();
        let d = north_m * b.cos() + east_m * b.sin();
        let p = &self.profile;
        match p.iter().position(|q| q[0] > d) {
            None => p.last().map_or(100.0, |q| q[1]),
            Some(0) => p[0][1],
            Some(i) => {
                let (a, c) = (p[i - 1], p[i]);
                a[1] + (c[1] - a[1]) * (d - a[0]) / (c[0] - a[0])
            }
        }
    }
}

impl Scenario {
    /// A built-in scenario by name.
    pub fn built_in(name: &str) -> Result<Scenario, ScenarioError> {
        let text = BUILT_IN
            .iter()
            .find(|(n, _)| *n == name)
            .map(|(_, t)| *t)
            .ok_or_else(|| ScenarioError::Unknown {
                name: name.into(),
                known: BUILT_IN
                    .iter()
                    .map(|(n, _)| *n)
                    .collect::<Vec<_>>()
                    .join(", "),
            })?;
        Scenario::from_toml(text)
    }

    /// Parses and checks a scenario.
    pub fn from_toml(text: &str) -> Result<Scenario, ScenarioError> {
        let s: Scenario = toml::from_str(text)?;
        s.check()?;
        Ok(s)
    }

    /// The scenario with its IMU sampled at `rate_hz` and every sensor's rate capped at it
    /// (sensors are sampled on the IMU's ticks; a dynamic flight is integrated at that step).
    pub fn with_imu_rate(&self, rate_hz: f64) -> Result<Scenario, ScenarioError> {
        let mut s = self.clone();
        s.imu.rate_hz = rate_hz;
        for (_, r) in s.rates_mut() {
            *r = r.min(rate_hz);
        }
        s.check()?;
        Ok(s)
    }

    /// Every sensor's rate but the IMU's, by section, Hz.
    fn rates_mut(&mut self) -> Vec<(&'static str, &mut f64)> {
        let mut rates = vec![("truth", &mut self.truth_rate_hz)];
        rates.extend(self.mag.as_mut().map(|x| ("mag", &mut x.rate_hz)));
        rates.extend(self.dvl.as_mut().map(|x| ("dvl", &mut x.rate_hz)));
        rates.extend(self.eml.as_mut().map(|x| ("eml", &mut x.rate_hz)));
        rates.extend(self.depth.as_mut().map(|x| ("depth", &mut x.rate_hz)));
        rates.extend(
            self.altimeter
                .as_mut()
                .map(|x| ("altimeter", &mut x.rate_hz)),
        );
        rates.extend(self.rpm.as_mut().map(|x| ("rpm", &mut x.rate_hz)));
        rates.extend(self.gnss.as_mut().map(|x| ("gnss", &mut x.rate_hz)));
        rates.extend(self.fins.as_mut().map(|x| ("fins", &mut x.rate_hz)));
        rates
    }

    fn check(&self) -> Result<(), ScenarioError> {
        let bad = |reason: String| ScenarioError::Invalid {
            name: self.name.clone(),
            reason,
        };
        let rate_ok = |r: f64| r.is_finite() && r > 0.0 && r <= self.imu.rate_hz;
        if !(self.imu.rate_hz.is_finite() && (1.0..=2000.0).contains(&self.imu.rate_hz)) {
            return Err(bad(format!(
                "imu.rate_hz {} is not in [1, 2000]",
                self.imu.rate_hz
            )));
        }
        for (name, &mut r) in self.clone().rates_mut() {
            if !rate_ok(r) {
                return Err(bad(format!(
                    "{name}.rate_hz {r} must be above 0 and at most the IMU rate"
                )));
            }
        }
        if let Some(key) = crate::config::non_finite_key(self) {
            return Err(bad(format!("{key} is not a finite number")));
        }
        if self.motion.numbers().iter().any(|&x| x < 0.0)
            || self.imu.gyro.quantum_rad_s < 0.0
            || self.imu.accel.quantum_m_s2 < 0.0
        {
            return Err(bad(
                "motion.* RMS figures and imu.*.quantum must not be negative".into(),
            ));
        }
        if self.imu.host_burst_s < 0.0 {
            return Err(bad(format!(
                "imu.host_burst_s {} must not be negative",
                self.imu.host_burst_s
            )));
        }
        if let Some(steel) = self.mag.as_ref().and_then(|m| m.steel) {
            if steel.radius_m <= 0.0 {
                return Err(bad(format!(
                    "mag.steel.radius_m {} must be above 0",
                    steel.radius_m
                )));
            }
        }
        let acoustic = [
            self.usbl.and_then(|u| u.problem()),
            self.lbl.as_ref().and_then(|l| l.problem()),
        ];
        if let Some(problem) = acoustic.into_iter().flatten().next() {
            return Err(bad(problem));
        }
        if let Some(d) = &self.dvl {
            if d.stamp_delay_s < 0.0 || d.correlated_m_s < 0.0 || d.correlation_s <= 0.0 {
                return Err(bad(format!(
                    "dvl.stamp_delay_s {} and dvl.correlated_m_s {} must not be negative, and \
                     dvl.correlation_s {} must be above 0",
                    d.stamp_delay_s, d.correlated_m_s, d.correlation_s
                )));
            }
        }
        self.check_flight().map_err(bad)?;
        if self.seabed.profile.is_empty()
            || self.seabed.profile.windows(2).any(|w| w[1][0] <= w[0][0])
        {
            return Err(bad(
                "seabed.profile needs points of increasing distance".into()
            ));
        }
        Ok(())
    }

    /// Kinematic or dynamic, consistently.
    fn check_flight(&self) -> Result<(), String> {
        let Some(d) = &self.dynamics else {
            if !self.phases.is_empty() {
                return Err("[[phase]] needs a [dynamics] section (vehicle, speed)".into());
            }
            if self.segments.is_empty() {
                return Err("no [[segment]]: a kinematic scenario needs at least one".into());
            }
            if self.fins.is_some() {
                return Err(
                    "[fins] needs a [dynamics] section: a kinematic trajectory has no fins".into(),
                );
            }
            if self.start.roll_deg != 0.0 || self.start.pitch_deg != 0.0 {
                return Err("start.roll_deg and start.pitch_deg need a [dynamics] section".into());
            }
            if self.rpm.is_some_and(|r| r.model.k_m_s_per_rpm <= 0.0) {
                return Err(
                    "rpm.k_m_s_per_rpm must be above 0 (it makes RPM from the speed)".into(),
                );
            }
            return Ok(());
        };
        if !self.segments.is_empty() {
            return Err(
                "[[segment]] and [dynamics] do not mix: a dynamic scenario flies [[phase]]s".into(),
            );
        }
        if self.phases.is_empty() {
            return Err("[dynamics] needs at least one [[phase]]".into());
        }
        if self.rpm.is_some_and(|r| r.model.k_m_s_per_rpm != 0.0) {
            return Err(
                "rpm.k_m_s_per_rpm: a dynamic scenario logs the propeller's own speed; remove it"
                    .into(),
            );
        }
        let positive = [
            ("dynamics.speed_m_s", d.speed_m_s),
            ("dynamics.max_vertical_rate_m_s", d.max_vertical_rate_m_s),
            ("dynamics.max_turn_rate_deg_s", d.max_turn_rate_deg_s),
        ];
        if let Some((name, v)) = positive.iter().find(|(_, v)| *v <= 0.0) {
            return Err(format!("{name} is {v}: it must be above 0"));
        }
        if !(0.0..=0.5).contains(&d.coef_uncertainty) {
            return Err(format!(
                "dynamics.coef_uncertainty {} must be in [0, 0.5] (a fraction: 0.1 = 10 %)",
                d.coef_uncertainty
            ));
        }
        for (i, p) in self.phases.iter().enumerate() {
            if let Some(problem) = p.problem() {
                return Err(format!("phase {} ({}): {problem}", i + 1, p.kind()));
            }
        }
        Ok(())
    }

    /// The truth trajectory of the segments (kinematic scenarios), checked first as a file
    /// is (a scenario may be built in code).
    pub fn trajectory(&self) -> Result<Trajectory, ScenarioError> {
        self.check()?;
        if self.dynamics.is_some() {
            return Err(ScenarioError::Invalid {
                name: self.name.clone(),
                reason: "a dynamic scenario has no kinematic trajectory".into(),
            });
        }
        let origin_lat = self.mission.origin_latitude_deg.to_radians();
        let lat = origin_lat + self.start.north_m / geodesy::meridian_radius_m(origin_lat);
        let lon = self.mission.origin_longitude_deg.to_radians()
            + self.start.east_m / (geodesy::prime_vertical_radius_m(origin_lat) * origin_lat.cos());
        let mut b = TrajectoryBuilder::new(
            lat.to_degrees(),
            lon.to_degrees(),
            self.start.depth_m,
            self.start.yaw_deg.to_radians(),
            self.start.speed_m_s,
        )
        .with_turn_rate(self.start.turn_rate_deg_s.to_radians());
        let wrap = |source| ScenarioError::Segment {
            name: self.name.clone(),
            source,
        };
        for seg in &self.segments {
            apply(&mut b, seg).map_err(wrap)?;
        }
        Ok(b.build(self.tail_s))
    }
}

fn apply(b: &mut TrajectoryBuilder, seg: &Segment) -> Result<(), SegmentError> {
    let r = f64::to_radians;
    match *seg {
        Segment::Cruise { duration_s } => {
            b.cruise(duration_s);
        }
        Segment::Speed { to_m_s, ramp_s } => {
            b.speed_to(to_m_s, ramp_s)?;
        }
        Segment::Turn {
            angle_deg,
            rate_deg_s,
            ramp_s,
        } => {
            b.turn(r(angle_deg), r(rate_deg_s), ramp_s)?;
        }
        Segment::Depth {
            to_m,
            pitch_deg,
            ramp_s,
        } => {
            b.depth_to(to_m, r(pitch_deg), ramp_s)?;
        }
        Segment::Surface { pitch_deg, ramp_s } => {
            b.depth_to(0.0, r(pitch_deg), ramp_s)?;
        }
        Segment::Spiral {
            angle_deg,
            rate_deg_s,
            to_m,
            pitch_deg,
            ramp_s,
        } => {
            b.spiral(r(angle_deg), r(rate_deg_s), to_m, r(pitch_deg), ramp_s)?;
        }
        Segment::Zigzag {
            legs,
            angle_deg,
            leg_s,
            rate_deg_s,
            ramp_s,
        } => {
            // First swing half the angle so the mean heading is kept.
            b.turn(
                r(angle_deg) / 2.0,
                r(rate_deg_s),
                ramp_s.min(angle_deg / 2.0 / rate_deg_s / 2.0),
            )?;
            let mut side = -1.0;
            for _ in 0..legs {
                b.cruise(leg_s);
                b.turn(side * r(angle_deg), r(rate_deg_s), ramp_s)?;
                side = -side;
            }
            b.turn(
                side * r(angle_deg) / 2.0,
                r(rate_deg_s),
                ramp_s.min(angle_deg / 2.0 / rate_deg_s / 2.0),
            )?;
        }
        Segment::Lawnmower {
            lanes,
            lane_s,
            rate_deg_s,
            ramp_s,
        } => {
            let mut side = 1.0;
            for lane in 0..lanes {
                b.cruise(lane_s);
                if lane + 1 < lanes {
                    b.turn(side * std::f64::consts::PI, r(rate_deg_s), ramp_s)?;
                    side = -side;
                }
            }
        }
        Segment::Hold { duration_s, ramp_s } => {
            let speed = b.speed_m_s();
            b.speed_to(0.0, ramp_s)?;
            b.cruise(duration_s);
            b.speed_to(speed, ramp_s)?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_built_in_scenario_parses_and_builds() {
        for (name, _) in BUILT_IN {
            let s = Scenario::built_in(name).unwrap_or_else(|e| panic!("{name}: {e}"));
            assert_eq!(&s.name, name);
            let duration_s = match crate::sim::dynamic::from_scenario(&s, 1, 0.01) {
                Ok(Some(flight)) => crate::sim::truth::TruthSource::duration_s(&flight.truth),
                Ok(None) => s.trajectory().map(|t| t.duration_s()).unwrap(),
                Err(e) => panic!("{name}: {e}"),
            };
            assert!(duration_s > 60.0, "{name}");
        }
        assert!(matches!(
            Scenario::built_in("nope"),
            Err(ScenarioError::Unknown { .. })
        ));
    }

    #[test]
    fn host_bursts_and_steel_are_checked() {
        let text = BUILT_IN
            .iter()
            .find(|(n, _)| *n == "pool-mems-host")
            .unwrap()
            .1;
        for (from, to) in [
            ("host_burst_s = 0.075", "host_burst_s = -0.075"),
            ("radius_m = 4.0", "radius_m = 0.0"),
            ("radius_m = 4.0", "radius_m = nan"),
        ] {
            assert!(text.contains(from), "{from}");
            assert!(
                matches!(
                    Scenario::from_toml(&text.replacen(from, to, 1)),
                    Err(ScenarioError::Invalid { .. })
                ),
                "{to}"
            );
        }
    }

    #[test]
    fn seabed_profile_interpolates() {
        let s = SeabedSpec {
            bearing_deg: 90.0,
            profile: vec![[0.0, 50.0], [100.0, 150.0]],
        };
        assert!((s.depth_m(0.0, 50.0) - 100.0).abs() < 1e-9);
        assert_eq!(s.depth_m(0.0, -10.0), 50.0);
        assert_eq!(s.depth_m(0.0, 500.0), 150.0);
    }

    #[test]
    fn bad_segments_are_errors_not_panics() {
        let base = BUILT_IN
            .iter()
            .find(|(n, _)| *n == "survey-short")
            .unwrap()
            .1;
        for (from, to) in [
            ("to_m_s = 1.5\nramp_s = 20.0", "to_m_s = 1.5\nramp_s = 0.0"),
            (
                "to_m_s = 1.5\nramp_s = 20.0",
                "to_m_s = -1.0\nramp_s = 20.0",
            ),
            (
                "rate_deg_s = 3.0\nramp_s = 10.0",
                "rate_deg_s = 0.0\nramp_s = 10.0",
            ),
            (
                "pitch_deg = 10.0\nramp_s = 8.0",
                "pitch_deg = 0.0\nramp_s = 8.0",
            ),
        ] {
            assert!(base.contains(from), "{from}");
            let s = Scenario::from_toml(&base.replacen(from, to, 1)).unwrap();
            assert!(
                matches!(s.trajectory(), Err(ScenarioError::Segment { .. })),
                "{to}"
            );
        }
    }

    #[test]
    fn rejects_bad_rates_and_unknown_keys() {
        let text = Scenario::built_in("survey").map(|_| BUILT_IN[0].1).unwrap();
        let bad = text.replacen("rate_hz = 100", "rate_hz = 0", 1);
        assert!(matches!(
            Scenario::from_toml(&bad),
            Err(ScenarioError::Invalid { .. })
        ));
        for (from, to, says) in [
            ("noise_nt = 100.0", "noise_nt = nan", "mag.noise_nt is not"),
            ("lane_s = 500.0", "lane_s = inf", "segment[4].lane_s is not"),
        ] {
            let err = Scenario::from_toml(&text.replacen(from, to, 1)).unwrap_err();
            assert!(err.to_string().contains(says), "{err}");
        }
        // Dynamic scenarios: phases checked, and no mixing with kinematic segments.
        let zigzag = Scenario::built_in("zigzag-rudder-20-20")
            .map(|_| {
                BUILT_IN
                    .iter()
                    .find(|b| b.0 == "zigzag-rudder-20-20")
                    .unwrap()
                    .1
            })
            .unwrap();
        for (from, to, says) in [
            (
                "trigger_deg = 20.0",
                "trigger_deg = 0.0",
                "phase 2 (rudder-zigzag): trigger_deg 0",
            ),
            (
                "duration_s = 300.0",
                "duration_s = -1.0",
                "phase 2 (rudder-zigzag): duration_s -1",
            ),
            (
                "speed_m_s = 1.5\n",
                "speed_m_s = 0.0\n",
                "dynamics.speed_m_s is 0",
            ),
            (
                "[[phase]]",
                "[[segment]]\ntype = \"cruise\"\nduration_s = 1.0\n\n[[phase]]",
                "do not mix",
            ),
        ] {
            assert!(zigzag.contains(from), "{from}");
            let err = Scenario::from_toml(&zigzag.replacen(from, to, 1)).unwrap_err();
            assert!(err.to_string().contains(says), "{err}");
        }
        let unknown = format!("{text}\nbogus = 1\n");
        assert!(matches!(
            Scenario::from_toml(&unknown),
            Err(ScenarioError::Parse(_))
        ));
    }
}
