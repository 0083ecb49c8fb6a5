//! The standard ROS 2 types, each turned into its contract message: which fields are read
//! (paths for [`super::cdr::Plan`]) and how they become the contract's, frames and units
//! converted.
//!
//! Frames: REP-103/105 (body FLU, world ENU) is turned into the contract's FRD/NED; a
//! message already in FRD/NED is kept. Which one a message is in comes from its
//! `header.frame_id` (a body frame ending in `_frd`, a world frame ending in `_ned`: native;
//! anything else, e.g. `base_link`, `odom`, `map`: REP-103), or from a per-topic override.

use crate::contract::{
    AcousticFix, Altimeter, Attitude, Depth, Dvl, FieldIssue, GnssFix, Imu, MagneticField,
    PositionFix, ShipPose, Truth, UsblObservation,
};
use nalgebra::{Matrix3, Quaternion, Rotation3, UnitQuaternion, Vector3};
use std::collections::BTreeMap;

/// Frame convention of a message.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Convention {
    /// REP-103: body x forward, y left, z up; world x east, y north, z up.
    Rep103,
    /// The contract's: body FRD, world NED.
    Native,
}

impl std::str::FromStr for Convention {
    type Err = String;

    /// `rep103` (also `flu`, `enu`) or `native` (also `frd`, `ned`).
    fn from_str(text: &str) -> Result<Self, Self::Err> {
        match text.trim().to_ascii_lowercase().as_str() {
            "rep103" | "rep-103" | "flu" | "enu" => Ok(Convention::Rep103),
            "native" | "frd" | "ned" => Ok(Convention::Native),
            other => Err(format!(
                "frame convention `{other}`: expected rep103 (FLU body, ENU world) or native \
                 (FRD body, NED world)"
            )),
        }
    }
}

crate::config::with_defaults! {
    /// What the conversions need that a ROS 2 message does not say.
    #[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
    #[serde(deny_unknown_fields, default)]
    pub struct RosSettings {
        /// Sea water density for FluidPressure to depth, kg/m^3.
        pub water_density_kg_m3: f64 = 1025.0,
        /// Pressure at the surface, Pa (FluidPressure is absolute).
        pub atmospheric_pressure_pa: f64 = 101_325.0,
        /// Gravity for FluidPressure to depth, m/s^2.
        pub gravity_m_s2: f64 = 9.80665,
        /// 1-sigma of a NavSatFix without a covariance (type unknown), m.
        pub gnss_sigma_unknown_m: f64 = 5.0,
        /// 1-sigma of a PointStamped position fix (it carries none), m.
        pub point_fix_sigma_m: f64 = 1.0,
        /// Whether an acoustic fix's header stamp is its time of validity (else the time the
        /// ship received it, and the reconstruction estimates the delay).
        pub acoustic_stamp_is_validity: bool = false,
    }
}

/// A standard ROS 2 type hindsight reads, and the contract message it becomes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RosType {
    Imu,
    MagneticField,
    NavSatFix,
    FluidPressure,
    Range,
    TwistWithCovarianceStamped,
    QuaternionStamped,
    PointStamped,
    /// `marine_acoustic_msgs/Dvl`, the DVL message of common drivers (UW-APL's
    /// marine_msgs): velocity, mode, good beams and altitude.
    AcousticDvl,
    /// Water Linked's A50/A125 driver message: `waterlinked_a50_ros_driver/DVL` (ROS 1) and
    /// `dvl_msgs/DVL` (ROS 2): velocity in the DVL's frame (x forward, y right, z down),
    /// `velocity_valid`, `altitude`.
    WaterLinkedDvl,
    /// The UUV Simulator's `uuv_sensor_ros_plugins_msgs/DVL`: velocity in the DVL link's
    /// frame, `velocity_covariance[0]` -1 when invalid, `altitude`.
    UuvDvl,
    /// `nav_msgs/Odometry`, a vehicle INS's or a localiser's track: read only for the topic
    /// named for the truth role, as the reference the solution is scored against.
    Odometry,
    /// `geographic_msgs/GeoPointStamped`: a positioned acoustic fix (latitude, longitude,
    /// altitude; no sigma, so one from the slant range).
    GeoPointStamped,
    /// `geographic_msgs/GeoPoseStamped`: a positioned acoustic fix (its orientation unused),
    /// or on the ship's topic, the ship's pose ([`RosType::ShipGeoPose`]).
    GeoPoseStamped,
    /// `geometry_msgs/PoseWithCovarianceStamped`: a position fix in a local world frame
    /// whose origin is the mission's (a USBL or LBL solution from a localiser), its sigma
    /// from the covariance.
    PoseWithCovarianceStamped,
    /// A `sensor_msgs/NavSatFix` on an acoustic positioning topic (see
    /// [`RosType::on_topic`]): an acoustic fix, its depth the altitude's negative.
    AcousticNavSatFix,
    /// A `geographic_msgs/GeoPoseStamped` on the ship's topic (see [`RosType::on_topic`]):
    /// the support ship's position and attitude.
    ShipGeoPose,
    /// EvoLogics' `USBLLONG` as its ROS drivers publish it
    /// (`vehicle_interface/AcousticModemUSBLLONG`): a ship-relative USBL observation (see
    /// [`super::evologics`]).
    EvologicsUsblLong,
}

