//! Statistics of a run: per-sensor innovation statistics, distance travelled.

use crate::filters::ins::aid_table::Sensor;
use crate::filters::ins::driver::ForwardRun;
use crate::filters::ins::driver::Residual;
use crate::filters::ins::record::Solution;
use crate::geodesy;
use crate::recon::alignment::start::Initialisation;
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
    pub sensor: Sensor,
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

/// Statistics of every sensor that has residuals. A stuck sensor's rejected repeats are left
/// out: they say nothing of its noise or its clock (they are warned of on their own).
pub fn sensor_stats(residuals: &[Residual]) -> Vec<SensorStats> {
    Sensor::ALL
        .iter()
        .filter_map(|&sensor| {
            let all: Vec<&Residual> = residuals
                .iter()
                .filter(|r| r.sensor == sensor && (r.accepted || !r.repeats))
                .collect();
            if all.is_empty() {
                return None;
            }
            let accepted: Vec<&&Residual> = all.iter().filter(|r| r.accepted).collect();
            let n = accepted.len().max(1) as f64;
            let mean_nis = accepted.iter().map(|r| r.nis).sum::<f64>() / n;
            let z: Vec<f64> = accepted
                .iter()
                .flat_map(|r| (0..usize::from(r.dims)).map(move |i| r.innovation[i] / r.sigma[i]))
                .collect();
            let m = z.len().max(1) as f64;
            let mean = z.iter().sum::<f64>() / m;
            let variance = z.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / m;
            Some(SensorStats {
                sensor,
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

/// A sensor's innovation figures, for a warning.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Flagged {
    pub sensor: Sensor,
    pub mean_nis: f64,
    pub dims: usize,
    pub rejected_pct: f64,
}

impl From<&SensorStats> for Flagged {
    fn from(s: &SensorStats) -> Self {
        Flagged {
            sensor: s.sensor,
            mean_nis: s.mean_nis,
            dims: s.dims,
            rejected_pct: 100.0 * s.rejected as f64 / s.count.max(1) as f64,
        }
    }
}

/// What a navigation engineer should read of a run, with its data.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum RunWarning {
    /// Every judged sensor's innovations are too large: the IMU is the one thing they share.
    ImuNoisier { sensors: Vec<Flagged> },
    /// One sensor's innovations are too large for its noise setting.
    InnovationsTooLarge(Flagged),
    /// Some of a sensor's measurements were rejected by the gate.
    Rejected {
        sensor: Sensor,
        rejected: usize,
        count: usize,
    },
    /// The gate was reopened after runs of rejections.
    GateReopened { times: usize },
    /// A long run of one sensor's readings was rejected, none let back in.
    LongRejectedRun { sensor: Sensor, readings: usize },
    /// Rejected readings that repeated the readings before exactly: a stuck sensor, whose
    /// gate was never reopened for them.
    StuckReadings { sensor: Sensor, readings: usize },
    /// Readings skipped: their innovation covariance was not positive definite.
    NotPositiveDefinite { sensor: Sensor, readings: usize },
    /// An IMU gap, bridged.
    ImuGap { from_ns: i64, seconds: f64 },
    /// No declination for the log's date: 0 with a 20 deg sigma.
    DeclinationUnknown,
    /// Heading sources (or the alignment) that disagree.
    HeadingDisagreement(crate::recon::alignment::heading::HeadingDisagreement),
    /// Magnetometer readings left out as a disturbed field.
    MagDisturbed { readings: usize },
    /// A long stretch with no velocity measurement taken (none in range, or all rejected):
    /// the IMU alone carried the track there.
    UnaidedVelocity {
        from_ns: i64,
        seconds: f64,
        /// Of the span of the measurements.
        share: f64,
    },
}

impl std::fmt::Display for RunWarning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let figures = |x: &Flagged| {
            format!(
                "{} mean NIS {:.1} for {}, {:.0} % rejected",
                x.sensor, x.mean_nis, x.dims, x.rejected_pct
            )
        };
        match self {
            RunWarning::ImuNoisier { sensors } => write!(
                f,
                "the innovations of every aiding sensor are too large ({}): the IMU is probably \
                 much noisier than its figures ([imu]); let self-tuning estimate them, or give \
                 the data sheet's",
                sensors.iter().map(figures).collect::<Vec<_>>().join("; ")
            ),
            RunWarning::InnovationsTooLarge(x) => write!(
                f,
                "{}: mean NIS {:.1} for {} expected, {:.1} % rejected: its noise setting may be \
                 too small, its clock offset or its mounting wrong",
                x.sensor, x.mean_nis, x.dims, x.rejected_pct
            ),
            RunWarning::Rejected {
                sensor,
                rejected,
                count,
            } => write!(
                f,
                "{sensor}: {rejected} of {count} measurements rejected by the gate (see \
                 residuals.parquet)"
            ),
            RunWarning::GateReopened { times } => write!(
                f,
                "the gate was reopened {times} times after a sensor's measurements had been \
                 rejected many times in a row: the filter had drifted from it (see \
                 residuals.parquet)"
            ),
            RunWarning::LongRejectedRun { sensor, readings } => write!(
                f,
                "{sensor}: {readings} readings in a row were rejected by the gate (the longest \
                 run): a stuck or faulty sensor, or a filter that drifted from it (see \
                 residuals.parquet)"
            ),
            RunWarning::StuckReadings { sensor, readings } => write!(
                f,
                "{sensor}: {readings} readings repeated the ones before exactly and disagreed \
                 with the filter: a stuck sensor? None of them was applied (see \
                 residuals.parquet)"
            ),
            RunWarning::NotPositiveDefinite { sensor, readings } => write!(
                f,
                "{sensor}: {readings} readings skipped, their innovation covariance not positive \
                 definite (a measurement covariance of zero or less, or a covariance that lost \
                 its definiteness)"
            ),
            RunWarning::ImuGap { from_ns, seconds } => write!(
                f,
                "IMU gap of {seconds:.2} s at {}: bridged with grown covariance",
                crate::time::format_utc(*from_ns)
            ),
            RunWarning::DeclinationUnknown => write!(
                f,
                "magnetic declination unknown (no geomagnetic model covers the log's date: \
                 IGRF-14 covers 1900-2030), taken as 0 with a 20 deg sigma"
            ),
            RunWarning::HeadingDisagreement(d) => write!(f, "{d}"),
            RunWarning::MagDisturbed { readings } => write!(
                f,
                "mag: {readings} readings left out, their field magnitude off the log's median \
                 by more than mag.max_field_deviation (a disturbed field)"
            ),
            RunWarning::UnaidedVelocity {
                from_ns,
                seconds,
                share,
            } => write!(
                f,
                "no velocity measurement was taken for {seconds:.0} s from {} ({:.0} % of the \
                 run: the DVL had no bottom lock, was out of range or was rejected): the IMU \
                 alone carried the track there, and its speeds and positions in that stretch \
                 are the IMU's drift, not the vehicle's (see residuals.parquet)",
                crate::time::format_utc(*from_ns),
                100.0 * share
            ),
        }
    }
}

/// The longest stretch without a velocity measurement taken that is worth a warning: this
/// long, and this share of the run.
const UNAIDED_VELOCITY_S: f64 = 20.0;
const UNAIDED_VELOCITY_SHARE: f64 = 0.1;

/// The longest stretch between velocity measurements taken (DVL, EM log, the propeller's or
/// the model's velocity), when it is long ([`UNAIDED_VELOCITY_S`]) and a large share of the
/// run ([`UNAIDED_VELOCITY_SHARE`]); `None` for a run without any velocity sensor.
fn unaided_velocity(residuals: &[crate::filters::ins::driver::Residual]) -> Option<RunWarning> {
    let velocity = |s: Sensor| {
        matches!(
            s,
            Sensor::Dvl | Sensor::SpeedLog | Sensor::RpmVelocity | Sensor::ModelVelocity
        )
    };
    let (first, last) = (residuals.first()?.stamp_ns, residuals.last()?.stamp_ns);
    let taken: Vec<i64> = residuals
        .iter()
        .filter(|r| velocity(r.sensor) && r.accepted)
        .map(|r| r.stamp_ns)
        .collect();
    if !residuals.iter().any(|r| velocity(r.sensor)) {
        return None;
    }
    // The stretches before the first, between, and after the last taken measurement.
    let edges: Vec<i64> = std::iter::once(first)
        .chain(taken.iter().copied())
        .chain(std::iter::once(last))
        .collect();
    let (from_ns, longest_ns) = edges
        .windows(2)
        .map(|w| (w[0], w[1] - w[0]))
        .max_by_key(|&(_, d)| d)?;
    let seconds = longest_ns as f64 * 1e-9;
    let share = longest_ns as f64 / (last - first).max(1) as f64;
    (seconds >= UNAIDED_VELOCITY_S && share >= UNAIDED_VELOCITY_SHARE).then_some(
        RunWarning::UnaidedVelocity {
            from_ns,
            seconds,
            share,
        },
    )
}

/// Rejections in a row worth a warning: a sensor locked out that long is stuck or faulty, or
/// the filter has drifted from it without its readings agreeing enough to let it back in.
const LONG_REJECTED_RUN: usize = 50;

/// Warnings a navigation engineer should read: sensors whose innovations disagree with
/// their noise settings, IMU gaps, an unknown declination.
pub fn warnings(
    run: &ForwardRun,
    init: &Initialisation,
    sensors: &[SensorStats],
) -> Vec<RunWarning> {
    let mut out = Vec::new();
    let flagged: Vec<&SensorStats> = sensors
        .iter()
        .filter(|s| innovations_too_large(s))
        .collect();
    // Every judged sensor off at once points at the one thing they share: the IMU.
    let judged = sensors.iter().filter(|s| s.count >= 20).count();
    let blame_imu = flagged.len() >= 2 && flagged.len() == judged;
    if blame_imu {
        out.push(RunWarning::ImuNoisier {
            sensors: flagged.iter().map(|s| Flagged::from(*s)).collect(),
        });
    }
    for s in sensors {
        if innovations_too_large(s) {
            if !blame_imu {
                out.push(RunWarning::InnovationsTooLarge(s.into()));
            }
        } else if s.rejected > 0 {
            out.push(RunWarning::Rejected {
                sensor: s.sensor,
                rejected: s.rejected,
                count: s.count,
            });
        }
    }
    if run.gate_resets > 0 {
        out.push(RunWarning::GateReopened {
            times: run.gate_resets,
        });
    }
    for sensor in Sensor::ALL {
        let readings = run.longest_rejected_run[sensor];
        if readings >= LONG_REJECTED_RUN {
            out.push(RunWarning::LongRejectedRun { sensor, readings });
        }
        let readings = run.repeated_rejected[sensor];
        if readings > 0 {
            out.push(RunWarning::StuckReadings { sensor, readings });
        }
        let readings = run.not_positive_definite[sensor];
        if readings > 0 {
            out.push(RunWarning::NotPositiveDefinite { sensor, readings });
        }
    }
    out.extend(run.imu_gaps.iter().map(|g| RunWarning::ImuGap {
        from_ns: g.from_ns,
        seconds: (g.to_ns - g.from_ns) as f64 * 1e-9,
    }));
    let unknown = crate::recon::alignment::heading::DeclinationSource::Unknown;
    if init.declination.is_some_and(|d| d.source == unknown) {
        out.push(RunWarning::DeclinationUnknown);
    }
    out.extend(
        init.heading_disagreements
            .iter()
            .copied()
            .map(RunWarning::HeadingDisagreement),
    );
    if run.disturbed[Sensor::Magnetometer] > 0 {
        out.push(RunWarning::MagDisturbed {
            readings: run.disturbed[Sensor::Magnetometer],
        });
    }
    out.extend(unaided_velocity(&run.residuals));
    out
}

/// Horizontal distance along a solution, m.
pub fn distance_travelled_m<E>(
    solutions: impl IntoIterator<Item = Result<Solution, E>>,
) -> Result<f64, E> {
    let mut distance = Distance::default();
    for s in solutions {
        distance.add(&s?);
    }
    Ok(distance.total_m)
}

/// The distance travelled so far, summed a solution at a time.
#[derive(Debug, Clone, Copy, Default)]
pub struct Distance {
    pub total_m: f64,
    previous: Option<(f64, f64)>,
}

impl Distance {
    /// Adds the leg from the previous solution to `s`.
    pub fn add(&mut self, s: &Solution) {
        let here = (s.point.nav.lat_rad, s.point.nav.lon_rad);
        if let Some((lat, lon)) = self.previous {
            let (n, e) = geodesy::local_north_east_m(lat, lon, here.0, here.1);
            self.total_m += n.hypot(e);
        }
        self.previous = Some(here);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(t_s: i64, sensor: Sensor, accepted: bool) -> Residual {
        Residual {
            stamp_ns: t_s * 1_000_000_000,
            sensor,
            innovation: [0.0; 3],
            sigma: [1.0; 3],
            dims: 3,
            nis: 0.0,
            accepted,
            log_likelihood: 0.0,
            repeats: false,
            slant_range_m: None,
        }
    }

    /// A vehicle lifted out of the water: DVL readings taken for 17 s, none for 48 s (no
    /// bottom lock, then rejected), then taken again; the depth sensor's do not count.
    #[test]
    fn a_long_stretch_without_a_velocity_taken_is_told() {
        let mut r: Vec<Residual> = (0..=17).map(|t| at(t, Sensor::Dvl, true)).collect();
        r.extend((18..70).map(|t| at(t, Sensor::Depth, true)));
        r.extend((65..70).map(|t| at(t, Sensor::Dvl, false)));
        r.extend((70..=86).map(|t| at(t, Sensor::Dvl, true)));
        r.sort_by_key(|x| x.stamp_ns);
        let Some(RunWarning::UnaidedVelocity {
            from_ns,
            seconds,
            share,
        }) = unaided_velocity(&r)
        else {
            panic!("no warning");
        };
        assert_eq!(from_ns, 17_000_000_000);
        assert_eq!(seconds, 53.0);
        assert!((share - 53.0 / 86.0).abs() < 1e-12);
        // Readings taken every second: nothing to tell; no velocity sensor: nothing either.
        let steady: Vec<Residual> = (0..100).map(|t| at(t, Sensor::Dvl, true)).collect();
        assert_eq!(unaided_velocity(&steady), None);
        let depth: Vec<Residual> = (0..100).map(|t| at(t, Sensor::Depth, true)).collect();
        assert_eq!(unaided_velocity(&depth), None);
    }

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
                    log_likelihood: 0.0,
                    repeats: false,
                    slant_range_m: None,
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
