//! `report.html`: one self-contained page per run. Pictures are inline SVG drawn by
//! [`plots`](super::plots) (the PNGs beside it are the same plots), styles and the small
//! zoom script are inline, and nothing refers to a network or another file, so the page
//! works when mailed or opened offline.
//!
//! A command describes its page as [`Section`]s of [`Block`]s; [`Report::to_html`] renders
//! it. Nothing here knows about any command.

use super::plots::{self, Plot, PlotError};
use rayon::prelude::*;
use std::fmt::Write;

/// A page: a title, a line under it, sections in order.
#[derive(Debug, Clone, Default)]
pub struct Report {
    pub title: String,
    pub subtitle: String,
    pub sections: Vec<Section>,
    /// Shown at the foot of the page (version, settings file).
    pub footer: String,
}

/// A titled part of the page, listed in the page's contents.
#[derive(Debug, Clone)]
pub struct Section {
    pub heading: String,
    pub blocks: Vec<Block>,
}

/// A picture with its file stem (the PNG beside the page is `<stem>.png`) and a caption.
#[derive(Debug, Clone)]
pub struct Figure {
    pub stem: String,
    pub caption: String,
    pub plot: Plot,
}

/// What a section holds.
#[derive(Debug, Clone)]
pub enum Block {
    /// A paragraph of plain text.
    Text(String),
    /// A verdict, green when `good`.
    Verdict { good: bool, text: String },
    /// Name-value pairs.
    Facts(Vec<(String, String)>),
    /// A table with a header row.
    Table {
        headers: Vec<String>,
        rows: Vec<Vec<String>>,
    },
    /// Preformatted text (a report that is already laid out).
    Pre(String),
    /// Warnings (an empty list says "none").
    Warnings(Vec<String>),
    /// Boxed: a plot is far larger than the other blocks.
    Figure(Box<Figure>),
}

impl Section {
    pub fn new(heading: impl Into<String>) -> Self {
        Section {
            heading: heading.into(),
            blocks: Vec::new(),
        }
    }

    pub fn with(mut self, block: Block) -> Self {
        self.blocks.push(block);
        self
    }

    pub fn push(&mut self, block: Block) {
        self.blocks.push(block);
    }
}

impl Block {
    pub fn text(t: impl Into<String>) -> Self {
        Block::Text(t.into())
    }

    pub fn facts<K: Into<String>, V: Into<String>>(
        pairs: impl IntoIterator<Item = (K, V)>,
    ) -> Self {
        Block::Facts(
            pairs
                .into_iter()
                .map(|(k, v)| (k.into(), v.into()))
                .collect(),
        )
    }

    pub fn table<H: Into<String>>(
        headers: impl IntoIterator<Item = H>,
        rows: Vec<Vec<String>>,
    ) -> Self {
        Block::Table {
            headers: headers.into_iter().map(Into::into).collect(),
            rows,
        }
    }

    pub fn figure(stem: &str, caption: impl Into<String>, plot: Plot) -> Self {
        Block::Figure(Box::new(Figure {
            stem: stem.to_string(),
            caption: caption.into(),
            plot,
        }))
    }
}

impl Report {
    /// Every figure of the page, in order.
    pub fn figures(&self) -> impl Iterator<Item = &Figure> {
        self.sections
            .iter()
            .flat_map(|s| &s.blocks)
            .filter_map(|b| match b {
                Block::Figure(f) => Some(&**f),
                _ => None,
            })
    }

    /// The page. Figures are drawn in parallel.
    pub fn to_html(&self) -> Result<String, PlotError> {
        let figures: Vec<&Figure> = self.figures().collect();
        let svgs: Vec<String> = figures
            .par_iter()
            .map(|f| plots::to_svg(&f.plot))
            .collect::<Result<_, _>>()?;
        let mut svgs = svgs.into_iter();
        let mut html = String::with_capacity(64 * 1024 + svgs.len() * 200 * 1024);
        let title = escape(&self.title);
        let _ = write!(
            html,
            "<!doctype html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
             <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n\
             <title>{title}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n\
             <header><h1>{title}</h1><p class=\"sub\">{}</p></header>\n<nav><ol>",
            escape(&self.subtitle)
        );
        for (i, s) in self.sections.iter().enumerate() {
            let _ = write!(
                html,
                "<li><a href=\"#s{i}\">{}</a></li>",
                escape(&s.heading)
            );
        }
        html.push_str("</ol></nav>\n<main>\n");
        for (i, s) in self.sections.iter().enumerate() {
            let _ = writeln!(
                html,
                "<section id=\"s{i}\">\n<h2>{}</h2>",
                escape(&s.heading)
            );
            for b in &s.blocks {
                block_html(&mut html, b, &mut svgs);
            }
            html.push_str("</section>\n");
        }
        let _ = write!(
            html,
            "</main>\n<footer>{}</footer>\n<script>{ZOOM}</script>\n</body>\n</html>\n",
            escape(&self.footer)
        );
        Ok(html)
    }
}

