//! The trajectory as Foxglove messages, for `trajectory.mcap`: a LocationFix per solution for
//! the map panel and a PoseInFrame for the 3-D panel, so that a user opens the result beside
//! the original log and overlays the two.
//!
//! The messages are Foxglove's schemas as ROS 2 messages (`foxglove_msgs/msg/LocationFix`,
//! `foxglove_msgs/msg/PoseInFrame`), in CDR with their `ros2msg` definitions: Foxglove reads
//! them as its own, and so does any ROS 2 tool. A fixed binary layout takes under a third of
//! the JSON it replaced before compression (60 % after) and a fraction of its time to write (a
//! day's mission is a million messages).
//!
//! Foxglove's frames are REP-103: the pose is in `map` (east, north, up from the mission
//! origin) with the body FLU; the fix covariance is east-north-up.

use crate::filters::ins::record::Solution;
use crate::geodesy;
use crate::ingest::ros::map::ned_from_frd;
use crate::ingest::ros::msg::Dialect;
use crate::ingest::ros::wire::WireWriter;
use nalgebra::Matrix3;

/// The schema name of a fix.
pub const LOCATION_FIX: &str = "foxglove_msgs/msg/LocationFix";

/// The `ros2msg` definition of [`LOCATION_FIX`] (the fields hindsight writes, as the
/// `foxglove_msgs` package defines them), with its dependency.
pub const LOCATION_FIX_MSG: &str = "\
builtin_interfaces/Time timestamp
string frame_id
float64 latitude
float64 longitude
float64 altitude
float64[9] position_covariance
uint8 position_covariance_type
uint8 UNKNOWN=0
uint8 APPROXIMATED=1
uint8 DIAGONAL_KNOWN=2
uint8 KNOWN=3
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
";

/// The schema name of a pose.
pub const POSE_IN_FRAME: &str = "foxglove_msgs/msg/PoseInFrame";

/// The `ros2msg` definition of [`POSE_IN_FRAME`], with its dependencies.
pub const POSE_IN_FRAME_MSG: &str = "\
builtin_interfaces/Time timestamp
string frame_id
geometry_msgs/Pose pose
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
================================================================================
MSG: geometry_msgs/Pose
geometry_msgs/Point position
geometry_msgs/Quaternion orientation
================================================================================
MSG: geometry_msgs/Point
float64 x
float64 y
float64 z
================================================================================
MSG: geometry_msgs/Quaternion
float64 x 0
float64 y 0
float64 z 0
float64 w 1
";

/// `position_covariance_type` KNOWN: the full covariance.
const COVARIANCE_KNOWN: u8 = 3;

/// A stamp a ROS 2 time cannot hold (its seconds are 32-bit: 1901 to 2038).
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("the solution at {stamp_ns} ns is outside a ROS 2 time's range (1901 to 2038)")]
pub struct StampOutOfRange {
    pub stamp_ns: i64,
}

/// A ROS 2 message in `buffer` (its memory reused), its header's stamp checked to fit.
fn message(
    buffer: &mut Vec<u8>,
    stamp_ns: i64,
    frame_id: &str,
) -> Result<WireWriter, StampOutOfRange> {
    i32::try_from(stamp_ns.div_euclid(1_000_000_000)).map_err(|_| StampOutOfRange { stamp_ns })?;
    let mut m = WireWriter::reusing(std::mem::take(buffer), Dialect::Ros2);
    m.header(stamp_ns, frame_id);
    Ok(m)
}

/// North-east-down to east-north-up, for a covariance: `C_enu = T C_ned T^T`.
fn enu_covariance(ned: &Matrix3<f64>) -> [f64; 9] {
    let t = Matrix3::new(0.0, 1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, -1.0);
    let enu = t * ned * t.transpose();
    // Row-major, as Foxglove reads it.
    std::array::from_fn(|k| enu[(k / 3, k % 3)])
}

/// One solution as a [`LOCATION_FIX`], into `out` (cleared first).
pub fn location_fix(
    s: &Solution,
    frame_id: &str,
    out: &mut Vec<u8>,
) -> Result<(), StampOutOfRange> {
    let n = &s.point.nav;
    let mut m = message(out, s.stamp_ns, frame_id)?;
    m.f64s(&[n.lat_rad.to_degrees(), n.lon_rad.to_degrees(), n.height_m])
        .f64s(&enu_covariance(&s.position_cov))
        .u8(COVARIANCE_KNOWN);
    *out = m.into_bytes();
    Ok(())
}

