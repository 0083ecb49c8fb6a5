//! Settings of a reconstruction (the section `reconstruct` of the one configuration system,
//! [`crate::config`]), with a default for every key. `hindsight config reconstruct` prints
//! [`DEFAULT_TOML`], the one place every key is documented; a test checks that it parses
//! to [`Config::default`].
//!
//! The IMU's noise comes from a grade (typical data-sheet figures of the class), any value
//! of which a key overrides.

use crate::config::keyed;
use crate::config::{all, check_ranges, ConfigError, Range, Section};
use crate::filters::ins::aid_table::{Aiding, RpmVelocity, Sensor};
use crate::filters::ins::driver::{Propagation, Settings};
use crate::filters::ins::forward::{DvlMounting, Filter, ImuNoise};
use crate::filters::velocity::rpm::RpmFilter;
use crate::recon::on_off_auto::Switch;
use serde::{Deserialize, Serialize};

/// The default configuration, with the documentation of every key.
pub const DEFAULT_TOML: &str = r#"# hindsight reconstruct: configuration (every key optional; these are the defaults).

[imu]
# Grade of the IMU: "navigation" (0.01 deg/h gyro), "intermediate" (0.1 deg/h),
# "tactical" (1 deg/h) or "mems" (10 deg/h). Sets the values below that are not given.
# Not given (and [tune] on), the IMU's noise is estimated from the log; given, it is kept.
# grade = "tactical"
# Any of these overrides the grade's value (1-sigma):
# gyro_bias_deg_h = 1.0               # turn-on bias (initial uncertainty of the estimate)
# gyro_bias_instability_deg_h = 0.1   # bias wander over bias_correlation_s
# gyro_arw_deg_rt_h = 0.05            # angle random walk
# accel_bias_ug = 100.0
# accel_bias_instability_ug = 20.0
# accel_vrw_ug_rt_hz = 30.0           # velocity random walk
# bias_correlation_s = 3600.0
# gyro_scale_ppm = 100.0              # z gyro's scale factor error (estimated: a turn leaves
                                      # this times the angle turned in the heading); grades:
                                      # navigation 5, intermediate 30, tactical 100, MEMS 3000
estimate_biases = true     # false: the gyro and accelerometer biases and the gyro's scale
                           # factor are carried in the covariance but never estimated (a
                           # pure SDINS, as seed 000 compares against)

[dvl]
use = true
# sigma_m_s = 0.015        # per axis, white noise plus what scale and bias errors add
                           # (not given: estimated from the log, see [tune])
# max_altitude_m = 100.0   # readings above this altitude are out of range and not used (not
                           # given: 100, or the largest altitude the DVL reported with a
                           # bottom lock in the log when that is larger: a long-range DVL)
altimeter_max_age_s = 2.0  # a reading without altitude is checked against the echo
                           # sounder's (/altimeter) latest altitude of at most this age
check_range = true         # false: use every reading, even without bottom lock or out of
                           # range (to see what trusting a bad DVL costs; not for real use)
# lever_arm_m = [1.0, 0.0, 0.3]   # DVL position from the IMU, body FRD, m. Not given:
                            # estimated from the IMU's rates and the DVL (in turns and pitch
                            # changes its point moves with omega x l), and used when it is
                            # clear (summary.json `plan`); else 0
rotation_deg = [0.0, 0.0, 0.0]    # DVL axes from body axes: roll, pitch, yaw (Z-Y-X)
# stamp_delay_s = 0.3       # how late the DVL stamps a reading after it measured it, s
                            # (negative: early). Not given: estimated from the IMU and the
                            # DVL before any filter runs, and used when it is clear (the plan
                            # says which, summary.json `plan`); 0 when a clock offset moves the
                            # DVL's topic
# The DVL's calibration estimated with the trajectory (summary.json `dvl_calibration`):
# scale factor, misalignment in pitch and heading beyond rotation_deg, and a bias along each
# of its axes, from these prior sigmas. 0 holds one at zero. The bias is always estimated.
# The scale and misalignment are estimated where the log makes them observable ("auto": the
# plan decides, summary.json `plan`): absolute positions (GNSS, fixes) far enough apart that
# these priors would move them by more than their sigmas. Elsewhere they are held: without
# such positions they would only drift and widen the uncertainty.
scale_misalignment = "auto"       # true / false: estimate them, or hold them, whatever the log
scale_sigma = 0.005               # 1-sigma of the scale factor error (0.005 = 0.5 %)
misalignment_sigma_deg = 1.0      # 1-sigma of the mounting's pitch and heading error
held_misalignment_sigma_deg = 0.3 # held (not estimated): the heading misalignment's 1-sigma
                                  # that, with scale_sigma, widens the reported horizontal
                                  # position sigma (scale_sigma of the distance from the
                                  # start along the track, this across it); a real AUV's DVL:
                                  # 0.3-0.8 % and 0.2 deg. 0: not added
bias_sigma_m_s = 0.001            # 1-sigma of the bias, per axis (data sheets: +-0.1 cm/s)
# bias_walk_m_s_rt_h = 0.1        # random walk of the bias, per axis, m/s/sqrt(h): a DVL
                                  # error correlated in time (bottom type, beam geometry);
                                  # sigma s over correlation time T is about s sqrt(2/T).
                                  # Not given: 0, or the tuning's choice of 0.03, 0.1, 0.3
                                  # where it makes the innovations clearly more likely
# bias_correlation_s = 60.0       # with a walk: the bias is first-order Gauss-Markov with
                                  # this correlation time (its sigma walk sqrt(T/2)), so it
                                  # stays bounded; 0: a random walk. Not given: 0, or the
                                  # tuning's choice where the innovations show it
# "estimate": the forward filter estimates them. "consider": carried as consider states
# (Schmidt-Kalman), never corrected, so the uncertainty they cause grows honestly where
# nothing can tell them; it costs accuracy (the other states' gains allow for them).
calibration = "estimate"

[depth]
use = true
# sigma_m = 0.1            # white noise of a reading (not given: estimated, see [tune])
bias_sigma_m = 0.1         # constant offset of the sensor (zero point, water density): with
                           # depth the only vertical reference it cannot be estimated, so it
                           # is added to the reported depth uncertainty (a "consider" term)
min_interval_s = 0.1       # a faster depth sensor is decimated to this interval

[eml]
use = true
# sigma_m_s = 0.05         # white noise of a reading (not given:
                           # estimated, see [tune])
# The EM log reads the speed through the water, the DVL over the ground: the EM log's scale
# error and the water current (north, east) are estimated with the trajectory where both
# are present (summary.json `water`); without the DVL they stay near these priors.
scale_sigma = 0.02         # 1-sigma of the EM log's scale factor error (2 %)
current_sigma_m_s = 0.2    # 1-sigma of the water current, per horizontal axis
current_walk_m_s_rt_h = 0.05  # how fast the current changes (random walk), m/s/sqrt(h)

[mag]
use = true                 # the magnetometer (/mag) for the initial heading and as an aid
use_as_aid = true          # false: the initial heading only, no heading updates
sigma_deg = 2.0            # heading error of the calibrated magnetometer (deviation, field,
                           # declination), 1-sigma
correlation_s = 60.0       # that error's correlation time: the updates within it share one
                           # sigma (each update's sigma is sigma_deg sqrt(correlation_s /
                           # min_interval_s)), so a slow error is not averaged away
