//! Alignment: the start of a reconstruction from whatever the log has, in one place.
//!
//! - [`start`]: the initial estimate and which source gave each part (position, velocity,
//!   attitude, their sigmas), the entry of the others;
//! - [`at_rest`]: levelling and gyrocompassing from sensors at rest (also used by the AHRS
//!   methods);
//! - [`heading`]: the initial heading from every source, weighed by their sigmas;
//! - [`in_run`]: seed 002's in-run alignment of a vehicle dropped unaligned;
//! - [`in_motion`]: the heading the log's aiding supports, from any start (a bank of
//!   hypotheses);
//! - [`carry`]: body vectors measured at different times carried to one time by the gyro.

pub mod at_rest;
pub mod carry;
pub mod heading;
pub mod in_motion;
pub mod in_run;
pub mod start;
