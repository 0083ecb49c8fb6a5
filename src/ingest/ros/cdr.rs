//! CDR, the wire format of ROS 2 messages, read by a plan compiled from the message's
//! definition ([`super::msg`]): the plan walks every field in order (alignment, counts,
//! strings) and keeps only the values a mapping asked for, by path (`header.stamp.sec`,
//! `orientation_covariance[0]`). Nested messages are flattened into the plan, so reading a
//! message is one pass over a list of steps with no allocation.
//!
//! Encapsulations read: plain CDR (XCDR1, what ROS 2 writes) and plain XCDR2, big- or
//! little-endian. In XCDR1 a primitive is aligned to its size (at most 8) from the first
//! byte after the 4-byte encapsulation header; in XCDR2 to at most 4.
//!
//! ROS 1's serialisation is read by the same plan ([`Dialect::Ros1`] definitions): no
//! header, little-endian, no alignment, and a string's length without a terminating NUL.

use super::msg::{Definitions, Dialect, Element, Primitive, Shape};

/// Most values a plan can keep, and most strings.
pub const MAX_VALUES: usize = 16;
pub const MAX_STRINGS: usize = 4;

/// Why a plan could not be made for the asked paths.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum PlanError {
    #[error("more than {MAX_VALUES} values or {MAX_STRINGS} strings asked of one message")]
    TooMany,
}

/// Why a message could not be read.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum CdrError {
    #[error("message shorter than its layout: {need} bytes needed at byte {at}, {len} in all")]
    Short { at: usize, need: usize, len: usize },
    #[error("CDR encapsulation {0:#06x} is not read (plain CDR or XCDR2 only)")]
    Encapsulation(u16),
    #[error("string at byte {at} is not UTF-8 or not terminated")]
    BadString { at: usize },
}

#[derive(Debug, Clone, PartialEq)]
enum Step {
    /// One primitive, kept in a value slot or skipped.
    Value(Primitive, Option<usize>),
    /// Primitives of one size in a row, each kept or not (while the plan is built).
    Values(Vec<(Primitive, Option<usize>)>),
    /// `count` primitives of `size` bytes in a row: the byte offset in the run, the type and
    /// the slot of each kept one.
    Run {
        size: usize,
        count: usize,
        kept: Vec<(usize, Primitive, usize)>,
    },
    /// A string, kept in a string slot or skipped.
    Text(Option<usize>),
    /// `n` strings (fixed array), skipped.
    Texts(usize),
    WText,
    /// A sequence (count on the wire) of what the inner steps read, skipped.
    Sequence(Vec<Step>),
    /// A fixed array of messages, skipped.
    Repeat(usize, Vec<Step>),
}

/// A compiled reader of one message type.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    steps: Vec<Step>,
    dialect: Dialect,
    /// Whether the message has each asked number and string.
    has_number: Vec<bool>,
    has_string: Vec<bool>,
}

/// The values a plan kept from one message (numbers as `f64`, integers also exactly).
#[derive(Debug, Clone, Copy)]
pub struct Picked<'a> {
    pub number: [f64; MAX_VALUES],
    pub integer: [i64; MAX_VALUES],
    pub text: [&'a str; MAX_STRINGS],
}

impl Picked<'_> {
    /// Nothing read yet: numbers NaN, integers 0, strings empty.
    pub fn new() -> Self {
        Picked {
            number: [f64::NAN; MAX_VALUES],
            integer: [0; MAX_VALUES],
            text: [""; MAX_STRINGS],
        }
    }
}

impl Default for Picked<'_> {
    fn default() -> Self {
        Picked::new()
    }
}

impl Plan {
    /// A plan that keeps the values at `numbers` and the strings at `strings` (paths through
    /// the root type, fixed-array elements as `name[i]`): the i-th path's value lands in
    /// slot i of [`Picked`]. A path the message does not have (an optional field of another
    /// distro) is left out: see [`Plan::has_number`].
    pub fn new(defs: &Definitions, numbers: &[&str], strings: &[&str]) -> Result<Plan, PlanError> {
        if numbers.len() > MAX_VALUES || strings.len() > MAX_STRINGS {
            return Err(PlanError::TooMany);
        }
        let mut found = (vec![None; numbers.len()], vec![None; strings.len()]);
        let mut steps = Vec::new();
        let wanted = Wanted { numbers, strings };
        flatten(defs, &defs.root, "", &wanted, &mut found, &mut steps);
        let steps = into_runs(merge_runs(steps));
        Ok(Plan {
            steps,
            dialect: defs.dialect,
            has_number: found.0.iter().map(Option::is_some).collect(),
            has_string: found.1.iter().map(Option::is_some).collect(),
        })
    }

