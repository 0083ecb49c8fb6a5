//! Plots of tracks and time series, drawn by plotters to a PNG (bitmap in memory, encoded
//! with `png`) or to an SVG string for the HTML report: one drawing code for both, so the
//! report's pictures and the PNGs beside it are the same. Text uses DejaVu Sans Mono, shipped
//! in `assets/fonts` (Bitstream Vera licence, next to it), so no system font library is
//! needed.

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::FontStyle;
use std::io::Write;
use std::sync::Once;

const FONT: &[u8] = include_bytes!("../../assets/fonts/DejaVuSansMono.ttf");
const FAMILY: &str = "sans-serif";

/// Why a plot could not be made.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    #[error("drawing: {0}")]
    Draw(String),
    #[error("encoding PNG: {0}")]
    Encode(#[from] png::EncodingError),
}

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Style {
    /// Joined points; a non-finite point breaks the line.
    Line,
    /// Joined points, one pixel wide (a noisy series).
    Trace,
    /// Unjoined dots (fixes, innovations).
    Dots,
}

/// The colours series take in turn (Tableau 10), and a few with a fixed meaning.
pub mod colour {
    use plotters::style::RGBColor;
    pub const BLUE: RGBColor = RGBColor(0x1f, 0x77, 0xb4);
    pub const ORANGE: RGBColor = RGBColor(0xff, 0x7f, 0x0e);
    pub const GREEN: RGBColor = RGBColor(0x2c, 0xa0, 0x2c);
    pub const RED: RGBColor = RGBColor(0xd6, 0x27, 0x28);
    pub const PURPLE: RGBColor = RGBColor(0x94, 0x67, 0xbd);
    pub const BROWN: RGBColor = RGBColor(0x8c, 0x56, 0x4b);
    pub const PINK: RGBColor = RGBColor(0xe3, 0x77, 0xc2);
    pub const GREY: RGBColor = RGBColor(0x7f, 0x7f, 0x7f);
    pub const OLIVE: RGBColor = RGBColor(0xbc, 0xbd, 0x22);
    pub const CYAN: RGBColor = RGBColor(0x17, 0xbe, 0xcf);
    pub const BLACK: RGBColor = RGBColor(0, 0, 0);
    pub const CYCLE: [RGBColor; 10] = [
        BLUE, ORANGE, GREEN, RED, PURPLE, BROWN, PINK, GREY, OLIVE, CYAN,
    ];
    /// The forward solution, the smoothed one and the truth, in every report.
    pub const FORWARD: RGBColor = BLUE;
    pub const SMOOTHED: RGBColor = RED;
    pub const TRUTH: RGBColor = BLACK;
}

/// One named series.
#[derive(Debug, Clone)]
pub struct Series {
    pub name: String,
    pub points: Vec<(f64, f64)>,
    pub style: Style,
    /// Its colour; `None` takes the next of [`colour::CYCLE`].
    pub colour: Option<RGBColor>,
}

impl Series {
    pub fn line(name: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        Series {
            name: name.into(),
            points,
            style: Style::Line,
            colour: None,
        }
    }

    /// A thin line for a noisy series: a thick line's joins spike where it turns back on
    /// itself.
    pub fn trace(name: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        Series {
            style: Style::Trace,
            ..Series::line(name, points)
        }
    }

    pub fn dots(name: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        Series {
            style: Style::Dots,
            ..Series::line(name, points)
        }
    }

    pub fn coloured(self, c: RGBColor) -> Self {
        Series {
            colour: Some(c),
            ..self
        }
    }
}

/// A plot: series over Cartesian axes, with optional shaded x spans, horizontal reference
/// lines and labelled marks.
#[derive(Debug, Clone)]
pub struct Plot {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub series: Vec<Series>,
    /// Marked points (e.g. `start`, `end`).
    pub marks: Vec<(String, (f64, f64))>,
    /// Shaded spans of x (e.g. time without DVL bottom lock), with their legend label.
    pub bands: Vec<(f64, f64)>,
    pub band_label: String,
    /// Horizontal reference lines (bounds), dashed, with their legend label.
    pub hlines: Vec<f64>,
    pub hline_label: String,
    /// Draw the y axis downwards (depth).
    pub y_down: bool,
    /// Same scale on both axes (a map view).
    pub equal_axes: bool,
}

