//! PNG plots of tracks (plotters, drawn in memory, encoded with `png`, written through the
//! caller's staging like every other output). Text uses DejaVu Sans Mono, shipped in
//! `assets/fonts` (Bitstream Vera licence, next to it), so no system font library is needed.

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

/// One named line.
pub struct Series<'a> {
    pub name: &'a str,
    pub points: Vec<(f64, f64)>,
}

/// A track plot.
pub struct TrackPlot<'a> {
    pub title: &'a str,
    pub x_label: &'a str,
    pub y_label: &'a str,
    pub series: Vec<Series<'a>>,
    /// Marked points (e.g. `start`, `end`).
    pub marks: Vec<(&'a str, (f64, f64))>,
    /// Draw the y axis downwards (depth).
    pub y_down: bool,
    /// Same scale on both axes (a map view).
    pub equal_axes: bool,
}

const WIDTH: u32 = 1000;
const HEIGHT: u32 = 800;

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
pub fn write_png(plot: &TrackPlot<'_>, out: impl Write) -> Result<(), PlotError> {
    register_font();
    let mut rgb = vec![255u8; (WIDTH * HEIGHT * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (WIDTH, HEIGHT)).into_drawing_area();
        root.fill(&WHITE).map_err(draw_error)?;
        let (mut x0, mut x1, mut y0, mut y1) = bounds(plot);
        if plot.equal_axes {
            // Widen the narrower span so that a metre is as long on both axes (the plot
            // area is about WIDTH - 90 by HEIGHT - 110 pixels).
            let aspect = (WIDTH - 90) as f64 / (HEIGHT - 110) as f64;
            let (w, h) = (x1 - x0, y1 - y0);
            if w / h < aspect {
                let extra = (h * aspect - w) / 2.0;
                (x0, x1) = (x0 - extra, x1 + extra);
            } else {
                let extra = (w / aspect - h) / 2.0;
                (y0, y1) = (y0 - extra, y1 + extra);
            }
        }
        let y_range = if plot.y_down { y1..y0 } else { y0..y1 };
        let mut chart = ChartBuilder::on(&root)
            .caption(plot.title, (FAMILY, 22))
            .margin(15)
            .x_label_area_size(45)
            .y_label_area_size(70)
            .build_cartesian_2d(x0..x1, y_range)
            .map_err(draw_error)?;
        chart
            .configure_mesh()
            .x_desc(plot.x_label)
            .y_desc(plot.y_label)
            .label_style((FAMILY, 14))
            .draw()
            .map_err(draw_error)?;
        for (i, s) in plot.series.iter().enumerate() {
            let colour = Palette99::pick(i).to_rgba();
            chart
                .draw_series(LineSeries::new(
                    s.points.iter().copied(),
                    colour.stroke_width(2),
                ))
                .map_err(draw_error)?
                .label(s.name)
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(3))
                });
        }
        for (i, (name, (x, y))) in plot.marks.iter().enumerate() {
            // Labels stacked so that marks at the same place stay readable.
            let mark = EmptyElement::at((*x, *y))
                + Circle::new((0, 0), 6, BLACK.stroke_width(2))
                + Text::new(
                    name.to_string(),
                    (10, 4 + 18 * i as i32),
                    (FAMILY, 16).into_font(),
                );
            chart
                .draw_series(std::iter::once(mark))
                .map_err(draw_error)?;
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font((FAMILY, 15))
            .position(SeriesLabelPosition::UpperRight)
            .draw()
            .map_err(draw_error)?;
        root.present().map_err(draw_error)?;
    }
    let mut encoder = png::Encoder::new(out, WIDTH, HEIGHT);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder.write_header()?;
    writer.write_image_data(&rgb)?;
    writer.finish()?;
    Ok(())
}

/// The data's extent with a 5 % margin (a unit square around nothing).
fn bounds(plot: &TrackPlot<'_>) -> (f64, f64, f64, f64) {
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
    if x0 > x1 {
        return (-1.0, 1.0, -1.0, 1.0);
    }
    let pad = |a: f64, b: f64| ((b - a) * 0.05).max(0.5);
    let (px, py) = (pad(x0, x1), pad(y0, y1));
    (x0 - px, x1 + px, y0 - py, y1 + py)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn draws_a_png() {
        let plot = TrackPlot {
            title: "test",
            x_label: "east (m)",
            y_label: "north (m)",
            series: vec![Series {
                name: "circle",
                points: (0..100)
                    .map(|k| {
                        let a = k as f64 * 0.0635;
                        (10.0 * a.cos(), 10.0 * a.sin())
                    })
                    .collect(),
            }],
            marks: vec![("start", (10.0, 0.0))],
            y_down: false,
            equal_axes: true,
        };
        let mut bytes = Vec::new();
        write_png(&plot, &mut bytes).unwrap();
        assert_eq!(&bytes[1..4], b"PNG");
        let decoder = png::Decoder::new(bytes.as_slice());
        let reader = decoder.read_info().unwrap();
        assert_eq!((reader.info().width, reader.info().height), (WIDTH, HEIGHT));
    }
}
