//! `hindsight info LOG`: what is in a log, per topic.

use super::LogArgs;
use anyhow::Result;
use hindsight::ingest::{
    stats::GAP_FACTOR, Ending, IngestOptions, LayoutCheck, Log, RoleSource, Stream,
};
use hindsight::time::format_utc;

/// Show what a log holds: per topic its schema, rate, span, gaps and defects; the mission.
///
/// Columns: count = messages kept; rate = 1 / median interval; jitter = standard deviation of
/// the intervals that are not gaps; gaps = intervals over 3x the median; dup = repeated
/// stamps (dropped); ooo = messages stamped earlier than one already received (sorted into
/// place); invalid = failed decoding or validation (dropped; the first is shown). A ROS 2
/// topic of a type hindsight does not read is skipped, but its messages are walked through
/// the layout of the schema text in the file: invalid then counts those that do not fit.
/// Below the table: readings that say they are unusable (a DVL without bottom lock), and
/// the longest run of 10 or more messages repeating their predecessor's values in every
/// field (a sensor that samples and holds, or is stuck). Every
/// message is decoded and checked, streaming the file; info reports every defect and
/// skipped topic instead of stopping at the first.
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct InfoArgs {
    #[command(flatten)]
    pub log: LogArgs,

    /// List every gap with its time and length.
    #[arg(long)]
    pub gaps: bool,

    /// Also print the IMU's motion content per axis and band, as real-sensor figures give
    /// it: the gyro's first-difference scatter, its RMS in 1-50 Hz (vibration) and in
    /// 0.05-1 Hz (the sea, the vehicle's wobble), the accelerometer's RMS in 1-50 Hz. Set
    /// a simulated scenario's log beside a real one's (holds the log in memory).
    #[arg(long)]
    pub spectra: bool,
}

/// Repeats of one value that `info` reports as a held stream.
const HELD_REPEATS: u64 = 10;

pub fn run(args: InfoArgs) -> Result<()> {
    // info reports every defect instead of stopping at the first.
    let mut options = IngestOptions {
        skip_unknown: true,
        max_invalid_fraction: 1.0,
        keep_messages: false,
        strict_roles: false,
        check_layouts: true,
        ..IngestOptions::default()
    };
    options.keep_messages = args.spectra;
    args.log.source.apply(&mut options);
    let log = super::load(&args.log.log, &options, &args.log.offsets)?;
    print!(
        "{}",
        render(&log, &args.log.log.display().to_string(), args.gaps)
    );
    if args.spectra {
        print!("{}", render_spectra(&log));
    }
    Ok(())
}

/// The IMU's motion content per axis and band.
fn render_spectra(log: &Log) -> String {
    let streams = hindsight::recon::Streams::of(log);
    let Some(b) = hindsight::recon::tune::bands::imu_bands(streams.imu) else {
        return "spectra: fewer than 100 IMU samples\n".into();
    };
    let row = |what: &str, v: [f64; 3]| {
        vec![
            what.to_string(),
            format!("{:.4}", v[0]),
            format!("{:.4}", v[1]),
            format!("{:.4}", v[2]),
        ]
    };
    let rows = [
        row(
            "gyro first-difference std / sqrt(2), deg/s",
            b.gyro_difference_deg_s,
        ),
        row("gyro RMS in 1-50 Hz, deg/s", b.gyro_vibration_deg_s),
        row("gyro RMS in 0.05-1 Hz, deg/s", b.gyro_sea_deg_s),
        row(
            "accelerometer RMS in 1-50 Hz, m/s^2",
            b.accel_vibration_m_s2,
        ),
    ];
    format!(
        "\nIMU motion content ({:.1} Hz; bands at the mean rate of the samples as logged)\n{}",
        b.rate_hz,
        table(&["figure", "x (roll)", "y (pitch)", "z (yaw)"], &rows)
    )
}

fn render(log: &Log, name: &str, list_gaps: bool) -> String {
    let mut out = render_file(log, name);
    out.push_str(&render_topics(log));
    out.push_str(&render_notes(log, list_gaps));
    out
}

/// The file, its mission and other metadata.
fn render_file(log: &Log, name: &str) -> String {
    use std::fmt::Write;
    let mut out = String::new();
    let f = &log.file;
    let written = match (f.container, f.library.is_empty()) {
        (hindsight::ingest::Container::Mcap, true) => ", written by (unnamed library)".into(),
        (hindsight::ingest::Container::Mcap, false) => format!(", written by {}", f.library),
        (_, true) => String::new(),
        (_, false) => format!(" ({})", f.library),
    };
    let _ = writeln!(
        out,
        "{name}: {}{written}, {} bytes{}{}",
        f.container.name(),
        f.bytes_read,
        match (f.container, f.has_summary) {
            (hindsight::ingest::Container::Mcap, true) => ", with summary",
            (hindsight::ingest::Container::Mcap, false) => ", no summary",
            _ => "",
        },
        match f.ending {
            Ending::Complete => String::new(),
            Ending::Truncated { .. } => format!(
                ", CUT SHORT ({}; see the warning)",
                f.container.missing_end()
            ),
        }
    );
    match log.mission() {
        Ok(m) => {
            let _ = writeln!(
                out,
                "mission: origin {:.7} deg N, {:.7} deg E; vehicle {}; initial yaw {}\n  {}",
                m.origin_latitude_deg,
                m.origin_longitude_deg,
                m.vehicle,
                m.initial_yaw_rad
                    .map(|y| format!("{:.1} deg", y.to_degrees()))
                    .unwrap_or_else(|| "none".into()),
                m.description
            );
        }
        Err(e) => {
            let _ = writeln!(out, "mission: {e}");
        }
    }
    // Other metadata records (e.g. a simulator's `vehicle_truth`), by name and size.
    let others: Vec<String> = log
        .metadata
        .iter()
        .filter(|(name, _)| name.as_str() != "mission")
        .map(|(name, map)| format!("{name} ({} keys)", map.len()))
        .collect();
    if !others.is_empty() {
        let _ = writeln!(out, "other metadata: {}", others.join(", "));
    }
    out
}

