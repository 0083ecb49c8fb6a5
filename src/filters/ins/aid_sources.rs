//! The aiding sources, one row each of the table in [`super::aid_table`]: the readings, the
//! settings, and the update of one reading from the measurement models of
//! [`super::forward::measure`].

use super::aid_table::{
    Aid, Epoch, LeftOut, MagAiding, Measurement, RpmVelocity, Sensor, SensorReading, Update,
};
use super::forward::{measure, DvlMounting};
use crate::align::latest_at;
use crate::contract::{
    Altimeter, Depth, Dvl, GnssFix, MagneticField, PositionFix, Propeller, SpeedLog,
};
use crate::filters::velocity::model_aided::{BodyVelocityReading, ModelVelocity};
use crate::filters::velocity::rpm::{self, Reading, RpmFilter, RpmRun};
use crate::geodesy;
use nalgebra::{SMatrix, Vector3};
use std::sync::Mutex;

/// An aid's `len` and `stamp_ns` from its list of readings (each with a `stamp_ns`).
macro_rules! stamped_by {
    ($readings:ident) => {
        fn len(&self) -> usize {
            self.$readings.len()
        }
        fn stamp_ns(&self, i: usize) -> i64 {
            self.$readings[i].stamp_ns
        }
    };
}

/// Readings at least `min_interval_s` apart, the first one kept.
fn thinned<T: Clone>(readings: &[T], min_interval_s: f64, stamp: impl Fn(&T) -> i64) -> Vec<T> {
    let min_ns = (min_interval_s * 1e9) as i64;
    let mut kept: Vec<T> = Vec::with_capacity(readings.len());
    for r in readings {
        if kept
            .last()
            .is_none_or(|last| stamp(r) - stamp(last) >= min_ns)
        {
            kept.push(r.clone());
        }
    }
    kept
}

/// DVL velocity over ground, used with bottom lock within its altitude range.
pub struct DvlAid<'a> {
    pub readings: &'a [Dvl],
    /// Echo-sounder altitudes, to check the range when a reading carries none.
    pub altimeter: &'a [Altimeter],
    pub sigma_m_s: f64,
    pub max_altitude_m: f64,
    /// False: every reading is used.
    pub check_range: bool,
    pub altimeter_max_age_s: f64,
    pub mounting: DvlMounting,
}

impl DvlAid<'_> {
    fn in_range(&self, d: &Dvl) -> bool {
        let max_age_ns = (self.altimeter_max_age_s * 1e9) as i64;
        let altitude = d.altitude.or_else(|| {
            latest_at(self.altimeter, d.stamp_ns)
                .filter(|(_, age)| *age <= max_age_ns)
                .map(|(a, _)| a.altitude)
        });
        !self.check_range || (d.valid && altitude.is_none_or(|h| h <= self.max_altitude_m))
    }

    /// The readings in range, their velocity in the body axes (the nominal mounting). A
    /// reading that repeats the two before exactly is left out: a stuck DVL's stretch is a
    /// gap to whoever plans around the DVL or learns from it.
    pub fn in_range_body_velocities(&self) -> Vec<BodyVelocityReading> {
        let body_from_dvl = self.mounting.dvl_from_body.inverse();
        self.readings
            .iter()
            .enumerate()
            .filter(|&(i, d)| self.in_range(d) && !self.repeats(i))
            .map(|(_, d)| BodyVelocityReading {
                stamp_ns: d.stamp_ns,
                v_body_m_s: body_from_dvl * Vector3::from(d.velocity),
            })
            .collect()
    }
}

impl Aid for DvlAid<'_> {
    fn sensor(&self) -> Sensor {
        Sensor::Dvl
    }
    stamped_by!(readings);
    fn measure(&self, i: usize, at: &Epoch<'_>) -> Option<Update> {
        let d = &self.readings[i];
        if !self.in_range(d) {
            return None;
        }
        let (y, h) = measure::dvl_velocity(
            at.est,
            &Vector3::from(d.velocity),
            &self.mounting,
            &at.omega_nb_body,
        );
        let r = SMatrix::<f64, 3, 3>::identity() * self.sigma_m_s.powi(2);
        Some(Update::Three(Measurement { y, h, r }))
    }
    fn reading(&self, i: usize) -> Option<SensorReading> {
        Some(SensorReading::three(self.readings[i].velocity))
    }
    /// Three noisy components repeating to the bit, three readings running: the DVL has
    /// stopped measuring. (Two in a row happen to a DVL that reports whole mm/s with less
    /// than a mm/s of noise; three, about a thousandth as often.)
    fn repeats(&self, i: usize) -> bool {
        let v = |k: usize| self.readings[k].velocity;
        i >= 2 && v(i) == v(i - 1) && v(i - 1) == v(i - 2)
    }
}

