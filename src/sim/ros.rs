//! Contract messages written as the standard ROS types, in CDR as a rosbag2 recording holds
//! them or in ROS 1's serialisation as a ROS 1 bag does: for `hindsight bench --cdr` and
//! `--ros1`, and for tests of the ROS readers. The inverse of [`crate::ingest::ros::map`]:
//! REP-103 (body FLU, world ENU) or native (FRD/NED) frames.

use super::writer::{LogWriter, WriteError};
use crate::contract::{
    AcousticFix, Altimeter, Attitude, Depth, Dvl, GnssFix, Imu, MagneticField, Message,
    PositionFix, ShipPose, UsblObservation,
};
use crate::ingest::ros::map::RosType;
use crate::ingest::ros::map::{ned_from_frd, Convention, RosSettings};
use crate::ingest::ros::msg::Dialect;
use crate::ingest::ros::standard::definition as standard_definition;

use crate::ingest::{Log, Stream};
use nalgebra::UnitQuaternion;
use std::io::{Seek, Write};

pub use crate::ingest::ros::wire::WireWriter;

/// A contract message's standard ROS type: name, definition and bytes.
pub trait ToRos {
    /// The standard type the message is written as.
    const ROS_TYPE: RosType;
    /// The message in `convention`'s frames, serialised for the given ROS.
    fn encode(&self, dialect: Dialect, convention: Convention, settings: &RosSettings) -> Vec<u8>;
    /// The type's name in the given ROS: `pkg/msg/Type` (ROS 2) or `pkg/Type` (ROS 1).
    fn type_name(dialect: Dialect) -> String {
        let name = Self::ROS_TYPE.name();
        match dialect {
            Dialect::Ros1 => name.to_string(),
            Dialect::Ros2 => name.replacen('/', "/msg/", 1),
        }
    }
    /// The definition with its dependencies, in the given ROS (every type the simulator
    /// writes is a standard one).
    fn definition_in(dialect: Dialect) -> String {
        standard_definition(Self::ROS_TYPE, dialect).expect("a standard type the simulator writes")
    }
    /// The ROS 2 definition.
    fn definition() -> String {
        Self::definition_in(Dialect::Ros2)
    }
    /// The message as ROS 2 CDR.
    fn to_cdr(&self, convention: Convention, settings: &RosSettings) -> Vec<u8> {
        self.encode(Dialect::Ros2, convention, settings)
    }
}

/// Body FRD to the convention's body frame.
fn body(v: [f64; 3], c: Convention) -> [f64; 3] {
    match c {
        Convention::Native => v,
        Convention::Rep103 => [v[0], -v[1], -v[2]],
    }
}

/// A frame name that says the convention.
fn frame(name: &str, c: Convention, native_suffix: &str) -> String {
    match c {
        Convention::Native => format!("{name}{native_suffix}"),
        Convention::Rep103 => name.to_string(),
    }
}

impl ToRos for Imu {
    const ROS_TYPE: RosType = RosType::Imu;
    fn encode(&self, d: Dialect, c: Convention, _: &RosSettings) -> Vec<u8> {
        let mut w = WireWriter::of(d);
        let mut unknown = [0.0; 9];
        unknown[0] = -1.0; // no orientation
        w.header(self.stamp_ns, &frame("base_link", c, "_frd"))
            .f64s(&[0.0, 0.0, 0.0, 1.0])
            .f64s(&unknown)
            .f64s(&body(self.angular_velocity, c))
            .f64s(&[0.0; 9])
            .f64s(&body(self.specific_force, c))
            .f64s(&[0.0; 9]);
        w.into_bytes()
    }
}

impl ToRos for MagneticField {
    const ROS_TYPE: RosType = RosType::MagneticField;
    fn encode(&self, d: Dialect, c: Convention, _: &RosSettings) -> Vec<u8> {
        let mut w = WireWriter::of(d);
        w.header(self.stamp_ns, &frame("base_link", c, "_frd"))
            .f64s(&body(self.magnetic_field, c))
            .f64s(&[0.0; 9]);
        w.into_bytes()
    }
}