impl Plot {
    pub fn new(title: impl Into<String>, x_label: impl Into<String>, y_label: &str) -> Self {
        Plot {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            series: Vec::new(),
            marks: Vec::new(),
            bands: Vec::new(),
            band_label: String::new(),
            hlines: Vec::new(),
            hline_label: String::new(),
            y_down: false,
            equal_axes: false,
        }
    }

    pub fn with(mut self, s: Series) -> Self {
        self.series.push(s);
        self
    }
}

pub const WIDTH: u32 = 1000;
pub const HEIGHT: u32 = 800;

fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The font is compiled in and known to parse (a test draws a plot).
        let _ = plotters::style::register_font(FAMILY, FontStyle::Normal, FONT);
    });
}

fn draw_error<E: std::fmt::Debug>(e: E) -> PlotError {
    PlotError::Draw(format!("{e:?}"))
}

/// Draws the plot and writes it as a PNG to `out`.
pub fn write_png(plot: &Plot, out: impl Write) -> Result<(), PlotError> {
    register_font();
    let mut rgb = vec![255u8; (WIDTH * HEIGHT * 3) as usize];
    draw(
        plot,
        BitMapBackend::with_buffer(&mut rgb, (WIDTH, HEIGHT)).into_drawing_area(),
    )?;
    let mut encoder = png::Encoder::new(out, WIDTH, HEIGHT);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    // Line art compresses well with per-row adaptive filters. The default level: `Best`
    // saves 1.5 % of the size for several times the time, `Fast` triples the size.
    encoder.set_compression(png::Compression::Default);
    encoder.set_adaptive_filter(png::AdaptiveFilterType::Adaptive);
    let mut writer = encoder.write_header()?;
    writer.write_image_data(&rgb)?;
    writer.finish()?;
    Ok(())
}

/// Draws the plot as an SVG document (`<svg ...>...</svg>`) scaled to its container's
/// width, without the XML namespace (an HTML page does not need it).
pub fn to_svg(plot: &Plot) -> Result<String, PlotError> {
    register_font();
    let mut svg = String::new();
    draw(
        plot,
        SVGBackend::with_string(&mut svg, (WIDTH, HEIGHT)).into_drawing_area(),
    )?;
    let head = format!(
        "<svg width=\"{WIDTH}\" height=\"{HEIGHT}\" viewBox=\"0 0 {WIDTH} {HEIGHT}\" \
         xmlns=\"http://www.w3.org/2000/svg\">"
    );
    let responsive = format!(
        "<svg viewBox=\"0 0 {WIDTH} {HEIGHT}\" preserveAspectRatio=\"xMidYMid meet\" \
         role=\"img\">"
    );
    Ok(svg.replacen(&head, &responsive, 1))
}

/// Width of the strip right of the chart that holds the legend, pixels: the legend never
/// covers the data.
const LEGEND_PX: u32 = 190;

/// What a legend entry shows beside its name.
#[derive(Clone, Copy)]
enum Key {
    Line(RGBColor),
    Dashed(RGBColor),
    Dots(RGBColor),
    Band(RGBColor),
}

/// The legend's entries: shaded bands, the bounds, then each series.
fn legend_entries(plot: &Plot) -> Vec<(String, Key)> {
    let mut out = Vec::new();
    if !plot.bands.is_empty() {
        out.push((
            plot.band_label.clone(),
            Key::Band(RGBColor(0xc8, 0xc8, 0xc8)),
        ));
    }
    if !plot.hlines.is_empty() {
        out.push((plot.hline_label.clone(), Key::Dashed(colour::GREY)));
    }
    for (i, s) in plot.series.iter().enumerate() {
        let c = s.colour.unwrap_or(colour::CYCLE[i % colour::CYCLE.len()]);
        let key = match s.style {
            Style::Line | Style::Trace => Key::Line(c),
            Style::Dots => Key::Dots(c),
        };
        out.push((s.name.clone(), key));
    }
    out.retain(|(name, _)| !name.is_empty());
    out
}

