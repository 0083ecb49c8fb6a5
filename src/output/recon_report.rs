//! reconstruct's `report.html`: what a navigation engineer looks at first, from the summary,
//! the solutions, the residuals and what the log said (fixes, DVL outages, truth).

use crate::contract::{GnssFix, PositionFix, Truth};
use crate::filters::ins::aid_table::Sensor;
use crate::filters::ins::driver::Residual;
use crate::filters::ins::record::Solution;
use crate::geodesy::local_north_east_m;
use crate::output::plots::{colour, min_max, sample_cloud, thin, Plot, Series};
use crate::output::report::{Block, Report, Section};
use crate::recon::score::{self, EpochError};
use crate::recon::Reconstruction;
use crate::reconstruction::summary::{dvl_calibration_line, estimated_text, Summary};

/// Points per line in a picture (a 5.5 h mission has 200 000 rows per solution).
const LINE_POINTS: usize = 4000;
/// Dots per innovation component.
const DOT_POINTS: usize = 3000;
/// Normalised innovations beyond this are kept in the pictures however many there are.
const OUTLIER: f64 = 3.0;
/// DVL outages shorter than this are not shaded.
pub const OUTAGE_MIN_S: f64 = 2.0;

/// What the report draws from the log, taken before the log is freed.
#[derive(Debug, Clone, Default)]
pub struct FromLog {
    /// GNSS fixes (east, north), m from the origin.
    pub gnss_en: Vec<(f64, f64)>,
    /// Position fixes: label, east, north.
    pub fixes: Vec<(String, f64, f64)>,
    /// The truth (east, north, down) with its stamp.
    pub truth: Vec<(i64, [f64; 3])>,
    /// Stretches without DVL bottom lock, ns.
    pub dvl_outages: Vec<(i64, i64)>,
}

impl FromLog {
    pub fn new(
        gnss: &[GnssFix],
        fixes: &[PositionFix],
        dvl: &[crate::contract::Dvl],
        origin_rad: (f64, f64),
    ) -> Self {
        FromLog {
            gnss_en: gnss
                .iter()
                .map(|g| {
                    let (n, e) = local_north_east_m(
                        origin_rad.0,
                        origin_rad.1,
                        g.latitude_deg.to_radians(),
                        g.longitude_deg.to_radians(),
                    );
                    (e, n)
                })
                .collect(),
            fixes: fixes
                .iter()
                .map(|f| (f.label.clone(), f.east_m, f.north_m))
                .collect(),
            truth: Vec::new(),
            dvl_outages: crate::recon::stats::dvl_outages(dvl, OUTAGE_MIN_S),
        }
    }

    /// With the truth's track (read back after the filter).
    pub fn with_truth(self, truth: &[Truth]) -> Self {
        FromLog {
            truth: truth
                .iter()
                .map(|t| (t.stamp_ns, [t.east_m, t.north_m, t.down_m]))
                .collect(),
            ..self
        }
    }
}

/// Seconds, minutes or hours from the first solution, as the mission's length suits.
struct TimeAxis {
    t0_ns: i64,
    per_unit_s: f64,
    label: &'static str,
}

impl TimeAxis {
    fn new(t0_ns: i64, duration_s: f64) -> Self {
        let (per_unit_s, label) = if duration_s > 3.0 * 3600.0 {
            (3600.0, "time from the start (h)")
        } else if duration_s > 600.0 {
            (60.0, "time from the start (min)")
        } else {
            (1.0, "time from the start (s)")
        };
        TimeAxis {
            t0_ns,
            per_unit_s,
            label,
        }
    }

    fn at(&self, stamp_ns: i64) -> f64 {
        (stamp_ns - self.t0_ns) as f64 * 1e-9 / self.per_unit_s
    }

    fn plot(&self, title: &str, y_label: &str) -> Plot {
        Plot::new(title, self.label, y_label)
    }
}

