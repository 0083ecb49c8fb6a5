//! Time alignment: per-topic clock offsets, one time-ordered event stream over all topics,
//! and the look-ups filters need (samples between two times, value at a time, latest value
//! and its age).
//!
//! Pure functions over decoded streams; no I/O. May import: `contract`, `ingest` (types
//! only), `angle`, `time`.

mod lookup;
mod merge;
mod offsets;

pub use lookup::{between, interpolate, latest_at, latest_index_at};
pub use merge::{merged, Event, Merged};
pub use offsets::{apply_offsets, AlignError, ClockOffset};