    /// Whether the message has the i-th number asked for.
    pub fn has_number(&self, i: usize) -> bool {
        self.has_number.get(i).copied().unwrap_or(false)
    }

    /// Whether the message has the i-th string asked for.
    pub fn has_string(&self, i: usize) -> bool {
        self.has_string.get(i).copied().unwrap_or(false)
    }

    /// Walks one message through the whole layout, keeping nothing: the bytes it takes
    /// (at most the message's length; the rest is padding a writer may add).
    pub fn check(&self, data: &[u8]) -> Result<usize, CdrError> {
        let mut c = Cursor::new(data, self.dialect)?;
        c.steps(&self.steps, &mut None)?;
        Ok(c.at)
    }

    /// Reads one message (with its encapsulation header, in CDR).
    pub fn read<'a>(&self, data: &'a [u8]) -> Result<Picked<'a>, CdrError> {
        let mut out = Picked::new();
        self.read_into(data, &mut out)?;
        Ok(out)
    }

    /// Reads one message into `out` (filled in place: the hot path of a recording).
    pub fn read_into<'a>(&self, data: &'a [u8], out: &mut Picked<'a>) -> Result<(), CdrError> {
        let mut c = Cursor::new(data, self.dialect)?;
        c.steps(&self.steps, &mut Some(out))
    }
}

struct Wanted<'w> {
    numbers: &'w [&'w str],
    strings: &'w [&'w str],
}

type Found = (Vec<Option<usize>>, Vec<Option<usize>>);

/// The slot of `path` if it is asked for (and marks it found).
fn mark(list: &[&str], found: &mut [Option<usize>], path: &str) -> Option<usize> {
    let slot = list.iter().position(|p| *p == path)?;
    found[slot] = Some(slot);
    Some(slot)
}

/// The steps of `type_name`'s fields at `prefix`, single nested messages inlined.
fn flatten(
    defs: &Definitions,
    type_name: &str,
    prefix: &str,
    wanted: &Wanted<'_>,
    found: &mut Found,
    steps: &mut Vec<Step>,
) {
    let Some(fields) = defs.types.get(type_name) else {
        return; // parse() checked every type is defined
    };
    for f in fields {
        let path = format!("{prefix}{}", f.name);
        match (&f.element, f.shape) {
            (Element::Primitive(p), Shape::One) => {
                steps.push(Step::Value(*p, mark(wanted.numbers, &mut found.0, &path)))
            }
            (Element::Primitive(p), Shape::Fixed(n)) => {
                let slots: Vec<Option<usize>> = (0..n)
                    .map(|i| mark(wanted.numbers, &mut found.0, &format!("{path}[{i}]")))
                    .collect();
                steps.push(Step::Values(
                    slots.into_iter().map(|slot| (*p, slot)).collect(),
                ));
            }
            (Element::Primitive(p), Shape::Sequence) => {
                steps.push(Step::Sequence(vec![Step::Value(*p, None)]))
            }
            (Element::String, Shape::One) => {
                steps.push(Step::Text(mark(wanted.strings, &mut found.1, &path)))
            }
            (Element::String, Shape::Fixed(n)) => steps.push(Step::Texts(n)),
            (Element::String, Shape::Sequence) => {
                steps.push(Step::Sequence(vec![Step::Text(None)]))
            }
            (Element::WString, Shape::One) => steps.push(Step::WText),
            (Element::WString, Shape::Fixed(n)) => steps.push(Step::Repeat(n, vec![Step::WText])),
            (Element::WString, Shape::Sequence) => steps.push(Step::Sequence(vec![Step::WText])),
            (Element::Message(inner), Shape::One) => {
                flatten(defs, inner, &format!("{path}."), wanted, found, steps)
            }
            (Element::Message(inner), shape) => {
                let mut inner_steps = Vec::new();
                let none = Wanted {
                    numbers: &[],
                    strings: &[],
                };
                flatten(
                    defs,
                    inner,
                    "",
                    &none,
                    &mut (Vec::new(), Vec::new()),
                    &mut inner_steps,
                );
                steps.push(match shape {
                    Shape::Fixed(n) => Step::Repeat(n, inner_steps),
                    _ => Step::Sequence(inner_steps),
                });
            }
        }
    }
}

