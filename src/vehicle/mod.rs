//! Vehicle models: equations of motion and their Jacobians, as pure functions of state,
//! input and coefficients.
//!
//! - [`heave_pitch`]: seed 004's vertical-plane model, exactly as
//!   `docs/methods/heave-pitch-model.md` pins it down.

pub mod heave_pitch;
pub mod six_dof;
