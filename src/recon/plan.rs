//! The plan: which aids, calibration states and stages a reconstruction uses, decided from
//! the log, and why.
//!
//! [`LogFacts::of`] inspects the log (what is present, where the DVL is out, how far apart its
//! absolute positions are); [`Plan::decide`] applies the rules a navigation engineer expects
//! to those facts and to what the configuration switched; [`Plan::apply`] turns the
//! decisions into the configuration the passes run with. A part that refuses itself while
//! running (a propeller that does not tell the speed, a vehicle model that does not fit) is
//! marked afterwards with [`Plan::refuse`].

use super::acoustic_delay::ReceiptDelay;
use super::config::Config;
use super::dvl_delay::{self, StampDelay};
use super::on_off_auto::Switch;
use super::Streams;
use crate::filters::ins::aid_table::Sensor;
use crate::ingest::Mission;
use serde::Serialize;
use std::fmt;

/// A DVL gap: this long without a reading in range (bottom lock, altitude) while the IMU runs.
pub const DVL_GAP_S: f64 = 30.0;

/// The configuration key of the DVL's range.
pub const DVL_RANGE_KEY: &str = "dvl.max_altitude_m";

/// The configuration key of the DVL's stamp delay.
pub const DVL_DELAY_KEY: &str = "dvl.stamp_delay_s";

/// The configuration key of the acoustic fixes' receipt delay.
pub const ACOUSTIC_DELAY_KEY: &str = "acoustic_fix.receipt_delay_s";

/// The configuration key of the DVL's lever arm.
pub const DVL_LEVER_ARM_KEY: &str = "dvl.lever_arm_m";

/// A DVL stamp delay is used when it is this many sigmas from zero ...
pub const DELAY_MIN_SIGMAS: f64 = 3.0;
/// ... and explains the DVL's velocity changes clearly better than none: its chi-square
/// against zero delay is at least this (5 sigmas' worth).
pub const DELAY_MIN_CHI_SQUARE: f64 = 25.0;

/// A pair of absolute positions makes the DVL's scale and misalignment observable when the
/// error their priors would build up between the two is this many times the pair's sigma.
pub const OBSERVABLE_RATIO: f64 = 2.0;

/// Absolute positions kept for the pair search (the best of each stretch).
const MAX_POSITIONS: usize = 200;

/// What the log holds that the plan is decided from.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LogFacts {
    /// Readings per aiding sensor, in [`Sensor::ALL`]'s order.
    pub readings: Vec<(Sensor, usize)>,
    pub fins: usize,
    pub rpm: usize,
    /// DVL readings in range.
    pub dvl_in_range: usize,
    /// The largest altitude the DVL reported with a bottom lock: the range it showed, m.
    pub dvl_reported_range_m: Option<f64>,
    /// The DVL's range the passes use, m: the configured one, or (when the configuration
    /// does not give it) the larger of the default and the range the DVL showed.
    pub dvl_max_altitude_m: f64,
    /// Stretches of at least [`DVL_GAP_S`] without a DVL reading in range, while the IMU
    /// runs (after the first reading in range): their count and the longest, s.
    pub dvl_gaps: usize,
    pub dvl_longest_gap_s: f64,
    /// The vehicle the model aid would use (the configuration's, else the mission's when
    /// built in), or why there is none.
    pub vehicle: Result<String, String>,
    /// The farthest pair of absolute positions (GNSS, fixes), when there are two.
    pub farthest_positions: Option<PositionPair>,
    /// The DVL's stamp delay estimated from the IMU and the DVL (when the configuration
    /// gives none and the DVL is used).
    pub dvl_delay: Option<StampDelay>,
    /// Acoustic fixes stamped on receipt that carry no delay.
    pub acoustic_fixes_without_delay: usize,
    /// USBL observations stamped on receipt without their delay.
    pub usbl_without_delay: usize,
}

/// Two absolute positions and what lies between them.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PositionPair {
    pub distance_m: f64,
    /// Their combined 1-sigma, m.
    pub sigma_m: f64,
    pub seconds_apart: f64,
}

impl LogFacts {
    /// Inspects the streams (the configuration gives the DVL's range checks and the vehicle).
    pub fn of(streams: &Streams<'_>, mission: &Mission, config: &Config) -> LogFacts {
        let readings = Sensor::ALL
            .into_iter()
            .map(|s| (s, s.readings(streams)))
            .collect();
        let dvl_reported_range_m = streams
            .dvl
            .iter()
            .filter(|d| d.valid)
            .filter_map(|d| d.altitude)
            .filter(|h| h.is_finite())
            .max_by(f64::total_cmp);
        let dvl_max_altitude_m = match dvl_reported_range_m {
            Some(range) if !config.fixed.contains(DVL_RANGE_KEY) => {
                range.max(config.dvl.max_altitude_m)
            }
            _ => config.dvl.max_altitude_m,
        };
        let mut ranged = config.clone();
        ranged.dvl.max_altitude_m = dvl_max_altitude_m;
        let dvl = ranged.settings().aiding.dvl(streams);
        let readings_in_range = dvl.in_range_body_velocities();
        let in_range: Vec<i64> = readings_in_range.iter().map(|r| r.stamp_ns).collect();
        // The delay and the lever arm, unless the configuration gives both (a given delay is
        // held while the lever arm is estimated).
        let given_delay = config
            .fixed
            .contains(DVL_DELAY_KEY)
            .then_some(config.dvl.stamp_delay_s);
        let estimated = given_delay.is_none() || !config.fixed.contains(DVL_LEVER_ARM_KEY);
        let dvl_delay = (config.dvl.enabled && estimated)
            .then(|| {
                dvl_delay::estimate(
                    streams.imu,
                    &readings_in_range,
                    &dvl.mounting.lever_arm_body_m,
                    given_delay,
                )
            })
            .flatten();
        let imu_end = streams.imu.last().map_or(0, |m| m.stamp_ns);
        let (dvl_gaps, dvl_longest_gap_s) = gaps(&in_range, imu_end);
        LogFacts {
            readings,
            fins: streams.fins.len(),
            rpm: streams.rpm.len(),
            dvl_in_range: in_range.len(),
            dvl_reported_range_m,
            dvl_max_altitude_m,
            dvl_gaps,
            dvl_longest_gap_s,
            vehicle: vehicle_of(config, mission),
            farthest_positions: best_pair(
                farthest_positions(streams, mission, config),
                lbl_farthest_positions(streams, config),
            ),
            dvl_delay,
            acoustic_fixes_without_delay: streams
                .acoustic_fixes
                .iter()
                .filter(|f| crate::filters::ins::acoustic::needs_delay(f))
                .count(),
            usbl_without_delay: (streams.usbl.iter())
                .filter(|o| crate::filters::ins::usbl::observation_needs_delay(o))
                .count(),
        }
    }

