//! What a sink is, how it fails, and what it reports at the end.

use thiserror::Error;

use crate::record::TickRecord;

/// A destination for tick records: a file, a server, a test probe. Each sink runs on its own
/// thread (never real-time) behind its own bounded queue, so it may block, allocate and do I/O.
///
/// The sink is built before the pipeline starts (so that opening a file or binding a port fails
/// early, with an error the caller sees) and is told the [`RunLayout`](crate::RunLayout) then.
pub trait Sink: Send + 'static {
    /// A short name for reports, e.g. `"mcap run.mcap"`.
    fn name(&self) -> &str;

    /// Handles one record. An error is counted against this sink; the next records still come.
    ///
    /// # Errors
    /// Whatever went wrong writing this record.
    fn write(&mut self, record: &TickRecord) -> Result<(), SinkError>;

    /// Called when the sink's queue is empty for a moment: a chance to flush. The default does
    /// nothing.
    ///
    /// # Errors
    /// Whatever went wrong flushing.
    fn idle(&mut self) -> Result<(), SinkError> {
        Ok(())
    }

    /// Finishes the output (writes summaries, closes files, stops servers). Called once, after
    /// the last record (also after the sink [broke](Sink::is_broken)).
    ///
    /// # Errors
    /// Whatever went wrong finishing.
    fn close(&mut self) -> Result<(), SinkError>;

    /// Whether the output failed for good (a full disk, a closed device): the sink has ended
    /// what it had properly and takes no more. The pipeline then hands it no more records (each
    /// counts as [failed](SinkStats::failed), without an error of its own) and calls
    /// [`close`](Sink::close) at the end. The default: never.
    fn is_broken(&self) -> bool {
        false
    }

    /// Records this sink accepted ([`write`](Sink::write) returned `Ok`) that its output lost
    /// afterwards: held in a buffer when the output failed, so not readable. The pipeline counts
    /// them as failed, not written. The default: none.
    fn lost(&self) -> u64 {
        0
    }

    /// What else the sink has to say in its report (the live server: clients served and
    /// refused), asked once, after [`close`](Sink::close). The default: nothing.
    fn note(&self) -> Option<String> {
        None
    }
}

/// Why a sink could not open, write or close.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum SinkError {
    /// File or socket I/O failed.
    #[error("{context}: {source}")]
    Io {
        /// What was being done, e.g. `"creating run.mcap"`.
        context: String,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// The Foxglove SDK refused (creating the MCAP writer, a channel, or the server).
    #[error("{context}: {detail}")]
    Foxglove {
        /// What was being done.
        context: String,
        /// The SDK's error with its causes, e.g. `MCAP error: ...: No space left on device`.
        detail: String,
        /// The SDK's error.
        #[source]
        source: foxglove::FoxgloveError,
    },
    /// Encoding a message failed.
    #[error("encoding {what}: {detail}")]
    Encode {
        /// The message, e.g. `"/joint_states"`.
        what: &'static str,
        /// The encoder's message.
        detail: String,
    },
    /// Writing a CSV row failed.
    #[error("{context}: {source}")]
    Csv {
        /// What was being done.
        context: String,
        /// The CSV writer's error.
        #[source]
        source: csv::Error,
    },
    /// A setting is not usable.
    #[error("{0}")]
    Config(String),
    /// A sink of the caller's own failed.
    #[error("{0}")]
    Other(String),
}

impl SinkError {
    pub(crate) fn io(context: impl Into<String>, source: std::io::Error) -> Self {
        Self::Io {
            context: context.into(),
            source,
        }
    }

    pub(crate) fn foxglove(context: impl Into<String>, source: foxglove::FoxgloveError) -> Self {
        let mut detail = source.to_string();
        let mut cause = std::error::Error::source(&source);
        while let Some(error) = cause {
            let text = error.to_string();
            if !detail.contains(&text) {
                detail.push_str(": ");
                detail.push_str(&text);
            }
            cause = error.source();
        }
        Self::Foxglove {
            context: context.into(),
            detail,
            source,
        }
    }
}

/// What happened to one sink's records.
///
/// For every sink, `written + failed + dropped` equals the records the producer pushed while the
/// pipeline was open ([`PipelineStats::offered`](crate::PipelineStats::offered)), once the
/// pipeline has shut down. `written` counts only what the output holds readable: a record a file
/// sink took into a buffer that its failing disk then lost is `failed`.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct SinkStats {
    /// The sink's [`Sink::name`].
    pub name: String,
    /// Records the output holds (readable in a file, sent by a server).
    pub written: u64,
    /// Records the sink failed to write: [`Sink::write`] returned an error, the output had
    /// broken before ([`Sink::is_broken`]), or a failure lost them afterwards ([`Sink::lost`]).
    pub failed: u64,
    /// Records the sink never saw: its queue was full, or the pipeline's intake was.
    pub dropped: u64,
    /// Errors of any kind (writes, flushes, the final close); the records a broken sink is not
    /// handed are failed without an error each.
    pub errors: u64,
    /// The first error's message, if any.
    pub first_error: Option<String>,
    /// The sink's own note ([`Sink::note`]), if any.
    pub note: Option<String>,
}

impl std::fmt::Display for SinkStats {
    /// `mcap run.mcap: 4838 written, 0 failed, 0 dropped, 0 errors`, then the first error and
    /// the note in parentheses, if any.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}: {} written, {} failed, {} dropped, {} errors",
            self.name, self.written, self.failed, self.dropped, self.errors
        )?;
        if let Some(error) = &self.first_error {
            write!(f, " (first: {error})")?;
        }
        if let Some(note) = &self.note {
            write!(f, " ({note})")?;
        }
        Ok(())
    }
}
