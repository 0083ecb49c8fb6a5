//! Ship-relative USBL observations (`/usbl`, with the ship's `/ship_pose`) as an aid, raw:
//! each observation is the transponder's position in the axes of the ship's transducer, not
//! a fix the ship positioned. The ship's pose places the transducer; its errors (the GNSS
//! position, the heading and the tilt) go into the observation's noise, where a heading error
//! grows with the horizontal range.
//!
//! The range, bearing and elevation are taken as the vector they give in the transducer's
//! axes, `d = r (cos e cos b, cos e sin b, sin e)`, with the covariance their sigmas give
//! it. Unlike the angles, the vector has no singularity under the transducer and needs no
//! wrapping. The range is converted with the speed of sound the ranges share with the LBL
//! (`idx::SOUND_SPEED_SCALE`): the vector reads `d / (1 + k)`.
//!
//! An observation stamped when the ship received it is applied where it was valid, as the
//! positioned fixes are ([`super::acoustic`]): less the delay it carries, or the estimated one.

use super::acoustic::{validity_of, ValidFix};
use super::aid_table::{Aid, Epoch, Measurement, Sensor, SensorReading, Update};
use super::error_state::{idx, N};
use super::forward::Estimate;
use crate::align::interpolate;
use crate::contract::{ShipPose, UsblObservation};
use crate::geodesy;
use nalgebra::{Matrix3, Matrix6, Rotation3, SMatrix, SVector, Vector3};

/// How the USBL observations are taken.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UsblAiding {
    /// Time of receipt less time of validity, s, of the observations stamped on receipt that
    /// do not carry theirs (shared with the positioned fixes: one acoustic system); `None`:
    /// not known, and those observations are left out.
    pub receipt_delay_s: Option<f64>,
    /// 1-sigma of a range that carries none: this fraction of the range ...
    pub range_fraction: f64,
    /// ... and at least this, m.
    pub range_sigma_floor_m: f64,
    /// 1-sigma of a bearing or an elevation that carries none, rad.
    pub angle_sigma_rad: f64,
    /// The transducer on the ship: from the point the ship's position is of, in the ship's
    /// body axes (FRD), m ...
    pub transducer_lever_arm_m: [f64; 3],
    /// ... and its axes: the transducer-from-ship rotation (Z-Y-X Euler: roll, pitch, yaw),
    /// rad.
    pub transducer_alignment_rad: [f64; 3],
    /// 1-sigma of the ship's horizontal position, per axis, where its pose carries none, m.
    pub ship_position_sigma_m: f64,
    /// 1-sigma of the ship's reference point's height (heave), m.
    pub ship_height_sigma_m: f64,
    /// 1-sigma of the ship's heading where its pose carries none, rad.
    pub ship_heading_sigma_rad: f64,
    /// The heading error's correlation time, s (0: white): see [`heading_share`].
    pub ship_heading_correlation_s: f64,
    /// 1-sigma of the ship's roll and pitch, rad.
    pub ship_tilt_sigma_rad: f64,
    /// The ship's poses are interpolated across gaps up to this long, s.
    pub ship_max_gap_s: f64,
    /// The transponder on the vehicle, body FRD from the IMU, m.
    pub lever_arm_body_m: [f64; 3],
}

/// The ship when an observation was valid: where, how turned, how well known.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShipAt {
    pub lat_rad: f64,
    pub lon_rad: f64,
    /// Height of the ship's reference point, m (the poses carry none: the sea surface, 0).
    pub height_m: f64,
    pub ned_from_ship: Rotation3<f64>,
    /// 1-sigma of the horizontal position per axis, m.
    pub position_sigma_m: f64,
    /// 1-sigma of the heading, rad.
    pub heading_sigma_rad: f64,
}

/// The ship's pose at `t_ns`, interpolated (`None` outside the poses or across a gap longer
/// than the settings allow), with its sigmas or the settings'.
pub fn ship_at(ship: &[ShipPose], t_ns: i64, a: &UsblAiding) -> Option<ShipAt> {
    let pose = interpolate(ship, t_ns, (a.ship_max_gap_s * 1e9) as i64)?;
    Some(ShipAt {
        lat_rad: pose.latitude_deg.to_radians(),
        lon_rad: pose.longitude_deg.to_radians(),
        height_m: 0.0,
        ned_from_ship: Rotation3::from_euler_angles(pose.roll, pose.pitch, pose.yaw),
        position_sigma_m: (pose.horizontal_sigma_m.filter(|s| *s > 0.0))
            .unwrap_or(a.ship_position_sigma_m),
        heading_sigma_rad: (pose.heading_sigma_rad.filter(|s| *s > 0.0))
            .unwrap_or(a.ship_heading_sigma_rad),
    })
}

