//! every command's `report.html` is self-contained, holds its sections with the
//! pictures inline, has the same pictures as PNG beside it, and renders in a real browser
//! (headless Chromium; skipped with a message when none is installed, required in CI by
//! `HINDSIGHT_REQUIRE_BROWSER=1`).

use crate::common;
use common::{hindsight, scratch_dir, survey_bytes};
use hindsight::sim::writer::WriterOptions;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

/// The output folders of reconstruct, attitude, identify and study, made once per run.
fn reports() -> &'static [(&'static str, PathBuf)] {
    static MADE: OnceLock<Vec<(&'static str, PathBuf)>> = OnceLock::new();
    MADE.get_or_init(|| {
        let dir = scratch_dir("report");
        // A synthetic survey that loses DVL bottom lock for 12 s in its middle.
        let log = dir.join("survey.mcap");
        std::fs::write(&log, survey_bytes(WriterOptions::default(), 120.0)).unwrap();
        let run = |args: &[&str]| {
            let out = hindsight(args);
            assert!(
                out.status.success(),
                "{args:?}: {}",
                String::from_utf8_lossy(&out.stderr)
            );
        };
        let path = |p: &Path| p.to_str().unwrap().to_string();
        let out = |name: &str| dir.join(name);
        run(&[
            "reconstruct",
            &path(&log),
            "--out",
            &path(&out("reconstruct")),
        ]);
        run(&[
            "attitude",
            common::POOL_SAMPLE,
            "--out",
            &path(&out("attitude")),
        ]);
        let zigzag = dir.join("zz.mcap");
        run(&[
            "simulate",
            "--scenario",
            "zigzag-5-5",
            "--out",
            &path(&zigzag),
        ]);
        run(&["identify", &path(&zigzag), "--out", &path(&out("identify"))]);
        run(&[
            "study",
            "--scenario",
            "drop-no-dvl",
            "--runs",
            "2",
            "--out",
            &path(&out("study")),
        ]);
        ["reconstruct", "attitude", "identify", "study"]
            .into_iter()
            .map(|c| (c, out(c)))
            .collect()
    })
}

fn page(command: &str) -> (String, PathBuf) {
    let (_, dir) = reports().iter().find(|(c, _)| *c == command).unwrap();
    let html = std::fs::read_to_string(dir.join("report.html")).expect("report.html is written");
    (html, dir.clone())
}

/// Nothing in the page loads from elsewhere: no `src=`, no stylesheet or import, no URL,
/// and every link stays on the page.
fn assert_self_contained(html: &str) {
    let lower = html.to_ascii_lowercase();
    for forbidden in [
        "src=", "<link", "@import", "url(", "http:", "https:", "//cdn", "<img", "<iframe",
        "<object", "<embed",
    ] {
        assert!(
            !lower.contains(forbidden),
            "the page refers to an outside resource: `{forbidden}`"
        );
    }
    for (i, _) in lower.match_indices("href=") {
        assert!(
            lower[i..].starts_with("href=\"#"),
            "a link that leaves the page: {}",
            &html[i..i + 40]
        );
    }
}

/// The page's section headings in order.
fn headings(html: &str) -> Vec<String> {
    html.match_indices("<h2>")
        .map(|(i, _)| {
            let rest = &html[i + 4..];
            rest[..rest.find("</h2>").unwrap()].to_string()
        })
        .collect()
}

/// The stems of the page's figures (`<figure id="stem">`), each with its inline SVG.
fn figures(html: &str) -> Vec<String> {
    html.match_indices("<figure id=\"")
        .map(|(i, _)| {
            let rest = &html[i + 12..];
            let stem = rest[..rest.find('"').unwrap()].to_string();
            let body = &rest[..rest.find("</figure>").unwrap()];
            assert!(
                body.contains("<svg viewBox=") && body.contains("</svg>"),
                "figure {stem} holds its picture inline"
            );
            stem
        })
        .collect()
}

/// Every figure has its PNG beside the page, and a PNG beside it is a figure.
fn assert_pngs_match(dir: &Path, stems: &[String]) {
    for stem in stems {
        let bytes = std::fs::read(dir.join(format!("{stem}.png")))
            .unwrap_or_else(|_| panic!("{stem}.png beside report.html"));
        let info = png::Decoder::new(bytes.as_slice()).read_info().unwrap();
        assert_eq!((info.info().width, info.info().height), (1000, 800));
    }
    let mut pngs: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok()?.file_name().into_string().ok())
        .filter_map(|n| n.strip_suffix(".png").map(str::to_string))
        .collect();
    pngs.sort();
    let mut expected = stems.to_vec();
    expected.sort();
    assert_eq!(pngs, expected, "the PNGs are the page's pictures");
}

