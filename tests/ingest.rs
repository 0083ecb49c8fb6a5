//! Ingest on logs built in memory with the project's own writer.

use crate::common;
use hindsight::align::merged;
use hindsight::contract::*;
use hindsight::ingest::{read_log_from, Ending, IngestOptions, Log};
use hindsight::sim::writer::{to_bytes, Compression, WriterOptions};

/// Writes every message of type `T` from `source` into a new log, reads it back, and checks
/// that each message and its log time come back unchanged.
fn round_trip<T: Message>(source: &Log) {
    let written: Vec<T> = source.messages::<T>(T::DEFAULT_TOPIC).unwrap().to_vec();
    assert!(!written.is_empty(), "{}", T::SCHEMA_NAME);
    let bytes = to_bytes(WriterOptions::default(), |w| {
        for (i, m) in written.iter().enumerate() {
            w.write(T::DEFAULT_TOPIC, m, m.stamp_ns() as u64 + i as u64)?;
        }
        Ok(())
    })
    .unwrap();
    let log = common::read(&bytes);
    let stream = log.stream(T::DEFAULT_TOPIC).unwrap();
    assert_eq!(stream.schema_name, T::SCHEMA_NAME);
    assert_eq!(
        stream.messages::<T>().unwrap(),
        &written[..],
        "{}",
        T::SCHEMA_NAME
    );
    for (i, m) in written.iter().enumerate() {
        assert_eq!(stream.log_time_ns[i], m.stamp_ns() as u64 + i as u64);
    }
}

#[test]
fn every_schema_round_trips() {
    let source = common::read(&common::survey_bytes(WriterOptions::default(), 3.0));
    macro_rules! round_trip_all {
        ($($t:ident),*) => { $( round_trip::<$t>(&source); )* };
    }
    hindsight::for_each_message!(round_trip_all);
    assert_eq!(source.streams.len(), all_kinds().len());
}

#[test]
fn all_container_layouts_read_the_same() {
    let reference = common::read(&common::survey_bytes(WriterOptions::default(), 20.0));
    assert_eq!(reference.file.ending, Ending::Complete);
    assert!(reference.file.has_summary);
    let layouts = [
        (true, Compression::None, true),
        (true, Compression::Lz4, true),
        (true, Compression::Zstd, false),
        (true, Compression::Lz4, false),
        (false, Compression::None, true),
        (false, Compression::None, false),
    ];
    for (chunked, compression, summary) in layouts {
        let options = WriterOptions {
            chunked,
            compression,
            summary,
            chunk_size: 64 * 1024,
        };
        let log = common::read(&common::survey_bytes(options, 20.0));
        assert_eq!(log.file.ending, Ending::Complete, "{options:?}");
        assert_eq!(log.file.has_summary, summary, "{options:?}");
        common::assert_same_content(&reference, &log);
    }
}

/// Messages in a file cut at `cut`, counted by walking the raw framing (opcode u8, length u64
/// LE, body) independently of hindsight's reader: every message record that ends before the
/// cut, at the top level or inside an uncompressed chunk.
fn messages_before(bytes: &[u8], cut: usize) -> (u64, u64) {
    let (mut whole, mut partial) = (0u64, 0u64);
    let mut pos = 8usize;
    while pos + 9 <= bytes.len() {
        let op = bytes[pos];
        let len = u64::from_le_bytes(bytes[pos + 1..pos + 9].try_into().unwrap()) as usize;
        let end = pos + 9 + len;
        match op {
            0x05 if end <= cut => whole += 1,
            0x06 => {
                let name_len =
                    u32::from_le_bytes(bytes[pos + 37..pos + 41].try_into().unwrap()) as usize;
                assert_eq!(name_len, 0, "test expects uncompressed chunks");
                let mut inner = pos + 9 + 32 + 8;
                while inner + 9 <= end {
                    let ilen = u64::from_le_bytes(bytes[inner + 1..inner + 9].try_into().unwrap())
                        as usize;
                    let iend = inner + 9 + ilen;
                    if bytes[inner] == 0x05 && iend <= cut {
                        if end <= cut {
                            whole += 1;
                        } else {
                            partial += 1;
                        }
                    }
                    inner = iend;
                }
            }
            0x02 => break,
            _ => {}
        }
        pos = end;
    }
    (whole, partial)
}