uncalibrated_correlation_s = 600.0  # the correlation when the readings could not be
                           # calibrated (too few headings) yet their magnitude varies with
                           # the heading (a hard iron): their deviation then holds as long as
                           # the heading does (a survey lane)
min_interval_s = 1.0       # at most one heading update per interval
max_field_deviation = 0.15 # a reading whose magnitude is off the log's median by more than
                           # this fraction is a disturbed field and is not used
calibrate = true           # hard and soft iron fitted to the log's readings when it turns
                           # through enough headings (27 of 36 ten-degree sectors)
saturation_repeats = 3     # an axis at its extreme this many readings in a row is saturated

[rpm_velocity]
# Seed 003's velocity filter: the forward speed from the propeller (/rpm) as sf rpm + b,
# sf and b learnt from the DVL's forward speed while it is in range; while it is out (no
# reading in range for dvl_timeout_s), that speed is a body-velocity aid [V, 0, 0].
# "auto": used when the log has /rpm and the DVL has gaps (the plan, summary.json `plan`);
# it refuses itself when its checks fail (propeller stuck, speed not told by the propeller).
use = "auto"
speed_sigma_floor_m_s = 0.02  # least scatter of the speed about the relation (the scatter
                              # itself is learnt from the log's DVL)
max_speed_sigma_m_s = 0.25    # a larger learnt scatter: the propeller does not tell the speed
lateral_sigma_m_s = 0.1       # sway and heave, taken as zero
dvl_timeout_s = 1.0
min_interval_s = 1.0          # at most one speed per interval
min_dvl_updates = 50          # DVL readings learnt from before the speed is used

[model_velocity]
# Seed 000's model-aided velocity filter: the vehicle's 6-DOF model, driven by /fins, /rpm
# and the navigation's attitude, runs beside the vehicle; a 7-state EKF estimates its depth,
# velocity and rate errors from the depth sensor, the EM log, the gyro and the DVL, and the
# corrected body velocity is a body-velocity aid while the DVL is out. Needs /fins, /rpm
# and a vehicle file (the mission's `vehicle` when built in, or `vehicle` here). "auto":
# used whenever those are present (the plan); refused when the model does not fit.
use = "auto"
method = "proposed"           # or "virtual-sensor": the model's velocity as it is (Koifman
                              # and Bar-Itzhack), the baseline seed 000 improves on
vehicle = ""                  # a built-in vehicle (nps-auv-ii, remus-100) or a vehicle file;
                              # empty: the mission's vehicle
correlation_s = 30.0          # the aid's error is correlated over this time: each update's
                              # covariance is the filter's times correlation_s / min_interval_s
min_interval_s = 1.0          # at most one velocity per interval
dvl_timeout_s = 1.0           # without a DVL reading in range for this long, the DVL is out
max_nis = 3.0                 # a mean NIS per dimension of the filter's DVL and EM-log
                              # updates above this: the model does not fit the vehicle, and
                              # the aid is not used (with a warning)

[gnss]
use = true                 # sigma from each fix's horizontal_sigma_m

[position_fix]
use = true                 # sigma from each fix's sigma_m

[acoustic_fix]
# Positioned acoustic fixes (/acoustic_fix: a USBL's or an LBL system's latitude and
# longitude), each applied at its time of validity: its stamp when the fix says so, else its
# stamp less its received_after_s, else less receipt_delay_s. Gated; a run of refused fixes
# reopens the gate only when the fixes follow one smooth track (see [gate]).
use = true
# receipt_delay_s = 2.0      # how long after its time of validity the ship received a fix
                             # that carries no delay, s. Not given: estimated from the log
                             # (the fixes against a forward pass without them; see the plan)
slant_range_fraction = 0.01  # a fix without a sigma: this fraction of its slant range from the
                             # ship (/ship_pose) ...
sigma_floor_m = 0.5          # ... and at least this, m
sigma_without_ship_m = 5.0   # a fix without a sigma and without the ship's position, m
lever_arm_m = [0.0, 0.0, 0.0]  # the transponder on the vehicle from the IMU, body FRD, m

[usbl]
# Ship-relative USBL observations (/usbl: range, bearing and elevation in the axes of the
# ship's transducer) placed by the ship's pose (/ship_pose), each an update at its time of
# validity, found as the acoustic fixes' is ([acoustic_fix] receipt_delay_s; the transponder
# is [acoustic_fix] lever_arm_m). The errors of the ship's position, heading and tilt are in
# each observation's noise: a heading error grows with the horizontal range.
use = true
range_fraction = 0.002       # a range without a sigma: this fraction of it ...
range_sigma_floor_m = 0.2    # ... and at least this, m
angle_sigma_deg = 0.2        # a bearing or an elevation without a sigma, deg
transducer_lever_arm_m = [0.0, 0.0, 0.0]    # the transducer from the point the ship's
                                            # position is of, ship body FRD, m
transducer_alignment_deg = [0.0, 0.0, 0.0]  # the transducer's axes in the ship's: roll,
                                            # pitch, yaw (Z-Y-X), deg
ship_position_sigma_m = 1.0  # the ship's horizontal position where its pose carries none, m
ship_height_sigma_m = 0.5    # the transducer's height (the ship's heave), m
ship_heading_sigma_deg = 0.1 # the ship's heading where its pose carries none, deg
ship_heading_correlation_s = 10.0  # how long the ship's heading error lasts (a Gauss-Markov
                             # correlation time), s: observations closer together than this
                             # share it, and each is taken to tell that much less
ship_tilt_sigma_deg = 0.05   # the ship's roll and pitch, deg
ship_max_gap_s = 5.0         # ship poses further apart than this are not interpolated, s

[lbl]
# Ranges to the seabed beacons of a long-baseline network (/lbl), tightly coupled: each range
# is an update at its time of validity (half its two-way travel time before its stamp), and
# the speed of sound the ranges were converted with is corrected by a state of the filter.
# The beacons' places: the log's `beacons` record, or the table below (which wins per id).
use = true
range_sigma_m = 0.5          # a range that carries no sigma, m
sound_speed_m_s = 1500.0     # converts a travel time that carries no speed of sound, m/s
sound_speed_sigma = 0.005    # prior 1-sigma of the speed of sound's scale (0.005: 0.5 %)
lever_arm_m = [0.0, 0.0, 0.0]  # the LBL transceiver on the vehicle from the IMU, body FRD, m
# beacons = [{ id = "A", latitude_deg = 35.098, longitude_deg = 129.048, depth_m = 80.0 }]

[gate]
# Chi-square innovation gate: a consistent measurement passes with this probability;
# a rejected one is counted and recorded in residuals.parquet. 1.0 disables the gate.
probability = 0.999
# After this many rejections in a row of one sensor, its next measurement is applied
# ungated: a filter that has drifted must not lock its aiding out (0: never). Only when
# those rejected readings agree with each other and the reading is no exact repeat of the
# one before: an erratic or stuck sensor stays out.
reset_after = 20

[propagation]
covariance_interval_s = 0.1   # longest step of the covariance between epochs
imu_gap_s = 0.1               # a longer IMU interval is a gap (bridged, covariance grown)
gap_accel_m_s2_rt_hz = 0.05   # extra noise over a gap: motion nobody measured
gap_gyro_deg_s_rt_hz = 0.3