fn block_html(html: &mut String, block: &Block, svgs: &mut impl Iterator<Item = String>) {
    match block {
        Block::Text(t) => {
            let _ = writeln!(html, "<p>{}</p>", escape(t));
        }
        Block::Verdict { good, text } => {
            let class = if *good { "good" } else { "bad" };
            let _ = writeln!(html, "<p class=\"verdict {class}\">{}</p>", escape(text));
        }
        Block::Facts(pairs) => {
            html.push_str("<table class=\"facts\">\n");
            for (k, v) in pairs {
                let _ = writeln!(
                    html,
                    "<tr><th>{}</th><td>{}</td></tr>",
                    escape(k),
                    escape(v)
                );
            }
            html.push_str("</table>\n");
        }
        Block::Table { headers, rows } => {
            html.push_str("<table class=\"grid\">\n<tr>");
            for h in headers {
                let _ = write!(html, "<th>{}</th>", escape(h));
            }
            html.push_str("</tr>\n");
            for row in rows {
                html.push_str("<tr>");
                for c in row {
                    let class = if is_number(c) { "" } else { " class=\"t\"" };
                    let _ = write!(html, "<td{class}>{}</td>", escape(c));
                }
                html.push_str("</tr>\n");
            }
            html.push_str("</table>\n");
        }
        Block::Pre(t) => {
            let _ = writeln!(html, "<pre>{}</pre>", escape(t));
        }
        Block::Warnings(list) if list.is_empty() => {
            html.push_str("<p class=\"verdict good\">No warnings.</p>\n");
        }
        Block::Warnings(list) => {
            html.push_str("<ul class=\"warnings\">\n");
            for w in list {
                let _ = writeln!(html, "<li>{}</li>", escape(w));
            }
            html.push_str("</ul>\n");
        }
        Block::Figure(f) => {
            let svg = svgs.next().unwrap_or_default();
            let _ = writeln!(
                html,
                "<figure id=\"{}\">{svg}<figcaption>{} <span class=\"file\">({}.png; \
                 wheel to zoom, drag to pan, double-click to reset)</span></figcaption></figure>",
                escape(&f.stem),
                escape(&f.caption),
                escape(&f.stem)
            );
        }
    }
}

/// A cell that reads as a number (right-aligned; text is left-aligned).
fn is_number(cell: &str) -> bool {
    let c = cell.trim();
    matches!(c, "-" | "N/A")
        || c.split_whitespace()
            .next()
            .is_some_and(|w| w.parse::<f64>().is_ok())
}

/// Text made safe for HTML content and attribute values.
pub fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

