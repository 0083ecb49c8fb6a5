//! The initial heading from every source the log and the user offer, weighed by their sigmas.
//!
//! Sources: gyrocompassing (when the IMU's predicted error is small enough and the vehicle
//! held still), the magnetometer (its readings over the window carried to the start by the
//! gyro, tilt-compensated with the start's roll and pitch, with the declination), the
//! mission's `initial_yaw_rad`, and a heading given by hand. Every source is listed with its
//! value and sigma; `auto` combines all of them (inverse-variance, on the circle), a forced
//! choice uses that one alone. Sources that disagree beyond three sigmas of their difference
//! are named in a warning, and the combined sigma is widened to cover them.

use crate::angle::wrap_pi;
use serde::Serialize;
use std::fmt;

/// Where the declination used with the magnetometer came from.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum DeclinationSource {
    Given,
    Mission,
    /// The World Magnetic Model at the start's place and date (2020-2029).
    Wmm,
    /// IGRF-14 at the start's place and date (1900-2030, outside the WMM's years).
    Igrf,
    /// None known (no model has a value for the log's date): taken as 0 with a wide sigma.
    Unknown,
}

/// The declination and its 1-sigma, degrees.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct DeclinationUsed {
    pub source: DeclinationSource,
    pub declination_deg: f64,
    pub sigma_deg: f64,
}

/// Where a heading came from.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum HeadingSource {
    Gyrocompass,
    Magnetometer,
    Mission,
    Given,
    /// Several sources, combined by their sigmas.
    Combined,
    /// The in-motion alignment: the heading the log's aiding supports, carried back to the
    /// start.
    InMotion,
    /// The gyrocompass's heading, confirmed by gyrocompassing in motion: refined by the filter
    /// over the alignment's span (the Earth's rate seen with the DVL's velocity) and smoothed
    /// back to the start, within 3 sigmas of it. The forward pass starts from the
    /// gyrocompass's heading and sigma (the refined one is in the alignment's record).
    GyrocompassInMotion,
    /// No source: unknown.
    Unknown,
}

impl HeadingSource {
    pub fn name(&self) -> &'static str {
        match self {
            HeadingSource::Gyrocompass => "gyrocompass",
            HeadingSource::Magnetometer => "magnetometer",
            HeadingSource::Mission => "mission",
            HeadingSource::Given => "given",
            HeadingSource::Combined => "combined",
            HeadingSource::InMotion => "in_motion",
            HeadingSource::GyrocompassInMotion => "gyrocompass_in_motion",
            HeadingSource::Unknown => "unknown",
        }
    }
}

/// One source's heading at the start.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct HeadingCandidate {
    pub source: HeadingSource,
    /// Degrees from north, in [0, 360).
    pub heading_deg: f64,
    pub sigma_deg: f64,
    /// Whether it entered the initial heading.
    pub used: bool,
}

impl HeadingCandidate {
    /// Its source and heading.
    pub fn named(&self) -> SourceHeading {
        SourceHeading {
            source: self.source,
            heading_deg: self.heading_deg,
            sigma_deg: self.sigma_deg,
        }
    }

    pub fn new(source: HeadingSource, yaw_rad: f64, sigma_deg: f64) -> Self {
        HeadingCandidate {
            source,
            heading_deg: wrap_pi(yaw_rad).to_degrees().rem_euclid(360.0),
            sigma_deg,
            used: false,
        }
    }

    fn yaw_rad(&self) -> f64 {
        self.heading_deg.to_radians()
    }
}

/// The sources' combination: heading (rad), 1-sigma (deg), and a warning per pair of used
/// sources that disagree.
#[derive(Debug, Clone, PartialEq)]
pub struct Combined {
    pub yaw_rad: f64,
    pub sigma_deg: f64,
    pub disagreements: Vec<HeadingDisagreement>,
}

/// A heading a source gave, as a disagreement names it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SourceHeading {
    pub source: HeadingSource,
    /// Degrees from north, in [0, 360).
    pub heading_deg: f64,
    pub sigma_deg: f64,
}

/// Two headings of the start that do not agree.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(tag = "between", rename_all = "snake_case")]
pub enum HeadingDisagreement {
    /// Two sources farther apart than 3 sigmas of the two (`allowed_deg`).
    Sources {
        first: SourceHeading,
        second: SourceHeading,
        apart_deg: f64,
        allowed_deg: f64,
    },
    /// The in-motion alignment contradicted the start's heading, and was used instead.
    StartAndInMotion {
        start: SourceHeading,
        in_motion: SourceHeading,
    },
}

