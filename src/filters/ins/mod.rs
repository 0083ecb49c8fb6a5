//! Inertial navigation: the strapdown mechanization (the error-state filter comes later).

pub mod alignment;
pub mod driver;
pub mod error_state;
pub mod forward;
pub mod mechanization;
