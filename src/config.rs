//! One configuration system for every command that takes a settings file (`reconstruct`,
//! `batch` and `study` share reconstruct's; `attitude`; `identify`).
//!
//! Each command's settings are a [`Section`]: a serde type with a default for every key,
//! and its documented defaults ([`Section::DEFAULT_TOML`], printed by `hindsight config
//! SECTION`), which are the one place a key is documented. A test reads every section's
//! documented text back to its defaults. A file is parsed by [`load`] (or laid over a
//! preset by [`load_over`]): unknown keys and wrong types are refused naming the key and its
//! line, and every value is then checked against its range ([`Range`], [`check_ranges`]).
//! The library reads no files: the caller hands over the text and names the file in its
//! errors.

use serde::{de::DeserializeOwned, Serialize};
use std::collections::BTreeSet;

/// A command's settings.
pub trait Section: Serialize + DeserializeOwned + Default {
    /// The name `hindsight config` knows the section by.
    const NAME: &'static str;
    /// Every key with its default, unit and meaning, as TOML (it parses to the defaults).
    const DEFAULT_TOML: &'static str;

    /// Checks every value: the first one out of its range is the error.
    fn check(&self) -> Result<(), ConfigError>;

    /// Told which keys (dotted, `dvl.sigma_m_s`) the file gave, after parsing. Sections
    /// that treat given keys differently from defaulted ones (self-tuning keeps a given
    /// figure) record them here.
    fn given(&mut self, _keys: &BTreeSet<String>) {}

    /// Parses a file's text over the defaults ([`load`]).
    fn from_toml(text: &str) -> Result<Self, ConfigError> {
        load(text)
    }
}

/// Why a configuration cannot be used.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ConfigError {
    /// Not TOML, an unknown key or a wrong type (the parser's text names key and line).
    #[error("{message}")]
    Toml {
        /// The section's [`Section::NAME`].
        section: &'static str,
        message: String,
    },
    /// A value out of its range.
    #[error("`{key}`{}: {reason}", value.as_ref().map(|v| format!(" = {v}")).unwrap_or_default())]
    Bad {
        key: &'static str,
        value: Option<String>,
        reason: String,
    },
}

impl ConfigError {
    /// A value out of its range, shown with the value.
    pub fn bad(key: &'static str, value: impl std::fmt::Display, reason: &str) -> ConfigError {
        ConfigError::Bad {
            key,
            value: Some(value.to_string()),
            reason: reason.to_string(),
        }
    }

    /// A setting that cannot be used, where the value says little (a matrix, a list).
    pub fn bad_key(key: &'static str, reason: &str) -> ConfigError {
        ConfigError::Bad {
            key,
            value: None,
            reason: reason.to_string(),
        }
    }
}

/// Parses a file's text over the section's defaults: every key is optional, unknown keys
/// are refused, and every value is checked.
pub fn load<T: Section>(text: &str) -> Result<T, ConfigError> {
    let mut config: T = toml::from_str(text).map_err(toml_error::<T>)?;
    finish(&mut config, text)?;
    Ok(config)
}

/// Parses a file's text over a base (a preset): the keys the file gives replace the base's,
/// table by table; the base's other keys stay.
pub fn load_over<T: Section>(base: &T, text: &str) -> Result<T, ConfigError> {
    // Parsed alone first, so that unknown keys and wrong types are named with their line.
    toml::from_str::<T>(text).map_err(toml_error::<T>)?;
    let given: toml::Table = toml::from_str(text).map_err(toml_error::<T>)?;
    let mut merged = toml::Table::try_from(base).map_err(toml_error::<T>)?;
    merge(&mut merged, given);
    let mut config: T = merged.try_into().map_err(toml_error::<T>)?;
    finish(&mut config, text)?;
    Ok(config)
}

fn finish<T: Section>(config: &mut T, text: &str) -> Result<(), ConfigError> {
    let table: toml::Table = toml::from_str(text).map_err(toml_error::<T>)?;
    let mut keys = BTreeSet::new();
    dotted_keys(&table, "", &mut keys);
    config.given(&keys);
    config.check()
}

fn toml_error<T: Section>(e: impl std::fmt::Display) -> ConfigError {
    ConfigError::Toml {
        section: T::NAME,
        message: toml_one_line(&e.to_string()),
    }
}

/// A TOML error on one line: its place ("TOML parse error at line 8, column 5"), the line it
/// quotes, and what is wrong, without the caret that toml draws beneath.
pub fn toml_one_line(text: &str) -> String {
    let quoted_source = |l: &str| {
        let (n, rest) = l.split_once(" |")?;
        n.trim()
            .parse::<u64>()
            .ok()
            .map(|_| rest.trim().to_string())
    };
    let mut lines = text
        .lines()
        .map(str::trim_end)
        .filter(|l| !l.trim().is_empty());
    let mut head = lines
        .next()
        .unwrap_or_default()
        .trim_end_matches(':')
        .to_string();
    let mut rest = Vec::new();
    for l in lines {
        if let Some(source) = quoted_source(l) {
            head = format!("{head} (`{source}`)");
        } else if !l.trim_start().starts_with('|') {
            rest.push(l.trim());
        }
    }
    if rest.is_empty() {
        head
    } else {
        format!("{head}: {}", rest.join("; "))
    }
}