impl ToRos for Dvl {
    const ROS_TYPE: RosType = RosType::TwistWithCovarianceStamped;
    /// No bottom lock: covariance[0] = -1. The altitude has no place (the altimeter's).
    fn encode(&self, d: Dialect, c: Convention, _: &RosSettings) -> Vec<u8> {
        let mut w = WireWriter::of(d);
        let mut cov = [0.0; 36];
        let variance = if self.valid { 1e-4 } else { -1.0 };
        cov[0] = variance;
        cov[7] = variance;
        cov[14] = variance;
        w.header(self.stamp_ns, &frame("dvl_link", c, "_frd"))
            .f64s(&body(self.velocity, c))
            .f64s(&[0.0; 3])
            .f64s(&cov);
        w.into_bytes()
    }
}

impl ToRos for Depth {
    const ROS_TYPE: RosType = RosType::FluidPressure;
    fn encode(&self, d: Dialect, _: Convention, s: &RosSettings) -> Vec<u8> {
        let pressure =
            s.atmospheric_pressure_pa + self.depth * s.water_density_kg_m3 * s.gravity_m_s2;
        let mut w = WireWriter::of(d);
        w.header(self.stamp_ns, "pressure_link")
            .f64(pressure)
            .f64(0.0);
        w.into_bytes()
    }
}

impl ToRos for Altimeter {
    const ROS_TYPE: RosType = RosType::Range;
    fn encode(&self, d: Dialect, _: Convention, _: &RosSettings) -> Vec<u8> {
        let mut w = WireWriter::of(d);
        w.header(self.stamp_ns, "altimeter_link")
            .u8(0)
            .f32(0.05)
            .f32(0.3)
            .f32(200.0)
            .f32(self.altitude as f32);
        w.into_bytes()
    }
}

impl ToRos for GnssFix {
    const ROS_TYPE: RosType = RosType::NavSatFix;
    fn encode(&self, d: Dialect, _: Convention, _: &RosSettings) -> Vec<u8> {
        let var = self.horizontal_sigma_m * self.horizontal_sigma_m;
        let mut w = WireWriter::of(d);
        w.header(self.stamp_ns, "gps")
            .i8(0)
            .u16(1)
            .f64s(&[self.latitude_deg, self.longitude_deg, 0.0])
            .f64s(&[var, 0.0, 0.0, 0.0, var, 0.0, 0.0, 0.0, 4.0 * var])
            .u8(2);
        w.into_bytes()
    }
}

impl ToRos for Attitude {
    const ROS_TYPE: RosType = RosType::QuaternionStamped;
    fn encode(&self, d: Dialect, c: Convention, _: &RosSettings) -> Vec<u8> {
        let ned_from_body = UnitQuaternion::from_euler_angles(self.roll, self.pitch, self.yaw);
        let mut w = WireWriter::of(d);
        w.header(self.stamp_ns, &frame("map", c, "_ned"))
            .f64s(&quaternion(ned_from_body, c));
        w.into_bytes()
    }
}

impl ToRos for PositionFix {
    const ROS_TYPE: RosType = RosType::PointStamped;
    /// A horizontal-only fix has a NaN z (ROS's "unknown").
    fn encode(&self, d: Dialect, c: Convention, _: &RosSettings) -> Vec<u8> {
        let down = self.down_m.unwrap_or(f64::NAN);
        let p = match c {
            Convention::Native => [self.north_m, self.east_m, down],
            Convention::Rep103 => [self.east_m, self.north_m, -down],
        };
        let mut w = WireWriter::of(d);
        w.header(self.stamp_ns, &frame("map", c, "_ned")).f64s(&p);
        w.into_bytes()
    }
}

/// A NED-from-body attitude as the convention's quaternion `[x, y, z, w]` (the change of
/// axes, NED-ENU and FRD-FLU, is its own inverse: the same map both ways).
fn quaternion(ned_from_body: UnitQuaternion<f64>, c: Convention) -> [f64; 4] {
    let q = match c {
        Convention::Native => ned_from_body,
        Convention::Rep103 => ned_from_frd(&ned_from_body),
    };
    [q.i, q.j, q.k, q.w]
}

/// A depth as a geographic altitude (an unknown one: NaN, geographic_msgs' "unknown").
fn altitude(depth_m: Option<f64>) -> f64 {
    depth_m.map_or(f64::NAN, |d| -d)
}

