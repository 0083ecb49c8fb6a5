//! How a log's topics are read: which topic plays each role, and how ROS 2 messages are
//! converted. Shared by every command that reads a log.

use hindsight::ingest::ros::map::Convention;
use hindsight::ingest::{roles, IngestOptions, MissionDefaults};

/// Topic roles, frame conventions and ROS 2 conversions.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct SourceArgs {
    /// Topic playing a role: ROLE=TOPIC (repeatable), e.g. --topic imu=/vehicle/imu/data.
    /// Roles: imu, mag, dvl, eml, depth, altimeter, rpm, fins, attitude, gnss, position_fix,
    /// truth, and the acoustic ones: acoustic_fix, usbl, ship_pose, lbl. Without it a role takes its default topic (/imu), else the one topic of its
    /// type (a ROS 2 sensor_msgs/msg/Imu anywhere); two such topics are refused. A ROS
    /// nav_msgs/Odometry (a vehicle INS's track) is read only when named for truth, e.g.
    /// --topic truth=/ins/odometry: the solution is then scored against it, its world frame's
    /// origin taken as the mission's.
    #[arg(long = "topic", value_name = "ROLE=TOPIC", value_parser = parse_topic_role)]
    pub topics: Vec<(String, String)>,

    /// Frame convention of a ROS 2 topic whose frame_id misleads: TOPIC=rep103 (body FLU,
    /// world ENU: converted) or TOPIC=native (FRD/NED: kept). Repeatable. Without it: a body
    /// frame_id ending in _frd or a world frame_id ending in _ned is native, others REP-103.
    #[arg(long = "frame", value_name = "TOPIC=CONVENTION", value_parser = parse_frame)]
    pub frames: Vec<(String, Convention)>,

    /// Water density for a ROS 2 FluidPressure's depth, kg/m^3 [default: the config's, else
    /// 1025, sea water; fresh water is 997].
    #[arg(long, value_name = "KG/M3", value_parser = parse_density)]
    pub water_density: Option<f64>,

    /// Origin of the local frame for a log without a `mission` record (a ROS 2 recording):
    /// LAT,LON in degrees [default: the config's, else the first GNSS fix].
    #[arg(long, value_name = "LAT,LON", value_parser = parse_origin, allow_hyphen_values = true)]
    pub origin: Option<(f64, f64)>,
}

impl SourceArgs {
    /// Applies these settings over `options` (the command line wins over a config).
    pub fn apply(&self, options: &mut IngestOptions) {
        options.topics.extend(self.topics.iter().cloned());
        options
            .frame_conventions
            .extend(self.frames.iter().cloned());
        if let Some(rho) = self.water_density {
            options.ros2.water_density_kg_m3 = rho;
        }
    }

    /// `defaults` with the command line's origin over them.
    pub fn mission_defaults(&self, mut defaults: MissionDefaults) -> MissionDefaults {
        if let Some((lat, lon)) = self.origin {
            defaults.origin_latitude_deg = Some(lat);
            defaults.origin_longitude_deg = Some(lon);
        }
        defaults
    }
}

fn split_assignment<'t>(text: &'t str, form: &str) -> Result<(&'t str, &'t str), String> {
    match text.split_once('=') {
        Some((a, b)) if !a.trim().is_empty() && !b.trim().is_empty() => Ok((a.trim(), b.trim())),
        _ => Err(format!("`{text}`: expected {form}")),
    }
}

fn parse_topic_role(text: &str) -> Result<(String, String), String> {
    let (role, topic) = split_assignment(text, "ROLE=TOPIC, e.g. imu=/vehicle/imu/data")?;
    let named = [(role.to_string(), topic.to_string())].into();
    roles::check_role_names(&named).map_err(|e| e.to_string())?;
    Ok((role.to_string(), topic.to_string()))
}

fn parse_frame(text: &str) -> Result<(String, Convention), String> {
    let (topic, convention) = split_assignment(text, "TOPIC=rep103 or TOPIC=native")?;
    Ok((topic.to_string(), convention.parse()?))
}

fn parse_density(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(rho) if (900.0..=1100.0).contains(&rho) => Ok(rho),
        _ => Err(format!(
            "`{text}`: give a water density in kg/m^3 between 900 and 1100"
        )),
    }
}

fn parse_origin(text: &str) -> Result<(f64, f64), String> {
    let bad = || format!("`{text}`: expected LAT,LON in degrees, e.g. 35.1,129.05");
    let (lat, lon) = text.split_once(',').ok_or_else(bad)?;
    let lat: f64 = lat.trim().parse().map_err(|_| bad())?;
    let lon: f64 = lon.trim().parse().map_err(|_| bad())?;
    if lat.abs() <= 90.0 && lon.abs() <= 360.0 {
        Ok((lat, lon))
    } else {
        Err(bad())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn assignments_parse_and_bad_ones_say_the_form() {
        assert_eq!(
            parse_topic_role("imu=/vehicle/imu/data"),
            Ok(("imu".into(), "/vehicle/imu/data".into()))
        );
        assert!(parse_topic_role("gyro=/imu")
            .unwrap_err()
            .contains("roles are"));
        assert!(parse_topic_role("imu").unwrap_err().contains("ROLE=TOPIC"));
        assert_eq!(
            parse_frame("/dvl=native"),
            Ok(("/dvl".into(), Convention::Native))
        );
        assert!(parse_frame("/dvl=up").is_err());
        assert_eq!(parse_origin("-33.9,18.4"), Ok((-33.9, 18.4)));
        assert!(parse_origin("95,0").is_err());
        assert!(parse_density("1.025").is_err());
    }
}