    fn count(&self, sensor: Sensor) -> usize {
        self.readings
            .iter()
            .find(|(s, _)| *s == sensor)
            .map_or(0, |(_, n)| *n)
    }
}

/// Gaps of at least [`DVL_GAP_S`] between readings in range, and after the last one until
/// the IMU ends: their count and the longest, s.
fn gaps(stamps: &[i64], end_ns: i64) -> (usize, f64) {
    let Some(&last) = stamps.last() else {
        return (0, 0.0);
    };
    let lengths = stamps
        .windows(2)
        .map(|w| w[1] - w[0])
        .chain([end_ns - last])
        .map(|ns| ns as f64 * 1e-9)
        .filter(|&s| s >= DVL_GAP_S);
    lengths.fold((0, 0.0), |(n, longest), s| (n + 1, f64::max(longest, s)))
}

fn vehicle_of(config: &Config, mission: &Mission) -> Result<String, String> {
    if !config.model_velocity.vehicle.is_empty() {
        return Ok(config.model_velocity.vehicle.clone());
    }
    match crate::vehicle::six_dof::description::Vehicle::built_in(&mission.vehicle) {
        Some(_) => Ok(mission.vehicle.clone()),
        None if mission.vehicle.is_empty() => Err("the log names no vehicle".into()),
        None => Err(format!(
            "the mission's vehicle `{}` is not built in (give a vehicle file)",
            mission.vehicle
        )),
    }
}

/// The farthest-apart pair of absolute positions (GNSS fixes, position fixes, acoustic
/// fixes and USBL observations placed by the ship's pose), thinned to the best-sigma position
/// of each stretch (LBL ranges: [`lbl_farthest_positions`]).
fn farthest_positions(
    streams: &Streams<'_>,
    mission: &Mission,
    config: &Config,
) -> Option<PositionPair> {
    const EARTH_RADIUS_M: f64 = 6_371_000.0;
    let (lat0, lon0) = (
        mission.origin_latitude_deg.to_radians(),
        mission.origin_longitude_deg.to_radians(),
    );
    let mut acoustic = (config.acoustic_fix.aid())
        .map(|a| {
            crate::filters::ins::acoustic::valid_fixes(streams.acoustic_fixes, streams.ship, &a)
        })
        .unwrap_or_default();
    // Where the USBL's observations are, for the plan: a delay of seconds does not move them
    // by much.
    if let Some(a) = config.usbl.aid(&config.acoustic_fix, true) {
        let aid = crate::filters::ins::usbl::UsblAid::new(streams.usbl, streams.ship, &a);
        acoustic.extend(aid.positioned_fixes());
    }
    let acoustic = acoustic.into_iter().map(|f| {
        (
            f.stamp_ns,
            (f.lat_rad - lat0) * EARTH_RADIUS_M,
            (f.lon_rad - lon0) * EARTH_RADIUS_M * lat0.cos(),
            f.sigma_m,
        )
    });
    let mut all: Vec<(i64, f64, f64, f64)> = streams
        .gnss
        .iter()
        .map(|g| {
            (
                g.stamp_ns,
                (g.latitude_deg.to_radians() - lat0) * EARTH_RADIUS_M,
                (g.longitude_deg.to_radians() - lon0) * EARTH_RADIUS_M * lat0.cos(),
                g.horizontal_sigma_m,
            )
        })
        .chain(
            streams
                .fixes
                .iter()
                .map(|f| (f.stamp_ns, f.north_m, f.east_m, f.sigma_m)),
        )
        .chain(acoustic)
        .filter(|p| p.3 > 0.0 && p.1.is_finite() && p.2.is_finite())
        .collect();
    all.sort_by_key(|p| p.0);
    let stride = all.len().div_ceil(MAX_POSITIONS).max(1);
    let kept: Vec<_> = all
        .chunks(stride)
        .filter_map(|c| c.iter().min_by(|a, b| a.3.total_cmp(&b.3)).copied())
        .collect();
    let mut best: Option<PositionPair> = None;
    for (i, a) in kept.iter().enumerate() {
        for b in &kept[i + 1..] {
            let pair = PositionPair {
                distance_m: (b.1 - a.1).hypot(b.2 - a.2),
                sigma_m: a.3.hypot(b.3),
                seconds_apart: (b.0 - a.0) as f64 * 1e-9,
            };
            if best.is_none_or(|x| pair.distance_m / pair.sigma_m > x.distance_m / x.sigma_m) {
                best = Some(pair);
            }
        }
    }
    best
}

/// The pair of positions LBL ranges set farthest apart, at least: the vehicle moved at least
/// as far as the range to one beacon changed (the triangle inequality), between the shortest
/// and the longest range to it.
fn lbl_farthest_positions(streams: &Streams<'_>, config: &Config) -> Option<PositionPair> {
    use crate::filters::ins::lbl::{range_and_travel_time, range_sigma_m};
    let aiding = config.lbl.aid()?;
    // Per beacon: the shortest and the longest range, each with its stamp and sigma.
    type Extremes = ((f64, i64, f64), (f64, i64, f64));
    let mut per_beacon: std::collections::BTreeMap<&str, Extremes> = Default::default();
    for reply in streams.lbl {
        if streams.beacons.iter().all(|b| b.id != reply.beacon_id) {
            continue;
        }
        let Some((range_m, _)) = range_and_travel_time(reply, aiding.sound_speed_m_s) else {
            continue;
        };
        let this = (range_m, reply.stamp_ns, range_sigma_m(reply, &aiding));
        let e = per_beacon.entry(&reply.beacon_id).or_insert((this, this));
        if range_m < e.0 .0 {
            e.0 = this;
        }
        if range_m > e.1 .0 {
            e.1 = this;
        }
    }
    (per_beacon.values())
        .map(|(near, far)| PositionPair {
            distance_m: far.0 - near.0,
            sigma_m: near.2.hypot(far.2),
            seconds_apart: (far.1 - near.1).abs() as f64 * 1e-9,
        })
        .fold(None, |best, pair| best_pair(best, Some(pair)))
}

