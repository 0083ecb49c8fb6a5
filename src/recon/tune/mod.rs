//! Self-tuning: the noise figures a configuration does not give, estimated from the log.
//!
//! - `white`: the white noise of the DVL, depth sensor and EM log from the scatter of
//!   consecutive readings;
//! - `stationary`: the IMU's angle and velocity random walks from the Allan deviation where
//!   the vehicle was still, when it was for a minute or more;
//! - `moving`: else an upper bound of them from the high-frequency content of the IMU's
//!   samples while the vehicle moves (its vibration adds to it);
//! - `imu`: the IMU's noise by maximum likelihood of the forward filter's innovations over
//!   the mission's first span (the biases alone: the white noise is the IMU's own, measured).
//!
//! A figure the configuration gives is kept ([`Config::fixed`]) and reported as kept.

pub mod bands;
pub mod imu;
pub mod moving;
pub mod stationary;
pub mod white;

use crate::ingest::Mission;
use crate::recon::config::{Config, ImuSpec};
use crate::recon::Streams;
use serde::Serialize;
use std::fmt;
use white::WhiteNoise;

/// Where a figure came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Source {
    /// Estimated from the log.
    Estimated,
    /// Given by the configuration, kept.
    Configured,
    /// The built-in default: nothing to estimate it from, or the estimate failed.
    Default,
}

/// One aiding sensor's white noise.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SensorNoise {
    /// The configuration key it sets.
    pub key: &'static str,
    pub value: f64,
    pub source: Source,
    /// Second differences the estimate rests on (when estimated).
    pub differences: Option<usize>,
}

/// How the IMU's white noise was measured from its own data.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum WhiteFrom {
    /// The Allan deviation at 1 s over a still stretch.
    Still,
    /// The fourth differences of the samples while the vehicle moved.
    Moving,
}

/// The IMU's white noise measured from its own data: a still stretch's is the sensor's own and
/// every candidate takes it; the moving samples' is an upper bound (the hull's vibration adds
/// to it) that only bounds the bias prior and the noisier rungs' white noise.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ImuWhite {
    pub gyro_arw_deg_rt_h: f64,
    pub accel_vrw_ug_rt_hz: f64,
    pub from: WhiteFrom,
}

impl ImuWhite {
    /// Whether this is the sensor's white noise itself (a still stretch's), not an upper
    /// bound of it (the moving samples' high-frequency content: vibration adds to it).
    pub fn is_measured(&self) -> bool {
        self.from == WhiteFrom::Still
    }

    /// A still stretch's, else the moving samples'.
    fn of(
        still: Option<&stationary::StillNoise>,
        moving: Option<&moving::MovingNoise>,
    ) -> Option<Self> {
        let still = still.map(|s| ImuWhite {
            gyro_arw_deg_rt_h: s.gyro_arw_deg_rt_h,
            accel_vrw_ug_rt_hz: s.accel_vrw_ug_rt_hz,
            from: WhiteFrom::Still,
        });
        still.or(moving.map(|m| ImuWhite {
            gyro_arw_deg_rt_h: m.gyro_arw_deg_rt_h,
            accel_vrw_ug_rt_hz: m.accel_vrw_ug_rt_hz,
            from: WhiteFrom::Moving,
        }))
    }
}

/// The IMU's noise.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ImuNoiseTuning {
    pub source: Source,
    /// The model used ("tactical", "mems x100", ...; "configured").
    pub model: String,
    pub figures: ImuSpec,
    /// Every model tried, with its log-likelihood.
    pub candidates: Vec<imu::Scored>,
    /// The ladder's rungs not scored, and why.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub not_scored: Option<String>,
    /// The white noise measured where the vehicle was still ...
    pub still: Option<stationary::StillNoise>,
    /// ... and from the samples while it moved (measured when there was no still stretch).
    pub moving: Option<moving::MovingNoise>,
    /// The one the search used: a still stretch's as every model's white noise (the search
    /// then finds the biases alone), or the moving samples' as an upper bound of it.
    pub white: Option<ImuWhite>,
}