/// Whether a topic's name says it holds acoustic positions (`/usbl/fix`, `/acoustic_fix`).
fn names_acoustic(topic: &str) -> bool {
    let t = topic.to_ascii_lowercase();
    t.contains("usbl") || t.contains("acoustic")
}

/// Whether a topic's name says it holds the support ship's pose (`/ship/pose`).
fn names_ship(topic: &str) -> bool {
    topic.to_ascii_lowercase().contains("ship")
}

/// The stamp's paths, first in every type's list.
const STAMP: [&str; 2] = ["header.stamp.sec", "header.stamp.nanosec"];
/// The frame, the one string every type asks for.
pub const FRAME: [&str; 1] = ["header.frame_id"];

impl RosType {
    /// The types found by their name (the role readings of a type are not: see
    /// [`RosType::on_topic`]).
    pub const ALL: [RosType; 16] = [
        RosType::Imu,
        RosType::MagneticField,
        RosType::NavSatFix,
        RosType::FluidPressure,
        RosType::Range,
        RosType::TwistWithCovarianceStamped,
        RosType::QuaternionStamped,
        RosType::PointStamped,
        RosType::AcousticDvl,
        RosType::WaterLinkedDvl,
        RosType::UuvDvl,
        RosType::Odometry,
        RosType::GeoPointStamped,
        RosType::GeoPoseStamped,
        RosType::PoseWithCovarianceStamped,
        RosType::EvologicsUsblLong,
    ];

