//! Contract messages written as the standard ROS 2 types in CDR, as a rosbag2 recording holds
//! them: for `hindsight bench --cdr` and for tests of the ROS 2 reader. The inverse of
//! [`crate::ingest::ros2::map`]: REP-103 (body FLU, world ENU) or native (FRD/NED) frames.

use super::writer::{LogWriter, WriteError};
use crate::contract::{
    Altimeter, Attitude, Depth, Dvl, GnssFix, Imu, MagneticField, Message, PositionFix,
};
use crate::ingest::ros2::map::{ned_from_frd, Convention, Ros2Settings};
use crate::ingest::{Log, Stream};
use nalgebra::UnitQuaternion;
use std::io::{Seek, Write};

const SEPARATOR: &str =
    "================================================================================\n";
const HEADER: &str = "MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n";
const TIME: &str = "MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n";
const VECTOR3: &str = "MSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z\n";
const QUATERNION: &str =
    "MSG: geometry_msgs/Quaternion\nfloat64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n";
const POINT: &str = "MSG: geometry_msgs/Point\nfloat64 x\nfloat64 y\nfloat64 z\n";

/// A ROS 2 message definition with its dependencies, as rosbag2 stores it.
fn definition(main: &str, dependencies: &[&str]) -> String {
    let mut text = main.to_string();
    for d in dependencies {
        text.push_str(SEPARATOR);
        text.push_str(d);
    }
    text
}

/// Little-endian plain CDR (XCDR1), the encapsulation ROS 2 writes.
#[derive(Debug, Clone, Default)]
pub struct CdrWriter(Vec<u8>);

impl CdrWriter {
    /// A message with its encapsulation header.
    pub fn new() -> Self {
        CdrWriter(vec![0, 1, 0, 0])
    }
    /// The message's bytes so far.
    pub fn bytes(&self) -> &[u8] {
        &self.0
    }
    /// The message's bytes.
    pub fn into_bytes(self) -> Vec<u8> {
        self.0
    }
    fn align(&mut self, n: usize) {
        while !(self.0.len() - 4).is_multiple_of(n) {
            self.0.push(0);
        }
    }
    pub fn u8(&mut self, v: u8) -> &mut Self {
        self.0.push(v);
        self
    }
    pub fn i8(&mut self, v: i8) -> &mut Self {
        self.u8(v as u8)
    }
    pub fn u16(&mut self, v: u16) -> &mut Self {
        self.align(2);
        self.0.extend(v.to_le_bytes());
        self
    }
    pub fn i32(&mut self, v: i32) -> &mut Self {
        self.align(4);
        self.0.extend(v.to_le_bytes());
        self
    }
    pub fn u32(&mut self, v: u32) -> &mut Self {
        self.align(4);
        self.0.extend(v.to_le_bytes());
        self
    }
    pub fn f32(&mut self, v: f32) -> &mut Self {
        self.align(4);
        self.0.extend(v.to_le_bytes());
        self
    }
    pub fn f64(&mut self, v: f64) -> &mut Self {
        self.align(8);
        self.0.extend(v.to_le_bytes());
        self
    }
    pub fn f64s(&mut self, v: &[f64]) -> &mut Self {
        for &x in v {
            self.f64(x);
        }
        self
    }
    /// A string: length with the terminating NUL, the bytes, NUL.
    pub fn string(&mut self, s: &str) -> &mut Self {
        self.u32(s.len() as u32 + 1);
        self.0.extend(s.as_bytes());
        self.0.push(0);
        self
    }
    /// `std_msgs/Header`: the stamp as (int32 sec, uint32 nanosec), the frame.
    pub fn header(&mut self, stamp_ns: i64, frame_id: &str) -> &mut Self {
        self.i32(stamp_ns.div_euclid(1_000_000_000) as i32)
            .u32(stamp_ns.rem_euclid(1_000_000_000) as u32)
            .string(frame_id)
    }
}

