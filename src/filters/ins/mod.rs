//! Inertial navigation: strapdown mechanization, the 26-state error model, the forward
//! filter and its driver over a mission, coarse alignment, and the records the smoother reads.

pub mod acoustic;
pub mod aid_sources;
pub mod aid_table;
pub mod driver;
pub mod error_state;
pub mod forward;
pub mod heading_reset;
pub mod lbl;
pub mod mechanization;
pub mod record;
pub mod reopen;
pub mod solutions;
pub mod usbl;