    /// The type's full name, `pkg/Type`.
    pub fn name(self) -> &'static str {
        match self {
            RosType::Imu => "sensor_msgs/Imu",
            RosType::MagneticField => "sensor_msgs/MagneticField",
            RosType::NavSatFix | RosType::AcousticNavSatFix => "sensor_msgs/NavSatFix",
            RosType::FluidPressure => "sensor_msgs/FluidPressure",
            RosType::Range => "sensor_msgs/Range",
            RosType::TwistWithCovarianceStamped => "geometry_msgs/TwistWithCovarianceStamped",
            RosType::QuaternionStamped => "geometry_msgs/QuaternionStamped",
            RosType::PointStamped => "geometry_msgs/PointStamped",
            RosType::AcousticDvl => "marine_acoustic_msgs/Dvl",
            RosType::WaterLinkedDvl => "waterlinked_a50_ros_driver/DVL",
            RosType::UuvDvl => "uuv_sensor_ros_plugins_msgs/DVL",
            RosType::Odometry => "nav_msgs/Odometry",
            RosType::GeoPointStamped => "geographic_msgs/GeoPointStamped",
            RosType::GeoPoseStamped | RosType::ShipGeoPose => "geographic_msgs/GeoPoseStamped",
            RosType::PoseWithCovarianceStamped => "geometry_msgs/PoseWithCovarianceStamped",
            RosType::EvologicsUsblLong => "vehicle_interface/AcousticModemUSBLLONG",
        }
    }

    /// Other full names the same message goes by (another ROS, another package name).
    fn aliases(self) -> &'static [&'static str] {
        match self {
            RosType::WaterLinkedDvl => &["dvl_msgs/DVL"],
            RosType::UuvDvl => &["uuv_sensor_plugins_ros_msgs/DVL"],
            // The same message copied into other drivers' packages.
            RosType::EvologicsUsblLong => &[
                "vehicle_msgs/AcousticModemUSBLLONG",
                "evologics_ros/AcousticModemUSBLLONG",
            ],
            _ => &[],
        }
    }

    /// The type of a full name (`pkg/Type`).
    pub fn of(full_name: &str) -> Option<RosType> {
        RosType::ALL
            .into_iter()
            .find(|t| t.name() == full_name || t.aliases().contains(&full_name))
    }

    /// How this type is read on `topic`, where it serves more than one role (`named`: the
    /// topics named for roles, role -> topic):
    /// - a NavSatFix is an acoustic fix on the topic named for `acoustic_fix`, or one whose
    ///   name says `usbl` or `acoustic` (unless it is named for `gnss`);
    /// - a GeoPoseStamped is the ship's pose on the topic named for `ship_pose`, or one whose
    ///   name says `ship` but not `usbl` or `acoustic` (unless it is named for
    ///   `acoustic_fix`), else an acoustic fix.
    pub fn on_topic(self, topic: &str, named: &BTreeMap<String, String>) -> RosType {
        let named_for = |role: &str| named.get(role).is_some_and(|t| t == topic);
        match self {
            RosType::NavSatFix
                if named_for("acoustic_fix") || names_acoustic(topic) && !named_for("gnss") =>
            {
                RosType::AcousticNavSatFix
            }
            RosType::GeoPoseStamped
                if named_for("ship_pose")
                    || names_ship(topic)
                        && !names_acoustic(topic)
                        && !named_for("acoustic_fix") =>
            {
                RosType::ShipGeoPose
            }
            other => other,
        }
    }

    /// Whether the type's frame is a body frame (else a world frame, whose convention pairs
    /// with the body's: ENU with FLU, NED with FRD).
    fn in_body(self) -> bool {
        !matches!(
            self,
            RosType::QuaternionStamped
                | RosType::PointStamped
                | RosType::Odometry
                | RosType::GeoPointStamped
                | RosType::GeoPoseStamped
                | RosType::PoseWithCovarianceStamped
                | RosType::AcousticNavSatFix
                | RosType::ShipGeoPose
        )
    }

    /// The role a topic of this type must be named for to be read (`None`: read wherever
    /// it is). An odometry topic is a reference only when the user says so: a log may hold
    /// several (wheel, visual, the filter's own), and none of them is a truth by itself.
    pub fn only_when_named_for(self) -> Option<&'static str> {
        (self == RosType::Odometry).then_some("truth")
    }

    /// Whether a field may be missing from the type's schema (read as NaN then).
    pub fn may_lack(self, path: &str) -> bool {
        self == RosType::EvologicsUsblLong && super::evologics::OPTIONAL.contains(&path)
    }

    /// The numbers read, after the stamp.
    fn fields(self) -> &'static [&'static str] {
        match self {
            RosType::Imu => &[
                "angular_velocity.x",
                "angular_velocity.y",
                "angular_velocity.z",
                "linear_acceleration.x",
                "linear_acceleration.y",
                "linear_acceleration.z",
            ],
            RosType::MagneticField => &["magnetic_field.x", "magnetic_field.y", "magnetic_field.z"],
            RosType::NavSatFix => &[
                "status.status",
                "latitude",
                "longitude",
                "position_covariance[0]",
                "position_covariance[4]",
                "position_covariance_type",
            ],
            RosType::FluidPressure => &["fluid_pressure"],
            RosType::Range => &["range"],
            RosType::TwistWithCovarianceStamped => &[
                "twist.twist.linear.x",
                "twist.twist.linear.y",
                "twist.twist.linear.z",
                "twist.covariance[0]",
            ],
            RosType::QuaternionStamped => &[
                "quaternion.x",
                "quaternion.y",
                "quaternion.z",
                "quaternion.w",
            ],
            RosType::PointStamped => &["point.x", "point.y", "point.z"],
            RosType::AcousticDvl => &[
                "velocity.x",
                "velocity.y",
                "velocity.z",
                "velocity_mode",
                "num_good_beams",
                "altitude",
            ],
            RosType::WaterLinkedDvl => &[
                "velocity.x",
                "velocity.y",
                "velocity.z",
                "velocity_valid",
                "altitude",
            ],
            RosType::UuvDvl => &[
                "velocity.x",
                "velocity.y",
                "velocity.z",
                "velocity_covariance[0]",
                "altitude",
            ],
            RosType::Odometry => &[
                "pose.pose.position.x",
                "pose.pose.position.y",
                "pose.pose.position.z",
                "pose.pose.orientation.x",
                "pose.pose.orientation.y",
                "pose.pose.orientation.z",
                "pose.pose.orientation.w",
                "twist.twist.linear.x",
                "twist.twist.linear.y",
                "twist.twist.linear.z",
                "twist.twist.angular.x",
                "twist.twist.angular.y",
                "twist.twist.angular.z",
            ],
            RosType::GeoPointStamped
            | RosType::GeoPoseStamped
            | RosType::ShipGeoPose
            | RosType::PoseWithCovarianceStamped
            | RosType::AcousticNavSatFix => self.acoustic_fields(),
            RosType::EvologicsUsblLong => &super::evologics::FIELDS,
        }
    }

    /// The numbers the acoustic positioning types read, after the stamp.
    fn acoustic_fields(self) -> &'static [&'static str] {
        match self {
            RosType::GeoPointStamped => &[
                "position.latitude",
                "position.longitude",
                "position.altitude",
            ],
            RosType::GeoPoseStamped | RosType::ShipGeoPose => &[
                "pose.position.latitude",
                "pose.position.longitude",
                "pose.position.altitude",
                "pose.orientation.x",
                "pose.orientation.y",
                "pose.orientation.z",
                "pose.orientation.w",
            ],
            RosType::PoseWithCovarianceStamped => &[
                "pose.pose.position.x",
                "pose.pose.position.y",
                "pose.pose.position.z",
                "pose.covariance[0]",
                "pose.covariance[7]",
            ],
            RosType::AcousticNavSatFix => &[
                "status.status",
                "latitude",
                "longitude",
                "altitude",
                "position_covariance[0]",
                "position_covariance[4]",
                "position_covariance[8]",
                "position_covariance_type",
            ],
            _ => &[],
        }
    }

    /// Every number path, the stamp first.
    pub fn numbers(self) -> Vec<&'static str> {
        STAMP.iter().chain(self.fields()).copied().collect()
    }
}

/// `marine_acoustic_msgs/Dvl`'s `DVL_MODE_WATER`: the velocity is relative to the water.
const ACOUSTIC_DVL_MODE_WATER: f64 = 2.0;

/// A converted message.
#[derive(Debug, Clone, PartialEq)]
pub enum Converted {
    Imu(Imu),
    MagneticField(MagneticField),
    GnssFix(GnssFix),
    Depth(Depth),
    Altimeter(Altimeter),
    Dvl(Dvl),
    Attitude(Attitude),
    PositionFix(PositionFix),
    /// A reference track; its latitude and longitude are placed once the mission's origin
    /// is known ([`place_on_origin`]), until then they are the origin's (0, 0).
    Truth(Truth),
    AcousticFix(AcousticFix),
    ShipPose(ShipPose),
    Usbl(UsblObservation),
}

/// The convention a message's frame name says.
pub fn convention_of(frame_id: &str, in_body: bool) -> Convention {
    let native = if in_body { "_frd" } else { "_ned" };
    if frame_id.ends_with(native) || frame_id == &native[1..] {
        Convention::Native
    } else {
        Convention::Rep103
    }
}

