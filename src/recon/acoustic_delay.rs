//! The receipt delay of acoustic fixes stamped when the ship received them, estimated from
//! the log: the fixes against a track made without them.
//!
//! A fix received `d` after it was valid, placed at its stamp less a trial delay `t`, lies off
//! the track by the vehicle's velocity times `t - d`, plus the track's own drift, which the
//! dead-reckoned track builds up slowly. Over a window of a few minutes that drift is an
//! offset and a scale and turn of the path travelled (a DVL's scale factor, a heading error,
//! the heading turning steadily with a gyro's bias); what they cannot take up is the
//! velocity's change (the turns) times the delay's error. The delay is the trial one whose
//! fixes fit the track with each window's drift taken out best: a grid over
//! `[0, MAX_DELAY_S]`, then a parabola through the best point and its neighbours, whose
//! curvature gives the sigma (scaled up by the fit's chi-square per degree of freedom when
//! the fixes scatter more than their sigmas say). Outliers (multipath) are left out of each
//! window's drift and count a fixed cost, so that they cannot pull the delay.
//!
//! The USBL's raw observations (range and angles from the ship) are placed from where the
//! ship was at each trial time of validity: their error is the vehicle's velocity relative
//! to the ship's times `t - d`.

use crate::contract::{AcousticFix, ShipPose, UsblObservation};
use crate::filters::ins::acoustic::{needs_delay, valid_fixes, AcousticAiding};
use crate::filters::ins::driver::NavAt;
use crate::filters::ins::usbl::{observation_needs_delay, ship_at, UsblAid, UsblAiding};
use crate::geodesy;
use nalgebra::{SMatrix, SVector, Vector2, Vector3};
use serde::Serialize;

/// The longest delay tried, s.
pub const MAX_DELAY_S: f64 = 10.0;
/// The grid's step, s.
const STEP_S: f64 = 0.05;
/// The windows over which the track's drift is one offset, scale and turn, s.
const WINDOW_S: f64 = 300.0;
/// A fix farther than this many sigmas from its window's drift is an outlier.
const OUTLIER_SIGMAS: f64 = 4.0;
/// Fewer fixes than this in a window: the window is not used.
const MIN_WINDOW_FIXES: usize = 6;
/// A delay whose sigma is above this is not told by the log, s.
pub const MAX_SIGMA_S: f64 = 0.25;

/// The estimated receipt delay.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ReceiptDelay {
    pub delay_s: f64,
    pub sigma_s: f64,
    /// The delay against the track, before [`refine`] (equal to `delay_s` without it), s.
    pub track_delay_s: f64,
    /// Fixes and windows it rests on; fixes left out of the fit as outliers.
    pub fixes: usize,
    pub windows: usize,
    pub outliers: usize,
}

impl ReceiptDelay {
    /// Whether the log tells the delay.
    pub fn is_clear(&self) -> bool {
        self.sigma_s <= MAX_SIGMA_S
    }
}

/// A fix to place: its receipt stamp, where it is (north and east of the track's first
/// point), its sigma.
#[derive(Clone)]
struct Fix {
    receipt_s: f64,
    ne_m: Vector2<f64>,
    sigma_m: f64,
}

/// The track's transponder positions, north and east of its first point, by time.
struct Track {
    t_s: Vec<f64>,
    ne_m: Vec<Vector2<f64>>,
}

impl Track {
    fn new(track: &[NavAt], lever_arm_body_m: &Vector3<f64>) -> Option<(Track, (f64, f64))> {
        let first = track.first()?;
        let origin = (first.nav.lat_rad, first.nav.lon_rad);
        let ne_m = track
            .iter()
            .map(|p| {
                let (n, e) =
                    geodesy::local_north_east_m(origin.0, origin.1, p.nav.lat_rad, p.nav.lon_rad);
                let arm = p.nav.ned_from_body * lever_arm_body_m;
                Vector2::new(n + arm.x, e + arm.y)
            })
            .collect();
        let t_s = track.iter().map(|p| p.stamp_ns as f64 * 1e-9).collect();
        Some((Track { t_s, ne_m }, origin))
    }

