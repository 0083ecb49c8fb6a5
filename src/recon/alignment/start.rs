//! The initial estimate from what the log has, and which source gave each part.
//!
//! - Position: a GNSS fix near the start (the one closest to the median of those within
//!   `gnss_window_s`), else a `start` position fix near the
//!   start, else the first acoustic fix (or raw USBL observation placed by the ship's pose)
//!   that two of the next four agree with, else the mission origin. Depth from the first
//!   depth reading.
//! - Roll and pitch at the first sample: the specific force over the first `window_s` of IMU
//!   data, each sample carried to the start's body axes by the gyro, less the acceleration
//!   the DVL saw (carried the same way), levelled. A vehicle that rolls or turns during the
//!   window (a drop) is levelled as it was at the start.
//! - Heading (`recon::alignment::heading`): every source, combined by sigma (`auto`) or the one forced:
//!   gyrocompassing when the IMU's predicted gyrocompass error is below
//!   `gyrocompass_max_sigma_deg`, the vehicle is not turning and its level axes held still
//!   (moving base: the transport rate from the DVL velocity is removed); the magnetometer
//!   (its readings carried to the start by the gyro, tilt-compensated, with the declination
//!   given, from the mission, or from the World Magnetic Model or IGRF-14); the mission's
//!   `initial_yaw_rad`; a heading given by hand.
//! - Velocity: the first DVL reading in range, else the EM log's speed along the body x
//!   axis, else at rest.
//! - Biases: zero, with the IMU grade's turn-on sigma.
//!
use super::carry::Carry;
use super::heading::combine;
pub use super::heading::{DeclinationSource, DeclinationUsed, HeadingCandidate, HeadingSource};
use crate::contract::{GnssFix, Truth};
use crate::filters::ins::acoustic::{valid_fixes, AcousticAiding, ValidFix};
use crate::filters::ins::error_state::{idx, ErrorMatrix, ErrorState};
use crate::filters::ins::forward::{DvlMounting, Estimate};
use crate::filters::ins::mechanization::NavState;
use crate::filters::ins::usbl::{UsblAid, UsblAiding};
use crate::geodesy;
use crate::ingest::Mission;
use crate::recon::alignment::at_rest;
use crate::recon::config::{HeadingChoice, ImuSpec, InitialConfig};
use crate::recon::Streams;
use nalgebra::{UnitQuaternion, Vector3};
use std::fmt;

/// What the initialisation needs to know besides the log.
#[derive(Clone, Copy)]
pub struct InitSettings<'a> {
    pub initial: &'a InitialConfig,
    pub imu: ImuSpec,
    pub dvl_max_altitude_m: f64,
    pub dvl_sigma_m_s: f64,
    /// Random walk of the DVL's correlated error, m/s/sqrt(s) (0: none).
    pub dvl_bias_walk_m_s_rt_s: f64,
    pub dvl_mounting: DvlMounting,
    /// Prior 1-sigma of the DVL's calibration states (scale, misalignment pitch and heading
    /// rad, bias m/s).
    pub dvl_calibration_sigma: [f64; 6],
    /// Prior 1-sigma of the EM log's scale error and of the current north and east (m/s).
    pub water_sigma: [f64; 3],
    /// Prior 1-sigma of the speed of sound's scale (of the acoustic ranges).
    pub sound_speed_scale_sigma: f64,
    pub depth_sigma_m: f64,
    /// Forward speed (m/s) for a propeller reading (rev/min), when known: seed 002's in-run
    /// alignment needs it.
    pub speed_of_rpm: Option<&'a dyn Fn(f64) -> f64>,
    /// How acoustic fixes are placed in time and weighted (`None`: they are not used).
    pub acoustic: Option<AcousticAiding>,
    /// How the USBL's raw observations are placed (`None`: they are not used).
    pub usbl: Option<UsblAiding>,
}

/// Where the initial position came from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PositionSource {
    Gnss {
        stamp_ns: i64,
    },
    StartFix {
        stamp_ns: i64,
    },
    /// An acoustic fix at its time of validity.
    AcousticFix {
        stamp_ns: i64,
    },
    MissionOrigin,
    /// `/truth` with drawn errors (a Monte Carlo study).
    Truth,
}

/// Where the initial velocity came from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum VelocitySource {
    Dvl {
        stamp_ns: i64,
    },
    SpeedLog {
        stamp_ns: i64,
    },
    /// The propeller's speed (the configured gain, or the vehicle model's steady speed).
    Propeller {
        stamp_ns: i64,
    },
    AtRest,
    /// `/truth` with drawn errors (a Monte Carlo study).
    Truth,
}

/// The initial estimate and its sources, with their 1-sigma.
#[derive(Debug, Clone, PartialEq)]
pub struct Initialisation {
    /// The independent variances the covariance was built from.
    pub variances: ErrorState,
    /// Whether the velocity was measured along the body axes (its NED error then follows the
    /// heading's).
    pub body_velocity: bool,
    pub estimate: Estimate,
    pub position: PositionSource,
    pub position_sigma_m: f64,
    pub velocity: VelocitySource,
    pub velocity_sigma_m_s: f64,
    /// The source of the heading used (`Combined` when several were).
    pub heading: HeadingSource,
    pub heading_sigma_deg: f64,
    /// Every heading source with its value and sigma, and whether it was used.
    pub heading_sources: Vec<HeadingCandidate>,
    /// Why the other sources gave no heading.
    pub heading_unavailable: Vec<String>,
    /// Sources that disagree beyond their sigmas (warnings).
    pub heading_disagreements: Vec<crate::recon::alignment::heading::HeadingDisagreement>,
    /// Seed 002's in-run alignment, when it set the roll and pitch.
    pub in_run: Option<super::in_run::InRun>,
    /// The in-motion alignment's bank, when it ran.
    pub in_motion: Option<super::in_motion::InMotion>,
    /// The declination for the magnetometer (`None` without magnetometer readings).
    pub declination: Option<DeclinationUsed>,
    pub tilt_sigma_deg: f64,
    /// Stamp of the first IMU sample (the estimate's time), ns.
    pub estimate_stamp_ns: i64,
    /// Seconds of IMU data levelled (and gyrocompassed).
    pub window_s: f64,
}

/// Why no initial estimate could be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum InitError {
    #[error("no IMU data on /imu: a reconstruction needs the IMU")]
    NoImu,
    #[error("/imu has {0} sample(s): too few to initialise")]
    TooFewImu(usize),
    #[error(
        "no heading source ({0}), and the log does not determine the heading in motion: \
         the initial heading must be given ([initial] yaw_deg)"
    )]
    NoHeading(String),
    #[error("a start from /truth was asked for, but the log has no /truth (a simulated log's)")]
    NoTruth,
    #[error("heading source `{choice}` is not available: {reason}")]
    HeadingUnavailable {
        choice: &'static str,
        reason: String,
    },
}

/// The horizontal Earth rate must dominate the mean gyro for gyrocompassing: the vehicle
/// turns no faster than this multiple of the Earth rate during the window.
const STEADY_RATE_FACTOR: f64 = 2.0;

fn mean3(values: impl Iterator<Item = [f64; 3]>) -> Option<Vector3<f64>> {
    let (sum, n) = values.fold((Vector3::zeros(), 0usize), |(s, n), v| {
        (s + Vector3::from(v), n + 1)
    });
    (n > 0).then(|| sum / n as f64)
}

