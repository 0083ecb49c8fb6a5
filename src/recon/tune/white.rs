//! The white noise of a sampled signal from the scatter of its second differences.
//!
//! For readings `x_k = s(t_k) + n_k` with white noise `n` of variance `sigma^2` and a signal
//! that is close to linear over two sample intervals, `d_k = x_{k+1} - 2 x_k + x_{k-1}` has
//! variance `6 sigma^2`. Manoeuvres and outliers are kept out robustly: differences beyond
//! five median absolute deviations are dropped before the variance is taken (when the
//! readings are quantised so finely that the median deviation is zero, nothing is dropped
//! but the largest 1 %).

use serde::Serialize;

/// Fewest usable second differences for an estimate.
pub const MIN_DIFFERENCES: usize = 30;

/// A white-noise estimate.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct WhiteNoise {
    /// 1-sigma of one reading, in the signal's unit.
    pub sigma: f64,
    /// Second differences it rests on.
    pub differences: usize,
}

/// Second differences of the readings `(stamp_ns, value)` in time order, over triples whose
/// two intervals are both within half and one and a half times the median interval (a gap
/// or a change of rate would make the signal's curvature count as noise).
pub fn second_differences(readings: &[(i64, f64)]) -> Vec<f64> {
    if readings.len() < 3 {
        return Vec::new();
    }
    let mut dts: Vec<i64> = readings.windows(2).map(|w| w[1].0 - w[0].0).collect();
    let mid = dts.len() / 2;
    let median = *dts.select_nth_unstable(mid).1;
    if median <= 0 {
        return Vec::new();
    }
    let regular = |dt: i64| 2 * dt >= median && 2 * dt <= 3 * median;
    readings
        .windows(3)
        .filter(|w| regular(w[1].0 - w[0].0) && regular(w[2].0 - w[1].0))
        .map(|w| w[2].1 - 2.0 * w[1].1 + w[0].1)
        .filter(|d| d.is_finite())
        .collect()
}

/// The white noise of readings in time order; `None` with fewer than [`MIN_DIFFERENCES`]
/// usable second differences.
pub fn white_noise(readings: &[(i64, f64)]) -> Option<WhiteNoise> {
    white_noise_of_differences(second_differences(readings))
}

/// The white noise behind a set of second differences (several channels may be pooled).
pub fn white_noise_of_differences(mut d: Vec<f64>) -> Option<WhiteNoise> {
    if d.len() < MIN_DIFFERENCES {
        return None;
    }
    let median = median_of(&mut d.clone());
    let mad = median_of(&mut d.iter().map(|x| (x - median).abs()).collect::<Vec<_>>());
    if mad > 0.0 {
        let bound = 5.0 * 1.4826 * mad;
        d.retain(|x| (x - median).abs() <= bound);
    } else {
        d.sort_by(|a, b| a.abs().total_cmp(&b.abs()));
        d.truncate(d.len() - d.len() / 100);
    }
    let mean_square = d.iter().map(|x| x * x).sum::<f64>() / d.len() as f64;
    Some(WhiteNoise {
        sigma: (mean_square / 6.0).sqrt(),
        differences: d.len(),
    })
}

fn median_of(v: &mut [f64]) -> f64 {
    let mid = v.len() / 2;
    *v.select_nth_unstable_by(mid, f64::total_cmp).1
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    /// White noise on a manoeuvring signal (ramps and a slow sine), with a few outliers and a
    /// gap: the estimate is within 5 % of the truth.
    #[test]
    fn recovers_white_noise_under_manoeuvres_and_outliers() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let noise = Normal::new(0.0, 0.03).unwrap();
        let readings: Vec<(i64, f64)> = (0..4000)
            .filter(|k| !(1000..1100).contains(k))
            .map(|k| {
                let t = k as f64 * 0.2;
                let signal = 1.5 * (t / 40.0).min(1.0) + 0.3 * (t / 60.0).sin();
                let outlier = if k % 500 == 7 { 3.0 } else { 0.0 };
                (k * 200_000_000, signal + noise.sample(&mut rng) + outlier)
            })
            .collect();
        let w = white_noise(&readings).unwrap();
        assert!((w.sigma / 0.03 - 1.0).abs() < 0.05, "{w:?}");
        assert!(w.differences > 3800, "{w:?}");
    }

    #[test]
    fn too_few_readings_give_no_estimate() {
        let readings: Vec<(i64, f64)> = (0..20).map(|k| (k, k as f64)).collect();
        assert!(white_noise(&readings).is_none());
    }

    /// Readings quantised to 1 cm on a still signal: the quantisation is the noise.
    #[test]
    fn quantised_readings_are_not_noise_free() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let noise = Normal::new(0.0, 0.004).unwrap();
        let readings: Vec<(i64, f64)> = (0..2000)
            .map(|k| {
                (
                    k * 100_000_000,
                    ((10.0f64 + noise.sample(&mut rng)) * 100.0).round() / 100.0,
                )
            })
            .collect();
        let w = white_noise(&readings).unwrap();
        assert!(w.sigma > 0.002 && w.sigma < 0.01, "{w:?}");
    }
}
