//! hindsight: post-dive reconstruction of what an underwater vehicle did, from its recorded
//! sensor logs (MCAP).
//!
//! The pipeline reads a log ([`ingest`]), puts its asynchronous streams on one clock
//! ([`align`]), and writes tables ([`output`]). The log contract lives in [`contract`] (Rust
//! types) and `schemas/` (JSON Schemas). [`sim`] writes logs through the same contract.
//! `ARCHITECTURE.md` maps the modules and what each may import.

pub mod align;
pub mod angle;
pub mod attitude;
pub mod batch;
pub mod config;
pub mod contract;
pub mod disk_backed;
pub mod filters;
pub mod geodesy;
pub mod geomag;
pub mod growing_series;
pub mod identify;
pub mod import;
pub mod ingest;
pub mod output;
pub mod progress;
pub mod recon;
pub mod reconstruction;
pub mod sim;
pub mod small_matrix;
pub mod smooth;
pub mod study;
pub mod time;
pub mod vehicle;

pub use reconstruction::{reconstruct, Job, Observer, Reconstruction};
