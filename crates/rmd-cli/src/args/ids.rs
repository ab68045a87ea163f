//! Lists of motor ids on the command line: `3`, `1-4`, `1,3,5-8`, `all` (1..=32).

use std::fmt;

use rmd_protocol::MotorId;

/// A non-empty, sorted set of motor ids without duplicates.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct IdList(Vec<MotorId>);

impl IdList {
    /// Every id, 1..=32.
    pub(crate) fn all() -> Self {
        Self(
            (MotorId::MIN..=MotorId::MAX)
                .filter_map(|id| MotorId::new(id).ok())
                .collect(),
        )
    }

    /// The ids, ascending.
    pub(crate) fn ids(&self) -> &[MotorId] {
        &self.0
    }
}

/// Parses `3`, `1-4`, `1,3,5-8` or `all`.
pub(crate) fn parse(text: &str) -> Result<IdList, String> {
    let text = text.trim();
    if text.eq_ignore_ascii_case("all") {
        return Ok(IdList::all());
    }
    let mut ids = Vec::new();
    for part in text.split(',') {
        let part = part.trim();
        let (first, last) = match part.split_once('-') {
            Some((a, b)) => (one(a, text)?, one(b, text)?),
            None => {
                let id = one(part, text)?;
                (id, id)
            }
        };
        if first > last {
            return Err(format!(
                "motor id range `{part}` runs backwards: write {}-{}",
                last.get(),
                first.get()
            ));
        }
        ids.extend((first.get()..=last.get()).filter_map(|id| MotorId::new(id).ok()));
    }
    ids.sort();
    ids.dedup();
    Ok(IdList(ids))
}

fn one(text: &str, whole: &str) -> Result<MotorId, String> {
    let text = text.trim();
    let id: u8 = text.parse().map_err(|_| {
        format!("`{whole}` is not a list of motor ids (e.g. 1, 1-4, 1,3,5-8 or all)")
    })?;
    MotorId::new(id).map_err(|e| e.to_string())
}

impl fmt::Display for IdList {
    /// Compact form: `1-4`, `1,3,5-8`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut i = 0;
        let mut first = true;
        while i < self.0.len() {
            let start = self.0[i].get();
            let mut end = start;
            while i + 1 < self.0.len() && self.0[i + 1].get() == end + 1 {
                i += 1;
                end += 1;
            }
            if !first {
                f.write_str(",")?;
            }
            first = false;
            if end == start {
                write!(f, "{start}")?;
            } else {
                write!(f, "{start}-{end}")?;
            }
            i += 1;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn raw(list: &IdList) -> Vec<u8> {
        list.ids().iter().map(|m| m.get()).collect()
    }

    #[test]
    fn lists_ranges_and_all() {
        assert_eq!(raw(&parse("3").unwrap()), [3]);
        assert_eq!(raw(&parse("1-4").unwrap()), [1, 2, 3, 4]);
        assert_eq!(raw(&parse(" 7, 1-2,2 ").unwrap()), [1, 2, 7]);
        assert_eq!(parse("all").unwrap().ids().len(), 32);
        assert_eq!(parse("1,3,5-8,2").unwrap().to_string(), "1-3,5-8");
    }

    #[test]
    fn bad_lists_say_what_is_wrong() {
        assert_eq!(
            parse("0").unwrap_err(),
            "invalid motor id 0: must be 1..=32"
        );
        assert_eq!(
            parse("1-33").unwrap_err(),
            "invalid motor id 33: must be 1..=32"
        );
        assert!(parse("4-1").unwrap_err().contains("write 1-4"));
        assert!(parse("x").unwrap_err().contains("not a list of motor ids"));
        assert!(parse("").is_err());
        assert!(parse("1,,2").is_err());
    }
}