/// The pair whose distance stands out more from its sigma.
fn best_pair(a: Option<PositionPair>, b: Option<PositionPair>) -> Option<PositionPair> {
    match (a, b) {
        (Some(a), Some(b)) => Some(if b.distance_m / b.sigma_m > a.distance_m / a.sigma_m {
            b
        } else {
            a
        }),
        (a, b) => a.or(b),
    }
}

/// A part of the reconstruction the plan decides on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Part {
    /// An aiding sensor of the table.
    Aid(Sensor),
    /// The DVL's scale factor and mounting misalignment states.
    DvlScaleMisalignment,
    /// The DVL's bias states.
    DvlBias,
    /// The delay of the DVL's stamps, taken out of them.
    DvlStampDelay,
    /// The DVL's lever arm from the IMU.
    DvlLeverArm,
    /// The EM log's scale factor and the water current.
    EmlScaleCurrent,
    /// The IMU's biases (and the z gyro's scale factor).
    ImuBiases,
    /// Self-tuning of the noise figures.
    Tuning,
    /// The in-motion heading alignment.
    InMotionAlignment,
    /// The delay of acoustic fixes stamped on receipt, taken off their stamps.
    AcousticFixDelay,
}

impl Part {
    pub fn name(&self) -> &'static str {
        match self {
            Part::Aid(s) => s.name(),
            Part::DvlScaleMisalignment => "dvl scale and misalignment",
            Part::DvlBias => "dvl bias",
            Part::DvlStampDelay => "dvl stamp delay",
            Part::DvlLeverArm => "dvl lever arm",
            Part::EmlScaleCurrent => "eml scale and current",
            Part::ImuBiases => "imu biases",
            Part::Tuning => "self-tuning",
            Part::InMotionAlignment => "in-motion alignment",
            Part::AcousticFixDelay => "acoustic fix delay",
        }
    }
}

/// Why a part is used or not.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "reason", rename_all = "snake_case")]
pub enum Why {
    /// The log has its readings.
    Present { readings: usize },
    /// The log has none.
    Absent { needs: String },
    /// The DVL's readings, those in range, and the range used.
    InRange {
        readings: usize,
        in_range: usize,
        max_altitude_m: f64,
        /// The range is the one the DVL showed in the log (the configuration gave none).
        from_log: bool,
    },
    /// The DVL has readings but none in range.
    NoneInRange {
        readings: usize,
        max_altitude_m: f64,
    },
    /// The configuration turned it on or off.
    Switched { on: bool },
    /// On or off by default (the configuration leaves it as it is).
    ByDefault { on: bool },
    /// The DVL has gaps for it to bridge.
    DvlGaps { gaps: usize, longest_s: f64 },
    /// The DVL has no gap for it to bridge.
    NoDvlGaps,
    /// The model-aided filter bridges the DVL's gaps (it models the propeller too).
    ModelAidBridges,
    /// Absolute positions far enough apart for the priors to show.
    Observable {
        distance_m: f64,
        sigma_m: f64,
        predicted_m: f64,
    },
    /// No pair of absolute positions far enough apart.
    NotObservable { detail: String },
    /// Its prior sigma in the configuration is zero.
    PriorZero,
    /// It refused itself when it ran (its own checks).
    Refused { why: String },
    /// The forced-on part cannot run: the log lacks what it needs.
    ForcedButMissing { needs: String },
    /// Depends on another part.
    Follows { on: String, used: bool },
    /// The configuration gives it.
    Given { value: f64 },
    /// Estimated from the log, clearly (used) or not (not used).
    Estimated {
        delay_s: f64,
        sigma_s: f64,
        chi_square_vs_zero: f64,
        pairs: usize,
    },
    /// The log's readings could not tell it.
    CannotTell { detail: String },
    /// Each acoustic fix carries its time of validity (or its delay).
    CarriedByFixes,
    /// The acoustic fixes' receipt delay estimated from the log (used when the log tells it).
    EstimatedReceiptDelay {
        delay_s: f64,
        sigma_s: f64,
        /// Against the track alone, before the filter's likelihood refined it.
        track_delay_s: f64,
        fixes: usize,
        windows: usize,
        outliers: usize,
    },
    /// The configuration gives the lever arm, body FRD, m.
    GivenLeverArm { lever_arm_m: [f64; 3] },
    /// The lever arm estimated from the log, clearly other than the configured one (used) or
    /// not (not used).
    EstimatedLeverArm {
        /// The arm used: the configured one, with the estimate's clear axes when they are
        /// used.
        lever_arm_m: [f64; 3],
        /// The whole estimate and its sigmas.
        estimate_m: [f64; 3],
        sigma_m: [f64; 3],
        chi_square_vs_configured: f64,
        /// How much the clear axes move the readings, and the noise of their differences,
        /// m/s.
        effect_m_s: f64,
        noise_m_s: f64,
        pairs: usize,
        verdict: LeverVerdict,
    },
}