fn escape(text: &str) -> String {
    hindsight::output::report::escape(text)
}

#[test]
fn reconstruct_report_holds_what_an_engineer_looks_at_first() {
    let (html, dir) = page("reconstruct");
    assert_self_contained(&html);
    assert!(html.len() < 5_000_000, "{} bytes", html.len());
    assert_eq!(
        headings(&html),
        [
            "Summary",
            "Inputs and initialisation",
            "What was used and why",
            "Track",
            "Uncertainty",
            "Errors against /truth",
            "Innovations",
            "Calibration and tuning",
            "Warnings"
        ]
    );
    let stems = figures(&html);
    for needed in [
        "track",
        "depth",
        "position_sigma",
        "errors",
        "nees",
        "innovations_dvl",
        "innovations_depth",
        "innovations_gnss",
    ] {
        assert!(
            stems.iter().any(|s| s == needed),
            "figure {needed}: {stems:?}"
        );
    }
    assert_pngs_match(&dir, &stems);
    // The log loses bottom lock for 12 s: shaded on the time plots, coloured on the track.
    assert!(in_a_legend(&html, "no DVL bottom lock"));
    assert!(in_a_legend(&html, "smoothed, no DVL bottom lock"));
    // What summary.json says, the page says: inputs, the initial sources, the tuning, the
    // warnings, and the truth scores.
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    let imu = summary["inputs"]
        .as_array()
        .unwrap()
        .iter()
        .find(|i| i["topic"] == "/imu")
        .unwrap();
    assert!(html.contains(&format!("<td>{}</td>", imu["messages"])));
    // The plan: every decision of summary.json, by its name, in the page's table.
    let decisions = summary["plan"]["decisions"].as_array().unwrap();
    assert!(decisions.len() >= 10, "{decisions:?}");
    for d in decisions {
        let name = escape(d["name"].as_str().unwrap());
        assert!(
            html.contains(&format!("<td class=\"t\">{name}</td>")),
            "{name}"
        );
    }
    let init = &summary["initialisation"];
    assert!(html.contains(&format!(
        "{} (1-sigma {:.2} deg)",
        init["heading_source"].as_str().unwrap(),
        init["heading_sigma_deg"].as_f64().unwrap()
    )));
    assert!(html.contains("Self-tuning estimated these noise figures"));
    let warnings = summary["warnings"].as_array().unwrap();
    for w in warnings {
        let message = w["message"].as_str().unwrap();
        assert!(html.contains(&format!("<li>{}</li>", escape(message))));
    }
    if warnings.is_empty() {
        assert!(html.contains("No warnings."));
    }
    let rms = summary["truth"]["smoothed"]["horizontal_rms_m"]
        .as_f64()
        .unwrap();
    assert!(html.contains(&format!("horizontal RMS {rms:.2} m")));
    let report_s = summary["run_time_s"]["report"].as_f64().unwrap();
    assert!(report_s > 0.0 && report_s <= summary["run_time_s"]["total"].as_f64().unwrap());
}

#[test]
fn attitude_identify_and_study_reports_hold_their_results() {
    for (command, sections, stems) in [
        (
            "attitude",
            &[
                "Comparison",
                "Inputs, calibration and notes",
                "Dead-reckoned tracks",
                "Attitude errors against time",
                "Warnings",
            ][..],
            &[
                "tracks_xy",
                "tracks_xz",
                "error_roll",
                "error_pitch",
                "error_heading",
            ][..],
        ),
        (
            "identify",
            &["Coefficients", "Inputs", "Fit", "Warnings"][..],
            &["convergence", "fit_theta", "fit_w"][..],
        ),
        (
            "study",
            &["Cases", "Error against time", "Warnings"][..],
            &["error_vs_time"][..],
        ),
    ] {
        let (html, dir) = page(command);
        assert_self_contained(&html);
        assert_eq!(headings(&html), sections, "{command}");
        assert_eq!(figures(&html), stems, "{command}");
        assert_pngs_match(&dir, &figures(&html));
    }
    // The tables carry the results: every method of the comparison, every coefficient.
    let (html, _) = page("attitude");
    for method in ["raw", "ekf", "ukf", "cf", "mekf", "mekf-smoothed"] {
        assert!(
            html.contains(&format!("<td class=\"t\">{method}</td>")),
            "{method}"
        );
    }
    let (html, _) = page("identify");
    for name in hindsight::vehicle::heave_pitch::NAMES {
        assert!(
            html.contains(&format!("<td class=\"t\">{name}</td>")),
            "{name}"
        );
    }
}