/// Everything the page is made from.
pub struct Inputs<'a> {
    pub summary: &'a Summary,
    pub r: &'a Reconstruction,
    /// Both solutions at the rows drawn.
    pub samples: &'a Samples,
    pub origin_rad: (f64, f64),
    pub from_log: &'a FromLog,
    /// The forward and smoothed solutions' errors against the truth.
    pub truth_errors: Option<(&'a [ErrorPoint], &'a [ErrorPoint])>,
    pub init_text: String,
}

/// "What was used and why": every aid, calibration state and stage of the plan.
fn plan(s: &Summary) -> Section {
    let rows = s
        .plan
        .decisions
        .iter()
        .map(|d| {
            vec![
                d.name.to_string(),
                if d.used { "used" } else { "not used" }.to_string(),
                d.why.to_string(),
            ]
        })
        .collect();
    Section::new("What was used and why")
        .with(Block::text(
            "The plan decided from the log: each aiding sensor, calibration state and stage, \
             and why it was used or not (present in the log, observable, refused by its own \
             checks, or switched by the configuration).",
        ))
        .with(Block::table(["part", "used", "why"], rows))
}

/// Both solutions at the rows the page draws ([`spread`] over the output rows).
#[derive(Debug, Clone, Default)]
pub struct Samples {
    pub forward: Vec<Solution>,
    pub smoothed: Vec<Solution>,
}

pub fn build(x: &Inputs<'_>) -> Report {
    let s = x.summary;
    let (fwd, smo): (Vec<&Solution>, Vec<&Solution>) = (
        x.samples.forward.iter().collect(),
        x.samples.smoothed.iter().collect(),
    );
    let axis = TimeAxis::new(fwd.first().map_or(0, |s| s.stamp_ns), s.duration_s);
    let bands: Vec<(f64, f64)> = x
        .from_log
        .dvl_outages
        .iter()
        .map(|&(a, b)| (axis.at(a), axis.at(b)))
        .collect();
    let shade = |mut p: Plot| {
        if !bands.is_empty() {
            p.bands = bands.clone();
            p.band_label = "no DVL bottom lock".into();
        }
        p
    };
    let mut sections = vec![overview(s), inputs(s, &x.init_text), plan(s)];
    let mut track = Section::new("Track");
    track.push(Block::figure(
        "track",
        "Plan view from the mission origin: forward and smoothed solutions, the truth when \
         the log has it, GNSS and position fixes; the smoothed track is orange where the DVL \
         had no bottom lock.",
        track_plot(x, &fwd, &smo),
    ));
    track.push(Block::figure(
        "depth",
        "Depth against time.",
        shade(depth_plot(x, &axis, &fwd, &smo)),
    ));
    sections.push(track);
    sections.push(Section::new("Uncertainty").with(Block::figure(
        "position_sigma",
        "Horizontal and depth 1-sigma of both solutions (the smoother's is the smaller); \
         shaded: no DVL bottom lock.",
        shade(sigma_plot(&axis, &fwd, &smo)),
    )));
    if let (Some((ef, es)), Some(t)) = (x.truth_errors, &s.truth) {
        let mut errors = Section::new("Errors against /truth");
        let mut facts = Vec::new();
        for (name, sc) in [("forward", &t.forward), ("smoothed", &t.smoothed)] {
            if let Some(v) = sc {
                facts.push((
                    name.to_string(),
                    format!(
                        "horizontal RMS {:.2} m, max {:.2} m, final {:.2} m; yaw RMS {:.3} deg; \
                         horizontal NEES inside its 95 % bounds {:.1} % (above {:.1} %)",
                        v.horizontal_rms_m,
                        v.horizontal_max_m,
                        v.horizontal_final_m,
                        v.yaw_rms_deg,
                        100.0 * v.nees_horizontal_inside_95,
                        100.0 * v.nees_horizontal_above_95
                    ),
                ));
            }
        }
        errors.push(Block::facts(facts));
        errors.push(Block::figure(
            "errors",
            "Horizontal error against the truth, with the radius the filter claims holds it \
             95 % of the time (2.45 sigma).",
            shade(error_plot(&axis, ef, es)),
        ));
        errors.push(Block::figure(
            "nees",
            "Horizontal NEES (2 degrees of freedom) of each solution and its two-sided 95 % \
             bounds: a consistent filter stays between them 95 % of the time.",
            shade(nees_plot(&axis, ef, es)),
        ));
        sections.push(errors);
    }
    sections.push(innovations(s, &x.r.run.residuals, &axis));
    sections.push(calibration(s));
    sections.push(Section::new("Warnings").with(Block::Warnings(
        s.warnings.iter().map(ToString::to_string).collect(),
    )));
    Report {
        title: format!("hindsight reconstruct: {}", file_name(&s.log)),
        subtitle: format!(
            "{}: {:.0} s, {:.0} m travelled (smoothed)",
            s.log, s.duration_s, s.distance_travelled_m
        ),
        sections,
        footer: format!(
            "hindsight {}; every setting of the run is in summary.json",
            s.hindsight_version
        ),
    }
}

