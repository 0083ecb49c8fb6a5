//! ROS 2 recordings: topics in `cdr` with the standard types, read through the
//! schema text the file carries, converted to the contract's frames and units.

use crate::common;
use hindsight::contract::{Depth, Dvl, Imu};
use hindsight::ingest::{read_log_from, IngestError, IngestOptions};
use hindsight::sim::writer::{to_bytes, WriterOptions};

const HEADER: &str = "\
================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
";

const VECTOR3: &str = "\
================================================================================
MSG: geometry_msgs/Vector3
float64 x
float64 y
float64 z
";

fn imu_schema() -> String {
    format!(
        "std_msgs/Header header\ngeometry_msgs/Quaternion orientation\n\
         float64[9] orientation_covariance\ngeometry_msgs/Vector3 angular_velocity\n\
         float64[9] angular_velocity_covariance\ngeometry_msgs/Vector3 linear_acceleration\n\
         float64[9] linear_acceleration_covariance\n{HEADER}\
         ================================================================================\n\
         MSG: geometry_msgs/Quaternion\nfloat64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n{VECTOR3}"
    )
}

use hindsight::ingest::ros::wire::WireWriter as Cdr;

fn imu_cdr(stamp_ns: i64, frame: &str, w: [f64; 3], a: [f64; 3]) -> Vec<u8> {
    let mut c = Cdr::new();
    c.header(stamp_ns, frame)
        .f64s(&[0.0, 0.0, 0.0, 1.0])
        .f64s(&[0.0; 9]);
    c.f64s(&w).f64s(&[0.0; 9]).f64s(&a).f64s(&[0.0; 9]);
    c.into_bytes()
}

const T0: i64 = 1_700_000_000_000_000_000;

/// A log with ROS 2 topics beside json ones.
fn mixed_log(imu_frame: &str) -> Vec<u8> {
    to_bytes(WriterOptions::default(), |w| {
        let schema = imu_schema();
        for k in 0..50i64 {
            let t = T0 + k * 10_000_000;
            let data = imu_cdr(t, imu_frame, [0.01 * k as f64, 0.02, -0.03], [0.1, -0.2, 9.8]);
            w.write_raw("/imu", "sensor_msgs/msg/Imu", &schema, "cdr", &data, t as u64)?;
            let depth = Depth {
                stamp_ns: t,
                depth: 10.0 + k as f64,
            };
            w.write("/depth", &depth, t as u64)?;
        }
        let twist_schema = format!(
            "std_msgs/Header header\ngeometry_msgs/TwistWithCovariance twist\n{HEADER}\
             ================================================================================\n\
             MSG: geometry_msgs/TwistWithCovariance\ngeometry_msgs/Twist twist\nfloat64[36] covariance\n\
             ================================================================================\n\
             MSG: geometry_msgs/Twist\nVector3 linear\nVector3 angular\n{VECTOR3}"
        );
        for (k, cov0) in [(0i64, 1e-4), (1, -1.0)] {
            let t = T0 + k * 1_000_000_000;
            let mut c = Cdr::new();
            c.header(t, "dvl_frd").f64s(&[1.5, 0.1, -0.05, 0.0, 0.0, 0.0]);
            let mut cov = [0.0; 36];
            cov[0] = cov0;
            c.f64s(&cov);
            w.write_raw(
                "/dvl",
                "geometry_msgs/msg/TwistWithCovarianceStamped",
                &twist_schema,
                "cdr",
                c.bytes(),
                t as u64,
            )?;
        }
        Ok(())
    })
    .unwrap()
}

#[test]
fn cdr_topics_read_beside_json_in_the_contract_frames() {
    let log = read_log_from(&mixed_log("base_link")[..], &IngestOptions::default()).unwrap();
    let imu: &[Imu] = log.messages("/imu").unwrap();
    assert_eq!(imu.len(), 50);
    assert_eq!(imu[7].stamp_ns, T0 + 70_000_000);
    // base_link is REP-103 (FLU): y and z change sign.
    assert_eq!(imu[7].angular_velocity, [0.07, -0.02, 0.03]);
    assert_eq!(imu[7].specific_force, [0.1, 0.2, -9.8]);
    let depth: &[Depth] = log.messages("/depth").unwrap();
    assert_eq!(depth.len(), 50);
    let dvl: &[Dvl] = log.messages("/dvl").unwrap();
    assert_eq!(dvl.len(), 2);
    assert_eq!(dvl[0].velocity, [1.5, 0.1, -0.05]); // dvl_frd: kept
    assert!(
        dvl[0].valid && !dvl[1].valid,
        "covariance[0] = -1: no bottom lock"
    );

    let log = read_log_from(&mixed_log("imu_frd")[..], &IngestOptions::default()).unwrap();
    let imu: &[Imu] = log.messages("/imu").unwrap();
    assert_eq!(imu[7].specific_force, [0.1, -0.2, 9.8]);
}