[initial]
# Heading source: "auto" (every source available, combined by their sigmas: gyrocompass
# when the IMU is good enough, magnetometer, the mission's initial_yaw_rad, yaw_deg), or one
# of "gyrocompass", "magnetometer", "mission", "given" (that one alone). Either way, the
# in-motion alignment then checks it against the log (see [alignment]).
heading = "auto"
# yaw_deg = 45.0             # a heading given by hand (also on the command line)
# declination_deg = -7.8     # magnetic declination, east positive, -180..180 (also
                             # on the command line; else the mission's magnetic_declination_deg,
                             # else the World Magnetic Model, or IGRF-14 before 2020, at
                             # the start's place and date)
window_s = 30.0              # IMU data averaged for levelling and gyrocompassing
gyrocompass_max_sigma_deg = 1.0   # gyrocompass only when its predicted error is smaller
magnetometer_sigma_deg = 3.0      # heading error of a magnetometer (deviation, field)
mission_yaw_sigma_deg = 10.0      # of the mission's initial_yaw_rad
given_yaw_sigma_deg = 5.0         # of yaw_deg
in_run = true                # without DVL readings at the start but with /rpm: seed 002's
                             # in-run alignment of roll and pitch once the vehicle is stable
# set_depth_m = 30.0         # the depth the vehicle is sent to (its stability test);
                             # else the median depth of the first two minutes
in_run_sigma_deg = 0.2       # roll/pitch 1-sigma of the in-run alignment
# rpm_speed_m_s_per_rpm = 0.0015  # forward speed per propeller rev/min; else the mission
                             # vehicle's steady speed at that rpm (built-in vehicles)
gnss_window_s = 10.0          # a GNSS fix this soon after the start sets the position
origin_sigma_m = 20.0         # position sigma when starting at the mission origin
from_truth = false            # simulated logs only (Monte Carlo studies): start from /truth
                              # with errors drawn with the sigmas below (seed 000's Table 2)
truth_position_sigma_m = [10.0, 10.0, 1.0]      # north, east, down
truth_velocity_sigma_m_s = 0.1
truth_attitude_sigma_arcmin = [0.01, 0.01, 0.03]  # roll, pitch, yaw
truth_seed = 0                # seed of the drawn errors (a study uses the run's seed)

[alignment]
# In-motion alignment: a bank of heading hypotheses spread over 360 deg, each a full forward
# filter over the first span_s of the mission, scored by the likelihood of its innovations.
# A decisive winner other than the initial heading replaces it (smoothed back to the start);
# otherwise the span grows threefold up to the whole log.
use = true
hypotheses = 12
first_span_s = 300.0
hint_outlier_probability = 0.01   # prior probability that the initial heading is wrong
decisive_weight = 0.99            # posterior weight a hypothesis needs to decide
found_sigma_floor_deg = 5.0       # least start sigma of a heading found this way with a
                                  # gyro that cannot see the Earth's rate (its bias over the
                                  # horizontal Earth rate above 1 deg: MEMS, most tactical);
                                  # the found heading then rests on the aiding's pattern, and
                                  # its smoothed sigma on a linearisation that may not hold.
                                  # Either way the sigma is sqrt(2) times the smoothed one at
                                  # least (the forward pass uses the span's data again)

[tune]
# Self-tuning: the noise figures the configuration does not give are estimated from the
# log. The white noise of the DVL, depth sensor and EM log from the scatter of consecutive
# readings; the IMU's noise by maximum likelihood of the filter's innovations over the
# first span_s of the mission (candidate grades, then each of gyro and accelerometer scaled
# by 3 while the likelihood improves). Figures the configuration gives are kept.
use = true
span_s = 1800.0            # the IMU is tuned on the mission's first span_s seconds
settle_s = 300.0           # a start heading found in motion: the innovations of the span's
                           # first settle_s (at most a third of it) are not scored (they
                           # re-fit that heading)
dvl_bias_walk = "auto"     # choose [dvl] bias_walk_m_s_rt_h (0.03, 0.1, 0.3) by the
                           # likelihood before the IMU's refinements, so that a DVL error
                           # correlated in time is not blamed on the IMU. "auto": when the
                           # IMU grades navigation or intermediate (a MEMS or tactical IMU's
                           # own unmodelled errors, misalignment above all, would be soaked
                           # up by it: honest sigmas, larger errors); true / false: always,
                           # never
dvl_bias_correlation = false  # with a walk chosen, also choose a correlation time for it
                           # ([dvl] bias_correlation_s: 30, 120 or 600 s) by the likelihood.
                           # Off: on auv-at-sea seeds 1-10 the choice (often 30 s for a true
                           # 60 s) did not beat the plain walk (docs/methods/
                           # self-tuning.md, "The DVL error as Gauss-Markov")

[output]
rate_hz = 10.0             # trajectory rows per second (per solution)
aiding_epochs = false      # also a row at every aiding measurement's epoch

[topics]
# The topic of each role, where neither the contract's default topic (/imu, /dvl, ...) nor
# the message type tells (two topics of one type): the role's name, then its topic. Roles: imu, mag,
# dvl, eml, depth, altimeter, rpm, fins, attitude, gnss, position_fix, truth, acoustic_fix,
# usbl, ship_pose, lbl.
# imu = "/vehicle/imu/data"

[frames]
# A ROS 2 topic's frame convention where its frame_id misleads: "rep103" (body FLU, world
# ENU: converted) or "native" (body FRD, world NED: kept). Not given: from the frame_id
# (a body frame ending in _frd or a world frame ending in _ned is native).
# "/dvl/twist" = "native"

[ros2]
# How ROS 2 messages become the contract's.
water_density_kg_m3 = 1025.0      # FluidPressure to depth (sea water; fresh water 997)
atmospheric_pressure_pa = 101325.0  # FluidPressure is absolute: this is the surface
gravity_m_s2 = 9.80665
gnss_sigma_unknown_m = 5.0        # 1-sigma of a NavSatFix without a covariance
point_fix_sigma_m = 1.0           # 1-sigma of a PointStamped position fix (it has none)
acoustic_stamp_is_validity = false  # an acoustic fix's (GeoPointStamped) header stamp is
                                    # its time of validity; false: the time the ship
                                    # received it (the delay is then estimated)

[mission]
# What stands in for a log without a `mission` record (a ROS 2 recording): the origin of
# the local frame (not given: the first GNSS fix), the vehicle and the declination.
# origin_latitude_deg = 35.1
# origin_longitude_deg = 129.05
# vehicle = "remus-100"
# magnetic_declination_deg = -8.0
"#;

/// Grade of an IMU.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ImuGrade {
    /// Ring-laser or fibre-optic navigation grade: 0.01 deg/h gyro, 25 ug accelerometer.
    Navigation,
    /// Between navigation and tactical: 0.1 deg/h, 100 ug.
    Intermediate,
    /// Tactical: 1 deg/h gyro, 100 ug accelerometer.
    Tactical,
    /// MEMS AHRS: 10 deg/h, 1 mg.
    Mems,
}

