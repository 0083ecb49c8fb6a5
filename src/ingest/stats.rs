//! Per-stream timing statistics: rate, jitter, gaps, duplicates, out-of-order arrivals.
//!
//! Definitions (also in docs/guide/commands.md and `hindsight info --help`):
//! - *out-of-order*: a message whose `stamp_ns` is earlier than the latest stamp already
//!   received on its topic, in file order;
//! - *duplicate*: a message whose `stamp_ns` equals that of an earlier message of its topic;
//!   it is dropped (the first one received is kept);
//! - *period*: the median interval between consecutive stamps after sorting and dropping
//!   duplicates; *rate* is its inverse;
//! - *gap*: an interval longer than [`GAP_FACTOR`] times the median period;
//! - *jitter*: the standard deviation of the intervals that are not gaps.

/// An interval longer than this many median periods is a gap.
pub const GAP_FACTOR: f64 = 3.0;

/// A hole in a stream.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Gap {
    /// Stamp of the last message before the gap.
    pub after_ns: i64,
    /// Time to the next message.
    pub duration_ns: i64,
}

/// Timing of one stream, from its sorted, de-duplicated stamps.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Timing {
    /// First and last stamp, if any message.
    pub span_ns: Option<(i64, i64)>,
    /// Median interval, seconds (needs two messages).
    pub median_period_s: Option<f64>,
    /// Standard deviation of the non-gap intervals, seconds.
    pub jitter_s: Option<f64>,
    /// Intervals over [`GAP_FACTOR`] times the median period.
    pub gaps: Vec<Gap>,
}

impl Timing {
    /// Median rate in Hz.
    pub fn rate_hz(&self) -> Option<f64> {
        self.median_period_s.filter(|p| *p > 0.0).map(|p| 1.0 / p)
    }
}

/// Timing of strictly increasing stamps.
pub fn timing(sorted_unique_ns: &[i64]) -> Timing {
    timing_by(sorted_unique_ns.len(), |i| sorted_unique_ns[i])
}

/// [`timing`] of `n` sorted unique stamps read through `stamp` (no copy of a long stream's).
pub fn timing_by(n: usize, stamp: impl Fn(usize) -> i64) -> Timing {
    if n == 0 {
        return Timing::default();
    }
    let (first, last) = (stamp(0), stamp(n - 1));
    let interval = |i: usize| stamp(i + 1) - stamp(i);
    if n == 1 {
        return Timing {
            span_ns: Some((first, last)),
            ..Timing::default()
        };
    }
    // The intervals are copied to find their median: as 32-bit numbers where they fit (a
    // day of IMU intervals is then 40 MB, not 80).
    let median_ns = if (0..n - 1).all(|i| interval(i) <= i64::from(i32::MAX)) {
        let mut v: Vec<i32> = (0..n - 1).map(|i| interval(i) as i32).collect();
        median_in_place(&mut v, f64::from)
    } else {
        let mut v: Vec<i64> = (0..n - 1).map(interval).collect();
        median_in_place(&mut v, |x| x as f64)
    };
    let gap_threshold_ns = GAP_FACTOR * median_ns;
    let gaps: Vec<Gap> = (0..n - 1)
        .filter(|&i| interval(i) as f64 > gap_threshold_ns)
        .map(|i| Gap {
            after_ns: stamp(i),
            duration_ns: interval(i),
        })
        .collect();
    let regular = || {
        (0..n - 1)
            .map(|i| interval(i) as f64)
            .filter(|&d| d <= gap_threshold_ns)
    };
    let count = regular().count() as f64;
    let mean = regular().sum::<f64>() / count;
    let var = regular().map(|d| (d - mean).powi(2)).sum::<f64>() / count;
    Timing {
        span_ns: Some((first, last)),
        median_period_s: Some(median_ns * 1e-9),
        jitter_s: Some(var.sqrt() * 1e-9),
        gaps,
    }
}

/// Median of a non-empty slice (mean of the two middle values for an even count), reordering
/// `v` instead of copying it.
fn median_in_place<T: Ord + Copy>(v: &mut [T], to_f64: impl Fn(T) -> f64) -> f64 {
    let mid = v.len() / 2;
    let (_, &mut upper, _) = v.select_nth_unstable(mid);
    if v.len() % 2 == 1 {
        to_f64(upper)
    } else {
        let lower = *v[..mid].iter().max().unwrap_or(&upper);
        (to_f64(lower) + to_f64(upper)) / 2.0
    }
}

/// Stable sort by stamp, then duplicate removal: returns the indexes to keep, in time order,
/// and the number of duplicates dropped.
pub fn sorted_unique_order(stamps_ns: &[i64]) -> (Vec<usize>, u64) {
    let mut order: Vec<usize> = (0..stamps_ns.len()).collect();
    order.sort_by_key(|&i| stamps_ns[i]); // stable: the first received of equal stamps leads
    let before = order.len();
    order.dedup_by_key(|i| stamps_ns[*i]);
    let dropped = (before - order.len()) as u64;
    (order, dropped)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn regular_stream_has_rate_and_no_gaps() {
        let stamps: Vec<i64> = (0..101).map(|i| i * 10_000_000).collect();
        let t = timing(&stamps);
        assert_eq!(t.rate_hz(), Some(100.0));
        assert_eq!(t.jitter_s, Some(0.0));
        assert!(t.gaps.is_empty());
        assert_eq!(t.span_ns, Some((0, 1_000_000_000)));
    }

    #[test]
    fn finds_gaps_over_three_periods() {
        // 1 s period, with a 3.0 s interval (not a gap) and a 3.5 s one (a gap).
        let stamps = [0.0, 1.0, 2.0, 5.0, 6.0, 7.0, 8.0, 11.5, 12.5].map(|s: f64| (s * 1e9) as i64);
        let t = timing(&stamps);
        assert_eq!(t.median_period_s, Some(1.0));
        assert_eq!(
            t.gaps,
            vec![Gap {
                after_ns: 8_000_000_000,
                duration_ns: 3_500_000_000
            }]
        );
    }

    #[test]
    fn median_of_even_count_is_midpoint() {
        assert_eq!(median_in_place(&mut [1i64, 3, 2, 4], |x| x as f64), 2.5);
        assert_eq!(median_in_place(&mut [7i32], f64::from), 7.0);
    }

    #[test]
    fn order_is_stable_and_drops_later_duplicates() {
        let stamps = [30, 10, 20, 10, 40, 30];
        let (order, dropped) = sorted_unique_order(&stamps);
        assert_eq!(order, vec![1, 2, 0, 4]);
        assert_eq!(dropped, 2);
    }

    #[test]
    fn empty_and_single() {
        assert_eq!(timing(&[]), Timing::default());
        let t = timing(&[5]);
        assert_eq!(t.span_ns, Some((5, 5)));
        assert_eq!(t.rate_hz(), None);
    }
}