/// One solution as a [`POSE_IN_FRAME`] in `map` (east, north, up from the origin, radians;
/// the body FLU), into `out` (cleared first).
pub fn pose_in_frame(
    s: &Solution,
    origin_rad: (f64, f64),
    frame_id: &str,
    out: &mut Vec<u8>,
) -> Result<(), StampOutOfRange> {
    let n = &s.point.nav;
    let (north, east) =
        geodesy::local_north_east_m(origin_rad.0, origin_rad.1, n.lat_rad, n.lon_rad);
    // The change of axes (NED-ENU, FRD-FLU) is its own inverse.
    let q = ned_from_frd(&n.ned_from_body);
    let mut m = message(out, s.stamp_ns, frame_id)?;
    m.f64s(&[east, north, n.height_m, q.i, q.j, q.k, q.w]);
    *out = m.into_bytes();
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::filters::ins::error_state::{DvlCalibration, ErrorState, WaterState};
    use crate::filters::ins::mechanization::NavState;
    use crate::filters::ins::record::NavPoint;
    use crate::ingest::ros::cdr::Plan;
    use crate::ingest::ros::msg;
    use nalgebra::{UnitQuaternion, Vector3};

    #[test]
    fn a_ned_covariance_becomes_enu_row_major() {
        let ned = Matrix3::new(4.0, 1.0, 0.5, 1.0, 9.0, 0.2, 0.5, 0.2, 1.0);
        let enu = enu_covariance(&ned);
        // East variance 9, north 4, up 1; east-north 1; north-up -0.5; east-up -0.2.
        assert_eq!(enu[0], 9.0);
        assert_eq!(enu[4], 4.0);
        assert_eq!(enu[8], 1.0);
        assert_eq!((enu[1], enu[3]), (1.0, 1.0));
        assert_eq!((enu[5], enu[7]), (-0.5, -0.5));
        assert_eq!((enu[2], enu[6]), (-0.2, -0.2));
    }

    fn solution(stamp_ns: i64) -> Solution {
        let nav = NavState {
            lat_rad: 36.5_f64.to_radians(),
            lon_rad: (-121.9_f64).to_radians(),
            height_m: -42.5,
            vel_ned_m_s: Vector3::new(1.0, 0.5, 0.0),
            ned_from_body: UnitQuaternion::from_euler_angles(0.1, -0.2, 1.2),
        };
        let point = NavPoint {
            nav,
            gyro_bias: Vector3::zeros(),
            accel_bias: Vector3::zeros(),
            dvl: DvlCalibration::zeros(),
            water: WaterState::zeros(),
            gyro_scale_z: 0.0,
            sound_speed_scale: 0.0,
        };
        Solution {
            stamp_ns,
            point,
            sigma: ErrorState::zeros(),
            position_cov: Matrix3::new(4.0, 1.0, 0.5, 1.0, 9.0, 0.2, 0.5, 0.2, 1.0),
            attitude_cov: Matrix3::identity(),
        }
    }

    /// Each message reads back through the ROS 2 reader of the ingest (a CDR plan compiled
    /// from the definition written beside it), field by field.
    #[test]
    fn a_fix_reads_back_through_its_definition() {
        let s = solution(1_700_000_000_123_456_789);
        let mut data = Vec::new();
        location_fix(&s, "forward", &mut data).unwrap();
        let defs = msg::parse(LOCATION_FIX, LOCATION_FIX_MSG).unwrap();
        let mut numbers = vec![
            "timestamp.sec",
            "timestamp.nanosec",
            "latitude",
            "longitude",
            "altitude",
            "position_covariance_type",
        ];
        let elements: Vec<String> = (0..9)
            .map(|k| format!("position_covariance[{k}]"))
            .collect();
        numbers.extend(elements.iter().map(String::as_str));
        let plan = Plan::new(&defs, &numbers, &["frame_id"]).unwrap();
        assert_eq!(plan.check(&data).unwrap(), data.len());
        let got = plan.read(&data).unwrap();
        assert_eq!(
            (got.integer[0], got.integer[1]),
            (1_700_000_000, 123_456_789)
        );
        let nav = &s.point.nav;
        assert_eq!(got.number[2], nav.lat_rad.to_degrees());
        assert_eq!(got.number[3], nav.lon_rad.to_degrees());
        assert_eq!(got.number[4], -42.5);
        assert_eq!(got.integer[5], 3);
        let enu = enu_covariance(&s.position_cov);
        assert_eq!(&got.number[6..15], &enu[..]);
        assert_eq!(got.text[0], "forward");
    }

    #[test]
    fn a_pose_reads_back_in_map_with_the_body_flu() {
        let s = solution(-1_500_000_000);
        let origin = (36.5_f64.to_radians(), (-121.9_f64).to_radians());
        let mut data = Vec::new();
        pose_in_frame(&s, origin, "map", &mut data).unwrap();
        let defs = msg::parse(POSE_IN_FRAME, POSE_IN_FRAME_MSG).unwrap();
        let fields = [
            "timestamp.sec",
            "timestamp.nanosec",
            "pose.position.x",
            "pose.position.y",
            "pose.position.z",
            "pose.orientation.x",
            "pose.orientation.y",
            "pose.orientation.z",
            "pose.orientation.w",
        ];
        let plan = Plan::new(&defs, &fields, &["frame_id"]).unwrap();
        assert_eq!(plan.check(&data).unwrap(), data.len());
        let got = plan.read(&data).unwrap();
        // -1.5 s is 2 s before the epoch plus half a second.
        assert_eq!((got.integer[0], got.integer[1]), (-2, 500_000_000));
        // At the origin: east and north zero, up the height.
        assert_eq!(&got.number[2..5], &[0.0, 0.0, -42.5]);
        let q = ned_from_frd(&s.point.nav.ned_from_body);
        assert_eq!(&got.number[5..9], &[q.i, q.j, q.k, q.w]);
        assert_eq!(got.text[0], "map");
    }

    #[test]
    fn a_stamp_beyond_2038_is_refused_with_its_value() {
        let s = solution(3_000_000_000 * 1_000_000_000);
        let mut data = Vec::new();
        let err = location_fix(&s, "forward", &mut data).unwrap_err();
        assert_eq!(err.stamp_ns, 3_000_000_000 * 1_000_000_000);
    }
}