    /// The position at `t_s`, linear between epochs; `None` outside the track.
    fn at(&self, t_s: f64) -> Option<Vector2<f64>> {
        let k = self.t_s.partition_point(|&s| s < t_s);
        if k == 0 || k >= self.t_s.len() {
            return (k == 0 && self.t_s.first() == Some(&t_s)).then(|| self.ne_m[0]);
        }
        let (t0, t1) = (self.t_s[k - 1], self.t_s[k]);
        let w = if t1 > t0 { (t_s - t0) / (t1 - t0) } else { 0.0 };
        Some(self.ne_m[k - 1] * (1.0 - w) + self.ne_m[k] * w)
    }
}

/// One window's fixes (indices into the fixes).
type Window = std::ops::Range<usize>;

/// A window's drift of the track: an offset, and a scale and a turn of the displacement
/// since the window's start (a DVL's scale factor, a heading error: the drift they build up
/// follows the path, and turns with it), the turn growing in time (a gyro's bias turns the
/// dead-reckoned heading steadily).
#[derive(Debug, Clone, Copy)]
struct Drift {
    params: SVector<f64, PARAMS>,
}

/// The drift's parameters: north and east offsets, scale, turn, turn rate.
const PARAMS: usize = 5;

impl Drift {
    fn at(&self, r: &Residual) -> Vector2<f64> {
        let [north, east] = rows(r);
        Vector2::new(north.dot(&self.params), east.dot(&self.params))
    }
}

/// The rows of a residual's north and east in the drift's parameters.
fn rows(r: &Residual) -> [SVector<f64, PARAMS>; 2] {
    let (d, e) = (r.displacement_m, r.timed_displacement_m_s);
    [
        SVector::from([1.0, 0.0, d.x, -d.y, -e.y]),
        SVector::from([0.0, 1.0, d.y, d.x, e.x]),
    ]
}

/// A fix's residual from the track at its trial time, and the track's displacement there
/// since the window's start, `D(t)`, and its displacement weighted by the time since,
/// `int (s - t0) v ds = (t - t0) D(t) - int D ds`.
#[derive(Debug, Clone, Copy)]
struct Residual {
    off_m: Vector2<f64>,
    displacement_m: Vector2<f64>,
    timed_displacement_m_s: Vector2<f64>,
}

/// The residuals of a window's fixes at a trial delay (`None` off the track).
fn residuals_of(fixes: &[Fix], track: &Track, delay_s: f64) -> Vec<Option<Residual>> {
    let t0 = fixes[0].receipt_s - delay_s;
    let Some(start) = track.at(t0) else {
        return vec![None; fixes.len()];
    };
    let (mut last_t, mut last_d) = (t0, Vector2::zeros());
    let mut integral = Vector2::zeros();
    fixes
        .iter()
        .map(|f| {
            let t = f.receipt_s - delay_s;
            let p = track.at(t)?;
            let d = p - start;
            integral += (d + last_d) * (0.5 * (t - last_t));
            (last_t, last_d) = (t, d);
            Some(Residual {
                off_m: f.ne_m - p,
                displacement_m: d,
                timed_displacement_m_s: d * (t - t0) - integral,
            })
        })
        .collect()
}