/// Body FLU to FRD.
fn body(v: Vector3<f64>, c: Convention) -> [f64; 3] {
    match c {
        Convention::Native => v.into(),
        Convention::Rep103 => [v.x, -v.y, -v.z],
    }
}

/// World ENU to NED.
fn world(v: Vector3<f64>, c: Convention) -> Vector3<f64> {
    match c {
        Convention::Native => v,
        Convention::Rep103 => Vector3::new(v.y, v.x, -v.z),
    }
}

/// An altitude when the driver gives one (a positive finite number).
fn positive(altitude: f64) -> Option<f64> {
    (altitude.is_finite() && altitude > 0.0).then_some(altitude)
}

/// The body's attitude from a quaternion's `[x, y, z, w]` (`field` names it in an issue).
fn ned_from_body(
    xyzw: &[f64],
    c: Convention,
    field: &'static str,
) -> Result<UnitQuaternion<f64>, FieldIssue> {
    let q = Quaternion::new(xyzw[3], xyzw[0], xyzw[1], xyzw[2]);
    let norm = q.norm();
    if norm.is_nan() || norm <= 0.5 {
        return Err(FieldIssue::new(field, "not a rotation (norm far from 1)"));
    }
    let q = UnitQuaternion::from_quaternion(q);
    Ok(match c {
        Convention::Native => q,
        Convention::Rep103 => ned_from_frd(&q),
    })
}

/// A `nav_msgs/Odometry` as a reference track (`f`: its fields after the stamp). Per
/// REP-105 the pose is the body's in the world frame of `header.frame_id` and the twist is
/// in the body frame (`child_frame_id`); the world frame's origin is taken to be the
/// mission's.
fn reference(stamp_ns: i64, f: &[f64], c: Convention) -> Result<Truth, FieldIssue> {
    let v3 = |i: usize| Vector3::new(f[i], f[i + 1], f[i + 2]);
    let position_ned = world(v3(0), c);
    let ned_from_body = ned_from_body(&f[3..7], c, "pose.pose.orientation")?;
    let velocity_body = body(v3(7), c);
    let velocity_ned = ned_from_body * Vector3::from(velocity_body);
    let (roll, pitch, yaw) = ned_from_body.euler_angles();
    Ok(Truth {
        stamp_ns,
        latitude_deg: 0.0,
        longitude_deg: 0.0,
        north_m: position_ned.x,
        east_m: position_ned.y,
        down_m: position_ned.z,
        velocity_body,
        velocity_ned: velocity_ned.into(),
        attitude: [roll, pitch, yaw],
        angular_velocity: body(v3(10), c),
    })
}

/// Places a reference track's points on the mission's origin (degrees): their latitude and
/// longitude from their north and east, on the origin's local tangent (the inverse of
/// [`crate::geodesy::local_north_east_m`]).
pub fn place_on_origin(track: &mut [Truth], origin_deg: (f64, f64)) {
    let (lat0, lon0) = (origin_deg.0.to_radians(), origin_deg.1.to_radians());
    for t in track {
        let (lat, lon) = crate::geodesy::position_of_local_m(lat0, lon0, t.north_m, t.east_m);
        (t.latitude_deg, t.longitude_deg) = (lat.to_degrees(), lon.to_degrees());
    }
}

/// `ned_from_frd` of a REP-103 `enu_from_flu`: `C = R_ned_enu C_enu_flu R_flu_frd`.
pub fn ned_from_frd(q_enu_from_flu: &UnitQuaternion<f64>) -> UnitQuaternion<f64> {
    let ned_from_enu = Matrix3::new(0.0, 1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, -1.0);
    let flu_from_frd = Matrix3::from_diagonal(&Vector3::new(1.0, -1.0, -1.0));
    let c = ned_from_enu * q_enu_from_flu.to_rotation_matrix().matrix() * flu_from_frd;
    UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(c))
}

/// A GNSS fix; its sigma from the covariance's horizontal terms, or the settings' when the
/// covariance is unknown.
fn gnss_fix(stamp_ns: i64, f: &[f64], s: &RosSettings) -> Result<GnssFix, FieldIssue> {
    if f[0] < 0.0 {
        return Err(FieldIssue::new("status.status", "no fix (-1)"));
    }
    let sigma = if f[5] == 0.0 {
        s.gnss_sigma_unknown_m
    } else {
        (0.5 * (f[3] + f[4])).max(0.0).sqrt()
    };
    Ok(GnssFix {
        stamp_ns,
        latitude_deg: f[1],
        longitude_deg: f[2],
        horizontal_sigma_m: sigma,
    })
}

/// An acoustic fix from a geographic point `[latitude, longitude, altitude]` (a NaN
/// altitude, geographic_msgs' "unknown": a horizontal fix) and its sigmas (horizontal,
/// depth; `None`: from the slant range), stamped as the settings say.
fn acoustic_fix(
    stamp_ns: i64,
    [latitude_deg, longitude_deg, altitude]: [f64; 3],
    [horizontal_sigma_m, depth_sigma_m]: [Option<f64>; 2],
    s: &RosSettings,
) -> AcousticFix {
    let depth_m = (!altitude.is_nan()).then_some(-altitude);
    AcousticFix {
        stamp_ns,
        stamp_is_validity: s.acoustic_stamp_is_validity,
        received_after_s: None,
        latitude_deg,
        longitude_deg,
        depth_m,
        horizontal_sigma_m,
        depth_sigma_m: depth_sigma_m.filter(|_| depth_m.is_some()),
        beacon_id: String::new(),
    }
}

