//! The Earth's main magnetic field at a place and time, for the magnetometer's heading: the
//! declination with an honest 1-sigma.
//!
//! - From 2020 to 2029, the World Magnetic Model (WMM2020 and WMM2025, the
//!   `world_magnetic_model` crate), with the model's own error model.
//! - At any other date from 1900 to 2030, IGRF-14 ([`igrf`]), with WMM2020's error model: the
//!   error of a main-field model at the surface is mostly the crustal field both leave out.

pub mod igrf;

use world_magnetic_model::time::Date;
use world_magnetic_model::uom::si::angle::degree;
use world_magnetic_model::uom::si::f32::{Angle, Length};
use world_magnetic_model::uom::si::length::meter;
use world_magnetic_model::GeomagneticField;

/// Which model gave a declination.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FieldModel {
    Wmm,
    Igrf14,
}

impl FieldModel {
    pub fn name(self) -> &'static str {
        match self {
            FieldModel::Wmm => "World Magnetic Model",
            FieldModel::Igrf14 => "IGRF-14",
        }
    }
}

/// The declination at a place and time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Declination {
    /// East positive, degrees.
    pub declination_deg: f64,
    /// The model's 1-sigma uncertainty of it, degrees.
    pub sigma_deg: f64,
    /// The field's inclination (dip), degrees, down positive.
    pub inclination_deg: f64,
    pub model: FieldModel,
}

/// Why no model has a value.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("no geomagnetic model for the date: World Magnetic Model: {wmm}; {igrf}")]
pub struct GeomagError {
    wmm: String,
    igrf: String,
}

/// WMM2020's declination error model (its technical report, section 3.4): the 1-sigma is
/// `sqrt(c^2 + (v / H)^2)` degrees, `H` the horizontal intensity in nT.
const ERROR_MODEL_C_DEG: f64 = 0.26;
const ERROR_MODEL_V_DEG_NT: f64 = 5625.0;
/// The crate's ceiling on the declination's sigma, kept for IGRF-14's alike.
const MAX_SIGMA_DEG: f64 = 180.0;

/// The declination at latitude/longitude (degrees), height above the WGS-84 ellipsoid (m)
/// and time (ns since the Unix epoch): the World Magnetic Model's in its years (2020-2029),
/// else IGRF-14's (1900-2030).
pub fn declination(
    latitude_deg: f64,
    longitude_deg: f64,
    height_m: f64,
    stamp_ns: i64,
) -> Result<Declination, GeomagError> {
    let longitude_deg = crate::angle::wrap_pi(longitude_deg.to_radians()).to_degrees();
    let wmm = match wmm(latitude_deg, longitude_deg, height_m, stamp_ns) {
        Ok(d) => return Ok(d),
        Err(e) => e,
    };
    igrf_declination(latitude_deg, longitude_deg, height_m, stamp_ns)
        .map_err(|igrf| GeomagError { wmm, igrf })
}

fn wmm(
    latitude_deg: f64,
    longitude_deg: f64,
    height_m: f64,
    stamp_ns: i64,
) -> Result<Declination, String> {
    let date = date_of(stamp_ns)?;
    let field = GeomagneticField::new(
        Length::new::<meter>(height_m as f32),
        Angle::new::<degree>(latitude_deg as f32),
        Angle::new::<degree>(longitude_deg as f32),
        date,
    )
    .map_err(|e| e.to_string())?;
    Ok(Declination {
        declination_deg: f64::from(field.declination().get::<degree>()),
        sigma_deg: f64::from(field.declination_uncertainty().get::<degree>()),
        inclination_deg: f64::from(field.inclination().get::<degree>()),
        model: FieldModel::Wmm,
    })
}

fn igrf_declination(
    latitude_deg: f64,
    longitude_deg: f64,
    height_m: f64,
    stamp_ns: i64,
) -> Result<Declination, String> {
    let year = decimal_year(stamp_ns);
    let f = igrf::field_geodetic(year, latitude_deg, longitude_deg, height_m * 1e-3)?;
    let sigma = ERROR_MODEL_C_DEG.hypot(ERROR_MODEL_V_DEG_NT / f.horizontal_nt());
    Ok(Declination {
        declination_deg: f.declination_deg(),
        sigma_deg: sigma.min(MAX_SIGMA_DEG),
        inclination_deg: f.inclination_deg(),
        model: FieldModel::Igrf14,
    })
}

