//! Per-topic clock offsets (`--offset /dvl=-0.120`).

use crate::ingest::Log;
use crate::time;
use std::str::FromStr;

/// A correction added to every `stamp_ns` of one topic.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ClockOffset {
    pub topic: String,
    pub offset_ns: i64,
}

/// Errors of alignment settings.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum AlignError {
    #[error("clock offset `{text}`: expected TOPIC=SECONDS, e.g. /dvl=-0.120")]
    BadOffset { text: String },
    #[error("clock offset for topic {topic}: the log has no such topic (it has: {available})")]
    UnknownTopic { topic: String, available: String },
}

impl FromStr for ClockOffset {
    type Err = AlignError;

    fn from_str(text: &str) -> Result<Self, Self::Err> {
        let bad = || AlignError::BadOffset {
            text: text.to_string(),
        };
        let (topic, seconds) = text.rsplit_once('=').ok_or_else(bad)?;
        let seconds: f64 = seconds.trim().parse().map_err(|_| bad())?;
        if topic.is_empty() || !seconds.is_finite() || seconds.abs() > 86_400.0 {
            return Err(bad());
        }
        Ok(ClockOffset {
            topic: topic.trim().to_string(),
            offset_ns: time::s_to_ns(seconds).ok_or_else(bad)?,
        })
    }
}

/// Shifts the stamps of each named topic by its offset (corrected = recorded + offset).
///
/// Offsets do not reorder a stream, so the streams stay sorted.
pub fn apply_offsets(log: &mut Log, offsets: &[ClockOffset]) -> Result<(), AlignError> {
    for offset in offsets {
        let matching: Vec<usize> = (0..log.streams.len())
            .filter(|&i| log.streams[i].topic == offset.topic)
            .collect();
        if matching.is_empty() {
            return Err(AlignError::UnknownTopic {
                topic: offset.topic.clone(),
                available: log
                    .streams
                    .iter()
                    .map(|s| s.topic.as_str())
                    .collect::<Vec<_>>()
                    .join(", "),
            });
        }
        for i in matching {
            let stream = &mut log.streams[i];
            stream.samples.shift_stamps(offset.offset_ns);
            let timing = &mut stream.timing;
            if let Some((a, b)) = timing.span_ns.as_mut() {
                *a = a.saturating_add(offset.offset_ns);
                *b = b.saturating_add(offset.offset_ns);
            }
            for gap in &mut timing.gaps {
                gap.after_ns = gap.after_ns.saturating_add(offset.offset_ns);
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_topic_and_seconds() {
        let o: ClockOffset = "/dvl=-0.120".parse().unwrap();
        assert_eq!(
            o,
            ClockOffset {
                topic: "/dvl".into(),
                offset_ns: -120_000_000
            }
        );
        let o: ClockOffset = "/a=b/c=2.5".parse().unwrap();
        assert_eq!(o.topic, "/a=b/c");
    }

    #[test]
    fn rejects_malformed() {
        for bad in ["/dvl", "/dvl=", "=0.1", "/dvl=abc", "/dvl=nan", "/dvl=1e9"] {
            assert!(bad.parse::<ClockOffset>().is_err(), "{bad}");
        }
    }
}