/// A DVL reading of any of the DVL types: each marks bottom lock its own way.
fn dvl(ty: RosType, stamp_ns: i64, f: &[f64], c: Convention) -> Dvl {
    let (valid, altitude) = match ty {
        // Drivers mark a reading without bottom lock with covariance[0] = -1.
        RosType::TwistWithCovarianceStamped => (f[3] >= 0.0, None),
        // Bottom lock: not water-track mode (2), and three beams or more.
        RosType::AcousticDvl => (
            f[3] != ACOUSTIC_DVL_MODE_WATER && f[4] >= 3.0,
            positive(f[5]),
        ),
        RosType::WaterLinkedDvl => (f[3] != 0.0, positive(f[4])),
        // An invalid measurement has its covariance set to -1.
        _ => (f[3] >= 0.0, positive(f[4])),
    };
    Dvl {
        stamp_ns,
        velocity: body(Vector3::new(f[0], f[1], f[2]), c),
        valid,
        altitude,
    }
}

/// The message of an acoustic positioning type (`f`: its fields after the stamp).
fn acoustic(
    ty: RosType,
    stamp_ns: i64,
    f: &[f64],
    frame_id: &str,
    c: Convention,
    s: &RosSettings,
) -> Result<Converted, FieldIssue> {
    let v3 = |i: usize| Vector3::new(f[i], f[i + 1], f[i + 2]);
    Ok(match ty {
        RosType::GeoPointStamped | RosType::GeoPoseStamped => {
            Converted::AcousticFix(acoustic_fix(stamp_ns, [f[0], f[1], f[2]], [None; 2], s))
        }
        RosType::AcousticNavSatFix => {
            if f[0] < 0.0 {
                return Err(FieldIssue::new("status.status", "no fix (-1)"));
            }
            // An unknown covariance (type 0) or a variance of zero: the sigma from the slant
            // range.
            let sigma = |variance: f64| (f[7] != 0.0 && variance > 0.0).then(|| variance.sqrt());
            let sigmas = [sigma(0.5 * (f[4] + f[5])), sigma(f[6])];
            Converted::AcousticFix(acoustic_fix(stamp_ns, [f[1], f[2], f[3]], sigmas, s))
        }
        RosType::ShipGeoPose => {
            let q = ned_from_body(&f[3..7], c, "pose.orientation")?;
            let (roll, pitch, yaw) = q.euler_angles();
            Converted::ShipPose(ShipPose {
                stamp_ns,
                latitude_deg: f[0],
                longitude_deg: f[1],
                roll,
                pitch,
                yaw,
                horizontal_sigma_m: None,
                heading_sigma_rad: None,
            })
        }
        RosType::PoseWithCovarianceStamped => {
            let p = world(v3(0), c);
            let variance = 0.5 * (f[3] + f[4]);
            Converted::PositionFix(PositionFix {
                stamp_ns,
                north_m: p.x,
                east_m: p.y,
                down_m: (!p.z.is_nan()).then_some(p.z),
                // A covariance of zeros is a driver's "unknown".
                sigma_m: if variance > 0.0 {
                    variance.sqrt()
                } else {
                    s.point_fix_sigma_m
                },
                label: frame_id.to_string(),
            })
        }
        _ => {
            return Err(FieldIssue::new(
                "(message)",
                "internal: not an acoustic type",
            ))
        }
    })
}