impl ToRos for AcousticFix {
    const ROS_TYPE: RosType = RosType::GeoPointStamped;
    /// The point only: the sigmas, the time of receipt and the beacon have no place.
    fn encode(&self, d: Dialect, _: Convention, _: &RosSettings) -> Vec<u8> {
        let mut w = WireWriter::of(d);
        w.header(self.stamp_ns, "usbl").f64s(&[
            self.latitude_deg,
            self.longitude_deg,
            altitude(self.depth_m),
        ]);
        w.into_bytes()
    }
}

/// An acoustic fix written as a `sensor_msgs/NavSatFix`, as USBL drivers publish it (on a
/// topic whose name says `usbl`): its sigmas in the covariance (type unknown without them).
pub struct AcousticNavSatFix<'a>(pub &'a AcousticFix);

impl ToRos for AcousticNavSatFix<'_> {
    const ROS_TYPE: RosType = RosType::AcousticNavSatFix;
    fn encode(&self, d: Dialect, _: Convention, _: &RosSettings) -> Vec<u8> {
        let fix = self.0;
        let horizontal = fix.horizontal_sigma_m.map_or(0.0, |s| s * s);
        let depth = fix.depth_sigma_m.map_or(0.0, |s| s * s);
        let known = if fix.horizontal_sigma_m.is_some() {
            2
        } else {
            0
        };
        let mut w = WireWriter::of(d);
        w.header(fix.stamp_ns, "usbl")
            .i8(0)
            .u16(0)
            .f64s(&[fix.latitude_deg, fix.longitude_deg, altitude(fix.depth_m)])
            .f64s(&[horizontal, 0.0, 0.0, 0.0, horizontal, 0.0, 0.0, 0.0, depth])
            .u8(known);
        w.into_bytes()
    }
}

/// An acoustic fix written as a `geographic_msgs/GeoPoseStamped` (its orientation the
/// identity: a fix carries none).
pub struct AcousticGeoPose<'a>(pub &'a AcousticFix);

impl ToRos for AcousticGeoPose<'_> {
    const ROS_TYPE: RosType = RosType::GeoPoseStamped;
    fn encode(&self, d: Dialect, _: Convention, _: &RosSettings) -> Vec<u8> {
        let fix = self.0;
        let mut w = WireWriter::of(d);
        w.header(fix.stamp_ns, "usbl")
            .f64s(&[fix.latitude_deg, fix.longitude_deg, altitude(fix.depth_m)])
            .f64s(&[0.0, 0.0, 0.0, 1.0]);
        w.into_bytes()
    }
}

impl ToRos for ShipPose {
    const ROS_TYPE: RosType = RosType::ShipGeoPose;
    /// At the sea surface (altitude 0); the sigmas have no place.
    fn encode(&self, d: Dialect, c: Convention, _: &RosSettings) -> Vec<u8> {
        let ned_from_body = UnitQuaternion::from_euler_angles(self.roll, self.pitch, self.yaw);
        let mut w = WireWriter::of(d);
        w.header(self.stamp_ns, &frame("ship", c, "_ned"))
            .f64s(&[self.latitude_deg, self.longitude_deg, 0.0])
            .f64s(&quaternion(ned_from_body, c));
        w.into_bytes()
    }
}

/// A local position fix written as a `geometry_msgs/PoseWithCovarianceStamped` (a
/// localiser's USBL or LBL solution): its sigma in the covariance, orientation the identity.
pub struct PositionFixPose<'a>(pub &'a PositionFix);

impl ToRos for PositionFixPose<'_> {
    const ROS_TYPE: RosType = RosType::PoseWithCovarianceStamped;
    fn encode(&self, d: Dialect, c: Convention, _: &RosSettings) -> Vec<u8> {
        let fix = self.0;
        let down = fix.down_m.unwrap_or(f64::NAN);
        let p = match c {
            Convention::Native => [fix.north_m, fix.east_m, down],
            Convention::Rep103 => [fix.east_m, fix.north_m, -down],
        };
        let variance = fix.sigma_m * fix.sigma_m;
        let mut cov = [0.0; 36];
        (cov[0], cov[7], cov[14]) = (variance, variance, variance);
        let mut w = WireWriter::of(d);
        w.header(fix.stamp_ns, &frame("map", c, "_ned"))
            .f64s(&p)
            .f64s(&[0.0, 0.0, 0.0, 1.0])
            .f64s(&cov);
        w.into_bytes()
    }
}