/// The noise of an IMU, data-sheet units.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ImuSpec {
    pub gyro_bias_deg_h: f64,
    pub gyro_bias_instability_deg_h: f64,
    pub gyro_arw_deg_rt_h: f64,
    pub accel_bias_ug: f64,
    pub accel_bias_instability_ug: f64,
    pub accel_vrw_ug_rt_hz: f64,
    pub bias_correlation_s: f64,
    /// 1-sigma of the z gyro's scale factor error, ppm (an error state: each turn leaves a
    /// heading error of this times the angle turned).
    pub gyro_scale_ppm: f64,
}

impl ImuGrade {
    /// Typical data-sheet figures of the class.
    pub fn spec(self) -> ImuSpec {
        let (gb, gbi, arw, ab, abi, vrw, scale) = match self {
            ImuGrade::Navigation => (0.01, 0.003, 0.002, 25.0, 5.0, 5.0, 5.0),
            ImuGrade::Intermediate => (0.1, 0.01, 0.0125, 100.0, 10.0, 6.5, 30.0),
            ImuGrade::Tactical => (1.0, 0.1, 0.05, 100.0, 20.0, 30.0, 100.0),
            ImuGrade::Mems => (10.0, 3.0, 0.3, 1000.0, 100.0, 100.0, 3000.0),
        };
        ImuSpec {
            gyro_bias_deg_h: gb,
            gyro_bias_instability_deg_h: gbi,
            gyro_arw_deg_rt_h: arw,
            accel_bias_ug: ab,
            accel_bias_instability_ug: abi,
            accel_vrw_ug_rt_hz: vrw,
            bias_correlation_s: 3600.0,
            gyro_scale_ppm: scale,
        }
    }
}

const DEG_H: f64 = std::f64::consts::PI / 180.0 / 3600.0;
const UG: f64 = 9.80665e-6;

impl ImuSpec {
    /// The filter's noise densities: white noise, and bias random walks that reach the bias
    /// instability over the correlation time (`sigma sqrt(2 / tau)`).
    pub fn noise(&self) -> ImuNoise {
        let walk = (2.0 / self.bias_correlation_s).sqrt();
        ImuNoise {
            gyro_noise_density: self.gyro_arw_deg_rt_h.to_radians() / 60.0,
            accel_noise_density: self.accel_vrw_ug_rt_hz * UG,
            gyro_bias_walk: self.gyro_bias_instability_deg_h * DEG_H * walk,
            accel_bias_walk: self.accel_bias_instability_ug * UG * walk,
        }
    }

    /// Initial 1-sigma of the gyro bias, rad/s.
    pub fn gyro_bias_rad_s(&self) -> f64 {
        self.gyro_bias_deg_h * DEG_H
    }

    /// Initial 1-sigma of the z gyro's scale factor error (a fraction).
    pub fn gyro_scale(&self) -> f64 {
        self.gyro_scale_ppm * 1e-6
    }

    /// Initial 1-sigma of the accelerometer bias, m/s^2.
    pub fn accel_bias_m_s2(&self) -> f64 {
        self.accel_bias_ug * UG
    }
}

crate::config::with_defaults! {
    #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
    #[serde(deny_unknown_fields, default)]
    pub struct ImuConfig {
        pub grade: ImuGrade = ImuGrade::Tactical,
        pub gyro_bias_deg_h: Option<f64> = None,
        pub gyro_bias_instability_deg_h: Option<f64> = None,
        pub gyro_arw_deg_rt_h: Option<f64> = None,
        pub accel_bias_ug: Option<f64> = None,
        pub accel_bias_instability_ug: Option<f64> = None,
        pub accel_vrw_ug_rt_hz: Option<f64> = None,
        pub bias_correlation_s: Option<f64> = None,
        pub gyro_scale_ppm: Option<f64> = None,
        /// False: the biases and the gyro's scale factor are consider states (in the covariance,
        /// never estimated).
        pub estimate_biases: bool = true,
    }
}

impl ImuConfig {
    /// The grade's figures with the overrides applied.
    pub fn spec(&self) -> ImuSpec {
        let g = self.grade.spec();
        ImuSpec {
            gyro_bias_deg_h: self.gyro_bias_deg_h.unwrap_or(g.gyro_bias_deg_h),
            gyro_bias_instability_deg_h: self
                .gyro_bias_instability_deg_h
                .unwrap_or(g.gyro_bias_instability_deg_h),
            gyro_arw_deg_rt_h: self.gyro_arw_deg_rt_h.unwrap_or(g.gyro_arw_deg_rt_h),
            accel_bias_ug: self.accel_bias_ug.unwrap_or(g.accel_bias_ug),
            accel_bias_instability_ug: self
                .accel_bias_instability_ug
                .unwrap_or(g.accel_bias_instability_ug),
            accel_vrw_ug_rt_hz: self.accel_vrw_ug_rt_hz.unwrap_or(g.accel_vrw_ug_rt_hz),
            bias_correlation_s: self.bias_correlation_s.unwrap_or(g.bias_correlation_s),
            gyro_scale_ppm: self.gyro_scale_ppm.unwrap_or(g.gyro_scale_ppm),
        }
    }
}

crate::config::with_defaults! {
    #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
    #[serde(deny_unknown_fields, default)]
    pub struct DvlConfig {
        #[serde(rename = "use")]
        pub enabled: bool = true,
        pub sigma_m_s: f64 = 0.015,
        pub max_altitude_m: f64 = 100.0,
        pub altimeter_max_age_s: f64 = 2.0,
        pub check_range: bool = true,
        pub lever_arm_m: [f64; 3] = [0.0; 3],
        pub rotation_deg: [f64; 3] = [0.0; 3],
        /// How late the DVL stamps a reading after it measured it, s.
        pub stamp_delay_s: f64 = 0.0,
        /// Whether the scale and misalignment are estimated (else held at zero).
        pub scale_misalignment: Switch = Switch::Auto,
        pub scale_sigma: f64 = 0.005,
        pub misalignment_sigma_deg: f64 = 1.0,
        /// 1-sigma of a held heading misalignment, deg: with `scale_sigma`, what a held scale and
        /// misalignment add to the reported position sigma ([`crate::recon::held_dvl`]).
        pub held_misalignment_sigma_deg: f64 = 0.3,
        pub bias_sigma_m_s: f64 = 0.001,
        pub bias_walk_m_s_rt_h: f64 = 0.0,
        /// Correlation time of the bias, s (0: a random walk).
        pub bias_correlation_s: f64 = 0.0,
        pub calibration: CalibrationMode = CalibrationMode::Estimate,
    }
}

/// How the DVL's calibration states with a non-zero prior are used.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum CalibrationMode {
    /// Estimated by the forward filter (needs fixes to be observable).
    #[default]
    Estimate,
    /// Consider states: carried in the covariance (the uncertainty they cause grows
    /// honestly) but never corrected by the forward filter.
    Consider,
}

impl DvlConfig {
    pub fn mounting(&self) -> DvlMounting {
        DvlMounting::from_config(self.lever_arm_m, self.rotation_deg)
    }

    /// Prior 1-sigma of the calibration states: scale, misalignment pitch and heading (rad),
    /// bias along the DVL's three axes (m/s). The scale and misalignment are zero (held)
    /// unless `scale_misalignment` is on.
    pub fn calibration_sigma(&self) -> [f64; 6] {
        let on = self.scale_misalignment.is_on();
        let m = if on {
            self.misalignment_sigma_deg.to_radians()
        } else {
            0.0
        };
        let sf = if on { self.scale_sigma } else { 0.0 };
        let b = self.bias_sigma_m_s.hypot(self.correlated_sigma_m_s());
        [sf, m, m, b, b, b]
    }