/// What self-tuning did.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Tuning {
    /// The span the IMU was tuned on, s.
    pub span_s: f64,
    /// The log's first IMU stamp (for times in the report).
    pub log_start_ns: i64,
    pub imu: ImuNoiseTuning,
    pub sensors: Vec<SensorNoise>,
    /// The DVL's lever arm the plan estimated and used, body FRD, m (given back with the
    /// tuned figures).
    pub dvl_lever_arm_m: Option<[f64; 3]>,
    pub warnings: Vec<TuningWarning>,
}

/// What a user should know of self-tuning.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum TuningWarning {
    /// No candidate noise model could run over the tuning span: the configuration's figures
    /// are used.
    NoNoiseModelRan,
    /// The likelihood still rose after the last refinement round: the most likely model found
    /// is used.
    NoiseStillRising { rounds: usize, model: String },
    /// A tuned bias instability lets the bias wander faster than a still stretch's Allan
    /// deviation allows.
    InstabilityBeyondStill {
        sensor: &'static str,
        tuned: f64,
        bound: f64,
        unit: &'static str,
        correlation_s: f64,
        still_s: f64,
    },
}

impl fmt::Display for TuningWarning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            TuningWarning::NoNoiseModelRan => f.write_str(
                "imu: no candidate noise model could run over the tuning span; the \
                 configuration's figures are used",
            ),
            TuningWarning::NoiseStillRising { rounds, model } => write!(
                f,
                "imu: the noise estimate was still rising after {rounds} refinement rounds; \
                 the most likely model found ({model}) is used"
            ),
            TuningWarning::InstabilityBeyondStill {
                sensor,
                tuned,
                bound,
                unit,
                correlation_s,
                still_s,
            } => write!(
                f,
                "the tuned {sensor} bias instability {tuned:.3} {unit} (correlation \
                 {correlation_s:.0} s) lets the bias wander faster than the {still_s:.0} s \
                 still stretch's Allan deviation allows (at most {bound:.3} {unit}): the \
                 likelihood may have given the IMU errors of the aiding sensors"
            ),
        }
    }
}

/// The streams cut to their first `span_s` seconds from the first IMU sample.
pub(crate) fn first_span<'a>(streams: &Streams<'a>, span_s: f64) -> Streams<'a> {
    let Some(t0) = streams.imu.first().map(|m| m.stamp_ns) else {
        return *streams;
    };
    let end = t0.saturating_add((span_s * 1e9) as i64);
    fn cut<T: crate::contract::Message>(v: &[T], end: i64) -> &[T] {
        &v[..v.partition_point(|m| m.stamp_ns() <= end)]
    }
    Streams {
        imu: cut(streams.imu, end),
        mag: cut(streams.mag, end),
        dvl: cut(streams.dvl, end),
        altimeter: cut(streams.altimeter, end),
        eml: cut(streams.eml, end),
        depth: cut(streams.depth, end),
        gnss: cut(streams.gnss, end),
        fixes: cut(streams.fixes, end),
        rpm: cut(streams.rpm, end),
        fins: cut(streams.fins, end),
        truth: cut(streams.truth, end),
        acoustic_fixes: cut(streams.acoustic_fixes, end),
        usbl: cut(streams.usbl, end),
        ship: cut(streams.ship, end),
        lbl: cut(streams.lbl, end),
        beacons: streams.beacons,
    }
}