#[test]
fn truncated_file_recovers_every_whole_record() {
    for chunked in [false, true] {
        let options = WriterOptions {
            chunked,
            compression: Compression::None,
            chunk_size: 16 * 1024,
            ..WriterOptions::default()
        };
        let full = common::survey_bytes(options, 10.0);
        let complete = common::read(&full);
        let total = complete.message_count();
        let mut partial_seen = 0;
        for k in 1..60 {
            let cut = full.len() * k / 61;
            let log = read_log_from(&full[..cut], &IngestOptions::default())
                .unwrap_or_else(|e| panic!("cut at {cut}: {e}"));
            let (whole, partial) = messages_before(&full, cut);
            let got: u64 = log.streams.iter().map(|s| s.counts.received).sum();
            assert_eq!(
                got,
                whole + partial,
                "chunked {chunked}, cut at {cut} of {}",
                full.len()
            );
            match log.file.ending {
                Ending::Truncated {
                    partial_chunk_messages,
                    whole_records_end,
                } => {
                    assert_eq!(partial_chunk_messages, partial, "cut at {cut}");
                    assert!(whole_records_end as usize <= cut);
                }
                Ending::Complete => panic!("cut at {cut} read as complete"),
            }
            partial_seen += partial;
            assert!(log.warnings()[0].contains(&format!("recovered {got} messages")));
            assert!(got <= total);
        }
        assert_eq!(
            partial_seen > 0,
            chunked,
            "cuts inside chunks recover their first records"
        );
    }
}

#[test]
fn truncated_compressed_chunk_recovers_a_true_prefix() {
    // Compressors emit data in blocks (zstd: up to 128 KiB), so only chunks larger than a
    // block can give back part of their content: use the writer's default 1 MiB chunks.
    for compression in [Compression::Zstd, Compression::Lz4] {
        let options = WriterOptions {
            compression,
            ..WriterOptions::default()
        };
        let full = common::survey_bytes(options, 60.0);
        let complete = common::read(&full);
        let mut partial_total = 0;
        for k in 1..30 {
            let cut = full.len() * k / 31;
            let log = read_log_from(&full[..cut], &IngestOptions::default()).unwrap();
            if let Ending::Truncated {
                partial_chunk_messages,
                ..
            } = log.file.ending
            {
                partial_total += partial_chunk_messages;
            }
            // What was recovered is exactly the start of every stream of the whole log.
            for s in &log.streams {
                let c = complete.stream(&s.topic).unwrap();
                for i in 0..s.samples.len() {
                    assert_eq!(s.samples.stamp_ns(i), c.samples.stamp_ns(i));
                    for p in 0..s.samples.properties().len() {
                        assert_eq!(s.samples.get(i, p), c.samples.get(i, p));
                    }
                }
            }
        }
        assert!(
            partial_total > 0,
            "{compression:?}: messages recovered from cut-off chunks"
        );
    }
}

fn imu(stamp_ms: i64, tag: f64) -> Imu {
    Imu {
        stamp_ns: 1_700_000_000_000_000_000 + stamp_ms * 1_000_000,
        angular_velocity: [tag, 0.0, 0.0],
        specific_force: [0.0, 0.0, -9.81],
    }
}

#[test]
fn counts_out_of_order_duplicates_and_gaps() {
    // File order of stamps (ms): 15 is late (out of order), the second 20 repeats a stamp,
    // 100 follows a 60 ms hole (over 3x the 10 ms median), 5 is late again.
    let stamps_ms = [0, 10, 20, 15, 20, 30, 40, 100, 110, 5];
    let bytes = to_bytes(WriterOptions::default(), |w| {
        for (i, &s) in stamps_ms.iter().enumerate() {
            w.write("/imu", &imu(s, i as f64), i as u64)?;
        }
        Ok(())
    })
    .unwrap();
    let log = common::read(&bytes);
    let s = log.stream("/imu").unwrap();
    assert_eq!(s.counts.received, 10);
    assert_eq!(
        s.counts.out_of_order, 2,
        "15 and 5 arrive after later stamps"
    );
    assert_eq!(s.counts.duplicates, 1);
    assert_eq!(s.counts.invalid, 0);
    let kept: Vec<i64> = (0..s.samples.len())
        .map(|i| (s.samples.stamp_ns(i) - imu(0, 0.0).stamp_ns) / 1_000_000)
        .collect();
    assert_eq!(kept, vec![0, 5, 10, 15, 20, 30, 40, 100, 110]);
    // The first message stamped 20 (tag 2) is kept, the repeat (tag 4) dropped.
    let msgs = s.messages::<Imu>().unwrap();
    assert_eq!(msgs[4].angular_velocity[0], 2.0);
    assert_eq!(
        s.log_time_ns[1], 9,
        "log times follow their messages through the sort"
    );
    assert_eq!(s.timing.gaps.len(), 1);
    assert_eq!(s.timing.gaps[0].duration_ns, 60_000_000);
    // Intervals 5, 5, 5, 5, 10, 10, 60, 10 ms: median 7.5 ms.
    assert!((s.timing.median_period_s.unwrap() - 0.0075).abs() < 1e-12);
}