impl fmt::Display for Why {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Why::Present { readings } => write!(f, "present ({readings} readings)"),
            Why::Absent { needs } => write!(f, "absent: the log has no {needs}"),
            Why::InRange {
                readings,
                in_range,
                max_altitude_m,
                from_log,
            } => write!(
                f,
                "present ({readings} readings, {in_range} in range: bottom lock, altitude up to \
                 {max_altitude_m:.0} m{})",
                if *from_log { ", the range the DVL showed in the log" } else { "" }
            ),
            Why::NoneInRange {
                readings,
                max_altitude_m,
            } => write!(
                f,
                "{readings} readings, none in range (bottom lock, altitude up to \
                 {max_altitude_m:.0} m)"
            ),
            Why::Switched { on: true } => write!(f, "switched on by the configuration"),
            Why::Switched { on: false } => write!(f, "switched off by the configuration"),
            Why::ByDefault { on: true } => write!(f, "on by default"),
            Why::ByDefault { on: false } => write!(f, "off by default"),
            Why::DvlGaps { gaps, longest_s } => write!(
                f,
                "the DVL is out {gaps} time(s) for {DVL_GAP_S:.0} s or more (longest {longest_s:.0} s)"
            ),
            Why::NoDvlGaps => write!(f, "the DVL has no gap of {DVL_GAP_S:.0} s or more to bridge"),
            Why::ModelAidBridges => write!(f, "the model-aided filter bridges the DVL's gaps"),
            Why::Observable {
                distance_m,
                sigma_m,
                predicted_m,
            } => write!(
                f,
                "observable: absolute positions {distance_m:.0} m apart (1-sigma {sigma_m:.1} m), \
                 where the priors would show as {predicted_m:.1} m"
            ),
            Why::NotObservable { detail } => write!(f, "not observable: {detail}; held"),
            Why::PriorZero => write!(f, "held: its prior sigma is 0 in the configuration"),
            Why::Refused { why } => write!(f, "refused by its own checks: {why}"),
            Why::ForcedButMissing { needs } => {
                write!(f, "switched on, but refused: the log has no {needs}")
            }
            Why::Follows { on, used: true } => write!(f, "with the {on}"),
            Why::Follows { on, used: false } => write!(f, "the {on} is not used"),
            Why::Given { value } => write!(f, "{value:+.3} s, as given"),
            Why::Estimated {
                delay_s,
                sigma_s,
                chi_square_vs_zero,
                pairs,
            } => write_estimated_delay(f, *delay_s, *sigma_s, *chi_square_vs_zero, *pairs),
            Why::CannotTell { detail } => write!(f, "cannot tell: {detail}; 0 is used"),
            Why::CarriedByFixes => {
                write!(f, "each fix carries its time of validity or its delay")
            }
            Why::EstimatedReceiptDelay {
                delay_s,
                sigma_s,
                track_delay_s,
                fixes,
                windows,
                outliers,
            } => {
                write!(
                    f,
                    "{delay_s:.3} s (1-sigma {sigma_s:.3} s) by the likelihood of the fixes' \
                     innovations, from {track_delay_s:.3} s found by {fixes} fixes in \
                     {windows} windows against a pass without them ({outliers} off the \
                     track, left out)"
                )?;
                if *sigma_s <= super::acoustic_delay::MAX_SIGMA_S {
                    write!(f, ": taken off the stamps of the fixes received late")
                } else {
                    write!(
                        f,
                        ": not told clearly (the vehicle turns too little); 0 is used, give \
                         acoustic_fix.receipt_delay_s"
                    )
                }
            }
            Why::GivenLeverArm { lever_arm_m: [x, y, z] } => {
                write!(f, "[{x:+.2}, {y:+.2}, {z:+.2}] m (body FRD), as given")
            }
            Why::EstimatedLeverArm { .. } => self.write_estimated_lever_arm(f),
        }
    }
}

/// An estimated DVL stamp delay and whether it is taken out.
fn write_estimated_delay(
    f: &mut fmt::Formatter<'_>,
    delay_s: f64,
    sigma_s: f64,
    chi_square_vs_zero: f64,
    pairs: usize,
) -> fmt::Result {
    write!(
        f,
        "{delay_s:+.3} s (1-sigma {sigma_s:.3} s, chi-square {chi_square_vs_zero:.1} \
         against none) from the IMU and {pairs} pairs of DVL readings"
    )?;
    if delay_clear(delay_s, sigma_s, chi_square_vs_zero) {
        write!(f, ": taken out of the DVL's stamps")
    } else {
        write!(
            f,
            ": not clearly other than 0 (the velocity changes too little to tell); \
             0 is used"
        )
    }
}

impl Why {
    /// An estimated DVL lever arm and whether it is used.
    fn write_estimated_lever_arm(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let Why::EstimatedLeverArm {
            lever_arm_m: [x, y, z],
            estimate_m: [ex, ey, ez],
            sigma_m: [sx, sy, sz],
            chi_square_vs_configured,
            effect_m_s,
            noise_m_s,
            pairs,
            verdict,
        } = self
        else {
            return Ok(());
        };
        write!(
            f,
            "[{ex:+.2}, {ey:+.2}, {ez:+.2}] m (body FRD; 1-sigma {sx:.2}, {sy:.2}, \
             {sz:.2} m; chi-square {chi_square_vs_configured:.1} against the configured \
             one) from the IMU's rates and {pairs} pairs of DVL readings"
        )?;
        match verdict {
            LeverVerdict::Used => write!(
                f,
                ": [{x:+.2}, {y:+.2}, {z:+.2}] m used for every pass (the axes {:.0} \
                 sigmas clear; they move the readings by {:.1} cm/s in the turns)",
                dvl_delay::LEVER_AXIS_SIGMAS,
                effect_m_s * 100.0
            ),
            LeverVerdict::RatesBiased => write!(
                f,
                ": not used, the gyro's bias (a MEMS gyro's) is in the rates it \
                 multiplies; the configured one is used"
            ),
            LeverVerdict::NotClear => write!(
                f,
                ": not clearly other than the configured one (the body turns too \
                 little to tell); the configured one is used"
            ),
            LeverVerdict::NoEffect => write!(
                f,
                ": not used, its clear axes move the readings by {:.1} cm/s about \
                 each window's mean rate, under the {:.1} cm/s of their differences' \
                 noise; the configured one is used",
                effect_m_s * 100.0,
                noise_m_s * 100.0
            ),
        }
    }
}

/// Whether an estimated lever arm is used, or why not.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum LeverVerdict {
    Used,
    /// A MEMS gyro's bias is in the rates: it was not fitted.
    RatesBiased,
    /// No axis is clearly other than the configured arm's.
    NotClear,
    /// The clear axes change the readings less than their noise (a steady turn "shows" an
    /// arm that is something else).
    NoEffect,
}

/// One decision.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Decision {
    pub part: Part,
    pub name: &'static str,
    pub used: bool,
    #[serde(flatten)]
    pub why: Why,
}

/// Every decision, in a fixed order (the aids, the calibration states, the stages).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Plan {
    pub decisions: Vec<Decision>,
    /// The DVL's range the passes use, m.
    pub dvl_max_altitude_m: f64,
}