/// Draws the legend down the strip, level with the chart's top.
fn draw_legend<DB: DrawingBackend>(
    entries: &[(String, Key)],
    area: &DrawingArea<DB, Shift>,
) -> Result<(), PlotError> {
    let mut y = 70;
    for (name, key) in entries {
        let (x, w) = (8, 26);
        match *key {
            Key::Line(c) => area.draw(&PathElement::new(
                vec![(x, y), (x + w, y)],
                c.stroke_width(3),
            )),
            Key::Dashed(c) => area.draw(&PathElement::new(
                vec![(x, y), (x + 10, y)],
                c.stroke_width(2),
            )),
            Key::Dots(c) => area.draw(&Circle::new((x + w / 2, y), 4, c.filled())),
            Key::Band(c) => area.draw(&Rectangle::new(
                [(x, y - 6), (x + w, y + 6)],
                c.mix(0.55).filled(),
            )),
        }
        .map_err(draw_error)?;
        for (k, line) in wrapped(name, LEGEND_CHARS).iter().enumerate() {
            area.draw(&Text::new(
                line.clone(),
                (x + w + 8, y - 8 + 17 * k as i32),
                (FAMILY, 15).into_font(),
            ))
            .map_err(draw_error)?;
        }
        y += 9 + 17 * wrapped(name, LEGEND_CHARS).len().max(1) as i32;
    }
    Ok(())
}

/// Characters of a legend line that fit the strip.
const LEGEND_CHARS: usize = 17;

/// `text` in lines of at most `width` characters, broken at spaces (a longer word alone).
fn wrapped(text: &str, width: usize) -> Vec<String> {
    let mut lines: Vec<String> = Vec::new();
    for word in text.split_whitespace() {
        match lines.last_mut() {
            Some(line) if line.chars().count() + 1 + word.chars().count() <= width => {
                line.push(' ');
                line.push_str(word);
            }
            _ => lines.push(word.to_string()),
        }
    }
    lines
}

