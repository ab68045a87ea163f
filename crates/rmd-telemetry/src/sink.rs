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
    /// the last record.
    ///
    /// # Errors
    /// Whatever went wrong finishing.
    fn close(self: Box<Self>) -> Result<(), SinkError>;
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
/// pipeline has shut down.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct SinkStats {
    /// The sink's [`Sink::name`].
    pub name: String,
    /// Records the sink handled without error.
    pub written: u64,
    /// Records the sink failed to write ([`Sink::write`] returned an error).
    pub failed: u64,
    /// Records the sink never saw: its queue was full, or the pipeline's intake was.
    pub dropped: u64,
    /// Errors of any kind (writes, flushes, the final close).
    pub errors: u64,
    /// The first error's message, if any.
    pub first_error: Option<String>,
}