/// Joins consecutive values of one primitive type (a Vector3's x, y, z; a covariance after
/// it) into one step: after the first is aligned the rest follow with no padding (a
/// primitive's alignment divides its size), so the run is one bounds check.
fn merge_runs(steps: Vec<Step>) -> Vec<Step> {
    let mut out: Vec<Step> = Vec::with_capacity(steps.len());
    for step in steps {
        let values = match step {
            Step::Value(p, slot) => vec![(p, slot)],
            Step::Values(values) => values,
            Step::Sequence(inner) => {
                out.push(Step::Sequence(merge_runs(inner)));
                continue;
            }
            Step::Repeat(n, inner) => {
                out.push(Step::Repeat(n, merge_runs(inner)));
                continue;
            }
            other => {
                out.push(other);
                continue;
            }
        };
        // A fixed array of no elements (`float64[0]`) takes no bytes.
        let Some(&(first, _)) = values.first() else {
            continue;
        };
        let size = first.size();
        let previous = match out.last() {
            Some(Step::Value(q, first)) if q.size() == size => Some(vec![(*q, *first)]),
            Some(Step::Values(run)) if run[0].0.size() == size => Some(run.clone()),
            _ => None,
        };
        match previous {
            Some(mut run) => {
                run.extend(values);
                *out.last_mut().expect("a previous step") = Step::Values(run);
            }
            None => out.push(match values.as_slice() {
                [(p, slot)] => Step::Value(*p, *slot),
                _ => Step::Values(values),
            }),
        }
    }
    out
}

/// The plan's values as runs that list only their kept elements.
fn into_runs(steps: Vec<Step>) -> Vec<Step> {
    steps
        .into_iter()
        .map(|step| match step {
            Step::Value(p, slot) => Step::Run {
                size: p.size(),
                count: 1,
                kept: slot.map(|i| (0, p, i)).into_iter().collect(),
            },
            Step::Values(values) => {
                let size = values[0].0.size();
                Step::Run {
                    size,
                    count: values.len(),
                    kept: values
                        .iter()
                        .enumerate()
                        .filter_map(|(k, (p, slot))| slot.map(|i| (k * size, *p, i)))
                        .collect(),
                }
            }
            Step::Sequence(inner) => Step::Sequence(into_runs(inner)),
            Step::Repeat(n, inner) => Step::Repeat(n, into_runs(inner)),
            other => other,
        })
        .collect()
}

/// One primitive from its bytes (exactly `p.size()` of them) as (f64, i64).
#[inline]
fn decode(p: Primitive, b: &[u8], little: bool) -> (f64, i64) {
    macro_rules! int {
        ($t:ty, $n:literal) => {{
            let mut a = [0u8; $n];
            a.copy_from_slice(b);
            let v = if little {
                <$t>::from_le_bytes(a)
            } else {
                <$t>::from_be_bytes(a)
            };
            (v as f64, v as i64)
        }};
    }
    match p {
        Primitive::Bool | Primitive::Byte | Primitive::Char | Primitive::U8 => {
            (f64::from(b[0]), i64::from(b[0]))
        }
        Primitive::I8 => (f64::from(b[0] as i8), i64::from(b[0] as i8)),
        Primitive::I16 => int!(i16, 2),
        Primitive::U16 => int!(u16, 2),
        Primitive::I32 => int!(i32, 4),
        Primitive::U32 => int!(u32, 4),
        Primitive::I64 => int!(i64, 8),
        Primitive::U64 => int!(u64, 8),
        Primitive::F32 => {
            let (v, _) = int!(u32, 4);
            let x = f32::from_bits(v as u32);
            (f64::from(x), x as i64)
        }
        Primitive::F64 => {
            let (_, v) = int!(u64, 8);
            let x = f64::from_bits(v as u64);
            (x, x as i64)
        }
    }
}