/// The cost of a trial delay: per window, the fixes' normalised squared distances from the
/// window's drift (outliers counted at the bound and left out of the fit), summed; with the
/// outlier flags. `inliers` given: the drift is fitted to those fixes only and the cost is
/// theirs (a smooth function of the delay, for the curvature).
fn cost(
    fixes: &[Fix],
    windows: &[Window],
    track: &Track,
    delay_s: f64,
    inliers: Option<&[bool]>,
) -> (f64, Vec<bool>) {
    let bound = OUTLIER_SIGMAS.powi(2);
    let mut total = 0.0;
    let mut inlier = vec![false; fixes.len()];
    for w in windows {
        let residuals = residuals_of(&fixes[w.clone()], track, delay_s);
        let mut keep: Vec<bool> = match inliers {
            Some(given) => given[w.clone()].to_vec(),
            None => residuals.iter().map(Option::is_some).collect(),
        };
        keep.iter_mut()
            .zip(&residuals)
            .for_each(|(k, r)| *k &= r.is_some());
        let distance = |j: usize, drift: &Drift| -> f64 {
            let f = &fixes[w.start + j];
            residuals[j].map_or(f64::INFINITY, |r| {
                ((r.off_m - drift.at(&r)) / f.sigma_m).norm_squared()
            })
        };
        for iteration in 0..4 {
            let Some(drift) = fit_drift(&fixes[w.clone()], &residuals, &keep) else {
                // Too few fixes left to fit: every one of them is off.
                keep.fill(false);
                total += bound * keep.len() as f64;
                break;
            };
            if inliers.is_some() {
                total += (0..keep.len())
                    .filter(|&j| keep[j])
                    .map(|j| distance(j, &drift))
                    .sum::<f64>();
                break;
            }
            for (j, k) in keep.iter_mut().enumerate() {
                *k = distance(j, &drift) <= bound;
            }
            if iteration == 3 {
                total += (0..keep.len())
                    .map(|j| distance(j, &drift).min(bound))
                    .sum::<f64>();
            }
        }
        inlier[w.clone()].copy_from_slice(&keep);
    }
    (total, inlier)
}

/// The weighted least-squares drift of the kept residuals; `None` with too few of them.
fn fit_drift(fixes: &[Fix], residuals: &[Option<Residual>], keep: &[bool]) -> Option<Drift> {
    let mut normal = SMatrix::<f64, PARAMS, PARAMS>::zeros();
    let mut rhs = SVector::<f64, PARAMS>::zeros();
    let mut n = 0;
    for ((f, r), &k) in fixes.iter().zip(residuals).zip(keep) {
        let (Some(r), true) = (r, k) else { continue };
        let w = f.sigma_m.powi(-2);
        for (row, y) in rows(r).into_iter().zip([r.off_m.x, r.off_m.y]) {
            normal += row * row.transpose() * w;
            rhs += row * (y * w);
        }
        n += 1;
    }
    if n < 3 {
        return None;
    }
    let params = normal.cholesky()?.solve(&rhs);
    Some(Drift { params })
}

/// Windows of [`WINDOW_S`] over the fixes (in receipt order), each with enough fixes.
fn windows_of(fixes: &[Fix]) -> Vec<Window> {
    let mut out = Vec::new();
    let mut start = 0;
    while start < fixes.len() {
        let end_s = fixes[start].receipt_s + WINDOW_S;
        let end = start + fixes[start..].partition_point(|f| f.receipt_s < end_s);
        if end - start >= MIN_WINDOW_FIXES {
            out.push(start..end);
        }
        start = end;
    }
    out
}

/// The acoustic readings whose receipt delay is to be found, each kind with its settings
/// (`None`: not used).
pub struct Delayed<'a> {
    /// Positioned fixes.
    pub fixes: Option<(&'a [AcousticFix], &'a AcousticAiding)>,
    /// Ship-relative USBL observations, placed by the ship's pose.
    pub usbl: Option<(&'a [UsblObservation], &'a UsblAiding)>,
    pub ship: &'a [ShipPose],
    /// The transponder on the vehicle, body FRD from the IMU, m.
    pub lever_arm_body_m: [f64; 3],
}