/// The white noise of the aiding sensors: DVL (the three axes pooled, bottom-locked readings
/// only), depth, EM log.
fn sensor_noise(streams: &Streams<'_>) -> [(&'static str, Option<WhiteNoise>); 3] {
    let dvl: Vec<f64> = (0..3)
        .flat_map(|axis| {
            let readings: Vec<(i64, f64)> = streams
                .dvl
                .iter()
                .filter(|d| d.valid)
                .map(|d| (d.stamp_ns, d.velocity[axis]))
                .collect();
            white::second_differences(&readings)
        })
        .collect();
    let depth: Vec<(i64, f64)> = streams
        .depth
        .iter()
        .map(|d| (d.stamp_ns, d.depth))
        .collect();
    let eml: Vec<(i64, f64)> = streams.eml.iter().map(|e| (e.stamp_ns, e.speed)).collect();
    [
        ("dvl.sigma_m_s", white::white_noise_of_differences(dvl)),
        ("depth.sigma_m", white::white_noise(&depth)),
        ("eml.sigma_m_s", white::white_noise(&eml)),
    ]
}

/// Least sigma taken from an estimate, per key: below it a reading's error is dominated by
/// what the white noise does not show (resolution, scale and bias).
fn floor(key: &str) -> f64 {
    match key {
        "depth.sigma_m" => 0.005,
        _ => 0.002,
    }
}

fn slot<'c>(config: &'c mut Config, key: &str) -> &'c mut f64 {
    match key {
        "dvl.sigma_m_s" => &mut config.dvl.sigma_m_s,
        "depth.sigma_m" => &mut config.depth.sigma_m,
        _ => &mut config.eml.sigma_m_s,
    }
}

/// Estimates what the configuration does not give; returns the configuration to run with
/// and the report. With `[tune] use = false`, the configuration unchanged and no report.
pub fn tune(streams: &Streams<'_>, mission: &Mission, config: &Config) -> (Config, Option<Tuning>) {
    tune_from(streams, mission, config, crate::recon::Prepared::default())
}

/// [`tune`], the IMU's candidates started as `from` says (the pipeline's settled heading and
/// prepared magnetometer).
pub(crate) fn tune_from(
    streams: &Streams<'_>,
    mission: &Mission,
    config: &Config,
    from: crate::recon::Prepared<'_>,
) -> (Config, Option<Tuning>) {
    if !config.tune.enabled {
        return (config.clone(), None);
    }
    let mut tuned = config.clone();
    let mut warnings = Vec::new();
    let mut sensors = tune_sensor_noise(streams, config, &mut tuned);
    let imu = if config.fixed.iter().any(|k| k.starts_with("imu.")) {
        ImuNoiseTuning {
            source: Source::Configured,
            model: "configured".into(),
            figures: config.imu.spec(),
            candidates: Vec::new(),
            not_scored: None,
            still: None,
            moving: None,
            white: None,
        }
    } else {
        let tuned_imu = tune_imu(streams, mission, config, &mut tuned, from);
        warnings.extend(tuned_imu.warning);
        sensors.extend(tuned_imu.dvl_walk);
        tuned_imu.imu
    };
    warnings.extend(instability_beyond_bound(&imu));
    (
        tuned,
        Some(Tuning {
            span_s: config.tune.span_s,
            log_start_ns: streams.imu.first().map_or(0, |m| m.stamp_ns),
            imu,
            sensors,
            dvl_lever_arm_m: None,
            warnings,
        }),
    )
}

/// The white noise of the DVL, depth sensor and EM log from the scatter of their readings,
/// set in `tuned` unless the configuration gives it.
fn tune_sensor_noise(
    streams: &Streams<'_>,
    config: &Config,
    tuned: &mut Config,
) -> Vec<SensorNoise> {
    sensor_noise(streams)
        .into_iter()
        .map(|(key, estimate)| {
            if config.fixed.contains(key) {
                return SensorNoise {
                    key,
                    value: *slot(tuned, key),
                    source: Source::Configured,
                    differences: None,
                };
            }
            match estimate {
                Some(w) => {
                    let value = w.sigma.max(floor(key));
                    *slot(tuned, key) = value;
                    SensorNoise {
                        key,
                        value,
                        source: Source::Estimated,
                        differences: Some(w.differences),
                    }
                }
                None => SensorNoise {
                    key,
                    value: *slot(tuned, key),
                    source: Source::Default,
                    differences: None,
                },
            }
        })
        .collect()
}

