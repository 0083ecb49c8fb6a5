//! The acoustic ROS types (issue 58): each, written by hindsight's ROS writer in ROS 1 and in
//! ROS 2, reads as the contract's messages carrying what the type carries. The fixes are the
//! `usbl-survey` simulation's; the ship's poses turn through every heading; the EvoLogics
//! observations are `usbl-raw-survey`'s.

use crate::common;
use hindsight::contract::{AcousticFix, Message, PositionFix, ShipPose, UsblObservation};
use hindsight::ingest::ros::map::Convention;
use hindsight::ingest::ros::msg::Dialect;
use hindsight::ingest::Log;
use hindsight::sim::ros::{
    message_encoding, AcousticGeoPose, AcousticNavSatFix, PositionFixPose, ToRos,
    UsblLongWithoutCurrentTime,
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

/// The simulation's observations (`usbl-raw-survey` seed 1) as an EvoLogics driver gives them: its
/// `current_time` and `measurement_time` the simulator's delay apart (`with_times`; else
/// stamped on receipt only), the vehicle's transponder at address 2, no sigmas; those at
/// zero range (the simulator's first, at the ship) have no direction to write and are left
/// out.
fn driver_observations(sim: &common::Simulated, with_times: bool) -> Vec<UsblObservation> {
    let delay_s = sim.usbl_truth().receipt_delay_s;
    (sim.role::<UsblObservation>().iter())
        .filter(|o| o.range_m > 0.0)
        .map(|o| as_driver_gives(o, with_times.then_some(delay_s)))
        .collect()
}

/// `usbl-raw-survey` seed 1.
fn raw_survey() -> common::Simulated {
    common::simulated(&Scenario::built_in("usbl-raw-survey").unwrap(), 1)
}

/// A receipt-stamped observation as a driver gives it, with the delay when it knows it.
fn as_driver_gives(o: &UsblObservation, delay_s: Option<f64>) -> UsblObservation {
    assert!(!o.stamp_is_validity && o.received_after_s.is_none());
    let delay_ns = delay_s.map_or(0, |s| (s * 1e9).round() as i64);
    UsblObservation {
        stamp_ns: o.stamp_ns - delay_ns,
        stamp_is_validity: delay_s.is_some(),
        received_after_s: delay_s,
        range_sigma_m: None,
        bearing_sigma_rad: None,
        elevation_sigma_rad: None,
        beacon_id: "2".into(),
        ..o.clone()
    }
}

/// Equal but for the `float32`s of the message: the target's position to 0.1 mm per km, the
/// device's times to a quarter of a millisecond.
fn assert_close(read: &[UsblObservation], expected: &[UsblObservation], what: &str) {
    assert_eq!(read.len(), expected.len(), "{what}");
    for (r, e) in read.iter().zip(expected) {
        let close = (r.stamp_ns - e.stamp_ns).abs() <= 1_000_000
            && r.stamp_is_validity == e.stamp_is_validity
            && match (r.received_after_s, e.received_after_s) {
                (Some(a), Some(b)) => (a - b).abs() <= 1e-3,
                (a, b) => a == b,
            }
            && (r.range_m - e.range_m).abs() <= 1e-7 * e.range_m.max(1000.0)
            && (r.bearing_rad - e.bearing_rad).abs() <= 1e-6
            && (r.elevation_rad - e.elevation_rad).abs() <= 1e-6
            && (r.range_sigma_m, r.bearing_sigma_rad, r.elevation_sigma_rad) == (None, None, None)
            && match (r.sound_speed_m_s, e.sound_speed_m_s) {
                (Some(a), Some(b)) => (a - b).abs() <= 1e-3,
                (a, b) => a == b,
            }
            && r.beacon_id == e.beacon_id;
        assert!(close, "{what}: read {r:?}, expected {e:?}");
    }
}

/// EvoLogics' `USBLLONG` (issue 58's vendor message with both times): its two device times
/// place each observation at its time of validity, the delay kept; the older message
/// without `current_time` is read as stamped on receipt; the target's position becomes the
/// range, bearing and elevation in the transducer's axes.
#[test]
fn evologics_usbllong_reads_as_the_contract_observations() {
    let sim = raw_survey();
    let (timed, receipt) = (
        driver_observations(&sim, true),
        driver_observations(&sim, false),
    );
    assert!(timed.len() > 400, "{}", timed.len());
    let expected_timed = contract_log(&timed);
    let expected_receipt = contract_log(&receipt);
    let received_ns =
        |o: &UsblObservation| o.stamp_ns + o.received_after_s.map_or(0, |s| (s * 1e9) as i64);
    for dialect in [Dialect::Ros1, Dialect::Ros2] {
        let log = ros_log(dialect, "/evologics/usbllong", &timed, |o| {
            (received_ns(o), o.clone())
        });
        assert!(log.warnings().is_empty(), "{:?}", log.warnings());
        assert_close(
            log.role::<UsblObservation>(),
            expected_timed.role::<UsblObservation>(),
            &format!("{dialect:?} USBLLONG"),
        );
        let log = ros_log(dialect, "/evologics/usbllong", &receipt, |o| {
            (o.stamp_ns, UsblLongWithoutCurrentTime(o))
        });
        assert_close(
            log.role::<UsblObservation>(),
            expected_receipt.role::<UsblObservation>(),
            &format!("{dialect:?} USBLLONG without current_time"),
        );
    }
}

/// A survey whose USBL comes as `USBLLONG` (ROS 2, in the same file as the contract's other
/// topics), default run: the observations are placed by their own two times, so no delay is
/// estimated; every outlier is refused and no good observation; the track keeps the raw
/// survey's bars (smoothed RMS at most half the median positioned sigma, forward NEES inside
/// its bounds at least 90 % of the time).
#[test]
fn a_usbllong_survey_is_placed_by_its_two_times() {
    let sim = raw_survey();
    let written = driver_observations(&sim, false);
    let truth = sim.usbl_truth();
    let delay_s = truth.receipt_delay_s;
    let ros = sim.with_rewritten("/usbl", |o: &UsblObservation, raw| {
        if o.range_m <= 0.0 {
            return None;
        }
        let o = as_driver_gives(o, Some(delay_s));
        Some(common::RawMessage {
            schema_name: UsblObservation::type_name(Dialect::Ros2),
            schema_text: UsblObservation::definition_in(Dialect::Ros2),
            encoding: message_encoding(Dialect::Ros2).into(),
            data: o.encode(Dialect::Ros2, Convention::Native, &Default::default()),
            ..raw
        })
    });
    let read = ros.role::<UsblObservation>();
    assert_eq!(read.len(), written.len());
    assert!(read.iter().all(|o| o.stamp_is_validity));
    let r = ros.reconstruct(&hindsight::recon::config::Config::default());
    let delay = (r.summary.plan.decisions.iter())
        .find(|d| d.part == hindsight::recon::plan::Part::AcousticFixDelay);
    assert!(
        delay.is_some_and(|d| d.why == hindsight::recon::plan::Why::CarriedByFixes),
        "the delay carried by the observations: {delay:?}"
    );
    let delay_ns = (delay_s * 1e9).round() as i64;
    // The stamps of validity come through the device's float32 times: to a millisecond.
    let is_outlier = |stamp_ns: i64| {
        let receipt_ns = stamp_ns + delay_ns;
        (truth
            .outlier_receipts_ns
            .range(receipt_ns - 1_000_000..=receipt_ns + 1_000_000))
        .next()
        .is_some()
    };
    let median_sigma_m = common::median_positioned_sigma_m(&sim);
    let sensor = hindsight::filters::ins::aid_table::Sensor::Usbl;
    let run = common::AcousticRun::of((&ros, 1), &r, sensor, median_sigma_m, is_outlier);
    eprintln!("USBLLONG: {run:?}");
    run.assert_placed();
    assert!(run.forward_nees_inside >= 0.9, "{run:?}");
    assert_eq!(run.refusals.outliers_refused, run.refusals.outliers);
    run.refusals.assert_outliers_cannot_move_the_track();
}