    /// Steady 1-sigma of a Gauss-Markov bias, `walk sqrt(tau / 2)`, m/s (0 for a random walk):
    /// the correlated error is already there when the log starts, so the bias's prior holds
    /// it too (a filter sure of a zero bias reads a 1 cm/s sideways error as 0.3 deg of
    /// heading at 2 m/s).
    pub fn correlated_sigma_m_s(&self) -> f64 {
        if self.bias_correlation_s > 0.0 {
            self.bias_walk_m_s_rt_h / 60.0 * (self.bias_correlation_s / 2.0).sqrt()
        } else {
            0.0
        }
    }

    /// The error states carried as consider states.
    pub fn considered(&self) -> [bool; crate::filters::ins::error_state::N] {
        let mut considered = [false; crate::filters::ins::error_state::N];
        if self.calibration == CalibrationMode::Consider {
            let at = crate::filters::ins::error_state::idx::DVL;
            for (k, sigma) in self.calibration_sigma().iter().enumerate() {
                considered[at + k] = *sigma > 0.0;
            }
        }
        considered
    }
}

crate::config::with_defaults! {
    #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
    #[serde(deny_unknown_fields, default)]
    pub struct DepthConfig {
        #[serde(rename = "use")]
        pub enabled: bool = true,
        pub sigma_m: f64 = 0.1,
        pub bias_sigma_m: f64 = 0.1,
        pub min_interval_s: f64 = 0.1,
    }
}

crate::config::with_defaults! {
    #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
    #[serde(deny_unknown_fields, default)]
    pub struct MagConfig {
        #[serde(rename = "use")]
        pub enabled: bool = true,
        pub use_as_aid: bool = true,
        pub sigma_deg: f64 = 2.0,
        pub correlation_s: f64 = 60.0,
        pub uncalibrated_correlation_s: f64 = 600.0,
        pub min_interval_s: f64 = 1.0,
        pub max_field_deviation: f64 = 0.15,
        pub calibrate: bool = true,
        pub saturation_repeats: usize = 3,
    }
}

impl MagConfig {
    /// 1-sigma of one heading update, rad: the error's sigma spread over the updates within
    /// its correlation time (the longer one when the readings' deviation is unknown).
    pub fn update_sigma_rad(&self, deviation_unknown: bool) -> f64 {
        let correlation_s = if deviation_unknown {
            self.uncalibrated_correlation_s
        } else {
            self.correlation_s
        };
        let per_correlation = (correlation_s / self.min_interval_s).max(1.0);
        self.sigma_deg.to_radians() * per_correlation.sqrt()
    }
}

crate::config::with_defaults! {
    #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
    #[serde(deny_unknown_fields, default)]
    pub struct EmlConfig {
        #[serde(rename = "use")]
        pub enabled: bool = true,
        pub sigma_m_s: f64 = 0.05,
        pub scale_sigma: f64 = 0.02,
        pub current_sigma_m_s: f64 = 0.2,
        pub current_walk_m_s_rt_h: f64 = 0.05,
    }
}

crate::config::with_defaults! {
    /// A sensor that is used or not.
    #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
    #[serde(deny_unknown_fields, default)]
    pub struct UseConfig {
        #[serde(rename = "use")]
        pub enabled: bool = true,
    }
}

crate::config::with_defaults! {
    /// Positioned acoustic fixes.
    #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
    #[serde(deny_unknown_fields, default)]
    pub struct AcousticFixConfig {
        #[serde(rename = "use")]
        pub enabled: bool = true,
        /// Receipt less validity of the fixes stamped on receipt that carry no delay, s
        /// (estimated unless given: [`Config::fixed`]).
        pub receipt_delay_s: f64 = 0.0,
        pub slant_range_fraction: f64 = 0.01,
        pub sigma_floor_m: f64 = 0.5,
        pub sigma_without_ship_m: f64 = 5.0,
        pub lever_arm_m: [f64; 3] = [0.0; 3],
    }
}

impl AcousticFixConfig {
    /// The aid's settings, when it is used.
    pub fn aid(&self) -> Option<crate::filters::ins::acoustic::AcousticAiding> {
        self.enabled
            .then_some(crate::filters::ins::acoustic::AcousticAiding {
                receipt_delay_s: self.receipt_delay_s,
                slant_range_fraction: self.slant_range_fraction,
                sigma_floor_m: self.sigma_floor_m,
                sigma_without_ship_m: self.sigma_without_ship_m,
                lever_arm_body_m: self.lever_arm_m,
            })
    }
}

crate::config::with_defaults! {
    /// Ship-relative USBL observations.
    #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
    #[serde(deny_unknown_fields, default)]
    pub struct UsblConfig {
        #[serde(rename = "use")]
        pub enabled: bool = true,
        pub range_fraction: f64 = 0.002,
        pub range_sigma_floor_m: f64 = 0.2,
        pub angle_sigma_deg: f64 = 0.2,
        pub transducer_lever_arm_m: [f64; 3] = [0.0; 3],
        pub transducer_alignment_deg: [f64; 3] = [0.0; 3],
        pub ship_position_sigma_m: f64 = 1.0,
        pub ship_height_sigma_m: f64 = 0.5,
        pub ship_heading_sigma_deg: f64 = 0.1,
        pub ship_heading_correlation_s: f64 = 10.0,
        pub ship_tilt_sigma_deg: f64 = 0.05,
        pub ship_max_gap_s: f64 = 5.0,
    }
}

impl UsblConfig {
    /// The aid's settings, when it is used: the receipt delay and the transponder are the
    /// acoustic fixes' (one acoustic system on one vehicle); the delay only where it is
    /// known ([`Config::acoustic_delay_known`]).
    pub fn aid(
        &self,
        fixes: &AcousticFixConfig,
        delay_known: bool,
    ) -> Option<crate::filters::ins::usbl::UsblAiding> {
        self.enabled
            .then_some(crate::filters::ins::usbl::UsblAiding {
                receipt_delay_s: delay_known.then_some(fixes.receipt_delay_s),
                range_fraction: self.range_fraction,
                range_sigma_floor_m: self.range_sigma_floor_m,
                angle_sigma_rad: self.angle_sigma_deg.to_radians(),
                transducer_lever_arm_m: self.transducer_lever_arm_m,
                transducer_alignment_rad: self.transducer_alignment_deg.map(f64::to_radians),
                ship_position_sigma_m: self.ship_position_sigma_m,
                ship_height_sigma_m: self.ship_height_sigma_m,
                ship_heading_sigma_rad: self.ship_heading_sigma_deg.to_radians(),
                ship_heading_correlation_s: self.ship_heading_correlation_s,
                ship_tilt_sigma_rad: self.ship_tilt_sigma_deg.to_radians(),
                ship_max_gap_s: self.ship_max_gap_s,
                lever_arm_body_m: fixes.lever_arm_m,
            })
    }
}

crate::config::with_defaults! {
    /// Ranges to LBL beacons.
    #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
    #[serde(deny_unknown_fields, default)]
    pub struct LblConfig {
        #[serde(rename = "use")]
        pub enabled: bool = true,
        pub range_sigma_m: f64 = 0.5,
        pub sound_speed_m_s: f64 = 1500.0,
        pub sound_speed_sigma: f64 = 0.005,
        pub lever_arm_m: [f64; 3] = [0.0; 3],
        /// Beacons' places; each wins over the log's of its id.
        pub beacons: Vec<crate::contract::Beacon> = Vec::new(),
    }
}