/// Whether an observation is stamped on receipt and carries no delay: it needs the
/// system's receipt delay to be placed where it was valid.
pub fn observation_needs_delay(o: &UsblObservation) -> bool {
    !o.stamp_is_validity && o.received_after_s.is_none()
}

/// An observation made ready: when it was valid, the vector it measured, its sigmas, and
/// the ship then.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ValidObservation {
    /// Time of validity, ns.
    pub stamp_ns: i64,
    /// The transponder in the transducer's axes, m.
    pub transducer_m: Vector3<f64>,
    /// 1-sigma of the range (m), the bearing and the elevation (rad).
    pub sigmas: [f64; 3],
    pub ship: ShipAt,
    /// How many times its heading error's variance the observation is taken to carry
    /// ([`heading_share`]).
    pub heading_inflation: f64,
}

/// The factor on the ship's heading variance of an observation `interval_s` from its
/// neighbour, when the heading's error is a Gauss-Markov process of `correlation_s`.
///
/// Observations closer together than the correlation time share the error: taken as white,
/// `n` of them would average it down by `n`, where they average it down by only about
/// `n (1 - rho) / (1 + rho)`, `rho = exp(-interval / correlation)` (the steady state of a
/// first-order process sampled at that interval). The filter treats each observation as
/// independent, so the heading's variance in each is scaled up by `(1 + rho) / (1 - rho)`:
/// the information the run of them carries about the heading error is then the true one.
/// The own noise of the range and the angles is white and is not scaled.
pub fn heading_share(interval_s: f64, correlation_s: f64) -> f64 {
    if correlation_s <= 0.0 || !interval_s.is_finite() {
        return 1.0;
    }
    let rho = (-interval_s.max(0.0) / correlation_s).exp();
    if rho >= 1.0 {
        return f64::MAX.sqrt();
    }
    (1.0 + rho) / (1.0 - rho)
}

/// The vector a range, bearing and elevation give in the transducer's axes.
pub fn transducer_vector(range_m: f64, bearing_rad: f64, elevation_rad: f64) -> Vector3<f64> {
    let (sb, cb) = bearing_rad.sin_cos();
    let (se, ce) = elevation_rad.sin_cos();
    Vector3::new(ce * cb, ce * sb, se) * range_m
}

/// The covariance of [`transducer_vector`] from the sigmas of its range, bearing and
/// elevation, to first order, at the vector `d`.
pub fn transducer_covariance(d: &Vector3<f64>, sigmas: [f64; 3]) -> Matrix3<f64> {
    let range = d.norm().max(1e-9);
    let horizontal = d.x.hypot(d.y);
    let (cb, sb) = if horizontal > 1e-9 {
        (d.x / horizontal, d.y / horizontal)
    } else {
        (1.0, 0.0)
    };
    let (ce, se) = (horizontal / range, d.z / range);
    let by_range = d / range;
    let by_bearing = Vector3::new(-sb, cb, 0.0) * horizontal;
    let by_elevation = Vector3::new(-se * cb, -se * sb, ce) * range;
    let [sr, sb_, se_] = sigmas;
    by_range * by_range.transpose() * sr.powi(2)
        + by_bearing * by_bearing.transpose() * sb_.powi(2)
        + by_elevation * by_elevation.transpose() * se_.powi(2)
}

/// The geometry of the ship's transducer and the vehicle's transponder.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mounting {
    pub transducer_lever_arm_m: Vector3<f64>,
    pub transducer_from_ship: Rotation3<f64>,
    pub lever_arm_body_m: Vector3<f64>,
}

impl Mounting {
    pub fn of(a: &UsblAiding) -> Mounting {
        let [roll, pitch, yaw] = a.transducer_alignment_rad;
        Mounting {
            transducer_lever_arm_m: Vector3::from(a.transducer_lever_arm_m),
            transducer_from_ship: Rotation3::from_euler_angles(roll, pitch, yaw),
            lever_arm_body_m: Vector3::from(a.lever_arm_body_m),
        }
    }
}