#[test]
fn a_schema_that_does_not_parse_is_refused_naming_the_topic() {
    let bytes = to_bytes(WriterOptions::default(), |w| {
        let data = imu_cdr(T0, "base_link", [0.0; 3], [0.0; 3]);
        w.write_raw(
            "/vehicle/imu",
            "sensor_msgs/msg/Imu",
            "float64[x] broken\n",
            "cdr",
            &data,
            T0 as u64,
        )
    })
    .unwrap();
    let e = read_log_from(&bytes[..], &IngestOptions::default()).unwrap_err();
    assert!(matches!(e, IngestError::Ros2Schema { .. }), "{e}");
    let text = e.to_string();
    assert!(
        text.contains("/vehicle/imu")
            && text.contains("line 1")
            && text.contains("log time 2023-11-14T22:13:20.000Z")
            && !text.contains('\n'),
        "{text}"
    );
}

/// A ROS 2 recording's other topics (tf, diagnostics) are skipped with a warning; the same
/// topic named for a role is refused, naming it and the time of its first message.
#[test]
fn other_cdr_topics_are_skipped_unless_a_role_needs_them() {
    let bytes = to_bytes(WriterOptions::default(), |w| {
        let tf = "geometry_msgs/TransformStamped[] transforms\n";
        for k in 0..3u64 {
            let t = T0 as u64 + k * 10_000_000;
            w.write_raw(
                "/tf",
                "tf2_msgs/msg/TFMessage",
                tf,
                "cdr",
                &[0, 1, 0, 0, 0, 0, 0, 0],
                t,
            )?;
            let data = imu_cdr(t as i64, "base_link", [0.0; 3], [0.0, 0.0, 9.8]);
            w.write_raw(
                "/imu",
                "sensor_msgs/msg/Imu",
                &imu_schema(),
                "cdr",
                &data,
                t,
            )?;
        }
        Ok(())
    })
    .unwrap();
    let log = read_log_from(&bytes[..], &IngestOptions::default()).unwrap();
    assert_eq!(log.messages::<Imu>("/imu").unwrap().len(), 3);
    assert_eq!(log.skipped.len(), 1);
    assert!(
        log.warnings().iter().any(|w| w.starts_with(
            "skipped 1 topic of types hindsight does not read (3 \
                 messages): /tf (`tf2_msgs/msg/TFMessage` in cdr, 3)"
        )),
        "{:?}",
        log.warnings()
    );
    let options = IngestOptions {
        topics: [("imu".to_string(), "/tf".to_string())].into(),
        ..IngestOptions::default()
    };
    let e = read_log_from(&bytes[..], &options).unwrap_err();
    let text = e.to_string();
    assert!(matches!(e, IngestError::UnknownSchema { .. }), "{e}");
    assert!(
        text.contains("topic /tf at log time 2023-11-14T22:13:20.000Z")
            && text.contains("tf2_msgs/msg/TFMessage"),
        "{text}"
    );
}

#[test]
fn short_and_flipped_cdr_messages_are_counted_never_a_panic() {
    let bytes = to_bytes(WriterOptions::default(), |w| {
        let schema = imu_schema();
        let data = imu_cdr(T0, "base_link", [0.1; 3], [0.0, 0.0, 9.8]);
        w.write_raw("/imu", "sensor_msgs/msg/Imu", &schema, "cdr", &data, 0)?;
        w.write_raw(
            "/imu",
            "sensor_msgs/msg/Imu",
            &schema,
            "cdr",
            &data[..100],
            1,
        )
    })
    .unwrap();
    let options = IngestOptions {
        max_invalid_fraction: 1.0,
        ..IngestOptions::default()
    };
    let log = read_log_from(&bytes[..], &options).unwrap();
    let s = log.stream("/imu").unwrap();
    assert_eq!((s.counts.received, s.counts.invalid), (2, 1));
    assert!(
        s.issues[0].to_string().contains("shorter than its layout"),
        "{}",
        s.issues[0]
    );
    // Every single-byte corruption of an uncompressed copy reads or fails cleanly.
    let plain = to_bytes(
        WriterOptions {
            compression: hindsight::sim::writer::Compression::None,
            ..WriterOptions::default()
        },
        |w| {
            let data = imu_cdr(T0, "base_link", [0.1; 3], [0.0, 0.0, 9.8]);
            w.write_raw(
                "/imu",
                "sensor_msgs/msg/Imu",
                &imu_schema(),
                "cdr",
                &data,
                0,
            )
        },
    )
    .unwrap();
    for i in 0..plain.len() {
        let mut b = plain.clone();
        b[i] ^= 0x5a;
        let _ = read_log_from(&b[..], &options);
    }
}

