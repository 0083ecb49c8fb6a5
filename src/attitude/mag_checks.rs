//! Magnetometer readings that cannot be trusted: a saturated (clipped) sensor repeats its
//! limit. A reading with an axis at that axis's extreme value of the whole log, in a run of
//! at least `repeats` consecutive readings at that value, is flagged; the flagged readings
//! are taken out of every method's input and reported as spans. An axis constant over the
//! whole log is not flagged.

use crate::contract::MagneticField;

/// Consecutive flagged readings.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct SaturatedSpan {
    pub from_ns: i64,
    pub to_ns: i64,
    pub readings: usize,
}

/// The readings to use, and the spans taken out.
pub fn without_saturation(
    mag: &[MagneticField],
    repeats: usize,
) -> (Vec<MagneticField>, Vec<SaturatedSpan>) {
    without_saturation_owned(mag.to_vec(), repeats)
}

/// [`without_saturation`], taking the readings out of `mag` in place (no copy of a long
/// log's readings).
pub fn without_saturation_owned(
    mut mag: Vec<MagneticField>,
    repeats: usize,
) -> (Vec<MagneticField>, Vec<SaturatedSpan>) {
    let mut flagged = vec![false; mag.len()];
    for axis in 0..3 {
        let value = |k: usize| mag[k].magnetic_field[axis];
        let (lo, hi) = mag.iter().fold((f64::MAX, f64::MIN), |(lo, hi), m| {
            (
                lo.min(m.magnetic_field[axis]),
                hi.max(m.magnetic_field[axis]),
            )
        });
        let mut k = 0;
        while k < mag.len() {
            let v = value(k);
            let mut end = k + 1;
            while end < mag.len() && value(end) == v {
                end += 1;
            }
            // An axis that never changes is left alone (it is not clipped, or the whole log
            // is useless and the methods will say so).
            if lo < hi && (v == lo || v == hi) && end - k >= repeats {
                flagged[k..end].iter_mut().for_each(|f| *f = true);
            }
            k = end;
        }
    }
    let mut spans: Vec<SaturatedSpan> = Vec::new();
    let mut previous_flagged = false;
    for (m, &f) in mag.iter().zip(&flagged) {
        if f {
            match spans.last_mut() {
                Some(s) if previous_flagged => {
                    s.to_ns = m.stamp_ns;
                    s.readings += 1;
                }
                _ => spans.push(SaturatedSpan {
                    from_ns: m.stamp_ns,
                    to_ns: m.stamp_ns,
                    readings: 1,
                }),
            }
        }
        previous_flagged = f;
    }
    let mut flags = flagged.iter();
    mag.retain(|_| !flags.next().copied().unwrap_or(false));
    (mag, spans)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_clipped_axis_is_flagged_and_noise_is_not() {
        let mut mag: Vec<MagneticField> = (0..1000)
            .map(|k| MagneticField {
                stamp_ns: k * 20_000_000,
                magnetic_field: [20e-6 + (k as f64 * 0.37).sin() * 1e-6, 1e-6, 40e-6],
            })
            .collect();
        // 5 s at 50 Hz clipped at the sensor's limit on x.
        for m in &mut mag[300..550] {
            m.magnetic_field[0] = 250e-6;
        }
        let (kept, spans) = without_saturation(&mag, 3);
        assert_eq!(spans.len(), 1);
        assert_eq!(spans[0].readings, 250);
        assert_eq!(
            (spans[0].from_ns, spans[0].to_ns),
            (300 * 20_000_000, 549 * 20_000_000)
        );
        // y and z are constant over the whole log: not flagged.
        assert_eq!(kept.len(), 750);
        // Without the clipping nothing is flagged.
        for m in &mut mag[300..550] {
            m.magnetic_field[0] = 20e-6;
        }
        let (kept, spans) = without_saturation(&mag, 3);
        assert!(spans.is_empty() && kept.len() == 1000);
    }
}
