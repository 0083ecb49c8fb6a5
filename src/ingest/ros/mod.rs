//! ROS 2 recordings (rosbag2 into MCAP, messages in `cdr`): the message definitions the file
//! carries ([`msg`]) and a reader of CDR compiled from them ([`cdr`]). No layout is written
//! into the code: a field added in another distro (Jazzy's `Range.variance`) is read from
//! the schema text.

pub mod cdr;
pub mod decoder;
pub mod map;
pub mod msg;
pub mod standard;