struct Cursor<'a> {
    data: &'a [u8],
    at: usize,
    /// Where alignment counts from: the first byte after the header.
    origin: usize,
    little: bool,
    max_align: usize,
    /// Whether a string's length counts a terminating NUL (CDR) or not (ROS 1).
    nul_terminated: bool,
}

const HEADER: usize = 4;

impl<'a> Cursor<'a> {
    fn new(data: &'a [u8], dialect: Dialect) -> Result<Self, CdrError> {
        if dialect == Dialect::Ros1 {
            return Ok(Cursor {
                data,
                at: 0,
                origin: 0,
                little: true,
                max_align: 1,
                nul_terminated: false,
            });
        }
        let head = data.get(..HEADER).ok_or(CdrError::Short {
            at: 0,
            need: HEADER,
            len: data.len(),
        })?;
        let kind = u16::from_be_bytes([head[0], head[1]]);
        let (little, max_align) = match kind {
            0x0000 => (false, 8),
            0x0001 => (true, 8),
            0x0006 => (false, 4),
            0x0007 => (true, 4),
            other => return Err(CdrError::Encapsulation(other)),
        };
        Ok(Cursor {
            data,
            at: HEADER,
            origin: HEADER,
            little,
            max_align,
            nul_terminated: true,
        })
    }

