//! Value parsers of the flags only the benchmarks have (`--motors`, `--buses`), and the guard of
//! their loop `--rate`. The run flags they share with other commands are in `rmd_rig::args`.

use rmd_loop::robot::{MAX_BUSES, MAX_MOTORS_PER_BUS};

/// The most motors per bus a benchmark runs: beyond [`MAX_MOTORS_PER_BUS`] (what one 0x280
/// frame drives) the bus exchanges per motor.
pub(crate) const MAX_BENCH_MOTORS: u8 = 8;
use rmd_loop::schedule::MAX_PERIOD;
use rmd_rig::args::values;

/// `--rate` of a benchmark's loop: `rmd_rig::args::values::rate`, after refusing a rate whose
/// period is longer than the loop's longest ([`MAX_PERIOD`]) itself, since the loop's own check
/// cannot represent the period of a rate like 1e-300 Hz.
pub(crate) fn loop_rate(text: &str) -> Result<f64, String> {
    if let Ok(hz) = text.trim().parse::<f64>()
        && hz.is_finite()
        && hz > 0.0
        && 1.0 / hz > MAX_PERIOD.as_secs_f64()
    {
        return Err(format!(
            "{text} Hz is too slow: the loop period must be at most {MAX_PERIOD:?} (at least {} Hz)",
            1.0 / MAX_PERIOD.as_secs_f64()
        ));
    }
    values::rate(text)
}

/// `--motors`: motors per bus, 1..=8 (ids 1..=N; more than [`MAX_MOTORS_PER_BUS`] are driven
/// per motor, one 0xA1 request each).
pub(crate) fn motors(text: &str) -> Result<u8, String> {
    let n: u8 = text
        .trim()
        .parse()
        .map_err(|_| format!("`{text}` is not a number of motors"))?;
    if !(1..=MAX_BENCH_MOTORS).contains(&n) {
        return Err(format!(
            "{n} motors per bus: must be 1..={MAX_BENCH_MOTORS} (one 0x280 frame drives motor \
             ids 1..={MAX_MOTORS_PER_BUS}, more are driven per motor; use --buses for more \
             motors)"
        ));
    }
    Ok(n)
}

/// `--buses`: 1..=8.
pub(crate) fn buses(text: &str) -> Result<usize, String> {
    let n: usize = text
        .trim()
        .parse()
        .map_err(|_| format!("`{text}` is not a number of buses"))?;
    if !(1..=MAX_BUSES).contains(&n) {
        return Err(format!("{n} buses: must be 1..={MAX_BUSES}"));
    }
    Ok(n)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_are_checked() {
        assert_eq!(motors("4").unwrap(), 4);
        assert_eq!(motors("8").unwrap(), 8);
        assert!(motors("9").unwrap_err().contains("--buses"));
        assert!(motors("0").is_err());
        assert_eq!(buses("8").unwrap(), 8);
        assert!(buses("9").is_err());
        assert_eq!(loop_rate("1000").unwrap(), 1000.0);
        for bad in ["1e-300", "0.01", "0", "-5", "inf", "NaN", "1e300"] {
            assert!(loop_rate(bad).is_err(), "{bad}");
        }
        assert!(loop_rate("1e-300").unwrap_err().contains("too slow"));
    }
}
