//! The Earth's main magnetic field from the World Magnetic Model (WMM2020 and WMM2025, the
//! `world_magnetic_model` crate): the declination at a place and time, with the model's own
//! stated uncertainty (its error model, 1-sigma), for the magnetometer's heading.

use world_magnetic_model::time::Date;
use world_magnetic_model::uom::si::angle::degree;
use world_magnetic_model::uom::si::f32::{Angle, Length};
use world_magnetic_model::uom::si::length::meter;
use world_magnetic_model::GeomagneticField;

/// The declination at a place and time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Declination {
    /// East positive, degrees.
    pub declination_deg: f64,
    /// The model's 1-sigma uncertainty of it, degrees.
    pub sigma_deg: f64,
    /// The field's inclination (dip), degrees, down positive.
    pub inclination_deg: f64,
}

/// Why the model has no value.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("World Magnetic Model: {0}")]
pub struct GeomagError(String);

/// The WMM declination at latitude/longitude (degrees), height above the WGS-84 ellipsoid
/// (m) and time (ns since the Unix epoch); the model in force at that date (2020-2029).
pub fn declination(
    latitude_deg: f64,
    longitude_deg: f64,
    height_m: f64,
    stamp_ns: i64,
) -> Result<Declination, GeomagError> {
    let date = date_of(stamp_ns)?;
    let field = GeomagneticField::new(
        Length::new::<meter>(height_m as f32),
        Angle::new::<degree>(latitude_deg as f32),
        Angle::new::<degree>(crate::angle::wrap_pi(longitude_deg.to_radians()).to_degrees() as f32),
        date,
    )
    .map_err(|e| GeomagError(e.to_string()))?;
    Ok(Declination {
        declination_deg: f64::from(field.declination().get::<degree>()),
        sigma_deg: f64::from(field.declination_uncertainty().get::<degree>()),
        inclination_deg: f64::from(field.inclination().get::<degree>()),
    })
}

/// The UTC calendar date of a stamp.
fn date_of(stamp_ns: i64) -> Result<Date, GeomagError> {
    let days = stamp_ns.div_euclid(crate::time::NS_PER_S * 86_400);
    let (y, m, d) = crate::time::civil_from_days(days);
    let month = world_magnetic_model::time::Month::try_from(m as u8)
        .map_err(|e| GeomagError(e.to_string()))?;
    Date::from_calendar_date(y as i32, month, d as u8).map_err(|e| GeomagError(e.to_string()))
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

    #[test]
    fn outside_the_models_years_is_an_error() {
        let e = declination(35.0, 129.0, 0.0, stamp_of_decimal_year(2012.0)).unwrap_err();
        assert!(e.to_string().contains("World Magnetic Model"), "{e}");
    }
}
