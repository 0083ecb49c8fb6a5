//! The aiding sources as one table. Each source gives its readings' stamps and, for one
//! reading, the update (innovation `y`, its row `H` in the error state, its noise `R`), or
//! nothing when the reading is not used; the driver walks the table at every epoch, in the
//! table's order. The sources themselves are in [`super::aid_sources`].
//!
//! A new aiding sensor: its source (stamps and `(y, H, R)`), a [`Sensor`] name here, and its
//! row in [`Aiding::table`] with its settings in [`Aiding`]; the log's stream comes from
//! [`Streams`].

use super::acoustic::{AcousticAiding, AcousticFixAid};
use super::aid_sources;
use super::error_state::N;
use super::forward::{DvlMounting, Estimate};
use super::lbl::{LblAid, LblAiding};
use super::usbl::{UsblAid, UsblAiding};
use crate::contract::{
    AcousticFix, ControlSurfaces, Depth, Dvl, GnssFix, LblRange, MagneticField, Message,
    PositionFix, Propeller, SpeedLog, Streams, UsblObservation,
};
use crate::filters::velocity::rpm::RpmFilter;
use nalgebra::{SMatrix, SVector, Vector3};

/// Which sensor a measurement comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Sensor {
    Dvl = 0,
    Depth,
    Gnss,
    SpeedLog,
    PositionFix,
    Magnetometer,
    /// The propeller's speed through seed 003's velocity filter, while the DVL is out.
    RpmVelocity,
    /// The vehicle model's velocity through seed 000's filter, while the DVL is out.
    ModelVelocity,
    /// Positioned acoustic fixes (USBL, LBL systems) at their time of validity.
    AcousticFix,
    /// Ranges to the seabed beacons of a long-baseline network.
    Lbl,
    /// Ship-relative USBL observations (range, bearing, elevation), placed by the ship's pose.
    Usbl,
}

impl std::fmt::Display for Sensor {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl serde::Serialize for Sensor {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

impl Sensor {
    pub const ALL: [Sensor; 11] = [
        Sensor::Dvl,
        Sensor::Depth,
        Sensor::Gnss,
        Sensor::SpeedLog,
        Sensor::PositionFix,
        Sensor::Magnetometer,
        Sensor::RpmVelocity,
        Sensor::ModelVelocity,
        Sensor::AcousticFix,
        Sensor::Lbl,
        Sensor::Usbl,
    ];

    /// Whether it reads the velocity in the body's axes, where a heading error and a velocity
    /// turned with it look alike (`super::heading_reset`). The EM log's
    /// speed is not among them: its row leaves the attitude out.
    pub fn reads_body_velocity(self) -> bool {
        matches!(self, Sensor::Dvl)
    }

    /// Name used in tables and summaries.
    pub fn name(self) -> &'static str {
        match self {
            Sensor::Dvl => "dvl",
            Sensor::Depth => "depth",
            Sensor::Gnss => "gnss",
            Sensor::SpeedLog => "eml",
            Sensor::PositionFix => "position_fix",
            Sensor::Magnetometer => "mag",
            Sensor::RpmVelocity => "rpm_velocity",
            Sensor::ModelVelocity => "model_velocity",
            Sensor::AcousticFix => "acoustic_fix",
            Sensor::Lbl => "lbl",
            Sensor::Usbl => "usbl",
        }
    }

    /// The contract's topic of its readings.
    pub fn topic(self) -> &'static str {
        match self {
            Sensor::Dvl => Dvl::DEFAULT_TOPIC,
            Sensor::Depth => Depth::DEFAULT_TOPIC,
            Sensor::Gnss => GnssFix::DEFAULT_TOPIC,
            Sensor::SpeedLog => SpeedLog::DEFAULT_TOPIC,
            Sensor::PositionFix => PositionFix::DEFAULT_TOPIC,
            Sensor::Magnetometer => MagneticField::DEFAULT_TOPIC,
            Sensor::RpmVelocity => Propeller::DEFAULT_TOPIC,
            Sensor::ModelVelocity => ControlSurfaces::DEFAULT_TOPIC,
            Sensor::AcousticFix => AcousticFix::DEFAULT_TOPIC,
            Sensor::Lbl => LblRange::DEFAULT_TOPIC,
            Sensor::Usbl => UsblObservation::DEFAULT_TOPIC,
        }
    }

