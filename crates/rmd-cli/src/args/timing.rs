//! Value parsers of the CLI's own time flags: rates that set a period (`--rate` of `rmd torque`,
//! `speed`, `monitor`), whole microseconds or milliseconds (`--turnaround-us`, `--timeout-ms`,
//! ...) and the replay speed. Durations with units are `rmd_rig::args::duration`.
//!
//! Every value that is not representable (negative, infinite, NaN, too large, a period too long)
//! is a usage error naming the value, never a panic. Flags taking these parsers also take
//! `allow_hyphen_values`, so that `-1` is this error for the flag rather than an unknown
//! option.

use std::time::Duration;

use rmd_rig::args::duration::LONGEST;

fn number(text: &str, what: &str) -> Result<f64, String> {
    text.trim()
        .parse::<f64>()
        .map_err(|_| format!("`{text}` is not {what}"))
}

/// A rate in Hz whose period is at most [`LONGEST`] (about 31 years): finite, above 0.
///
/// A rate higher than the motors answer is accepted: the commands are then sent as fast as
/// the replies come.
pub(crate) fn rate_hz(text: &str) -> Result<f64, String> {
    let hz = number(text, "a rate in Hz")?;
    if !(hz.is_finite() && hz > 0.0) {
        return Err(format!("{text} Hz: a rate must be a finite number above 0"));
    }
    let slowest = 1.0 / LONGEST.as_secs_f64();
    if hz < slowest {
        return Err(format!(
            "{text} Hz is too slow: the period would be longer than {} (at least {slowest:e} Hz)",
            humantime::format_duration(LONGEST)
        ));
    }
    Ok(hz)
}

/// The period of a rate checked by [`rate_hz`] (0 for a rate too high for nanoseconds).
pub(crate) fn period(hz: f64) -> Duration {
    Duration::try_from_secs_f64(1.0 / hz).unwrap_or(LONGEST)
}

/// Whole units of `unit` (`us`, `ms`), `min..=max`.
fn whole(text: &str, unit: &str, min: u64, max: u64) -> Result<u64, String> {
    let t = text.trim();
    if t.starts_with('-') {
        return Err(format!("`{text}`: a duration cannot be negative"));
    }
    let value: u64 = t
        .parse()
        .map_err(|_| format!("`{text}` is not a whole number of {unit} ({min}..={max})"))?;
    if !(min..=max).contains(&value) {
        return Err(format!("{value} {unit}: must be {min}..={max}"));
    }
    Ok(value)
}

/// `--timeout-ms`: a reply timeout, 1..=60000 ms.
pub(crate) fn reply_timeout_ms(text: &str) -> Result<u64, String> {
    whole(text, "ms", 1, 60_000)
}

/// Microseconds of a simulated motor's turnaround or jitter (`rmd sim`), 0..=60 s (the longest
/// reply timeout).
pub(crate) fn sim_delay_us(text: &str) -> Result<u64, String> {
    whole(text, "us", 0, 60_000_000)
}

/// Microseconds of a busy-wait before a deadline (`--spin-us`, `--rx-spin-us`), 0..=1 s.
pub(crate) fn spin_us(text: &str) -> Result<u64, String> {
    whole(text, "us", 0, 1_000_000)
}

/// `rmd replay --speed`: a finite factor within 0.001..=1000000 (a pause of the log divided by
/// it stays a representable duration).
pub(crate) fn replay_speed(text: &str) -> Result<f64, String> {
    let speed = number(text, "a speed factor")?;
    if !(speed.is_finite() && (0.001..=1e6).contains(&speed)) {
        return Err(format!(
            "{text}: the replay speed must be a finite factor within 0.001..=1000000 (1: as \
             recorded)"
        ));
    }
    Ok(speed)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rates_set_representable_periods() {
        assert_eq!(rate_hz("50"), Ok(50.0));
        assert_eq!(period(50.0), Duration::from_millis(20));
        assert_eq!(rate_hz("1e300"), Ok(1e300));
        assert_eq!(period(1e300), Duration::ZERO);
        for bad in ["0", "-1", "inf", "-inf", "NaN", "1e-300", "fast"] {
            assert!(rate_hz(bad).is_err(), "{bad}");
        }
        assert!(rate_hz("1e-300").unwrap_err().contains("too slow"));
        // The slowest accepted rate still has a representable period.
        let slowest = 1.0 / LONGEST.as_secs_f64();
        assert!(period(rate_hz(&slowest.to_string()).unwrap()) <= LONGEST);
    }

    #[test]
    fn whole_units_within_their_range() {
        assert_eq!(reply_timeout_ms("50"), Ok(50));
        assert_eq!(sim_delay_us("0"), Ok(0));
        assert_eq!(spin_us("1000000"), Ok(1_000_000));
        assert!(reply_timeout_ms("0").unwrap_err().contains("1..=60000"));
        assert!(reply_timeout_ms("-1").unwrap_err().contains("negative"));
        assert!(sim_delay_us("60000001").is_err());
        for bad in ["inf", "NaN", "1e300", "1.5", "18446744073709551616"] {
            assert!(spin_us(bad).unwrap_err().contains("whole number"), "{bad}");
        }
    }

    #[test]
    fn replay_speeds_keep_pauses_representable() {
        assert_eq!(replay_speed("2"), Ok(2.0));
        assert_eq!(replay_speed("0.001"), Ok(0.001));
        for bad in ["0", "-1", "inf", "NaN", "1e-300", "1e300"] {
            assert!(replay_speed(bad).is_err(), "{bad}");
        }
    }
}