/// Pressure depth, thinned to a minimum interval.
pub struct DepthAid {
    readings: Vec<Depth>,
    sigma_m: f64,
    left_out: LeftOut,
}

impl DepthAid {
    pub fn new(readings: &[Depth], sigma_m: f64, min_interval_s: f64) -> Self {
        let kept = thinned(readings, min_interval_s, |d| d.stamp_ns);
        DepthAid {
            left_out: LeftOut {
                by_interval: readings.len() - kept.len(),
                disturbed: 0,
            },
            readings: kept,
            sigma_m,
        }
    }
}

impl Aid for DepthAid {
    fn sensor(&self) -> Sensor {
        Sensor::Depth
    }
    stamped_by!(readings);
    fn measure(&self, i: usize, at: &Epoch<'_>) -> Option<Update> {
        let (y, h) = measure::depth(at.est, self.readings[i].depth);
        let r = SMatrix::<f64, 1, 1>::new(self.sigma_m.powi(2));
        Some(Update::One(Measurement { y, h, r }))
    }
    fn reading(&self, i: usize) -> Option<SensorReading> {
        Some(SensorReading::one(self.readings[i].depth))
    }
    fn left_out(&self) -> LeftOut {
        self.left_out
    }
}

/// GNSS horizontal position, with each fix's own sigma.
pub struct GnssAid<'a> {
    pub readings: &'a [GnssFix],
}

impl Aid for GnssAid<'_> {
    fn sensor(&self) -> Sensor {
        Sensor::Gnss
    }
    stamped_by!(readings);
    fn measure(&self, i: usize, at: &Epoch<'_>) -> Option<Update> {
        let g = &self.readings[i];
        let (y, h) = measure::horizontal_position(
            at.est,
            g.latitude_deg.to_radians(),
            g.longitude_deg.to_radians(),
        );
        let r = SMatrix::<f64, 2, 2>::identity() * g.horizontal_sigma_m.powi(2);
        Some(Update::Two(Measurement { y, h, r }))
    }
}

/// Known positions in the mission frame (USBL fixes, surveyed marks), with their sigmas.
pub struct FixAid<'a> {
    readings: &'a [PositionFix],
    /// Mission origin, rad, and the radii that turn north and east metres into its latitude
    /// and longitude (the inverse of `geodesy::local_north_east_m`).
    origin_rad: (f64, f64),
    origin_rn: f64,
    origin_re: f64,
}

impl<'a> FixAid<'a> {
    pub fn new(readings: &'a [PositionFix], origin_rad: (f64, f64)) -> Self {
        let lat = origin_rad.0;
        FixAid {
            readings,
            origin_rad,
            origin_rn: geodesy::meridian_radius_m(lat),
            origin_re: geodesy::prime_vertical_radius_m(lat) * lat.cos(),
        }
    }
}

impl Aid for FixAid<'_> {
    fn sensor(&self) -> Sensor {
        Sensor::PositionFix
    }
    stamped_by!(readings);
    fn measure(&self, i: usize, at: &Epoch<'_>) -> Option<Update> {
        let f = &self.readings[i];
        let (lat0, lon0) = self.origin_rad;
        let (lat, lon) = (
            lat0 + f.north_m / self.origin_rn,
            lon0 + f.east_m / self.origin_re,
        );
        let (y, h) = measure::horizontal_position(at.est, lat, lon);
        let r = SMatrix::<f64, 2, 2>::identity() * f.sigma_m.powi(2);
        Some(Update::Two(Measurement { y, h, r }))
    }
}

/// EM-log speed through the water; not used below 0.1 m/s forward.
pub struct SpeedLogAid<'a> {
    pub readings: &'a [SpeedLog],
    pub sigma_m_s: f64,
}

impl Aid for SpeedLogAid<'_> {
    fn sensor(&self) -> Sensor {
        Sensor::SpeedLog
    }
    stamped_by!(readings);
    fn measure(&self, i: usize, at: &Epoch<'_>) -> Option<Update> {
        let (y, h, attitude_variance) = measure::speed(at.est, self.readings[i].speed)?;
        let r = SMatrix::<f64, 1, 1>::new(self.sigma_m_s.powi(2) + attitude_variance);
        Some(Update::One(Measurement { y, h, r }))
    }
    fn reading(&self, i: usize) -> Option<SensorReading> {
        Some(SensorReading::one(self.readings[i].speed))
    }
}