#[test]
fn merged_stream_is_time_ordered_and_stable() {
    let t0 = 1_700_000_000_000_000_000i64;
    let bytes = to_bytes(WriterOptions::default(), |w| {
        // Three topics with coinciding stamps, written in scrambled file order.
        for k in (0..50).rev() {
            let t = t0 + k * 20_000_000;
            w.write(
                "/depth",
                &Depth {
                    stamp_ns: t,
                    depth: k as f64,
                },
                0,
            )?;
        }
        for k in 0..100 {
            w.write("/imu", &imu(k * 10, k as f64), 0)?;
            if k % 5 == 0 {
                let t = t0 + k * 10_000_000;
                w.write(
                    "/rpm",
                    &Propeller {
                        stamp_ns: t,
                        rpm: k as f64,
                    },
                    0,
                )?;
            }
        }
        Ok(())
    })
    .unwrap();
    let log = common::read(&bytes);
    let order: Vec<&str> = log.streams.iter().map(|s| s.topic.as_str()).collect();
    assert_eq!(order, vec!["/depth", "/imu", "/rpm"]);
    let events: Vec<_> = merged(&log.streams).collect();
    assert_eq!(events.len(), 50 + 100 + 20);
    for pair in events.windows(2) {
        let (a, b) = (pair[0], pair[1]);
        assert!(a.stamp_ns <= b.stamp_ns, "time order");
        if a.stamp_ns == b.stamp_ns {
            assert!(
                (a.stream, a.index) < (b.stream, b.index),
                "ties in stream order"
            );
        }
        let stamp = log.streams[b.stream].samples.stamp_ns(b.index);
        assert_eq!(stamp, b.stamp_ns);
    }
    // At t0 all three topics coincide: depth, imu, rpm in that order.
    let first3: Vec<usize> = events[..3].iter().map(|e| e.stream).collect();
    assert_eq!(first3, vec![0, 1, 2]);
}

#[test]
fn stats_only_reading_counts_the_same() {
    let bytes = common::survey_bytes(WriterOptions::default(), 20.0);
    let full = common::read(&bytes);
    let lean = read_log_from(
        &bytes[..],
        &IngestOptions {
            keep_messages: false,
            ..IngestOptions::default()
        },
    )
    .unwrap();
    assert_eq!(full.streams.len(), lean.streams.len());
    for (a, b) in full.streams.iter().zip(&lean.streams) {
        assert_eq!(a.counts, b.counts, "{}", a.topic);
        assert_eq!(a.timing, b.timing, "{}", a.topic);
        assert_eq!(a.counts.kept as usize, a.samples.len());
        assert!(b.samples.is_empty() && b.log_time_ns.is_empty());
    }
}

#[test]
fn clock_offset_moves_stamps_span_and_gaps_of_one_topic() {
    let t0 = 1_700_000_000_000_000_000i64;
    let bytes = to_bytes(WriterOptions::default(), |w| {
        for k in [0i64, 1, 2, 10, 11] {
            w.write(
                "/depth",
                &Depth {
                    stamp_ns: t0 + k * 1_000_000_000,
                    depth: 1.0,
                },
                0,
            )?;
            w.write(
                "/rpm",
                &Propeller {
                    stamp_ns: t0 + k * 1_000_000_000,
                    rpm: 1.0,
                },
                0,
            )?;
        }
        Ok(())
    })
    .unwrap();
    let mut log = common::read(&bytes);
    let offsets = ["/depth=-0.25".parse().unwrap()];
    hindsight::align::apply_offsets(&mut log, &offsets).unwrap();
    let depth = log.stream("/depth").unwrap();
    let rpm = log.stream("/rpm").unwrap();
    assert_eq!(depth.samples.stamp_ns(0), t0 - 250_000_000);
    assert_eq!(rpm.samples.stamp_ns(0), t0);
    assert_eq!(
        depth.timing.span_ns,
        Some((t0 - 250_000_000, t0 + 11_000_000_000 - 250_000_000))
    );
    assert_eq!(
        depth.timing.gaps[0].after_ns,
        t0 + 2_000_000_000 - 250_000_000
    );
    assert_eq!(rpm.timing.gaps[0].after_ns, t0 + 2_000_000_000);
    // The merged stream now puts the depth sample first.
    let first = merged(&log.streams).next().unwrap();
    assert_eq!(log.streams[first.stream].topic, "/depth");
}

