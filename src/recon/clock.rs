//! Finding a sensor's clock offset from the filter's own innovations: when the DVL's
//! innovations are far larger than its noise, rerun the forward filter over the start of the
//! mission with the DVL stamps shifted, and say which shift fits best.

use super::config::Config;
use super::{forward_pass, Prepared, Streams};
use crate::contract::{Dvl, Imu};
use crate::filters::ins::aid_table::Sensor;
use crate::ingest::Mission;

/// Seconds of the mission searched (from the first IMU sample).
const SEARCH_WINDOW_S: f64 = 600.0;
/// Coarse candidates: -5 s to +5 s in 0.5 s steps; then 0.1 s steps around the best.
const COARSE_STEP_S: f64 = 0.5;
pub const COARSE_SPAN_S: f64 = 5.0;
const FINE_STEP_S: f64 = 0.1;

/// A suggested offset for the DVL's stamps and how well it fits.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct OffsetSuggestion {
    /// What to pass as `--offset /dvl=SECONDS` (added to the stamps).
    pub offset_s: f64,
    /// Mean DVL NIS (each clipped at 100) with that offset and with none.
    pub mean_nis: f64,
    pub mean_nis_unshifted: f64,
}

/// Mean of the DVL's NIS over the search window with its stamps moved by `offset_s`, each NIS
/// clipped at 100 so that a diverged stretch does not swamp the rest (`None`: no DVL update
/// or the filter failed).
fn dvl_fit(
    streams: &Streams<'_>,
    imu: &[Imu],
    mission: &Mission,
    config: &Config,
    offset_s: f64,
    from: Prepared<'_>,
) -> Option<f64> {
    let shift = (offset_s * 1e9).round() as i64;
    let dvl: Vec<Dvl> = streams
        .dvl
        .iter()
        .map(|d| Dvl {
            stamp_ns: d.stamp_ns + shift,
            ..d.clone()
        })
        .collect();
    let shifted = Streams {
        imu,
        dvl: &dvl,
        ..*streams
    };
    let run = forward_pass(&shifted, mission, config, from.scored())
        .ok()?
        .run;
    let nis: Vec<f64> = run
        .residuals
        .iter()
        .filter(|r| r.sensor == Sensor::Dvl)
        .map(|r| r.nis.min(100.0))
        .collect();
    (!nis.is_empty()).then(|| nis.iter().sum::<f64>() / nis.len() as f64)
}

/// The DVL offset that minimises its innovations over the first ten minutes, when it fits
/// clearly better (mean NIS at most half) than no offset. The candidates start from `from`'s
/// settled heading when it has one.
pub fn suggest_dvl_offset(
    streams: &Streams<'_>,
    mission: &Mission,
    config: &Config,
    from: Prepared<'_>,
) -> Option<OffsetSuggestion> {
    let t0 = streams.imu.first()?.stamp_ns;
    let end = t0 + (SEARCH_WINDOW_S * 1e9) as i64;
    let imu = &streams.imu[..streams.imu.partition_point(|m| m.stamp_ns <= end)];
    // The candidates start from the initial heading as it is: the in-motion alignment's bank
    // for each of them would cost a dozen forward passes more.
    let mut config = config.clone();
    config.alignment.enabled = false;
    let fit = |offset: f64| dvl_fit(streams, imu, mission, &config, offset, from);
    let unshifted = fit(0.0)?;
    let best = |candidates: Vec<f64>| {
        candidates
            .into_iter()
            .filter_map(|o| fit(o).map(|f| (o, f)))
            .min_by(|a, b| a.1.total_cmp(&b.1))
    };
    let steps = (COARSE_SPAN_S / COARSE_STEP_S).round() as i32;
    let (coarse, _) = best((-steps..=steps).map(|k| k as f64 * COARSE_STEP_S).collect())?;
    let (offset_s, mean_nis) = best((-4..=4).map(|k| coarse + k as f64 * FINE_STEP_S).collect())?;
    (mean_nis <= 0.5 * unshifted && offset_s.abs() > 0.5 * FINE_STEP_S).then_some(
        OffsetSuggestion {
            offset_s: (offset_s * 10.0).round() / 10.0,
            mean_nis,
            mean_nis_unshifted: unshifted,
        },
    )
}