/// Magnetic heading: at most one reading per interval, none whose magnitude is off the
/// reference (a disturbed field).
pub struct MagAid {
    readings: Vec<MagneticField>,
    declination_rad: f64,
    sigma_rad: f64,
    left_out: LeftOut,
}

impl MagAid {
    pub fn new(mag: &[MagneticField], a: &MagAiding) -> Self {
        let min_ns = (a.min_interval_s * 1e9) as i64;
        let mut kept = Vec::<MagneticField>::new();
        let mut left_out = LeftOut::default();
        for m in mag {
            if kept
                .last()
                .is_some_and(|last| m.stamp_ns - last.stamp_ns < min_ns)
            {
                left_out.by_interval += 1;
                continue;
            }
            let norm = Vector3::from(m.magnetic_field).norm();
            if (norm / a.reference_norm_t - 1.0).abs() > a.max_norm_deviation {
                left_out.disturbed += 1;
                continue;
            }
            kept.push(m.clone());
        }
        MagAid {
            readings: kept,
            declination_rad: a.declination_rad,
            sigma_rad: a.sigma_rad,
            left_out,
        }
    }
}

impl Aid for MagAid {
    fn sensor(&self) -> Sensor {
        Sensor::Magnetometer
    }
    stamped_by!(readings);
    fn measure(&self, i: usize, at: &Epoch<'_>) -> Option<Update> {
        let field = Vector3::from(self.readings[i].magnetic_field);
        let (y, h) = measure::magnetic_heading(at.est, &field, self.declination_rad)?;
        let r = SMatrix::<f64, 1, 1>::new(self.sigma_rad.powi(2));
        Some(Update::One(Measurement { y, h, r }))
    }
    fn left_out(&self) -> LeftOut {
        self.left_out
    }
}

/// Seed 003's switch: while the DVL is out, the propeller's speed from the velocity filter
/// ([`crate::filters::velocity::rpm`], learnt from the DVL's forward speed while in range),
/// as a body velocity `[V, 0, 0]` over ground (sway and heave taken as zero).
pub struct RpmVelocityAid {
    speeds: Vec<rpm::RpmSpeed>,
    lateral_sigma_m_s: f64,
    /// The filter's run (its speeds moved into the aid), or why the propeller was refused.
    pub run: Result<RpmRun, rpm::RpmRefused>,
}

impl RpmVelocityAid {
    /// Runs the velocity filter over the propeller's readings and the DVL's readings in
    /// range (`dvl`'s check), their forward speed in the body axes.
    pub fn new(propeller: &[Propeller], dvl: &DvlAid<'_>, settings: &RpmVelocity) -> Self {
        let mut readings: Vec<Reading> = propeller
            .iter()
            .map(|p| Reading::Rpm {
                stamp_ns: p.stamp_ns,
                rpm: p.rpm,
            })
            .chain(
                dvl.in_range_body_velocities()
                    .iter()
                    .map(|d| Reading::DvlForward {
                        stamp_ns: d.stamp_ns,
                        speed_m_s: d.v_body_m_s.x,
                    }),
            )
            .collect();
        readings.sort_by_key(Reading::stamp_ns);
        let filter = RpmFilter {
            dvl_sigma_m_s: dvl.sigma_m_s,
            ..settings.filter
        };
        let mut run = if propeller.is_empty() {
            Ok(RpmRun::default())
        } else {
            rpm::run(&filter, &readings)
        };
        RpmVelocityAid {
            speeds: run
                .as_mut()
                .map(|r| std::mem::take(&mut r.speeds))
                .unwrap_or_default(),
            lateral_sigma_m_s: settings.lateral_sigma_m_s,
            run,
        }
    }
}

impl Aid for RpmVelocityAid {
    fn sensor(&self) -> Sensor {
        Sensor::RpmVelocity
    }
    stamped_by!(speeds);
    fn measure(&self, i: usize, at: &Epoch<'_>) -> Option<Update> {
        let s = &self.speeds[i];
        let (y, h) = super::forward::measure::body_velocity_uncalibrated(
            at.est,
            &Vector3::new(s.speed_m_s, 0.0, 0.0),
        );
        let lateral = self.lateral_sigma_m_s.powi(2);
        let r = SMatrix::<f64, 3, 3>::from_diagonal(&Vector3::new(
            s.sigma_m_s.powi(2),
            lateral,
            lateral,
        ));
        Some(Update::Three(Measurement { y, h, r }))
    }
    fn notes(&self) -> Vec<String> {
        match &self.run {
            Err(why) => vec![why.to_string()],
            Ok(_) => Vec::new(),
        }
    }
}