    fn take(&mut self, n: usize, align: usize) -> Result<&'a [u8], CdrError> {
        if n == 0 {
            return Ok(&[]); // nothing to align: an empty sequence ends at its count
        }
        let a = align.min(self.max_align);
        let offset = self.at - self.origin;
        let start = self.at + (a - offset % a) % a;
        let end = start.checked_add(n).filter(|&e| e <= self.data.len());
        let end = end.ok_or(CdrError::Short {
            at: start,
            need: n,
            len: self.data.len(),
        })?;
        self.at = end;
        Ok(&self.data[start..end])
    }

    fn count(&mut self) -> Result<usize, CdrError> {
        let b = self.take(4, 4)?;
        let b = [b[0], b[1], b[2], b[3]];
        Ok(if self.little {
            u32::from_le_bytes(b)
        } else {
            u32::from_be_bytes(b)
        } as usize)
    }

    /// One primitive as (f64, i64).
    fn value(&mut self, p: Primitive) -> Result<(f64, i64), CdrError> {
        let b = self.take(p.size(), p.size())?;
        Ok(decode(p, b, self.little))
    }

    fn text(&mut self) -> Result<&'a str, CdrError> {
        let n = self.count()?;
        let at = self.at;
        let bytes = self.take(n, 1)?;
        // In CDR the length counts the terminating NUL (an empty string may be sent as
        // length 0).
        let body = match bytes.split_last() {
            _ if !self.nul_terminated => bytes,
            None => bytes,
            Some((0, body)) => body,
            Some(_) => return Err(CdrError::BadString { at }),
        };
        std::str::from_utf8(body).map_err(|_| CdrError::BadString { at })
    }

    fn steps(&mut self, steps: &[Step], out: &mut Option<&mut Picked<'a>>) -> Result<(), CdrError> {
        for step in steps {
            match step {
                Step::Value(p, slot) => {
                    let v = self.value(*p)?;
                    if let (Some(i), Some(o)) = (slot, out.as_deref_mut()) {
                        (o.number[*i], o.integer[*i]) = v;
                    }
                }
                Step::Values(values) => {
                    // Only while a plan is built: `into_runs` turns these into runs.
                    let size = values[0].0.size();
                    self.take(size * values.len(), size)?;
                }
                Step::Run { size, count, kept } => {
                    let run = self.take(size * count, *size)?;
                    if let Some(o) = out.as_deref_mut() {
                        for &(at, p, i) in kept {
                            let b = &run[at..at + size];
                            if p == Primitive::F64 && self.little {
                                // The common case, without the general decode's dispatch.
                                let x = f64::from_le_bytes(b.try_into().expect("8 bytes"));
                                (o.number[i], o.integer[i]) = (x, x as i64);
                            } else {
                                (o.number[i], o.integer[i]) = decode(p, b, self.little);
                            }
                        }
                    }
                }
                Step::Text(slot) => {
                    let t = self.text()?;
                    if let (Some(i), Some(o)) = (slot, out.as_deref_mut()) {
                        o.text[*i] = t;
                    }
                }
                Step::Texts(n) => {
                    for _ in 0..*n {
                        self.text()?;
                    }
                }
                Step::WText => {
                    let n = self.count()?;
                    self.take(n.saturating_mul(4), 4)?;
                }
                Step::Sequence(inner) => {
                    let n = self.count()?;
                    // A sequence of one primitive: one take for all its elements.
                    if let [Step::Run {
                        size,
                        count: 1,
                        kept,
                    }] = inner.as_slice()
                    {
                        if kept.is_empty() {
                            self.take(n.saturating_mul(*size), *size)?;
                            continue;
                        }
                    }
                    for _ in 0..n {
                        self.steps(inner, &mut None)?;
                    }
                }
                Step::Repeat(n, inner) => {
                    for _ in 0..*n {
                        self.steps(inner, &mut None)?;
                    }
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::super::msg::parse;
    use super::*;

    use crate::ingest::ros::wire::WireWriter as Writer;

    const RANGE_HUMBLE: &str = "\
std_msgs/Header header
uint8 radiation_type
float32 field_of_view
float32 min_range
float32 max_range
float32 range
================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
";

    fn range_bytes(frame: &str, variance: Option<f32>) -> Vec<u8> {
        let mut w = Writer::new();
        w.i32(1_700_000_000).u32(500_000_000).string(frame).u8(1);
        w.f32(0.1).f32(0.5).f32(80.0).f32(42.25);
        if let Some(v) = variance {
            w.f32(v);
        }
        w.into_bytes()
    }

    #[test]
    fn reads_the_range_of_both_distros() {
        let wanted = [
            "header.stamp.sec",
            "header.stamp.nanosec",
            "range",
            "variance",
        ];
        for (text, variance) in [
            (RANGE_HUMBLE, None),
            (super::super::msg::tests::RANGE_JAZZY, Some(0.04)),
        ] {
            let defs = parse("sensor_msgs/msg/Range", text).unwrap();
            let plan = Plan::new(&defs, &wanted, &["header.frame_id"]).unwrap();
            let data = range_bytes("sonar_frd", variance);
            let got = plan.read(&data).unwrap();
            assert_eq!(got.integer[0], 1_700_000_000);
            assert_eq!(got.integer[1], 500_000_000);
            assert_eq!(got.number[2], 42.25);
            assert_eq!(plan.has_number(3).then(|| got.number[3] as f32), variance);
            assert!(plan.has_string(0));
            assert_eq!(got.text[0], "sonar_frd");
            // Every byte short of the layout is refused, none panics.
            for cut in 0..data.len() {
                assert!(plan.read(&data[..cut]).is_err(), "cut at {cut}");
            }
        }
    }

    #[test]
    fn aligns_doubles_after_odd_strings_and_skips_sequences() {
        let text = "\
string frame_id
int32[] skipped
geometry_msgs/Point[] points
float64[4] cov
float64 x
================================================================================
MSG: geometry_msgs/Point
float64 x
float64 y
float64 z
";
        let defs = parse("a/B", text).unwrap();
        let plan = Plan::new(&defs, &["cov[3]", "x", "cov[0]"], &[]).unwrap();
        let mut w = Writer::new();
        w.string("ab")
            .u32(2)
            .i32(7)
            .i32(8)
            .u32(1)
            .f64(1.0)
            .f64(2.0)
            .f64(3.0);
        w.f64(10.0).f64(11.0).f64(12.0).f64(13.0).f64(-4.5);
        let got = plan.read(w.bytes()).unwrap();
        assert_eq!(got.number[..3], [13.0, -4.5, 10.0]);
    }

    /// Found by the fuzz harness (tests/fuzz.rs): a fixed array of no elements takes no
    /// bytes (it once emptied a run of values and panicked), and a fixed array too long to
    /// plan is refused with the definition's line (it once asked for 64 GB).
    #[test]
    fn empty_and_huge_fixed_arrays() {
        let defs = parse("a/B", "float64[0] none\nfloat64 x").unwrap();
        let plan = Plan::new(&defs, &["x"], &[]).unwrap();
        let mut w = Writer::new();
        w.f64(2.5);
        assert_eq!(plan.read(w.bytes()).unwrap().number[0], 2.5);
        let e = parse("a/B", "float64[4294967295] big").unwrap_err();
        assert!(e.to_string().contains("fixed array"), "{e}");
    }

    /// Two rules rosbag2's recordings taught: an empty sequence ends at its count (no
    /// alignment for elements that are not there), and a message of constants only takes
    /// one byte.
    #[test]
    fn empty_sequences_and_empty_messages() {
        let text = "\
int64[] none
uint32 after
Empty e
uint8 last
================================================================================
MSG: a/Empty
uint8 ONLY=1
";
        let defs = parse("a/B", text).unwrap();
        let plan = Plan::new(&defs, &["after", "last"], &[]).unwrap();
        let mut w = Writer::new();
        w.u32(0).u32(77).u8(0).u8(9);
        let got = plan.read(w.bytes()).unwrap();
        assert_eq!((got.integer[0], got.integer[1]), (77, 9));
        assert_eq!(plan.check(w.bytes()).unwrap(), w.bytes().len());
    }

    /// ROS 1's `sensor_msgs/Range` as a ROS 1 bag stores its definition: a header with a
    /// sequence number and the built-in `time`.
    const RANGE_ROS1: &str = "\
uint8 ULTRASOUND=0
Header header
uint8 radiation_type
float32 field_of_view
float32 min_range
float32 max_range
float32 range
================================================================================
MSG: std_msgs/Header
uint32 seq
time stamp
string frame_id
";

    #[test]
    fn reads_ros1_without_header_alignment_or_nul() {
        let defs =
            super::super::msg::parse_as(Dialect::Ros1, "sensor_msgs/Range", RANGE_ROS1).unwrap();
        let plan = Plan::new(
            &defs,
            &[
                "header.stamp.sec",
                "header.stamp.nanosec",
                "range",
                "header.seq",
            ],
            &["header.frame_id"],
        )
        .unwrap();
        // Written by hand, as roscpp serialises: seq, secs, nsecs, "sonar" (5 bytes, no NUL),
        // then an odd byte and floats with no padding.
        let mut data = Vec::new();
        data.extend(7u32.to_le_bytes());
        data.extend(1_700_000_000u32.to_le_bytes());
        data.extend(500_000_000u32.to_le_bytes());
        data.extend(5u32.to_le_bytes());
        data.extend(b"sonar");
        data.push(1);
        for v in [0.1f32, 0.5, 80.0, 42.25] {
            data.extend(v.to_le_bytes());
        }
        let got = plan.read(&data).unwrap();
        assert_eq!(
            (got.integer[0], got.integer[1], got.integer[3]),
            (1_700_000_000, 500_000_000, 7)
        );
        assert_eq!(got.number[2], 42.25);
        assert_eq!(got.text[0], "sonar");
        assert_eq!(
            plan.check(&data).unwrap(),
            data.len(),
            "every byte, no padding"
        );
        for cut in 0..data.len() {
            assert!(plan.read(&data[..cut]).is_err(), "cut at {cut}");
        }
    }

    #[test]
    fn big_endian_and_bad_headers() {
        let defs = parse("a/B", "uint16 a\nfloat64 b\n").unwrap();
        let plan = Plan::new(&defs, &["a", "b"], &[]).unwrap();
        let mut data = vec![0, 0, 0, 0, 0x01, 0x02, 0, 0, 0, 0, 0, 0];
        data.extend(2.5f64.to_be_bytes());
        let got = plan.read(&data).unwrap();
        assert_eq!(got.integer[0], 0x0102);
        assert_eq!(got.number[1], 2.5);
        assert_eq!(
            plan.read(&[0, 0x0a, 0, 0]).unwrap_err(),
            CdrError::Encapsulation(0x0a)
        );
        assert!(matches!(plan.read(&[0, 1]), Err(CdrError::Short { .. })));
    }
}
