//! Human-readable UTC times for error messages and summaries (RFC 3339, millisecond precision),
//! and the parser of the same form for times given on the command line.

use thiserror::Error;

/// A time that is not `YYYY-MM-DDTHH:MM:SS[.fff…]Z` (UTC), or out of range.
#[derive(Debug, Error, Clone, PartialEq, Eq)]
#[error("time `{text}`: {problem} (expected RFC 3339 in UTC, e.g. 2026-03-02T06:00:00Z)")]
pub struct TimeParseError {
    /// The text given.
    pub text: String,
    /// What is wrong.
    pub problem: &'static str,
}

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

/// UTC calendar date `YYYY-MM-DD` of a time in ns since the Unix epoch.
pub fn utc_date(t_ns: i64) -> String {
    rfc3339_ns(t_ns)[..10].to_string()
}

/// Days since 1970-01-01 of a proleptic Gregorian date (H. Hinnant's days-from-civil).
fn days_from_civil(y: i64, m: i64, d: i64) -> i64 {
    let y = if m <= 2 { y - 1 } else { y };
    let era = y.div_euclid(400);
    let yoe = y - era * 400;
    let mp = (m + 9) % 12;
    let doy = (153 * mp + 2) / 5 + d - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    era * 146_097 + doe - 719_468
}

/// Parses `YYYY-MM-DDTHH:MM:SS[.f…]Z` (UTC, `T` or a space between date and time, up to nine
/// fraction digits) into ns since the Unix epoch. The inverse of [`rfc3339_ns`] for whole
/// milliseconds.
///
/// # Errors
/// [`TimeParseError`] for any other form, an impossible date or time of day, or a time outside
/// the years 1678–2261 (the range of i64 ns).
pub fn parse_rfc3339_utc_ns(text: &str) -> Result<i64, TimeParseError> {
    let bad = |problem| TimeParseError {
        text: text.to_string(),
        problem,
    };
    let b = text.as_bytes();
    let digits = |r: std::ops::Range<usize>| -> Result<i64, TimeParseError> {
        let s = b.get(r).ok_or_else(|| bad("too short"))?;
        if s.is_empty() || !s.iter().all(u8::is_ascii_digit) {
            return Err(bad("a digit is expected"));
        }
        Ok(s.iter().fold(0i64, |a, &c| a * 10 + i64::from(c - b'0')))
    };
    if b.len() < 20 {
        return Err(bad("too short"));
    }
    if b[4] != b'-' || b[7] != b'-' || !(b[10] == b'T' || b[10] == b' ') || b[13] != b':' {
        return Err(bad("separators must be YYYY-MM-DDTHH:MM:SS"));
    }
    if b[16] != b':' {
        return Err(bad("separators must be YYYY-MM-DDTHH:MM:SS"));
    }
    let (y, mo, d) = (digits(0..4)?, digits(5..7)?, digits(8..10)?);
    let (h, mi, s) = (digits(11..13)?, digits(14..16)?, digits(17..19)?);
    let mut i = 19;
    let mut frac_ns = 0i64;
    if b[i] == b'.' {
        let start = i + 1;
        i = start;
        while i < b.len() && b[i].is_ascii_digit() {
            i += 1;
        }
        let n = i - start;
        if n == 0 || n > 9 {
            return Err(bad("the fraction of a second needs 1 to 9 digits"));
        }
        frac_ns = digits(start..i)? * 10i64.pow(9 - n as u32);
    }
    if &b[i..] != b"Z" {
        return Err(bad("the time must end in Z (UTC)"));
    }
    let leap = (y % 4 == 0 && y % 100 != 0) || y % 400 == 0;
    let month_days = [
        31,
        if leap { 29 } else { 28 },
        31,
        30,
        31,
        30,
        31,
        31,
        30,
        31,
        30,
        31,
    ];
    if !(1..=12).contains(&mo) || d < 1 || d > month_days[(mo - 1) as usize] {
        return Err(bad("no such date"));
    }
    if h > 23 || mi > 59 || s > 59 {
        return Err(bad("no such time of day"));
    }
    if !(1678..=2261).contains(&y) {
        return Err(bad(
            "outside the years 1678-2261 that ns since 1970 can hold",
        ));
    }
    let secs = days_from_civil(y, mo, d) * 86_400 + h * 3600 + mi * 60 + s;
    Ok(secs * 1_000_000_000 + frac_ns)
}

#[cfg(test)]
mod tests {
    #[test]
    fn parses_what_it_formats() {
        use super::{parse_rfc3339_utc_ns as parse, rfc3339_ns};
        for t in [
            0,
            1_772_431_200_123_000_000,
            951_782_400_000_000_000,
            -86_400_000_000_000,
        ] {
            assert_eq!(parse(&rfc3339_ns(t)).unwrap(), t);
        }
        assert_eq!(
            parse("2026-03-02T06:00:00Z").unwrap(),
            1_772_431_200_000_000_000
        );
        assert_eq!(
            parse("2026-03-02 06:00:00.5Z").unwrap(),
            1_772_431_200_500_000_000
        );
        for bad in [
            "",
            "2026-03-02T06:00:00",
            "2026-03-02T06:00:00+01:00",
            "2026-02-29T00:00:00Z",
            "2026-13-01T00:00:00Z",
            "2026-03-02T24:00:00Z",
            "2026-03-02T06:00:00.Z",
            "2026-03-02T06:00:00.1234567890Z",
            "2026/03/02T06:00:00Z",
            "1500-01-01T00:00:00Z",
            "２026-03-02T06:00:00Z",
        ] {
            assert!(parse(bad).is_err(), "{bad}");
        }
    }

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
