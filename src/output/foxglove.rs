//! The trajectory as Foxglove messages (JSON), for `trajectory.mcap`: a `foxglove.LocationFix`
//! per solution for the map panel and a `foxglove.PoseInFrame` for the 3-D panel, so that a
//! user opens the result beside the original log and overlays the two.
//!
//! Foxglove's frames are REP-103: the pose is in `map` (east, north, up from the mission
//! origin) with the body FLU; the fix covariance is east-north-up.

use crate::filters::ins::record::Solution;
use crate::geodesy;
use crate::ingest::ros::map::ned_from_frd;
use nalgebra::Matrix3;
use serde::Serialize;

/// The JSON Schema of `foxglove.LocationFix` (the fields hindsight writes).
pub const LOCATION_FIX_SCHEMA: &str = r#"{
  "title": "foxglove.LocationFix",
  "type": "object",
  "properties": {
    "timestamp": {"type": "object", "properties": {"sec": {"type": "integer"}, "nsec": {"type": "integer"}}},
    "frame_id": {"type": "string"},
    "latitude": {"type": "number"},
    "longitude": {"type": "number"},
    "altitude": {"type": "number"},
    "position_covariance": {"type": "array", "items": {"type": "number"}, "minItems": 9, "maxItems": 9},
    "position_covariance_type": {"type": "integer"}
  }
}"#;

/// The JSON Schema of `foxglove.PoseInFrame`.
pub const POSE_IN_FRAME_SCHEMA: &str = r#"{
  "title": "foxglove.PoseInFrame",
  "type": "object",
  "properties": {
    "timestamp": {"type": "object", "properties": {"sec": {"type": "integer"}, "nsec": {"type": "integer"}}},
    "frame_id": {"type": "string"},
    "pose": {"type": "object", "properties": {
      "position": {"type": "object", "properties": {"x": {"type": "number"}, "y": {"type": "number"}, "z": {"type": "number"}}},
      "orientation": {"type": "object", "properties": {"x": {"type": "number"}, "y": {"type": "number"}, "z": {"type": "number"}, "w": {"type": "number"}}}
    }}
  }
}"#;

/// `position_covariance_type` KNOWN: the full covariance.
const COVARIANCE_KNOWN: u8 = 3;

#[derive(Serialize)]
struct Time {
    sec: i64,
    nsec: i64,
}

impl Time {
    fn of(stamp_ns: i64) -> Time {
        Time {
            sec: stamp_ns.div_euclid(1_000_000_000),
            nsec: stamp_ns.rem_euclid(1_000_000_000),
        }
    }
}

#[derive(Serialize)]
struct LocationFix<'a> {
    timestamp: Time,
    frame_id: &'a str,
    latitude: f64,
    longitude: f64,
    altitude: f64,
    position_covariance: [f64; 9],
    position_covariance_type: u8,
}

#[derive(Serialize)]
struct Xyz {
    x: f64,
    y: f64,
    z: f64,
}

#[derive(Serialize)]
struct Xyzw {
    x: f64,
    y: f64,
    z: f64,
    w: f64,
}

#[derive(Serialize)]
struct Pose {
    position: Xyz,
    orientation: Xyzw,
}

#[derive(Serialize)]
struct PoseInFrame<'a> {
    timestamp: Time,
    frame_id: &'a str,
    pose: Pose,
}

/// North-east-down to east-north-up, for a covariance: `C_enu = T C_ned T^T`.
fn enu_covariance(ned: &Matrix3<f64>) -> [f64; 9] {
    let t = Matrix3::new(0.0, 1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, -1.0);
    let enu = t * ned * t.transpose();
    // Row-major, as Foxglove reads it.
    std::array::from_fn(|k| enu[(k / 3, k % 3)])
}

/// One solution as a `foxglove.LocationFix` (JSON).
pub fn location_fix(s: &Solution, frame_id: &str) -> Vec<u8> {
    let n = &s.point.nav;
    let fix = LocationFix {
        timestamp: Time::of(s.stamp_ns),
        frame_id,
        latitude: n.lat_rad.to_degrees(),
        longitude: n.lon_rad.to_degrees(),
        altitude: n.height_m,
        position_covariance: enu_covariance(&s.position_cov),
        position_covariance_type: COVARIANCE_KNOWN,
    };
    serde_json::to_vec(&fix).expect("numbers serialize")
}

/// One solution as a `foxglove.PoseInFrame` (JSON) in `map`: east, north, up from the origin
/// (radians), the body FLU.
pub fn pose_in_frame(s: &Solution, origin_rad: (f64, f64), frame_id: &str) -> Vec<u8> {
    let n = &s.point.nav;
    let (north, east) =
        geodesy::local_north_east_m(origin_rad.0, origin_rad.1, n.lat_rad, n.lon_rad);
    // The change of axes (NED-ENU, FRD-FLU) is its own inverse.
    let q = ned_from_frd(&n.ned_from_body);
    let pose = PoseInFrame {
        timestamp: Time::of(s.stamp_ns),
        frame_id,
        pose: Pose {
            position: Xyz {
                x: east,
                y: north,
                z: n.height_m,
            },
            orientation: Xyzw {
                x: q.i,
                y: q.j,
                z: q.k,
                w: q.w,
            },
        },
    };
    serde_json::to_vec(&pose).expect("numbers serialize")
}

#[cfg(test)]
mod tests {
    use super::*;

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

    #[test]
    fn time_splits_into_seconds_and_nanoseconds() {
        let t = Time::of(1_700_000_000_123_456_789);
        assert_eq!((t.sec, t.nsec), (1_700_000_000, 123_456_789));
    }
}
