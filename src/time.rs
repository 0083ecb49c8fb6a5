//! Time stamps: integer nanoseconds since the Unix epoch (UTC), as the log contract fixes.
//!
//! Only human-facing output converts to seconds or calendar dates.

/// Nanoseconds per second.
pub const NS_PER_S: i64 = 1_000_000_000;

/// First stamp the contract accepts: 1970-01-01T00:00:00Z.
pub const MIN_STAMP_NS: i64 = 0;

/// First stamp the contract rejects: 2100-01-01T00:00:00Z.
pub const END_STAMP_NS: i64 = 4_102_444_800 * NS_PER_S;

/// Whether a stamp lies in the contract's range [1970, 2100).
pub fn stamp_in_range(stamp_ns: i64) -> bool {
    (MIN_STAMP_NS..END_STAMP_NS).contains(&stamp_ns)
}

/// Nanoseconds from seconds, rounded to the nearest nanosecond; `None` if not representable.
pub fn s_to_ns(seconds: f64) -> Option<i64> {
    let ns = (seconds * 1e9).round();
    (ns.is_finite() && ns.abs() < 9.2e18).then_some(ns as i64)
}

/// ISO 8601 UTC text of a stamp with millisecond precision, e.g. `2023-11-14T22:13:20.000Z`.
///
/// Stamps before 1970 are printed too (proleptic Gregorian), so error messages can show them.
pub fn format_utc(stamp_ns: i64) -> String {
    let secs = stamp_ns.div_euclid(NS_PER_S);
    let millis = stamp_ns.rem_euclid(NS_PER_S) / 1_000_000;
    let days = secs.div_euclid(86_400);
    let sod = secs.rem_euclid(86_400);
    let (y, m, d) = civil_from_days(days);
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}.{millis:03}Z",
        sod / 3600,
        (sod / 60) % 60,
        sod % 60
    )
}

/// Year, month, day of a count of days since 1970-01-01 (H. Hinnant's algorithm).
pub fn civil_from_days(days: i64) -> (i64, u32, u32) {
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    let y = yoe + era * 400 + i64::from(m <= 2);
    (y, m, d)
}

/// Days since 1970-01-01 of a proleptic Gregorian date (the inverse of [`civil_from_days`]).
pub fn days_from_civil(year: i64, month: u32, day: u32) -> i64 {
    let y = if month <= 2 { year - 1 } else { year };
    let era = y.div_euclid(400);
    let yoe = y.rem_euclid(400);
    let m = i64::from(month);
    let doy = (153 * (if m > 2 { m - 3 } else { m + 9 }) + 2) / 5 + i64::from(day) - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    era * 146_097 + doe - 719_468
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn calendar_days_round_trip() {
        for days in [-800_000, -1, 0, 59, 60, 11_016, 19_675, 47_482] {
            let (y, m, d) = civil_from_days(days);
            assert_eq!(days_from_civil(y, m, d), days, "{y}-{m}-{d}");
        }
        assert_eq!(days_from_civil(2000, 3, 1), 11_017);
    }

    #[test]
    fn formats_known_dates() {
        assert_eq!(format_utc(0), "1970-01-01T00:00:00.000Z");
        assert_eq!(
            format_utc(1_700_000_000_123_456_789),
            "2023-11-14T22:13:20.123Z"
        );
        assert_eq!(format_utc(END_STAMP_NS), "2100-01-01T00:00:00.000Z");
        assert_eq!(format_utc(-NS_PER_S), "1969-12-31T23:59:59.000Z");
        assert_eq!(
            format_utc(951_782_400 * NS_PER_S),
            "2000-02-29T00:00:00.000Z"
        );
    }

    #[test]
    fn range_is_half_open() {
        assert!(stamp_in_range(0));
        assert!(!stamp_in_range(-1));
        assert!(stamp_in_range(END_STAMP_NS - 1));
        assert!(!stamp_in_range(END_STAMP_NS));
    }

    #[test]
    fn seconds_round_trip() {
        assert_eq!(s_to_ns(-0.120), Some(-120_000_000));
        assert_eq!(s_to_ns(f64::NAN), None);
    }
}
