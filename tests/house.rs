//! House rules read from the source itself (parsed with `syn`, so that strings, comments
//! and macros are told apart):
//! - no function of `src` is longer than [`MAX_FUNCTION_LINES`], but those listed in
//!   [`LONG_BY_NATURE`] with the reason each is;
//! - no string of the library names a command-line flag (`--name`): the library says what is
//!   wrong, the CLI says which flag to give;
//! - clap is used by the CLI only.
//!
//! `cargo test --release --test all house::` runs them; CI runs them with the rest.

use proc_macro2::{TokenStream, TokenTree};
use std::path::{Path, PathBuf};
use syn::visit::{self, Visit};

/// Lines of a function, from `fn` to its closing brace.
const MAX_FUNCTION_LINES: usize = 100;

/// Functions over the limit by their nature: (file, function, why). A listed function that
/// is no longer long fails the check too, so that the list stays true.
const LONG_BY_NATURE: &[(&str, &str, &str)] = &[];

/// The CLI's own files: the only place flags are named and clap is used.
fn in_cli(path: &Path) -> bool {
    path.starts_with("src/cli") || path == Path::new("src/main.rs")
}

/// Every `.rs` file under `dir`, sorted, as paths relative to the crate.
fn rust_files(dir: &str) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![PathBuf::from(dir)];
    while let Some(d) = stack.pop() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join(&d);
        for entry in std::fs::read_dir(&root).unwrap_or_else(|e| panic!("{d:?}: {e}")) {
            let name = entry.unwrap().file_name();
            let rel = d.join(&name);
            if root.join(&name).is_dir() {
                stack.push(rel);
            } else if rel.extension().is_some_and(|e| e == "rs") {
                out.push(rel);
            }
        }
    }
    out.sort();
    out
}

fn parse(path: &Path) -> syn::File {
    let text = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join(path))
        .unwrap_or_else(|e| panic!("{path:?}: {e}"));
    syn::parse_file(&text).unwrap_or_else(|e| panic!("{path:?} does not parse: {e}"))
}

/// Functions and their lengths, in lines.
#[derive(Default)]
struct Functions {
    found: Vec<(String, usize, usize)>,
}

impl Functions {
    fn add(&mut self, name: &syn::Ident, fn_token: &syn::token::Fn, body: &syn::Block) {
        let first = fn_token.span.start().line;
        let last = body.brace_token.span.close().end().line;
        self.found.push((name.to_string(), first, last + 1 - first));
    }
}

impl<'ast> Visit<'ast> for Functions {
    fn visit_item_fn(&mut self, f: &'ast syn::ItemFn) {
        self.add(&f.sig.ident, &f.sig.fn_token, &f.block);
        visit::visit_item_fn(self, f);
    }
    fn visit_impl_item_fn(&mut self, f: &'ast syn::ImplItemFn) {
        self.add(&f.sig.ident, &f.sig.fn_token, &f.block);
        visit::visit_impl_item_fn(self, f);
    }
    fn visit_trait_item_fn(&mut self, f: &'ast syn::TraitItemFn) {
        if let Some(body) = &f.default {
            self.add(&f.sig.ident, &f.sig.fn_token, body);
        }
        visit::visit_trait_item_fn(self, f);
    }
}

fn long_functions(dirs: &[&str], limit: usize) -> Vec<String> {
    dirs.iter()
        .flat_map(|dir| rust_files(dir))
        .flat_map(|path| {
            let mut functions = Functions::default();
            functions.visit_file(&parse(&path));
            functions
                .found
                .into_iter()
                .filter(move |(_, _, lines)| *lines > limit)
                .map(move |(name, line, lines)| {
                    format!("{}:{line} `{name}`: {lines} lines", path.display())
                })
        })
        .collect()
}

#[test]
fn no_function_of_src_is_over_the_limit_but_those_listed() {
    let long = long_functions(&["src"], MAX_FUNCTION_LINES);
    let listed = |l: &String| {
        LONG_BY_NATURE.iter().any(|(file, name, _)| {
            l.starts_with(&format!("{file}:")) && l.contains(&format!("`{name}`"))
        })
    };
    let unlisted: Vec<&String> = long.iter().filter(|l| !listed(l)).collect();
    assert!(
        unlisted.is_empty(),
        "functions over {MAX_FUNCTION_LINES} lines (split them, or list them with a reason):\n{}",
        unlisted
            .iter()
            .map(|l| l.as_str())
            .collect::<Vec<_>>()
            .join("\n")
    );
    for (file, name, why) in LONG_BY_NATURE {
        assert!(
            !why.is_empty(),
            "{file} `{name}` is listed without a reason"
        );
        assert!(
            long.iter()
                .any(|l| l.starts_with(&format!("{file}:")) && l.contains(&format!("`{name}`"))),
            "{file} `{name}` is listed as long but is not: take it off the list"
        );
    }
}

/// Whether `text` names a flag: `--` then a lowercase letter, at the start or after a
/// character that cannot be part of a word or an arrow (`-->`).
fn names_a_flag(text: &str) -> bool {
    let bytes = text.as_bytes();
    (0..bytes.len().saturating_sub(2)).any(|i| {
        bytes[i] == b'-'
            && bytes[i + 1] == b'-'
            && bytes[i + 2].is_ascii_lowercase()
            && (i == 0 || !(bytes[i - 1].is_ascii_alphanumeric() || bytes[i - 1] == b'-'))
    })
}

/// String literals that name a flag, with their lines; doc comments are not strings.
#[derive(Default)]
struct FlagStrings {
    found: Vec<(usize, String)>,
}

impl FlagStrings {
    fn check(&mut self, line: usize, text: String) {
        if names_a_flag(&text) {
            self.found.push((line, text));
        }
    }

