//! Statistics of a run: per-sensor innovation statistics, distance travelled.

use crate::filters::ins::aiding::Sensor;
use crate::filters::ins::driver::ForwardRun;
use crate::filters::ins::driver::Residual;
use crate::filters::ins::record::Solution;
use crate::geodesy;
use crate::recon::init::Initialisation;
use serde::Serialize;

/// Stretches without a usable DVL reading (no bottom lock, or no reading at all) longer than
/// `min_s`: from the last usable reading before to the first after, in ns. A log that ends
/// (or starts) without lock has a stretch to its last (from its first) reading.
pub fn dvl_outages(dvl: &[crate::contract::Dvl], min_s: f64) -> Vec<(i64, i64)> {
    let min_ns = (min_s * 1e9) as i64;
    let mut spans = Vec::new();
    let (Some(first), Some(last)) = (dvl.first(), dvl.last()) else {
        return spans;
    };
    let mut from = first.stamp_ns;
    for d in dvl.iter().filter(|d| d.valid) {
        if d.stamp_ns - from > min_ns {
            spans.push((from, d.stamp_ns));
        }
        from = d.stamp_ns;
    }
    if last.stamp_ns - from > min_ns {
        spans.push((from, last.stamp_ns));
    }
    spans
}

/// Innovation statistics of one sensor.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SensorStats {
    pub sensor: &'static str,
    /// Measurements the filter saw (accepted or rejected by the gate).
    pub count: usize,
    pub rejected: usize,
    /// Components of one innovation.
    pub dims: usize,
    /// Mean NIS of the accepted measurements (a consistent filter: `dims`).
    pub mean_nis: f64,
    /// Mean and variance of the normalised innovation components (innovation over its
    /// predicted sigma) of the accepted measurements (consistent: 0 and 1).
    pub normalised_mean: f64,
    pub normalised_variance: f64,
}

/// Statistics of every sensor that has residuals.
pub fn sensor_stats(residuals: &[Residual]) -> Vec<SensorStats> {
    Sensor::ALL
        .iter()
        .filter_map(|&sensor| {
            let all: Vec<&Residual> = residuals.iter().filter(|r| r.sensor == sensor).collect();
            if all.is_empty() {
                return None;
            }
            let accepted: Vec<&&Residual> = all.iter().filter(|r| r.accepted).collect();
            let n = accepted.len().max(1) as f64;
            let mean_nis = accepted.iter().map(|r| r.nis).sum::<f64>() / n;
            let z: Vec<f64> = accepted
                .iter()
                .flat_map(|r| (0..r.dims).map(move |i| r.innovation[i] / r.sigma[i]))
                .collect();
            let m = z.len().max(1) as f64;
            let mean = z.iter().sum::<f64>() / m;
            let variance = z.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / m;
            Some(SensorStats {
                sensor: sensor.name(),
                count: all.len(),
                rejected: all.len() - accepted.len(),
                dims: sensor.dims(),
                mean_nis,
                normalised_mean: mean,
                normalised_variance: variance,
            })
        })
        .collect()
}

/// A sensor whose innovations are too large for its noise setting: a mean NIS over twice its
/// size, or over 5 % rejected (judged from 20 measurements).
pub fn innovations_too_large(s: &SensorStats) -> bool {
    s.count >= 20 && (s.mean_nis > 2.0 * s.dims as f64 || s.rejected as f64 / s.count as f64 > 0.05)
}