fn decision(part: Part, used: bool, why: Why) -> Decision {
    Decision {
        part,
        name: part.name(),
        used,
        why,
    }
}

impl Plan {
    /// The rules, applied to the log's facts and the configuration's switches.
    pub fn decide(facts: &LogFacts, config: &Config) -> Plan {
        let mut decisions: Vec<Decision> = Sensor::ALL
            .into_iter()
            .map(|s| aid_decision(s, facts, config))
            .collect();
        let uses = |d: &[Decision], s: Sensor| d.iter().any(|x| x.part == Part::Aid(s) && x.used);
        let dvl = uses(&decisions, Sensor::Dvl);
        decisions.push(scale_misalignment(facts, config, dvl));
        let follows = |on: &str, used: bool| Why::Follows {
            on: on.into(),
            used,
        };
        let bias = dvl && config.dvl.bias_sigma_m_s > 0.0;
        decisions.push(decision(
            Part::DvlBias,
            bias,
            if dvl && !bias {
                Why::PriorZero
            } else {
                follows("dvl", dvl)
            },
        ));
        decisions.push(stamp_delay(facts, config, dvl));
        decisions.push(lever_arm(facts, config, dvl));
        let eml = uses(&decisions, Sensor::SpeedLog);
        decisions.push(decision(Part::EmlScaleCurrent, eml, follows("eml", eml)));
        let default = Config::default();
        for (part, on, by_default) in [
            (
                Part::ImuBiases,
                config.imu.estimate_biases,
                default.imu.estimate_biases,
            ),
            (Part::Tuning, config.tune.enabled, default.tune.enabled),
            (
                Part::InMotionAlignment,
                config.alignment.enabled,
                default.alignment.enabled,
            ),
        ] {
            let why = if on == by_default {
                Why::ByDefault { on }
            } else {
                Why::Switched { on }
            };
            decisions.push(decision(part, on, why));
        }
        if uses(&decisions, Sensor::AcousticFix) || uses(&decisions, Sensor::Usbl) {
            decisions.push(acoustic_fix_delay(facts, config));
        }
        Plan {
            decisions,
            dvl_max_altitude_m: facts.dvl_max_altitude_m,
        }
    }

    /// The acoustic fixes' receipt delay as the pipeline estimated it (`None`: no track to
    /// estimate it from).
    pub fn estimated_acoustic_delay(&mut self, estimate: Option<&ReceiptDelay>) {
        let round = |x: f64| (x * 1000.0).round() / 1000.0;
        let d = match estimate {
            Some(e) => decision(
                Part::AcousticFixDelay,
                e.is_clear(),
                Why::EstimatedReceiptDelay {
                    delay_s: round(e.delay_s),
                    sigma_s: round(e.sigma_s),
                    track_delay_s: round(e.track_delay_s),
                    fixes: e.fixes,
                    windows: e.windows,
                    outliers: e.outliers,
                },
            ),
            None => decision(
                Part::AcousticFixDelay,
                false,
                Why::CannotTell {
                    detail: "too few fixes under a track without them".into(),
                },
            ),
        };
        match self.decisions.iter_mut().find(|x| x.part == d.part) {
            Some(x) => *x = d,
            None => self.decisions.push(d),
        }
    }

    /// Whether the acoustic fixes' receipt delay is left for the pipeline to estimate.
    pub fn acoustic_delay_to_estimate(&self) -> bool {
        self.decisions.iter().any(|d| {
            d.part == Part::AcousticFixDelay && matches!(d.why, Why::CannotTell { .. }) && !d.used
        }) && (self.uses(Part::Aid(Sensor::AcousticFix)) || self.uses(Part::Aid(Sensor::Usbl)))
    }

    /// The acoustic fixes' receipt delay used, s.
    pub fn acoustic_delay_s(&self) -> f64 {
        let d = self
            .decisions
            .iter()
            .find(|d| d.part == Part::AcousticFixDelay);
        match d.map(|d| (d.used, &d.why)) {
            Some((true, Why::Given { value })) => *value,
            Some((true, Why::EstimatedReceiptDelay { delay_s, .. })) => *delay_s,
            _ => 0.0,
        }
    }

    /// The delay taken out of the DVL's stamps, s (0 when none is).
    pub fn dvl_stamp_delay_s(&self) -> f64 {
        let d = self
            .decisions
            .iter()
            .find(|d| d.part == Part::DvlStampDelay);
        match d.map(|d| (d.used, &d.why)) {
            Some((true, Why::Given { value })) => *value,
            Some((true, Why::Estimated { delay_s, .. })) => *delay_s,
            _ => 0.0,
        }
    }

    /// The DVL's lever arm the plan estimated and uses, body FRD, m (`None`: the
    /// configuration's is used).
    pub fn dvl_lever_arm_m(&self) -> Option<[f64; 3]> {
        self.decisions
            .iter()
            .find(|d| d.part == Part::DvlLeverArm && d.used)
            .and_then(|d| match d.why {
                Why::EstimatedLeverArm { lever_arm_m, .. } => Some(lever_arm_m),
                _ => None,
            })
    }

    /// Whether the part is used.
    pub fn uses(&self, part: Part) -> bool {
        self.decisions.iter().any(|d| d.part == part && d.used)
    }

    /// The configuration the passes run with: every `auto` switch set as decided, and a part
    /// forced on that the log cannot support turned off.
    pub fn apply(&self, config: &Config) -> Config {
        let mut c = config.clone();
        c.rpm_velocity.enabled = Switch::from_bool(self.uses(Part::Aid(Sensor::RpmVelocity)));
        c.model_velocity.enabled = Switch::from_bool(self.uses(Part::Aid(Sensor::ModelVelocity)));
        c.dvl.scale_misalignment = Switch::from_bool(self.uses(Part::DvlScaleMisalignment));
        c.dvl.max_altitude_m = self.dvl_max_altitude_m;
        c.dvl.stamp_delay_s = self.dvl_stamp_delay_s();
        if let Some(lever_arm_m) = self.dvl_lever_arm_m() {
            c.dvl.lever_arm_m = lever_arm_m;
        }
        c
    }

    /// A part refused itself while running: not used, and why.
    pub fn refuse(&mut self, part: Part, why: String) {
        if let Some(d) = self.decisions.iter_mut().find(|d| d.part == part) {
            d.used = false;
            d.why = Why::Refused { why };
        }
    }

