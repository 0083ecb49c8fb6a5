//! What the commands say on the terminal: messages (silenced by `--quiet`), warnings (also
//! kept for the report), and progress bars (drawn only on a terminal, never under
//! `--quiet`). Errors are printed by `main` whatever the setting.

use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

static QUIET: AtomicBool = AtomicBool::new(false);

/// `--quiet`: nothing but errors from here on.
pub fn set_quiet(quiet: bool) {
    QUIET.store(quiet, Ordering::Relaxed);
}

pub fn quiet() -> bool {
    QUIET.load(Ordering::Relaxed)
}

/// A message to stderr (progress, notes, warnings), unless `--quiet`.
macro_rules! say {
    ($($arg:tt)*) => {
        if !$crate::cli::console::quiet() {
            eprintln!($($arg)*);
        }
    };
}

/// A result line to stdout (tables, the files written), unless `--quiet`.
macro_rules! out {
    ($($arg:tt)*) => {
        if !$crate::cli::console::quiet() {
            println!($($arg)*);
        }
    };
}

pub(crate) use {out, say};

/// One line of a console table: each cell padded to its width (positive: right-aligned,
/// negative: left-aligned, 0: as it is), joined by single spaces.
pub fn row<S: AsRef<str>>(cells: &[S], widths: &[i32]) -> String {
    cells
        .iter()
        .zip(widths.iter().chain(std::iter::repeat(&0)))
        .map(|(c, &w)| {
            let (c, n) = (c.as_ref(), w.unsigned_abs() as usize);
            match w {
                w if w > 0 => format!("{c:>n$}"),
                w if w < 0 => format!("{c:<n$}"),
                _ => c.to_string(),
            }
        })
        .collect::<Vec<_>>()
        .join(" ")
}

/// Prints a table: the header, then each row, laid out by [`row`].
pub fn print_table<H: AsRef<str>, S: AsRef<str>>(headers: &[H], rows: &[Vec<S>], widths: &[i32]) {
    out!("{}", row(headers, widths));
    for r in rows {
        out!("{}", row(r, widths));
    }
}

/// Says `warning: <text>` and keeps the text for the report.
pub fn warn(kept: &mut Vec<String>, text: String) {
    say!("warning: {text}");
    kept.push(text);
}

/// Whether progress may be drawn: stderr is a terminal and the run is not quiet.
fn drawing() -> bool {
    !quiet() && std::io::stderr().is_terminal()
}

/// A bar of `len` steps (`unit` names them) on stderr, hidden unless [`drawing`].
pub fn bar(len: u64, what: &str, unit: &str) -> ProgressBar {
    if !drawing() {
        return ProgressBar::hidden();
    }
    let template =
        format!("{{msg:18}} {{bar:40}} {{pos}}/{{len}} {unit}, {{elapsed}} ({{eta}} left)");
    let style =
        ProgressStyle::with_template(&template).unwrap_or_else(|_| ProgressStyle::default_bar());
    let bar = ProgressBar::new(len)
        .with_style(style)
        .with_message(what.to_string());
    bar.enable_steady_tick(Duration::from_millis(200));
    bar
}

/// A bar of bytes read, hidden unless [`drawing`] (wrap the reader with
/// [`ProgressBar::wrap_read`]).
pub fn bytes_bar(len: u64, what: &str) -> ProgressBar {
    if !drawing() {
        return ProgressBar::hidden();
    }
    let style = ProgressStyle::with_template(
        "{msg:18} {bar:40} {bytes}/{total_bytes}, {elapsed} ({eta} left)",
    )
    .unwrap_or_else(|_| ProgressStyle::default_bar());
    let bar = ProgressBar::new(len)
        .with_style(style)
        .with_message(what.to_string());
    bar.enable_steady_tick(Duration::from_millis(200));
    bar
}

/// A bar of the fraction done (0-100 %), hidden unless [`drawing`]; feed it with
/// its `set_position` (percent).
pub fn fraction_bar(what: &str) -> ProgressBar {
    if !drawing() {
        return ProgressBar::hidden();
    }
    let style =
        ProgressStyle::with_template("{msg:18} {bar:40} {percent:>3} %, {elapsed} ({eta} left)")
            .unwrap_or_else(|_| ProgressStyle::default_bar());
    let bar = ProgressBar::new(100)
        .with_style(style)
        .with_message(what.to_string());
    bar.enable_steady_tick(Duration::from_millis(200));
    bar
}

/// A spinner for work of unknown length, hidden unless [`drawing`].
pub fn spinner(what: &str) -> ProgressBar {
    if !drawing() {
        return ProgressBar::hidden();
    }
    let style = ProgressStyle::with_template("{spinner} {msg} {elapsed}")
        .unwrap_or_else(|_| ProgressStyle::default_spinner());
    let bar = ProgressBar::new_spinner()
        .with_style(style)
        .with_message(what.to_string());
    bar.enable_steady_tick(Duration::from_millis(120));
    bar
}

/// The notes and warnings of a run, said as they come and kept for its report.
#[derive(Debug, Default)]
pub struct Said {
    pub notes: Vec<String>,
    pub warnings: Vec<String>,
}

impl Said {
    /// Says `note: <text>`.
    pub fn note(&mut self, text: String) {
        say!("note: {text}");
        self.notes.push(text);
    }

    /// Says `warning: <text>`.
    pub fn warn(&mut self, text: String) {
        warn(&mut self.warnings, text);
    }

    /// Says `text` as it is (a result worth keeping, e.g. a calibration).
    pub fn info(&mut self, text: String) {
        say!("{text}");
        self.notes.push(text);
    }
}