/// The IMU's first `window_s`: what the start is levelled (and gyrocompassed) from.
struct ImuWindow<'a> {
    window: &'a [crate::contract::Imu],
    /// Stamps of its first sample and of its end, ns.
    t0: i64,
    end_ns: i64,
    /// Seconds it spans.
    seconds: f64,
    f_mean: Vector3<f64>,
    w_mean: Vector3<f64>,
    /// Each sample's attitude relative to the start, by the gyro.
    carry: Carry,
}

impl<'a> ImuWindow<'a> {
    fn of(imu: &'a [crate::contract::Imu], window_s: f64) -> Result<Self, InitError> {
        let first = imu.first().ok_or(InitError::NoImu)?;
        if imu.len() < 2 {
            return Err(InitError::TooFewImu(imu.len()));
        }
        let t0 = first.stamp_ns;
        let end_ns = t0 + (window_s * 1e9) as i64;
        let window = &imu[..imu.partition_point(|m| m.stamp_ns <= end_ns)];
        Ok(ImuWindow {
            window,
            t0,
            end_ns,
            seconds: (window.last().map_or(t0, |m| m.stamp_ns) - t0) as f64 * 1e-9,
            f_mean: mean3(window.iter().map(|m| m.specific_force)).unwrap_or_default(),
            w_mean: mean3(window.iter().map(|m| m.angular_velocity)).unwrap_or_default(),
            carry: Carry::new(window),
        })
    }

    fn contains(&self, stamp_ns: i64) -> bool {
        stamp_ns >= self.t0 && stamp_ns <= self.end_ns
    }
}

/// The DVL's readings in range within the window, as body-axis velocities.
fn dvl_in_window(
    src: &Streams<'_>,
    set: &InitSettings<'_>,
    w: &ImuWindow<'_>,
) -> Vec<(i64, Vector3<f64>)> {
    let body_from_dvl = set.dvl_mounting.dvl_from_body.inverse();
    src.dvl
        .iter()
        .filter(|d| w.contains(d.stamp_ns))
        .filter(|d| d.valid && d.altitude.is_none_or(|h| h <= set.dvl_max_altitude_m))
        .map(|d| (d.stamp_ns, body_from_dvl * Vector3::from(d.velocity)))
        .collect()
}

/// The DVL's mean acceleration between its first and last readings from `from` to `to`,
/// when those are more than a second apart (else zero).
fn dvl_accel(dvl: &[(i64, Vector3<f64>)], from: i64, to: i64) -> Vector3<f64> {
    let mut inside = dvl.iter().filter(|d| d.0 >= from && d.0 <= to);
    let first = inside.next();
    match (first, inside.next_back().or(first)) {
        (Some(a), Some(b)) if b.0 - a.0 > 1_000_000_000 => {
            (b.1 - a.1) / ((b.0 - a.0) as f64 * 1e-9)
        }
        _ => Vector3::zeros(),
    }
}

/// Roll and pitch at the start: `f = a - g` in the body, so `-g = f - a`. Each sample is
/// carried to the start's body axes by the gyro, so that a vehicle rolling or turning in the
/// window is levelled as it was at the start: `q f = d(q v)/dt - g_b0` (q: start body from
/// body), so the mean of `q f` less the DVL's change of `q v` over its span is `-g` in the
/// start's axes.
fn carried_level(w: &ImuWindow<'_>, dvl: &[(i64, Vector3<f64>)]) -> (f64, f64) {
    let f_carried = mean3(
        w.window
            .iter()
            .zip(&w.carry.q)
            .map(|(m, q)| (q * Vector3::from(m.specific_force)).into()),
    )
    .unwrap_or(w.f_mean);
    let carried_accel = match (dvl.first(), dvl.last()) {
        (Some(a), Some(b)) if b.0 - a.0 > 1_000_000_000 => {
            (w.carry.at(b.0) * b.1 - w.carry.at(a.0) * a.1) / ((b.0 - a.0) as f64 * 1e-9)
        }
        _ => Vector3::zeros(),
    };
    at_rest::level(&(f_carried - carried_accel))
}

/// How fast the level axes turned during the window, rad/s, and the noise of that figure: the
/// tilt of its first third against its last (a rate there enters the gyrocompass's mean like
/// the Earth rate does). A change of acceleration between the thirds also tilts the levelled
/// vector: the DVL's is removed when it stands out of the DVL's noise.
fn level_rate(
    w: &ImuWindow<'_>,
    dvl: &[(i64, Vector3<f64>)],
    set: &InitSettings<'_>,
) -> (f64, f64) {
    let window = w.window;
    let third = window.len() / 3;
    let span_s = w.seconds * 2.0 / 3.0;
    let (a, b) = (&window[..third], &window[window.len() - third..]);
    let stamps = |p: &[crate::contract::Imu]| {
        p.first()
            .map_or((0, 0), |f| (f.stamp_ns, p.last().map_or(0, |l| l.stamp_ns)))
    };
    let ((a0, a1), (b0, b1)) = (stamps(a), stamps(b));
    let third_s = ((a1 - a0) as f64 * 1e-9).max(1e-3);
    let accel_change = dvl_accel(dvl, b0, b1) - dvl_accel(dvl, a0, a1);
    // Two DVL differences over a third each, differenced: the white noise of their four
    // readings, and the correlated error's drift over each third.
    let drift_m_s = set.dvl_bias_walk_m_s_rt_s * (2.0 * third_s).sqrt();
    let accel_noise = (2.0 * set.dvl_sigma_m_s).hypot(drift_m_s) / third_s;
    let (accel_change, accel_noise) = if accel_change.norm() > 3.0 * accel_noise {
        (accel_change, accel_noise)
    } else {
        (Vector3::zeros(), 0.0)
    };
    let tilt = |p: &[crate::contract::Imu], less: Vector3<f64>| {
        mean3(p.iter().map(|m| m.specific_force)).map(|f| at_rest::level(&(f - less)))
    };
    let rate = match (tilt(a, Vector3::zeros()), tilt(b, accel_change)) {
        (Some(x), Some(y)) if third > 0 && span_s > 0.0 => (y.0 - x.0).hypot(y.1 - x.1) / span_s,
        _ => 0.0,
    };
    // The accelerometer's noise on two means of a third each, differenced, and the DVL's
    // when its acceleration was removed.
    let accel_white = set.imu.noise().accel_noise_density / third_s.sqrt() * 2f64.sqrt();
    (
        rate,
        accel_white.hypot(accel_noise) / GRAVITY_M_S2 / span_s.max(1e-3),
    )
}

/// Gravity as the levelling's sigmas take it, m/s^2.
const GRAVITY_M_S2: f64 = 9.81;

/// Roll and pitch at the start with their 1-sigma (deg), and seed 002's in-run alignment
/// when it set them.
struct Levelling {
    roll: f64,
    pitch: f64,
    tilt_sigma_deg: f64,
    in_run: Option<super::in_run::InRun>,
}

