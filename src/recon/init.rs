//! The initial estimate from what the log has, and which source gave each part.
//!
//! - Position: a GNSS fix near the start (the one closest to the median of those within
//!   `gnss_window_s`), else a `start` position fix near the
//!   start, else the mission origin. Depth from the first depth reading.
//! - Roll and pitch at the first sample: the specific force over the first `window_s` of IMU
//!   data, each sample carried to the start's body axes by the gyro, less the acceleration
//!   the DVL saw (carried the same way), levelled. A vehicle that rolls or turns during the
//!   window (a drop) is levelled as it was at the start.
//! - Heading (`recon::heading`): every source, combined by sigma (`auto`) or the one forced:
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
use super::config::{HeadingChoice, ImuSpec, InitialConfig};
use super::heading::combine;
pub use super::heading::{DeclinationSource, DeclinationUsed, HeadingCandidate, HeadingSource};
use super::Streams;
use crate::contract::{GnssFix, Truth};
use crate::filters::ins::alignment;
use crate::filters::ins::error_state::{idx, ErrorMatrix, ErrorState};
use crate::filters::ins::forward::{DvlMounting, Estimate};
use crate::filters::ins::mechanization::NavState;
use crate::geodesy;
use crate::ingest::Mission;
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
    pub depth_sigma_m: f64,
    /// Forward speed (m/s) for a propeller reading (rev/min), when known: seed 002's in-run
    /// alignment needs it.
    pub speed_of_rpm: Option<&'a dyn Fn(f64) -> f64>,
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
    pub heading_disagreements: Vec<String>,
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