    /// Decisions the user forced against the log (a part switched on that cannot run).
    pub fn overruled(&self) -> impl Iterator<Item = &Decision> {
        self.decisions
            .iter()
            .filter(|d| matches!(d.why, Why::ForcedButMissing { .. }))
    }
}

impl fmt::Display for Plan {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for d in &self.decisions {
            let used = if d.used { "used" } else { "not used" };
            writeln!(f, "{:<27} {:<9} {}", d.name, used, d.why)?;
        }
        Ok(())
    }
}

/// Whether an estimated delay is clearly other than zero.
fn delay_clear(delay_s: f64, sigma_s: f64, chi_square_vs_zero: f64) -> bool {
    delay_s.abs() >= DELAY_MIN_SIGMAS * sigma_s && chi_square_vs_zero >= DELAY_MIN_CHI_SQUARE
}

/// A part the DVL's windows decide, when too few of them pair up.
fn too_few_windows(part: Part) -> Decision {
    let detail = format!(
        "fewer than {} windows of {} s with DVL readings in range in pairs",
        dvl_delay::MIN_WINDOWS,
        dvl_delay::WINDOW_S
    );
    decision(part, false, Why::CannotTell { detail })
}

/// Whether an estimated lever arm is clearly other than the configured one.
fn lever_clear(chi_square_vs_configured: f64) -> bool {
    chi_square_vs_configured >= dvl_delay::LEVER_MIN_CHI_SQUARE
}

/// The DVL's lever arm: the configuration's, else the estimate when it is clear.
fn lever_arm(facts: &LogFacts, config: &Config, dvl: bool) -> Decision {
    let part = Part::DvlLeverArm;
    if !dvl {
        return without_dvl(part);
    }
    let lever_arm_m = config.dvl.lever_arm_m;
    if config.fixed.contains(DVL_LEVER_ARM_KEY) {
        return decision(part, true, Why::GivenLeverArm { lever_arm_m });
    }
    match facts.dvl_delay {
        None => too_few_windows(part),
        Some(d) => {
            let l = d.lever_arm;
            let round = |x: f64| (x * 1000.0).round() / 1000.0;
            let verdict = if l.rates_biased {
                LeverVerdict::RatesBiased
            } else if !(l.fitted
                && lever_clear(l.chi_square_vs_configured)
                && l.clear_lever_arm_m != lever_arm_m)
            {
                LeverVerdict::NotClear
            } else if l.clear_effect_m_s < d.residual_m_s {
                LeverVerdict::NoEffect
            } else {
                LeverVerdict::Used
            };
            decision(
                part,
                verdict == LeverVerdict::Used,
                Why::EstimatedLeverArm {
                    lever_arm_m: if verdict == LeverVerdict::Used {
                        l.clear_lever_arm_m.map(round)
                    } else {
                        lever_arm_m
                    },
                    estimate_m: l.lever_arm_m.map(round),
                    sigma_m: l.sigma_m.map(round),
                    chi_square_vs_configured: (l.chi_square_vs_configured * 10.0).round() / 10.0,
                    effect_m_s: round(l.clear_effect_m_s),
                    noise_m_s: round(d.residual_m_s),
                    pairs: d.pairs,
                    verdict,
                },
            )
        }
    }
}

/// A part of the DVL's, the DVL not being used.
fn without_dvl(part: Part) -> Decision {
    let why = Why::Follows {
        on: "dvl".into(),
        used: false,
    };
    decision(part, false, why)
}

/// The acoustic fixes' receipt delay: carried by each fix, given, or left for the pipeline
/// to estimate (it needs a track: [`Plan::estimated_acoustic_delay`]).
fn acoustic_fix_delay(facts: &LogFacts, config: &Config) -> Decision {
    let part = Part::AcousticFixDelay;
    // A given delay stands even where no fix needs it: the USBL's raw observations share it.
    if config.fixed.contains(ACOUSTIC_DELAY_KEY) {
        let value = config.acoustic_fix.receipt_delay_s;
        return decision(part, value != 0.0, Why::Given { value });
    }
    if facts.acoustic_fixes_without_delay == 0 && facts.usbl_without_delay == 0 {
        return decision(part, true, Why::CarriedByFixes);
    }
    let detail = "not estimated yet".to_string();
    decision(part, false, Why::CannotTell { detail })
}

/// The DVL's stamp delay: the configuration's, else the estimate when it is clear.
fn stamp_delay(facts: &LogFacts, config: &Config, dvl: bool) -> Decision {
    let part = Part::DvlStampDelay;
    if !dvl {
        return without_dvl(part);
    }
    if config.fixed.contains(DVL_DELAY_KEY) {
        let value = config.dvl.stamp_delay_s;
        return decision(part, value != 0.0, Why::Given { value });
    }
    match facts.dvl_delay {
        None => too_few_windows(part),
        Some(d) => {
            let round = |x: f64| (x * 1000.0).round() / 1000.0;
            decision(
                part,
                delay_clear(d.delay_s, d.sigma_s, d.chi_square_vs_zero),
                Why::Estimated {
                    delay_s: round(d.delay_s),
                    sigma_s: round(d.sigma_s),
                    chi_square_vs_zero: (d.chi_square_vs_zero * 10.0).round() / 10.0,
                    pairs: d.pairs,
                },
            )
        }
    }
}

/// An aiding sensor: present and switched on (its `use`), or the rules of the velocity
/// filters.
fn aid_decision(sensor: Sensor, facts: &LogFacts, config: &Config) -> Decision {
    let part = Part::Aid(sensor);
    match sensor {
        Sensor::RpmVelocity => return rpm_velocity(facts, config),
        Sensor::ModelVelocity => return model_velocity(facts, config),
        _ => {}
    }
    let readings = facts.count(sensor);
    if !config.uses(sensor) {
        return decision(part, false, Why::Switched { on: false });
    }
    if sensor == Sensor::Dvl && readings > 0 && facts.dvl_in_range == 0 {
        return decision(
            part,
            false,
            Why::NoneInRange {
                readings,
                max_altitude_m: facts.dvl_max_altitude_m,
            },
        );
    }
    if sensor == Sensor::Dvl && readings > 0 {
        return decision(
            part,
            true,
            Why::InRange {
                readings,
                in_range: facts.dvl_in_range,
                max_altitude_m: facts.dvl_max_altitude_m,
                from_log: facts.dvl_max_altitude_m != config.dvl.max_altitude_m,
            },
        );
    }
    if readings == 0 {
        return decision(
            part,
            false,
            Why::Absent {
                needs: sensor.topic().into(),
            },
        );
    }
    decision(part, true, Why::Present { readings })
}