/// The EvoLogics device's clock of an observation: seconds within the hour, plus 100 s
/// (small, as a device's uptime: `float32` keeps them to 0.25 ms).
fn device_clock_s(stamp_ns: i64) -> f64 {
    100.0 + stamp_ns.rem_euclid(3_600_000_000_000) as f64 * 1e-9
}

/// A USBL observation as EvoLogics' `USBLLONG` (the inverse of
/// [`crate::ingest::ros::evologics`]): the header stamped on receipt, the device's two
/// times the delay apart (0 for a time of validity without one; `current_time` NaN for a
/// stamp of receipt), the target in the
/// transducer's axes, the propagation time from the speed of sound (0 without one), the
/// beacon id as the remote address (0 when it is not a number). The device's own attitude
/// and motion-compensated position are written as zeros: the reader takes the ship's.
fn usbl_long(o: &UsblObservation, d: Dialect, with_current_time: bool) -> Vec<u8> {
    // A time of validity without a delay: received at once.
    let delay_s = o
        .stamp_is_validity
        .then(|| o.received_after_s.unwrap_or(0.0));
    let receipt_ns = o.stamp_ns + delay_s.map_or(0, |s| (s * 1e9).round() as i64);
    let measurement_time = device_clock_s(o.stamp_ns);
    let current_time = delay_s.map_or(f64::NAN, |s| measurement_time + s);
    let (cos_e, sin_e) = (o.elevation_rad.cos(), o.elevation_rad.sin());
    let target = [
        o.range_m * cos_e * o.bearing_rad.cos(),
        o.range_m * cos_e * o.bearing_rad.sin(),
        o.range_m * sin_e,
    ];
    let propagation_us = o.sound_speed_m_s.map_or(0.0, |c| o.range_m / c * 1e6);
    let mut w = WireWriter::of(d);
    w.header(receipt_ns, "usbl");
    if with_current_time {
        w.f32(current_time as f32);
    }
    w.f32(measurement_time as f32)
        .u8(o.beacon_id.parse().unwrap_or(0));
    for v in target.into_iter().chain([0.0; 6]) {
        w.f32(v as f32);
    }
    w.f32(propagation_us as f32).f32(0.0).u32(0);
    w.into_bytes()
}

impl ToRos for UsblObservation {
    const ROS_TYPE: RosType = RosType::EvologicsUsblLong;
    fn encode(&self, d: Dialect, _: Convention, _: &RosSettings) -> Vec<u8> {
        usbl_long(self, d, true)
    }
}

/// A USBL observation as the older `USBLLONG` message of the same driver, which has no
/// `current_time`: stamped on receipt only.
pub struct UsblLongWithoutCurrentTime<'a>(pub &'a UsblObservation);

impl ToRos for UsblLongWithoutCurrentTime<'_> {
    const ROS_TYPE: RosType = RosType::EvologicsUsblLong;
    fn encode(&self, d: Dialect, _: Convention, _: &RosSettings) -> Vec<u8> {
        usbl_long(self.0, d, false)
    }
    fn definition_in(dialect: Dialect) -> String {
        UsblObservation::definition_in(dialect).replacen("float32 current_time\n", "", 1)
    }
}

/// The encoder of one stream: its messages in their standard type.
struct StreamEncoder<'a> {
    type_name: String,
    definition: String,
    encode: Box<dyn Fn(usize) -> Vec<u8> + 'a>,
}

