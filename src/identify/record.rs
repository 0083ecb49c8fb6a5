//! What identification reads from a log: the stern plane, q, theta, w and depth on the IMU's
//! clock, and the forward speed.

use crate::contract::{Attitude, ControlSurfaces, Depth, Dvl, Imu};
use crate::ingest::Log;

/// One log's measurements, on the IMU's clock (`t_s` from its first sample).
#[derive(Debug, Clone, PartialEq)]
pub struct Record {
    pub name: String,
    /// Stamp of the first IMU sample, ns.
    pub start_stamp_ns: i64,
    pub t_s: Vec<f64>,
    /// Stern plane (latest `/fins` reading), rad.
    pub plane_rad: Vec<f64>,
    /// Pitch rate (gyro y), rad/s.
    pub q_rad_s: Vec<f64>,
    /// Pitch (latest `/attitude`, or hindsight's own attitude), rad.
    pub theta_rad: Vec<f64>,
    /// Heave velocity (DVL body z) at the grid index of each valid reading.
    pub w_m_s: Vec<(usize, f64)>,
    /// Depth at the grid index of each reading.
    pub depth_m: Vec<(usize, f64)>,
    /// Forward speed: the mean DVL body x velocity (or the one given), m/s.
    pub speed_m_s: f64,
    /// Where theta came from.
    pub theta_source: &'static str,
    /// Weight minus buoyancy during this log, N, when known to differ from the settings'
    /// constant (a ballast change).
    pub weight_minus_buoyancy_n: Option<f64>,
}

/// Why a log cannot be identified from.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RecordError {
    #[error("{log}: no IMU data on /imu (q is measured by the gyro)")]
    NoImu { log: String },
    #[error("{log}: no stern-plane input on /fins: identification needs the input that drove the motion")]
    NoFins { log: String },
    #[error("{log}: no DVL readings on /dvl with bottom lock: w is measured by the DVL (and U, unless the speed is given)")]
    NoDvl { log: String },
    #[error("{log}: no depth readings on /depth")]
    NoDepth { log: String },
    #[error(
        "{log}: {duration_s:.0} s of data, shorter than the model's slowest time constant \
         ({needed_s:.0} s): the coefficients cannot be identified from it"
    )]
    TooShort {
        log: String,
        duration_s: f64,
        needed_s: f64,
    },
    #[error(
        "{log}: the {fin} moves by {range_deg:.2} deg in all: no manoeuvre, so the \
         coefficients are unidentifiable (fly a zig-zag)"
    )]
    NoManoeuvre {
        log: String,
        fin: &'static str,
        range_deg: f64,
    },
    #[error(
        "{log}: no propeller speed on /rpm: the 6-DOF model's thrust depends on it (identify \
         with the heave-pitch model, which takes the forward speed instead, or record /rpm)"
    )]
    NoRpm { log: String },
}

/// The latest sample at or before each grid stamp (the first one before it starts).
pub(crate) fn latest<T>(samples: &[T], stamp: impl Fn(&T) -> i64, grid: &[i64]) -> Vec<usize> {
    let mut j = 0;
    grid.iter()
        .map(|&t| {
            while j + 1 < samples.len() && stamp(&samples[j + 1]) <= t {
                j += 1;
            }
            j
        })
        .collect()
}

/// The grid index nearest to each stamp.
pub(crate) fn nearest(grid: &[i64], t: i64) -> usize {
    let i = grid.partition_point(|&g| g < t);
    if i == 0 {
        0
    } else if i == grid.len() || t - grid[i - 1] <= grid[i] - t {
        i - 1
    } else {
        i
    }
}

/// The IMU's stamps, the clock identification runs on: refused when shorter than
/// [`MIN_DURATION_S`].
pub(crate) fn imu_grid(log: &str, imu: &[Imu]) -> Result<Vec<i64>, RecordError> {
    let grid: Vec<i64> = imu.iter().map(|m| m.stamp_ns).collect();
    let duration_s = match (grid.first(), grid.last()) {
        (Some(a), Some(b)) => (b - a) as f64 * 1e-9,
        _ => 0.0,
    };
    if duration_s < MIN_DURATION_S {
        return Err(RecordError::TooShort {
            log: log.to_string(),
            duration_s,
            needed_s: MIN_DURATION_S,
        });
    }
    Ok(grid)
}

