//! The keyword arguments of one command (`**fields`), taken one by one and typed; what is left
//! over at the end is an error that lists what the command takes.

use pyo3::prelude::*;
use pyo3::types::PyDict;

/// The fields given to one command.
pub(crate) struct Fields<'py> {
    command: &'static str,
    given: Vec<(String, Bound<'py, PyAny>)>,
    takes: Vec<&'static str>,
}

impl<'py> Fields<'py> {
    /// The fields of `dict` (none without it) for `command`.
    pub(crate) fn new(command: &'static str, dict: Option<&Bound<'py, PyDict>>) -> PyResult<Self> {
        let mut given = Vec::new();
        if let Some(dict) = dict {
            for (key, value) in dict.iter() {
                given.push((key.extract::<String>()?, value));
            }
        }
        Ok(Self {
            command,
            given,
            takes: Vec::new(),
        })
    }

    fn take(&mut self, key: &'static str) -> Option<Bound<'py, PyAny>> {
        self.takes.push(key);
        let at = self.given.iter().position(|(k, _)| k == key)?;
        let (_, value) = self.given.swap_remove(at);
        (!value.is_none()).then_some(value)
    }

    /// An integer field, if given.
    pub(crate) fn int(&mut self, key: &'static str) -> Result<Option<i64>, String> {
        self.take(key)
            .map(|v| {
                v.extract::<i64>()
                    .map_err(|_| format!("{key} must be an integer, not {}", type_name(&v)))
            })
            .transpose()
    }

    /// A number field, if given.
    pub(crate) fn number(&mut self, key: &'static str) -> Result<Option<f64>, String> {
        self.take(key)
            .map(|v| {
                v.extract::<f64>()
                    .map_err(|_| format!("{key} must be a number, not {}", type_name(&v)))
            })
            .transpose()
    }

    /// A text field, if given.
    pub(crate) fn text(&mut self, key: &'static str) -> Result<Option<String>, String> {
        self.take(key)
            .map(|v| {
                v.extract::<String>()
                    .map_err(|_| format!("{key} must be a string, not {}", type_name(&v)))
            })
            .transpose()
    }

    /// Four integers (motors 1..=4), if given.
    pub(crate) fn four_ints(&mut self, key: &'static str) -> Result<Option<[i64; 4]>, String> {
        self.four(key, "integer", |v| v.extract::<Vec<i64>>())
    }

    /// Four numbers (motors 1..=4), if given.
    pub(crate) fn four_numbers(&mut self, key: &'static str) -> Result<Option<[f64; 4]>, String> {
        self.four(key, "number", |v| v.extract::<Vec<f64>>())
    }

    fn four<T: Copy>(
        &mut self,
        key: &'static str,
        what: &str,
        extract: impl Fn(&Bound<'py, PyAny>) -> PyResult<Vec<T>>,
    ) -> Result<Option<[T; 4]>, String> {
        let Some(v) = self.take(key) else {
            return Ok(None);
        };
        let values = extract(&v).map_err(|_| {
            format!(
                "{key} must be 4 {what}s (motors 1..=4), not {}",
                type_name(&v)
            )
        })?;
        <[T; 4]>::try_from(values.as_slice())
            .map(Some)
            .map_err(|_| {
                format!(
                    "{key}: expected 4 values (motors 1..=4), got {}",
                    values.len()
                )
            })
    }

    /// A required integer field.
    pub(crate) fn required_int(&mut self, key: &'static str) -> Result<i64, String> {
        self.int(key)?
            .ok_or_else(|| format!("{} needs {key}", self.command))
    }

    /// An error for `a` and `b` given together, or `Ok` when one at most is.
    pub(crate) fn one_of<A, B>(
        &self,
        a: (&str, &Option<A>),
        b: (&str, &Option<B>),
    ) -> Result<(), String> {
        match (a.1, b.1) {
            (Some(_), Some(_)) => Err(format!(
                "{}: give {} or {}, not both",
                self.command, a.0, b.0
            )),
            (None, None) => Err(format!("{} needs {} or {}", self.command, a.0, b.0)),
            _ => Ok(()),
        }
    }

    /// Ends: an error naming the first field the command does not take.
    pub(crate) fn finish(self) -> Result<(), String> {
        match self.given.first() {
            None => Ok(()),
            Some((key, _)) if self.takes.is_empty() => {
                Err(format!("{} takes no field `{key}` (only id)", self.command))
            }
            Some((key, _)) => Err(format!(
                "{} takes no field `{key}` (its fields: {})",
                self.command,
                self.takes.join(", ")
            )),
        }
    }
}

fn type_name(value: &Bound<'_, PyAny>) -> String {
    value
        .get_type()
        .name()
        .map(|n| n.to_string())
        .unwrap_or_else(|_| "?".to_owned())
}