/// A Chromium binary: `HINDSIGHT_BROWSER`, else the distribution's names on the PATH.
fn browser() -> Option<PathBuf> {
    if let Some(b) = std::env::var_os("HINDSIGHT_BROWSER") {
        return Some(PathBuf::from(b));
    }
    let path = std::env::var_os("PATH")?;
    ["chromium", "chromium-browser", "google-chrome"]
        .iter()
        .flat_map(|name| std::env::split_paths(&path).map(move |d| d.join(name)))
        .find(|p| p.is_file())
}

/// Pixels within a small distance of `rgb`.
fn pixels_near(rgb: &[u8], colour: [u8; 3]) -> usize {
    rgb.chunks_exact(3)
        .filter(|p| (0..3).all(|c| (p[c] as i32 - colour[c] as i32).abs() <= 12))
        .count()
}

#[test]
fn reports_render_in_a_real_browser() {
    let Some(chromium) = browser() else {
        common::skip_unless_required(
            "HINDSIGHT_REQUIRE_BROWSER",
            "no chromium is installed",
            "skipped: no chromium on the PATH (install Debian's `chromium` to run this)",
        );
        return;
    };
    let shots = Path::new(env!("CARGO_TARGET_TMPDIR")).join("report-screenshots");
    std::fs::create_dir_all(&shots).unwrap();
    for (command, dir) in reports() {
        let shot = shots.join(format!("{command}.png"));
        let _ = std::fs::remove_file(&shot);
        let url = format!(
            "file://{}",
            dir.join("report.html").canonicalize().unwrap().display()
        );
        let profile = scratch_dir(&format!("chromium-{command}"));
        let status = Command::new(&chromium)
            .args([
                "--headless",
                "--no-sandbox",
                "--disable-gpu",
                "--hide-scrollbars",
                "--no-first-run",
                &format!("--user-data-dir={}", profile.display()),
                &format!("--screenshot={}", shot.display()),
                "--window-size=1280,4000",
                &url,
            ])
            .output()
            .expect("chromium runs");
        assert!(
            shot.is_file(),
            "{command}: no screenshot; chromium said {}",
            String::from_utf8_lossy(&status.stderr)
        );
        let bytes = std::fs::read(&shot).unwrap();
        let mut reader = png::Decoder::new(bytes.as_slice()).read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size()];
        let frame = reader.next_frame(&mut buf).unwrap();
        let channels = frame.color_type.samples();
        let rgb: Vec<u8> = buf[..frame.buffer_size()]
            .chunks_exact(channels)
            .flat_map(|p| [p[0], p[1], p[2]])
            .collect();
        eprintln!("{command}: {}", shot.display());
        // The header band drew (the page's style), and the pictures drew: the first series'
        // colour (Tableau blue) appears in quantity only where an inline SVG was painted.
        let header = pixels_near(&rgb, [0x17, 0x32, 0x4d]);
        let blue = pixels_near(&rgb, [0x1f, 0x77, 0xb4]);
        assert!(header > 20_000, "{command}: header pixels {header}");
        assert!(blue > 500, "{command}: series pixels {blue}");
        if *command == "reconstruct" {
            let red = pixels_near(&rgb, [0xd6, 0x27, 0x28]);
            assert!(red > 500, "the smoothed track drew: {red}");
        }
    }
}

/// Whether `name` is written in a picture of the page, on one line or wrapped over several
/// consecutive ones (a legend wraps long names).
fn in_a_legend(html: &str, name: &str) -> bool {
    let texts: Vec<&str> = html
        .split("</text>")
        .filter_map(|piece| piece.trim_end().rsplit('\n').next())
        .map(str::trim)
        .collect();
    (1..=4).any(|n| texts.windows(n).any(|w| w.join(" ") == name))
}