impl LblConfig {
    /// The aid's settings, when it is used.
    pub fn aid(&self) -> Option<crate::filters::ins::lbl::LblAiding> {
        self.enabled.then_some(crate::filters::ins::lbl::LblAiding {
            range_sigma_m: self.range_sigma_m,
            sound_speed_m_s: self.sound_speed_m_s,
            lever_arm_body_m: self.lever_arm_m,
        })
    }
}

crate::config::with_defaults! {
    /// The propeller's velocity filter's settings; the defaults are the filter's own.
    #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
    #[serde(deny_unknown_fields, default)]
    pub struct RpmVelocityConfig {
        #[serde(rename = "use")]
        pub enabled: Switch = Switch::Auto,
        pub speed_sigma_floor_m_s: f64 = RpmFilter::default().speed_sigma_floor_m_s,
        pub max_speed_sigma_m_s: f64 = RpmFilter::default().max_speed_sigma_m_s,
        pub lateral_sigma_m_s: f64 = 0.1,
        pub dvl_timeout_s: f64 = RpmFilter::default().dvl_timeout_s,
        pub min_interval_s: f64 = RpmFilter::default().min_interval_s,
        pub min_dvl_updates: usize = RpmFilter::default().min_dvl_updates,
    }
}

impl RpmVelocityConfig {
    /// The aid, or `None` when not used.
    pub fn aid(&self) -> Option<RpmVelocity> {
        self.enabled.is_on().then(|| RpmVelocity {
            filter: RpmFilter {
                speed_sigma_floor_m_s: self.speed_sigma_floor_m_s,
                max_speed_sigma_m_s: self.max_speed_sigma_m_s,
                dvl_timeout_s: self.dvl_timeout_s,
                min_interval_s: self.min_interval_s,
                min_dvl_updates: self.min_dvl_updates,
                ..RpmFilter::default()
            },
            lateral_sigma_m_s: self.lateral_sigma_m_s,
        })
    }
}

crate::config::with_defaults! {
    #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
    #[serde(deny_unknown_fields, default)]
    pub struct GateConfig {
        pub probability: f64 = 0.999,
        pub reset_after: usize = 20,
    }
}

crate::config::with_defaults! {
    #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
    #[serde(deny_unknown_fields, default)]
    pub struct PropagationConfig {
        pub covariance_interval_s: f64 = 0.1,
        pub imu_gap_s: f64 = 0.1,
        pub gap_accel_m_s2_rt_hz: f64 = 0.05,
        pub gap_gyro_deg_s_rt_hz: f64 = 0.3,
    }
}

/// Where the initial heading comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum HeadingChoice {
    Auto,
    Gyrocompass,
    Magnetometer,
    Mission,
    Given,
}

crate::config::with_defaults! {
    #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
    #[serde(deny_unknown_fields, default)]
    pub struct InitialConfig {
        pub heading: HeadingChoice = HeadingChoice::Auto,
        pub yaw_deg: Option<f64> = None,
        pub declination_deg: Option<f64> = None,
        pub window_s: f64 = 30.0,
        pub gyrocompass_max_sigma_deg: f64 = 1.0,
        pub magnetometer_sigma_deg: f64 = 3.0,
        pub mission_yaw_sigma_deg: f64 = 10.0,
        pub given_yaw_sigma_deg: f64 = 5.0,
        pub in_run: bool = true,
        pub set_depth_m: Option<f64> = None,
        pub in_run_sigma_deg: f64 = 0.2,
        pub rpm_speed_m_s_per_rpm: Option<f64> = None,
        pub gnss_window_s: f64 = 10.0,
        pub origin_sigma_m: f64 = 20.0,
        /// Monte Carlo studies of simulated logs: start from `/truth` with errors drawn with
        /// these sigmas (seed 000's Table 2), instead of from the sensors.
        pub from_truth: bool = false,
        pub truth_position_sigma_m: [f64; 3] = [10.0, 10.0, 1.0],
        pub truth_velocity_sigma_m_s: f64 = 0.1,
        pub truth_attitude_sigma_arcmin: [f64; 3] = [0.01, 0.01, 0.03],
        /// Seed of the drawn start errors (a study sets it to the run's seed).
        pub truth_seed: u64 = 0,
    }
}

crate::config::with_defaults! {
    #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
    #[serde(deny_unknown_fields, default)]
    pub struct AlignmentConfig {
        #[serde(rename = "use")]
        pub enabled: bool = true,
        pub hypotheses: usize = 12,
        pub first_span_s: f64 = 300.0,
        pub hint_outlier_probability: f64 = 0.01,
        pub decisive_weight: f64 = 0.99,
        pub found_sigma_floor_deg: f64 = 5.0,
    }
}

crate::config::with_defaults! {
    #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
    #[serde(deny_unknown_fields, default)]
    pub struct OutputConfig {
        pub rate_hz: f64 = 10.0,
        pub aiding_epochs: bool = false,
    }
}

crate::config::with_defaults! {
    #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
    #[serde(deny_unknown_fields, default)]
    pub struct TuneConfig {
        #[serde(rename = "use")]
        pub enabled: bool = true,
        pub span_s: f64 = 1800.0,
        /// With a start heading the in-motion alignment found, the innovations of the span's
        /// first `settle_s` (at most a third of the span) are left out of each candidate's score.
        pub settle_s: f64 = 300.0,
        /// Whether the DVL bias's random walk is chosen by the likelihood (when not given).
        pub dvl_bias_walk: Switch = Switch::Auto,
        /// Whether the walk's correlation time is also chosen by the likelihood (when not given).
        pub dvl_bias_correlation: bool = false,
    }
}

/// The settings estimated from the log (self-tuning, the plan), as dotted keys. A configuration that gives one keeps
/// it (see [`Config::fixed`]).
pub const TUNABLE_KEYS: [&str; 17] = [
    "imu.grade",
    "imu.gyro_bias_deg_h",
    "imu.gyro_bias_instability_deg_h",
    "imu.gyro_arw_deg_rt_h",
    "imu.accel_bias_ug",
    "imu.accel_bias_instability_ug",
    "imu.accel_vrw_ug_rt_hz",
    "imu.bias_correlation_s",
    "dvl.sigma_m_s",
    "depth.sigma_m",
    "eml.sigma_m_s",
    "dvl.max_altitude_m",
    "dvl.bias_walk_m_s_rt_h",
    "dvl.bias_correlation_s",
    "dvl.stamp_delay_s",
    "dvl.lever_arm_m",
    "acoustic_fix.receipt_delay_s",
];