/// Seed 000's model-aided velocity (or the virtual sensor's) while the DVL is out: the
/// filter's body velocity over ground with its covariance, spread over the updates within its
/// correlation time (the filter's error is slow: a covariance applied at every update as if
/// independent would be averaged away).
///
/// The velocities may come in as the model's filter runs ([`ModelVelocityAid::taking`]): the
/// table grows between the stretches of a pass, each velocity put in before the pass reaches
/// its stamp.
pub struct ModelVelocityAid {
    velocities: Mutex<Vec<ModelVelocity>>,
    /// Each velocity's covariance is multiplied by this.
    inflation: f64,
    notes: Vec<String>,
}

/// How the model's velocities are handed to the navigation filter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModelVelocityUse {
    pub correlation_s: f64,
    pub min_interval_s: f64,
    pub dvl_timeout_s: f64,
}

/// Which of the model's velocities (in time order) the navigation filter takes: those with
/// no DVL reading in range within the timeout before them, at least the least interval
/// apart.
pub struct ModelVelocitySelection<'a> {
    dvl_in_range: &'a [BodyVelocityReading],
    timeout_ns: i64,
    min_interval_ns: i64,
    last_taken_ns: Option<i64>,
}

impl<'a> ModelVelocitySelection<'a> {
    /// `dvl_in_range`: the DVL's readings in range, time-sorted.
    pub fn new(dvl_in_range: &'a [BodyVelocityReading], how: &ModelVelocityUse) -> Self {
        ModelVelocitySelection {
            dvl_in_range,
            timeout_ns: (how.dvl_timeout_s * 1e9) as i64,
            min_interval_ns: (how.min_interval_s * 1e9) as i64,
            last_taken_ns: None,
        }
    }

    /// Whether the next velocity, stamped `t_ns`, is taken.
    pub fn takes(&mut self, t_ns: i64) -> bool {
        let i = self.dvl_in_range.partition_point(|d| d.stamp_ns <= t_ns);
        let dvl_out = i == 0 || t_ns - self.dvl_in_range[i - 1].stamp_ns > self.timeout_ns;
        let spaced = self
            .last_taken_ns
            .is_none_or(|last| t_ns - last >= self.min_interval_ns);
        let taken = dvl_out && spaced;
        if taken {
            self.last_taken_ns = Some(t_ns);
        }
        taken
    }
}

impl ModelVelocityAid {
    /// No velocities yet: they are put in with [`ModelVelocityAid::take`] as they come.
    pub fn taking(how: &ModelVelocityUse) -> Self {
        ModelVelocityAid {
            velocities: Mutex::new(Vec::new()),
            inflation: (how.correlation_s / how.min_interval_s).max(1.0),
            notes: Vec::new(),
        }
    }

    /// Puts in the next of the model's velocities (time order) that `selection` takes.
    pub fn take(&self, velocities: &[ModelVelocity], selection: &mut ModelVelocitySelection<'_>) {
        self.list()
            .extend(velocities.iter().filter(|v| selection.takes(v.stamp_ns)));
    }

    /// No velocities, and why.
    pub fn refused(why: String) -> Self {
        ModelVelocityAid {
            velocities: Mutex::new(Vec::new()),
            inflation: 1.0,
            notes: vec![why],
        }
    }

    fn list(&self) -> std::sync::MutexGuard<'_, Vec<ModelVelocity>> {
        // A producer that panicked left whole velocities behind: still good to read.
        self.velocities.lock().unwrap_or_else(|e| e.into_inner())
    }
}

impl Aid for ModelVelocityAid {
    fn sensor(&self) -> Sensor {
        Sensor::ModelVelocity
    }
    fn len(&self) -> usize {
        self.list().len()
    }
    fn stamp_ns(&self, i: usize) -> i64 {
        self.list()[i].stamp_ns
    }
    fn measure(&self, i: usize, at: &Epoch<'_>) -> Option<Update> {
        let v = self.list()[i];
        let (y, h) = super::forward::measure::body_velocity_uncalibrated(at.est, &v.v_body_m_s);
        Some(Update::Three(Measurement {
            y,
            h,
            r: v.cov * self.inflation,
        }))
    }
    fn notes(&self) -> Vec<String> {
        self.notes.clone()
    }
}

/// A row of another table, borrowed: a pass whose table adds a row to a table another pass
/// uses at the same time.
pub struct Borrowed<'a>(pub &'a dyn Aid);

