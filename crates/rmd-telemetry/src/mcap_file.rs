//! The MCAP file sink: every record, in chunks, closed with a summary and index.

use std::fs::File;
use std::io::{self, BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, Instant};

use foxglove::{Context, McapCompression, McapWriteOptions, McapWriterHandle};

use crate::channels::Channels;
use crate::layout::RunLayout;
use crate::record::TickRecord;
use crate::sink::{Sink, SinkError};

/// How the MCAP file is written.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct McapOptions {
    /// Target uncompressed chunk size (bytes). A chunk is written whole when it fills up; a
    /// process that dies loses at most the chunk in progress (see `flush_interval`).
    pub chunk_size: u64,
    /// Compress chunks with zstd (default). Off writes plain chunks.
    pub compress: bool,
    /// Finish the chunk in progress at least this often (wall time) so that a crash loses at most
    /// this much; `None` finishes chunks only when they fill up.
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

/// The I/O errors the file saw (the SDK logs them and carries on; we count them).
#[derive(Debug, Default)]
struct IoErrors {
    count: u64,
    first: Option<String>,
}

/// Where the MCAP bytes go: a file or a caller's writer.
trait Output: Write + Seek + Send {}
impl<T: Write + Seek + Send> Output for T {}

/// The output behind the MCAP writer, recording every I/O error.
struct RecordingFile {
    inner: Box<dyn Output>,
    errors: Arc<Mutex<IoErrors>>,
}

impl RecordingFile {
    fn note<T>(&self, result: io::Result<T>) -> io::Result<T> {
        if let Err(error) = &result {
            let mut errors = self.errors.lock().unwrap_or_else(PoisonError::into_inner);
            errors.count += 1;
            errors.first.get_or_insert_with(|| error.to_string());
        }
        result
    }
}

impl Write for RecordingFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let result = self.inner.write(buf);
        self.note(result)
    }

    fn flush(&mut self) -> io::Result<()> {
        let result = self.inner.flush();
        self.note(result)
    }
}

impl Seek for RecordingFile {
    fn seek(&mut self, pos: SeekFrom) -> io::Result<u64> {
        let result = self.inner.seek(pos);
        self.note(result)
    }
}

/// Writes every record to an MCAP file: `/joint_states` and `/diagnostics` as ROS 2 messages
/// (`ros2msg` schema, CDR), `/motor_states`, `/loop_timing` and `/signals` as JSON with a JSON
/// Schema, the run layout as the metadata record `rmd_rt.run`. See `docs/telemetry.md`.
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
    writer: Option<McapWriterHandle<RecordingFile>>,
    // Keeps the channels' context alive as long as the sink.
    _context: Arc<Context>,
    errors: Arc<Mutex<IoErrors>>,
    errors_reported: u64,
    flush_interval: Option<Duration>,
    last_flush: Instant,
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
        Self::with_output(Box::new(BufWriter::new(file)), path, layout, options)
    }

    /// Writes the MCAP stream to `writer` (a buffer, a pipe with seeking, a custom file) instead
    /// of a file; `label` names it in reports and errors.
    ///
    /// # Errors
    /// As [`McapSink::create`], for the header and metadata written now.
    pub fn to_writer(
        writer: impl Write + Seek + Send + 'static,
        label: impl Into<PathBuf>,
        layout: &RunLayout,
        options: McapOptions,
    ) -> Result<Self, SinkError> {
        Self::with_output(Box::new(writer), label.into(), layout, options)
    }

    fn with_output(
        output: Box<dyn Output>,
        path: PathBuf,
        layout: &RunLayout,
        options: McapOptions,
    ) -> Result<Self, SinkError> {
        let errors = Arc::new(Mutex::new(IoErrors::default()));
        let file = RecordingFile {
            inner: output,
            errors: Arc::clone(&errors),
        };
        let write_options = McapWriteOptions::new()
            .chunk_size(Some(options.chunk_size.max(1)))
            .compression(options.compress.then_some(McapCompression::Zstd))
            // Compress on the sink's own thread: no extra threads beside the real-time loop.
            .compression_threads(0);
        let context = Context::new();
        let writer = context
            .mcap_writer_with_options(write_options)
            .create(file)
            .map_err(|e| SinkError::foxglove(format!("starting {}", path.display()), e))?;
        let channels = Channels::new(&context, Arc::new(layout.clone()))?;
        writer
            .write_metadata("rmd_rt.run", channels.metadata())
            .map_err(|e| SinkError::foxglove(format!("writing {}", path.display()), e))?;
        Ok(Self {
            name: format!("mcap {}", path.display()),
            path,
            channels,
            writer: Some(writer),
            _context: context,
            errors,
            errors_reported: 0,
            flush_interval: options.flush_interval,
            last_flush: Instant::now(),
        })
    }

    /// The file's path (or the label given to [`McapSink::to_writer`]).
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// An error for I/O failures seen since the last call, if any.
    fn new_io_errors(&mut self) -> Result<(), SinkError> {
        let errors = self.errors.lock().unwrap_or_else(PoisonError::into_inner);
        if errors.count == self.errors_reported {
            return Ok(());
        }
        self.errors_reported = errors.count;
        Err(SinkError::io(
            format!("writing {}", self.path.display()),
            io::Error::other(errors.first.clone().unwrap_or_default()),
        ))
    }

    fn flush(&mut self) -> Result<(), SinkError> {
        self.last_flush = Instant::now();
        if let Some(writer) = &self.writer {
            writer
                .flush()
                .map_err(|e| SinkError::foxglove(format!("flushing {}", self.path.display()), e))?;
        }
        Ok(())
    }
}

impl Sink for McapSink {
    fn name(&self) -> &str {
        &self.name
    }

    fn write(&mut self, record: &TickRecord) -> Result<(), SinkError> {
        self.channels.observe(record)?;
        self.channels.publish(record)?;
        if self
            .flush_interval
            .is_some_and(|every| self.last_flush.elapsed() >= every)
        {
            self.flush()?;
        }
        self.new_io_errors()
    }

    fn close(mut self: Box<Self>) -> Result<(), SinkError> {
        let health = self.channels.flush_health();
        self.channels.close();
        let closed = match self.writer.take() {
            Some(writer) => writer
                .close()
                .map_err(|e| SinkError::foxglove(format!("closing {}", self.path.display()), e))
                .and_then(|mut file| {
                    file.inner
                        .flush()
                        .map_err(|e| SinkError::io(format!("closing {}", self.path.display()), e))
                }),
            None => Ok(()),
        };
        health?;
        closed?;
        self.new_io_errors()
    }
}