impl Delayed<'_> {
    /// The readings that carry no time of validity, placed north and east of `origin` as
    /// though received `delay_s` after they were valid, in receipt order. A positioned fix
    /// stays where it is; a raw observation is placed from where the ship was then, so its
    /// place moves with the trial delay as the ship moves. Only observations the ship's pose
    /// covers at every trial delay are taken, so that each trial places the same readings.
    fn placer(&self, origin: (f64, f64)) -> impl Fn(f64) -> Vec<Fix> + '_ {
        let ne = move |lat_rad: f64, lon_rad: f64| {
            let (n, e) = geodesy::local_north_east_m(origin.0, origin.1, lat_rad, lon_rad);
            Vector2::new(n, e)
        };
        let positioned: Vec<Fix> = self.fixes.map_or_else(Vec::new, |(readings, aiding)| {
            let undelayed: Vec<AcousticFix> = readings
                .iter()
                .filter(|f| needs_delay(f))
                .cloned()
                .collect();
            let at_receipt = AcousticAiding {
                receipt_delay_s: 0.0,
                ..*aiding
            };
            (valid_fixes(&undelayed, self.ship, &at_receipt).into_iter())
                .map(|f| Fix {
                    receipt_s: f.stamp_ns as f64 * 1e-9,
                    ne_m: ne(f.lat_rad, f.lon_rad),
                    sigma_m: f.sigma_m,
                })
                .collect()
        });
        let raw: Vec<UsblObservation> = self.usbl.map_or_else(Vec::new, |(readings, aiding)| {
            let steps = (MAX_DELAY_S / STEP_S).round() as i64;
            let step_ns = (STEP_S * 1e9).round() as i64;
            (readings.iter())
                .filter(|o| observation_needs_delay(o))
                .filter(|o| {
                    (0..=steps)
                        .all(|k| ship_at(self.ship, o.stamp_ns - k * step_ns, aiding).is_some())
                })
                .cloned()
                .collect()
        });
        move |delay_s: f64| {
            let mut fixes = positioned.clone();
            if let Some((_, aiding)) = self.usbl {
                let trial = UsblAiding {
                    receipt_delay_s: Some(delay_s),
                    ..*aiding
                };
                let aid = UsblAid::new(&raw, self.ship, &trial);
                fixes.extend(aid.positioned_fixes().map(|f| Fix {
                    receipt_s: f.stamp_ns as f64 * 1e-9 + delay_s,
                    ne_m: ne(f.lat_rad, f.lon_rad),
                    sigma_m: f.sigma_m,
                }));
            }
            fixes.sort_by(|a, b| a.receipt_s.total_cmp(&b.receipt_s));
            fixes
        }
    }
}

/// The receipt delay of the readings that carry none, from `track` (a pass without them);
/// `None` without such readings or a track under them.
pub fn estimate(readings: &Delayed<'_>, track: &[NavAt]) -> Option<ReceiptDelay> {
    let (track, origin) = Track::new(track, &Vector3::from(readings.lever_arm_body_m))?;
    let fixes_at = readings.placer(origin);
    let windows = windows_of(&fixes_at(0.0));
    if windows.is_empty() {
        return None;
    }
    let trial = |d: f64, inliers: Option<&[bool]>| cost(&fixes_at(d), &windows, &track, d, inliers);
    let steps = (MAX_DELAY_S / STEP_S).round() as usize;
    let (best_k, _) = (0..=steps)
        .map(|k| (k, trial(k as f64 * STEP_S, None).0))
        .min_by(|a, b| a.1.total_cmp(&b.1))?;
    // The neighbours of the grid's best, with its inliers held: a parabola.
    let best_s = (best_k.clamp(1, steps - 1)) as f64 * STEP_S;
    let (_, inliers) = trial(best_s, None);
    let held = |d: f64| trial(d, Some(&inliers)).0;
    let (before, at, after) = (held(best_s - STEP_S), held(best_s), held(best_s + STEP_S));
    let curvature = (before - 2.0 * at + after) / STEP_S.powi(2);
    let used = inliers.iter().filter(|&&k| k).count();
    let dof = (2 * used).saturating_sub(PARAMS * windows.len() + 1).max(1);
    let scatter = (at / dof as f64).max(1.0);
    let (delay_s, sigma_s) = if curvature > 0.0 {
        let shift = -0.5 * (after - before) / (curvature * STEP_S);
        (
            best_s + shift.clamp(-STEP_S, STEP_S),
            (2.0 * scatter / curvature).sqrt(),
        )
    } else {
        (best_s, f64::INFINITY)
    };
    let in_windows: usize = windows.iter().map(|w| w.len()).sum();
    Some(ReceiptDelay {
        delay_s: delay_s.max(0.0),
        sigma_s,
        track_delay_s: delay_s.max(0.0),
        fixes: in_windows,
        windows: windows.len(),
        outliers: in_windows - used,
    })
}