/// What the estimate predicts of an observation: the transponder in the transducer's axes
/// as the ranges read it (`d / (1 + k)`), its rows in the error state, and its rows in the
/// ship's errors (north, east, down of its position, m; the small rotation of its attitude
/// about north, east, down, rad).
///
/// With `D` the ship's reference point to the transponder in the ship's NED (`p - s + C l`),
/// `S` the ship's attitude and `T` the transducer's: `d = T (S^T D - l_t)`, so
/// `H_p = T S^T / (1 + k)`, `H_psi = -T S^T [(C l) x] / (1 + k)`, `H_k = -d / (1 + k)^2`; the
/// ship's position `-T S^T / (1 + k)` and attitude `T S^T [D x] / (1 + k)`. The vehicle's
/// NED axes and the ship's differ by the angle between their verticals (1.6e-4 rad a
/// kilometre apart): in `D` they are told apart, in the rows not.
pub fn predicted(
    est: &Estimate,
    ship: &ShipAt,
    m: &Mounting,
) -> (Vector3<f64>, SMatrix<f64, 3, N>, SMatrix<f64, 3, 6>) {
    let nav = &est.nav;
    let arm_ned = nav.ned_from_body * m.lever_arm_body_m;
    let to_vehicle = geodesy::ned_offset_m(
        (ship.lat_rad, ship.lon_rad, ship.height_m),
        (nav.lat_rad, nav.lon_rad, nav.height_m),
    );
    let d_ned = to_vehicle + arm_ned;
    let t = m.transducer_from_ship.matrix();
    let a = t * ship.ned_from_ship.matrix().transpose();
    let d = a * d_ned - t * m.transducer_lever_arm_m;
    let scale = 1.0 + est.sound_speed_scale;
    let mut h = SMatrix::<f64, 3, N>::zeros();
    h.fixed_view_mut::<3, 3>(0, idx::POS)
        .copy_from(&(a / scale));
    h.fixed_view_mut::<3, 3>(0, idx::ATT)
        .copy_from(&(-a * arm_ned.cross_matrix() / scale));
    h.fixed_view_mut::<3, 1>(0, idx::SOUND_SPEED_SCALE)
        .copy_from(&(-d / scale.powi(2)));
    let mut ship_rows = SMatrix::<f64, 3, 6>::zeros();
    ship_rows
        .fixed_view_mut::<3, 3>(0, 0)
        .copy_from(&(-a / scale));
    ship_rows
        .fixed_view_mut::<3, 3>(0, 3)
        .copy_from(&(a * d_ned.cross_matrix() / scale));
    (d / scale, h, ship_rows)
}

/// The covariance of the ship's errors in [`predicted`]'s order: its position (horizontal
/// and height sigmas), then its attitude: the heading's sigma about down, the tilt's about
/// the ship's own x and y axes.
pub fn ship_covariance(ship: &ShipAt, height_sigma_m: f64, tilt_sigma_rad: f64) -> Matrix6<f64> {
    let mut cov = Matrix6::zeros();
    let horizontal = ship.position_sigma_m.powi(2);
    cov.fixed_view_mut::<3, 3>(0, 0)
        .copy_from(&Matrix3::from_diagonal(&Vector3::new(
            horizontal,
            horizontal,
            height_sigma_m.powi(2),
        )));
    let s = ship.ned_from_ship.matrix();
    let tilt = Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, 0.0)) * tilt_sigma_rad.powi(2);
    let mut attitude = s * tilt * s.transpose();
    attitude[(2, 2)] += ship.heading_sigma_rad.powi(2);
    cov.fixed_view_mut::<3, 3>(3, 3).copy_from(&attitude);
    cov
}

/// The USBL observations' row of the aiding table.
pub struct UsblAid {
    observations: Vec<ValidObservation>,
    mounting: Mounting,
    ship_height_sigma_m: f64,
    ship_tilt_sigma_rad: f64,
    /// Observations left out: no ship pose when they were valid.
    without_ship: usize,
    /// Observations left out: stamped on receipt, with no delay known.
    without_delay: usize,
}

impl UsblAid {
    pub fn new(readings: &[UsblObservation], ship: &[ShipPose], a: &UsblAiding) -> Self {
        let (mut without_ship, mut without_delay) = (0, 0);
        let mut observations: Vec<ValidObservation> = Vec::with_capacity(readings.len());
        for o in readings {
            // The settings' delay serves only observations that carry no time of validity.
            let delay_s = match a.receipt_delay_s {
                Some(delay_s) => delay_s,
                None if !observation_needs_delay(o) => 0.0,
                None => {
                    without_delay += 1;
                    continue;
                }
            };
            let stamp_ns =
                validity_of(o.stamp_ns, o.stamp_is_validity, o.received_after_s, delay_s);
            let Some(ship) = ship_at(ship, stamp_ns, a) else {
                without_ship += 1;
                continue;
            };
            let own = |s: Option<f64>| s.filter(|s| *s > 0.0);
            let range_sigma = (a.range_fraction * o.range_m).max(a.range_sigma_floor_m);
            observations.push(ValidObservation {
                stamp_ns,
                transducer_m: transducer_vector(o.range_m, o.bearing_rad, o.elevation_rad),
                sigmas: [
                    own(o.range_sigma_m).unwrap_or(range_sigma),
                    own(o.bearing_sigma_rad).unwrap_or(a.angle_sigma_rad),
                    own(o.elevation_sigma_rad).unwrap_or(a.angle_sigma_rad),
                ],
                ship,
                heading_inflation: 1.0,
            });
        }
        observations.sort_by_key(|o| o.stamp_ns);
        // Each observation's interval to its neighbour before (the first: after).
        let stamps: Vec<i64> = observations.iter().map(|o| o.stamp_ns).collect();
        for (i, o) in observations.iter_mut().enumerate() {
            let neighbour = if i > 0 {
                stamps.get(i - 1)
            } else {
                stamps.get(1)
            };
            let interval_s =
                neighbour.map_or(f64::INFINITY, |&t| (o.stamp_ns - t).abs() as f64 * 1e-9);
            o.heading_inflation = heading_share(interval_s, a.ship_heading_correlation_s);
        }
        UsblAid {
            observations,
            mounting: Mounting::of(a),
            ship_height_sigma_m: a.ship_height_sigma_m,
            ship_tilt_sigma_rad: a.ship_tilt_sigma_rad,
            without_ship,
            without_delay,
        }
    }