    /// Its readings in `streams`.
    pub fn readings(self, streams: &Streams<'_>) -> usize {
        match self {
            Sensor::Dvl => streams.dvl.len(),
            Sensor::Depth => streams.depth.len(),
            Sensor::Gnss => streams.gnss.len(),
            Sensor::SpeedLog => streams.eml.len(),
            Sensor::PositionFix => streams.fixes.len(),
            Sensor::Magnetometer => streams.mag.len(),
            Sensor::RpmVelocity => streams.rpm.len(),
            Sensor::ModelVelocity => streams.fins.len(),
            Sensor::AcousticFix => streams.acoustic_fixes.len(),
            Sensor::Lbl => streams.lbl.len(),
            Sensor::Usbl => streams.usbl.len(),
        }
    }

    /// `streams` without this sensor's readings (the propeller's kept: see below).
    pub fn left_out_of<'a>(self, streams: Streams<'a>) -> Streams<'a> {
        match self {
            Sensor::Dvl => Streams {
                dvl: &[],
                ..streams
            },
            Sensor::Depth => Streams {
                depth: &[],
                ..streams
            },
            Sensor::Gnss => Streams {
                gnss: &[],
                ..streams
            },
            Sensor::SpeedLog => Streams {
                eml: &[],
                ..streams
            },
            Sensor::PositionFix => Streams {
                fixes: &[],
                ..streams
            },
            Sensor::Magnetometer => Streams {
                mag: &[],
                ..streams
            },
            // The propeller's readings serve the initialisation too (speed, in-run
            // alignment): the aid is left out by its settings, the stream is kept.
            Sensor::RpmVelocity => streams,
            Sensor::ModelVelocity => Streams {
                fins: &[],
                ..streams
            },
            Sensor::AcousticFix => Streams {
                acoustic_fixes: &[],
                ..streams
            },
            Sensor::Lbl => Streams {
                lbl: &[],
                ..streams
            },
            Sensor::Usbl => Streams {
                usbl: &[],
                ..streams
            },
        }
    }

    /// Number of components of its innovation.
    pub fn dims(self) -> usize {
        match self {
            Sensor::Dvl | Sensor::RpmVelocity | Sensor::ModelVelocity | Sensor::Usbl => 3,
            Sensor::Depth | Sensor::SpeedLog | Sensor::Magnetometer | Sensor::Lbl => 1,
            Sensor::Gnss | Sensor::PositionFix | Sensor::AcousticFix => 2,
        }
    }
}

/// A count per sensor.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct PerSensor([usize; Sensor::ALL.len()]);

impl std::ops::Index<Sensor> for PerSensor {
    type Output = usize;
    fn index(&self, s: Sensor) -> &usize {
        &self.0[s as usize]
    }
}

impl std::ops::IndexMut<Sensor> for PerSensor {
    fn index_mut(&mut self, s: Sensor) -> &mut usize {
        &mut self.0[s as usize]
    }
}

/// A measurement of `M` components for the Kalman core.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Measurement<const M: usize> {
    pub y: SVector<f64, M>,
    pub h: SMatrix<f64, M, N>,
    pub r: SMatrix<f64, M, M>,
}

/// A measurement of one to three components.
// Made and consumed once per reading, on the stack: boxing the larger variants would
// allocate on every update.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Update {
    One(Measurement<1>),
    Two(Measurement<2>),
    Three(Measurement<3>),
}

/// What a measurement may depend on at its epoch.
#[derive(Debug, Clone, Copy)]
pub struct Epoch<'a> {
    pub est: &'a Estimate,
    /// Bias-corrected body rate relative to NED.
    pub omega_nb_body: Vector3<f64>,
}

/// Readings a source left out before the filter saw them.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct LeftOut {
    /// Closer than the source's minimum interval to the last reading kept.
    pub by_interval: usize,
    /// Disturbed (a magnetometer's field magnitude off its reference).
    pub disturbed: usize,
}