/// Everything a reconstruction can be told.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Config {
    pub imu: ImuConfig,
    pub dvl: DvlConfig,
    pub depth: DepthConfig,
    pub eml: EmlConfig,
    pub mag: MagConfig,
    pub rpm_velocity: RpmVelocityConfig,
    pub model_velocity: ModelVelocityConfig,
    pub gnss: UseConfig,
    pub position_fix: UseConfig,
    pub acoustic_fix: AcousticFixConfig,
    pub usbl: UsblConfig,
    pub lbl: LblConfig,
    pub gate: GateConfig,
    pub propagation: PropagationConfig,
    pub initial: InitialConfig,
    pub alignment: AlignmentConfig,
    pub tune: TuneConfig,
    pub output: OutputConfig,
    /// Topics named for roles (role -> topic).
    pub topics: std::collections::BTreeMap<String, String>,
    /// ROS 2 topics' frame conventions where the frame_id misleads.
    pub frames: std::collections::BTreeMap<String, crate::ingest::ros::map::Convention>,
    pub ros2: crate::ingest::ros::map::RosSettings,
    pub mission: crate::ingest::MissionDefaults,
    /// The tunable keys ([`TUNABLE_KEYS`]) the configuration gave: kept as given.
    #[serde(skip)]
    pub fixed: std::collections::BTreeSet<String>,
    /// The reconstruction placed the acoustic receipt delay (estimated it from the log, or
    /// found it could not): the USBL's raw observations stamped on receipt take
    /// `acoustic_fix.receipt_delay_s` as given.
    #[serde(skip)]
    pub acoustic_delay_placed: bool,
}

impl Config {
    /// Whether the acoustic receipt delay is known: given, or placed by the reconstruction.
    pub fn acoustic_delay_known(&self) -> bool {
        self.acoustic_delay_placed || self.fixed.contains("acoustic_fix.receipt_delay_s")
    }

    /// Whether the configuration uses the sensor (its section's `use`).
    pub fn uses(&self, sensor: Sensor) -> bool {
        match sensor {
            Sensor::Dvl => self.dvl.enabled,
            Sensor::Depth => self.depth.enabled,
            Sensor::Gnss => self.gnss.enabled,
            Sensor::SpeedLog => self.eml.enabled,
            Sensor::PositionFix => self.position_fix.enabled,
            Sensor::AcousticFix => self.acoustic_fix.enabled,
            Sensor::Lbl => self.lbl.enabled,
            Sensor::Usbl => self.usbl.enabled,
            Sensor::Magnetometer => self.mag.enabled,
            Sensor::RpmVelocity => self.rpm_velocity.enabled.is_on(),
            Sensor::ModelVelocity => self.model_velocity.enabled.is_on(),
        }
    }
}

crate::config::with_defaults! {
    #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
    #[serde(deny_unknown_fields, default)]
    pub struct ModelVelocityConfig {
        #[serde(rename = "use")]
        pub enabled: Switch = Switch::Auto,
        pub method: ModelMethod = ModelMethod::Proposed,
        pub vehicle: String = String::new(),
        /// The vehicle file `vehicle` names, read by the caller: the library reads no files.
        /// `None` for a built-in vehicle.
        #[serde(skip)]
        pub vehicle_file: Option<crate::vehicle::six_dof::description::Vehicle> = None,
        pub correlation_s: f64 = 30.0,
        pub min_interval_s: f64 = 1.0,
        pub dvl_timeout_s: f64 = 1.0,
        pub max_nis: f64 = 3.0,
    }
}

/// Which velocity the model aid hands on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ModelMethod {
    Proposed,
    VirtualSensor,
}

impl Section for Config {
    const NAME: &'static str = "reconstruct";
    const DEFAULT_TOML: &'static str = DEFAULT_TOML;

    /// Checks ranges (positive sigmas and intervals, a probability in (0, 1]): the first key
    /// out of its range is the error.
    fn check(&self) -> Result<(), ConfigError> {
        check_ranges(
            all(Range::Positive, self.positive())
                .chain(all(Range::NonNegative, self.non_negative()))
                .chain(self.other_ranges()),
        )?;
        match self.lbl.beacons.iter().find_map(|b| b.problem()) {
            Some(reason) => Err(ConfigError::Bad {
                key: "lbl.beacons",
                value: None,
                reason,
            }),
            None => Ok(()),
        }
    }

    /// The tunable keys ([`TUNABLE_KEYS`]) the file gives are kept as given.
    fn given(&mut self, keys: &std::collections::BTreeSet<String>) {
        self.fixed = TUNABLE_KEYS
            .iter()
            .filter(|key| keys.contains(**key))
            .map(|key| key.to_string())
            .collect();
    }
}

impl Config {
    /// The keys that must be positive numbers.
    fn positive(&self) -> Vec<(&'static str, f64)> {
        let spec = self.imu.spec();
        [
            &keyed!(self.alignment => alignment; first_span_s, found_sigma_floor_deg)[..],
            &keyed!(self.mag => mag;
                sigma_deg, correlation_s, uncalibrated_correlation_s, min_interval_s,
                max_field_deviation),
            &keyed!(self.rpm_velocity => rpm_velocity;
                speed_sigma_floor_m_s, max_speed_sigma_m_s, lateral_sigma_m_s, dvl_timeout_s,
                min_interval_s),
            &keyed!(self.model_velocity => model_velocity;
                correlation_s, min_interval_s, dvl_timeout_s, max_nis),
            &keyed!(spec => imu;
                gyro_bias_deg_h, gyro_arw_deg_rt_h, accel_bias_ug, accel_vrw_ug_rt_hz,
                bias_correlation_s),
            &keyed!(self.dvl => dvl; sigma_m_s, max_altitude_m),
            &keyed!(self.depth => depth; sigma_m),
            &keyed!(self.eml => eml; sigma_m_s),
            &keyed!(self.lbl => lbl; sound_speed_m_s),
            &keyed!(self.usbl => usbl; ship_max_gap_s),
            &keyed!(self.propagation => propagation; covariance_interval_s, imu_gap_s),
            &keyed!(self.initial => initial;
                window_s, magnetometer_sigma_deg, given_yaw_sigma_deg, origin_sigma_m),
            &keyed!(self.output => output; rate_hz),
            &keyed!(self.tune => tune; span_s),
        ]
        .concat()
    }

    /// The keys that must be zero or positive.
    fn non_negative(&self) -> Vec<(&'static str, f64)> {
        let spec = self.imu.spec();
        [
            &keyed!(spec => imu; gyro_scale_ppm)[..],
            &keyed!(self.tune => tune; settle_s),
            &keyed!(self.eml => eml; scale_sigma, current_sigma_m_s, current_walk_m_s_rt_h),
            &keyed!(self.acoustic_fix => acoustic_fix;
                slant_range_fraction, sigma_floor_m, sigma_without_ship_m),
            &keyed!(self.lbl => lbl; range_sigma_m, sound_speed_sigma),
            &keyed!(self.usbl => usbl;
                range_fraction, range_sigma_floor_m, angle_sigma_deg, ship_position_sigma_m,
                ship_height_sigma_m, ship_heading_sigma_deg, ship_heading_correlation_s,
                ship_tilt_sigma_deg),
            &keyed!(self.dvl => dvl;
                altimeter_max_age_s, scale_sigma, misalignment_sigma_deg,
                held_misalignment_sigma_deg, bias_sigma_m_s, bias_walk_m_s_rt_h,
                bias_correlation_s),
            &keyed!(spec => imu; gyro_bias_instability_deg_h, accel_bias_instability_ug),
            &keyed!(self.depth => depth; min_interval_s, bias_sigma_m),
            &keyed!(self.propagation => propagation; gap_accel_m_s2_rt_hz, gap_gyro_deg_s_rt_hz),
        ]
        .concat()
    }

