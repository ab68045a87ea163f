//! The MCAP file sink: every record, in chunks, closed with a summary and index; on a write
//! error, cut back to its last complete chunk and ended there, readable.

use std::fs::File;
use std::io::{Seek, Write};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

use foxglove::{Context, McapCompression, McapWriteOptions, McapWriterHandle};

use crate::channels::Channels;
use crate::layout::RunLayout;
use crate::output::{SealableOutput, Units};
use crate::record::TickRecord;
use crate::sink::{Sink, SinkError};

/// How the MCAP file is written.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct McapOptions {
    /// Target uncompressed chunk size (bytes): a chunk is ended (compressed and written whole)
    /// at the first record boundary past it. A process that dies loses at most the chunk in
    /// progress (see `flush_interval`); a write error loses at most that too (the file is cut
    /// back to its last complete chunk).
    pub chunk_size: u64,
    /// Compress chunks with zstd (default). Off writes plain chunks.
    pub compress: bool,
    /// End the chunk in progress at least this often (wall time) so that a crash or a full disk
    /// loses at most this much; `None` ends chunks only when they fill up.
    pub flush_interval: Option<Duration>,
}

impl Default for McapOptions {
    fn default() -> Self {
        Self {
            chunk_size: 1024 * 1024,
            compress: true,
            flush_interval: Some(Duration::from_secs(1)),
        }
    }
}

/// Bytes an MCAP message record adds to its payload (opcode, length, channel id, sequence, log
/// and publish time), for the chunk size.
const MESSAGE_OVERHEAD: u64 = 1 + 8 + 2 + 4 + 8 + 8;

/// The end of a file cut back after a write error: a Data End record (data section CRC 0: not
/// computed), a Footer with no summary (summary start, summary offset start and CRC 0), and the
/// closing magic, as the MCAP specification lays them out. A reader then finds the file complete,
/// without index, and reads its chunks in order.
fn ending() -> Vec<u8> {
    let mut tail = Vec::with_capacity(1 + 8 + 4 + 1 + 8 + 20 + mcap::MAGIC.len());
    tail.push(mcap::records::op::DATA_END);
    tail.extend_from_slice(&4u64.to_le_bytes());
    tail.extend_from_slice(&0u32.to_le_bytes());
    tail.push(mcap::records::op::FOOTER);
    tail.extend_from_slice(&20u64.to_le_bytes());
    tail.extend_from_slice(&0u64.to_le_bytes());
    tail.extend_from_slice(&0u64.to_le_bytes());
    tail.extend_from_slice(&0u32.to_le_bytes());
    tail.extend_from_slice(mcap::MAGIC);
    tail
}

/// Writes every record to an MCAP file: `/joint_states` and `/diagnostics` as ROS 2 messages
/// (`ros2msg` schema, CDR), `/motor_states`, `/loop_timing` and `/signals` as JSON with a JSON
/// Schema, the run layout as the metadata record `rmd_rt.run`. See `docs/telemetry.md`.
///
/// Chunks are built in memory and written whole, each followed by its message indexes. When a
/// write fails (a full disk), the file is cut back to the end of its last complete chunk and
/// ended there (Data End, Footer, no summary): every record up to that chunk stays readable,
/// the sink [breaks](Sink::is_broken), and the records it held that were not in that chunk
/// count as failed ([`Sink::lost`]).
///
/// ```no_run
/// use rmd_telemetry::{McapOptions, McapSink, RunLayout, Telemetry};
///
/// let layout = RunLayout::builder(1000.0).bus_count(1).build()?;
/// let (producer, pipeline) = Telemetry::builder()
///     .sink(McapSink::create("run.mcap", &layout, McapOptions::default())?)
///     .start()?;
/// // ... producer.push(&record) once per tick ...
/// println!("{}", pipeline.shutdown());
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub struct McapSink {
    name: String,
    path: PathBuf,
    channels: Channels,
    writer: Option<McapWriterHandle<SealableOutput>>,
    output: SealableOutput,
    // Keeps the channels' context alive as long as the sink.
    _context: Arc<Context>,
    chunk_size: u64,
    flush_interval: Option<Duration>,
    /// Bytes logged into the chunk in progress (payloads and message records).
    chunk_bytes: u64,
    last_flush: Instant,
    /// Records accepted, and those in complete chunks (readable whatever happens next).
    accepted: u64,
    in_chunks: u64,
    /// The file was cut back after a write error.
    broken: bool,
}

impl McapSink {
    /// Creates (or truncates) the file at `path` and writes its header, channels and the layout's
    /// metadata.
    ///
    /// # Errors
    /// [`SinkError::Io`] if the file cannot be created; [`SinkError::Foxglove`] if the writer or
    /// a channel cannot be set up.
    pub fn create(
        path: impl AsRef<Path>,
        layout: &RunLayout,
        options: McapOptions,
    ) -> Result<Self, SinkError> {
        let path = path.as_ref().to_owned();
        let file = File::create(&path)
            .map_err(|e| SinkError::io(format!("creating {}", path.display()), e))?;
        Self::with_output(
            SealableOutput::file(file, Units::Marked),
            path,
            layout,
            options,
        )
    }