/// The initial estimate at the first IMU sample.
/// The initial estimate at the first IMU sample, from the streams in use (a sensor the
/// configuration leaves out comes as an empty slice).
pub fn initialise(
    src: &Streams<'_>,
    mission: &Mission,
    set: &InitSettings<'_>,
) -> Result<Initialisation, InitError> {
    let cfg = set.initial;
    let imu = src.imu;
    let first = imu.first().ok_or(InitError::NoImu)?;
    if imu.len() < 2 {
        return Err(InitError::TooFewImu(imu.len()));
    }
    let t0 = first.stamp_ns;
    let window_end = t0 + (cfg.window_s * 1e9) as i64;
    let in_window = |s: i64| s >= t0 && s <= window_end;
    let window = &imu[..imu.partition_point(|m| m.stamp_ns <= window_end)];
    let window_s = (window.last().map_or(t0, |m| m.stamp_ns) - t0) as f64 * 1e-9;
    let f_mean = mean3(window.iter().map(|m| m.specific_force)).unwrap_or_default();
    let w_mean = mean3(window.iter().map(|m| m.angular_velocity)).unwrap_or_default();

    // DVL readings in range within the window, in body axes.
    let body_from_dvl = set.dvl_mounting.dvl_from_body.inverse();
    let dvl: Vec<(i64, Vector3<f64>)> = if !src.dvl.is_empty() {
        src.dvl
            .iter()
            .filter(|d| in_window(d.stamp_ns))
            .filter(|d| d.valid && d.altitude.is_none_or(|h| h <= set.dvl_max_altitude_m))
            .map(|d| (d.stamp_ns, body_from_dvl * Vector3::from(d.velocity)))
            .collect()
    } else {
        Vec::new()
    };

    // Levelling: f = a - g in the body, so -g = f - a; the DVL gives the mean a (between
    // its first and last readings from `from` to `to`, when more than a second apart).
    let dvl_accel = |from: i64, to: i64| {
        let mut inside = dvl.iter().filter(|d| d.0 >= from && d.0 <= to);
        let first = inside.next();
        match (first, inside.next_back().or(first)) {
            (Some(a), Some(b)) if b.0 - a.0 > 1_000_000_000 => {
                (b.1 - a.1) / ((b.0 - a.0) as f64 * 1e-9)
            }
            _ => Vector3::zeros(),
        }
    };
    // Levelling at the start: each sample carried to the start's body axes by the gyro, so
    // that a vehicle rolling or turning in the window is levelled as it was at the start.
    // `q f = d(q v)/dt - g_b0` (q: start body from body), so the mean of `q f` less the DVL's
    // change of `q v` over its span is `-g` in the start's axes.
    let carry = Carry::new(window);
    let f_carried = mean3(
        window
            .iter()
            .zip(&carry.q)
            .map(|(m, q)| (q * Vector3::from(m.specific_force)).into()),
    )
    .unwrap_or(f_mean);
    let carried_accel = {
        let (a, b) = (dvl.first(), dvl.last());
        match (a, b) {
            (Some(a), Some(b)) if b.0 - a.0 > 1_000_000_000 => {
                (carry.at(b.0) * b.1 - carry.at(a.0) * a.1) / ((b.0 - a.0) as f64 * 1e-9)
            }
            _ => Vector3::zeros(),
        }
    };
    let (mut roll, mut pitch) = alignment::level(&(f_carried - carried_accel));
    // How fast the level axes turned during the window: the tilt of its first third against
    // its last (a rate there enters the gyrocompass's mean like the Earth rate does). A
    // change of acceleration between the thirds also tilts the levelled vector: the DVL's is
    // removed when it stands out of the DVL's noise.
    let (level_rate_rad_s, level_rate_noise_rad_s) = {
        let third = window.len() / 3;
        let span_s = window_s * 2.0 / 3.0;
        let (a, b) = (&window[..third], &window[window.len() - third..]);
        let stamps = |p: &[crate::contract::Imu]| {
            p.first()
                .map_or((0, 0), |f| (f.stamp_ns, p.last().map_or(0, |l| l.stamp_ns)))
        };
        let ((a0, a1), (b0, b1)) = (stamps(a), stamps(b));
        let third_s = ((a1 - a0) as f64 * 1e-9).max(1e-3);
        let accel_change = dvl_accel(b0, b1) - dvl_accel(a0, a1);
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
            mean3(p.iter().map(|m| m.specific_force)).map(|f| alignment::level(&(f - less)))
        };
        let rate = match (tilt(a, Vector3::zeros()), tilt(b, accel_change)) {
            (Some(x), Some(y)) if third > 0 && span_s > 0.0 => {
                (y.0 - x.0).hypot(y.1 - x.1) / span_s
            }
            _ => 0.0,
        };
        // The accelerometer's noise on two means of a third each, differenced, and the
        // DVL's when its acceleration was removed.
        let accel_white = set.imu.noise().accel_noise_density / third_s.sqrt() * 2f64.sqrt();
        (
            rate,
            accel_white.hypot(accel_noise) / 9.81 / span_s.max(1e-3),
        )
    };
    let g = 9.81;
    let motion_tilt_deg = if dvl.len() >= 2 { 0.1 } else { 0.5 };
    // The gyro's bias over the window turns the carried samples: half of it on average.
    let carry_deg = (set.imu.gyro_bias_rad_s() * window_s * 0.5).to_degrees();
    let mut tilt_sigma_deg = (set.imu.accel_bias_m_s2() / g)
        .to_degrees()
        .hypot(motion_tilt_deg)
        .hypot(carry_deg);
    // Without the DVL, the window's accelerations cannot be removed from the levelling: a
    // moving vehicle with a propeller is aligned in run (seed 002) once it is stable.
    let in_run = match (set.speed_of_rpm, dvl.is_empty() && !src.rpm.is_empty()) {
        (Some(speed), true) if cfg.in_run => {
            let set_depth_m = cfg.set_depth_m.unwrap_or_else(|| median_depth(src, t0));
            super::in_run::align(imu, src.depth, src.rpm, set_depth_m, speed, 1.0, g)
        }
        _ => None,
    };
    if let Some(a) = in_run {
        roll = a.start_roll_rad;
        pitch = a.start_pitch_rad;
        tilt_sigma_deg = (set.imu.accel_bias_m_s2() / g)
            .to_degrees()
            .hypot(cfg.in_run_sigma_deg);
    }

    // Position.
    let origin = (
        mission.origin_latitude_deg.to_radians(),
        mission.origin_longitude_deg.to_radians(),
    );
    let near_start = |s: i64| ((s - t0) as f64 * 1e-9).abs() <= cfg.gnss_window_s;
    // Of the fixes near the start, the one closest to their median: one outlier among
    // them cannot place the start.
    let gnss = {
        let near: Vec<&GnssFix> = src.gnss.iter().filter(|g| near_start(g.stamp_ns)).collect();
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
    };
    let start_fix = src
        .fixes
        .iter()
        .find(|f| f.label == "start" && near_start(f.stamp_ns));
    let speed_guess = dvl.first().map_or(2.0, |d| d.1.norm());
    let (lat, lon, position, position_sigma_m) = if let Some(g) = gnss {
        let late_s = ((g.stamp_ns - t0) as f64 * 1e-9).abs();
        (
            g.latitude_deg.to_radians(),
            g.longitude_deg.to_radians(),
            PositionSource::Gnss {
                stamp_ns: g.stamp_ns,
            },
            g.horizontal_sigma_m.hypot(speed_guess * late_s),
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
    } else {
        (
            origin.0,
            origin.1,
            PositionSource::MissionOrigin,
            cfg.origin_sigma_m,
        )
    };
    let (down_m, down_sigma_m) = match src.depth.iter().find(|d| in_window(d.stamp_ns)) {
        Some(d) => (d.depth, set.depth_sigma_m),
        None => start_fix
            .and_then(|f| f.down_m.map(|d| (d, f.sigma_m)))
            .unwrap_or((0.0, 10.0)),
    };

    // Velocity along the body axes (heading not needed yet).
    let eml = src.eml.iter().find(|e| in_window(e.stamp_ns));
    let (v_body, velocity, velocity_sigma_m_s) = if let Some(d) = dvl.first() {
        (
            d.1,
            VelocitySource::Dvl { stamp_ns: d.0 },
            set.dvl_sigma_m_s.hypot(0.05),
        )
    } else if let Some(e) = eml {
        (
            Vector3::new(e.speed, 0.0, 0.0),
            VelocitySource::SpeedLog {
                stamp_ns: e.stamp_ns,
            },
            0.1 + 0.05 * e.speed,
        )
    } else if let Some((p, speed)) = set.speed_of_rpm.and_then(|f| {
        let p = src.rpm.iter().find(|p| in_window(p.stamp_ns))?;
        Some((p, f(p.rpm)))
    }) {
        (
            Vector3::new(speed, 0.0, 0.0),
            VelocitySource::Propeller {
                stamp_ns: p.stamp_ns,
            },
            0.1 + 0.1 * speed.abs(),
        )
    } else {
        (Vector3::zeros(), VelocitySource::AtRest, 1.0)
    };

    let declination =
        (!src.mag.is_empty()).then(|| declination(mission, cfg, lat, lon, -down_m, t0));
    let found = headings(
        src,
        mission,
        set,
        &HeadingInputs {
            lat,
            height_m: -down_m,
            roll,
            pitch,
            w_mean,
            level_rate_rad_s,
            level_rate_noise_rad_s,
            tilt_sigma_deg,
            v_body,
            v_sigma_m_s: velocity_sigma_m_s,
            window_s,
            t0,
            window_end,
            declination,
            carry: &carry,
        },
    )?;
    let (heading, yaw, heading_sigma_deg) = (found.source, found.yaw_rad, found.sigma_deg);
    // The in-run alignment's carry back to the start, with the Earth's rotation removed now
    // that the heading is known.
    if let (Some(a), true) = (in_run, heading != HeadingSource::Unknown) {
        (roll, pitch) = super::in_run::start_tilt(imu, &a, yaw, lat);
    }

    let ned_from_body = UnitQuaternion::from_euler_angles(roll, pitch, yaw);
    let deg2 = |d: f64| d.to_radians().powi(2);
    let (gb, ab) = (
        set.imu.gyro_bias_rad_s().powi(2),
        set.imu.accel_bias_m_s2().powi(2),
    );
    let (p2, v2) = (position_sigma_m.powi(2), velocity_sigma_m_s.powi(2));
    let variances = ErrorState::from_column_slice(&[
        p2,
        p2,
        down_sigma_m.powi(2),
        v2,
        v2,
        v2,
        deg2(tilt_sigma_deg),
        deg2(tilt_sigma_deg),
        deg2(heading_sigma_deg),
        gb,
        gb,
        gb,
        ab,
        ab,
        ab,
        set.dvl_calibration_sigma[0].powi(2),
        set.dvl_calibration_sigma[1].powi(2),
        set.dvl_calibration_sigma[2].powi(2),
        set.dvl_calibration_sigma[3].powi(2),
        set.dvl_calibration_sigma[4].powi(2),
        set.dvl_calibration_sigma[5].powi(2),
        set.water_sigma[0].powi(2),
        set.water_sigma[1].powi(2),
        set.water_sigma[2].powi(2),
        set.imu.gyro_scale().powi(2),
    ]);
    let body_velocity = !matches!(velocity, VelocitySource::AtRest);
    let vel_ned = ned_from_body * v_body;
    let cov = initial_covariance(&variances, &vel_ned, body_velocity);
    Ok(Initialisation {
        variances,
        body_velocity,
        estimate: Estimate {
            nav: NavState {
                lat_rad: lat,
                lon_rad: lon,
                height_m: -down_m,
                vel_ned_m_s: vel_ned,
                ned_from_body,
            },
            gyro_bias: Vector3::zeros(),
            accel_bias: Vector3::zeros(),
            dvl: Default::default(),
            water: Default::default(),
            gyro_scale_z: 0.0,
            cov,
        },
        position,
        position_sigma_m,
        velocity,
        velocity_sigma_m_s,
        heading,
        heading_sigma_deg,
        heading_sources: found.candidates,
        heading_unavailable: found.unavailable,
        heading_disagreements: found.disagreements,
        in_motion: None,
        in_run,
        declination,
        tilt_sigma_deg,
        estimate_stamp_ns: t0,
        window_s,
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
    disagreements: Vec<String>,
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
    let horizontal = alignment::horizontal_earth_rate(h.lat);
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
    let mut yaw = alignment::gyrocompass(&h.w_mean, h.roll, h.pitch);
    for _ in 0..2 {
        let c = UnitQuaternion::from_euler_angles(h.roll, h.pitch, yaw);
        let w_en = geodesy::transport_rate_ned(h.lat, h.height_m, &(c * h.v_body));
        yaw = alignment::gyrocompass(&(h.w_mean - c.inverse() * w_en), h.roll, h.pitch);
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
    let yaw = alignment::magnetic_heading(&m, h.roll, h.pitch, d.declination_deg.to_radians());
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
        let nav = &self.estimate.nav;
        let (roll, pitch, yaw) = nav.ned_from_body.euler_angles();
        let position = match self.position {
            PositionSource::Gnss { .. } => "first GNSS fix".to_string(),
            PositionSource::StartFix { .. } => "`start` position fix".to_string(),
            PositionSource::MissionOrigin => {
                "mission origin (no GNSS fix or start mark near the start)".to_string()
            }
            PositionSource::Truth => "/truth with drawn errors (a study's start)".to_string(),
        };
        writeln!(
            f,
            "position   {:.7} deg N {:.7} deg E, depth {:.1} m   from {position} (1-sigma {:.1} m)",
            nav.lat_rad.to_degrees(),
            nav.lon_rad.to_degrees(),
            -nav.height_m,
            self.position_sigma_m
        )?;
        let velocity = match self.velocity {
            VelocitySource::Dvl { .. } => "first DVL reading in range",
            VelocitySource::SpeedLog { .. } => "EM-log speed along the body x axis",
            VelocitySource::Propeller { .. } => "propeller speed along the body x axis",
            VelocitySource::Truth => "/truth with a drawn error",
            VelocitySource::AtRest => "none: assumed at rest",
        };
        let v = nav.vel_ned_m_s;
        writeln!(
            f,
            "velocity   N {:.2} E {:.2} D {:.2} m/s   from {velocity} (1-sigma {:.2} m/s)",
            v.x, v.y, v.z, self.velocity_sigma_m_s
        )?;
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
        )?;
        let declination = |d: &DeclinationUsed| {
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
        };
        for c in &self.heading_sources {
            let detail = match c.source {
                HeadingSource::Gyrocompass => {
                    format!("gyrocompassing {:.0} s of IMU data", self.window_s)
                }
                HeadingSource::Magnetometer => format!(
                    "magnetometer, {}",
                    self.declination
                        .as_ref()
                        .map(declination)
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

impl PositionSource {
    pub fn name(&self) -> &'static str {
        match self {
            PositionSource::Gnss { .. } => "gnss",
            PositionSource::StartFix { .. } => "start_fix",
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