/// The delay refined by the forward filter's own judgement: the log-likelihood of the fixes'
/// innovations (`log_likelihood` of a trial delay: a forward pass with the fixes placed by
/// it), maximised by parabolas through the estimate and its neighbours, 0.2 s then 0.06 s
/// away; its curvature gives the sigma. The track's estimate leaves the filter's own
/// calibration to a window's drift (0.1 s off on `usbl-survey`); the filter models it. The
/// estimate is kept as it was when the likelihood has no maximum near it.
pub fn refine(
    estimate: &ReceiptDelay,
    log_likelihood: &(dyn Fn(f64) -> f64 + Sync),
) -> ReceiptDelay {
    let mut delay_s = estimate.delay_s;
    let mut sigma_s = None;
    for h in [0.2, 0.06] {
        let points = [delay_s - h, delay_s, delay_s + h].map(|d| d.max(0.0));
        let (before, (at, after)) = rayon::join(
            || log_likelihood(points[0]),
            || rayon::join(|| log_likelihood(points[1]), || log_likelihood(points[2])),
        );
        let curvature = (before - 2.0 * at + after) / (h * h);
        let peaked = curvature < 0.0;
        if !peaked || points[0] == points[1] {
            break;
        }
        let shift = 0.5 * h * (before - after) / (before - 2.0 * at + after);
        delay_s = (delay_s + shift.clamp(-2.0 * h, 2.0 * h)).max(0.0);
        sigma_s = Some((-1.0 / curvature).sqrt());
    }
    match sigma_s {
        Some(sigma_s) => ReceiptDelay {
            delay_s,
            sigma_s,
            ..*estimate
        },
        None => *estimate,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::filters::ins::mechanization::NavState;
    use nalgebra::UnitQuaternion;
    use rand::{Rng, SeedableRng};
    use rand_distr::StandardNormal;

    const LAT0: f64 = 0.6;
    const LON0: f64 = 2.2;

    /// A lawnmower at 1.5 m/s: lanes of 150 s north, then south, joined by half circles of
    /// 30 s.
    fn true_ne_m(t: f64) -> Vector2<f64> {
        const R: f64 = 45.0 / std::f64::consts::PI;
        let lane = (t / 180.0).floor();
        let s = t - lane * 180.0;
        let east0 = lane * 2.0 * R;
        let northward = lane as i64 % 2 == 0;
        if s < 150.0 {
            let along = 1.5 * s;
            Vector2::new(if northward { along } else { 225.0 - along }, east0)
        } else {
            let a = (s - 150.0) / 30.0 * std::f64::consts::PI;
            let north = if northward {
                225.0 + R * a.sin()
            } else {
                -R * a.sin()
            };
            Vector2::new(north, east0 + R * (1.0 - a.cos()))
        }
    }

    fn lat_lon(ne: Vector2<f64>) -> (f64, f64) {
        geodesy::position_of_local_m(LAT0, LON0, ne.x, ne.y)
    }

    /// A track with the drift of a DVL's 0.3 % scale error and a 0.1 deg heading error, and
    /// a slow one in time, and fixes every 3 s received `delay_s` late, 3 % of them
    /// 10-50 m off.
    fn scene(delay_s: f64, seed: u64) -> (Vec<NavAt>, Vec<AcousticFix>) {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let track = (0..=15_000)
            .map(|k| {
                let t = k as f64 * 0.1;
                let path = true_ne_m(t) - true_ne_m(0.0);
                let (scale, turn) = (0.003, 0.1f64.to_radians());
                let drift = Vector2::new(
                    scale * path.x - turn * path.y,
                    turn * path.x + scale * path.y,
                ) + Vector2::new(2e-4 * t, -1e-4 * t);
                let (lat_rad, lon_rad) = lat_lon(true_ne_m(t) + drift);
                NavAt {
                    stamp_ns: (t * 1e9) as i64,
                    nav: NavState {
                        lat_rad,
                        lon_rad,
                        height_m: -20.0,
                        vel_ned_m_s: Vector3::zeros(),
                        ned_from_body: UnitQuaternion::identity(),
                    },
                }
            })
            .collect();
        let fixes = (1..480)
            .map(|k| {
                let t = k as f64 * 3.0;
                let noise: Vector2<f64> =
                    Vector2::from_fn(|_, _| rng.sample::<f64, _>(StandardNormal));
                let mut error = noise * 0.8;
                if rng.random::<f64>() < 0.03 {
                    let b = rng.random_range(0.0..std::f64::consts::TAU);
                    error += Vector2::new(b.cos(), b.sin()) * rng.random_range(10.0..50.0);
                }
                let (lat, lon) = lat_lon(true_ne_m(t) + error);
                AcousticFix {
                    stamp_ns: ((t + delay_s) * 1e9) as i64,
                    stamp_is_validity: false,
                    received_after_s: None,
                    latitude_deg: lat.to_degrees(),
                    longitude_deg: lon.to_degrees(),
                    depth_m: None,
                    horizontal_sigma_m: Some(0.8),
                    depth_sigma_m: None,
                    beacon_id: String::new(),
                }
            })
            .collect();
        (track, fixes)
    }

    fn positioned<'a>(fixes: &'a [AcousticFix], aiding: &'a AcousticAiding) -> Delayed<'a> {
        Delayed {
            fixes: Some((fixes, aiding)),
            usbl: None,
            ship: &[],
            lever_arm_body_m: [0.0; 3],
        }
    }

    fn aiding() -> AcousticAiding {
        AcousticAiding {
            receipt_delay_s: 0.0,
            slant_range_fraction: 0.01,
            sigma_floor_m: 0.5,
            sigma_without_ship_m: 5.0,
            lever_arm_body_m: [0.0; 3],
        }
    }

    #[test]
    fn the_delay_is_found_through_drift_and_outliers() {
        for (delay_s, seed) in [(1.3, 1), (2.0, 2), (2.85, 3)] {
            let (track, fixes) = scene(delay_s, seed);
            let d = estimate(&positioned(&fixes, &aiding()), &track).expect("an estimate");
            assert!(d.is_clear(), "{d:?}");
            assert!(
                (d.delay_s - delay_s).abs() < 3.0 * d.sigma_s.max(0.01),
                "{d:?} vs {delay_s}"
            );
            assert!((d.delay_s - delay_s).abs() < 0.1, "{d:?} vs {delay_s}");
            assert!((5..=30).contains(&d.outliers), "{d:?}");
        }
    }

    /// Raw observations from a ship following the vehicle 120 s behind (so that the ship
    /// turns as the vehicle did): the transponder in the ship's axes, received `delay_s`
    /// late. A trial delay moves the ship's place with the ship's own velocity; were the
    /// observations placed as positioned fixes, the ship's turns would bias the delay.
    fn raw_scene(delay_s: f64) -> (Vec<ShipPose>, Vec<UsblObservation>) {
        let ship_ne = |t: f64| true_ne_m((t - 120.0).max(0.0));
        let ship: Vec<ShipPose> = (0..=3000)
            .map(|k| {
                let t = k as f64 * 0.5;
                let (lat, lon) = lat_lon(ship_ne(t));
                ShipPose {
                    stamp_ns: (t * 1e9) as i64,
                    latitude_deg: lat.to_degrees(),
                    longitude_deg: lon.to_degrees(),
                    roll: 0.0,
                    pitch: 0.0,
                    yaw: 0.0,
                    horizontal_sigma_m: None,
                    heading_sigma_rad: None,
                }
            })
            .collect();
        let observations = (60..480)
            .map(|k| {
                let t = k as f64 * 3.0;
                let d = true_ne_m(t) - ship_ne(t);
                let horizontal = d.norm();
                UsblObservation {
                    stamp_ns: ((t + delay_s) * 1e9) as i64,
                    stamp_is_validity: false,
                    received_after_s: None,
                    range_m: horizontal.hypot(20.0),
                    bearing_rad: d.y.atan2(d.x),
                    elevation_rad: 20.0f64.atan2(horizontal),
                    range_sigma_m: None,
                    bearing_sigma_rad: None,
                    elevation_sigma_rad: None,
                    sound_speed_m_s: None,
                    beacon_id: String::new(),
                }
            })
            .collect();
        (ship, observations)
    }

    #[test]
    fn the_delay_of_raw_observations_is_found_where_the_ship_was() {
        let usbl = UsblAiding {
            receipt_delay_s: None,
            range_fraction: 0.002,
            range_sigma_floor_m: 0.2,
            angle_sigma_rad: 0.2f64.to_radians(),
            transducer_lever_arm_m: [0.0; 3],
            transducer_alignment_rad: [0.0; 3],
            ship_position_sigma_m: 0.5,
            ship_height_sigma_m: 0.5,
            ship_heading_sigma_rad: 0.1f64.to_radians(),
            ship_heading_correlation_s: 10.0,
            ship_tilt_sigma_rad: 0.05f64.to_radians(),
            ship_max_gap_s: 5.0,
            lever_arm_body_m: [0.0; 3],
        };
        let (track, _) = scene(0.0, 6);
        for delay_s in [1.4, 2.7] {
            let (ship, observations) = raw_scene(delay_s);
            let readings = Delayed {
                fixes: None,
                usbl: Some((&observations, &usbl)),
                ship: &ship,
                lever_arm_body_m: [0.0; 3],
            };
            let d = estimate(&readings, &track).expect("an estimate");
            assert!(d.is_clear(), "{d:?}");
            assert!((d.delay_s - delay_s).abs() < 0.1, "{d:?} vs {delay_s}");
            // The ship's poses cover every trial delay of all but the first observations.
            assert!(d.fixes >= observations.len() - 4, "{d:?}");
        }
    }

    #[test]
    fn refining_climbs_the_likelihood_to_its_peak() {
        let first = ReceiptDelay {
            delay_s: 2.1,
            sigma_s: 0.03,
            track_delay_s: 2.1,
            fixes: 400,
            windows: 5,
            outliers: 10,
        };
        // A log-likelihood peaked at 1.93 s with a 0.02 s sigma.
        let peaked = |d: f64| -0.5 * ((d - 1.93) / 0.02).powi(2);
        let refined = refine(&first, &peaked);
        assert!((refined.delay_s - 1.93).abs() < 1e-6, "{refined:?}");
        assert!((refined.sigma_s - 0.02).abs() < 1e-6, "{refined:?}");
        assert_eq!(refined.track_delay_s, 2.1);
        let flat = |_: f64| -3.0;
        assert_eq!(refine(&first, &flat), first);
    }

    #[test]
    fn fixes_that_carry_their_delay_need_no_estimate() {
        let (track, mut fixes) = scene(2.0, 4);
        for f in &mut fixes {
            f.received_after_s = Some(2.0);
        }
        assert_eq!(estimate(&positioned(&fixes, &aiding()), &track), None);
    }

    #[test]
    fn a_straight_run_cannot_tell_the_delay() {
        // North at 1.5 m/s throughout: a delay is a constant offset, which the drift takes up.
        let (mut track, mut fixes) = scene(2.0, 5);
        for p in &mut track {
            let t = p.stamp_ns as f64 * 1e-9;
            (p.nav.lat_rad, p.nav.lon_rad) = lat_lon(Vector2::new(1.5 * t, 0.0));
        }
        for f in &mut fixes {
            let t = f.stamp_ns as f64 * 1e-9 - 2.0;
            let (lat, lon) = lat_lon(Vector2::new(1.5 * t, 0.3));
            (f.latitude_deg, f.longitude_deg) = (lat.to_degrees(), lon.to_degrees());
        }
        let d = estimate(&positioned(&fixes, &aiding()), &track).expect("an estimate");
        assert!(!d.is_clear(), "{d:?}");
    }
}