/// A contract message's standard ROS 2 type: name, definition and CDR.
pub trait ToRos2 {
    /// Full type name, `pkg/msg/Type`.
    const TYPE_NAME: &'static str;
    /// The definition with its dependencies.
    fn definition() -> String;
    /// The message in `convention`'s frames.
    fn to_cdr(&self, convention: Convention, settings: &Ros2Settings) -> Vec<u8>;
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

impl ToRos2 for Imu {
    const TYPE_NAME: &'static str = "sensor_msgs/msg/Imu";
    fn definition() -> String {
        definition(
            "std_msgs/Header header\ngeometry_msgs/Quaternion orientation\n\
             float64[9] orientation_covariance\ngeometry_msgs/Vector3 angular_velocity\n\
             float64[9] angular_velocity_covariance\ngeometry_msgs/Vector3 linear_acceleration\n\
             float64[9] linear_acceleration_covariance\n",
            &[HEADER, TIME, QUATERNION, VECTOR3],
        )
    }
    fn to_cdr(&self, c: Convention, _: &Ros2Settings) -> Vec<u8> {
        let mut w = CdrWriter::new();
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

impl ToRos2 for MagneticField {
    const TYPE_NAME: &'static str = "sensor_msgs/msg/MagneticField";
    fn definition() -> String {
        definition(
            "std_msgs/Header header\ngeometry_msgs/Vector3 magnetic_field\n\
             float64[9] magnetic_field_covariance\n",
            &[HEADER, TIME, VECTOR3],
        )
    }
    fn to_cdr(&self, c: Convention, _: &Ros2Settings) -> Vec<u8> {
        let mut w = CdrWriter::new();
        w.header(self.stamp_ns, &frame("base_link", c, "_frd"))
            .f64s(&body(self.magnetic_field, c))
            .f64s(&[0.0; 9]);
        w.into_bytes()
    }
}

impl ToRos2 for Dvl {
    const TYPE_NAME: &'static str = "geometry_msgs/msg/TwistWithCovarianceStamped";
    fn definition() -> String {
        definition(
            "std_msgs/Header header\nTwistWithCovariance twist\n",
            &[
                HEADER,
                TIME,
                "MSG: geometry_msgs/TwistWithCovariance\nTwist twist\nfloat64[36] covariance\n",
                "MSG: geometry_msgs/Twist\nVector3 linear\nVector3 angular\n",
                VECTOR3,
            ],
        )
    }
    /// No bottom lock: covariance[0] = -1. The altitude has no place (the altimeter's).
    fn to_cdr(&self, c: Convention, _: &Ros2Settings) -> Vec<u8> {
        let mut w = CdrWriter::new();
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

impl ToRos2 for Depth {
    const TYPE_NAME: &'static str = "sensor_msgs/msg/FluidPressure";
    fn definition() -> String {
        definition(
            "std_msgs/Header header\nfloat64 fluid_pressure\nfloat64 variance\n",
            &[HEADER, TIME],
        )
    }
    fn to_cdr(&self, _: Convention, s: &Ros2Settings) -> Vec<u8> {
        let pressure =
            s.atmospheric_pressure_pa + self.depth * s.water_density_kg_m3 * s.gravity_m_s2;
        let mut w = CdrWriter::new();
        w.header(self.stamp_ns, "pressure_link")
            .f64(pressure)
            .f64(0.0);
        w.into_bytes()
    }
}

impl ToRos2 for Altimeter {
    const TYPE_NAME: &'static str = "sensor_msgs/msg/Range";
    fn definition() -> String {
        definition(
            "uint8 ULTRASOUND=0\nuint8 INFRARED=1\nstd_msgs/Header header\nuint8 radiation_type\n\
             float32 field_of_view\nfloat32 min_range\nfloat32 max_range\nfloat32 range\n",
            &[HEADER, TIME],
        )
    }
    fn to_cdr(&self, _: Convention, _: &Ros2Settings) -> Vec<u8> {
        let mut w = CdrWriter::new();
        w.header(self.stamp_ns, "altimeter_link")
            .u8(0)
            .f32(0.05)
            .f32(0.3)
            .f32(200.0)
            .f32(self.altitude as f32);
        w.into_bytes()
    }
}

impl ToRos2 for GnssFix {
    const TYPE_NAME: &'static str = "sensor_msgs/msg/NavSatFix";
    fn definition() -> String {
        definition(
            "std_msgs/Header header\nNavSatStatus status\nfloat64 latitude\nfloat64 longitude\n\
             float64 altitude\nfloat64[9] position_covariance\n\
             uint8 COVARIANCE_TYPE_UNKNOWN = 0\nuint8 COVARIANCE_TYPE_DIAGONAL_KNOWN = 2\n\
             uint8 position_covariance_type\n",
            &[
                HEADER,
                TIME,
                "MSG: sensor_msgs/NavSatStatus\nint8 STATUS_NO_FIX =  -1\nint8 STATUS_FIX = 0\n\
                 int8 status\nuint16 SERVICE_GPS = 1\nuint16 service\n",
            ],
        )
    }
    fn to_cdr(&self, _: Convention, _: &Ros2Settings) -> Vec<u8> {
        let var = self.horizontal_sigma_m * self.horizontal_sigma_m;
        let mut w = CdrWriter::new();
        w.header(self.stamp_ns, "gps")
            .i8(0)
            .u16(1)
            .f64s(&[self.latitude_deg, self.longitude_deg, 0.0])
            .f64s(&[var, 0.0, 0.0, 0.0, var, 0.0, 0.0, 0.0, 4.0 * var])
            .u8(2);
        w.into_bytes()
    }
}

impl ToRos2 for Attitude {
    const TYPE_NAME: &'static str = "geometry_msgs/msg/QuaternionStamped";
    fn definition() -> String {
        definition(
            "std_msgs/Header header\ngeometry_msgs/Quaternion quaternion\n",
            &[HEADER, TIME, QUATERNION],
        )
    }
    fn to_cdr(&self, c: Convention, _: &Ros2Settings) -> Vec<u8> {
        let ned_from_body = UnitQuaternion::from_euler_angles(self.roll, self.pitch, self.yaw);
        // The change of axes (NED-ENU, FRD-FLU) is its own inverse: the same map both ways.
        let q = match c {
            Convention::Native => ned_from_body,
            Convention::Rep103 => ned_from_frd(&ned_from_body),
        };
        let mut w = CdrWriter::new();
        w.header(self.stamp_ns, &frame("map", c, "_ned"))
            .f64s(&[q.i, q.j, q.k, q.w]);
        w.into_bytes()
    }
}

impl ToRos2 for PositionFix {
    const TYPE_NAME: &'static str = "geometry_msgs/msg/PointStamped";
    fn definition() -> String {
        definition(
            "std_msgs/Header header\ngeometry_msgs/Point point\n",
            &[HEADER, TIME, POINT],
        )
    }
    /// A horizontal-only fix has a NaN z (ROS's "unknown").
    fn to_cdr(&self, c: Convention, _: &Ros2Settings) -> Vec<u8> {
        let down = self.down_m.unwrap_or(f64::NAN);
        let p = match c {
            Convention::Native => [self.north_m, self.east_m, down],
            Convention::Rep103 => [self.east_m, self.north_m, -down],
        };
        let mut w = CdrWriter::new();
        w.header(self.stamp_ns, &frame("map", c, "_ned")).f64s(&p);
        w.into_bytes()
    }
}

/// The encoder of one stream: its messages as CDR of their standard type.
struct StreamEncoder<'a> {
    type_name: &'static str,
    definition: String,
    encode: Box<dyn Fn(usize) -> Vec<u8> + 'a>,
}

fn encoder_of<'a>(
    stream: &'a Stream,
    c: Convention,
    s: &'a Ros2Settings,
) -> Option<StreamEncoder<'a>> {
    fn typed<'a, T: ToRos2 + Message>(
        stream: &'a Stream,
        c: Convention,
        s: &'a Ros2Settings,
    ) -> Option<StreamEncoder<'a>> {
        let messages = stream.messages::<T>()?;
        Some(StreamEncoder {
            type_name: T::TYPE_NAME,
            definition: T::definition(),
            encode: Box::new(move |i| messages[i].to_cdr(c, s)),
        })
    }
    typed::<Imu>(stream, c, s)
        .or_else(|| typed::<MagneticField>(stream, c, s))
        .or_else(|| typed::<Dvl>(stream, c, s))
        .or_else(|| typed::<Depth>(stream, c, s))
        .or_else(|| typed::<Altimeter>(stream, c, s))
        .or_else(|| typed::<GnssFix>(stream, c, s))
        .or_else(|| typed::<Attitude>(stream, c, s))
        .or_else(|| typed::<PositionFix>(stream, c, s))
}