    /// The observations in use, in time order.
    pub fn observations(&self) -> &[ValidObservation] {
        &self.observations
    }

    /// The update of observation `i` at the estimate: the innovation, its rows, and the
    /// noise of the observation and of the ship's pose.
    pub fn update(&self, i: usize, est: &Estimate) -> Measurement<3> {
        let o = &self.observations[i];
        let (d, h, ship_rows) = predicted(est, &o.ship, &self.mounting);
        let shared = ShipAt {
            heading_sigma_rad: o.ship.heading_sigma_rad * o.heading_inflation.sqrt(),
            ..o.ship
        };
        let ship = ship_covariance(&shared, self.ship_height_sigma_m, self.ship_tilt_sigma_rad);
        // The observation's own noise at the predicted vector: an outlier does not choose
        // its own sigma.
        let r = transducer_covariance(&d, o.sigmas) + ship_rows * ship * ship_rows.transpose();
        Measurement {
            y: SVector::<f64, 3>::from(o.transducer_m - d),
            h,
            r,
        }
    }

    /// The 1-sigma per horizontal axis of the position observation `i` gives the transponder
    /// (the observation's own noise and the ship's errors, at the vector it measured), m: the
    /// sigma a positioned fix of it would carry (its heading error not scaled up for the
    /// neighbours that share it: one observation's own accuracy).
    pub fn positioned_sigma_m(&self, i: usize) -> f64 {
        let o = &self.observations[i];
        let m = &self.mounting;
        let ned_from_transducer =
            o.ship.ned_from_ship.matrix() * m.transducer_from_ship.matrix().transpose();
        let own = transducer_covariance(&o.transducer_m, o.sigmas);
        let d_ned = self.ship_to_transponder_ned_m(i);
        let ship = ship_covariance(&o.ship, self.ship_height_sigma_m, self.ship_tilt_sigma_rad);
        let turn = d_ned.cross_matrix();
        let cov = ned_from_transducer * own * ned_from_transducer.transpose()
            + ship.fixed_view::<3, 3>(0, 0)
            + turn * ship.fixed_view::<3, 3>(3, 3) * turn.transpose();
        (0.5 * (cov[(0, 0)] + cov[(1, 1)])).sqrt()
    }

    /// Where observation `i` puts the transponder from the ship's reference point, in the
    /// ship's NED axes, m (the ship's pose taken as it is).
    fn ship_to_transponder_ned_m(&self, i: usize) -> Vector3<f64> {
        let (o, m) = (&self.observations[i], &self.mounting);
        let in_ship = m.transducer_from_ship.inverse() * o.transducer_m + m.transducer_lever_arm_m;
        o.ship.ned_from_ship * in_ship
    }

    /// Where observation `i` puts the transponder, latitude and longitude, rad.
    pub fn positioned_rad(&self, i: usize) -> (f64, f64) {
        let (ship, ned) = (
            &self.observations[i].ship,
            self.ship_to_transponder_ned_m(i),
        );
        geodesy::position_of_local_m(ship.lat_rad, ship.lon_rad, ned.x, ned.y)
    }

    /// The observations as positioned fixes would be, in time order: where each puts the
    /// transponder, its sigma ([`Self::positioned_sigma_m`]), its range as the slant range.
    /// What the start, the plan and the delay's estimate place, where the filter takes the
    /// raw observation.
    pub fn positioned_fixes(&self) -> impl Iterator<Item = ValidFix> + '_ {
        (0..self.observations.len()).map(|i| {
            let (lat_rad, lon_rad) = self.positioned_rad(i);
            ValidFix {
                stamp_ns: self.observations[i].stamp_ns,
                lat_rad,
                lon_rad,
                sigma_m: self.positioned_sigma_m(i),
                slant_range_m: Some(self.observations[i].transducer_m.norm()),
            }
        })
    }

    /// Where observation `i` puts the transponder, north and east of the first observation's
    /// ship, m.
    pub fn positioned_ne_m(&self, i: usize) -> Option<[f64; 2]> {
        let (first, o) = (self.observations.first()?, &self.observations[i]);
        let (north, east) = geodesy::local_north_east_m(
            first.ship.lat_rad,
            first.ship.lon_rad,
            o.ship.lat_rad,
            o.ship.lon_rad,
        );
        let ned = self.ship_to_transponder_ned_m(i);
        Some([north + ned.x, east + ned.y])
    }
}