    /// The strings of a macro's arguments (`format!`, `write!`, ...), which syn leaves as
    /// tokens.
    fn tokens(&mut self, tokens: TokenStream) {
        for tree in tokens {
            match tree {
                TokenTree::Group(g) => self.tokens(g.stream()),
                TokenTree::Literal(lit) => {
                    if let syn::Lit::Str(s) = syn::Lit::new(lit.clone()) {
                        self.check(lit.span().start().line, s.value());
                    }
                }
                _ => {}
            }
        }
    }
}

impl<'ast> Visit<'ast> for FlagStrings {
    fn visit_attribute(&mut self, a: &'ast syn::Attribute) {
        match &a.meta {
            _ if a.path().is_ident("doc") => {}
            // `#[error("...")]` and the like: tokens to syn.
            syn::Meta::List(list) => self.tokens(list.tokens.clone()),
            _ => visit::visit_attribute(self, a),
        }
    }
    fn visit_lit_str(&mut self, s: &'ast syn::LitStr) {
        self.check(s.span().start().line, s.value());
    }
    fn visit_macro(&mut self, m: &'ast syn::Macro) {
        self.tokens(m.tokens.clone());
    }
}

#[test]
fn the_library_names_no_flag() {
    let found: Vec<String> = rust_files("src")
        .into_iter()
        .filter(|p| !in_cli(p))
        .flat_map(|path| {
            let mut strings = FlagStrings::default();
            strings.visit_file(&parse(&path));
            strings
                .found
                .into_iter()
                .map(move |(line, text)| format!("{}:{line}: {text:?}", path.display()))
        })
        .collect();
    assert!(
        found.is_empty(),
        "strings outside src/cli that name a command-line flag (give the library a typed hint \
         and let the CLI name the flag):\n{}",
        found.join("\n")
    );
}

/// Paths and imports that start at the `clap` crate, also in attributes (`derive`) and
/// macros, which syn leaves as tokens.
#[derive(Default)]
struct ClapUses {
    lines: Vec<usize>,
}

impl ClapUses {
    fn tokens(&mut self, tokens: TokenStream) {
        for tree in tokens {
            match tree {
                TokenTree::Group(g) => self.tokens(g.stream()),
                TokenTree::Ident(i) if i == "clap" => self.lines.push(i.span().start().line),
                _ => {}
            }
        }
    }
}

impl<'ast> Visit<'ast> for ClapUses {
    fn visit_attribute(&mut self, a: &'ast syn::Attribute) {
        if let syn::Meta::List(list) = &a.meta {
            self.tokens(list.tokens.clone());
        }
        visit::visit_attribute(self, a);
    }
    fn visit_macro(&mut self, m: &'ast syn::Macro) {
        self.tokens(m.tokens.clone());
        visit::visit_macro(self, m);
    }
    fn visit_use_tree(&mut self, t: &'ast syn::UseTree) {
        if let syn::UseTree::Path(p) = t {
            if p.ident == "clap" {
                self.lines.push(p.ident.span().start().line);
            }
        }
        visit::visit_use_tree(self, t);
    }
    fn visit_path(&mut self, p: &'ast syn::Path) {
        if p.segments.first().is_some_and(|s| s.ident == "clap") {
            self.lines.push(p.segments[0].ident.span().start().line);
        }
        visit::visit_path(self, p);
    }
}

#[test]
fn clap_is_used_by_the_cli_only() {
    let found: Vec<String> = rust_files("src")
        .into_iter()
        .filter(|p| !in_cli(p))
        .flat_map(|path| {
            let mut uses = ClapUses::default();
            uses.visit_file(&parse(&path));
            uses.lines
                .into_iter()
                .map(move |line| format!("{}:{line}", path.display()))
        })
        .collect();
    assert!(
        found.is_empty(),
        "clap used outside src/cli and main.rs (the CLI maps its arguments to the library's \
         types):\n{}",
        found.join("\n")
    );
}

#[test]
fn the_checks_see_what_they_look_for() {
    // A check that finds nothing because it looks at nothing would pass: each must see the
    // things it counts.
    assert!(names_a_flag("give --origin LAT,LON"));
    assert!(names_a_flag("--skip-unknown"));
    assert!(!names_a_flag("a -- b"));
    assert!(!names_a_flag("x-->y"));
    assert!(!names_a_flag("well-known"));
    let mut strings = FlagStrings::default();
    strings.visit_file(
        &syn::parse_file(
            r#"/// Give `--doc`: not a string.
            #[error("--in-attribute")]
            fn f() -> String { let _ = "--plain"; format!("{} --in-macro", 1) }"#,
        )
        .unwrap(),
    );
    let texts: Vec<&str> = strings.found.iter().map(|(_, t)| t.as_str()).collect();
    assert_eq!(texts, ["--in-attribute", "--plain", "{} --in-macro"]);
    let mut uses = ClapUses::default();
    uses.visit_file(
        &syn::parse_file(
            "use clap::Parser; #[derive(clap::ValueEnum)] enum E { A } fn f() { clap::x(); }",
        )
        .unwrap(),
    );
    assert_eq!(uses.lines.len(), 3);
    let mut functions = Functions::default();
    functions.visit_file(
        &syn::parse_file("fn a() {\n\n}\nimpl S { fn b(&self) {\n fn c() {}\n}\n}").unwrap(),
    );
    let lengths: Vec<(&str, usize)> = functions
        .found
        .iter()
        .map(|(n, _, l)| (n.as_str(), *l))
        .collect();
    assert_eq!(lengths, [("a", 3), ("b", 3), ("c", 1)]);
    // And the core has functions to measure.
    assert!(rust_files("src/recon").len() > 10);
}