/// A reading as the sensor gave it: its first `dims` components, in the sensor's units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensorReading {
    pub dims: usize,
    pub value: [f64; 3],
}

impl SensorReading {
    pub fn one(value: f64) -> SensorReading {
        SensorReading {
            dims: 1,
            value: [value, 0.0, 0.0],
        }
    }
    pub fn three(value: [f64; 3]) -> SensorReading {
        SensorReading { dims: 3, value }
    }
}

/// One row of the aiding table.
pub trait Aid: Sync {
    fn sensor(&self) -> Sensor;
    /// Number of readings.
    fn len(&self) -> usize;
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Stamp of reading `i` (non-decreasing in `i`), ns.
    fn stamp_ns(&self, i: usize) -> i64;
    /// The update of reading `i`, or `None` when the reading is not used (counted).
    fn measure(&self, i: usize, at: &Epoch<'_>) -> Option<Update>;
    /// SensorReading `i` as the sensor gave it, to judge whether a run of rejected readings agrees
    /// with itself before the gate reopens ([`super::reopen`]). `None` for sources without
    /// one: their gate reopens on the count of rejections alone.
    fn reading(&self, _i: usize) -> Option<SensorReading> {
        None
    }
    /// Reading `i`'s slant range from the acoustic observer that made it (the ship, the
    /// beacon), m, what an acoustic reading's error grows with; `None` for other sources.
    fn slant_range_m(&self, _i: usize) -> Option<f64> {
        None
    }
    /// Whether reading `i` repeats the readings before it exactly, every component: a stuck
    /// sensor's sign (such a reading never reopens the gate). False for sources whose
    /// readings may repeat honestly.
    fn repeats(&self, _i: usize) -> bool {
        false
    }
    /// Readings left out before the filter.
    fn left_out(&self) -> LeftOut {
        LeftOut::default()
    }
    /// What a user should know of the source (why it could not be used).
    fn notes(&self) -> Vec<String> {
        Vec::new()
    }
    /// Readings the source left out that a user should know of (ranges to beacons not in the
    /// table, observations without a ship's pose). When it left out every reading, these
    /// say why the source could not be used.
    fn left_out_notes(&self) -> Vec<String> {
        Vec::new()
    }
}

/// The table the driver walks, in the order the sources are applied within an epoch.
pub type AidTable<'a> = Vec<Box<dyn Aid + 'a>>;

/// First reading of `aid` stamped after `t_ns`.
pub fn first_after(aid: &dyn Aid, t_ns: i64) -> usize {
    let (mut lo, mut hi) = (0, aid.len());
    while lo < hi {
        let mid = (lo + hi) / 2;
        if aid.stamp_ns(mid) <= t_ns {
            lo = mid + 1;
        } else {
            hi = mid;
        }
    }
    lo
}

/// Measurement noise, validity and gating of the aiding sensors.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aiding {
    /// DVL velocity 1-sigma per axis, m/s.
    pub dvl_sigma_m_s: f64,
    /// DVL readings above this altitude are not used (out of range), m.
    pub dvl_max_altitude_m: f64,
    /// False: every DVL reading is used, even without bottom lock or out of range (only to
    /// show what trusting a bad DVL costs).
    pub dvl_check_range: bool,
    pub dvl_mounting: DvlMounting,
    /// When a DVL reading carries no altitude, the echo sounder's latest altitude within this
    /// age is used to check the range, s.
    pub altimeter_max_age_s: f64,
    /// Depth 1-sigma, m.
    pub depth_sigma_m: f64,
    /// Depth readings closer than this to the last one used are skipped (a 100 Hz depth
    /// sensor adds nothing over 10 Hz but epochs), s.
    pub depth_min_interval_s: f64,
    /// EM-log speed 1-sigma, m/s (`None`: the EM log is not used).
    pub eml_sigma_m_s: Option<f64>,
    /// Magnetic heading updates (`None`: the magnetometer is not used).
    pub mag: Option<MagAiding>,
    /// The propeller's speed while the DVL is out (`None`: not used).
    pub rpm_velocity: Option<RpmVelocity>,
    /// Positioned acoustic fixes (`None`: not used).
    pub acoustic: Option<AcousticAiding>,
    /// Ranges to LBL beacons (`None`: not used).
    pub lbl: Option<LblAiding>,
    /// Ship-relative USBL observations (`None`: not used).
    pub usbl: Option<UsblAiding>,
    /// Probability of the chi-square gate (a consistent measurement passes it with this
    /// probability); `None` disables gating.
    pub gate_probability: Option<f64>,
    /// After this many rejections in a row of one sensor, its next measurement is applied
    /// ungated (a filter that has drifted must not lock its aiding out); 0: never.
    pub gate_reset_after: usize,
}

