//! Value parsers of the run flags: each value is checked when the command line is parsed, so a
//! bad one is a usage error (exit 2, one line on stderr) before anything runs.

/// `--rate` (alias `--rate-hz`) of a loop: a positive, finite rate in Hz within the loop's range.
pub fn rate(text: &str) -> Result<f64, String> {
    let hz: f64 = text
        .trim()
        .parse()
        .map_err(|_| format!("`{text}` is not a rate in Hz"))?;
    if !(hz.is_finite() && hz > 0.0) {
        return Err(format!("{text} Hz: must be a positive number"));
    }
    rmd_loop::schedule::Period::from_hz(hz).map_err(|e| e.to_string())?;
    Ok(hz)
}

/// `--cpu`: a CPU this process may run on.
pub fn cpu(text: &str) -> Result<usize, String> {
    let cpu: usize = text
        .trim()
        .parse()
        .map_err(|_| format!("`{text}` is not a CPU index"))?;
    let ids = core_affinity::get_core_ids().unwrap_or_default();
    if ids.iter().any(|c| c.id == cpu) {
        Ok(cpu)
    } else {
        let list: Vec<String> = ids.iter().map(|c| c.id.to_string()).collect();
        Err(format!(
            "CPU {cpu} is not available to this process (available: {})",
            if list.is_empty() {
                "unknown".to_string()
            } else {
                list.join(", ")
            }
        ))
    }
}

/// `--fifo`: a SCHED_FIFO priority, 1..=99.
pub fn fifo(text: &str) -> Result<u8, String> {
    let p: u8 = text
        .trim()
        .parse()
        .map_err(|_| format!("`{text}` is not a priority (1..=99)"))?;
    if !(1..=99).contains(&p) {
        return Err(format!("priority {p}: must be 1..=99"));
    }
    Ok(p)
}

/// `--cpu-dma-latency`: a CPU wake-up latency in whole microseconds (at most
/// [`MAX_CPU_LATENCY`](rmd_loop::os::MAX_CPU_LATENCY)), or `off`.
pub fn cpu_latency(text: &str) -> Result<rmd_loop::robot::CpuLatencySetting, String> {
    use rmd_loop::robot::CpuLatencySetting;
    let text = text.trim();
    if text.eq_ignore_ascii_case("off") {
        return Ok(CpuLatencySetting::Off);
    }
    let max = rmd_loop::os::MAX_CPU_LATENCY.as_micros();
    let us: u32 = text
        .parse()
        .map_err(|_| format!("`{text}` is not a latency in whole microseconds, nor `off`"))?;
    if u128::from(us) > max {
        return Err(format!("{us} us: must be at most {max} us (or `off`)"));
    }
    Ok(CpuLatencySetting::Us(us))
}

/// `--spin-us`: microseconds of busy-waiting before each deadline, 0..=1 s (a negative or
/// fractional value is a usage error naming the flag, not an unknown argument).
pub fn spin_us(text: &str) -> Result<u64, String> {
    match text.trim().parse::<u64>() {
        Ok(us) if us <= 1_000_000 => Ok(us),
        _ => Err(format!(
            "`{text}` is not a whole number of microseconds from 0 to 1000000 (1 s)"
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spin_margins_are_checked() {
        assert_eq!(spin_us("200"), Ok(200));
        for bad in ["-1", "1.5", "1000001", "inf", ""] {
            assert!(spin_us(bad).unwrap_err().contains("whole number"), "{bad}");
        }
    }

    #[test]
    fn values_are_checked() {
        assert_eq!(rate("1000").unwrap(), 1000.0);
        for bad in ["0", "-5", "nan", "1e9", "0.001"] {
            assert!(rate(bad).is_err(), "{bad}");
        }
        assert_eq!(fifo("99").unwrap(), 99);
        assert!(fifo("0").is_err());
        assert!(fifo("100").is_err());
        assert_eq!(cpu("0").unwrap(), 0);
        assert!(cpu("100000").unwrap_err().contains("not available"));
        use rmd_loop::robot::CpuLatencySetting;
        assert_eq!(cpu_latency("0").unwrap(), CpuLatencySetting::Us(0));
        assert_eq!(cpu_latency("25").unwrap(), CpuLatencySetting::Us(25));
        assert_eq!(cpu_latency("off").unwrap(), CpuLatencySetting::Off);
        assert!(cpu_latency("-1").unwrap_err().contains("microseconds"));
        assert!(cpu_latency("2000000").unwrap_err().contains("at most"));
    }
}