/// Shortest log that can be identified from: the model's slowest time constant (the pitch
/// oscillation's period is about 60 s with the published coefficients).
pub const MIN_DURATION_S: f64 = 60.0;
/// Least stern-plane movement that counts as a manoeuvre, deg.
pub const MIN_PLANE_RANGE_DEG: f64 = 1.0;

impl Record {
    /// Reads a log. `speed_m_s` overrides the DVL's forward speed.
    pub fn from_log(name: &str, log: &Log, speed_m_s: Option<f64>) -> Result<Record, RecordError> {
        let log_name = name.to_string();
        let imu: &[Imu] = log.role();
        let fins: &[ControlSurfaces] = log.role();
        let attitude: &[Attitude] = log.role();
        let dvl: Vec<&Dvl> = log.role::<Dvl>().iter().filter(|d| d.valid).collect();
        let depth: &[Depth] = log.role();
        if imu.len() < 2 {
            return Err(RecordError::NoImu { log: log_name });
        }
        if fins.is_empty() {
            return Err(RecordError::NoFins { log: log_name });
        }
        if dvl.is_empty() {
            return Err(RecordError::NoDvl { log: log_name });
        }
        if depth.is_empty() {
            return Err(RecordError::NoDepth { log: log_name });
        }
        let grid = imu_grid(&log_name, imu)?;
        let t0 = grid[0];
        let plane_rad: Vec<f64> = latest(fins, |f| f.stamp_ns, &grid)
            .into_iter()
            .map(|j| fins[j].stern_plane)
            .collect();
        let (lo, hi) = plane_rad
            .iter()
            .fold((f64::MAX, f64::MIN), |(lo, hi), &p| (lo.min(p), hi.max(p)));
        let range_deg = (hi - lo).to_degrees();
        if range_deg < MIN_PLANE_RANGE_DEG {
            return Err(RecordError::NoManoeuvre {
                log: log_name,
                fin: "stern plane",
                range_deg,
            });
        }
        let (theta_rad, theta_source) = if attitude.is_empty() {
            (
                own_pitch(imu),
                "hindsight's attitude (gyro and accelerometer; no /attitude)",
            )
        } else {
            (
                latest(attitude, |a| a.stamp_ns, &grid)
                    .into_iter()
                    .map(|j| attitude[j].pitch)
                    .collect(),
                "/attitude",
            )
        };
        let speed_m_s = speed_m_s
            .unwrap_or_else(|| dvl.iter().map(|d| d.velocity[0]).sum::<f64>() / dvl.len() as f64);
        Ok(Record {
            name: log_name,
            start_stamp_ns: t0,
            t_s: grid.iter().map(|&t| (t - t0) as f64 * 1e-9).collect(),
            plane_rad,
            q_rad_s: imu.iter().map(|m| m.angular_velocity[1]).collect(),
            theta_rad,
            w_m_s: dvl
                .iter()
                .map(|d| (nearest(&grid, d.stamp_ns), d.velocity[2]))
                .collect(),
            depth_m: depth
                .iter()
                .map(|d| (nearest(&grid, d.stamp_ns), d.depth))
                .collect(),
            speed_m_s,
            theta_source,
            weight_minus_buoyancy_n: None,
        })
    }
}

/// Pitch from the IMU alone: hindsight's MEKF without a magnetometer (gravity and gyro).
fn own_pitch(imu: &[Imu]) -> Vec<f64> {
    let inputs = crate::attitude::AhrsInputs {
        imu,
        mag: &[],
        declination_rad: 0.0,
        initial_yaw_rad: Some(0.0),
    };
    let (samples, _) = crate::attitude::mekf::run_smoothed(
        &inputs,
        &crate::attitude::mekf::MekfSettings::default(),
    )
    .unwrap_or_else(|| crate::attitude::mekf::run(&inputs, &Default::default()));
    imu.iter()
        .map(|m| {
            crate::attitude::dead_reckoning::attitude_at(&samples, m.stamp_ns)
                .map_or(0.0, |q| crate::attitude::euler::from_quaternion(&q)[1])
        })
        .collect()
}