/// rosbag2's own test recordings (`tests/fixtures/rosbag2/`, Apache-2.0): every message of
/// every cdr topic walks its whole layout, compiled from the schema text in the file
/// (test_msgs' BasicTypes and Arrays: every primitive, bounded and unbounded arrays and
/// strings; std_msgs/String), ending within the message; and `info` reads each file
/// (service events too).
#[test]
fn rosbag2_recordings_fit_their_schemas_and_read_in_info() {
    use hindsight::ingest::ros::{cdr::Plan, msg::parse};
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/rosbag2");
    let mut files = 0;
    let mut checked = std::collections::BTreeMap::<String, usize>::new();
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_none_or(|e| e != "mcap") {
            continue;
        }
        files += 1;
        let bytes = std::fs::read(&path).unwrap();
        for message in mcap::MessageStream::new(&bytes).unwrap() {
            let message = message.unwrap();
            let channel = &message.channel;
            if channel.message_encoding != "cdr" {
                continue;
            }
            let schema = channel.schema.as_ref().expect("a cdr channel has a schema");
            if schema.name.contains("/srv/") {
                // A service event's schema is the .srv text (request --- response), not the
                // event's layout: nothing hindsight reads; `info` below still reads the file.
                *checked
                    .entry("(service events, skipped)".into())
                    .or_default() += 1;
                continue;
            }
            let text = String::from_utf8_lossy(&schema.data);
            let defs = parse(&schema.name, &text)
                .unwrap_or_else(|e| panic!("{}: {}: {e}", path.display(), schema.name));
            let plan = Plan::new(&defs, &[], &[]).unwrap();
            let used = plan.check(&message.data).unwrap_or_else(|e| {
                panic!(
                    "{}: {}: {e}: {:02x?}",
                    path.display(),
                    schema.name,
                    &message.data[..]
                )
            });
            // What is left is at most the alignment padding some writers add.
            assert!(
                message.data.len() - used < 8,
                "{}: {} of {} bytes",
                schema.name,
                used,
                message.data.len()
            );
            *checked.entry(schema.name.clone()).or_default() += 1;
        }
        let o = common::hindsight(&["info", path.to_str().unwrap()]);
        assert!(
            o.status.success(),
            "{}: {}",
            path.display(),
            common::stderr(&o)
        );
    }
    println!("{files} files; messages checked per type: {checked:?}");
    assert_eq!(files, 4);
    for ty in [
        "test_msgs/msg/BasicTypes",
        "test_msgs/msg/Arrays",
        "std_msgs/msg/String",
    ] {
        assert!(checked.get(ty).is_some_and(|&n| n > 0), "{ty}: {checked:?}");
    }
}

/// A log with the same IMU messages (cdr) on each of `topics`, and json depth.
fn imu_on_topics(topics: &[&str]) -> Vec<u8> {
    to_bytes(WriterOptions::default(), |w| {
        let schema = imu_schema();
        for k in 0..20i64 {
            let t = T0 + k * 10_000_000;
            let data = imu_cdr(t, "base_link", [0.0, 0.0, 0.01], [0.0, 0.0, 9.8]);
            for topic in topics {
                w.write_raw(
                    topic,
                    "sensor_msgs/msg/Imu",
                    &schema,
                    "cdr",
                    &data,
                    t as u64,
                )?;
            }
            w.write(
                "/depth",
                &Depth {
                    stamp_ns: t,
                    depth: 5.0,
                },
                t as u64,
            )?;
        }
        Ok(())
    })
    .unwrap()
}

fn read_naming(
    bytes: &[u8],
    named: &[(&str, &str)],
) -> Result<hindsight::ingest::Log, IngestError> {
    let options = IngestOptions {
        topics: named
            .iter()
            .map(|(r, t)| (r.to_string(), t.to_string()))
            .collect(),
        ..IngestOptions::default()
    };
    read_log_from(bytes, &options)
}