/// Output rows read back for the page's pictures: a picture thins to a few thousand points
/// anyway, and a day-long mission has a million rows.
pub const REPORT_ROWS: usize = 50_000;

/// At most `n` of `keep`, evenly spread, the first and last among them.
pub fn spread(keep: &[usize], n: usize) -> Vec<usize> {
    if keep.len() <= n || n < 2 {
        return keep.to_vec();
    }
    (0..n)
        .map(|i| keep[i * (keep.len() - 1) / (n - 1)])
        .collect()
}

fn file_name(path: &str) -> &str {
    path.rsplit(['/', '\\']).next().unwrap_or(path)
}

fn overview(s: &Summary) -> Section {
    let verdict = Block::Verdict {
        good: s.consistency.consistent,
        text: s.consistency.verdict_line(),
    };
    let mut facts = vec![
        ("log".to_string(), s.log.clone()),
        (
            "mission origin".into(),
            format!(
                "{:.6}, {:.6} deg{}",
                s.mission.origin_latitude_deg,
                s.mission.origin_longitude_deg,
                if s.mission.vehicle.is_empty() {
                    String::new()
                } else {
                    format!("; vehicle {}", s.mission.vehicle)
                }
            ),
        ),
        (
            "duration, distance".into(),
            format!(
                "{:.0} s, {:.0} m (smoothed)",
                s.duration_s, s.distance_travelled_m
            ),
        ),
        (
            "filter".into(),
            format!(
                "{} epochs, {} measurements, {} rejected, {} DVL readings out of range",
                s.epochs, s.residuals, s.rejected, s.dvl_out_of_range
            ),
        ),
    ];
    for (name, sigma) in [
        ("final 1-sigma, forward", &s.final_sigma.forward),
        ("final 1-sigma, smoothed", &s.final_sigma.smoothed),
    ] {
        if let Some(x) = sigma {
            facts.push((
                name.into(),
                format!(
                    "horizontal {:.2} m, depth {:.2} m, yaw {:.3} deg",
                    x.horizontal_m, x.down_m, x.yaw_deg
                ),
            ));
        }
    }
    let t = &s.run_time_s;
    facts.push((
        "run time".into(),
        format!(
            "{:.1} s (ingest {:.1}, forward {:.1}, smoother {:.1})",
            t.total, t.ingest, t.forward, t.smoother
        ),
    ));
    Section::new("Summary")
        .with(verdict)
        .with(Block::Facts(facts))
}