/// Levels the start from the window, or, without the DVL but with a propeller, by the
/// in-run alignment (seed 002) once the vehicle is stable: the window's accelerations
/// cannot be removed from the levelling without the DVL.
fn levelling(
    src: &Streams<'_>,
    set: &InitSettings<'_>,
    w: &ImuWindow<'_>,
    dvl: &[(i64, Vector3<f64>)],
) -> Levelling {
    let (roll, pitch) = carried_level(w, dvl);
    let accel_tilt_deg = (set.imu.accel_bias_m_s2() / GRAVITY_M_S2).to_degrees();
    let motion_tilt_deg = if dvl.len() >= 2 { 0.1 } else { 0.5 };
    // The gyro's bias over the window turns the carried samples: half of it on average.
    let carry_deg = (set.imu.gyro_bias_rad_s() * w.seconds * 0.5).to_degrees();
    let levelled = Levelling {
        roll,
        pitch,
        tilt_sigma_deg: accel_tilt_deg.hypot(motion_tilt_deg).hypot(carry_deg),
        in_run: None,
    };
    let cfg = set.initial;
    let Some(speed) = set
        .speed_of_rpm
        .filter(|_| cfg.in_run && dvl.is_empty() && !src.rpm.is_empty())
    else {
        return levelled;
    };
    let set_depth_m = cfg.set_depth_m.unwrap_or_else(|| median_depth(src, w.t0));
    let aligned = super::in_run::align(
        src.imu,
        src.depth,
        src.rpm,
        set_depth_m,
        speed,
        1.0,
        GRAVITY_M_S2,
    );
    match aligned {
        Some(a) => Levelling {
            roll: a.start_roll_rad,
            pitch: a.start_pitch_rad,
            tilt_sigma_deg: accel_tilt_deg.hypot(cfg.in_run_sigma_deg),
            in_run: Some(a),
        },
        None => levelled,
    }
}

/// The start's position, its source and 1-sigma, and its depth with its 1-sigma.
struct StartPosition {
    lat: f64,
    lon: f64,
    source: PositionSource,
    sigma_m: f64,
    down_m: f64,
    down_sigma_m: f64,
}

/// Of the GNSS fixes near the start, the one closest to their median: one outlier among them
/// cannot place the start.
fn start_gnss(fixes: &[GnssFix], near_start: impl Fn(i64) -> bool) -> Option<&GnssFix> {
    let near: Vec<&GnssFix> = fixes.iter().filter(|g| near_start(g.stamp_ns)).collect();
    let median = |f: fn(&GnssFix) -> f64| {
        let mut v: Vec<f64> = near.iter().map(|g| f(g)).collect();
        v.sort_by(f64::total_cmp);
        v.get(v.len() / 2).copied().unwrap_or_default()
    };
    let (lat_m, lon_m) = (median(|g| g.latitude_deg), median(|g| g.longitude_deg));
    near.into_iter().min_by(|a, b| {
        let d = |g: &GnssFix| (g.latitude_deg - lat_m).hypot(g.longitude_deg - lon_m);
        d(a).total_cmp(&d(b))
    })
}

/// The acoustic fixes read for the start: the first this many within
/// [`ACOUSTIC_START_WINDOW_S`] of it ...
const ACOUSTIC_START_FIXES: usize = 5;
/// ... s.
const ACOUSTIC_START_WINDOW_S: f64 = 60.0;
/// The speed the vehicle may have moved at between the start and that fix when nothing
/// tells it, m/s.
const ACOUSTIC_START_SPEED_M_S: f64 = 1.0;

/// Of the first acoustic fixes after the start (at their times of validity), the earliest
/// that two others agree with (within three sigmas and the way the vehicle may have moved
/// between them): a multipath outlier among them cannot place the start.
fn start_acoustic_fix(src: &Streams<'_>, set: &InitSettings<'_>, t0: i64) -> Option<ValidFix> {
    let first: Vec<ValidFix> = acoustic_positions(src, set)
        .into_iter()
        .filter(|f| {
            let after_s = (f.stamp_ns - t0) as f64 * 1e-9;
            (0.0..=ACOUSTIC_START_WINDOW_S).contains(&after_s)
        })
        .take(ACOUSTIC_START_FIXES)
        .collect();
    let agree = |a: &ValidFix, b: &ValidFix| {
        let (north, east) = geodesy::local_north_east_m(a.lat_rad, a.lon_rad, b.lat_rad, b.lon_rad);
        let apart_s = ((a.stamp_ns - b.stamp_ns) as f64 * 1e-9).abs();
        north.hypot(east) <= 3.0 * a.sigma_m.hypot(b.sigma_m) + ACOUSTIC_START_SPEED_M_S * apart_s
    };
    first
        .iter()
        .find(|a| {
            first
                .iter()
                .filter(|b| b.stamp_ns != a.stamp_ns && agree(a, b))
                .count()
                >= 2
        })
        .copied()
}

/// The acoustic fixes and the USBL's raw observations placed by the ship's pose, in time
/// order.
fn acoustic_positions(src: &Streams<'_>, set: &InitSettings<'_>) -> Vec<ValidFix> {
    let mut positions = (set.acoustic.as_ref())
        .map(|a| valid_fixes(src.acoustic_fixes, src.ship, a))
        .unwrap_or_default();
    if let Some(a) = &set.usbl {
        positions.extend(UsblAid::new(src.usbl, src.ship, a).positioned_fixes());
        positions.sort_by_key(|f| f.stamp_ns);
    }
    positions
}

/// The start's position: a GNSS fix near the start, else a `start` position fix, else an
/// acoustic fix, else the mission origin; its depth from the first depth reading (else the
/// fix's, else 0).
fn start_position(
    src: &Streams<'_>,
    mission: &Mission,
    set: &InitSettings<'_>,
    w: &ImuWindow<'_>,
    speed_guess_m_s: f64,
) -> StartPosition {
    let cfg = set.initial;
    let origin = (
        mission.origin_latitude_deg.to_radians(),
        mission.origin_longitude_deg.to_radians(),
    );
    let t0 = w.t0;
    let near_start = |s: i64| ((s - t0) as f64 * 1e-9).abs() <= cfg.gnss_window_s;
    let start_fix = src
        .fixes
        .iter()
        .find(|f| f.label == "start" && near_start(f.stamp_ns));
    let (lat, lon, source, sigma_m) = if let Some(g) = start_gnss(src.gnss, near_start) {
        let late_s = ((g.stamp_ns - t0) as f64 * 1e-9).abs();
        (
            g.latitude_deg.to_radians(),
            g.longitude_deg.to_radians(),
            PositionSource::Gnss {
                stamp_ns: g.stamp_ns,
            },
            g.horizontal_sigma_m.hypot(speed_guess_m_s * late_s),
        )
    } else if let Some(f) = start_fix {
        let rn = geodesy::meridian_radius_m(origin.0);
        let re = geodesy::prime_vertical_radius_m(origin.0) * origin.0.cos();
        (
            origin.0 + f.north_m / rn,
            origin.1 + f.east_m / re,
            PositionSource::StartFix {
                stamp_ns: f.stamp_ns,
            },
            f.sigma_m.max(0.01),
        )
    } else if let Some(f) = start_acoustic_fix(src, set, t0) {
        let late_s = ((f.stamp_ns - t0) as f64 * 1e-9).abs();
        (
            f.lat_rad,
            f.lon_rad,
            PositionSource::AcousticFix {
                stamp_ns: f.stamp_ns,
            },
            f.sigma_m
                .hypot(speed_guess_m_s.max(ACOUSTIC_START_SPEED_M_S) * late_s),
        )
    } else {
        (
            origin.0,
            origin.1,
            PositionSource::MissionOrigin,
            cfg.origin_sigma_m,
        )
    };
    let (down_m, down_sigma_m) = match src.depth.iter().find(|d| w.contains(d.stamp_ns)) {
        Some(d) => (d.depth, set.depth_sigma_m),
        None => start_fix
            .and_then(|f| f.down_m.map(|d| (d, f.sigma_m)))
            .unwrap_or((0.0, 10.0)),
    };
    StartPosition {
        lat,
        lon,
        source,
        sigma_m,
        down_m,
        down_sigma_m,
    }
}