const STYLE: &str = "
body{font-family:system-ui,-apple-system,'Segoe UI',Roboto,sans-serif;margin:0;color:#1d2733;background:#f6f7f9;line-height:1.45}
header{background:#17324d;color:#fff;padding:18px 32px}
header h1{margin:0;font-size:1.5em}
.sub{margin:4px 0 0;opacity:.85}
nav{background:#fff;border-bottom:1px solid #d9dee4;padding:6px 32px}
nav ol{margin:0;padding:0;list-style:none;display:flex;flex-wrap:wrap;gap:4px 18px}
nav a{color:#17324d;text-decoration:none;font-size:.92em}
main{max-width:1100px;margin:0 auto;padding:8px 24px 32px}
section{background:#fff;border:1px solid #d9dee4;border-radius:6px;margin:18px 0;padding:6px 20px 14px}
h2{font-size:1.2em;border-bottom:1px solid #e4e8ec;padding-bottom:6px}
table{border-collapse:collapse;margin:8px 0;font-size:.9em}
table.grid th,table.grid td{border:1px solid #d9dee4;padding:3px 8px;text-align:right}
table.grid th{background:#eef1f4}
table.grid td:first-child,table.grid th:first-child,table.grid td.t{text-align:left}
table.facts th{text-align:left;padding:2px 16px 2px 0;font-weight:600;vertical-align:top}
table.facts td{padding:2px 0}
pre{background:#f3f5f7;padding:10px;overflow-x:auto;font-size:.85em}
.verdict{display:inline-block;padding:4px 10px;border-radius:4px;font-weight:600}
.good{background:#e3f4e6;color:#1e6b2c}
.bad{background:#fbe6e4;color:#9b2218}
ul.warnings li{color:#8a4b00;margin:3px 0}
figure{margin:14px 0}
figure svg{width:100%;height:auto;border:1px solid #e4e8ec;cursor:grab;touch-action:none}
figcaption{font-size:.9em;color:#4a5663}
.file{color:#8793a0}
footer{text-align:center;color:#6b7785;font-size:.85em;padding:0 0 24px}
";

/// Wheel to zoom, drag to pan, double-click to reset: each figure's SVG view box.
const ZOOM: &str = "
document.querySelectorAll('figure svg').forEach(function(s){
var b0=s.getAttribute('viewBox').split(' ').map(Number),b=b0.slice(),drag=null;
function set(){s.setAttribute('viewBox',b.join(' '));}
function at(e){var r=s.getBoundingClientRect();return[b[0]+(e.clientX-r.left)/r.width*b[2],b[1]+(e.clientY-r.top)/r.height*b[3]];}
s.addEventListener('wheel',function(e){e.preventDefault();var p=at(e),k=e.deltaY<0?0.8:1.25;
b=[p[0]-(p[0]-b[0])*k,p[1]-(p[1]-b[1])*k,b[2]*k,b[3]*k];set();},{passive:false});
s.addEventListener('pointerdown',function(e){drag=[e.clientX,e.clientY];s.setPointerCapture(e.pointerId);});
s.addEventListener('pointermove',function(e){if(!drag)return;var r=s.getBoundingClientRect();
b[0]-=(e.clientX-drag[0])/r.width*b[2];b[1]-=(e.clientY-drag[1])/r.height*b[3];drag=[e.clientX,e.clientY];set();});
s.addEventListener('pointerup',function(){drag=null;});
s.addEventListener('dblclick',function(){b=b0.slice();set();});
});
";

#[cfg(test)]
mod tests {
    use super::*;
    use crate::output::plots::Series;

    #[test]
    fn a_page_holds_its_sections_escaped_and_its_figures_inline() {
        let plot = Plot::new("track <1>", "east (m)", "north (m)")
            .with(Series::line("smoothed", vec![(0.0, 0.0), (1.0, 2.0)]));
        let report = Report {
            title: "run of a&b".into(),
            subtitle: "log \"x\"".into(),
            sections: vec![
                Section::new("Inputs").with(Block::table(
                    ["topic", "messages"],
                    vec![vec!["/imu".into(), "<12>".into()]],
                )),
                Section::new("Track").with(Block::figure("track", "the track", plot)),
                Section::new("Warnings").with(Block::Warnings(vec!["dvl: late".into()])),
            ],
            footer: "hindsight".into(),
        };
        let html = report.to_html().unwrap();
        assert!(html.starts_with("<!doctype html>"));
        assert!(html.contains("<title>run of a&amp;b</title>"));
        assert!(
            html.contains("<td class=\"t\">&lt;12&gt;</td>"),
            "text, left-aligned"
        );
        assert!(html.contains("<h2>Track</h2>") && html.contains("<h2>Warnings</h2>"));
        assert!(html.contains("<li>dvl: late</li>"));
        assert_eq!(html.matches("<svg ").count(), 1);
        assert!(
            html.contains(">\ntrack &lt;1&gt;\n</text>"),
            "the plot's title in the SVG, escaped"
        );
        assert_eq!(report.figures().count(), 1);
        assert!(!html.contains("http"));
    }
}