fn draw<DB: DrawingBackend>(plot: &Plot, root: DrawingArea<DB, Shift>) -> Result<(), PlotError> {
    root.fill(&WHITE).map_err(draw_error)?;
    let entries = legend_entries(plot);
    let (chart_area, legend_area) = if entries.is_empty() {
        (root.clone(), None)
    } else {
        let (a, b) = root.split_horizontally(WIDTH - LEGEND_PX);
        (a, Some(b))
    };
    if let Some(area) = &legend_area {
        draw_legend(&entries, area)?;
    }
    let (x0, x1, y0, y1) = axes(plot, chart_area.dim_in_pixel().0);
    let y_range = if plot.y_down { y1..y0 } else { y0..y1 };
    let mut chart = ChartBuilder::on(&chart_area)
        .caption(&plot.title, (FAMILY, 22))
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d(x0..x1, y_range)
        .map_err(draw_error)?;
    chart
        .configure_mesh()
        .x_desc(&plot.x_label)
        .y_desc(&plot.y_label)
        .label_style((FAMILY, 14))
        .draw()
        .map_err(draw_error)?;
    if !plot.bands.is_empty() {
        let shade = RGBColor(0xc8, 0xc8, 0xc8).mix(0.55).filled();
        chart
            .draw_series(
                plot.bands
                    .iter()
                    .map(|&(a, b)| Rectangle::new([(a.max(x0), y0), (b.min(x1), y1)], shade)),
            )
            .map_err(draw_error)?;
    }
    if !plot.hlines.is_empty() {
        let style = colour::GREY.stroke_width(2);
        for &h in &plot.hlines {
            chart
                .draw_series(DashedLineSeries::new([(x0, h), (x1, h)], 8, 6, style))
                .map_err(draw_error)?;
        }
    }
    // The data units of one pixel on each axis.
    let (w_px, h_px) = chart.plotting_area().dim_in_pixel();
    let pixel = (
        (x1 - x0).abs() / f64::from(w_px.max(1)),
        (y1 - y0).abs() / f64::from(h_px.max(1)),
    );
    for (i, s) in plot.series.iter().enumerate() {
        let c = s.colour.unwrap_or(colour::CYCLE[i % colour::CYCLE.len()]);
        match s.style {
            Style::Line | Style::Trace => {
                let line = c.stroke_width(if s.style == Style::Line { 2 } else { 1 });
                chart
                    .draw_series(
                        segments(&s.points)
                            .map(move |seg| PathElement::new(apart(seg, pixel), line)),
                    )
                    .map_err(draw_error)?
            }
            Style::Dots => {
                // One dot per pixel: dense clouds (innovations) would only repaint it.
                let mut painted = std::collections::HashSet::new();
                let dots: Vec<(f64, f64)> = s
                    .points
                    .iter()
                    .filter(|(x, y)| x.is_finite() && y.is_finite())
                    .filter(|(x, y)| {
                        painted.insert(((x / pixel.0).round() as i64, (y / pixel.1).round() as i64))
                    })
                    .copied()
                    .collect();
                chart
                    .draw_series(dots.into_iter().map(|p| Circle::new(p, 2, c.filled())))
                    .map_err(draw_error)?
            }
        };
    }
    for (i, (name, (x, y))) in plot.marks.iter().enumerate() {
        // Labels stacked so that marks at the same place stay readable.
        let mark = EmptyElement::at((*x, *y))
            + Circle::new((0, 0), 6, BLACK.stroke_width(2))
            + Text::new(
                name.clone(),
                (10, 4 + 18 * i as i32),
                (FAMILY, 16).into_font(),
            );
        chart
            .draw_series(std::iter::once(mark))
            .map_err(draw_error)?;
    }
    root.present().map_err(draw_error)?;
    Ok(())
}

/// The points of a line at least 1.5 pixels apart (`pixel`: the data units of one pixel on
/// each axis), and its last. Plotters' bitmap backend draws a spike across the picture for a
/// thick line through two points on one pixel; fewer points also keep the SVG small.
fn apart(points: &[(f64, f64)], pixel: (f64, f64)) -> Vec<(f64, f64)> {
    let mut out: Vec<(f64, f64)> = Vec::with_capacity(points.len().min(4096));
    for &p in points {
        match out.last() {
            Some(q) if (p.0 - q.0).abs() < 1.5 * pixel.0 && (p.1 - q.1).abs() < 1.5 * pixel.1 => {}
            _ => out.push(p),
        }
    }
    if let (Some(&last), Some(kept)) = (points.last(), out.last_mut()) {
        *kept = last;
    }
    out
}

/// The runs of finite points between non-finite ones.
fn segments(points: &[(f64, f64)]) -> impl Iterator<Item = &[(f64, f64)]> {
    points
        .split(|(x, y)| !(x.is_finite() && y.is_finite()))
        .filter(|s| !s.is_empty())
}

/// The axes' ranges: the data's extent with a 5 % margin (a unit square around nothing),
/// widened on one axis where both must have the same scale.
fn axes(plot: &Plot, width_px: u32) -> (f64, f64, f64, f64) {
    let (mut x0, mut x1, mut y0, mut y1) = bounds(plot);
    if plot.equal_axes {
        // Widen the narrower span so that a metre is as long on both axes (the plot area is
        // about width - 90 by HEIGHT - 110 pixels).
        let aspect = (width_px.saturating_sub(90)) as f64 / (HEIGHT - 110) as f64;
        let (w, h) = (x1 - x0, y1 - y0);
        if w / h < aspect {
            let extra = (h * aspect - w) / 2.0;
            (x0, x1) = (x0 - extra, x1 + extra);
        } else {
            let extra = (w / aspect - h) / 2.0;
            (y0, y1) = (y0 - extra, y1 + extra);
        }
    }
    (x0, x1, y0, y1)
}

