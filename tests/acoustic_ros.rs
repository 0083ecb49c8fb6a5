//! The acoustic ROS types (issue 58): each, written by hindsight's ROS writer in ROS 1 and in
//! ROS 2, reads as the contract's messages carrying what the type carries. The fixes are the
//! `usbl-survey` simulation's; the ship's poses turn through every heading.

use crate::common;
use hindsight::contract::{AcousticFix, Message, PositionFix, ShipPose};
use hindsight::ingest::ros::msg::Dialect;
use hindsight::ingest::Log;
use hindsight::sim::ros::{
    message_encoding, AcousticGeoPose, AcousticNavSatFix, PositionFixPose, ToRos,
};
use hindsight::sim::scenario::Scenario;
use hindsight::sim::writer::{to_bytes, WriterOptions};

/// A log of `messages`, each written as `W` on `topic` in `dialect`, read back.
fn ros_log<'a, M: 'a, W: ToRos>(
    dialect: Dialect,
    topic: &str,
    messages: &'a [M],
    as_ros: impl Fn(&'a M) -> (i64, W),
) -> Log {
    let settings = Default::default();
    let convention = hindsight::ingest::ros::map::Convention::Rep103;
    let bytes = to_bytes(WriterOptions::default(), |w| {
        for m in messages {
            let (stamp_ns, ros) = as_ros(m);
            w.write_raw(
                topic,
                &W::type_name(dialect),
                &W::definition_in(dialect),
                message_encoding(dialect),
                &ros.encode(dialect, convention, &settings),
                stamp_ns as u64,
            )?;
        }
        Ok(())
    })
    .unwrap();
    common::read(&bytes)
}

/// A contract log of `messages` on their default topic, read back.
fn contract_log<T: Message>(messages: &[T]) -> Log {
    let bytes = to_bytes(WriterOptions::default(), |w| {
        for m in messages {
            w.write(T::DEFAULT_TOPIC, m, m.stamp_ns() as u64)?;
        }
        Ok(())
    })
    .unwrap();
    common::read(&bytes)
}

/// The fixes of `usbl-survey` seed 1 as a ROS driver gives them: stamped on receipt, no
/// time of validity, no beacon; `with_sigmas` false: no sigmas either.
fn survey_fixes(with_sigmas: bool) -> Vec<AcousticFix> {
    let log = common::simulated(&Scenario::built_in("usbl-survey").unwrap(), 1);
    let fixes: Vec<AcousticFix> = log
        .role::<AcousticFix>()
        .iter()
        .map(|f| AcousticFix {
            stamp_is_validity: false,
            received_after_s: None,
            beacon_id: String::new(),
            horizontal_sigma_m: f.horizontal_sigma_m.filter(|_| with_sigmas),
            depth_sigma_m: f.depth_sigma_m.filter(|_| with_sigmas),
            ..f.clone()
        })
        .collect();
    assert!(fixes.len() > 100, "{} fixes", fixes.len());
    fixes
}

#[test]
fn acoustic_fixes_in_ros_read_as_the_contract_messages() {
    let (with, without) = (survey_fixes(true), survey_fixes(false));
    assert!(with.iter().all(|f| f.horizontal_sigma_m.is_some()));
    let expected_with = contract_log(&with);
    let expected_without = contract_log(&without);
    let (table_with, table_without) = (
        expected_with.role::<AcousticFix>(),
        expected_without.role::<AcousticFix>(),
    );
    for dialect in [Dialect::Ros1, Dialect::Ros2] {
        // GeoPointStamped: on any topic; the point only.
        let log = ros_log(dialect, "/acoustic_fix", &with, |f| (f.stamp_ns, f.clone()));
        assert_eq!(
            log.role::<AcousticFix>(),
            table_without,
            "{dialect:?} GeoPoint"
        );
        // NavSatFix on a USBL topic: the sigmas in the covariance.
        let log = ros_log(dialect, "/usbl/fix", &with, |f| {
            (f.stamp_ns, AcousticNavSatFix(f))
        });
        assert_eq!(
            log.role::<AcousticFix>(),
            table_with,
            "{dialect:?} NavSatFix"
        );
        assert!(log.role::<hindsight::contract::GnssFix>().is_empty());
        let log = ros_log(dialect, "/usbl/fix", &without, |f| {
            (f.stamp_ns, AcousticNavSatFix(f))
        });
        assert_eq!(
            log.role::<AcousticFix>(),
            table_without,
            "{dialect:?} NavSatFix"
        );
        // GeoPoseStamped not on the ship's topic: the point only.
        let log = ros_log(dialect, "/usbl/pose", &with, |f| {
            (f.stamp_ns, AcousticGeoPose(f))
        });
        assert_eq!(
            log.role::<AcousticFix>(),
            table_without,
            "{dialect:?} GeoPose"
        );
    }
}

#[test]
fn a_ship_pose_and_a_local_fix_in_ros_read_as_the_contract_messages() {
    let poses: Vec<ShipPose> = (0..72)
        .map(|i| ShipPose {
            stamp_ns: 1_700_000_000_000_000_000 + i * 1_000_000_000,
            latitude_deg: 35.1 + 1e-5 * i as f64,
            longitude_deg: 129.05 - 2e-5 * i as f64,
            roll: 0.05 * (0.3 * i as f64).sin(),
            pitch: 0.03 * (0.2 * i as f64).cos(),
            yaw: hindsight::angle::wrap_pi((5.0 * i as f64).to_radians()),
            horizontal_sigma_m: None,
            heading_sigma_rad: None,
        })
        .collect();
    let fixes: Vec<PositionFix> = (0..50)
        .map(|i| PositionFix {
            stamp_ns: 1_700_000_000_000_000_000 + i * 2_000_000_000,
            north_m: 12.5 * i as f64,
            east_m: -7.25 * i as f64,
            down_m: (i % 5 != 0).then_some(40.0 + 0.1 * i as f64),
            sigma_m: 0.5 + 0.01 * i as f64,
            label: "map".into(),
        })
        .collect();
    let expected_poses = contract_log(&poses);
    let expected_fixes = contract_log(&fixes);
    for dialect in [Dialect::Ros1, Dialect::Ros2] {
        let log = ros_log(dialect, "/ship/pose", &poses, |p| (p.stamp_ns, p.clone()));
        let (read, expected) = (log.role::<ShipPose>(), expected_poses.role::<ShipPose>());
        assert_eq!(read.len(), expected.len(), "{dialect:?}");
        for (r, e) in read.iter().zip(expected) {
            assert_eq!(
                (r.stamp_ns, r.latitude_deg, r.longitude_deg),
                (e.stamp_ns, e.latitude_deg, e.longitude_deg)
            );
            // Through a quaternion: equal to rounding.
            for (a, b) in [(r.roll, e.roll), (r.pitch, e.pitch), (r.yaw, e.yaw)] {
                assert!(
                    hindsight::angle::wrap_pi(a - b).abs() < 1e-12,
                    "{r:?} {e:?}"
                );
            }
        }
        let log = ros_log(dialect, "/usbl/local", &fixes, |f| {
            (f.stamp_ns, PositionFixPose(f))
        });
        // The label is the frame's name: `map` in REP-103.
        assert_eq!(
            log.role::<PositionFix>(),
            expected_fixes.role::<PositionFix>(),
            "{dialect:?}"
        );
    }
}