/// The start's velocity along the body axes (the heading is not needed for it), its source
/// and 1-sigma: the first DVL reading in range, else the EM log's speed along x, else the
/// propeller's speed, else at rest.
fn start_body_velocity(
    src: &Streams<'_>,
    set: &InitSettings<'_>,
    w: &ImuWindow<'_>,
    dvl: &[(i64, Vector3<f64>)],
) -> (Vector3<f64>, VelocitySource, f64) {
    if let Some(d) = dvl.first() {
        return (
            d.1,
            VelocitySource::Dvl { stamp_ns: d.0 },
            set.dvl_sigma_m_s.hypot(0.05),
        );
    }
    if let Some(e) = src.eml.iter().find(|e| w.contains(e.stamp_ns)) {
        return (
            Vector3::new(e.speed, 0.0, 0.0),
            VelocitySource::SpeedLog {
                stamp_ns: e.stamp_ns,
            },
            0.1 + 0.05 * e.speed,
        );
    }
    let propeller = set.speed_of_rpm.and_then(|f| {
        let p = src.rpm.iter().find(|p| w.contains(p.stamp_ns))?;
        Some((p, f(p.rpm)))
    });
    match propeller {
        Some((p, speed)) => (
            Vector3::new(speed, 0.0, 0.0),
            VelocitySource::Propeller {
                stamp_ns: p.stamp_ns,
            },
            0.1 + 0.1 * speed.abs(),
        ),
        None => (Vector3::zeros(), VelocitySource::AtRest, 1.0),
    }
}

/// The 1-sigma of the start's parts that the log decides.
struct StartSigmas {
    position_m: f64,
    down_m: f64,
    velocity_m_s: f64,
    tilt_deg: f64,
    heading_deg: f64,
}

/// The independent variances of the start's error state, placed by [`idx`]: the log's
/// sigmas, the IMU's turn-on biases and the calibration states' priors.
fn start_variances(set: &InitSettings<'_>, sigma: &StartSigmas) -> ErrorState {
    let mut v = ErrorState::zeros();
    let mut put = |at: usize, values: &[f64]| {
        for (k, x) in values.iter().enumerate() {
            v[at + k] = x.powi(2);
        }
    };
    let tilt = sigma.tilt_deg.to_radians();
    let (gyro, accel) = (set.imu.gyro_bias_rad_s(), set.imu.accel_bias_m_s2());
    put(
        idx::POS,
        &[sigma.position_m, sigma.position_m, sigma.down_m],
    );
    put(idx::VEL, &[sigma.velocity_m_s; 3]);
    put(idx::ATT, &[tilt, tilt, sigma.heading_deg.to_radians()]);
    put(idx::GYRO_BIAS, &[gyro; 3]);
    put(idx::ACCEL_BIAS, &[accel; 3]);
    put(idx::DVL, &set.dvl_calibration_sigma);
    put(idx::WATER, &set.water_sigma);
    put(idx::GYRO_SCALE_Z, &[set.imu.gyro_scale()]);
    put(idx::SOUND_SPEED_SCALE, &[set.sound_speed_scale_sigma]);
    v
}

/// The initial estimate at the first IMU sample, from the streams in use (a sensor the
/// configuration leaves out comes as an empty slice): levelling, position, velocity, the
/// heading's sources, then the covariance.
pub fn initialise(
    src: &Streams<'_>,
    mission: &Mission,
    set: &InitSettings<'_>,
) -> Result<Initialisation, InitError> {
    let w = ImuWindow::of(src.imu, set.initial.window_s)?;
    let dvl = dvl_in_window(src, set, &w);
    let level = levelling(src, set, &w, &dvl);
    let speed_guess_m_s = dvl.first().map_or(2.0, |d| d.1.norm());
    let at = start_position(src, mission, set, &w, speed_guess_m_s);
    let (v_body, velocity, velocity_sigma_m_s) = start_body_velocity(src, set, &w, &dvl);
    let declination = (!src.mag.is_empty())
        .then(|| declination(mission, set.initial, at.lat, at.lon, -at.down_m, w.t0));
    let (level_rate_rad_s, level_rate_noise_rad_s) = level_rate(&w, &dvl, set);
    let found = headings(
        src,
        mission,
        set,
        &HeadingInputs {
            lat: at.lat,
            height_m: -at.down_m,
            roll: level.roll,
            pitch: level.pitch,
            w_mean: w.w_mean,
            level_rate_rad_s,
            level_rate_noise_rad_s,
            tilt_sigma_deg: level.tilt_sigma_deg,
            v_body,
            v_sigma_m_s: velocity_sigma_m_s,
            window_s: w.seconds,
            t0: w.t0,
            window_end: w.end_ns,
            declination,
            carry: &w.carry,
        },
    )?;
    let yaw = found.yaw_rad;
    // The in-run alignment's carry back to the start, with the Earth's rotation removed now
    // that the heading is known.
    let (roll, pitch) = match level.in_run {
        Some(a) if found.source != HeadingSource::Unknown => {
            super::in_run::start_tilt(src.imu, &a, yaw, at.lat)
        }
        _ => (level.roll, level.pitch),
    };
    let variances = start_variances(
        set,
        &StartSigmas {
            position_m: at.sigma_m,
            down_m: at.down_sigma_m,
            velocity_m_s: velocity_sigma_m_s,
            tilt_deg: level.tilt_sigma_deg,
            heading_deg: found.sigma_deg,
        },
    );
    let ned_from_body = UnitQuaternion::from_euler_angles(roll, pitch, yaw);
    let body_velocity = !matches!(velocity, VelocitySource::AtRest);
    let vel_ned = ned_from_body * v_body;
    let cov = initial_covariance(&variances, &vel_ned, body_velocity);
    Ok(Initialisation {
        variances,
        body_velocity,
        estimate: Estimate {
            nav: NavState {
                lat_rad: at.lat,
                lon_rad: at.lon,
                height_m: -at.down_m,
                vel_ned_m_s: vel_ned,
                ned_from_body,
            },
            gyro_bias: Vector3::zeros(),
            accel_bias: Vector3::zeros(),
            dvl: Default::default(),
            water: Default::default(),
            gyro_scale_z: 0.0,
            sound_speed_scale: 0.0,
            cov,
        },
        position: at.source,
        position_sigma_m: at.sigma_m,
        velocity,
        velocity_sigma_m_s,
        heading: found.source,
        heading_sigma_deg: found.sigma_deg,
        heading_sources: found.candidates,
        heading_unavailable: found.unavailable,
        heading_disagreements: found.disagreements,
        in_motion: None,
        in_run: level.in_run,
        declination,
        tilt_sigma_deg: level.tilt_sigma_deg,
        estimate_stamp_ns: w.t0,
        window_s: w.seconds,
    })
}