/// A stamp as a decimal year (UTC): the year plus the fraction of it gone.
pub fn decimal_year(stamp_ns: i64) -> f64 {
    const NS_PER_DAY: i64 = crate::time::NS_PER_S * 86_400;
    let day = stamp_ns.div_euclid(NS_PER_DAY);
    let (y, _, _) = crate::time::civil_from_days(day);
    let start = crate::time::days_from_civil(y, 1, 1) * NS_PER_DAY;
    let end = crate::time::days_from_civil(y + 1, 1, 1) * NS_PER_DAY;
    y as f64 + (stamp_ns - start) as f64 / (end - start) as f64
}

/// The UTC calendar date of a stamp.
fn date_of(stamp_ns: i64) -> Result<Date, String> {
    let days = stamp_ns.div_euclid(crate::time::NS_PER_S * 86_400);
    let (y, m, d) = crate::time::civil_from_days(days);
    let month = world_magnetic_model::time::Month::try_from(m as u8).map_err(|e| e.to_string())?;
    Date::from_calendar_date(y as i32, month, d as u8).map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The stamp of a decimal year as the WMM reads dates: day `1 + (year - floor) * days`.
    fn stamp_of_decimal_year(year: f64) -> i64 {
        let whole = year.floor() as i64;
        let days_in_year = if whole % 4 == 0 { 366 } else { 365 };
        let day = ((year - year.floor()) * days_in_year as f64).round() as i64;
        let jan1 = crate::time::days_from_civil(whole, 1, 1);
        (jan1 + day) * 86_400 * crate::time::NS_PER_S
    }

    /// WMM2025's published test values (the model report's table: decimal year, height km,
    /// latitude, longitude, declination in degrees to 0.01).
    #[test]
    fn matches_the_published_wmm2025_test_values() {
        let table = [
            (2025.0, 0.0, 80.0, 0.0, 1.28),
            (2025.0, 0.0, 0.0, 120.0, -0.16),
            (2025.0, 0.0, -80.0, 240.0, 68.78),
            (2025.0, 100.0, 80.0, 0.0, 0.85),
            (2025.0, 100.0, 0.0, 120.0, -0.15),
            (2025.0, 100.0, -80.0, 240.0, 68.21),
            (2027.5, 0.0, 80.0, 0.0, 2.59),
            (2027.5, 0.0, 0.0, 120.0, -0.24),
            (2027.5, 0.0, -80.0, 240.0, 68.49),
            (2027.5, 100.0, 80.0, 0.0, 2.16),
            (2027.5, 100.0, 0.0, 120.0, -0.23),
            (2027.5, 100.0, -80.0, 240.0, 67.93),
        ];
        for (year, km, lat, lon, want) in table {
            let d = declination(lat, lon, km * 1000.0, stamp_of_decimal_year(year)).unwrap();
            assert!(
                (d.declination_deg - want).abs() <= 0.011,
                "{year} {km} km {lat} {lon}: {} vs {want}",
                d.declination_deg
            );
            assert!(d.sigma_deg > 0.0 && d.sigma_deg < 5.0, "{}", d.sigma_deg);
        }
    }

    /// The stamp of a calendar day at 00:00 UTC.
    fn stamp_of_day(y: i64, m: u32, d: u32) -> i64 {
        crate::time::days_from_civil(y, m, d) * 86_400 * crate::time::NS_PER_S
    }

    /// Before 2020 the declination is IGRF-14's: against published declinations of other
    /// models of the same main field (decimal year or day, height km, latitude, longitude,
    /// degrees), within a tenth of a degree.
    /// - WMM2010's test values at its epoch (its report, 2010.0). Its 2012.5 values are left
    ///   out: they are the 2009 model's forecast, 0.12-0.21 deg from where the definitive
    ///   field went (IGRF-14 interpolates the definitive 2010 and 2015 fields).
    /// - WMM2015v2's test values (NOAA, the 2019 re-issue of `WMM2015testvalues.pdf`; 2017.5
    ///   is taken as 1 July 2017, as the table's users do).
    /// - NOAA's online calculator with WMM2015v2 at three cities.
    #[test]
    fn before_2020_igrf_matches_published_declinations_within_a_tenth_of_a_degree() {
        let points = [
            (stamp_of_decimal_year(2010.0), 0.0, 80.0, 0.0, -6.13),
            (stamp_of_decimal_year(2010.0), 0.0, 0.0, 120.0, 0.97),
            (stamp_of_decimal_year(2010.0), 0.0, -80.0, 240.0, 70.21),
            (stamp_of_decimal_year(2010.0), 100.0, 80.0, 0.0, -6.57),
            (stamp_of_decimal_year(2010.0), 100.0, 0.0, 120.0, 0.94),
            (stamp_of_decimal_year(2010.0), 100.0, -80.0, 240.0, 69.62),
            (stamp_of_decimal_year(2015.0), 0.0, 80.0, 0.0, -3.90),
            (stamp_of_decimal_year(2015.0), 0.0, 0.0, 120.0, 0.55),
            (stamp_of_decimal_year(2015.0), 0.0, -80.0, 240.0, 69.81),
            (stamp_of_decimal_year(2015.0), 100.0, 80.0, 0.0, -4.32),
            (stamp_of_decimal_year(2015.0), 100.0, 0.0, 120.0, 0.54),
            (stamp_of_decimal_year(2015.0), 100.0, -80.0, 240.0, 69.22),
            (stamp_of_day(2017, 7, 1), 0.0, 80.0, 0.0, -2.59),
            (stamp_of_day(2017, 7, 1), 0.0, 0.0, 120.0, 0.37),
            (stamp_of_day(2017, 7, 1), 0.0, -80.0, 240.0, 69.59),
            (stamp_of_day(2017, 7, 1), 100.0, 80.0, 0.0, -3.01),
            (stamp_of_day(2017, 7, 1), 100.0, 0.0, 120.0, 0.36),
            (stamp_of_day(2017, 7, 1), 100.0, -80.0, 240.0, 69.01),
            (
                stamp_of_day(2018, 1, 10),
                1.630,
                40.014986,
                -105.270546,
                8.4116,
            ),
            (
                stamp_of_day(2019, 8, 28),
                0.022,
                51.507335,
                -0.127683,
                -0.0432,
            ),
            (
                stamp_of_day(2019, 12, 31),
                0.054,
                -33.867487,
                151.206990,
                12.5805,
            ),
        ];
        for (stamp, km, lat, lon, want) in points {
            let d = declination(lat, lon, km * 1000.0, stamp).unwrap();
            assert_eq!(d.model, FieldModel::Igrf14);
            assert!(
                (d.declination_deg - want).abs() <= 0.1,
                "{stamp} {km} km {lat} {lon}: {} vs {want}",
                d.declination_deg
            );
            // The error model's sigma: under half a degree away from the poles.
            if lat.abs() < 60.0 {
                assert!(d.sigma_deg > 0.26 && d.sigma_deg <= 0.5, "{}", d.sigma_deg);
            }
        }
    }

    #[test]
    fn the_decimal_year_counts_the_days_gone() {
        assert_eq!(decimal_year(stamp_of_day(2016, 1, 1)), 2016.0);
        // 2016 is a leap year: 1 July is 182 days in.
        assert!((decimal_year(stamp_of_day(2016, 7, 1)) - (2016.0 + 182.0 / 366.0)).abs() < 1e-12);
    }

    #[test]
    fn outside_the_models_years_is_an_error() {
        let e = declination(35.0, 129.0, 0.0, stamp_of_decimal_year(1850.0)).unwrap_err();
        assert!(e.to_string().contains("World Magnetic Model"), "{e}");
        assert!(e.to_string().contains("1900-2030"), "{e}");
    }
}
