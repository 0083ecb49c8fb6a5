//! progress bars only on a terminal, and `--quiet` leaves only errors.

use crate::common;
use common::{hindsight, scratch_dir, stderr, SAMPLE};
use std::process::Command;

/// What a progress bar or spinner writes: a carriage return to redraw the line, an escape
/// sequence to clear it, or the bar's characters.
fn has_progress(text: &str) -> bool {
    text.contains('\r') || text.contains('\u{1b}') || text.contains('░') || text.contains('█')
}

#[test]
fn no_progress_when_stderr_is_not_a_terminal() {
    let out = scratch_dir("console-pipe");
    let run = hindsight(&["reconstruct", SAMPLE, "--out", out.to_str().unwrap()]);
    assert!(run.status.success(), "{}", stderr(&run));
    let (said, printed) = (
        stderr(&run),
        String::from_utf8_lossy(&run.stdout).into_owned(),
    );
    assert!(
        said.contains("forward filter") && printed.contains("wrote"),
        "{said}"
    );
    assert!(!has_progress(&said), "progress drawn into a pipe:\n{said}");
    assert!(!has_progress(&printed));
}

#[test]
fn quiet_prints_nothing_but_errors() {
    let out = scratch_dir("console-quiet");
    let run = hindsight(&[
        "reconstruct",
        SAMPLE,
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(run.status.success(), "{}", stderr(&run));
    assert_eq!(stderr(&run), "", "stderr under --quiet");
    assert_eq!(
        String::from_utf8_lossy(&run.stdout),
        "",
        "stdout under --quiet"
    );
    for file in [
        "trajectory.parquet",
        "summary.json",
        "report.html",
        "track.png",
    ] {
        assert!(out.join(file).is_file(), "{file} is still written");
    }
    // An error is still said, with its exit status.
    let missing = out.join("missing.mcap");
    let run = hindsight(&["-q", "reconstruct", missing.to_str().unwrap(), "--out", "x"]);
    assert_eq!(run.status.code(), Some(3));
    assert!(
        stderr(&run).starts_with("error: reading"),
        "{}",
        stderr(&run)
    );
    assert_eq!(String::from_utf8_lossy(&run.stdout), "");
}

/// `script` (util-linux) runs a command on a pseudo-terminal; without it, skipped.
fn on_a_terminal(command: &str) -> Option<String> {
    let script = ["/usr/bin/script", "/bin/script"]
        .into_iter()
        .find(|p| std::path::Path::new(p).is_file())?;
    let out = Command::new(script)
        .args(["-qfec", command, "/dev/null"])
        .output()
        .expect("script runs");
    assert!(out.status.success(), "{}", stderr(&out));
    Some(String::from_utf8_lossy(&out.stdout).into_owned())
}

#[test]
fn progress_draws_on_a_terminal_unless_quiet() {
    let out = scratch_dir("console-tty");
    let command = format!(
        "{} reconstruct {SAMPLE} --out {} > /dev/null",
        env!("CARGO_BIN_EXE_hindsight"),
        out.display()
    );
    let Some(terminal) = on_a_terminal(&command) else {
        eprintln!("skipped: no `script` to make a terminal");
        return;
    };
    assert!(
        has_progress(&terminal),
        "no progress on a terminal:\n{terminal}"
    );
    assert!(terminal.contains("reading the log") && terminal.contains("smoother"));
    let quiet = on_a_terminal(&format!("{command} --quiet")).unwrap();
    assert_eq!(quiet, "", "--quiet on a terminal");
}