impl Aid for Borrowed<'_> {
    fn sensor(&self) -> Sensor {
        self.0.sensor()
    }
    fn len(&self) -> usize {
        self.0.len()
    }
    fn stamp_ns(&self, i: usize) -> i64 {
        self.0.stamp_ns(i)
    }
    fn measure(&self, i: usize, at: &Epoch<'_>) -> Option<Update> {
        self.0.measure(i, at)
    }
    fn reading(&self, i: usize) -> Option<SensorReading> {
        self.0.reading(i)
    }
    fn repeats(&self, i: usize) -> bool {
        self.0.repeats(i)
    }
    fn slant_range_m(&self, i: usize) -> Option<f64> {
        self.0.slant_range_m(i)
    }
    fn left_out(&self) -> LeftOut {
        self.0.left_out()
    }
    fn notes(&self) -> Vec<String> {
        self.0.notes()
    }
    fn left_out_notes(&self) -> Vec<String> {
        self.0.left_out_notes()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The magnetometer readings the filter takes: one per interval, none whose magnitude is
    /// off the reference by more than the allowed fraction (a disturbed field).
    #[test]
    fn disturbed_and_too_frequent_mag_readings_are_skipped() {
        let mag: Vec<MagneticField> = (0..20)
            .map(|k| MagneticField {
                stamp_ns: k * 500_000_000,
                magnetic_field: if k == 4 {
                    [9e-5, 0.0, 0.0]
                } else {
                    [2e-5, 0.0, 4e-5]
                },
            })
            .collect();
        let aiding = MagAiding {
            declination_rad: 0.0,
            sigma_rad: 0.1,
            min_interval_s: 1.0,
            reference_norm_t: 2e-5f64.hypot(4e-5),
            max_norm_deviation: 0.15,
        };
        let aid = MagAid::new(&mag, &aiding);
        let left = aid.left_out();
        assert_eq!((aid.len(), left.by_interval, left.disturbed), (10, 9, 1));
        assert!(aid.readings.iter().all(|m| m.stamp_ns != 2_000_000_000));
    }

    /// Depth thinned to its interval: the first reading kept, then each at least the
    /// interval after the last kept.
    #[test]
    fn depth_is_thinned_to_its_interval() {
        let depth: Vec<Depth> = (0..10)
            .map(|k| Depth {
                stamp_ns: k * 40_000_000,
                depth: 1.0,
            })
            .collect();
        let aid = DepthAid::new(&depth, 0.1, 0.1);
        let stamps: Vec<i64> = (0..aid.len()).map(|i| aid.stamp_ns(i)).collect();
        assert_eq!(stamps, [0, 120_000_000, 240_000_000, 360_000_000]);
        assert_eq!(aid.left_out().by_interval, 6);
    }

    /// The model's velocities the navigation filter takes: only while the DVL has been out
    /// for the timeout, at least the least interval apart; the same whether the velocities
    /// come all at once or in pieces as the model's filter makes them.
    #[test]
    fn model_velocities_are_taken_while_the_dvl_is_out_and_the_same_in_pieces() {
        let s = 1_000_000_000i64;
        // The DVL in range until 10 s and again from 30 s.
        let dvl: Vec<BodyVelocityReading> = (0..=10)
            .chain(30..=40)
            .map(|k| BodyVelocityReading {
                stamp_ns: k * s,
                v_body_m_s: Vector3::zeros(),
            })
            .collect();
        let how = ModelVelocityUse {
            correlation_s: 4.0,
            min_interval_s: 2.0,
            dvl_timeout_s: 3.0,
        };
        // The model at 10 Hz from 0 to 45 s.
        let velocities: Vec<ModelVelocity> = (0..450)
            .map(|k| ModelVelocity {
                stamp_ns: k * s / 10,
                v_body_m_s: Vector3::new(k as f64, 0.0, 0.0),
                cov: nalgebra::Matrix3::identity(),
            })
            .collect();
        let whole = ModelVelocityAid::taking(&how);
        whole.take(&velocities, &mut ModelVelocitySelection::new(&dvl, &how));
        let stamps = |aid: &ModelVelocityAid| -> Vec<i64> {
            (0..aid.len()).map(|i| aid.stamp_ns(i) / (s / 10)).collect()
        };
        // Out from 13.1 s (more than 3 s after the reading at 10 s) to 30 s, and after 43 s;
        // 2 s apart.
        let want: Vec<i64> = (131..300)
            .step_by(20)
            .chain((431..450).step_by(20))
            .collect();
        assert_eq!(stamps(&whole), want);
        let pieces = ModelVelocityAid::taking(&how);
        let mut selection = ModelVelocitySelection::new(&dvl, &how);
        for piece in velocities.chunks(37) {
            pieces.take(piece, &mut selection);
        }
        assert_eq!(stamps(&pieces), want);
        // The covariance is spread over the updates within the correlation time.
        assert_eq!((whole.inflation, pieces.inflation), (2.0, 2.0));
    }
}
