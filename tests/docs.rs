//! The README and the book under `docs/`: every relative link resolves to a file of the
//! repository, and every `#anchor` into a page to a heading or an `id` of that page. The
//! README stays short, with the main job's command near its top.

use std::path::{Path, PathBuf};

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// The README and every Markdown page of the book.
fn pages() -> Vec<PathBuf> {
    let mut out = vec![root().join("README.md")];
    let mut stack = vec![root().join("docs")];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else if path.extension().is_some_and(|e| e == "md") {
                out.push(path);
            }
        }
    }
    out.sort();
    out
}

/// The targets of the Markdown links `[text](target)` of `text`, outside code.
fn link_targets(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut fenced = false;
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
            continue;
        }
        if fenced {
            continue;
        }
        // Inline code spans are the odd pieces between backticks.
        for (i, piece) in line.split('`').enumerate() {
            if i % 2 == 1 {
                continue;
            }
            let mut rest = piece;
            while let Some(at) = rest.find("](") {
                let after = &rest[at + 2..];
                let Some(end) = after.find(')') else { break };
                out.push(after[..end].trim().to_string());
                rest = &after[end..];
            }
        }
    }
    out
}

/// GitHub's and mdBook's anchor of a heading: lowercase, punctuation dropped, spaces as `-`.
fn slug(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter_map(|c| match c {
            ' ' => Some('-'),
            c if c.is_alphanumeric() || c == '-' || c == '_' => Some(c),
            _ => None,
        })
        .collect()
}

/// The anchors a page offers: its headings' slugs and its `id="..."` attributes.
fn anchors(text: &str) -> Vec<String> {
    let mut out: Vec<String> = text
        .lines()
        .filter(|l| l.starts_with('#'))
        .map(|l| slug(l.trim_start_matches('#')))
        .collect();
    let mut rest = text;
    while let Some(at) = rest.find("id=\"") {
        let after = &rest[at + 4..];
        let end = after.find('"').unwrap_or(0);
        out.push(after[..end].to_string());
        rest = &after[end..];
    }
    out
}

fn broken_links() -> Vec<String> {
    let mut broken = Vec::new();
    for page in pages() {
        let text = std::fs::read_to_string(&page).unwrap();
        let dir = page.parent().unwrap();
        for target in link_targets(&text) {
            if target.contains("://") || target.starts_with("mailto:") {
                continue;
            }
            let (file, anchor) = match target.split_once('#') {
                Some((f, a)) => (f, Some(a)),
                None => (target.as_str(), None),
            };
            let path = if file.is_empty() {
                page.clone()
            } else {
                dir.join(file)
            };
            let shown = page
                .strip_prefix(root())
                .unwrap_or(&page)
                .display()
                .to_string();
            if !path.exists() {
                broken.push(format!("{shown}: ({target}): no such file"));
                continue;
            }
            if let Some(anchor) = anchor.filter(|_| path.extension().is_some_and(|e| e == "md")) {
                let to = std::fs::read_to_string(&path).unwrap();
                if !anchors(&to).iter().any(|a| a == anchor) {
                    broken.push(format!("{shown}: ({target}): no such anchor"));
                }
            }
        }
    }
    broken
}

#[test]
fn every_link_of_the_readme_and_the_book_resolves() {
    let broken = broken_links();
    assert!(broken.is_empty(), "broken links:\n{}", broken.join("\n"));
}

#[test]
fn the_readme_is_short_and_starts_with_the_main_job() {
    let readme = std::fs::read_to_string(root().join("README.md")).unwrap();
    let lines: Vec<&str> = readme.lines().collect();
    assert!(lines.len() <= 220, "README.md is {} lines", lines.len());
    assert!(
        lines
            .iter()
            .take(40)
            .any(|l| l.contains("reconstruct sample-logs/") && l.contains("--out")),
        "the main job's command is not in the README's first 40 lines"
    );
    // And the README's links reach into the book.
    assert!(link_targets(&readme).iter().any(|t| t.starts_with("docs/")));
}

#[test]
fn the_link_checker_sees_links_and_anchors() {
    let text = "see [a](x.md#b) and `[no](code.md)`\n```\n[no](fenced.md)\n```\n[c](y.md)";
    assert_eq!(link_targets(text), ["x.md#b", "y.md"]);
    assert_eq!(
        slug("Self-tuning, calibration and `--quiet`"),
        "self-tuning-calibration-and---quiet"
    );
    assert!(anchors("# A b\n<a id=\"lee2016\"></a>").contains(&"lee2016".to_string()));
    // The book has pages to check.
    assert!(pages().len() > 10);
}