/// Every leaf key of a table, dotted (`section.key`); arrays are leaves.
fn dotted_keys(table: &toml::Table, prefix: &str, keys: &mut BTreeSet<String>) {
    for (key, value) in table {
        let path = if prefix.is_empty() {
            key.clone()
        } else {
            format!("{prefix}.{key}")
        };
        match value {
            toml::Value::Table(t) => dotted_keys(t, &path, keys),
            _ => {
                keys.insert(path);
            }
        }
    }
}

/// The key of the first number in `value` that is not finite, dotted as a TOML file writes
/// it (`segment[3].lane_s`; arrays counted from 1): a file may write `nan` and `inf`.
pub fn non_finite_key(value: &impl Serialize) -> Option<String> {
    fn find(value: &toml::Value, at: String) -> Option<String> {
        let within = |key: &dyn std::fmt::Display| match at.is_empty() {
            true => key.to_string(),
            false => format!("{at}.{key}"),
        };
        match value {
            toml::Value::Float(x) => (!x.is_finite()).then_some(at),
            toml::Value::Table(t) => t.iter().find_map(|(k, v)| find(v, within(k))),
            toml::Value::Array(a) => {
                (a.iter().enumerate()).find_map(|(i, v)| find(v, format!("{at}[{}]", i + 1)))
            }
            _ => None,
        }
    }
    find(&toml::Value::try_from(value).ok()?, String::new())
}

/// Lays `given` over `base`, table by table.
fn merge(base: &mut toml::Table, given: toml::Table) {
    for (key, value) in given {
        match (base.get_mut(&key), value) {
            (Some(toml::Value::Table(b)), toml::Value::Table(g)) => merge(b, g),
            (_, value) => {
                base.insert(key, value);
            }
        }
    }
}