/// What [`write_as_ros2`] does with a stream of no standard ROS 2 type (`/eml`, `/rpm`,
/// `/fins`, `/truth`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Others {
    /// Left out.
    Leave,
    /// Written as the contract's json beside the cdr topics (a mixed file).
    Json,
}

/// Writes `log` as a ROS 2 recording: the streams with a standard ROS 2 type as CDR, on
/// their topics (`topic_of` renames them, e.g. `/imu` to `/vehicle/imu/data`), the others
/// as `others` says; in stamp order, logged at their stamps, without a `mission` record (as
/// rosbag2 writes). Returns the messages written.
pub fn write_as_ros2<W: Write + Seek>(
    log: &Log,
    convention: Convention,
    settings: &Ros2Settings,
    others: Others,
    topic_of: &dyn Fn(&str) -> String,
    w: &mut LogWriter<W>,
) -> Result<u64, WriteError> {
    let encoders: Vec<Option<StreamEncoder>> = log
        .streams
        .iter()
        .map(|s| encoder_of(s, convention, settings))
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
                w.write_raw(topic, e.type_name, &e.definition, "cdr", &data, log_time)?;
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

/// The streams of `log` with a standard ROS 2 type as CDR on their own topics, the others
/// left out (see [`write_as_ros2`]).
pub fn write_standard_streams<W: Write + Seek>(
    log: &Log,
    convention: Convention,
    settings: &Ros2Settings,
    w: &mut LogWriter<W>,
) -> Result<u64, WriteError> {
    write_as_ros2(
        log,
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
    use crate::ingest::ros2::decoder::Ros2Decoder;

    /// Writes `m` as its ROS 2 type and reads it back through the schema text.
    fn round_trip<T: ToRos2 + Message>(m: &T, c: Convention) -> T {
        let s = Ros2Settings::default();
        let d = Ros2Decoder::for_schema(T::TYPE_NAME, &T::definition(), None, s)
            .unwrap()
            .unwrap();
        let mut out = d.new_samples();
        d.decode_into(&m.to_cdr(c, &s), out.as_mut()).unwrap();
        out.as_slice::<T>().unwrap()[0].clone()
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