fn bounds(plot: &Plot) -> (f64, f64, f64, f64) {
    let all = plot
        .series
        .iter()
        .flat_map(|s| s.points.iter().copied())
        .chain(plot.marks.iter().map(|m| m.1))
        .filter(|(x, y)| x.is_finite() && y.is_finite());
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for (x, y) in all {
        (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
    }
    for &h in &plot.hlines {
        (y0, y1) = (y0.min(h), y1.max(h));
    }
    if x0 > x1 {
        return (-1.0, 1.0, -1.0, 1.0);
    }
    let pad = |a: f64, b: f64| {
        let p = (b - a) * 0.05;
        if p > 0.0 {
            p
        } else {
            (a.abs() * 0.05).max(0.5)
        }
    };
    let (px, py) = (pad(x0, x1), pad(y0, y1));
    (x0 - px, x1 + px, y0 - py, y1 + py)
}

/// At most about `max_points` of a time series (x increasing) for a picture: per bucket of
/// consecutive points its smallest and largest y in their order, so peaks and outliers stay
/// visible. A bucket holding a break (a non-finite y) keeps the break.
pub fn min_max(points: &[(f64, f64)], max_points: usize) -> Vec<(f64, f64)> {
    let buckets = (max_points / 2).max(1);
    if points.len() <= max_points {
        return points.to_vec();
    }
    let size = points.len().div_ceil(buckets);
    let mut out = Vec::with_capacity(2 * buckets + 8);
    for chunk in points.chunks(size) {
        let finite = || chunk.iter().enumerate().filter(|(_, p)| p.1.is_finite());
        let lo = finite().min_by(|a, b| a.1 .1.total_cmp(&b.1 .1));
        let hi = finite().max_by(|a, b| a.1 .1.total_cmp(&b.1 .1));
        if let (Some(lo), Some(hi)) = (lo, hi) {
            let (a, b) = if lo.0 <= hi.0 { (lo, hi) } else { (hi, lo) };
            out.push(*a.1);
            if b.0 != a.0 {
                out.push(*b.1);
            }
        }
        if let Some(gap) = chunk.iter().find(|p| !p.1.is_finite()) {
            out.push(*gap);
        }
    }
    out
}

/// About `max_points` of a cloud of dots (x increasing) for a picture: every k-th point, so
/// that the picture's density stays the data's (the extremes alone would draw a cloud as two
/// bands at its edges), and besides, in each stretch of k points, the one farthest from zero
/// when it lies beyond `outlier` (so rare large values stay visible).
pub fn sample_cloud(points: &[(f64, f64)], max_points: usize, outlier: f64) -> Vec<(f64, f64)> {
    if points.len() <= max_points {
        return points.to_vec();
    }
    let step = points.len().div_ceil(max_points.max(1));
    let mut out = Vec::with_capacity(2 * max_points);
    for chunk in points.chunks(step) {
        out.push(chunk[0]);
        let far = chunk[1..]
            .iter()
            .filter(|p| p.1.is_finite())
            .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()));
        if let Some(p) = far.filter(|p| p.1.abs() > outlier) {
            out.push(*p);
        }
    }
    out
}