/// The range a configuration value must lie in.
#[derive(Debug, Clone, Copy)]
pub enum Range {
    /// Finite and above zero.
    Positive,
    /// Finite, zero or above.
    NonNegative,
    /// In (0, 1).
    OpenProbability,
    /// In (0, 1].
    Probability,
    /// In `[low, high]`, and why.
    Within(f64, f64, &'static str),
    /// At least this, and why.
    AtLeast(f64, &'static str),
    /// Finite and above this, and why.
    Above(f64, &'static str),
}

impl Range {
    /// Whether `x` lies in the range (NaN never does).
    pub fn holds(self, x: f64) -> bool {
        match self {
            Range::Positive => x.is_finite() && x > 0.0,
            Range::NonNegative => x.is_finite() && x >= 0.0,
            Range::OpenProbability => x > 0.0 && x < 1.0,
            Range::Probability => x > 0.0 && x <= 1.0,
            Range::Within(low, high, _) => x.is_finite() && (low..=high).contains(&x),
            Range::AtLeast(low, _) => x >= low,
            Range::Above(low, _) => x.is_finite() && x > low,
        }
    }

    /// What a value out of the range is told.
    pub fn reason(self) -> &'static str {
        match self {
            Range::Positive => "must be a positive number",
            Range::NonNegative => "must be zero or positive",
            Range::OpenProbability => "must be a probability in (0, 1)",
            Range::Probability => "must be a probability in (0, 1]",
            Range::Within(_, _, why) | Range::AtLeast(_, why) | Range::Above(_, why) => why,
        }
    }
}

/// Checks each (key, value, range) in turn: the first value out of its range is the error.
pub fn check_ranges(
    rules: impl IntoIterator<Item = (&'static str, f64, Range)>,
) -> Result<(), ConfigError> {
    for (key, value, range) in rules {
        if !range.holds(value) {
            return Err(ConfigError::bad(key, value, range.reason()));
        }
    }
    Ok(())
}

/// `[("section.key", section.key), ...]`: each value with its dotted key, the key spelled
/// from the value's own path (`keyed!(self.dvl => dvl; sigma_m_s, max_altitude_m)`), so
/// that the two cannot disagree.
macro_rules! keyed {
    ($values:expr => $section:ident; $($key:ident),+ $(,)?) => {
        [$((concat!(stringify!($section), ".", stringify!($key)), $values.$key)),+]
    };
}
pub(crate) use keyed;

/// A struct whose every field gives its default beside it (`name: Type = default,`), and
/// `Default` made of them. Attributes and derives are given as for any struct.
macro_rules! with_defaults {
    (
        $(#[$meta:meta])*
        $vis:vis struct $name:ident {
            $($(#[$field_meta:meta])* $field_vis:vis $field:ident: $ty:ty = $default:expr),* $(,)?
        }
    ) => {
        $(#[$meta])*
        $vis struct $name {
            $($(#[$field_meta])* $field_vis $field: $ty),*
        }

        impl Default for $name {
            fn default() -> Self {
                $name { $($field: $default),* }
            }
        }
    };
}
pub(crate) use with_defaults;

/// Every key given the same range.
pub fn all(
    range: Range,
    keys: impl IntoIterator<Item = (&'static str, f64)>,
) -> impl Iterator<Item = (&'static str, f64, Range)> {
    keys.into_iter()
        .map(move |(key, value)| (key, value, range))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::attitude::config::AttitudeConfig;
    use crate::identify::config::IdentifyConfig;
    use crate::recon::config::Config;

    #[test]
    fn a_non_finite_number_is_found_by_its_key() {
        #[derive(Serialize)]
        struct Inner {
            profile: Vec<[f64; 2]>,
        }
        #[derive(Serialize)]
        struct File {
            rate_hz: f64,
            seabed: Inner,
        }
        let file = |x: f64| File {
            rate_hz: 1.0,
            seabed: Inner {
                profile: vec![[0.0, 1.0], [2.0, x]],
            },
        };
        assert_eq!(non_finite_key(&file(3.0)), None);
        for x in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            let key = non_finite_key(&file(x));
            assert_eq!(key.as_deref(), Some("seabed.profile[2][2]"), "{x}");
        }
    }

    /// Every section's documented text parses back to its defaults, and so does an empty
    /// file.
    fn documented_defaults_are_the_defaults<T: Section + PartialEq + std::fmt::Debug>() {
        assert_eq!(
            load::<T>(T::DEFAULT_TOML).unwrap(),
            T::default(),
            "{}",
            T::NAME
        );
        assert_eq!(load::<T>("").unwrap(), T::default(), "{}", T::NAME);
        assert_eq!(
            load_over::<T>(&T::default(), T::DEFAULT_TOML).unwrap(),
            T::default(),
            "{}",
            T::NAME
        );
    }

    #[test]
    fn every_sections_documented_defaults_are_its_defaults() {
        documented_defaults_are_the_defaults::<Config>();
        documented_defaults_are_the_defaults::<AttitudeConfig>();
        documented_defaults_are_the_defaults::<IdentifyConfig>();
    }

    /// An unknown key is refused in every section, naming the key and its line; a value out
    /// of range names its dotted key and the value.
    #[test]
    fn unknown_keys_and_bad_values_are_named() {
        fn refused<T: Section + std::fmt::Debug>(text: &str, named: &[&str]) {
            let e = load::<T>(text).unwrap_err().to_string();
            for n in named {
                assert!(e.contains(n), "{}: {e:?} lacks {n:?}", T::NAME);
            }
        }
        refused::<Config>("[dvl]\n\nsigma = 0.1\n", &["sigma", "line 3"]);
        refused::<AttitudeConfig>("[ekf]\nprocess_nois = 1\n", &["process_nois", "line 2"]);
        refused::<IdentifyConfig>("[noise]\ndepth = 0.02\n", &["depth", "line 2"]);
        refused::<Config>("[dvl]\nsigma_m_s = -1.0\n", &["`dvl.sigma_m_s` = -1"]);
        refused::<AttitudeConfig>("[cf]\nkp = -1.0\n", &["`cf.kp` = -1"]);
        refused::<IdentifyConfig>("[noise]\ndepth_m = 0.0\n", &["`noise.depth_m` = 0"]);
        // A key of a section that exists in another section's file is unknown here.
        refused::<IdentifyConfig>("[cf]\nkp = 1.0\n", &["cf"]);
    }

    #[test]
    fn the_given_keys_are_dotted_leaves() {
        let table: toml::Table =
            toml::from_str("a = 1\n[b]\nc = [1, 2]\n[b.d]\ne = \"x\"\n").unwrap();
        let mut keys = BTreeSet::new();
        dotted_keys(&table, "", &mut keys);
        let keys: Vec<&str> = keys.iter().map(String::as_str).collect();
        assert_eq!(keys, ["a", "b.c", "b.d.e"]);
    }

    #[test]
    fn ranges_hold_and_refuse() {
        assert!(Range::Positive.holds(1e-300) && !Range::Positive.holds(0.0));
        assert!(!Range::Positive.holds(f64::NAN) && !Range::Positive.holds(f64::INFINITY));
        assert!(Range::NonNegative.holds(0.0) && !Range::NonNegative.holds(-1e-300));
        assert!(!Range::OpenProbability.holds(1.0) && Range::Probability.holds(1.0));
        assert!(
            Range::Within(-1.0, 1.0, "").holds(1.0) && !Range::Within(-1.0, 1.0, "").holds(1.5)
        );
        assert!(!Range::AtLeast(2.0, "").holds(f64::NAN));
        let e = check_ranges([
            ("a.b", 2.0, Range::Positive),
            ("c.d", 2.0, Range::Probability),
        ]);
        assert_eq!(
            e.unwrap_err().to_string(),
            "`c.d` = 2: must be a probability in (0, 1]"
        );
    }
}
