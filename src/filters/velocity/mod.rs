//! Velocity filters that bridge DVL outages: the forward speed from another source, learnt
//! while the DVL is in range, handed to the navigation filter as a body-velocity aid while
//! it is not.

pub mod model_aided;
pub mod rpm;