fn inputs(s: &Summary, init_text: &str) -> Section {
    let rows = s
        .inputs
        .iter()
        .map(|i| {
            vec![
                i.topic.to_string(),
                i.log_topic.clone().unwrap_or_else(|| "-".into()),
                i.messages.to_string(),
                if i.used { "yes" } else { "no" }.to_string(),
            ]
        })
        .collect();
    let i = &s.initialisation;
    let heading_rows = i
        .heading_sources
        .iter()
        .map(|h| {
            vec![
                format!("{:?}", h.source),
                format!("{:.1}", h.heading_deg),
                format!("{:.2}", h.sigma_deg),
                if h.used { "yes" } else { "no" }.to_string(),
            ]
        })
        .collect();
    let mut section = Section::new("Inputs and initialisation")
        .with(Block::table(
            ["role", "log topic", "messages", "used"],
            rows,
        ))
        .with(Block::facts([
            (
                "position",
                format!(
                    "{} (1-sigma {:.2} m)",
                    i.position_source, i.position_sigma_m
                ),
            ),
            (
                "velocity",
                format!(
                    "{} (1-sigma {:.3} m/s)",
                    i.velocity_source, i.velocity_sigma_m_s
                ),
            ),
            (
                "heading",
                format!(
                    "{} (1-sigma {:.2} deg)",
                    i.heading_source, i.heading_sigma_deg
                ),
            ),
            ("tilt 1-sigma", format!("{:.2} deg", i.tilt_sigma_deg)),
        ]))
        .with(Block::table(
            ["heading source", "heading (deg)", "1-sigma (deg)", "used"],
            heading_rows,
        ));
    if !i.heading_unavailable.is_empty() {
        section.push(Block::text(format!(
            "Heading sources not available: {}.",
            i.heading_unavailable.join("; ")
        )));
    }
    section.push(Block::Pre(init_text.to_string()));
    section
}

fn track_plot(x: &Inputs<'_>, fwd: &[&Solution], smo: &[&Solution]) -> Plot {
    let en = |s: &Solution| {
        let n = &s.point.nav;
        let (north, east) =
            local_north_east_m(x.origin_rad.0, x.origin_rad.1, n.lat_rad, n.lon_rad);
        (east, north)
    };
    let mut plot = Plot::new("track, plan view", "east (m)", "north (m)");
    plot.equal_axes = true;
    if !x.from_log.truth.is_empty() {
        let truth: Vec<(f64, f64)> = x.from_log.truth.iter().map(|(_, p)| (p[0], p[1])).collect();
        plot.series
            .push(Series::line("truth", thin(&truth, LINE_POINTS)).coloured(colour::TRUTH));
    }
    let forward: Vec<(f64, f64)> = fwd.iter().map(|s| en(s)).collect();
    let smoothed: Vec<(f64, f64)> = smo.iter().map(|s| en(s)).collect();
    plot.series
        .push(Series::line("forward", thin(&forward, LINE_POINTS)).coloured(colour::FORWARD));
    plot.series
        .push(Series::line("smoothed", thin(&smoothed, LINE_POINTS)).coloured(colour::SMOOTHED));
    // The smoothed track inside the outages, broken between them.
    let outages = &x.from_log.dvl_outages;
    if !outages.is_empty() {
        let mut no_lock = Vec::new();
        let mut inside_before = false;
        for (s, p) in smo.iter().zip(&smoothed) {
            let inside = outages.iter().any(|&(a, b)| (a..=b).contains(&s.stamp_ns));
            if inside {
                no_lock.push(*p);
            } else if inside_before {
                no_lock.push((f64::NAN, f64::NAN));
            }
            inside_before = inside;
        }
        plot.series.push(
            Series::line("smoothed, no DVL bottom lock", thin(&no_lock, LINE_POINTS))
                .coloured(colour::ORANGE),
        );
    }
    if !x.from_log.gnss_en.is_empty() {
        plot.series.push(
            Series::dots("GNSS fixes", thin(&x.from_log.gnss_en, DOT_POINTS))
                .coloured(colour::GREEN),
        );
    }
    let fixes = &x.from_log.fixes;
    if !fixes.is_empty() {
        let points: Vec<(f64, f64)> = fixes.iter().map(|f| (f.1, f.2)).collect();
        plot.series.push(
            Series::dots("position fixes", thin(&points, DOT_POINTS)).coloured(colour::PURPLE),
        );
        let named = fixes.len() <= 10;
        plot.marks = fixes
            .iter()
            .filter(|f| named || f.0 == "start" || f.0 == "end")
            .map(|f| (f.0.clone(), (f.1, f.2)))
            .collect();
    }
    plot
}