/// Replaces the start's position, velocity and attitude by `/truth`'s at the start with
/// errors drawn (seeded) with the configured sigmas, and their covariance by those sigmas: a
/// Monte Carlo study's start (seed 000's Table 2).
pub fn start_from_truth(init: &mut Initialisation, truth: &Truth, cfg: &InitialConfig) {
    use rand::SeedableRng;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(cfg.truth_seed);
    rng.set_stream(2000);
    let mut z =
        || -> f64 { rand_distr::Distribution::sample(&rand_distr::StandardNormal, &mut rng) };
    let p = cfg.truth_position_sigma_m;
    let arcmin = |x: f64| (x / 60.0).to_radians();
    let a = cfg.truth_attitude_sigma_arcmin.map(arcmin);
    let v = cfg.truth_velocity_sigma_m_s;
    let dp = Vector3::new(p[0] * z(), p[1] * z(), p[2] * z());
    let dv = Vector3::new(v * z(), v * z(), v * z());
    let da = Vector3::new(a[0] * z(), a[1] * z(), a[2] * z());
    let lat = truth.latitude_deg.to_radians();
    let true_attitude =
        UnitQuaternion::from_euler_angles(truth.attitude[0], truth.attitude[1], truth.attitude[2]);
    let (roll, pitch, yaw) = true_attitude.euler_angles();
    let nav = &mut init.estimate.nav;
    nav.lat_rad = lat + dp.x / geodesy::meridian_radius_m(lat);
    nav.lon_rad = truth.longitude_deg.to_radians()
        + dp.y / (geodesy::prime_vertical_radius_m(lat) * lat.cos());
    nav.height_m = -(truth.down_m + dp.z);
    nav.vel_ned_m_s = Vector3::from(truth.velocity_ned) + dv;
    nav.ned_from_body = UnitQuaternion::from_euler_angles(roll + da.x, pitch + da.y, yaw + da.z);
    for i in 0..3 {
        init.variances[idx::POS + i] = p[i].powi(2);
        init.variances[idx::VEL + i] = v.powi(2);
        init.variances[idx::ATT + i] = a[i].powi(2);
    }
    init.body_velocity = false;
    init.estimate.cov = initial_covariance(&init.variances, &nav.vel_ned_m_s, false);
    init.position = PositionSource::Truth;
    init.position_sigma_m = p[0].hypot(p[1]) / std::f64::consts::SQRT_2;
    init.velocity = VelocitySource::Truth;
    init.velocity_sigma_m_s = v;
    init.heading_sigma_deg = a[2].to_degrees();
    init.tilt_sigma_deg = a[0].max(a[1]).to_degrees();
}

/// The initial covariance from independent variances, with the velocity's error tied to the
/// attitude's when the velocity was measured along the body axes (DVL, EM log): an attitude
/// error `psi` turns it, `dv = psi x v = -[v x] psi`.
pub fn initial_covariance(
    variances: &ErrorState,
    vel_ned: &Vector3<f64>,
    body_velocity: bool,
) -> ErrorMatrix {
    let independent = ErrorMatrix::from_diagonal(variances);
    if !body_velocity {
        return independent;
    }
    let mut t = ErrorMatrix::identity();
    t.fixed_view_mut::<3, 3>(idx::VEL, idx::ATT)
        .copy_from(&(-vel_ned.cross_matrix()));
    let cov = t * independent * t.transpose();
    (cov + cov.transpose()) * 0.5
}

impl Initialisation {
    /// The initial estimate turned to another heading (rad) with another heading sigma (deg):
    /// attitude and velocity turned about the vertical, covariance rebuilt.
    /// Takes the heading of a start settled before (its value and sigma, the sources, their
    /// disagreements, the in-motion bank); the rest (position, velocity, tilt, the IMU's
    /// prior) stays this initialisation's.
    pub fn adopt_heading(&mut self, settled: &Initialisation) {
        let (_, _, yaw) = settled.estimate.nav.ned_from_body.euler_angles();
        self.estimate = self.estimate_with_heading(yaw, settled.heading_sigma_deg);
        self.heading = settled.heading;
        self.heading_sigma_deg = settled.heading_sigma_deg;
        self.heading_sources = settled.heading_sources.clone();
        self.heading_unavailable = settled.heading_unavailable.clone();
        self.heading_disagreements = settled.heading_disagreements.clone();
        self.in_motion = settled.in_motion.clone();
    }

    pub fn estimate_with_heading(&self, yaw_rad: f64, sigma_deg: f64) -> Estimate {
        let nav = &self.estimate.nav;
        let (_, _, yaw) = nav.ned_from_body.euler_angles();
        let turn = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw_rad - yaw);
        let vel_ned = turn * nav.vel_ned_m_s;
        let mut variances = self.variances;
        variances[idx::ATT + 2] = sigma_deg.to_radians().powi(2);
        Estimate {
            nav: NavState {
                ned_from_body: turn * nav.ned_from_body,
                vel_ned_m_s: vel_ned,
                ..*nav
            },
            cov: initial_covariance(&variances, &vel_ned, self.body_velocity),
            ..self.estimate
        }
    }
}

/// The set depth seed 002's stability test needs, when none is given: the median depth over
/// the first two minutes.
fn median_depth(src: &Streams<'_>, t0: i64) -> f64 {
    let end = t0 + 120_000_000_000;
    let mut d: Vec<f64> = src
        .depth
        .iter()
        .filter(|m| m.stamp_ns <= end)
        .map(|m| m.depth)
        .collect();
    d.sort_by(f64::total_cmp);
    d.get(d.len() / 2).copied().unwrap_or(0.0)
}

/// The declination: given, else the mission's, else the World Magnetic Model's or IGRF-14's
/// at the start ([`crate::geomag::declination`]).
fn declination(
    mission: &Mission,
    cfg: &InitialConfig,
    lat: f64,
    lon: f64,
    height_m: f64,
    t0: i64,
) -> DeclinationUsed {
    // A declination from a chart or the mission is as good as the model's, about 0.5 deg.
    const STATED_SIGMA_DEG: f64 = 0.5;
    let stated = |source, d| DeclinationUsed {
        source,
        declination_deg: d,
        sigma_deg: STATED_SIGMA_DEG,
    };
    if let Some(d) = cfg.declination_deg {
        return stated(DeclinationSource::Given, d);
    }
    if let Some(d) = mission.magnetic_declination_deg {
        return stated(DeclinationSource::Mission, d);
    }
    match crate::geomag::declination(lat.to_degrees(), lon.to_degrees(), height_m, t0) {
        Ok(d) => DeclinationUsed {
            source: match d.model {
                crate::geomag::FieldModel::Wmm => DeclinationSource::Wmm,
                crate::geomag::FieldModel::Igrf14 => DeclinationSource::Igrf,
            },
            declination_deg: d.declination_deg,
            sigma_deg: d.sigma_deg,
        },
        // Declination reaches 20 deg at mid latitudes: say so in the sigma.
        Err(_) => DeclinationUsed {
            source: DeclinationSource::Unknown,
            declination_deg: 0.0,
            sigma_deg: 20.0,
        },
    }
}