/// The contract message of one read message (`n`: the numbers in [`RosType::numbers`]
/// order; `frame_id`; the convention when the topic overrides it).
pub fn convert(
    ty: RosType,
    n: &[f64],
    stamp: (i64, i64),
    frame_id: &str,
    given: Option<Convention>,
    s: &RosSettings,
) -> Result<Converted, FieldIssue> {
    let stamp_ns = stamp
        .0
        .checked_mul(1_000_000_000)
        .and_then(|t| t.checked_add(stamp.1))
        .ok_or_else(|| FieldIssue::new("header.stamp", "out of range"))?;
    let c = given.unwrap_or_else(|| match ty {
        // The message defines its frame: z toward the seabed, x forward (so y starboard).
        RosType::AcousticDvl | RosType::WaterLinkedDvl | RosType::EvologicsUsblLong => {
            Convention::Native
        }
        _ => convention_of(frame_id, ty.in_body()),
    });
    let f = &n[STAMP.len()..];
    let v3 = |i: usize| Vector3::new(f[i], f[i + 1], f[i + 2]);
    Ok(match ty {
        RosType::Imu => Converted::Imu(Imu {
            stamp_ns,
            angular_velocity: body(v3(0), c),
            specific_force: body(v3(3), c),
        }),
        RosType::MagneticField => Converted::MagneticField(MagneticField {
            stamp_ns,
            magnetic_field: body(v3(0), c),
        }),
        RosType::NavSatFix => Converted::GnssFix(gnss_fix(stamp_ns, f, s)?),
        RosType::FluidPressure => Converted::Depth(Depth {
            stamp_ns,
            depth: (f[0] - s.atmospheric_pressure_pa) / (s.water_density_kg_m3 * s.gravity_m_s2),
        }),
        RosType::Range => Converted::Altimeter(Altimeter {
            stamp_ns,
            altitude: f[0],
        }),
        RosType::TwistWithCovarianceStamped
        | RosType::AcousticDvl
        | RosType::WaterLinkedDvl
        | RosType::UuvDvl => Converted::Dvl(dvl(ty, stamp_ns, f, c)),
        RosType::QuaternionStamped => {
            let (roll, pitch, yaw) = ned_from_body(&f[0..4], c, "quaternion")?.euler_angles();
            Converted::Attitude(Attitude {
                stamp_ns,
                roll,
                pitch,
                yaw,
            })
        }
        RosType::Odometry => Converted::Truth(reference(stamp_ns, f, c)?),
        RosType::GeoPointStamped
        | RosType::GeoPoseStamped
        | RosType::AcousticNavSatFix
        | RosType::ShipGeoPose
        | RosType::PoseWithCovarianceStamped => acoustic(ty, stamp_ns, f, frame_id, c, s)?,
        RosType::EvologicsUsblLong => Converted::Usbl(super::evologics::usbl_long(stamp_ns, f, s)?),
        RosType::PointStamped => {
            let p = world(v3(0), c);
            Converted::PositionFix(PositionFix {
                stamp_ns,
                north_m: p.x,
                east_m: p.y,
                // NaN is ROS's "unknown": a horizontal-only fix.
                down_m: (!p.z.is_nan()).then_some(p.z),
                sigma_m: s.point_fix_sigma_m,
                label: frame_id.to_string(),
            })
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn numbers(fields: &[f64]) -> Vec<f64> {
        [0.0, 0.0].iter().chain(fields).copied().collect()
    }

    #[test]
    fn conventions_come_from_the_frame_name() {
        assert_eq!(convention_of("base_link", true), Convention::Rep103);
        assert_eq!(convention_of("imu_frd", true), Convention::Native);
        assert_eq!(convention_of("map", false), Convention::Rep103);
        assert_eq!(convention_of("odom_ned", false), Convention::Native);
        assert_eq!(convention_of("ned", false), Convention::Native);
        // A body frame named like a world frame is still REP-103 in the body.
        assert_eq!(convention_of("base_ned", true), Convention::Rep103);
    }

    #[test]
    fn flu_vectors_become_frd() {
        let s = RosSettings::default();
        let n = numbers(&[0.1, 0.2, 0.3, 1.0, 2.0, 9.8]);
        let Converted::Imu(m) = convert(RosType::Imu, &n, (5, 7), "base_link", None, &s).unwrap()
        else {
            panic!()
        };
        assert_eq!(m.stamp_ns, 5_000_000_007);
        assert_eq!(m.angular_velocity, [0.1, -0.2, -0.3]);
        // At rest and level, REP-103's accelerometer reads +9.8 up: FRD's -9.8 down.
        assert_eq!(m.specific_force, [1.0, -2.0, -9.8]);
        let Converted::Imu(m) = convert(RosType::Imu, &n, (5, 7), "imu_frd", None, &s).unwrap()
        else {
            panic!()
        };
        assert_eq!(m.specific_force, [1.0, 2.0, 9.8]);
        // A topic's override wins over the frame name.
        let Converted::Imu(m) = convert(
            RosType::Imu,
            &n,
            (5, 7),
            "imu_frd",
            Some(Convention::Rep103),
            &s,
        )
        .unwrap() else {
            panic!()
        };
        assert_eq!(m.angular_velocity, [0.1, -0.2, -0.3]);
    }

    /// A REP-103 attitude (ENU from FLU) gives the contract's Euler angles: yaw measured from
    /// north clockwise (90 deg - ENU yaw), roll the same, pitch of the other sign.
    #[test]
    fn enu_quaternions_become_ned_euler_angles() {
        let (roll, pitch, yaw_enu) = (0.1f64, 0.2f64, 1.2f64);
        let q = UnitQuaternion::from_euler_angles(roll, pitch, yaw_enu);
        let n = numbers(&[q.i, q.j, q.k, q.w]);
        let s = RosSettings::default();
        let Converted::Attitude(a) =
            convert(RosType::QuaternionStamped, &n, (0, 0), "map", None, &s).unwrap()
        else {
            panic!()
        };
        let yaw_ned = std::f64::consts::FRAC_PI_2 - yaw_enu;
        assert!((a.roll - roll).abs() < 1e-12, "{a:?}");
        assert!((a.pitch + pitch).abs() < 1e-12, "{a:?}");
        assert!(
            (crate::angle::wrap_pi(a.yaw - yaw_ned)).abs() < 1e-12,
            "{a:?}"
        );
        let Converted::Attitude(a) =
            convert(RosType::QuaternionStamped, &n, (0, 0), "map_ned", None, &s).unwrap()
        else {
            panic!()
        };
        assert!((a.yaw - yaw_enu).abs() < 1e-12 && (a.pitch - pitch).abs() < 1e-12);
        let bad = numbers(&[0.0, 0.0, 0.0, 0.0]);
        assert!(convert(RosType::QuaternionStamped, &bad, (0, 0), "map", None, &s).is_err());
    }

    /// A NavSatFix is an acoustic fix on an acoustic topic or the one named for the role,
    /// a GeoPoseStamped the ship's pose on the ship's; the names never overrule a role the
    /// user named.
    #[test]
    fn a_topic_of_two_roles_is_read_as_the_one_it_plays() {
        let none = BTreeMap::new();
        let named = |role: &str, topic: &str| BTreeMap::from([(role.into(), topic.into())]);
        let fix = RosType::NavSatFix;
        assert_eq!(fix.on_topic("/gps/fix", &none), RosType::NavSatFix);
        assert_eq!(fix.on_topic("/USBL/fix", &none), RosType::AcousticNavSatFix);
        assert_eq!(fix.on_topic("/acoustic", &none), RosType::AcousticNavSatFix);
        let acoustic = named("acoustic_fix", "/pos");
        assert_eq!(fix.on_topic("/pos", &acoustic), RosType::AcousticNavSatFix);
        let gnss = named("gnss", "/usbl/gps");
        assert_eq!(fix.on_topic("/usbl/gps", &gnss), RosType::NavSatFix);
        let pose = RosType::GeoPoseStamped;
        assert_eq!(pose.on_topic("/ship/pose", &none), RosType::ShipGeoPose);
        assert_eq!(
            pose.on_topic("/ship/usbl/pose", &none),
            RosType::GeoPoseStamped
        );
        assert_eq!(pose.on_topic("/pose", &none), RosType::GeoPoseStamped);
        let ship = named("ship_pose", "/nav/pose");
        assert_eq!(pose.on_topic("/nav/pose", &ship), RosType::ShipGeoPose);
        let vehicle = named("acoustic_fix", "/ship_fix");
        assert_eq!(
            pose.on_topic("/ship_fix", &vehicle),
            RosType::GeoPoseStamped
        );
        // Types of one role stay as they are.
        assert_eq!(RosType::Imu.on_topic("/usbl", &none), RosType::Imu);
        // The role readings are not found by their names.
        assert_eq!(
            RosType::of("sensor_msgs/NavSatFix"),
            Some(RosType::NavSatFix)
        );
    }

    /// A GeoPointStamped is an acoustic fix stamped on receipt unless the settings say
    /// otherwise; its altitude is the depth's negative, NaN a horizontal fix.
    #[test]
    fn geo_points_become_acoustic_fixes() {
        let s = RosSettings::default();
        let fix = |alt: f64, s: &RosSettings| match convert(
            RosType::GeoPointStamped,
            &numbers(&[35.1, 129.05, alt]),
            (3, 0),
            "usbl",
            None,
            s,
        )
        .unwrap()
        {
            Converted::AcousticFix(f) => f,
            other => panic!("{other:?}"),
        };
        let f = fix(-42.5, &s);
        assert_eq!(
            (f.stamp_ns, f.latitude_deg, f.longitude_deg),
            (3_000_000_000, 35.1, 129.05)
        );
        assert_eq!((f.depth_m, f.stamp_is_validity), (Some(42.5), false));
        assert_eq!((f.horizontal_sigma_m, f.received_after_s), (None, None));
        assert_eq!(fix(f64::NAN, &s).depth_m, None);
        let valid = RosSettings {
            acoustic_stamp_is_validity: true,
            ..s
        };
        assert!(fix(-1.0, &valid).stamp_is_validity);
        assert_eq!(
            RosType::of("geographic_msgs/GeoPointStamped"),
            Some(RosType::GeoPointStamped)
        );
    }

    #[test]
    fn pressure_fixes_and_dvl_lock() {
        let s = RosSettings::default();
        let p = s.atmospheric_pressure_pa + 100.0 * s.water_density_kg_m3 * s.gravity_m_s2;
        let Converted::Depth(d) =
            convert(RosType::FluidPressure, &numbers(&[p]), (0, 0), "", None, &s).unwrap()
        else {
            panic!()
        };
        assert!((d.depth - 100.0).abs() < 1e-9);
        let fix = |status: f64, cov_type: f64| {
            convert(
                RosType::NavSatFix,
                &numbers(&[status, 35.0, 129.5, 4.0, 16.0, cov_type]),
                (0, 0),
                "gps",
                None,
                &s,
            )
        };
        let Ok(Converted::GnssFix(g)) = fix(0.0, 2.0) else {
            panic!()
        };
        assert!((g.horizontal_sigma_m - 10f64.sqrt()).abs() < 1e-12);
        let Ok(Converted::GnssFix(g)) = fix(0.0, 0.0) else {
            panic!()
        };
        assert_eq!(g.horizontal_sigma_m, s.gnss_sigma_unknown_m);
        assert_eq!(fix(-1.0, 2.0).unwrap_err().field, "status.status");
        let dvl = |cov0: f64| {
            let n = numbers(&[1.0, 0.1, 0.0, cov0]);
            match convert(
                RosType::TwistWithCovarianceStamped,
                &n,
                (0, 0),
                "dvl_frd",
                None,
                &s,
            ) {
                Ok(Converted::Dvl(d)) => d,
                other => panic!("{other:?}"),
            }
        };
        assert!(dvl(0.0001).valid);
        assert!(!dvl(-1.0).valid);
        let point = |z: f64| match convert(
            RosType::PointStamped,
            &numbers(&[10.0, 20.0, z]),
            (0, 0),
            "map",
            None,
            &s,
        ) {
            Ok(Converted::PositionFix(p)) => p,
            other => panic!("{other:?}"),
        };
        let p = point(-5.0);
        assert_eq!((p.north_m, p.east_m, p.down_m), (20.0, 10.0, Some(5.0)));
        let p = point(f64::NAN);
        assert_eq!(p.down_m, None, "NaN is unknown: a horizontal fix");
    }

    /// A REP-103 odometry (ENU pose, FLU twist) and its native twin give one reference
    /// point: heading 30 deg east of north, 1 m/s ahead, 2 m deep, 10 m north and 20 m east.
    #[test]
    fn odometry_becomes_a_reference_point_in_either_convention() {
        let s = RosSettings::default();
        let heading = 30f64.to_radians();
        let enu =
            UnitQuaternion::from_euler_angles(0.0, 0.0, std::f64::consts::FRAC_PI_2 - heading);
        let ned = UnitQuaternion::from_euler_angles(0.0, 0.0, heading);
        let rep103 = numbers(&[
            20.0, 10.0, -2.0, enu.i, enu.j, enu.k, enu.w, 1.0, 0.0, 0.0, 0.0, 0.0, -0.1,
        ]);
        let native = numbers(&[
            10.0, 20.0, 2.0, ned.i, ned.j, ned.k, ned.w, 1.0, 0.0, 0.0, 0.0, 0.0, 0.1,
        ]);
        for (n, frame) in [(rep103, "odom"), (native, "odom_ned")] {
            let Ok(Converted::Truth(t)) = convert(RosType::Odometry, &n, (3, 0), frame, None, &s)
            else {
                panic!("{frame}")
            };
            assert_eq!(
                (t.north_m, t.east_m, t.down_m),
                (10.0, 20.0, 2.0),
                "{frame}"
            );
            assert!((t.attitude[2] - heading).abs() < 1e-12, "{frame}: {t:?}");
            assert!(t.attitude[0].abs() < 1e-12 && t.attitude[1].abs() < 1e-12);
            let v = t.velocity_ned;
            assert!((v[0] - heading.cos()).abs() < 1e-12 && (v[1] - heading.sin()).abs() < 1e-12);
            assert_eq!(t.velocity_body, [1.0, 0.0, 0.0]);
            // Turning to starboard: FLU's z rate is negative, FRD's positive.
            assert_eq!(t.angular_velocity, [0.0, 0.0, 0.1]);
        }
        let mut track = [Truth {
            stamp_ns: 0,
            latitude_deg: 0.0,
            longitude_deg: 0.0,
            north_m: 1000.0,
            east_m: 0.0,
            down_m: 0.0,
            velocity_body: [0.0; 3],
            velocity_ned: [0.0; 3],
            attitude: [0.0; 3],
            angular_velocity: [0.0; 3],
        }];
        place_on_origin(&mut track, (35.0, 129.0));
        // A kilometre north is about 0.009 deg of latitude.
        assert!(
            (track[0].latitude_deg - 35.009_013).abs() < 1e-5,
            "{track:?}"
        );
        assert_eq!(track[0].longitude_deg, 129.0);
        assert!(RosType::Odometry.only_when_named_for() == Some("truth"));
    }

    #[test]
    fn driver_dvls_give_their_lock_altitude_and_frame() {
        let s = RosSettings::default();
        let dvl = |ty: RosType, lock: f64, altitude: f64, frame: &str| {
            let n = numbers(&[1.0, 0.1, 0.02, lock, altitude]);
            match convert(ty, &n, (0, 0), frame, None, &s) {
                Ok(Converted::Dvl(d)) => d,
                other => panic!("{other:?}"),
            }
        };
        // Water Linked: the DVL's own frame is x forward, y right, z down.
        let d = dvl(RosType::WaterLinkedDvl, 1.0, 3.5, "dvl_link");
        assert!(d.valid);
        assert_eq!(d.velocity, [1.0, 0.1, 0.02]);
        assert_eq!(d.altitude, Some(3.5));
        assert!(!dvl(RosType::WaterLinkedDvl, 0.0, 3.5, "dvl_link").valid);
        assert_eq!(RosType::of("dvl_msgs/DVL"), Some(RosType::WaterLinkedDvl));
        // UUV Simulator: a Gazebo link is REP-103; -1 covariance is invalid.
        let d = dvl(RosType::UuvDvl, 0.0, 7.0, "rexrov/dvl_link");
        assert!(d.valid);
        assert_eq!(d.velocity, [1.0, -0.1, -0.02]);
        assert_eq!(d.altitude, Some(7.0));
        assert!(!dvl(RosType::UuvDvl, -1.0, 7.0, "rexrov/dvl_link").valid);
        assert_eq!(dvl(RosType::UuvDvl, 0.0, 0.0, "dvl_frd").altitude, None);
        assert_eq!(
            dvl(RosType::UuvDvl, 0.0, 7.0, "dvl_frd").velocity,
            [1.0, 0.1, 0.02]
        );
    }

    #[test]
    fn acoustic_dvl_lock_comes_from_mode_and_beams_and_its_frame_is_native() {
        let s = RosSettings::default();
        let dvl = |mode: f64, beams: f64, altitude: f64| {
            let n = numbers(&[1.0, 0.1, 0.02, mode, beams, altitude]);
            match convert(RosType::AcousticDvl, &n, (0, 0), "dvl_link", None, &s) {
                Ok(Converted::Dvl(d)) => d,
                other => panic!("{other:?}"),
            }
        };
        let d = dvl(1.0, 4.0, 12.5);
        assert!(d.valid);
        assert_eq!(d.velocity, [1.0, 0.1, 0.02], "x forward, z down: kept");
        assert_eq!(d.altitude, Some(12.5));
        assert!(dvl(1.0, 3.0, 12.5).valid, "three beams give a velocity");
        assert!(!dvl(1.0, 2.0, 12.5).valid);
        assert!(!dvl(2.0, 4.0, 12.5).valid, "water track is not over ground");
        assert_eq!(dvl(1.0, 4.0, 0.0).altitude, None);
    }
}