fn depth_plot(x: &Inputs<'_>, axis: &TimeAxis, fwd: &[&Solution], smo: &[&Solution]) -> Plot {
    let depth = |sol: &[&Solution]| -> Vec<(f64, f64)> {
        let points: Vec<(f64, f64)> = sol
            .iter()
            .map(|s| (axis.at(s.stamp_ns), -s.point.nav.height_m))
            .collect();
        min_max(&points, LINE_POINTS)
    };
    let mut plot = axis.plot("depth", "depth (m)");
    plot.y_down = true;
    if !x.from_log.truth.is_empty() {
        let truth: Vec<(f64, f64)> = x
            .from_log
            .truth
            .iter()
            .map(|(t, p)| (axis.at(*t), p[2]))
            .collect();
        plot.series
            .push(Series::line("truth", min_max(&truth, LINE_POINTS)).coloured(colour::TRUTH));
    }
    plot.with(Series::line("forward", depth(fwd)).coloured(colour::FORWARD))
        .with(Series::line("smoothed", depth(smo)).coloured(colour::SMOOTHED))
}

fn sigma_plot(axis: &TimeAxis, fwd: &[&Solution], smo: &[&Solution]) -> Plot {
    let series = |sol: &[&Solution], f: fn(&Solution) -> f64| -> Vec<(f64, f64)> {
        let points: Vec<(f64, f64)> = sol.iter().map(|s| (axis.at(s.stamp_ns), f(s))).collect();
        min_max(&points, LINE_POINTS)
    };
    let horizontal = |s: &Solution| s.sigma[0].hypot(s.sigma[1]);
    let down = |s: &Solution| s.sigma[2];
    axis.plot("position 1-sigma", "1-sigma (m)")
        .with(
            Series::line("forward, horizontal", series(fwd, horizontal)).coloured(colour::FORWARD),
        )
        .with(
            Series::line("smoothed, horizontal", series(smo, horizontal))
                .coloured(colour::SMOOTHED),
        )
        .with(Series::line("forward, depth", series(fwd, down)).coloured(colour::CYAN))
        .with(Series::line("smoothed, depth", series(smo, down)).coloured(colour::PINK))
}

/// The radius that holds a circular 2-D Gaussian error 95 % of the time, in sigmas.
const CIRCLE_95: f64 = 2.447_746_830_680_816;

/// What the report draws of a solution's error against the truth at an epoch (a day's
/// mission has a million of them per solution: the whole [`EpochError`] is five times this).
#[derive(Debug, Clone, Copy)]
pub struct ErrorPoint {
    stamp_ns: i64,
    horizontal_m: f64,
    /// The radius the filter claims holds the horizontal error 95 % of the time.
    radius_95_m: f64,
    nees_horizontal: f64,
}

impl From<&EpochError> for ErrorPoint {
    fn from(e: &EpochError) -> Self {
        ErrorPoint {
            stamp_ns: e.stamp_ns,
            horizontal_m: e.horizontal_m(),
            radius_95_m: CIRCLE_95 * e.position_sigma_m.x.hypot(e.position_sigma_m.y) / 2f64.sqrt(),
            nees_horizontal: e.nees_horizontal,
        }
    }
}

/// A line of `f` along `rows`, thinned for the picture.
fn error_line(axis: &TimeAxis, rows: &[ErrorPoint], f: fn(&ErrorPoint) -> f64) -> Vec<(f64, f64)> {
    let points: Vec<(f64, f64)> = rows.iter().map(|e| (axis.at(e.stamp_ns), f(e))).collect();
    min_max(&points, LINE_POINTS)
}

