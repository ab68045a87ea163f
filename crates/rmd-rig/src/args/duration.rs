//! Durations on the command line: a number with units, as [`humantime`] reads them (`2s`,
//! `500ms`, `1.5s`, `2m`, `1m30s`, `1h`), or a bare number of seconds (`1.5`), so that flags
//! that took seconds keep their meaning.
//!
//! Negative, infinite, NaN and overflowing values are errors, and so is a value outside the
//! flag's range ([`Bounds`]); none of them panics.

use std::time::Duration;

/// The range a flag accepts.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct Bounds {
    /// Whether 0 is accepted.
    pub zero: bool,
    /// The longest accepted duration.
    pub max: Duration,
}

/// Longest run accepted (one day).
pub const MAX_RUN: Duration = Duration::from_secs(86_400);

/// `--duration` (alias `--seconds`) of a run: above 0 and at most a day, with units (`500ms`,
/// `2m`) or a bare number of seconds.
///
/// ```
/// use core::time::Duration;
/// use rmd_rig::args::duration::run_length;
/// assert_eq!(run_length("2.5"), Ok(Duration::from_millis(2500)));
/// assert_eq!(run_length("20ms"), Ok(Duration::from_millis(20)));
/// assert!(run_length("inf").is_err());
/// assert!(run_length("-1").is_err());
/// assert!(run_length("1e300").is_err());
/// ```
pub fn run_length(text: &str) -> Result<Duration, String> {
    parse(text, Bounds::positive_up_to(MAX_RUN))
}

/// `--stall-bound`: how long a tick may take before the supervisor ends the run; 1 ms up to
/// a minute (the robot description then checks it against the period).
///
/// ```
/// use core::time::Duration;
/// use rmd_rig::args::duration::stall_bound;
/// assert_eq!(stall_bound("200ms"), Ok(Duration::from_millis(200)));
/// assert_eq!(stall_bound("0.5"), Ok(Duration::from_millis(500)));
/// assert!(stall_bound("0").is_err());
/// assert!(stall_bound("500us").is_err());
/// assert!(stall_bound("2m").is_err());
/// ```
pub fn stall_bound(text: &str) -> Result<Duration, String> {
    let bound = parse(text, Bounds::positive_up_to(MAX_STALL_BOUND))?;
    if bound < Duration::from_millis(1) {
        return Err(format!(
            "`{text}`: the stall bound is whole milliseconds, at least 1ms"
        ));
    }
    Ok(bound)
}

/// Longest `--stall-bound` (as `loop.stall_bound_ms` allows).
pub const MAX_STALL_BOUND: Duration = rmd_loop::robot::MAX_STALL_BOUND;

impl Bounds {
    /// 0 up to `max`.
    pub const fn up_to(max: Duration) -> Self {
        Bounds { zero: true, max }
    }

    /// Above 0, up to `max`.
    pub const fn positive_up_to(max: Duration) -> Self {
        Bounds { zero: false, max }
    }
}

/// The longest duration a flag without a range of its own accepts (about 31 years).
pub const LONGEST: Duration = Duration::from_secs(1_000_000_000);

/// A duration flag without a range of its own (`--wait-timeout`, `rmd torque --duration`,
/// `rmd log --duration`): 0 up to [`LONGEST`].
pub fn any(text: &str) -> Result<Duration, String> {
    parse(text, Bounds::up_to(LONGEST))
}

/// What a duration looks like, for error messages.
const EXAMPLES: &str = "e.g. 2s, 500ms, 1.5s, 2m; a bare number is seconds";

/// Parses `text` as a duration within `bounds`.
pub fn parse(text: &str, bounds: Bounds) -> Result<Duration, String> {
    let t = text.trim();
    if t.starts_with('-') {
        return Err(format!("`{text}`: a duration cannot be negative"));
    }
    let duration = match t.parse::<f64>() {
        Ok(seconds) if !seconds.is_finite() => {
            return Err(format!("`{text}` is not a finite duration ({EXAMPLES})"));
        }
        Ok(seconds) => Duration::try_from_secs_f64(seconds)
            .map_err(|_| format!("`{text}` seconds is too long: at most {}", show(bounds.max)))?,
        Err(_) => humantime::parse_duration(t)
            .map_err(|e| format!("`{text}` is not a duration: {e} ({EXAMPLES})"))?,
    };
    if duration.is_zero() && !bounds.zero {
        return Err(format!("`{text}`: the duration must be above 0"));
    }
    if duration > bounds.max {
        return Err(format!(
            "`{text}` is too long: at most {}",
            show(bounds.max)
        ));
    }
    Ok(duration)
}

/// A duration in humantime's words (`1day`, `16years 10months ...`).
fn show(duration: Duration) -> String {
    humantime::format_duration(duration).to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    const DAY: Duration = Duration::from_secs(86_400);

    fn ok(text: &str) -> Duration {
        parse(text, Bounds::up_to(DAY)).unwrap()
    }

    fn err(text: &str, bounds: Bounds) -> String {
        parse(text, bounds).unwrap_err()
    }

    #[test]
    fn units_and_bare_seconds() {
        assert_eq!(ok("2s"), Duration::from_secs(2));
        assert_eq!(ok("500ms"), Duration::from_millis(500));
        assert_eq!(ok("1.5s"), Duration::from_millis(1500));
        assert_eq!(ok("2m"), Duration::from_secs(120));
        assert_eq!(ok("1min"), Duration::from_secs(60));
        assert_eq!(ok("1m30s"), Duration::from_secs(90));
        assert_eq!(ok(" 1.5 "), Duration::from_millis(1500));
        assert_eq!(ok("3"), Duration::from_secs(3));
        assert_eq!(ok("0"), Duration::ZERO);
        assert_eq!(ok("24h"), DAY);
    }

    #[test]
    fn bad_values_are_clear_errors() {
        let day = Bounds::positive_up_to(DAY);
        assert!(err("-1", day).contains("cannot be negative"));
        assert!(err("-1s", day).contains("cannot be negative"));
        for text in ["inf", "nan", "NaN", "infinity", "+inf"] {
            assert!(err(text, day).contains("not a finite duration"), "{text}");
        }
        assert!(err("0", day).contains("above 0"));
        assert!(err("0ms", day).contains("above 0"));
        assert!(err("86401", day).contains("at most 1day"));
        assert!(err("25h", day).contains("at most 1day"));
        assert!(err("1e300", day).contains("too long"));
        assert!(err("100000000000000000000y", day).contains("not a duration"));
        assert!(err("soon", day).contains("not a duration"));
        assert!(err("", day).contains("not a duration"));
        assert!(err("5 parsecs", day).contains("not a duration"));
    }
}