    /// The keys with a range of their own.
    fn other_ranges(&self) -> Vec<(&'static str, f64, Range)> {
        let mut out = vec![
            (
                "dvl.stamp_delay_s",
                self.dvl.stamp_delay_s,
                Range::Within(-60.0, 60.0, "must be a delay in seconds, -60 to 60"),
            ),
            (
                "acoustic_fix.receipt_delay_s",
                self.acoustic_fix.receipt_delay_s,
                Range::Within(0.0, 60.0, "must be a delay in seconds, 0 to 60"),
            ),
        ];
        if let Some(d) = self.initial.declination_deg {
            out.push((
                "initial.declination_deg",
                d,
                Range::Within(
                    -180.0,
                    180.0,
                    "must be a declination in degrees, -180 to 180 (east positive)",
                ),
            ));
        }
        out.extend([
            (
                "alignment.hint_outlier_probability",
                self.alignment.hint_outlier_probability,
                Range::OpenProbability,
            ),
            (
                "alignment.decisive_weight",
                self.alignment.decisive_weight,
                Range::OpenProbability,
            ),
            (
                "alignment.hypotheses",
                self.alignment.hypotheses as f64,
                Range::AtLeast(4.0, "must be 4 or more"),
            ),
            (
                "mag.saturation_repeats",
                self.mag.saturation_repeats as f64,
                Range::AtLeast(2.0, "must be 2 or more"),
            ),
            (
                "gate.probability",
                self.gate.probability,
                Range::Probability,
            ),
        ]);
        out
    }

    /// The error states carried as consider states: the DVL's calibration (its `calibration`
    /// mode), and the IMU's biases and scale factor when they are not to be estimated.
    pub fn considered(&self) -> [bool; crate::filters::ins::error_state::N] {
        use crate::filters::ins::error_state::idx;
        let mut considered = self.dvl.considered();
        if !self.imu.estimate_biases {
            for i in (idx::GYRO_BIAS..idx::ACCEL_BIAS + 3).chain([idx::GYRO_SCALE_Z]) {
                considered[i] = true;
            }
        }
        considered
    }

    /// The forward filter's settings.
    pub fn settings(&self) -> Settings {
        let noise = self.imu.spec().noise();
        let p = &self.propagation;
        Settings {
            filter: Filter {
                noise,
                height_damping: None,
                current_walk: self.eml.current_walk_m_s_rt_h / 60.0,
                dvl_bias_walk: self.dvl.bias_walk_m_s_rt_h / 60.0,
                dvl_bias_correlation_s: (self.dvl.bias_correlation_s > 0.0)
                    .then_some(self.dvl.bias_correlation_s),
                considered: self.considered(),
            },
            propagation: Propagation {
                covariance_interval_s: p.covariance_interval_s,
                imu_gap_s: p.imu_gap_s,
                gap_noise: ImuNoise {
                    gyro_noise_density: p.gap_gyro_deg_s_rt_hz.to_radians(),
                    accel_noise_density: p.gap_accel_m_s2_rt_hz,
                    gyro_bias_walk: 0.0,
                    accel_bias_walk: 0.0,
                },
            },
            aiding: Aiding {
                dvl_sigma_m_s: self.dvl.sigma_m_s,
                dvl_max_altitude_m: self.dvl.max_altitude_m,
                dvl_check_range: self.dvl.check_range,
                altimeter_max_age_s: self.dvl.altimeter_max_age_s,
                dvl_mounting: self.dvl.mounting(),
                depth_sigma_m: self.depth.sigma_m,
                depth_min_interval_s: self.depth.min_interval_s,
                eml_sigma_m_s: self.eml.enabled.then_some(self.eml.sigma_m_s),
                // Set by the reconstruction, which knows the declination and the field.
                mag: None,
                rpm_velocity: self.rpm_velocity.aid(),
                acoustic: self.acoustic_fix.aid(),
                lbl: self.lbl.aid(),
                usbl: self
                    .usbl
                    .aid(&self.acoustic_fix, self.acoustic_delay_known()),
                gate_probability: (self.gate.probability < 1.0).then_some(self.gate.probability),
                gate_reset_after: self.gate.reset_after,
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_commented_override_is_a_known_key() {
        // The commented-out examples, uncommented, must parse too.
        let uncommented: String = DEFAULT_TOML
            .lines()
            .map(|l| match l.strip_prefix("# ") {
                Some(rest) if rest.contains(" = ") && !rest.starts_with(' ') => rest,
                _ => l,
            })
            .map(|l| format!("{l}\n"))
            .collect();
        let c = Config::from_toml(&uncommented).unwrap();
        assert_eq!(c.initial.yaw_deg, Some(45.0));
        assert_eq!(c.lbl.beacons[0].depth_m, 80.0);
        assert_eq!(c.initial.declination_deg, Some(-7.8));
        assert_eq!(c.imu.gyro_bias_deg_h, Some(1.0));
        assert_eq!(c.topics["imu"], "/vehicle/imu/data");
        assert_eq!(
            c.frames["/dvl/twist"],
            crate::ingest::ros::map::Convention::Native
        );
        assert_eq!(c.mission.origin_longitude_deg, Some(129.05));
    }

    /// Every key a range names is a key of the file, and a value out of the range is
    /// refused naming it.
    #[test]
    fn every_range_names_its_own_key() {
        let c = Config::default();
        for (key, _) in c.positive().into_iter().chain(c.non_negative()) {
            let (section, name) = key.split_once('.').unwrap();
            let e = Config::from_toml(&format!("[{section}]\n{name} = -1.0\n")).unwrap_err();
            assert!(
                e.to_string().contains(&format!("`{key}` = -1")),
                "{key}: {e}"
            );
        }
    }

    #[test]
    fn bad_settings_name_the_key() {
        let e = Config::from_toml("[imu]\ngrade = \"consumer\"\n").unwrap_err();
        assert!(e.to_string().contains("grade"), "{e}");
        let e = Config::from_toml("[gate]\nprobability = 1.5\n").unwrap_err();
        assert!(e.to_string().contains("gate.probability"), "{e}");
    }

    #[test]
    fn the_figures_a_configuration_gives_are_fixed() {
        assert!(Config::from_toml(DEFAULT_TOML).unwrap().fixed.is_empty());
        let c =
            Config::from_toml("[imu]\naccel_bias_ug = 50.0\n[dvl]\nsigma_m_s = 0.02\nuse = true\n")
                .unwrap();
        let fixed: Vec<&str> = c.fixed.iter().map(String::as_str).collect();
        assert_eq!(fixed, ["dvl.sigma_m_s", "imu.accel_bias_ug"]);
    }

    #[test]
    fn grade_overrides_apply() {
        let c =
            Config::from_toml("[imu]\ngrade = \"navigation\"\ngyro_bias_deg_h = 0.002\n").unwrap();
        let s = c.imu.spec();
        assert_eq!(s.gyro_bias_deg_h, 0.002);
        assert_eq!(s.accel_bias_ug, ImuGrade::Navigation.spec().accel_bias_ug);
        // 0.05 deg/sqrt(h) = 0.05 / 60 deg/sqrt(s).
        let n = ImuGrade::Tactical.spec().noise();
        assert!((n.gyro_noise_density - 0.05f64.to_radians() / 60.0).abs() < 1e-15);
    }
}