fn error_plot(axis: &TimeAxis, fwd: &[ErrorPoint], smo: &[ErrorPoint]) -> Plot {
    let horizontal = |e: &ErrorPoint| e.horizontal_m;
    let radius = |e: &ErrorPoint| e.radius_95_m;
    axis.plot("horizontal error against /truth", "horizontal error (m)")
        .with(Series::line("forward", error_line(axis, fwd, horizontal)).coloured(colour::FORWARD))
        .with(
            Series::line("smoothed", error_line(axis, smo, horizontal)).coloured(colour::SMOOTHED),
        )
        .with(
            Series::line("forward 95 % radius", error_line(axis, fwd, radius))
                .coloured(colour::CYAN),
        )
        .with(
            Series::line("smoothed 95 % radius", error_line(axis, smo, radius))
                .coloured(colour::PINK),
        )
}

fn nees_plot(axis: &TimeAxis, fwd: &[ErrorPoint], smo: &[ErrorPoint]) -> Plot {
    let nees = |e: &ErrorPoint| e.nees_horizontal;
    let (lo, hi) = score::bounds_95(2);
    let mut plot = axis
        .plot("horizontal NEES", "NEES (2 dof)")
        .with(Series::line("forward", error_line(axis, fwd, nees)).coloured(colour::FORWARD))
        .with(Series::line("smoothed", error_line(axis, smo, nees)).coloured(colour::SMOOTHED));
    plot.hlines = vec![lo, hi];
    plot.hline_label = format!("95 % bounds ({lo:.2}, {hi:.2})");
    plot
}

/// The names of a sensor's innovation components.
fn components(sensor: Sensor, dims: usize) -> &'static [&'static str] {
    match (sensor, dims) {
        (Sensor::Gnss | Sensor::PositionFix, 2) => &["north", "east"],
        (Sensor::PositionFix, 3) => &["north", "east", "down"],
        (Sensor::Magnetometer, 1) => &["heading"],
        (Sensor::Depth, 1) => &["depth"],
        (_, 1) => &["speed"],
        (_, 2) => &["x", "y"],
        _ => &["x", "y", "z"],
    }
}

fn innovations(s: &Summary, residuals: &[Residual], axis: &TimeAxis) -> Section {
    let verdict = |name: Sensor| {
        s.consistency
            .innovations
            .iter()
            .find(|i| i.sensor == name)
            .map_or("-".to_string(), |i| i.verdict.to_string())
    };
    let rows = s
        .sensors
        .iter()
        .map(|x| {
            vec![
                x.sensor.to_string(),
                (x.count - x.rejected).to_string(),
                x.rejected.to_string(),
                format!("{:.2} / {}", x.mean_nis, x.dims),
                format!("{:.3}", x.normalised_mean),
                format!("{:.3}", x.normalised_variance),
                verdict(x.sensor),
            ]
        })
        .collect();
    let mut section = Section::new("Innovations").with(Block::text(
        "Each aiding measurement's innovation over its predicted 1-sigma. A consistent filter's \
         normalised innovations have mean 0 and variance 1, and 95 % of them lie within \
         +-1.96; the mean NIS equals the measurement's size. Rejected: outside the gate. On long \
         missions each picture shows an even sample of at most 3000 per component (so the \
         density is the data's) and, of each stretch between two sampled ones, the largest \
         beyond +-3.",
    ));
    section.push(Block::table(
        [
            "sensor",
            "used",
            "rejected",
            "mean NIS",
            "norm mean",
            "norm var",
            "verdict",
        ],
        rows,
    ));
    for sensor in Sensor::ALL {
        let mine: Vec<&Residual> = residuals.iter().filter(|r| r.sensor == sensor).collect();
        let Some(dims) = mine.first().map(|r| usize::from(r.dims)) else {
            continue;
        };
        let mut plot = axis.plot(
            &format!("{} normalised innovations", sensor.name()),
            "innovation / predicted sigma",
        );
        for (i, name) in components(sensor, dims).iter().enumerate().take(dims) {
            let points: Vec<(f64, f64)> = mine
                .iter()
                .filter(|r| r.accepted && r.sigma[i] > 0.0)
                .map(|r| (axis.at(r.stamp_ns), r.innovation[i] / r.sigma[i]))
                .collect();
            plot.series.push(Series::dots(
                *name,
                sample_cloud(&points, DOT_POINTS, OUTLIER),
            ));
        }
        let rejected: Vec<(f64, f64)> = mine
            .iter()
            .filter(|r| !r.accepted && r.sigma[0] > 0.0)
            .map(|r| (axis.at(r.stamp_ns), r.innovation[0] / r.sigma[0]))
            .collect();
        if !rejected.is_empty() {
            plot.series.push(
                Series::dots(
                    "rejected (first component)",
                    sample_cloud(&rejected, DOT_POINTS, OUTLIER),
                )
                .coloured(colour::BLACK),
            );
        }
        plot.hlines = vec![-1.96, 1.96];
        plot.hline_label = "95 % bounds (+-1.96)".into();
        section.push(Block::figure(
            &format!("innovations_{}", sensor.name()),
            format!(
                "{}: {} measurements, {} rejected.",
                sensor.name(),
                mine.len(),
                mine.iter().filter(|r| !r.accepted).count()
            ),
            plot,
        ));
        if let Some(figure) = against_slant_range(sensor, &mine) {
            section.push(figure);
        }
    }
    section
}