/// What the model aid needs that the log lacks.
fn model_needs(facts: &LogFacts) -> Option<String> {
    let mut missing = Vec::new();
    if facts.fins == 0 {
        missing.push("/fins".to_string());
    }
    if facts.rpm == 0 {
        missing.push("/rpm".to_string());
    }
    if let Err(why) = &facts.vehicle {
        missing.push(format!("vehicle ({why})"));
    }
    (!missing.is_empty()).then(|| missing.join(", "))
}

/// Seed 000's model-aided filter: whenever /fins, /rpm and a vehicle are present.
fn model_velocity(facts: &LogFacts, config: &Config) -> Decision {
    let part = Part::Aid(Sensor::ModelVelocity);
    let needs = model_needs(facts);
    match (config.model_velocity.enabled, needs) {
        (Switch::Off, _) => decision(part, false, Why::Switched { on: false }),
        (Switch::On, Some(needs)) => decision(part, false, Why::ForcedButMissing { needs }),
        (Switch::On, None) => decision(part, true, Why::Switched { on: true }),
        (Switch::Auto, Some(needs)) => decision(part, false, Why::Absent { needs }),
        (Switch::Auto, None) => decision(
            part,
            true,
            Why::Present {
                readings: facts.fins,
            },
        ),
    }
}

/// Seed 003's propeller velocity filter: whenever /rpm exists and the DVL has gaps (and the
/// model aid does not bridge them already).
fn rpm_velocity(facts: &LogFacts, config: &Config) -> Decision {
    let part = Part::Aid(Sensor::RpmVelocity);
    let needs = match (facts.rpm, facts.dvl_in_range) {
        (0, _) => Some("/rpm".to_string()),
        (_, 0) => Some("DVL readings in range to learn the propeller's speed from".into()),
        _ => None,
    };
    let model = model_velocity(facts, config).used;
    match (config.rpm_velocity.enabled, needs) {
        (Switch::Off, _) => decision(part, false, Why::Switched { on: false }),
        (Switch::On, Some(needs)) => decision(part, false, Why::ForcedButMissing { needs }),
        (Switch::On, None) => decision(part, true, Why::Switched { on: true }),
        (Switch::Auto, Some(needs)) => decision(part, false, Why::Absent { needs }),
        (Switch::Auto, None) if facts.dvl_gaps == 0 => decision(part, false, Why::NoDvlGaps),
        (Switch::Auto, None) if model => decision(part, false, Why::ModelAidBridges),
        (Switch::Auto, None) => decision(
            part,
            true,
            Why::DvlGaps {
                gaps: facts.dvl_gaps,
                longest_s: facts.dvl_longest_gap_s,
            },
        ),
    }
}