fn encoder_of<'a>(
    stream: &'a Stream,
    d: Dialect,
    c: Convention,
    s: &'a RosSettings,
) -> Option<StreamEncoder<'a>> {
    fn typed<'a, T: ToRos + Message>(
        stream: &'a Stream,
        d: Dialect,
        c: Convention,
        s: &'a RosSettings,
    ) -> Option<StreamEncoder<'a>> {
        let messages = stream.messages::<T>()?;
        Some(StreamEncoder {
            type_name: T::type_name(d),
            definition: T::definition_in(d),
            encode: Box::new(move |i| messages[i].encode(d, c, s)),
        })
    }
    typed::<Imu>(stream, d, c, s)
        .or_else(|| typed::<MagneticField>(stream, d, c, s))
        .or_else(|| typed::<Dvl>(stream, d, c, s))
        .or_else(|| typed::<Depth>(stream, d, c, s))
        .or_else(|| typed::<Altimeter>(stream, d, c, s))
        .or_else(|| typed::<GnssFix>(stream, d, c, s))
        .or_else(|| typed::<Attitude>(stream, d, c, s))
        .or_else(|| typed::<PositionFix>(stream, d, c, s))
        .or_else(|| typed::<AcousticFix>(stream, d, c, s))
        .or_else(|| typed::<ShipPose>(stream, d, c, s))
        .or_else(|| typed::<UsblObservation>(stream, d, c, s))
}

/// What [`write_as_ros`] does with a stream of no standard ROS type (`/eml`, `/rpm`,
/// `/fins`, `/truth`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Others {
    /// Left out.
    Leave,
    /// Written as the contract's json beside the ROS topics (a mixed file).
    Json,
}

/// The MCAP message encoding of a ROS's messages.
pub fn message_encoding(dialect: Dialect) -> &'static str {
    match dialect {
        Dialect::Ros1 => "ros1",
        Dialect::Ros2 => "cdr",
    }
}

/// One message of a standard type, serialised: what a ROS container writes.
pub struct RosMessage<'a> {
    /// Index of the log's stream it comes from.
    pub stream: usize,
    pub type_name: &'a str,
    pub definition: &'a str,
    pub data: Vec<u8>,
    pub log_time_ns: u64,
}