/// Warnings a navigation engineer should read: sensors whose innovations disagree with
/// their noise settings, IMU gaps, an unknown declination.
pub fn warnings(run: &ForwardRun, init: &Initialisation, sensors: &[SensorStats]) -> Vec<String> {
    let mut out = Vec::new();
    let too_large = innovations_too_large;
    let flagged: Vec<&SensorStats> = sensors.iter().filter(|s| too_large(s)).collect();
    // Every judged sensor off at once points at the one thing they share: the IMU.
    let judged = sensors.iter().filter(|s| s.count >= 20).count();
    let blame_imu = flagged.len() >= 2 && flagged.len() == judged;
    if blame_imu {
        out.push(format!(
            "the innovations of every aiding sensor are too large ({}): the IMU is probably much \
             noisier than its figures ([imu]); let self-tuning estimate them, or give the data \
             sheet's",
            flagged
                .iter()
                .map(|s| format!(
                    "{} mean NIS {:.1} for {}, {:.0} % rejected",
                    s.sensor,
                    s.mean_nis,
                    s.dims,
                    100.0 * s.rejected as f64 / s.count as f64
                ))
                .collect::<Vec<_>>()
                .join("; ")
        ));
    }
    for s in sensors {
        let rejected = s.rejected as f64 / s.count as f64;
        if too_large(s) && blame_imu {
            continue;
        }
        if too_large(s) {
            out.push(format!(
                "{}: mean NIS {:.1} for {} expected, {:.1} % rejected: its noise setting may be too \
                 small, its clock offset (--offset /{}=SECONDS), or its mounting wrong",
                s.sensor,
                s.mean_nis,
                s.dims,
                100.0 * rejected,
                if s.sensor == "position_fix" { "position_fix" } else { s.sensor }
            ));
        } else if s.rejected > 0 {
            out.push(format!(
                "{}: {} of {} measurements rejected by the gate (see residuals.parquet)",
                s.sensor, s.rejected, s.count
            ));
        }
    }
    if run.gate_resets > 0 {
        out.push(format!(
            "the gate was reopened {} times after a sensor's measurements had been rejected many \
             times in a row: the filter had drifted from it (see residuals.parquet)",
            run.gate_resets
        ));
    }
    for g in &run.imu_gaps {
        out.push(format!(
            "IMU gap of {:.2} s at {}: bridged with grown covariance",
            (g.to_ns - g.from_ns) as f64 * 1e-9,
            crate::time::format_utc(g.from_ns)
        ));
    }
    if let Some(d) = init.declination {
        if d.source == crate::recon::heading::DeclinationSource::Unknown {
            out.push(
                "magnetic declination unknown (the World Magnetic Model has no value for the \
                 log's date), taken as 0 with a 20 deg sigma: pass --declination DEG"
                    .into(),
            );
        }
    }
    out.extend(init.heading_disagreements.iter().cloned());
    if run.disturbed[Sensor::Magnetometer] > 0 {
        out.push(format!(
            "mag: {} readings left out, their field magnitude off the log's median by more \
             than mag.max_field_deviation (a disturbed field)",
            run.disturbed[Sensor::Magnetometer]
        ));
    }
    out
}

/// Horizontal distance along a solution, m.
pub fn distance_travelled_m<E>(
    solutions: impl IntoIterator<Item = Result<Solution, E>>,
) -> Result<f64, E> {
    let mut total = 0.0;
    let mut previous: Option<Solution> = None;
    for s in solutions {
        let s = s?;
        if let Some(p) = previous {
            let (a, b) = (&p.point.nav, &s.point.nav);
            let (n, e) = geodesy::local_north_east_m(a.lat_rad, a.lon_rad, b.lat_rad, b.lon_rad);
            total += n.hypot(e);
        }
        previous = Some(s);
    }
    Ok(total)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normalised_innovations_of_a_consistent_sensor() {
        use rand::SeedableRng;
        use rand_distr::{Distribution, Normal};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let normal = Normal::new(0.0, 2.0).unwrap();
        let residuals: Vec<Residual> = (0..20_000)
            .map(|k| {
                let innovation = [normal.sample(&mut rng), normal.sample(&mut rng), 0.0];
                Residual {
                    stamp_ns: k,
                    sensor: Sensor::Gnss,
                    innovation,
                    sigma: [2.0, 2.0, 0.0],
                    dims: 2,
                    nis: (innovation[0].powi(2) + innovation[1].powi(2)) / 4.0,
                    accepted: k % 100 != 0,
                }
            })
            .collect();
        let s = sensor_stats(&residuals);
        assert_eq!(s.len(), 1);
        assert_eq!((s[0].count, s[0].rejected, s[0].dims), (20_000, 200, 2));
        assert!((s[0].mean_nis - 2.0).abs() < 0.05, "{}", s[0].mean_nis);
        assert!(s[0].normalised_mean.abs() < 0.02);
        assert!((s[0].normalised_variance - 1.0).abs() < 0.03);
    }
}
