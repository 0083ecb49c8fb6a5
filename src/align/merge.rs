//! One time-ordered event stream over all topics: a stable k-way merge by `stamp_ns`.

use crate::ingest::Stream;

/// One message in the merged stream.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Event {
    pub stamp_ns: i64,
    /// Index into the streams given to [`merged`].
    pub stream: usize,
    /// Index of the message within its stream.
    pub index: usize,
}

/// Iterator over all messages of several sorted streams in `stamp_ns` order.
///
/// Stable: equal stamps come out in stream order, and within a stream in stream order.
/// A log has a dozen topics, so the next event is found by a linear scan of the stream
/// heads (kept in stream order), which beats a binary heap at this size.
pub struct Merged<'a> {
    streams: &'a [Stream],
    /// Next event of every stream not yet exhausted, in stream order.
    heads: Vec<Event>,
    remaining: usize,
}

/// Merges streams that are each sorted by `stamp_ns` (as ingest leaves them).
pub fn merged(streams: &[Stream]) -> Merged<'_> {
    let heads = streams
        .iter()
        .enumerate()
        .filter(|(_, s)| !s.samples.is_empty())
        .map(|(stream, s)| Event {
            stamp_ns: s.samples.stamp_ns(0),
            stream,
            index: 0,
        })
        .collect();
    let remaining = streams.iter().map(|s| s.samples.len()).sum();
    Merged {
        streams,
        heads,
        remaining,
    }
}

impl Iterator for Merged<'_> {
    type Item = Event;

    fn next(&mut self) -> Option<Event> {
        let mut best = 0;
        for (k, head) in self.heads.iter().enumerate().skip(1) {
            if head.stamp_ns < self.heads[best].stamp_ns {
                best = k;
            }
        }
        let event = *self.heads.get(best)?;
        let samples = &self.streams[event.stream].samples;
        if event.index + 1 < samples.len() {
            let head = &mut self.heads[best];
            head.index += 1;
            head.stamp_ns = samples.stamp_ns(head.index);
        } else {
            self.heads.remove(best);
        }
        self.remaining -= 1;
        Some(event)
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        (self.remaining, Some(self.remaining))
    }
}

impl ExactSizeIterator for Merged<'_> {}