/// An acoustic sensor's residuals (a fix's horizontal distance from the prediction, a
/// range's signed difference, m) against the slant range they were made over, the refused
/// ones marked: an acoustic error grows with the range, and multipath stands out of it.
fn against_slant_range(sensor: Sensor, mine: &[&Residual]) -> Option<Block> {
    let residual_m = |r: &Residual| match r.dims {
        1 => r.innovation[0],
        2 => r.innovation[0].hypot(r.innovation[1]),
        _ => r.innovation[0]
            .hypot(r.innovation[1])
            .hypot(r.innovation[2]),
    };
    let points = |accepted: bool| -> Vec<(f64, f64)> {
        let mut p: Vec<(f64, f64)> = (mine.iter())
            .filter(|r| r.accepted == accepted)
            .filter_map(|r| Some((f64::from(r.slant_range_m?), residual_m(r))))
            .collect();
        p.sort_by(|a, b| a.0.total_cmp(&b.0));
        p
    };
    let (taken, refused) = (points(true), points(false));
    if taken.is_empty() && refused.is_empty() {
        return None;
    }
    let what = match mine.first().map_or(0, |r| r.dims) {
        1 => "range measured minus predicted (m)",
        2 => "horizontal distance from the prediction (m)",
        _ => "distance from the prediction (m)",
    };
    let mut plot = Plot::new(
        format!("{} residuals against slant range", sensor.name()),
        "slant range (m)",
        what,
    );
    plot.series.push(Series::dots(
        "taken",
        sample_cloud(&taken, DOT_POINTS, OUTLIER),
    ));
    if !refused.is_empty() {
        plot.series.push(
            Series::dots("refused by the gate", thin(&refused, DOT_POINTS)).coloured(colour::BLACK),
        );
    }
    Some(Block::figure(
        &format!("slant_range_{}", sensor.name()),
        format!(
            "{}: {} readings with a slant range, {} refused by the gate.",
            sensor.name(),
            taken.len() + refused.len(),
            refused.len()
        ),
        plot,
    ))
}

