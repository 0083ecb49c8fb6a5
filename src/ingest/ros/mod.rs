//! ROS recordings: ROS 2's (messages in `cdr`) and ROS 1's (`ros1`, in MCAP or in a bag). The
//! message definitions the file carries ([`msg`]) and a reader compiled from them for either
//! serialisation ([`cdr`]). No layout is written into the code: a field added in another
//! distro (Jazzy's `Range.variance`) is read from the schema text. The standard types'
//! definitions ([`standard`]) serve the files that carry none (sqlite3 bags before Iron).

pub mod cdr;
pub mod decoder;
pub mod evologics;
pub mod map;
pub mod msg;
pub mod standard;
pub mod wire;