    /// Writes the MCAP stream to `writer` (a buffer, a pipe with seeking, a custom file) instead
    /// of a file; `label` names it in reports and errors. After a write error the stream is
    /// ended at its last complete chunk by seeking back and writing the end there; what lay
    /// beyond stays in a writer that cannot be shortened.
    ///
    /// # Errors
    /// As [`McapSink::create`], for the header and metadata written now.
    pub fn to_writer(
        writer: impl Write + Seek + Send + 'static,
        label: impl Into<PathBuf>,
        layout: &RunLayout,
        options: McapOptions,
    ) -> Result<Self, SinkError> {
        Self::with_output(
            SealableOutput::writer(Box::new(writer), Units::Marked),
            label.into(),
            layout,
            options,
        )
    }

    fn with_output(
        output: SealableOutput,
        path: PathBuf,
        layout: &RunLayout,
        options: McapOptions,
    ) -> Result<Self, SinkError> {
        let write_options = McapWriteOptions::new()
            // Chunks end only where this sink ends them (`flush`), between records: the chunks
            // written hold exactly the records accepted before.
            .chunk_size(None)
            // Each chunk is built in memory and written whole (no placeholder length patched
            // later), so the file holds complete records only.
            .disable_seeking(true)
            .compression(options.compress.then_some(McapCompression::Zstd))
            // Compress on the sink's own thread: no extra threads beside the real-time loop.
            .compression_threads(0);
        let context = Context::new();
        let writer = context
            .mcap_writer_with_options(write_options)
            .create(output.clone())
            .map_err(|e| SinkError::foxglove(format!("starting {}", path.display()), e))?;
        let channels = Channels::new(&context, Arc::new(layout.clone()))?;
        writer
            .write_metadata("rmd_rt.run", channels.metadata())
            .map_err(|e| SinkError::foxglove(format!("writing {}", path.display()), e))?;
        // The header and metadata are out: the first complete part.
        output.mark_here();
        Ok(Self {
            name: format!("mcap {}", path.display()),
            path,
            channels,
            writer: Some(writer),
            output,
            _context: context,
            chunk_size: options.chunk_size.max(1),
            flush_interval: options.flush_interval,
            chunk_bytes: 0,
            last_flush: Instant::now(),
            accepted: 0,
            in_chunks: 0,
            broken: false,
        })
    }

    /// The file's path (or the label given to [`McapSink::to_writer`]).
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Ends the chunk in progress and writes it; on success everything accepted so far is in
    /// the file.
    fn end_chunk(&mut self) -> Result<(), SinkError> {
        self.last_flush = Instant::now();
        let Some(writer) = &self.writer else {
            return Ok(());
        };
        let flushed = writer.flush();
        self.check(flushed.map_err(|e| SinkError::foxglove(self.context("writing"), e)))?;
        self.output.mark_here();
        self.in_chunks = self.accepted;
        self.chunk_bytes = 0;
        Ok(())
    }

    fn context(&self, doing: &str) -> String {
        format!("{doing} {}", self.path.display())
    }

    /// `result`, or the first I/O error the output saw (the SDK only logs some): either way the
    /// file is then cut back to its last complete chunk and ended there.
    fn check(&mut self, result: Result<(), SinkError>) -> Result<(), SinkError> {
        let (errors, first) = self.output.errors();
        let failure = match result {
            Err(error) => error,
            Ok(()) if errors > 0 => SinkError::io(
                self.context("writing"),
                std::io::Error::other(first.unwrap_or_default()),
            ),
            Ok(()) => return Ok(()),
        };
        self.break_off();
        Err(failure)
    }

    /// Cuts the file back to its last complete chunk and ends it; the sink takes no more.
    fn break_off(&mut self) {
        self.broken = true;
        // A failed seal leaves the file ending at the last complete chunk or where the failing
        // write left it; the first error is the one reported either way.
        let _ = self.output.seal(&ending());
        if let Some(writer) = self.writer.take() {
            // The output refuses every write now: closing only releases the writer.
            let _ = writer.close();
        }
        self.channels.close();
    }
}

impl Sink for McapSink {
    fn name(&self) -> &str {
        &self.name
    }

    fn write(&mut self, record: &TickRecord) -> Result<(), SinkError> {
        let bytes = self.channels.observe(record)? + self.channels.publish(record)?;
        // About four messages a record (the diagnostics once a second).
        self.chunk_bytes += bytes as u64 + 4 * MESSAGE_OVERHEAD;
        // Counted in the chunk it ends; if that write fails, this record fails with it (the
        // error says so) and is not among the lost ones.
        self.accepted += 1;
        let due = self
            .flush_interval
            .is_some_and(|every| self.last_flush.elapsed() >= every);
        let ended = if due || self.chunk_bytes >= self.chunk_size {
            self.end_chunk()
        } else {
            self.check(Ok(()))
        };
        if ended.is_err() {
            self.accepted -= 1;
        }
        ended
    }

    fn close(&mut self) -> Result<(), SinkError> {
        if self.broken {
            return Ok(());
        }
        let health = self.channels.flush_health();
        self.channels.close();
        let closed = match self.writer.take() {
            Some(writer) => writer
                .close()
                .map(drop)
                .map_err(|e| SinkError::foxglove(self.context("closing"), e)),
            None => Ok(()),
        };
        self.check(closed)?;
        self.in_chunks = self.accepted;
        health
    }

    fn is_broken(&self) -> bool {
        self.broken
    }

    fn lost(&self) -> u64 {
        if self.broken {
            self.accepted - self.in_chunks
        } else {
            0
        }
    }
}