/// What the IMU's tuning found, with the DVL drift it chose on the way.
struct TunedImu {
    imu: ImuNoiseTuning,
    dvl_walk: Vec<SensorNoise>,
    warning: Option<TuningWarning>,
}

/// The IMU's noise by the likelihood of the filter's innovations over the first span (its
/// white noise from a still stretch or the motion when there is one), set in `tuned`.
fn tune_imu(
    streams: &Streams<'_>,
    mission: &Mission,
    config: &Config,
    tuned: &mut Config,
    from: crate::recon::Prepared<'_>,
) -> TunedImu {
    let still = stationary::still_noise(streams.imu, streams.dvl);
    let span = first_span(streams, config.tune.span_s);
    let moving = still
        .is_none()
        .then(|| moving::moving_noise(span.imu))
        .flatten();
    let white = ImuWhite::of(still.as_ref(), moving.as_ref());
    let search = imu::search(&span, mission, tuned, white.as_ref(), from);
    let dvl_walk = search
        .dvl_bias_walk
        .map(|drift| chosen_dvl_drift(tuned, &drift))
        .unwrap_or_default();
    let imu = match search.best {
        Some(best) => {
            *tuned = imu::with_candidate(tuned, &best, white.as_ref());
            ImuNoiseTuning {
                source: Source::Estimated,
                model: best.label(),
                figures: best.spec_with(white.as_ref()),
                candidates: search.tried,
                not_scored: search.left_out,
                still,
                moving,
                white,
            }
        }
        None => ImuNoiseTuning {
            source: Source::Default,
            model: "configured".into(),
            figures: config.imu.spec(),
            candidates: search.tried,
            not_scored: search.left_out,
            still,
            moving,
            white,
        },
    };
    TunedImu {
        imu,
        dvl_walk,
        warning: search.warning,
    }
}

/// The DVL drift the search chose, set in `tuned`, as the figures it reports.
fn chosen_dvl_drift(tuned: &mut Config, drift: &imu::DvlDrift) -> Vec<SensorNoise> {
    tuned.dvl.bias_walk_m_s_rt_h = drift.walk_m_s_rt_h;
    tuned.dvl.bias_correlation_s = drift.correlation_s;
    let noise = |key, value, gain: f64| SensorNoise {
        key,
        value,
        source: if gain > 0.0 {
            Source::Estimated
        } else {
            Source::Default
        },
        differences: None,
    };
    let mut out = vec![noise(
        "dvl.bias_walk_m_s_rt_h",
        drift.walk_m_s_rt_h,
        drift.walk_gain,
    )];
    if drift.correlation_s > 0.0 {
        out.push(noise(
            "dvl.bias_correlation_s",
            drift.correlation_s,
            drift.correlation_gain,
        ));
    }
    out
}

/// A warning when the tuned bias instabilities let the biases wander faster than a still
/// stretch's Allan deviation allows: the likelihood gave the IMU errors that are elsewhere.
fn instability_beyond_bound(imu: &ImuNoiseTuning) -> Vec<TuningWarning> {
    let (Some(still), Source::Estimated) = (&imu.still, imu.source) else {
        return Vec::new();
    };
    let f = &imu.figures;
    let t = f.bias_correlation_s;
    let checks = [
        (
            "gyro",
            f.gyro_bias_instability_deg_h,
            still.gyro_bias_instability_bound_deg_h(t),
            "deg/h",
        ),
        (
            "accelerometer",
            f.accel_bias_instability_ug,
            still.accel_bias_instability_bound_ug(t),
            "ug",
        ),
    ];
    checks
        .into_iter()
        .filter_map(|(sensor, tuned, bound, unit)| {
            let bound = bound.filter(|b| tuned > *b)?;
            Some(TuningWarning::InstabilityBeyondStill {
                sensor,
                tuned,
                bound,
                unit,
                correlation_s: t,
                still_s: still.duration_s(),
            })
        })
        .collect()
}