/// What a person looks for in `info`: DVL readings without bottom lock, and a
/// stream that samples and holds (a stuck pressure sensor), counted whether the messages
/// are kept or not.
#[test]
fn unusable_readings_and_held_values_are_counted() {
    const T0: i64 = 1_700_000_000_000_000_000;
    let bytes = to_bytes(WriterOptions::default(), |w| {
        for k in 0..100i64 {
            let t = T0 + k * 100_000_000;
            let dvl = Dvl {
                stamp_ns: t,
                velocity: [1.5 + 1e-3 * k as f64, 0.0, 0.0],
                valid: !(30..45).contains(&k),
                altitude: Some(10.0),
            };
            w.write("/dvl", &dvl, t as u64)?;
            // The pressure sensor sticks at 12.5 m for messages 50..80.
            let depth = if (50..80).contains(&k) {
                12.5
            } else {
                10.0 + 0.01 * k as f64
            };
            w.write("/depth", &Depth { stamp_ns: t, depth }, t as u64)?;
        }
        Ok(())
    })
    .unwrap();
    for keep_messages in [true, false] {
        let options = IngestOptions {
            keep_messages,
            ..IngestOptions::default()
        };
        let log = read_log_from(&bytes[..], &options).unwrap();
        let dvl = &log.stream("/dvl").unwrap().counts;
        assert_eq!(dvl.flagged, 15);
        assert_eq!(dvl.held.repeats, 0, "the velocity changes");
        let depth = &log.stream("/depth").unwrap().counts;
        assert_eq!(depth.flagged, 0);
        assert_eq!(depth.held.repeats, 29, "30 messages, 29 repeats");
        assert_eq!(depth.held.from_ns, T0 + 50 * 100_000_000);
        assert!((depth.held.seconds() - 2.9).abs() < 1e-9);
        assert_eq!(
            log.stream("/depth").unwrap().samples.len(),
            if keep_messages { 100 } else { 0 }
        );
    }
    let dir = common::scratch_dir("info-held");
    let path = dir.join("held.mcap");
    std::fs::write(&path, &bytes).unwrap();
    let o = common::hindsight(&["info", path.to_str().unwrap()]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("unusable  /dvl: 15 of 100 readings")
            && text.contains("held  /depth: 30 messages in a row"),
        "{text}"
    );
}

/// Decoding on other threads (the default on a machine with more than one core) reads the
/// same log as decoding on the reading thread, counts, statistics and issues included, on a
/// survey long enough for many batches per topic, with late, repeated and invalid messages.
#[test]
fn decoding_on_other_threads_reads_the_same_log() {
    use hindsight::sim::synthetic::{write_survey, SurveySpec};
    let spec = SurveySpec {
        duration_s: 900.0,
        seed: 11,
        ..SurveySpec::default()
    };
    let bytes = to_bytes(WriterOptions::default(), |w| {
        write_survey(w, &spec)?;
        for (i, &s) in [5, 20, 20, 700_000].iter().enumerate() {
            w.write("/imu", &imu(s, i as f64), i as u64)?;
        }
        let mut wild = imu(30_000, 0.0);
        wild.angular_velocity[1] = 1e6; // beyond any gyro: invalid
        w.write("/imu", &wild, 30_000)
    })
    .unwrap();
    let read = |threads: usize, keep_messages: bool| {
        read_log_from(
            &bytes[..],
            &IngestOptions {
                decode_threads: threads,
                keep_messages,
                ..IngestOptions::default()
            },
        )
        .unwrap()
    };
    for keep_messages in [true, false] {
        let (one, many) = (read(1, keep_messages), read(4, keep_messages));
        common::assert_same_content(&one, &many);
        for (a, b) in one.streams.iter().zip(&many.streams) {
            assert_eq!(a.counts, b.counts, "{}", a.topic);
            assert_eq!(a.timing, b.timing, "{}", a.topic);
            assert_eq!(a.issues, b.issues, "{}", a.topic);
        }
        let imu_counts = &one.stream("/imu").unwrap().counts;
        assert_eq!(imu_counts.invalid, 1);
        assert!(imu_counts.out_of_order >= 3 && imu_counts.duplicates >= 1);
        let received: u64 = one.streams.iter().map(|s| s.counts.received).sum();
        assert!(received > 100_000, "many batches per topic");
    }
}
