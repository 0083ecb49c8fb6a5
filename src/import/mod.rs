//! Logs from other forms into the contract: CSV exports of a vehicle's computer, by a map
//! ([`map::CsvMap`]) that says which columns are which fields. The messages are checked as
//! any log's are and written as a contract log (json in MCAP) that every command reads.

pub mod csv;
pub mod map;

use crate::ingest::Mission;
use crate::sim::writer::{LogWriter, WriteError};
use std::io::{Seek, Write};

/// Writes the map's mission record (when it has one) and the imported messages.
pub fn write_log<W: Write + Seek>(
    mission: Option<&map::MissionMap>,
    messages: &[csv::Imported],
    w: &mut LogWriter<W>,
) -> Result<(), WriteError> {
    if let Some(m) = mission {
        w.write_mission(&Mission {
            origin_latitude_deg: m.origin_latitude_deg,
            origin_longitude_deg: m.origin_longitude_deg,
            vehicle: m.vehicle.clone(),
            description: m.description.clone(),
            initial_yaw_rad: None,
            magnetic_declination_deg: m.magnetic_declination_deg,
        })?;
    }
    for m in messages {
        let log_time = u64::try_from(m.stamp_ns).unwrap_or(0);
        w.write_raw(
            &m.topic,
            m.schema_name,
            m.schema_json,
            "json",
            &m.json,
            log_time,
        )?;
    }
    Ok(())
}