impl fmt::Display for HeadingDisagreement {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            HeadingDisagreement::Sources {
                first: a,
                second: b,
                apart_deg,
                allowed_deg,
            } => write!(
                f,
                "heading sources disagree: {} {:.1} deg (1-sigma {:.1}) and {} {:.1} deg \
                 (1-sigma {:.1}) are {apart_deg:.1} deg apart, beyond 3 sigma ({allowed_deg:.1} \
                 deg)",
                a.source.name(),
                a.heading_deg,
                a.sigma_deg,
                b.source.name(),
                b.heading_deg,
                b.sigma_deg
            ),
            HeadingDisagreement::StartAndInMotion { start, in_motion } => write!(
                f,
                "the initial heading {:.1} deg ({}, 1-sigma {:.1}) is contradicted by the log: \
                 the in-motion alignment found {:.1} deg (1-sigma {:.2}), used instead",
                start.heading_deg,
                start.source.name(),
                start.sigma_deg,
                in_motion.heading_deg,
                in_motion.sigma_deg
            ),
        }
    }
}

/// Combines the candidates marked `used` (inverse-variance, about the most precise one, so
/// that the wrap at +-180 deg does no harm). `None` when none is used.
pub fn combine(candidates: &[HeadingCandidate]) -> Option<Combined> {
    let used: Vec<&HeadingCandidate> = candidates.iter().filter(|c| c.used).collect();
    let best = used
        .iter()
        .min_by(|a, b| a.sigma_deg.total_cmp(&b.sigma_deg))?;
    let reference = best.yaw_rad();
    let (mut sum_w, mut sum_wd) = (0.0, 0.0);
    for c in &used {
        let w = 1.0 / c.sigma_deg.powi(2);
        sum_w += w;
        sum_wd += w * wrap_pi(c.yaw_rad() - reference);
    }
    let yaw = wrap_pi(reference + sum_wd / sum_w);
    let mut sigma_deg = (1.0 / sum_w).sqrt();
    let mut disagreements = Vec::new();
    for (i, a) in used.iter().enumerate() {
        for b in &used[i + 1..] {
            let apart = wrap_pi(a.yaw_rad() - b.yaw_rad()).to_degrees().abs();
            let allowed = 3.0 * a.sigma_deg.hypot(b.sigma_deg);
            if apart > allowed {
                disagreements.push(HeadingDisagreement::Sources {
                    first: a.named(),
                    second: b.named(),
                    apart_deg: apart,
                    allowed_deg: allowed,
                });
            }
        }
    }
    if !disagreements.is_empty() {
        // The combination of sources that do not agree is no better than their spread.
        let spread = used
            .iter()
            .map(|c| wrap_pi(c.yaw_rad() - yaw).to_degrees().abs())
            .fold(0.0, f64::max);
        sigma_deg = sigma_deg.max(spread);
    }
    Some(Combined {
        yaw_rad: yaw,
        sigma_deg,
        disagreements,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn used(source: HeadingSource, deg: f64, sigma: f64) -> HeadingCandidate {
        HeadingCandidate {
            used: true,
            ..HeadingCandidate::new(source, deg.to_radians(), sigma)
        }
    }

    #[test]
    fn combines_by_inverse_variance_across_north() {
        let c = combine(&[
            used(HeadingSource::Magnetometer, 358.0, 2.0),
            used(HeadingSource::Mission, 4.0, 4.0),
        ])
        .unwrap();
        // (358 * 1/4 + 364 * 1/16) / (1/4 + 1/16) = 359.2
        let deg = c.yaw_rad.to_degrees().rem_euclid(360.0);
        assert!((deg - 359.2).abs() < 1e-9, "{deg}");
        assert!((c.sigma_deg - (1.0f64 / (0.25 + 1.0 / 16.0)).sqrt()).abs() < 1e-12);
        assert!(c.disagreements.is_empty());
    }

    #[test]
    fn unused_sources_do_not_count_and_disagreement_is_named() {
        let mut given = used(HeadingSource::Given, 90.0, 5.0);
        given.used = false;
        let c = combine(&[used(HeadingSource::Magnetometer, 10.0, 2.0), given]).unwrap();
        assert!((c.yaw_rad.to_degrees() - 10.0).abs() < 1e-9);
        let c = combine(&[
            used(HeadingSource::Magnetometer, 10.0, 2.0),
            used(HeadingSource::Mission, 60.0, 5.0),
        ])
        .unwrap();
        assert_eq!(c.disagreements.len(), 1);
        let HeadingDisagreement::Sources { first, second, .. } = c.disagreements[0] else {
            panic!("{:?}", c.disagreements);
        };
        assert_eq!(first.source, HeadingSource::Magnetometer);
        assert_eq!(second.source, HeadingSource::Mission);
        let text = c.disagreements[0].to_string();
        assert!(text.contains("magnetometer 10.0 deg (1-sigma 2.0) and mission 60.0 deg"));
        // The sigma covers the spread.
        assert!(c.sigma_deg > 40.0, "{}", c.sigma_deg);
        assert!(combine(&[given]).is_none());
    }
}
