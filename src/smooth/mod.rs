//! Smoothers: pure functions of what the forward pass recorded; they never re-run the models.
//!
//! May import: `filters` (types), `nalgebra`.

pub mod error_rts;
pub mod rts;