impl Aid for UsblAid {
    fn sensor(&self) -> Sensor {
        Sensor::Usbl
    }
    fn len(&self) -> usize {
        self.observations.len()
    }
    fn stamp_ns(&self, i: usize) -> i64 {
        self.observations[i].stamp_ns
    }
    fn measure(&self, i: usize, at: &Epoch<'_>) -> Option<Update> {
        Some(Update::Three(self.update(i, at.est)))
    }
    /// The range measured: what the observation's error grows with.
    fn slant_range_m(&self, i: usize) -> Option<f64> {
        Some(self.observations[i].transducer_m.norm())
    }
    /// The positioned observation, so that a run of refused observations reopens the gate
    /// only when they follow one smooth track ([`super::reopen`]): multipath scatters off it.
    fn reading(&self, i: usize) -> Option<SensorReading> {
        let [north, east] = self.positioned_ne_m(i)?;
        Some(SensorReading {
            dims: 2,
            value: [north, east, 0.0],
        })
    }
    fn left_out_notes(&self) -> Vec<String> {
        self.why_left_out()
    }
}

impl UsblAid {
    /// Why observations were left out.
    fn why_left_out(&self) -> Vec<String> {
        let mut notes = Vec::new();
        if self.without_delay > 0 {
            notes.push(format!(
                "{} USBL observations were left out: they are stamped when the ship received \
                 them, and no receipt delay was given or estimated; give it \
                 ([acoustic_fix] receipt_delay_s)",
                self.without_delay
            ));
        }
        if self.without_ship > 0 {
            notes.push(format!(
                "{} USBL observations were left out: no ship's pose (/ship_pose) around the \
                 time they were valid (poses further apart than [usbl] ship_max_gap_s are \
                 not interpolated)",
                self.without_ship
            ));
        }
        notes
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::filters::ins::error_state::{DvlCalibration, ErrorMatrix, ErrorState, WaterState};
    use crate::filters::ins::mechanization::NavState;
    use nalgebra::UnitQuaternion;

    const LAT: f64 = 0.6;
    const LON: f64 = 0.1;

    /// A level ship heading north at (`LAT`, `LON`) at `t_s`, its pose without sigmas.
    fn level_pose(t_s: i64) -> ShipPose {
        ShipPose {
            stamp_ns: t_s * 1_000_000_000,
            latitude_deg: LAT.to_degrees(),
            longitude_deg: LON.to_degrees(),
            roll: 0.0,
            pitch: 0.0,
            yaw: 0.0,
            horizontal_sigma_m: None,
            heading_sigma_rad: None,
        }
    }

    /// An observation at its time of validity `stamp_ns`, without sigmas.
    fn observed(
        stamp_ns: i64,
        range_m: f64,
        bearing_rad: f64,
        elevation_rad: f64,
    ) -> UsblObservation {
        UsblObservation {
            stamp_ns,
            stamp_is_validity: true,
            received_after_s: None,
            range_m,
            bearing_rad,
            elevation_rad,
            range_sigma_m: None,
            bearing_sigma_rad: None,
            elevation_sigma_rad: None,
            sound_speed_m_s: None,
            beacon_id: String::new(),
        }
    }

    /// Settings of a USBL on the ship's reference point, received 2 s late.
    fn aiding() -> UsblAiding {
        UsblAiding {
            receipt_delay_s: Some(2.0),
            range_fraction: 0.005,
            range_sigma_floor_m: 0.3,
            angle_sigma_rad: 0.003,
            transducer_lever_arm_m: [0.0; 3],
            transducer_alignment_rad: [0.0; 3],
            ship_position_sigma_m: 1.0,
            ship_height_sigma_m: 0.2,
            ship_heading_sigma_rad: 0.002,
            ship_heading_correlation_s: 0.0,
            ship_tilt_sigma_rad: 0.001,
            ship_max_gap_s: 5.0,
            lever_arm_body_m: [0.0; 3],
        }
    }

    fn estimate(lat_rad: f64, lon_rad: f64, depth_m: f64) -> Estimate {
        Estimate {
            nav: NavState {
                lat_rad,
                lon_rad,
                height_m: -depth_m,
                vel_ned_m_s: Vector3::new(1.2, 0.8, 0.1),
                ned_from_body: UnitQuaternion::from_euler_angles(0.02, -0.05, 0.7),
            },
            gyro_bias: Vector3::zeros(),
            accel_bias: Vector3::zeros(),
            dvl: DvlCalibration::zeros(),
            water: WaterState::new(0.0, 0.0, 0.0),
            gyro_scale_z: 0.0,
            sound_speed_scale: 2e-3,
            cov: ErrorMatrix::identity() * 1e-4,
        }
    }

    fn ship(yaw_rad: f64) -> ShipAt {
        ShipAt {
            lat_rad: LAT,
            lon_rad: LON,
            height_m: 0.0,
            ned_from_ship: Rotation3::from_euler_angles(0.03, -0.02, yaw_rad),
            position_sigma_m: 1.0,
            heading_sigma_rad: 0.1_f64.to_radians(),
        }
    }

    fn mounting() -> Mounting {
        Mounting {
            transducer_lever_arm_m: Vector3::new(3.0, 1.0, 4.5),
            transducer_from_ship: Rotation3::from_euler_angles(0.01, 0.02, -0.03),
            lever_arm_body_m: Vector3::new(1.2, -0.4, -0.6),
        }
    }

    /// A vehicle 100 m north of a level ship heading east, 50 m down, the transducer at the
    /// ship's reference point and in its axes: 100 m to port (FRD y -100), 50 m below.
    #[test]
    fn the_vehicle_is_seen_in_the_transducers_axes() {
        let (lat, lon) = geodesy::position_of_local_m(LAT, LON, 100.0, 0.0);
        let mut est = estimate(lat, lon, 50.0);
        est.sound_speed_scale = 0.0;
        let level = ShipAt {
            ned_from_ship: Rotation3::from_euler_angles(0.0, 0.0, std::f64::consts::FRAC_PI_2),
            ..ship(0.0)
        };
        let m = Mounting {
            transducer_lever_arm_m: Vector3::zeros(),
            transducer_from_ship: Rotation3::identity(),
            lever_arm_body_m: Vector3::zeros(),
        };
        let (d, _, _) = predicted(&est, &level, &m);
        // The Earth's curvature over 100 m puts the vehicle 0.8 mm lower.
        assert!((d - Vector3::new(0.0, -100.0, 50.0)).amax() < 2e-3, "{d}");
        let seen = transducer_vector(
            d.norm(),
            (-90.0_f64).to_radians(),
            (50.0_f64 / 100.0).atan(),
        );
        assert!((seen - d).amax() < 2e-3, "{seen} against {d}");
    }

    /// The rows in the error state and in the ship's errors, by central differences: a
    /// centimetre's step in position, a microradian's in the angles.
    #[test]
    fn the_rows_match_finite_differences() {
        // The vehicle 400 m south-west of the ship and 120 m down.
        let (lat, lon) = geodesy::position_of_local_m(LAT, LON, -300.0, -250.0);
        let est = estimate(lat, lon, 120.0);
        let (ship, m) = (ship(0.8), mounting());
        let (_, h, ship_rows) = predicted(&est, &ship, &m);
        for i in 0..N {
            let eps = if i < idx::ATT { 0.01 } else { 1e-6 };
            let mut dx = ErrorState::zeros();
            dx[i] = eps;
            let at = |dx: &ErrorState| predicted(&est.corrected_by(dx), &ship, &m).0;
            let numeric = (at(&dx) - at(&-dx)) / (2.0 * eps);
            assert!(
                (numeric - h.column(i)).amax() < 1e-4,
                "column {i}: {numeric} vs {}",
                h.column(i)
            );
        }
        assert!(h.fixed_view::<3, 3>(0, idx::ATT).amax() > 0.1, "{h}");
        // The ship moved north, east, down, and turned about north, east, down.
        let moved = |k: usize, eps: f64| {
            let mut s = ship;
            if k < 3 {
                let mut ned = Vector3::zeros();
                ned[k] = eps;
                (s.lat_rad, s.lon_rad) = geodesy::position_of_local_m(LAT, LON, ned.x, ned.y);
                s.height_m = -ned.z;
            } else {
                let mut turn = Vector3::zeros();
                turn[k - 3] = eps;
                s.ned_from_ship = Rotation3::new(turn) * ship.ned_from_ship;
            }
            predicted(&est, &s, &m).0
        };
        for k in 0..6 {
            let eps = if k < 3 { 0.01 } else { 1e-6 };
            let numeric = (moved(k, eps) - moved(k, -eps)) / (2.0 * eps);
            assert!(
                (numeric - ship_rows.column(k)).amax() < 1e-3,
                "ship column {k}: {numeric} vs {}",
                ship_rows.column(k)
            );
        }
    }

    /// The vector's covariance is `J diag(sigma^2) J^T` with `J` the vector's derivatives by
    /// range, bearing and elevation (central differences).
    #[test]
    fn the_vectors_covariance_follows_its_sigmas() {
        let (r, b, e) = (600.0, 2.3, 0.4);
        let sigmas = [1.5, 0.004, 0.006];
        let step = [1e-3, 1e-7, 1e-7];
        let mut j = Matrix3::zeros();
        for k in 0..3 {
            let mut plus = [r, b, e];
            let mut minus = plus;
            plus[k] += step[k];
            minus[k] -= step[k];
            let column = (transducer_vector(plus[0], plus[1], plus[2])
                - transducer_vector(minus[0], minus[1], minus[2]))
                / (2.0 * step[k]);
            j.set_column(k, &column);
        }
        let expected =
            j * Matrix3::from_diagonal(&Vector3::from(sigmas.map(|s: f64| s * s))) * j.transpose();
        let got = transducer_covariance(&transducer_vector(r, b, e), sigmas);
        assert!(
            (got - expected).amax() < 1e-6 * expected.amax(),
            "{got} against {expected}"
        );
        // Under the transducer the bearing has no say, and nothing divides by zero.
        let below = transducer_covariance(&Vector3::new(0.0, 0.0, 80.0), sigmas);
        assert!(below.iter().all(|x| x.is_finite()));
        assert!((below[(2, 2)] - 1.5f64.powi(2)).abs() < 1e-9);
    }

    /// The ship's heading error spreads the observation across the line of sight by the
    /// horizontal range times the heading's sigma: at 1000 m, 0.5 deg is 8.7 m.
    #[test]
    fn the_ships_heading_error_grows_with_the_range() {
        let a = UsblAiding {
            receipt_delay_s: None,
            range_fraction: 0.0,
            range_sigma_floor_m: 0.1,
            angle_sigma_rad: 1e-6,
            ship_position_sigma_m: 0.0,
            ship_height_sigma_m: 0.0,
            ship_heading_sigma_rad: 0.0,
            ship_tilt_sigma_rad: 0.0,
            ..aiding()
        };
        let pose = |t_s: i64, heading_sigma_deg: f64| ShipPose {
            heading_sigma_rad: Some(heading_sigma_deg.to_radians()),
            ..level_pose(t_s)
        };
        for north_m in [100.0, 1000.0] {
            let (lat, lon) = geodesy::position_of_local_m(LAT, LON, north_m, 0.0);
            let mut est = estimate(lat, lon, 50.0);
            est.nav.ned_from_body = UnitQuaternion::identity();
            est.sound_speed_scale = 0.0;
            let seen = observed(
                10_000_000_000,
                north_m.hypot(50.0),
                0.0,
                (50.0 / north_m).atan(),
            );
            let cross_range_sigma = |heading_sigma_deg: f64| {
                let ship = [pose(9, heading_sigma_deg), pose(11, heading_sigma_deg)];
                let aid = UsblAid::new(std::slice::from_ref(&seen), &ship, &a);
                aid.update(0, &est).r[(1, 1)].sqrt()
            };
            let ship = [pose(9, 0.5), pose(11, 0.5)];
            let aid = UsblAid::new(std::slice::from_ref(&seen), &ship, &a);
            // Positioned: the heading's spread (east, across the line of sight) and the
            // range's 0.1 m (north), over two axes.
            let positioned = aid.positioned_sigma_m(0);
            let spread = north_m * 0.5_f64.to_radians();
            let along = 0.1 * north_m / north_m.hypot(50.0);
            let expected_positioned = (0.5 * (spread * spread + along * along)).sqrt();
            assert!(
                (positioned - expected_positioned).abs() < 1e-3 * expected_positioned,
                "{north_m} m: positioned {positioned} against {expected_positioned}"
            );
            let grown = cross_range_sigma(0.5);
            let expected = north_m * 0.5_f64.to_radians();
            assert!(cross_range_sigma(0.0) < 1e-3);
            assert!(
                (grown - expected).abs() < 1e-3 * expected,
                "{north_m} m: {grown} against {expected}"
            );
        }
    }

    /// The mean of `n` samples of a first-order Gauss-Markov error, `interval` apart, has the
    /// variance of `n` independent samples of `heading_share` times the variance: exactly,
    /// `sigma^2 / n^2 (n + 2 sum_k (n - k) rho^k)`, for long runs.
    #[test]
    fn a_shared_heading_error_counts_as_fewer_observations() {
        for (interval_s, correlation_s) in [(3.5f64, 10.0f64), (2.0, 60.0), (5.0, 1.0)] {
            let rho: f64 = (-interval_s / correlation_s).exp();
            let n = 20_000usize;
            let sum: f64 = (1..n).map(|k| (n - k) as f64 * rho.powi(k as i32)).sum();
            let exact = (n as f64 + 2.0 * sum) / (n as f64).powi(2);
            let taken = heading_share(interval_s, correlation_s) / n as f64;
            assert!(
                (taken / exact - 1.0).abs() < 0.01,
                "{interval_s} s apart, {correlation_s} s: {taken} against {exact}"
            );
        }
        assert_eq!(heading_share(3.0, 0.0), 1.0);
        assert_eq!(heading_share(f64::INFINITY, 10.0), 1.0);
        assert!(heading_share(0.0, 10.0).is_finite());
    }

    /// The ship's heading variance of a run of observations is scaled by their intervals;
    /// the positioned sigma (one observation's own accuracy) is not.
    #[test]
    fn observations_close_together_share_their_heading_error() {
        let a = UsblAiding {
            ship_heading_correlation_s: 10.0,
            receipt_delay_s: Some(0.0),
            ..aiding()
        };
        let ship: Vec<ShipPose> = (0..=60).map(level_pose).collect();
        let seen = |t_s: i64| observed(t_s * 1_000_000_000, 300.0, 0.0, 0.0);
        // 3 s apart, then one 40 s later.
        let readings = [seen(10), seen(13), seen(16), seen(56)];
        let aid = UsblAid::new(&readings, &ship, &a);
        let factors: Vec<f64> = aid
            .observations()
            .iter()
            .map(|o| o.heading_inflation)
            .collect();
        let close = heading_share(3.0, 10.0);
        assert_eq!(&factors[..3], &[close; 3]);
        assert!((factors[3] - heading_share(40.0, 10.0)).abs() < 1e-12);
        assert!(factors[3] < 1.04 && close > 4.0);
        let white = UsblAid::new(
            &readings,
            &ship,
            &UsblAiding {
                ship_heading_correlation_s: 0.0,
                ..a
            },
        );
        let (lat, lon) = geodesy::position_of_local_m(LAT, LON, 300.0, 0.0);
        let mut est = estimate(lat, lon, 0.0);
        est.nav.ned_from_body = UnitQuaternion::identity();
        est.sound_speed_scale = 0.0;
        // Across the line of sight (y) the heading's share of the noise is scaled; along it
        // (x) nothing changes.
        let (shared, own) = (aid.update(0, &est).r, white.update(0, &est).r);
        let heading_part = (300.0 * a.ship_heading_sigma_rad).powi(2);
        let added = shared[(1, 1)] - own[(1, 1)];
        assert!(
            (added / ((close - 1.0) * heading_part) - 1.0).abs() < 1e-6,
            "{added} against {}",
            (close - 1.0) * heading_part
        );
        assert!((shared[(0, 0)] - own[(0, 0)]).abs() < 1e-9);
        assert_eq!(aid.positioned_sigma_m(0), white.positioned_sigma_m(0));
    }

    /// An observation is placed at its time of validity and the ship interpolated there; one
    /// without a ship's pose around it is counted and named.
    #[test]
    fn an_observation_is_placed_where_the_ship_was_when_it_was_valid() {
        let a = aiding();
        // The ship sails east, 1 m/s (poses every second from 0 to 20 s).
        let ship: Vec<ShipPose> = (0..=20)
            .map(|t| {
                let (lat, lon) = geodesy::position_of_local_m(LAT, LON, 0.0, t as f64);
                ShipPose {
                    latitude_deg: lat.to_degrees(),
                    longitude_deg: lon.to_degrees(),
                    yaw: std::f64::consts::FRAC_PI_2,
                    horizontal_sigma_m: Some(0.5),
                    ..level_pose(t)
                }
            })
            .collect();
        let seen = |stamp_s: f64| UsblObservation {
            stamp_is_validity: false,
            bearing_sigma_rad: Some(0.01),
            ..observed((stamp_s * 1e9) as i64, 200.0, 0.0, 0.5)
        };
        let aid = UsblAid::new(&[seen(12.5), seen(30.0), seen(1.0)], &ship, &a);
        let o = aid.observations();
        assert_eq!(o.len(), 1, "{o:?}");
        assert_eq!(o[0].stamp_ns, 10_500_000_000);
        let (north, east) =
            geodesy::local_north_east_m(LAT, LON, o[0].ship.lat_rad, o[0].ship.lon_rad);
        assert!(
            north.abs() < 1e-6 && (east - 10.5).abs() < 1e-6,
            "{north} {east}"
        );
        assert_eq!(o[0].ship.position_sigma_m, 0.5);
        assert_eq!(o[0].ship.heading_sigma_rad, 0.002);
        assert_eq!(o[0].sigmas, [1.0, 0.01, 0.003]);
        let notes = aid.left_out_notes();
        assert!(
            notes[0].starts_with("2 USBL observations were left out"),
            "{notes:?}"
        );
        // Positioned: ahead of the ship (east), 200 m * cos(0.5) away.
        let [n, e] = aid.positioned_ne_m(0).unwrap();
        assert!(
            n.abs() < 1e-6 && (e - 200.0 * 0.5f64.cos()).abs() < 1e-6,
            "{n} {e}"
        );
    }
}
