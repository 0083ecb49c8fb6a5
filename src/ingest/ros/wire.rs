//! The inverse of [`super::cdr`]: a ROS message's bytes written field by field, in CDR as a
//! rosbag2 recording holds them or in ROS 1's serialisation. For the simulator's ROS logs,
//! the Foxglove output and tests of the readers.

use super::msg::Dialect;

/// One writer method per primitive type, named as the type: its little-endian bytes, aligned.
macro_rules! primitives {
    ($($t:ident),*) => {
        $(
            #[doc = concat!("A `", stringify!($t), "`.")]
            pub fn $t(&mut self, v: $t) -> &mut Self {
                self.put(v.to_le_bytes())
            }
        )*
    };
}

/// A ROS message's bytes: little-endian plain CDR (XCDR1), the encapsulation ROS 2 writes,
/// each primitive aligned to its size from the first byte after the 4-byte header; or ROS 1's
/// serialisation (no header, no alignment, strings without a NUL).
#[derive(Debug, Clone)]
pub struct WireWriter {
    bytes: Vec<u8>,
    dialect: Dialect,
}

impl Default for WireWriter {
    fn default() -> Self {
        WireWriter::new()
    }
}

impl WireWriter {
    /// A CDR message with its encapsulation header.
    pub fn new() -> Self {
        WireWriter::of(Dialect::Ros2)
    }

    /// A message of the given ROS.
    pub fn of(dialect: Dialect) -> Self {
        WireWriter::reusing(Vec::new(), dialect)
    }

    /// A message of the given ROS written into `buffer` (cleared first), to reuse its memory.
    pub fn reusing(mut buffer: Vec<u8>, dialect: Dialect) -> Self {
        buffer.clear();
        if dialect == Dialect::Ros2 {
            buffer.extend([0, 1, 0, 0]);
        }
        WireWriter {
            bytes: buffer,
            dialect,
        }
    }

    /// The message's bytes so far.
    pub fn bytes(&self) -> &[u8] {
        &self.bytes
    }

    /// The message's bytes.
    pub fn into_bytes(self) -> Vec<u8> {
        self.bytes
    }

    /// A primitive's little-endian bytes, aligned to its size in CDR.
    fn put<const N: usize>(&mut self, le_bytes: [u8; N]) -> &mut Self {
        if self.dialect == Dialect::Ros2 {
            let padding = (N - (self.bytes.len() - 4) % N) % N;
            self.bytes.extend(std::iter::repeat_n(0u8, padding));
        }
        self.bytes.extend(le_bytes);
        self
    }

    primitives!(u8, i8, u16, i32, u32, f32, f64);

    pub fn f64s(&mut self, v: &[f64]) -> &mut Self {
        for &x in v {
            self.f64(x);
        }
        self
    }

    /// A string: in CDR its length with the terminating NUL, the bytes, NUL; in ROS 1 its
    /// length and its bytes.
    pub fn string(&mut self, s: &str) -> &mut Self {
        let nul = self.dialect == Dialect::Ros2;
        self.u32(s.len() as u32 + u32::from(nul));
        self.bytes.extend(s.as_bytes());
        if nul {
            self.bytes.push(0);
        }
        self
    }

    /// `std_msgs/Header`: the stamp as (int32 sec, uint32 nanosec), the frame; in ROS 1 a
    /// sequence number (0) first and the seconds unsigned. The seconds are truncated to 32
    /// bits: a caller whose stamps may fall outside 1901-2038 checks them first.
    pub fn header(&mut self, stamp_ns: i64, frame_id: &str) -> &mut Self {
        let sec = stamp_ns.div_euclid(1_000_000_000);
        let nanosec = stamp_ns.rem_euclid(1_000_000_000) as u32;
        match self.dialect {
            Dialect::Ros1 => self.u32(0).u32(sec as u32),
            Dialect::Ros2 => self.i32(sec as i32),
        }
        .u32(nanosec)
        .string(frame_id)
    }
}