/// Every message of `log`'s streams with a standard ROS type, serialised for `dialect`, in
/// stamp order (logged at their stamps), to `each`.
pub fn for_each_ros_message<E>(
    log: &Log,
    dialect: Dialect,
    convention: Convention,
    settings: &RosSettings,
    mut each: impl FnMut(RosMessage<'_>) -> Result<(), E>,
) -> Result<u64, E> {
    let encoders: Vec<Option<StreamEncoder>> = log
        .streams
        .iter()
        .map(|s| encoder_of(s, dialect, convention, settings))
        .collect();
    let mut written = 0;
    for event in crate::align::merged(&log.streams) {
        if let Some(e) = &encoders[event.stream] {
            each(RosMessage {
                stream: event.stream,
                type_name: &e.type_name,
                definition: &e.definition,
                data: (e.encode)(event.index),
                log_time_ns: u64::try_from(event.stamp_ns).unwrap_or(0),
            })?;
            written += 1;
        }
    }
    Ok(written)
}

/// Writes `log` as a ROS 2 recording (CDR, as rosbag2 writes MCAP) or a ROS 1 one (as
/// `mcap convert` writes a bag): the streams with a standard ROS type on their topics
/// (`topic_of` renames them, e.g. `/imu` to `/vehicle/imu/data`), the others as `others`
/// says; in stamp order, logged at their stamps, without a `mission` record. Returns the
/// messages written.
pub fn write_as_ros<W: Write + Seek>(
    log: &Log,
    dialect: Dialect,
    convention: Convention,
    settings: &RosSettings,
    others: Others,
    topic_of: &dyn Fn(&str) -> String,
    w: &mut LogWriter<W>,
) -> Result<u64, WriteError> {
    let encoders: Vec<Option<StreamEncoder>> = log
        .streams
        .iter()
        .map(|s| encoder_of(s, dialect, convention, settings))
        .collect();
    let topics: Vec<String> = log.streams.iter().map(|s| topic_of(&s.topic)).collect();
    let mut written = 0;
    for event in crate::align::merged(&log.streams) {
        let stream = &log.streams[event.stream];
        let log_time = u64::try_from(event.stamp_ns).unwrap_or(0);
        let topic = &topics[event.stream];
        match (&encoders[event.stream], others) {
            (Some(e), _) => {
                let data = (e.encode)(event.index);
                let encoding = message_encoding(dialect);
                w.write_raw(
                    topic,
                    &e.type_name,
                    &e.definition,
                    encoding,
                    &data,
                    log_time,
                )?;
            }
            (None, Others::Json) => {
                let kind = crate::contract::kind_by_schema(stream.samples.schema_name())
                    .expect("a stream holds a contract message");
                let data = stream.samples.to_json(event.index);
                w.write_raw(
                    topic,
                    kind.schema_name(),
                    kind.schema_json(),
                    "json",
                    &data,
                    log_time,
                )?;
            }
            (None, Others::Leave) => continue,
        }
        written += 1;
    }
    Ok(written)
}

/// [`write_as_ros`] for ROS 2.
pub fn write_as_ros2<W: Write + Seek>(
    log: &Log,
    convention: Convention,
    settings: &RosSettings,
    others: Others,
    topic_of: &dyn Fn(&str) -> String,
    w: &mut LogWriter<W>,
) -> Result<u64, WriteError> {
    write_as_ros(
        log,
        Dialect::Ros2,
        convention,
        settings,
        others,
        topic_of,
        w,
    )
}

/// The streams of `log` with a standard ROS type on their own topics, the others left out
/// (see [`write_as_ros`]).
pub fn write_standard_streams<W: Write + Seek>(
    log: &Log,
    dialect: Dialect,
    convention: Convention,
    settings: &RosSettings,
    w: &mut LogWriter<W>,
) -> Result<u64, WriteError> {
    write_as_ros(
        log,
        dialect,
        convention,
        settings,
        Others::Leave,
        &|t| t.to_string(),
        w,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ingest::decode::Decoder;
    use crate::ingest::ros::decoder::RosDecoder;

    /// Writes `m` as its ROS type and reads it back through the schema text, in ROS 2 and
    /// in ROS 1; both must read the same.
    fn round_trip<T: ToRos + Message>(m: &T, c: Convention) -> T {
        read_back(m, "", c)
    }

    /// Writes `m` as its ROS type on `topic` and reads it back as `T` through the schema
    /// text, in ROS 2 and in ROS 1; both must read the same.
    fn read_back<W: ToRos, T: Message>(m: &W, topic: &str, c: Convention) -> T {
        use crate::ingest::ros::decoder::TopicRoles;
        let s = RosSettings::default();
        let named = Default::default();
        let roles = TopicRoles {
            topic,
            named: &named,
        };
        let [ros1, ros2] = [Dialect::Ros1, Dialect::Ros2].map(|dialect| {
            let name = W::type_name(dialect);
            let definition = W::definition_in(dialect);
            let d = RosDecoder::for_topic_in(dialect, &name, &definition, roles, None, s)
                .unwrap()
                .unwrap();
            assert_eq!(d.ros_type(), W::ROS_TYPE);
            let mut out = d.new_samples();
            d.decode_into(&m.encode(dialect, c, &s), out.as_mut())
                .unwrap();
            out.as_slice::<T>().unwrap()[0].clone()
        });
        assert_eq!(ros1, ros2, "{}", W::ROS_TYPE.name());
        ros2
    }

    /// The acoustic types read back as written: the contract's fix where the type carries
    /// all of it, its point (no sigma) where it does not.
    #[test]
    fn acoustic_types_read_back_as_written_in_both_conventions() {
        let fix = AcousticFix {
            stamp_ns: 1_700_000_000_123_456_789,
            stamp_is_validity: false,
            received_after_s: None,
            latitude_deg: 35.1,
            longitude_deg: 129.05,
            depth_m: Some(42.5),
            horizontal_sigma_m: Some(1.5),
            depth_sigma_m: Some(0.5),
            beacon_id: String::new(),
        };
        let point = AcousticFix {
            horizontal_sigma_m: None,
            depth_sigma_m: None,
            ..fix.clone()
        };
        let no_sigma = AcousticFix {
            depth_m: None,
            ..point.clone()
        };
        for c in [Convention::Rep103, Convention::Native] {
            assert_eq!(round_trip(&point, c), point);
            assert_eq!(round_trip(&fix, c), point);
            assert_eq!(round_trip(&no_sigma, c), no_sigma);
            let nav: AcousticFix = read_back(&AcousticNavSatFix(&fix), "/usbl/fix", c);
            assert_eq!(nav, fix);
            let nav: AcousticFix = read_back(&AcousticNavSatFix(&no_sigma), "/usbl/fix", c);
            assert_eq!(nav, no_sigma);
            let pose: AcousticFix = read_back(&AcousticGeoPose(&fix), "/usbl/pose", c);
            assert_eq!(pose, point);
            let ship = ShipPose {
                stamp_ns: 5,
                latitude_deg: 35.2,
                longitude_deg: 129.1,
                roll: 0.05,
                pitch: -0.02,
                yaw: 2.5,
                horizontal_sigma_m: None,
                heading_sigma_rad: None,
            };
            let back: ShipPose = read_back(&ship, "/ship_pose", c);
            assert_eq!(
                (back.latitude_deg, back.longitude_deg),
                (ship.latitude_deg, ship.longitude_deg)
            );
            for (a, b) in [
                (ship.roll, back.roll),
                (ship.pitch, back.pitch),
                (ship.yaw, back.yaw),
            ] {
                assert!(
                    crate::angle::wrap_pi(a - b).abs() < 1e-12,
                    "{c:?}: {back:?}"
                );
            }
            let local = PositionFix {
                stamp_ns: 5,
                north_m: 10.0,
                east_m: -20.0,
                down_m: Some(30.0),
                sigma_m: 2.0,
                label: String::new(),
            };
            let back: PositionFix = read_back(&PositionFixPose(&local), "/usbl/local", c);
            assert_eq!(
                (back.north_m, back.east_m, back.down_m, back.sigma_m),
                (local.north_m, local.east_m, local.down_m, local.sigma_m)
            );
        }
    }

    #[test]
    fn every_type_reads_back_as_written_in_both_conventions() {
        for c in [Convention::Rep103, Convention::Native] {
            let imu = Imu {
                stamp_ns: 1_700_000_000_123_456_789,
                angular_velocity: [0.01, -0.02, 0.03],
                specific_force: [0.1, 0.2, -9.8],
            };
            assert_eq!(round_trip(&imu, c), imu);
            let mag = MagneticField {
                stamp_ns: 5,
                magnetic_field: [2e-5, -3e-6, 4e-5],
            };
            assert_eq!(round_trip(&mag, c), mag);
            for valid in [true, false] {
                let dvl = Dvl {
                    stamp_ns: 5,
                    velocity: [1.5, -0.1, 0.02],
                    valid,
                    altitude: None,
                };
                assert_eq!(round_trip(&dvl, c), dvl);
            }
            let depth = round_trip(
                &Depth {
                    stamp_ns: 5,
                    depth: 42.5,
                },
                c,
            );
            assert!((depth.depth - 42.5).abs() < 1e-9);
            let alt = round_trip(
                &Altimeter {
                    stamp_ns: 5,
                    altitude: 12.25,
                },
                c,
            );
            assert_eq!(alt.altitude, 12.25);
            let fix = GnssFix {
                stamp_ns: 5,
                latitude_deg: 35.1,
                longitude_deg: 129.05,
                horizontal_sigma_m: 2.5,
            };
            assert_eq!(round_trip(&fix, c), fix);
            let att = Attitude {
                stamp_ns: 5,
                roll: 0.1,
                pitch: -0.2,
                yaw: 2.0,
            };
            let back = round_trip(&att, c);
            for (a, b) in [
                (att.roll, back.roll),
                (att.pitch, back.pitch),
                (att.yaw, back.yaw),
            ] {
                assert!(
                    crate::angle::wrap_pi(a - b).abs() < 1e-12,
                    "{c:?}: {back:?}"
                );
            }
            for down_m in [Some(3.0), None] {
                let p = PositionFix {
                    stamp_ns: 5,
                    north_m: 10.0,
                    east_m: -20.0,
                    down_m,
                    sigma_m: 1.0,
                    label: String::new(),
                };
                let back = round_trip(&p, c);
                assert_eq!(
                    (back.north_m, back.east_m, back.down_m),
                    (p.north_m, p.east_m, p.down_m)
                );
            }
        }
    }
}