/// At most about `max_points` of a track (every k-th point and the last), keeping breaks.
pub fn thin(points: &[(f64, f64)], max_points: usize) -> Vec<(f64, f64)> {
    if points.len() <= max_points {
        return points.to_vec();
    }
    let step = points.len().div_ceil(max_points.max(1));
    let mut out: Vec<(f64, f64)> = Vec::with_capacity(max_points + 2);
    for chunk in points.chunks(step) {
        out.push(chunk[0]);
        if let Some(gap) = chunk[1..]
            .iter()
            .find(|p| !(p.0.is_finite() && p.1.is_finite()))
        {
            out.push(*gap);
        }
    }
    if let Some(last) = points.last() {
        out.push(*last);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn circle() -> Plot {
        let points = (0..100)
            .map(|k| {
                let a = k as f64 * 0.0635;
                (10.0 * a.cos(), 10.0 * a.sin())
            })
            .collect();
        let mut plot = Plot::new("test", "east (m)", "north (m)")
            .with(Series::line("circle", points))
            .with(Series::dots("fixes", vec![(1.0, 2.0), (f64::NAN, 0.0)]));
        plot.marks.push(("start".into(), (10.0, 0.0)));
        plot.bands = vec![(-5.0, 0.0)];
        plot.band_label = "no bottom lock".into();
        plot.hlines = vec![-2.0, 2.0];
        plot.hline_label = "bounds".into();
        plot.equal_axes = true;
        plot
    }

    #[test]
    fn draws_a_png() {
        let mut bytes = Vec::new();
        write_png(&circle(), &mut bytes).unwrap();
        assert_eq!(&bytes[1..4], b"PNG");
        let decoder = png::Decoder::new(bytes.as_slice());
        let reader = decoder.read_info().unwrap();
        assert_eq!((reader.info().width, reader.info().height), (WIDTH, HEIGHT));
    }

    #[test]
    fn draws_an_inline_svg() {
        let svg = to_svg(&circle()).unwrap();
        assert!(
            svg.starts_with("<svg viewBox=\"0 0 1000 800\""),
            "{}",
            &svg[..80]
        );
        assert!(svg.trim_end().ends_with("</svg>"));
        assert!(!svg.contains("http"), "no namespace URL or other reference");
        for text in [
            "test",
            "circle",
            "fixes",
            "no bottom lock",
            "bounds",
            "start",
        ] {
            assert!(
                svg.contains(&format!(">\n{text}\n</text>")),
                "{text} is drawn"
            );
        }
    }

    #[test]
    fn min_max_keeps_peaks_order_and_breaks() {
        let mut points: Vec<(f64, f64)> = (0..10_000).map(|k| (k as f64, 0.0)).collect();
        points[1234].1 = 50.0;
        points[7777].1 = -30.0;
        points[5000].1 = f64::NAN;
        let thinned = min_max(&points, 200);
        assert!(thinned.len() <= 210, "{}", thinned.len());
        assert!(thinned.contains(&(1234.0, 50.0)) && thinned.contains(&(7777.0, -30.0)));
        assert!(thinned.iter().any(|p| p.1.is_nan()));
        let finite: Vec<f64> = thinned
            .iter()
            .filter(|p| p.1.is_finite())
            .map(|p| p.0)
            .collect();
        assert!(finite.windows(2).all(|w| w[0] < w[1]), "x stays in order");
        assert_eq!(min_max(&points[..100], 200), points[..100].to_vec());
    }

    #[test]
    fn a_sampled_cloud_keeps_its_spread_and_its_outliers() {
        // A deterministic cloud spread evenly over (-2, 2) (the golden-ratio sequence, even
        // in any stride), with two outliers.
        let mut points: Vec<(f64, f64)> = (0..100_000)
            .map(|k| (k as f64, (k as f64 * 0.618_033_988_75).fract() * 4.0 - 2.0))
            .collect();
        points[4242].1 = 6.0;
        points[77_777].1 = -5.0;
        let sampled = sample_cloud(&points, 2000, 3.0);
        assert!(sampled.len() <= 2010, "{}", sampled.len());
        assert!(sampled.contains(&(4242.0, 6.0)) && sampled.contains(&(77_777.0, -5.0)));
        // The inner half holds about half the dots, as in the data (min/max would hold none).
        let inner = sampled.iter().filter(|p| p.1.abs() < 1.0).count() as f64;
        assert!((inner / sampled.len() as f64 - 0.5).abs() < 0.05, "{inner}");
    }

    #[test]
    fn thin_keeps_the_ends_and_breaks() {
        let mut points: Vec<(f64, f64)> = (0..10_000).map(|k| (k as f64, -(k as f64))).collect();
        points[4321] = (f64::NAN, f64::NAN);
        let thinned = thin(&points, 500);
        assert!(thinned.len() <= 505, "{}", thinned.len());
        assert_eq!(thinned.first(), points.first());
        assert_eq!(thinned.last(), points.last());
        assert!(thinned.iter().any(|p| p.0.is_nan()));
    }
}