impl Tuning {
    /// The tuned figures as a configuration file (`--config` reuses them; a figure given
    /// there is kept, so a rerun with it does not tune again).
    pub fn as_toml(&self) -> String {
        let f = &self.imu.figures;
        let mut out = format!(
            "# Noise figures estimated by hindsight reconstruct (self-tuning); reuse as a configuration file.\n\
             [imu]\n\
             # model: {}{}\n\
             gyro_bias_deg_h = {}\n\
             gyro_bias_instability_deg_h = {}\n\
             gyro_arw_deg_rt_h = {}\n\
             accel_bias_ug = {}\n\
             accel_bias_instability_ug = {}\n\
             accel_vrw_ug_rt_hz = {}\n\
             bias_correlation_s = {}\n",
            self.imu.model,
            match self.imu.white.map(|w| w.from) {
                Some(WhiteFrom::Still) => "; ARW and VRW from a still stretch (Allan deviation)",
                Some(WhiteFrom::Moving) => {
                    "; ARW and VRW from the IMU's samples while moving (fourth differences)"
                }
                None => "",
            },
            f.gyro_bias_deg_h,
            f.gyro_bias_instability_deg_h,
            f.gyro_arw_deg_rt_h,
            f.accel_bias_ug,
            f.accel_bias_instability_ug,
            f.accel_vrw_ug_rt_hz,
            f.bias_correlation_s
        );
        // One table per section (a TOML table may not be given twice).
        let mut sections: Vec<(&str, String)> = Vec::new();
        for s in &self.sensors {
            let (section, key) = s.key.split_once('.').unwrap_or(("", s.key));
            let line = format!("{key} = {:.6}\n", s.value);
            match sections.iter_mut().find(|(name, _)| *name == section) {
                Some((_, lines)) => lines.push_str(&line),
                None => sections.push((section, line)),
            }
        }
        if let Some([x, y, z]) = self.dvl_lever_arm_m {
            let line = format!("lever_arm_m = [{x:.3}, {y:.3}, {z:.3}]\n");
            match sections.iter_mut().find(|(name, _)| *name == "dvl") {
                Some((_, lines)) => lines.push_str(&line),
                None => sections.push(("dvl", line)),
            }
        }
        for (section, lines) in sections {
            out.push_str(&format!("\n[{section}]\n{lines}"));
        }
        out
    }
}

impl fmt::Display for Tuning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let source = |s: Source| match s {
            Source::Estimated => "estimated",
            Source::Configured => "configured, kept",
            Source::Default => "default",
        };
        let s = &self.imu.figures;
        writeln!(
            f,
            "IMU        {} ({}): gyro {:.3} deg/h, ARW {:.4} deg/sqrt(h); accel {:.0} ug, VRW {:.1} ug/sqrt(Hz)",
            self.imu.model,
            source(self.imu.source),
            s.gyro_bias_deg_h,
            s.gyro_arw_deg_rt_h,
            s.accel_bias_ug,
            s.accel_vrw_ug_rt_hz
        )?;
        if let Some(w) = &self.imu.still {
            writeln!(
                f,
                "           ARW and VRW from the Allan deviation at 1 s over a {:.0} s still \
                 stretch ({} s into the log)",
                w.duration_s(),
                (w.from_ns - self.log_start_ns) / 1_000_000_000
            )?;
            let t = s.bias_correlation_s;
            if let (Some(g), Some(a)) = (
                w.gyro_bias_instability_bound_deg_h(t),
                w.accel_bias_instability_bound_ug(t),
            ) {
                writeln!(
                    f,
                    "           bias instability at most {g:.3} deg/h and {a:.1} ug \
                     (correlation {t:.0} s) from the same stretch; tuned {:.3} deg/h, {:.1} ug",
                    s.gyro_bias_instability_deg_h, s.accel_bias_instability_ug
                )?;
            }
        }
        if !self.imu.candidates.is_empty() {
            writeln!(
                f,
                "           {} models scored on the first {:.0} s",
                self.imu.candidates.len(),
                self.span_s
            )?;
        }
        if let Some(why) = &self.imu.not_scored {
            writeln!(f, "           {why}")?;
        }
        for n in &self.sensors {
            write!(f, "{:<10} {:.4} ({})", n.key, n.value, source(n.source))?;
            if let Some(d) = n.differences {
                write!(f, " from {d} differences")?;
            }
            writeln!(f)?;
        }
        if let Some([x, y, z]) = self.dvl_lever_arm_m {
            writeln!(
                f,
                "dvl.lever_arm_m [{x:.3}, {y:.3}, {z:.3}] m, body FRD (estimated)"
            )?;
        }
        Ok(())
    }
}