fn calibration(s: &Summary) -> Section {
    let mut facts = Vec::new();
    if let Some(d) = &s.dvl_calibration {
        facts.push(("DVL".to_string(), dvl_calibration_line(d)));
    }
    if let Some(w) = &s.water {
        facts.push((
            "EM log and water".to_string(),
            format!(
                "EM log scale factor {}; current at the end north {}, east {}",
                estimated_text(&w.eml_scale_factor, 1.0, 4, ""),
                estimated_text(&w.current_m_s[0], 1.0, 3, " m/s"),
                estimated_text(&w.current_m_s[1], 1.0, 3, " m/s"),
            ),
        ));
    }
    if let Some(g) = &s.gyro_scale_factor_z {
        facts.push(("z gyro scale factor".into(), estimated_text(g, 1.0, 6, "")));
    }
    if let Some(c) = &s.sound_speed_scale {
        facts.push((
            "speed of sound".into(),
            format!(
                "the acoustic ranges' times {}",
                estimated_text(c, 1.0, 5, "")
            ),
        ));
    }
    let m = &s.magnetometer;
    facts.push((
        "magnetometer".into(),
        format!(
            "{} readings used; {}; field magnitude varies {:.2} % beyond its noise{}; {} \
             disturbed readings left out",
            m.readings_used,
            if m.calibrated {
                "hard/soft iron calibrated from the log".to_string()
            } else {
                format!(
                    "not calibrated{}",
                    m.calibration_skipped
                        .as_ref()
                        .map(|w| format!(" ({w})"))
                        .unwrap_or_default()
                )
            },
            m.magnitude_variation_pct,
            if m.deviation_unknown {
                " (deviation unknown: heading updates held correlated)"
            } else {
                ""
            },
            m.disturbed
        ),
    ));
    let mut section = Section::new("Calibration and tuning").with(Block::Facts(facts));
    match &s.tuning {
        Some(t) => {
            section.push(Block::text(
                "Self-tuning estimated these noise figures from the log (kept in tuned.toml, a \
                 settings file for a rerun):",
            ));
            section.push(Block::Pre(t.to_string()));
        }
        None => section.push(Block::text(
            "Self-tuning was off: the configuration's noise figures were used.",
        )),
    }
    section
}

#[cfg(test)]
mod tests {
    use super::*;

    fn residual(dims: u8, innovation: [f64; 3], slant_m: Option<f32>, accepted: bool) -> Residual {
        Residual {
            stamp_ns: 0,
            sensor: Sensor::Usbl,
            innovation,
            sigma: [1.0; 3],
            dims,
            nis: 1.0,
            accepted,
            log_likelihood: 0.0,
            repeats: false,
            slant_range_m: slant_m,
        }
    }

    /// Each reading with a slant range is a dot at its range and its distance from the
    /// prediction (the range's signed difference for a range); the refused ones apart, in
    /// black.
    #[test]
    fn acoustic_residuals_are_drawn_against_their_slant_range() {
        let readings = [
            residual(3, [3.0, 4.0, 12.0], Some(150.0), true),
            residual(3, [0.3, 0.4, 0.0], Some(90.0), true),
            residual(3, [30.0, 40.0, 0.0], Some(120.0), false),
            residual(3, [1.0, 1.0, 1.0], None, true),
        ];
        let mine: Vec<&Residual> = readings.iter().collect();
        let Some(Block::Figure(f)) = against_slant_range(Sensor::Usbl, &mine) else {
            panic!("a figure")
        };
        assert_eq!(f.stem, "slant_range_usbl");
        assert!(
            f.caption
                .contains("3 readings with a slant range, 1 refused by the gate"),
            "{}",
            f.caption
        );
        let [taken, refused] = &f.plot.series[..] else {
            panic!("{:?}", f.plot.series)
        };
        assert_eq!(taken.points, [(90.0, 0.5), (150.0, 13.0)]);
        assert_eq!(refused.points, [(120.0, 50.0)]);
        assert_eq!(refused.colour, Some(colour::BLACK));
        let range = [residual(1, [-0.4, 0.0, 0.0], Some(800.0), true)];
        let Some(Block::Figure(f)) = against_slant_range(Sensor::Lbl, &[&range[0]]) else {
            panic!("a figure")
        };
        assert_eq!(f.plot.series[0].points, [(800.0, -0.4)]);
        let none = [residual(3, [1.0; 3], None, true)];
        assert!(against_slant_range(Sensor::Usbl, &[&none[0]]).is_none());
    }
}
