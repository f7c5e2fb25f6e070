//! Local date and time from text (ISO 8601 with a UTC offset), as scene files and the
//! command line give them.

use crate::LocalTime;

/// Parses an ISO 8601 local date and time with its UTC offset:
/// `YYYY-MM-DDTHH:MM[:SS[.fff]]` then `Z` or `±HH[:MM]` (a space may stand for `T`).
pub fn parse_local_time(s: &str) -> Result<LocalTime, String> {
    let bad = || {
        format!(
            "'{s}' is not a local date and time with its UTC offset, e.g. \"2024-06-21T14:30:00+02:00\" (or ...Z for UTC)"
        )
    };
    let s = s.trim();
    let (date, rest) = s.split_once(['T', ' ']).ok_or_else(bad)?;
    let mut dp = date.split('-');
    let year: i32 = dp.next().and_then(|x| x.parse().ok()).ok_or_else(bad)?;
    let month: u32 = dp.next().and_then(|x| x.parse().ok()).ok_or_else(bad)?;
    let day: u32 = dp.next().and_then(|x| x.parse().ok()).ok_or_else(bad)?;
    if dp.next().is_some() {
        return Err(bad());
    }
    let (clock, tz) = if let Some(c) = rest.strip_suffix('Z') {
        (c, 0.0)
    } else if let Some(i) = rest.rfind(['+', '-']) {
        let (c, z) = rest.split_at(i);
        let sign = if z.starts_with('-') { -1.0 } else { 1.0 };
        let z = &z[1..];
        let (h, m) = z.split_once(':').unwrap_or((z, "0"));
        let h: f64 = h.parse().map_err(|_| bad())?;
        let m: f64 = m.parse().map_err(|_| bad())?;
        (c, sign * (h + m / 60.0))
    } else {
        return Err(format!(
            "'{s}' has no UTC offset: end it with Z (UTC) or the local offset such as +02:00"
        ));
    };
    let mut cp = clock.split(':');
    let hour: u32 = cp.next().and_then(|x| x.parse().ok()).ok_or_else(bad)?;
    let minute: u32 = cp.next().and_then(|x| x.parse().ok()).ok_or_else(bad)?;
    let second: f64 = match cp.next() {
        Some(x) => x.parse().map_err(|_| bad())?,
        None => 0.0,
    };
    if cp.next().is_some() {
        return Err(bad());
    }
    Ok(LocalTime::new(year, month, day, hour, minute, second, tz))
}

#[cfg(test)]
mod tests {
    use super::parse_local_time as parse_time;

    #[test]
    fn times_parse_with_their_offsets() {
        let t = parse_time("2024-06-21T14:30:15+02:00").unwrap();
        assert_eq!(
            (t.year, t.month, t.day, t.hour, t.minute),
            (2024, 6, 21, 14, 30)
        );
        assert_eq!((t.second, t.timezone), (15.0, 2.0));
        assert_eq!(parse_time("2003-10-17 12:30-07:00").unwrap().timezone, -7.0);
        assert_eq!(parse_time("2024-01-01T00:00Z").unwrap().timezone, 0.0);
        assert_eq!(parse_time("2024-01-01T10:00+05:30").unwrap().timezone, 5.5);
        assert!(
            parse_time("2024-06-21T14:30")
                .unwrap_err()
                .contains("no UTC offset")
        );
        assert!(parse_time("June 21").is_err());
    }
}
