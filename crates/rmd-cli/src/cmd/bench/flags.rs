//! Value parsers of the flags only the benchmarks have (`--motors`, `--buses`). The run flags
//! they share with other commands are in `rmd_rig::args`.

use rmd_loop::robot::{MAX_BUSES, MAX_MOTORS_PER_BUS};

/// `--motors`: motors per bus, 1..=4.
pub(crate) fn motors(text: &str) -> Result<u8, String> {
    let n: u8 = text
        .trim()
        .parse()
        .map_err(|_| format!("`{text}` is not a number of motors"))?;
    if !(1..=MAX_MOTORS_PER_BUS as u8).contains(&n) {
        return Err(format!(
            "{n} motors per bus: must be 1..={MAX_MOTORS_PER_BUS} (one 0x280 frame drives motor \
             ids 1..=4; use --buses for more motors)"
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
        assert!(motors("5").unwrap_err().contains("--buses"));
        assert!(motors("0").is_err());
        assert_eq!(buses("8").unwrap(), 8);
        assert!(buses("9").is_err());
    }
}
