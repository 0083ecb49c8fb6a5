//! `hindsight config SECTION`, and the one reader of settings files every command uses.

use anyhow::{Context, Result};
use hindsight::attitude::config::AttitudeConfig;
use hindsight::config::{load, load_over, Section};
use hindsight::identify::config::IdentifyConfig;
use hindsight::recon::config::Config;
use std::path::Path;

/// Print a command's settings with their defaults (TOML, every key explained).
///
/// The printed text is a valid settings file: edit what you need, drop the rest (every key
/// is optional), and hand it to the command with --config FILE. Unknown keys are refused.
#[derive(Debug, clap::Args)]
pub struct ConfigArgs {
    /// Whose settings: reconstruct (also used by batch and study), attitude or identify.
    #[arg(value_enum, default_value_t = SectionChoice::Reconstruct)]
    pub section: SectionChoice,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum SectionChoice {
    Reconstruct,
    Attitude,
    Identify,
}

pub fn run(args: ConfigArgs) -> Result<()> {
    print!("{}", default_toml(args.section));
    Ok(())
}

/// A section's documented defaults.
pub fn default_toml(section: SectionChoice) -> &'static str {
    match section {
        SectionChoice::Reconstruct => Config::DEFAULT_TOML,
        SectionChoice::Attitude => AttitudeConfig::DEFAULT_TOML,
        SectionChoice::Identify => IdentifyConfig::DEFAULT_TOML,
    }
}

/// Where to find a section's keys.
pub fn every_key_hint(section: &str) -> &'static str {
    match section {
        "attitude" => "`hindsight config attitude` prints every key with its default",
        "identify" => "`hindsight config identify` prints every key with its default",
        _ => "`hindsight config reconstruct` prints every key with its default",
    }
}

/// Reads a settings file: over `base` (a preset) when given, else over the defaults. Its
/// errors name the file.
pub fn read<T: Section>(path: &Path, base: Option<&T>) -> Result<T> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("reading the configuration {}", path.display()))?;
    let parsed = match base {
        Some(base) => load_over(base, &text),
        None => load(&text),
    };
    parsed.with_context(|| format!("configuration {}", path.display()))
}