/// Simulated IMU white noise for the tests of the random-walk estimates.
#[cfg(test)]
pub(crate) mod test_noise {
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};

    /// Per-sample sigmas at `fs` Hz (rad/s, m/s^2) of an angle random walk (deg/sqrt(h)) and
    /// a velocity random walk (ug/sqrt(Hz)).
    pub fn per_sample(arw_deg_rt_h: f64, vrw_ug_rt_hz: f64, fs: f64) -> (f64, f64) {
        (
            arw_deg_rt_h.to_radians() / 60.0 * fs.sqrt(),
            vrw_ug_rt_hz * 9.80665e-6 * fs.sqrt(),
        )
    }

    /// Seeded normal draws of a given sigma.
    pub fn normal(seed: u64) -> impl FnMut(f64) -> f64 {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        move |sigma: f64| {
            let z: f64 = StandardNormal.sample(&mut rng);
            z * sigma
        }
    }
}

#[cfg(test)]
mod bound_tests {
    use super::*;
    use crate::recon::config::ImuGrade;

    fn tuning(gyro_instability_deg_h: f64, source: Source) -> ImuNoiseTuning {
        let mut figures = ImuGrade::Mems.spec();
        figures.gyro_bias_instability_deg_h = gyro_instability_deg_h;
        ImuNoiseTuning {
            source,
            model: "mems".into(),
            figures,
            candidates: Vec::new(),
            not_scored: None,
            still: Some(stationary::StillNoise {
                from_ns: 0,
                to_ns: 600_000_000_000,
                gyro_arw_deg_rt_h: 0.3,
                accel_vrw_ug_rt_hz: 80.0,
                clusters: 590,
                // For the 3600 s correlation: 10 deg/h and 1000 ug at most.
                gyro_bias_walk_bound_deg_h_rt_h: Some(10.0 * 2f64.sqrt()),
                accel_bias_walk_bound_ug_rt_h: Some(1000.0 * 2f64.sqrt()),
            }),
            moving: None,
            white: None,
        }
    }

    /// A tuned bias instability beyond what the still stretch allows is reported; one within
    /// it, or a configured one, is not.
    #[test]
    fn a_tuned_instability_beyond_the_still_bound_is_reported() {
        let warned = instability_beyond_bound(&tuning(30.0, Source::Estimated));
        assert_eq!(warned.len(), 1, "{warned:?}");
        let TuningWarning::InstabilityBeyondStill {
            sensor,
            tuned,
            bound,
            ..
        } = warned[0]
        else {
            panic!("{warned:?}");
        };
        assert_eq!((sensor, tuned), ("gyro", 30.0));
        assert!((bound - 10.0).abs() < 1e-9, "{bound}");
        let text = warned[0].to_string();
        assert!(
            text.contains("gyro bias instability 30.000 deg/h"),
            "{text}"
        );
        assert!(text.contains("at most 10.000 deg/h"), "{text}");
        assert!(instability_beyond_bound(&tuning(3.0, Source::Estimated)).is_empty());
        assert!(instability_beyond_bound(&tuning(30.0, Source::Configured)).is_empty());
    }
}