/// The DVL's scale and misalignment: estimated when absolute positions are far enough apart
/// for their priors to show, else held.
fn scale_misalignment(facts: &LogFacts, config: &Config, dvl: bool) -> Decision {
    let part = Part::DvlScaleMisalignment;
    let d = &config.dvl;
    if !dvl {
        return without_dvl(part);
    }
    if let Some(on) = d.scale_misalignment.given() {
        return decision(part, on, Why::Switched { on });
    }
    let prior = d.scale_sigma.hypot(d.misalignment_sigma_deg.to_radians());
    if prior == 0.0 {
        return decision(part, false, Why::PriorZero);
    }
    match facts.farthest_positions {
        Some(p) if prior * p.distance_m >= OBSERVABLE_RATIO * p.sigma_m => decision(
            part,
            true,
            Why::Observable {
                distance_m: p.distance_m,
                sigma_m: p.sigma_m,
                predicted_m: prior * p.distance_m,
            },
        ),
        Some(p) => decision(
            part,
            false,
            Why::NotObservable {
                detail: format!(
                    "the farthest absolute positions are {:.0} m apart (1-sigma {:.1} m), where \
                     the priors would show as only {:.1} m",
                    p.distance_m,
                    p.sigma_m,
                    prior * p.distance_m
                ),
            },
        ),
        None => decision(
            part,
            false,
            Why::NotObservable {
                detail: "fewer than two absolute positions (GNSS, fixes)".into(),
            },
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Section;

    fn facts() -> LogFacts {
        LogFacts {
            readings: Sensor::ALL.into_iter().map(|s| (s, 100)).collect(),
            fins: 0,
            rpm: 100,
            dvl_in_range: 100,
            dvl_reported_range_m: Some(80.0),
            dvl_max_altitude_m: 100.0,
            dvl_gaps: 0,
            dvl_longest_gap_s: 0.0,
            vehicle: Err("none".into()),
            farthest_positions: None,
            dvl_delay: None,
            acoustic_fixes_without_delay: 0,
            usbl_without_delay: 0,
        }
    }

    fn delay(delay_s: f64, sigma_s: f64, chi_square_vs_zero: f64) -> Option<StampDelay> {
        Some(StampDelay {
            delay_s,
            sigma_s,
            chi_square_vs_zero,
            pairs: 500,
            windows: 25,
            residual_m_s: 0.007,
            lever_arm: lever(false, 0.0),
        })
    }

    fn lever(fitted: bool, chi_square_vs_configured: f64) -> dvl_delay::LeverArm {
        dvl_delay::LeverArm {
            lever_arm_m: [1.0, 0.0, 0.3],
            correction_m: [1.0, 0.0, 0.3],
            sigma_m: [0.1, 0.2, 0.3],
            chi_square_vs_configured,
            fitted,
            rates_biased: false,
            clear_lever_arm_m: [1.0, 0.0, 0.3],
            clear_effect_m_s: 0.05,
        }
    }

    #[test]
    fn a_clear_lever_arm_is_used_and_a_given_one_is_kept() {
        let config = Config::default();
        for (fitted, chi_square, used) in [
            (true, 120.0, true),
            (true, 9.0, false),
            (false, 30.0, false),
        ] {
            let mut estimate = delay(0.3, 0.2, 4.0);
            if let Some(d) = estimate.as_mut() {
                d.lever_arm = lever(fitted, chi_square);
            }
            let facts = LogFacts {
                dvl_delay: estimate,
                ..facts()
            };
            let plan = Plan::decide(&facts, &config);
            assert_eq!(plan.uses(Part::DvlLeverArm), used, "{estimate:?}");
            let applied = plan.apply(&config).dvl.lever_arm_m;
            assert_eq!(applied, if used { [1.0, 0.0, 0.3] } else { [0.0; 3] });
        }
        let given = Config::from_toml("[dvl]\nlever_arm_m = [0.5, 0.0, 0.2]\n").unwrap();
        let mut estimate = delay(0.3, 0.2, 4.0);
        if let Some(d) = estimate.as_mut() {
            d.lever_arm = lever(true, 120.0);
        }
        let facts = LogFacts {
            dvl_delay: estimate,
            ..facts()
        };
        let plan = Plan::decide(&facts, &given);
        assert_eq!(plan.dvl_lever_arm_m(), None);
        assert_eq!(plan.apply(&given).dvl.lever_arm_m, [0.5, 0.0, 0.2]);
    }

    #[test]
    fn a_clear_dvl_delay_is_taken_out_and_an_unclear_one_is_not() {
        let config = Config::default();
        for (estimate, taken) in [
            (delay(0.3, 0.02, 400.0), 0.3),
            (delay(0.3, 0.2, 400.0), 0.0),
            (delay(0.3, 0.02, 9.0), 0.0),
            (None, 0.0),
        ] {
            let facts = LogFacts {
                dvl_delay: estimate,
                ..facts()
            };
            let plan = Plan::decide(&facts, &config);
            assert_eq!(plan.dvl_stamp_delay_s(), taken, "{estimate:?}");
            assert_eq!(plan.uses(Part::DvlStampDelay), taken != 0.0);
            assert_eq!(plan.apply(&config).dvl.stamp_delay_s, taken);
        }
    }

    #[test]
    fn a_given_dvl_delay_is_kept_whatever_the_estimate() {
        let mut config = Config::from_toml("[dvl]\nstamp_delay_s = 0.25\n").unwrap();
        let facts = LogFacts {
            dvl_delay: delay(1.0, 0.01, 900.0),
            ..facts()
        };
        assert_eq!(Plan::decide(&facts, &config).dvl_stamp_delay_s(), 0.25);
        config.dvl.enabled = false;
        let plan = Plan::decide(&facts, &config);
        assert!(!plan.uses(Part::DvlStampDelay));
        assert_eq!(plan.dvl_stamp_delay_s(), 0.0);
    }

    fn used(plan: &Plan, part: Part) -> bool {
        plan.uses(part)
    }

    #[test]
    fn gaps_are_counted_between_readings_and_after_the_last() {
        let s = |t: f64| (t * 1e9) as i64;
        let stamps = [s(0.0), s(1.0), s(40.0), s(41.0)];
        let rounded = |(n, longest): (usize, f64)| (n, (longest * 1e6).round() / 1e6);
        assert_eq!(rounded(gaps(&stamps, s(42.0))), (1, 39.0));
        assert_eq!(rounded(gaps(&stamps, s(100.0))), (2, 59.0));
        assert_eq!(gaps(&[], s(100.0)), (0, 0.0));
    }

    #[test]
    fn the_propeller_filter_bridges_gaps_when_the_model_cannot() {
        let config = Config::default();
        let mut f = facts();
        assert!(!used(
            &Plan::decide(&f, &config),
            Part::Aid(Sensor::RpmVelocity)
        ));
        f.dvl_gaps = 1;
        f.dvl_longest_gap_s = 300.0;
        let plan = Plan::decide(&f, &config);
        assert!(used(&plan, Part::Aid(Sensor::RpmVelocity)));
        assert!(!used(&plan, Part::Aid(Sensor::ModelVelocity)));
        f.fins = 10;
        f.vehicle = Ok("remus-100".into());
        let plan = Plan::decide(&f, &config);
        assert!(used(&plan, Part::Aid(Sensor::ModelVelocity)));
        assert!(!used(&plan, Part::Aid(Sensor::RpmVelocity)));
        let applied = plan.apply(&config);
        assert!(applied.uses(Sensor::ModelVelocity) && !applied.uses(Sensor::RpmVelocity));
    }

    #[test]
    fn a_part_forced_on_without_its_inputs_is_refused_with_the_reason() {
        let mut config = Config::default();
        config.model_velocity.enabled = Switch::On;
        let plan = Plan::decide(&facts(), &config);
        let d = plan
            .decisions
            .iter()
            .find(|d| d.part == Part::Aid(Sensor::ModelVelocity))
            .unwrap();
        assert!(!d.used);
        assert!(d.why.to_string().contains("/fins"), "{}", d.why);
        assert_eq!(plan.overruled().count(), 1);
        assert!(!plan.apply(&config).uses(Sensor::ModelVelocity));
    }

    #[test]
    fn scale_and_misalignment_follow_the_distance_between_absolute_positions() {
        let config = Config::default();
        let mut f = facts();
        let pair = |distance_m| PositionPair {
            distance_m,
            sigma_m: 3.5,
            seconds_apart: 600.0,
        };
        // 0.5 % and 1 deg over 200 m: 3.6 m, about one sigma: held.
        f.farthest_positions = Some(pair(200.0));
        assert!(!Plan::decide(&f, &config).uses(Part::DvlScaleMisalignment));
        // Over 2 km: 36 m, ten sigmas.
        f.farthest_positions = Some(pair(2000.0));
        let plan = Plan::decide(&f, &config);
        assert!(plan.uses(Part::DvlScaleMisalignment));
        let c = plan.apply(&config);
        assert_eq!(c.dvl.calibration_sigma()[0], 0.005);
        // Held where the user says so.
        let mut off = config.clone();
        off.dvl.scale_misalignment = Switch::Off;
        assert!(!Plan::decide(&f, &off).uses(Part::DvlScaleMisalignment));
    }
}
