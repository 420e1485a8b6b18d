//! Human-readable UTC times for error messages and summaries (RFC 3339, millisecond precision).

/// Formats ns since the Unix epoch as `YYYY-MM-DDTHH:MM:SS.mmmZ` (proleptic Gregorian, UTC).
pub fn rfc3339_ns(t_ns: i64) -> String {
    let secs = t_ns.div_euclid(1_000_000_000);
    let ms = t_ns.rem_euclid(1_000_000_000) / 1_000_000;
    let days = secs.div_euclid(86_400);
    let sod = secs.rem_euclid(86_400);
    // Civil-from-days (H. Hinnant's algorithm): days since 1970-01-01 to y-m-d.
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}.{ms:03}Z",
        sod / 3600,
        (sod / 60) % 60,
        sod % 60
    )
}

#[cfg(test)]
mod tests {
    #[test]
    fn known_dates() {
        assert_eq!(super::rfc3339_ns(0), "1970-01-01T00:00:00.000Z");
        // 2026-03-02T06:00:00Z = 1772431200 s
        assert_eq!(
            super::rfc3339_ns(1_772_431_200_123_000_000),
            "2026-03-02T06:00:00.123Z"
        );
        assert_eq!(
            super::rfc3339_ns(951_782_400_000_000_000),
            "2000-02-29T00:00:00.000Z"
        );
    }
}