struct HeadingInputs<'c> {
    lat: f64,
    height_m: f64,
    roll: f64,
    pitch: f64,
    w_mean: Vector3<f64>,
    /// Rate of the levelled tilt over the window (first third against last), rad/s, and the
    /// part of it accelerometer noise explains.
    level_rate_rad_s: f64,
    level_rate_noise_rad_s: f64,
    tilt_sigma_deg: f64,
    v_body: Vector3<f64>,
    /// 1-sigma of `v_body`, m/s (its transport rate is removed from the gyro mean).
    v_sigma_m_s: f64,
    window_s: f64,
    t0: i64,
    window_end: i64,
    declination: Option<DeclinationUsed>,
    carry: &'c Carry,
}

/// A source's heading (rad) and 1-sigma (deg), or why it has none.
type Found = Result<(f64, f64), String>;

/// The heading sources found, their combination, and why the others gave none.
struct Headings {
    source: HeadingSource,
    yaw_rad: f64,
    sigma_deg: f64,
    candidates: Vec<HeadingCandidate>,
    unavailable: Vec<String>,
    disagreements: Vec<crate::recon::alignment::heading::HeadingDisagreement>,
}

/// Every heading source, then the combination (`auto`) or the one forced. Without any source
/// (`auto`), the heading is unknown: 0 with a sigma of 180 deg, for the in-motion alignment
/// to find.
fn headings(
    src: &Streams<'_>,
    mission: &Mission,
    set: &InitSettings<'_>,
    h: &HeadingInputs<'_>,
) -> Result<Headings, InitError> {
    let cfg = set.initial;
    let sources: [(HeadingSource, Found); 4] = [
        (HeadingSource::Gyrocompass, gyrocompass(set, h)),
        (HeadingSource::Magnetometer, magnetometer(src, set, h)),
        (
            HeadingSource::Mission,
            mission
                .initial_yaw_rad
                .map(|y| (y, cfg.mission_yaw_sigma_deg))
                .ok_or_else(|| "mission: no initial_yaw_rad in the mission metadata".to_string()),
        ),
        (
            HeadingSource::Given,
            cfg.yaw_deg
                .map(|y| (y.to_radians(), cfg.given_yaw_sigma_deg))
                .ok_or_else(|| "given: no heading given by hand (initial yaw_deg)".to_string()),
        ),
    ];
    let forced = match cfg.heading {
        HeadingChoice::Auto => None,
        HeadingChoice::Gyrocompass => Some(HeadingSource::Gyrocompass),
        HeadingChoice::Magnetometer => Some(HeadingSource::Magnetometer),
        HeadingChoice::Mission => Some(HeadingSource::Mission),
        HeadingChoice::Given => Some(HeadingSource::Given),
    };
    let mut candidates = Vec::new();
    let mut unavailable = Vec::new();
    for (source, found) in sources {
        match found {
            Ok((yaw, sigma)) => {
                let mut c = HeadingCandidate::new(source, yaw, sigma);
                c.used = forced.is_none_or(|f| f == source);
                candidates.push(c);
            }
            Err(reason) => {
                if forced == Some(source) {
                    return Err(InitError::HeadingUnavailable {
                        choice: source.name(),
                        reason,
                    });
                }
                unavailable.push(reason);
            }
        }
    }
    let Some(combined) = combine(&candidates) else {
        return Ok(Headings {
            source: HeadingSource::Unknown,
            yaw_rad: 0.0,
            sigma_deg: 180.0,
            candidates,
            unavailable,
            disagreements: Vec::new(),
        });
    };
    let mut used = candidates.iter().filter(|c| c.used);
    let source = match (used.next(), used.next()) {
        (Some(only), None) => only.source,
        _ => HeadingSource::Combined,
    };
    Ok(Headings {
        source,
        yaw_rad: combined.yaw_rad,
        sigma_deg: combined.sigma_deg,
        candidates,
        unavailable,
        disagreements: combined.disagreements,
    })
}

/// Gyrocompass: the predicted error from the gyro bias and the noise averaged over the
/// window, relative to the horizontal Earth rate; (yaw rad, sigma deg).
fn gyrocompass(set: &InitSettings<'_>, h: &HeadingInputs<'_>) -> Result<(f64, f64), String> {
    let cfg = set.initial;
    let horizontal = at_rest::horizontal_earth_rate(h.lat);
    let noise = set.imu.noise().gyro_noise_density / h.window_s.max(1e-3).sqrt();
    // An unknown velocity leaves an unknown transport rate, v / R, in the gyro mean.
    let transport = h.v_sigma_m_s / geodesy::prime_vertical_radius_m(h.lat);
    let sigma_deg =
        (set.imu.gyro_bias_rad_s().hypot(noise).hypot(transport) / horizontal).to_degrees();
    if sigma_deg > cfg.gyrocompass_max_sigma_deg {
        return Err(format!(
            "gyrocompass: the IMU's predicted heading error {sigma_deg:.1} deg exceeds {} deg",
            cfg.gyrocompass_max_sigma_deg
        ));
    }
    // A vehicle pitching or rolling during the window (an autopilot settling, waves) puts its
    // own rate into the gyro mean: an error of rate / horizontal Earth rate, counted when it
    // stands out of the accelerometer noise.
    let motion_deg = if h.level_rate_rad_s > 3.0 * h.level_rate_noise_rad_s {
        (h.level_rate_rad_s / horizontal).to_degrees()
    } else {
        0.0
    };
    if motion_deg > cfg.gyrocompass_max_sigma_deg {
        return Err(format!(
            "gyrocompass: the vehicle's tilt changed by {:.4} deg during the first {:.0} s \
             ({:.1e} rad/s against an Earth rate of {:.1e}: heading error up to {motion_deg:.1} deg)",
            (h.level_rate_rad_s * h.window_s * 2.0 / 3.0).to_degrees(),
            h.window_s,
            h.level_rate_rad_s,
            horizontal
        ));
    }
    let sigma_deg = sigma_deg.hypot(motion_deg);
    if h.w_mean.norm() > STEADY_RATE_FACTOR * geodesy::OMEGA_IE_RAD_S {
        return Err(format!(
            "gyrocompass: the vehicle turned during the first {:.0} s (mean rate {:.3} deg/s)",
            h.window_s,
            h.w_mean.norm().to_degrees()
        ));
    }
    // Moving base: remove the transport rate of the velocity at the current heading (twice:
    // the heading changes the velocity's direction).
    let mut yaw = at_rest::gyrocompass(&h.w_mean, h.roll, h.pitch);
    for _ in 0..2 {
        let c = UnitQuaternion::from_euler_angles(h.roll, h.pitch, yaw);
        let w_en = geodesy::transport_rate_ned(h.lat, h.height_m, &(c * h.v_body));
        yaw = at_rest::gyrocompass(&(h.w_mean - c.inverse() * w_en), h.roll, h.pitch);
    }
    Ok((yaw, sigma_deg))
}

