//! Thousandths written as decimals, for messages.

use core::fmt;

/// A number given in thousandths, formatted as a decimal without trailing zeros (`12.5`, `-3`,
/// `0.01`).
pub(crate) struct Milli(pub(crate) i64);

impl fmt::Display for Milli {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let sign = if self.0 < 0 { "-" } else { "" };
        let abs = self.0.unsigned_abs();
        let (whole, mut frac) = (abs / 1000, abs % 1000);
        write!(f, "{sign}{whole}")?;
        if frac != 0 {
            let mut digits = 3;
            while frac % 10 == 0 {
                frac /= 10;
                digits -= 1;
            }
            write!(f, ".{frac:0digits$}")?;
        }
        Ok(())
    }
}