#[test]
fn a_role_takes_its_default_topic_then_the_one_topic_of_its_type() {
    use hindsight::contract::Streams;
    use hindsight::ingest::RoleSource;
    let log = read_naming(&imu_on_topics(&["/vehicle/imu/data"]), &[]).unwrap();
    assert_eq!(log.role_topic::<Imu>(), Some("/vehicle/imu/data"));
    assert_eq!(Streams::of(&log).imu.len(), 20);
    assert_eq!(Streams::of(&log).depth.len(), 20);
    let imu_role = log.roles.iter().find(|c| c.role == "imu").unwrap();
    assert_eq!(imu_role.source, RoleSource::ByType);

    // The default topic wins over another of the type.
    let log = read_naming(&imu_on_topics(&["/imu_aux", "/imu"]), &[]).unwrap();
    assert_eq!(log.role_topic::<Imu>(), Some("/imu"));
    // Named, another topic wins over the default.
    let log = read_naming(
        &imu_on_topics(&["/imu_aux", "/imu"]),
        &[("imu", "/imu_aux")],
    )
    .unwrap();
    assert_eq!(log.role_topic::<Imu>(), Some("/imu_aux"));
    assert_eq!(Streams::of(&log).imu.len(), 20);
}

#[test]
fn an_ambiguous_or_misnamed_role_is_refused_naming_the_candidates() {
    let two = imu_on_topics(&["/port/imu", "/stbd/imu"]);
    let e = read_naming(&two, &[]).unwrap_err();
    let text = e.to_string();
    assert!(matches!(e, IngestError::Role(_)), "{e:?}");
    assert!(
        text.contains("ambiguous") && text.contains("/port/imu") && text.contains("/stbd/imu"),
        "{text}"
    );
    let log = read_naming(&two, &[("imu", "/stbd/imu")]).unwrap();
    assert_eq!(log.role_topic::<Imu>(), Some("/stbd/imu"));

    let text = read_naming(&two, &[("imu", "/imu")])
        .unwrap_err()
        .to_string();
    assert!(
        text.contains("no topic /imu") && text.contains("/port/imu"),
        "{text}"
    );
    let text = read_naming(&two, &[("imu", "/depth")])
        .unwrap_err()
        .to_string();
    assert!(text.contains("/depth holds `hindsight.Depth`"), "{text}");
    let text = read_naming(&two, &[("gyro", "/port/imu")])
        .unwrap_err()
        .to_string();
    assert!(text.contains("unknown topic role `gyro`"), "{text}");

    // Not strict (what info uses): read, the problem kept as a warning.
    let options = IngestOptions {
        strict_roles: false,
        ..IngestOptions::default()
    };
    let log = read_log_from(&two[..], &options).unwrap();
    assert_eq!(log.role_topic::<Imu>(), None);
    assert!(log.warnings().iter().any(|w| w.contains("ambiguous")));
}

/// `info` walks the messages of cdr types hindsight does not map through their schema's
/// layout: a message shorter than its layout is counted with its topic and log time.
#[test]
fn unmapped_cdr_topics_are_checked_against_their_layout() {
    use hindsight::ingest::LayoutCheck;
    let bytes = to_bytes(WriterOptions::default(), |w| {
        let schema = "float64[] values\nstring note\n";
        let mut fits = Cdr::new();
        fits.u32(2).f64s(&[1.0, 2.0]).string("ok");
        let mut short = Cdr::new();
        short.u32(5).f64(1.0);
        for (k, data) in [fits.bytes(), short.bytes(), fits.bytes()]
            .into_iter()
            .enumerate()
        {
            let t = T0 as u64 + k as u64 * 1_000_000_000;
            w.write_raw("/samples", "acme_msgs/msg/Samples", schema, "cdr", data, t)?;
        }
        Ok(())
    })
    .unwrap();
    let options = IngestOptions {
        check_layouts: true,
        skip_unknown: true,
        ..IngestOptions::default()
    };
    let log = read_log_from(&bytes[..], &options).unwrap();
    let Some(LayoutCheck::Checked {
        misfits,
        first: Some(issue),
    }) = &log.skipped[0].layout
    else {
        panic!("{:?}", log.skipped);
    };
    assert_eq!(*misfits, 1);
    assert_eq!(issue.log_time_ns, T0 as u64 + 1_000_000_000);
    assert!(
        issue.to_string().contains("shorter than its layout"),
        "{issue}"
    );
    // Without the check (the commands that reconstruct), the topic is only counted.
    let log = read_log_from(&bytes[..], &IngestOptions::default()).unwrap();
    assert_eq!(log.skipped[0].layout, None);
    assert_eq!(log.skipped[0].messages, 3);
}