/// Magnetometer: the readings of the window carried to the start's body axes by the gyro
/// (so a vehicle turning in the window still gives its start heading), their mean
/// tilt-compensated with the start's roll and pitch, plus the declination; (yaw rad, sigma
/// deg).
fn magnetometer(
    src: &Streams<'_>,
    set: &InitSettings<'_>,
    h: &HeadingInputs<'_>,
) -> Result<(f64, f64), String> {
    let m = mean3(
        src.mag
            .iter()
            .filter(|m| m.stamp_ns >= h.t0 && m.stamp_ns <= h.window_end)
            .map(|m| (h.carry.at(m.stamp_ns) * Vector3::from(m.magnetic_field)).into()),
    )
    .ok_or_else(|| "magnetometer: no /mag data in the alignment window".to_string())?;
    let d = h
        .declination
        .ok_or_else(|| "magnetometer: no /mag data".to_string())?;
    let yaw = at_rest::magnetic_heading(&m, h.roll, h.pitch, d.declination_deg.to_radians());
    // A tilt error turns the field's vertical part into the horizontal one: up to tilt error
    // x tan(inclination) of heading.
    let levelled = UnitQuaternion::from_euler_angles(h.roll, h.pitch, 0.0) * m;
    let tan_inclination = (levelled.z.abs() / levelled.x.hypot(levelled.y).max(1e-12)).min(5.0);
    let sigma = set
        .initial
        .magnetometer_sigma_deg
        .hypot(d.sigma_deg)
        .hypot(h.tilt_sigma_deg * tan_inclination);
    Ok((yaw, sigma))
}

impl fmt::Display for Initialisation {
    /// One line per quantity: value, source, 1-sigma.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.write_position(f)?;
        self.write_velocity(f)?;
        self.write_tilt(f)?;
        self.write_heading_sources(f)?;
        self.write_heading(f)
    }
}

impl Initialisation {
    fn write_position(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let nav = &self.estimate.nav;
        let position = match self.position {
            PositionSource::Gnss { .. } => "first GNSS fix",
            PositionSource::StartFix { .. } => "`start` position fix",
            PositionSource::AcousticFix { .. } => {
                "the first acoustic fix (or USBL observation) that two of the next four agree with"
            }
            PositionSource::MissionOrigin => {
                "mission origin (no GNSS fix or start mark near the start)"
            }
            PositionSource::Truth => "/truth with drawn errors (a study's start)",
        };
        writeln!(
            f,
            "position   {:.7} deg N {:.7} deg E, depth {:.1} m   from {position} (1-sigma {:.1} m)",
            nav.lat_rad.to_degrees(),
            nav.lon_rad.to_degrees(),
            -nav.height_m,
            self.position_sigma_m
        )
    }

    fn write_velocity(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let velocity = match self.velocity {
            VelocitySource::Dvl { .. } => "first DVL reading in range",
            VelocitySource::SpeedLog { .. } => "EM-log speed along the body x axis",
            VelocitySource::Propeller { .. } => "propeller speed along the body x axis",
            VelocitySource::Truth => "/truth with a drawn error",
            VelocitySource::AtRest => "none: assumed at rest",
        };
        let v = self.estimate.nav.vel_ned_m_s;
        writeln!(
            f,
            "velocity   N {:.2} E {:.2} D {:.2} m/s   from {velocity} (1-sigma {:.2} m/s)",
            v.x, v.y, v.z, self.velocity_sigma_m_s
        )
    }

    fn write_tilt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (roll, pitch, _) = self.estimate.nav.ned_from_body.euler_angles();
        let tilt_from = match self.in_run {
            Some(a) => format!(
                "in-run alignment (seed 002) stable at {:.1} s, aligned at {:.1} s ({:.2} / {:.2} \
                 deg then), carried back by the gyro",
                (a.stable_at_ns - self.estimate_stamp_ns) as f64 * 1e-9,
                a.aligned_after_s,
                a.roll_rad.to_degrees(),
                a.pitch_rad.to_degrees()
            ),
            None => format!("levelling {:.0} s of IMU data", self.window_s),
        };
        writeln!(
            f,
            "roll/pitch {:.2} / {:.2} deg   from {tilt_from} (1-sigma {:.2} deg)",
            roll.to_degrees(),
            pitch.to_degrees(),
            self.tilt_sigma_deg
        )
    }

    fn write_heading_sources(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for c in &self.heading_sources {
            let detail = match c.source {
                HeadingSource::Gyrocompass => {
                    format!("gyrocompassing {:.0} s of IMU data", self.window_s)
                }
                HeadingSource::Magnetometer => format!(
                    "magnetometer, {}",
                    self.declination
                        .as_ref()
                        .map(describe_declination)
                        .unwrap_or_default()
                ),
                HeadingSource::Mission => "mission metadata initial_yaw_rad".to_string(),
                HeadingSource::Given => "given by hand".to_string(),
                _ => c.source.name().to_string(),
            };
            writeln!(
                f,
                "  source   {:.2} deg   {detail} (1-sigma {:.2} deg){}",
                c.heading_deg,
                c.sigma_deg,
                if c.used { "" } else { "   not used" }
            )?;
        }
        for reason in &self.heading_unavailable {
            writeln!(f, "  no source {reason}")?;
        }
        Ok(())
    }

    fn write_heading(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let yaw = self.estimate.nav.ned_from_body.euler_angles().2;
        let refined = self.in_motion.as_ref().and_then(|m| {
            m.refined_heading_deg
                .zip(m.refined_sigma_deg)
                .map(|r| (r, m.span_s))
        });
        let confirmed = match (self.heading, refined) {
            (HeadingSource::GyrocompassInMotion, Some(((deg, sigma), span_s))) => format!(
                ", confirmed by gyrocompassing in motion: refined over the first {span_s:.0} s \
                 and smoothed back, {deg:.2} deg (1-sigma {sigma:.2}); the forward pass starts \
                 from the gyrocompass's"
            ),
            _ => String::new(),
        };
        write!(
            f,
            "heading    {:.2} deg   from {}{confirmed} (1-sigma {:.2} deg)",
            crate::angle::wrap_pi(yaw).to_degrees().rem_euclid(360.0),
            match self.heading {
                HeadingSource::Combined => "the sources above, combined by their sigmas",
                HeadingSource::Unknown => "no source: the in-motion alignment finds it",
                HeadingSource::InMotion => "the in-motion alignment over the log",
                _ => "the source above",
            },
            self.heading_sigma_deg
        )
    }
}

fn describe_declination(d: &DeclinationUsed) -> String {
    format!(
        "declination {:.2} deg ({}, 1-sigma {:.2})",
        d.declination_deg,
        match d.source {
            DeclinationSource::Given => "given",
            DeclinationSource::Mission => "mission metadata",
            DeclinationSource::Wmm => "World Magnetic Model",
            DeclinationSource::Igrf => "IGRF-14",
            DeclinationSource::Unknown => "unknown, taken as 0: give the declination",
        },
        d.sigma_deg
    )
}

impl PositionSource {
    pub fn name(&self) -> &'static str {
        match self {
            PositionSource::Gnss { .. } => "gnss",
            PositionSource::StartFix { .. } => "start_fix",
            PositionSource::AcousticFix { .. } => "acoustic_fix",
            PositionSource::MissionOrigin => "mission_origin",
            PositionSource::Truth => "truth",
        }
    }
}