/// The magnetometer as a heading sensor.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MagAiding {
    /// Declination at the site, rad, east positive.
    pub declination_rad: f64,
    /// 1-sigma of one heading update, rad (the heading error's sigma, spread over the
    /// updates within its correlation time).
    pub sigma_rad: f64,
    /// Readings closer than this to the last one used are skipped, s.
    pub min_interval_s: f64,
    /// The undisturbed field's magnitude (of the calibrated readings), T.
    pub reference_norm_t: f64,
    /// A reading whose magnitude differs from the reference by more than this fraction is a
    /// disturbed field and is not used.
    pub max_norm_deviation: f64,
}

/// Seed 003's velocity filter as an aid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RpmVelocity {
    pub filter: RpmFilter,
    /// 1-sigma of the sway and heave taken as zero, m/s.
    pub lateral_sigma_m_s: f64,
}

impl Aiding {
    /// The DVL's row over `streams`.
    pub fn dvl<'a>(&self, streams: &Streams<'a>) -> aid_sources::DvlAid<'a> {
        aid_sources::DvlAid {
            readings: streams.dvl,
            altimeter: streams.altimeter,
            sigma_m_s: self.dvl_sigma_m_s,
            max_altitude_m: self.dvl_max_altitude_m,
            check_range: self.dvl_check_range,
            altimeter_max_age_s: self.altimeter_max_age_s,
            mounting: self.dvl_mounting,
        }
    }

    /// The table over `streams` (mission origin `origin_rad`, latitude and longitude, the
    /// frame of the position fixes): a row per sensor the settings use, in the order the
    /// updates are applied within an epoch.
    pub fn table<'a>(&self, streams: &Streams<'a>, origin_rad: (f64, f64)) -> AidTable<'a> {
        let dvl = self.dvl(streams);
        let rpm_velocity = self
            .rpm_velocity
            .filter(|_| !streams.rpm.is_empty())
            .map(|r| aid_sources::RpmVelocityAid::new(streams.rpm, &dvl, &r));
        let mut table: AidTable<'a> = vec![
            Box::new(dvl),
            Box::new(aid_sources::DepthAid::new(
                streams.depth,
                self.depth_sigma_m,
                self.depth_min_interval_s,
            )),
            Box::new(aid_sources::GnssAid {
                readings: streams.gnss,
            }),
            Box::new(aid_sources::FixAid::new(streams.fixes, origin_rad)),
        ];
        if let Some(acoustic) = self.acoustic.filter(|_| !streams.acoustic_fixes.is_empty()) {
            table.push(Box::new(AcousticFixAid::new(
                streams.acoustic_fixes,
                streams.ship,
                &acoustic,
            )));
        }
        if let Some(lbl) = self.lbl.filter(|_| !streams.lbl.is_empty()) {
            table.push(Box::new(LblAid::new(streams.lbl, streams.beacons, &lbl)));
        }
        if let Some(usbl) = self.usbl.filter(|_| !streams.usbl.is_empty()) {
            table.push(Box::new(UsblAid::new(streams.usbl, streams.ship, &usbl)));
        }
        if let Some(sigma_m_s) = self.eml_sigma_m_s {
            table.push(Box::new(aid_sources::SpeedLogAid {
                readings: streams.eml,
                sigma_m_s,
            }));
        }
        if let Some(mag) = self.mag {
            table.push(Box::new(aid_sources::MagAid::new(streams.mag, &mag)));
        }
        if let Some(r) = rpm_velocity {
            table.push(Box::new(r));
        }
        table
    }
}