/// The table of topics, the skipped ones with them.
fn render_topics(log: &Log) -> String {
    let mut out = String::new();
    let header = [
        "topic",
        "schema",
        "enc",
        "count",
        "rate Hz",
        "jitter ms",
        "first stamp (UTC)",
        "last stamp (UTC)",
        "gaps",
        "dup",
        "ooo",
        "invalid",
    ];
    let mut rows: Vec<Vec<String>> = log.streams.iter().map(row).collect();
    for s in &log.skipped {
        let mut r = vec![String::new(); header.len()];
        r[0] = s.topic.clone();
        r[1] = s.schema_name.clone();
        r[2] = s.message_encoding.clone();
        r[3] = s.messages.to_string();
        r[4] = "(no decoder: skipped)".into();
        if let Some(LayoutCheck::Checked { misfits, .. }) = &s.layout {
            r[4] = "(no decoder: layout checked)".into();
            r[11] = misfits.to_string();
        }
        rows.push(r);
    }
    out.push_str(&table(&header, &rows));
    out
}

/// What a person looks for under the table: moved roles, layouts, unusable and held
/// readings, role problems, gaps and the first invalid message of each topic.
fn render_notes(log: &Log, list_gaps: bool) -> String {
    use std::fmt::Write;
    let mut out = String::new();
    let moved: Vec<String> = log
        .roles
        .iter()
        .filter(|c| c.source != RoleSource::DefaultTopic)
        .map(|c| format!("{} {}", c.role, c.topic))
        .collect();
    if !moved.is_empty() {
        let _ = writeln!(
            out,
            "roles not at their default topic: {}",
            moved.join(", ")
        );
    }
    for s in &log.skipped {
        match &s.layout {
            Some(LayoutCheck::Checked {
                first: Some(issue), ..
            }) => {
                let _ = writeln!(out, "layout  {issue}");
            }
            Some(LayoutCheck::NoLayout(why)) => {
                let _ = writeln!(out, "layout  {}: not checked: {why}", s.topic);
            }
            _ => {}
        }
    }
    for s in &log.streams {
        let c = &s.counts;
        if c.flagged > 0 {
            let _ = writeln!(
                out,
                "unusable  {}: {} of {} readings say they are not usable (a DVL without bottom \
                 lock: valid false), {:.1} %",
                s.topic,
                c.flagged,
                c.kept,
                100.0 * c.flagged as f64 / c.kept.max(1) as f64
            );
        }
        if c.held.repeats >= HELD_REPEATS {
            let _ = writeln!(
                out,
                "held  {}: {} messages in a row repeat the same values over {:.1} s from {} \
                 (a sensor that samples and holds, or is stuck)",
                s.topic,
                c.held.repeats + 1,
                c.held.seconds(),
                format_utc(c.held.from_ns)
            );
        }
    }
    for p in &log.role_problems {
        let _ = writeln!(out, "role  {p}");
    }
    for s in &log.streams {
        if list_gaps {
            for g in &s.timing.gaps {
                let _ = writeln!(
                    out,
                    "gap  {}: {:.3} s after {}",
                    s.topic,
                    g.duration_ns as f64 * 1e-9,
                    format_utc(g.after_ns)
                );
            }
        }
        if let Some(issue) = s.issues.first() {
            let _ = writeln!(out, "invalid  {issue}");
        }
    }
    if !list_gaps && log.streams.iter().any(|s| !s.timing.gaps.is_empty()) {
        let _ = writeln!(
            out,
            "(gaps: intervals over {GAP_FACTOR}x the median; --gaps lists them)"
        );
    }
    out
}

fn row(s: &Stream) -> Vec<String> {
    let t = &s.timing;
    let c = &s.counts;
    let stamp = |x: Option<i64>| x.map(format_utc).unwrap_or_else(|| "-".into());
    vec![
        s.topic.clone(),
        s.schema_name.clone(),
        s.message_encoding.clone(),
        c.kept.to_string(),
        t.rate_hz()
            .map(|r| format!("{r:.3}"))
            .unwrap_or_else(|| "-".into()),
        t.jitter_s
            .map(|j| format!("{:.3}", j * 1e3))
            .unwrap_or_else(|| "-".into()),
        stamp(t.span_ns.map(|s| s.0)),
        stamp(t.span_ns.map(|s| s.1)),
        t.gaps.len().to_string(),
        c.duplicates.to_string(),
        c.out_of_order.to_string(),
        c.invalid.to_string(),
    ]
}

/// Left-aligned text columns, numbers right-aligned.
fn table(header: &[&str], rows: &[Vec<String>]) -> String {
    let mut widths: Vec<usize> = header.iter().map(|h| h.len()).collect();
    for r in rows {
        for (w, cell) in widths.iter_mut().zip(r) {
            *w = (*w).max(cell.chars().count());
        }
    }
    let numeric = |i: usize| i >= 3 && !matches!(i, 6 | 7);
    let line = |cells: Vec<&str>| {
        let parts: Vec<String> = cells
            .iter()
            .enumerate()
            .map(|(i, c)| {
                if numeric(i) {
                    format!("{c:>w$}", w = widths[i])
                } else {
                    format!("{c:<w$}", w = widths[i])
                }
            })
            .collect();
        parts.join("  ").trim_end().to_string() + "\n"
    };
    let mut out = line(header.to_vec());
    for r in rows {
        out.push_str(&line(r.iter().map(String::as_str).collect()));
    }
    out
}