impl VelocitySource {
    pub fn name(&self) -> &'static str {
        match self {
            VelocitySource::Dvl { .. } => "dvl",
            VelocitySource::SpeedLog { .. } => "eml",
            VelocitySource::Propeller { .. } => "rpm",
            VelocitySource::Truth => "truth",
            VelocitySource::AtRest => "at_rest",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contract::{Dvl, Imu, SpeedLog};
    use crate::recon::config::ImuGrade;

    const SECOND: i64 = 1_000_000_000;

    /// A still IMU at 100 Hz for `seconds`, rolled and pitched by the angles given (rad).
    fn still_imu(seconds: i64, roll: f64, pitch: f64) -> Vec<Imu> {
        let ned_from_body = UnitQuaternion::from_euler_angles(roll, pitch, 0.3);
        let f_body = ned_from_body.inverse() * Vector3::new(0.0, 0.0, -9.81);
        (0..=seconds * 100)
            .map(|k| Imu {
                stamp_ns: k * SECOND / 100,
                angular_velocity: [0.0; 3],
                specific_force: f_body.into(),
            })
            .collect()
    }

    fn settings(initial: &InitialConfig) -> InitSettings<'_> {
        InitSettings {
            initial,
            imu: ImuGrade::Tactical.spec(),
            dvl_max_altitude_m: 100.0,
            dvl_sigma_m_s: 0.01,
            dvl_bias_walk_m_s_rt_s: 0.0,
            dvl_mounting: DvlMounting::default(),
            dvl_calibration_sigma: [0.005, 0.01, 0.02, 0.001, 0.002, 0.003],
            water_sigma: [0.02, 0.2, 0.3],
            sound_speed_scale_sigma: 0.005,
            depth_sigma_m: 0.1,
            speed_of_rpm: None,
            acoustic: None,
            usbl: None,
        }
    }

    #[test]
    fn a_log_without_imu_or_with_one_sample_is_refused() {
        assert_eq!(ImuWindow::of(&[], 30.0).err(), Some(InitError::NoImu));
        let one = still_imu(0, 0.0, 0.0);
        assert_eq!(
            ImuWindow::of(&one, 30.0).err(),
            Some(InitError::TooFewImu(1))
        );
    }

    #[test]
    fn levelling_finds_the_roll_and_pitch_of_a_still_vehicle() {
        let imu = still_imu(60, 0.05, -0.1);
        let w = ImuWindow::of(&imu, 30.0).unwrap();
        assert!((w.seconds - 30.0).abs() < 1e-9, "{}", w.seconds);
        let (roll, pitch) = carried_level(&w, &[]);
        assert!((roll - 0.05).abs() < 1e-9, "{roll}");
        assert!((pitch + 0.1).abs() < 1e-9, "{pitch}");
        // Still: the level axes do not turn.
        let initial = InitialConfig::default();
        let (rate, noise) = level_rate(&w, &[], &settings(&initial));
        assert!(rate < 1e-12 && noise > 0.0, "{rate} {noise}");
    }

    #[test]
    fn the_start_gnss_fix_is_the_one_nearest_the_median_not_an_outlier() {
        let fix = |s: i64, lat: f64| GnssFix {
            stamp_ns: s * SECOND,
            latitude_deg: lat,
            longitude_deg: 129.0,
            horizontal_sigma_m: 3.0,
        };
        let fixes = [
            fix(0, 35.5),
            fix(1, 35.0001),
            fix(2, 35.0),
            fix(3, 35.0002),
            fix(60, 35.0),
        ];
        // The median of the four near the start is 35.0002 deg: that fix, not the outlier
        // 55 km away, nor the one a minute later.
        let chosen = start_gnss(&fixes, |s| s <= 5 * SECOND).unwrap();
        assert_eq!(chosen.stamp_ns, 3 * SECOND);
        assert!(start_gnss(&fixes, |s| s > 100 * SECOND).is_none());
    }

    #[test]
    fn the_start_velocity_comes_from_the_dvl_then_the_em_log_then_rest() {
        let imu = still_imu(60, 0.0, 0.0);
        let w = ImuWindow::of(&imu, 30.0).unwrap();
        let initial = InitialConfig::default();
        let set = settings(&initial);
        let eml = [SpeedLog {
            stamp_ns: 2 * SECOND,
            speed: 1.5,
        }];
        let dvl_reading = Dvl {
            stamp_ns: 3 * SECOND,
            velocity: [1.2, 0.1, 0.0],
            valid: true,
            altitude: Some(20.0),
        };
        let dvl_streams = [dvl_reading.clone()];
        let streams = Streams {
            imu: &imu,
            eml: &eml,
            dvl: &dvl_streams,
            ..Default::default()
        };
        let dvl = dvl_in_window(&streams, &set, &w);
        let (v, source, _) = start_body_velocity(&streams, &set, &w, &dvl);
        assert_eq!(
            source,
            VelocitySource::Dvl {
                stamp_ns: 3 * SECOND
            }
        );
        assert_eq!(v, Vector3::new(1.2, 0.1, 0.0));
        // Out of range (above the DVL's altitude limit): not a start velocity.
        let high = [Dvl {
            altitude: Some(500.0),
            ..dvl_reading
        }];
        let streams = Streams {
            dvl: &high,
            ..streams
        };
        let dvl = dvl_in_window(&streams, &set, &w);
        let (v, source, sigma) = start_body_velocity(&streams, &set, &w, &dvl);
        assert_eq!(
            source,
            VelocitySource::SpeedLog {
                stamp_ns: 2 * SECOND
            }
        );
        assert_eq!((v, sigma), (Vector3::new(1.5, 0.0, 0.0), 0.1 + 0.05 * 1.5));
        let streams = Streams {
            eml: &[],
            ..streams
        };
        let (v, source, _) = start_body_velocity(&streams, &set, &w, &[]);
        assert_eq!((v, source), (Vector3::zeros(), VelocitySource::AtRest));
    }

    #[test]
    fn each_start_variance_sits_at_its_state() {
        let initial = InitialConfig::default();
        let set = settings(&initial);
        let v = start_variances(
            &set,
            &StartSigmas {
                position_m: 2.0,
                down_m: 0.5,
                velocity_m_s: 0.1,
                tilt_deg: 0.2,
                heading_deg: 3.0,
            },
        );
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-15 * b.abs().max(1e-30);
        assert!(close(v[idx::POS], 4.0) && close(v[idx::POS + 1], 4.0));
        assert!(close(v[idx::POS + 2], 0.25));
        assert!((0..3).all(|k| close(v[idx::VEL + k], 0.01)));
        assert!(close(v[idx::ATT], 0.2f64.to_radians().powi(2)));
        assert!(close(v[idx::ATT + 2], 3f64.to_radians().powi(2)));
        let gyro = set.imu.gyro_bias_rad_s().powi(2);
        let accel = set.imu.accel_bias_m_s2().powi(2);
        assert!((0..3).all(|k| close(v[idx::GYRO_BIAS + k], gyro)));
        assert!((0..3).all(|k| close(v[idx::ACCEL_BIAS + k], accel)));
        assert!(close(v[idx::DVL_SCALE], 0.005f64.powi(2)));
        assert!(close(v[idx::DVL_MISALIGNMENT + 1], 0.02f64.powi(2)));
        assert!(close(v[idx::DVL_BIAS + 2], 0.003f64.powi(2)));
        assert!(close(v[idx::EML_SCALE], 0.02f64.powi(2)));
        assert!(close(v[idx::CURRENT + 1], 0.3f64.powi(2)));
        assert!(close(v[idx::GYRO_SCALE_Z], set.imu.gyro_scale().powi(2)));
        assert!(v.iter().all(|x| *x > 0.0), "every state has a prior");
    }
}
