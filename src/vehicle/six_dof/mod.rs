//! Seed 000's 6-DOF vehicle model (Gertler-Hagen style) with vehicle descriptions as data.
//!
//! - [`description`]: vehicle files to terms (the one place names meet the model).
//! - [`terms`]: hydrodynamic terms as products of factors, with exact gradients.
//! - [`model`]: the equations of motion and their Jacobian by velocity and rate.

pub mod autopilot;
pub mod description;
pub mod flight_plan;
pub mod model;
pub mod motion;
pub mod properties;
pub mod terms;
