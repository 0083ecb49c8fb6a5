//! The definitions of the standard types hindsight reads, as ROS 2 Humble's rosbag2 would
//! store them and as a ROS 1 bag does (comments left out). A ROS 2 bag in sqlite3 storage
//! before Iron carries no definitions; its topics of these types are read with these. The
//! simulator writes its ROS recordings with them too.

use super::map::RosType;
use super::msg::Dialect;

const SEPARATOR: &str =
    "================================================================================\n";
const HEADER: &str = "MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n";
/// ROS 1's `std_msgs/Header`: a sequence number, and the built-in `time`.
const HEADER_ROS1: &str = "MSG: std_msgs/Header\nuint32 seq\ntime stamp\nstring frame_id\n";
const TIME: &str = "MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n";
const VECTOR3: &str = "MSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z\n";
const QUATERNION: &str =
    "MSG: geometry_msgs/Quaternion\nfloat64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n";
const POINT: &str = "MSG: geometry_msgs/Point\nfloat64 x\nfloat64 y\nfloat64 z\n";
const TWIST_WITH_COVARIANCE: &str =
    "MSG: geometry_msgs/TwistWithCovariance\nTwist twist\nfloat64[36] covariance\n";
const TWIST: &str = "MSG: geometry_msgs/Twist\nVector3 linear\nVector3 angular\n";
const POSE_WITH_COVARIANCE: &str =
    "MSG: geometry_msgs/PoseWithCovariance\nPose pose\nfloat64[36] covariance\n";
const POSE: &str = "MSG: geometry_msgs/Pose\nPoint position\nQuaternion orientation\n";
const GEO_POINT: &str =
    "MSG: geographic_msgs/GeoPoint\nfloat64 latitude\nfloat64 longitude\nfloat64 altitude\n";

/// `vehicle_interface/AcousticModemUSBLLONG` as the oceansystemslab EvoLogics driver
/// publishes it (an older variant has no `current_time`).
const USBL_LONG: &str = "std_msgs/Header header\nfloat32 current_time\nfloat32 measurement_time\n\
     uint8 remote_address\nfloat32 X\nfloat32 Y\nfloat32 Z\nfloat32 N\nfloat32 E\nfloat32 U\n\
     float32 roll\nfloat32 pitch\nfloat32 yaw\nfloat32 propagation_time\nfloat32 accuracy\n\
     diagnostic_msgs/KeyValue[] info\n";
const KEY_VALUE: &str = "MSG: diagnostic_msgs/KeyValue\nstring key\nstring value\n";

/// A message definition with its dependencies, written as ROS 2's: ROS 1's has its own
/// header and no `Time`.
fn joined(dialect: Dialect, main: &str, dependencies: &[&str]) -> String {
    let mut text = main.to_string();
    for &d in dependencies {
        let d = match (dialect, d) {
            (Dialect::Ros1, HEADER) => HEADER_ROS1,
            (Dialect::Ros1, TIME) => continue,
            _ => d,
        };
        text.push_str(SEPARATOR);
        text.push_str(d);
    }
    text
}

/// The definition of a standard type in the given ROS (`None`: not known here).
pub fn definition(ty: RosType, dialect: Dialect) -> Option<String> {
    let d = dialect;
    Some(match ty {
        RosType::Imu => joined(
            d,
            "std_msgs/Header header\ngeometry_msgs/Quaternion orientation\n\
             float64[9] orientation_covariance\ngeometry_msgs/Vector3 angular_velocity\n\
             float64[9] angular_velocity_covariance\ngeometry_msgs/Vector3 linear_acceleration\n\
             float64[9] linear_acceleration_covariance\n",
            &[HEADER, TIME, QUATERNION, VECTOR3],
        ),
        RosType::MagneticField => joined(
            d,
            "std_msgs/Header header\ngeometry_msgs/Vector3 magnetic_field\n\
             float64[9] magnetic_field_covariance\n",
            &[HEADER, TIME, VECTOR3],
        ),
        RosType::TwistWithCovarianceStamped => joined(
            d,
            "std_msgs/Header header\nTwistWithCovariance twist\n",
            &[HEADER, TIME, TWIST_WITH_COVARIANCE, TWIST, VECTOR3],
        ),
        RosType::Odometry => joined(
            d,
            "std_msgs/Header header\nstring child_frame_id\n\
             geometry_msgs/PoseWithCovariance pose\ngeometry_msgs/TwistWithCovariance twist\n",
            &[
                HEADER,
                TIME,
                POSE_WITH_COVARIANCE,
                POSE,
                POINT,
                QUATERNION,
                TWIST_WITH_COVARIANCE,
                TWIST,
                VECTOR3,
            ],
        ),
        RosType::FluidPressure => joined(
            d,
            "std_msgs/Header header\nfloat64 fluid_pressure\nfloat64 variance\n",
            &[HEADER, TIME],
        ),
        RosType::Range => joined(
            d,
            "uint8 ULTRASOUND=0\nuint8 INFRARED=1\nstd_msgs/Header header\nuint8 radiation_type\n\
             float32 field_of_view\nfloat32 min_range\nfloat32 max_range\nfloat32 range\n",
            &[HEADER, TIME],
        ),
        RosType::NavSatFix | RosType::AcousticNavSatFix => joined(
            d,
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
        ),
        RosType::QuaternionStamped => joined(
            d,
            "std_msgs/Header header\ngeometry_msgs/Quaternion quaternion\n",
            &[HEADER, TIME, QUATERNION],
        ),
        RosType::GeoPointStamped => joined(
            d,
            "std_msgs/Header header\ngeographic_msgs/GeoPoint position\n",
            &[HEADER, TIME, GEO_POINT],
        ),
        RosType::GeoPoseStamped | RosType::ShipGeoPose => joined(
            d,
            "std_msgs/Header header\ngeographic_msgs/GeoPose pose\n",
            &[
                HEADER,
                TIME,
                "MSG: geographic_msgs/GeoPose\nGeoPoint position\n\
                 geometry_msgs/Quaternion orientation\n",
                GEO_POINT,
                QUATERNION,
            ],
        ),
        RosType::PoseWithCovarianceStamped => joined(
            d,
            "std_msgs/Header header\ngeometry_msgs/PoseWithCovariance pose\n",
            &[HEADER, TIME, POSE_WITH_COVARIANCE, POSE, POINT, QUATERNION],
        ),
        RosType::PointStamped => joined(
            d,
            "std_msgs/Header header\ngeometry_msgs/Point point\n",
            &[HEADER, TIME, POINT],
        ),
        RosType::EvologicsUsblLong => joined(d, USBL_LONG, &[HEADER, TIME, KEY_VALUE]),
        RosType::AcousticDvl | RosType::WaterLinkedDvl | RosType::UuvDvl => return None,
    })
}
