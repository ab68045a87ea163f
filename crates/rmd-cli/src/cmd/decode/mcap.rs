//! `rmd decode --mcap OUT` (and `--mcap` of the commands that move motors): the decoded frames
//! of a candump log as an MCAP file that Foxglove and PlotJuggler open, one channel per motor
//! and direction.
//!
//! Each message is the JSON object `rmd decode` prints for the frame (same fields, same
//! names: `iq_amps`, `speed_dps`, `temperature_celsius`, `voltage_volts`, ...), on the topic
//!
//! - `/<interface>/motor<ID>/replies` and `/<interface>/motor<ID>/requests` (`/motor<ID>/...`
//!   for lines without an interface, candump's compact form);
//! - `/<interface>/multi_torque` for the 0x280 multi-motor torque frames;
//!
//! with `json` message encoding and a JSON Schema, its log time the line's timestamp (`-L` and
//! `-t a` logs: Unix time; lines without one: 1 ms after the line before, from 0). The file is
//! written by the Foxglove SDK (zstd chunks, summary and index), with a metadata record
//! `rmd_rt.decode` naming the source, the protocol and the encoder width.

use std::collections::{BTreeMap, HashMap};
use std::fs::File;
use std::io::{self, BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, PoisonError};

use foxglove::{
    Context, McapCompression, McapWriteOptions, McapWriterHandle, PartialMetadata, RawChannel,
    Schema,
};
use rmd_bus::candump::CandumpLine;
use serde_json::{Value, json};

/// Lines without a timestamp are logged this long after the line before.
const UNTIMED_STEP_NS: u64 = 1_000_000;

/// The file, remembering its first I/O error (the SDK logs write errors and carries on).
struct Output {
    file: BufWriter<File>,
    error: Arc<Mutex<Option<String>>>,
}

impl Output {
    fn note<T>(&self, result: io::Result<T>) -> io::Result<T> {
        if let Err(e) = &result {
            self.error
                .lock()
                .unwrap_or_else(PoisonError::into_inner)
                .get_or_insert_with(|| e.to_string());
        }
        result
    }
}

impl Write for Output {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let result = self.file.write(buf);
        self.note(result)
    }
    fn flush(&mut self) -> io::Result<()> {
        let result = self.file.flush();
        self.note(result)
    }
}

impl Seek for Output {
    fn seek(&mut self, pos: SeekFrom) -> io::Result<u64> {
        let result = self.file.seek(pos);
        self.note(result)
    }
}

/// What an MCAP file got.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct McapSummary {
    /// The file.
    pub(crate) path: PathBuf,
    /// Messages written.
    pub(crate) messages: u64,
    /// Channels (topics) created.
    pub(crate) channels: usize,
}

impl std::fmt::Display for McapSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "mcap {}: {} decoded frames on {} channel(s)",
            self.path.display(),
            self.messages,
            self.channels
        )
    }
}

/// Decoded frames into an MCAP file.
pub(crate) struct McapFrames {
    path: PathBuf,
    context: Arc<Context>,
    writer: Option<McapWriterHandle<Output>>,
    error: Arc<Mutex<Option<String>>>,
    channels: HashMap<String, Arc<RawChannel>>,
    schema: Vec<u8>,
    messages: u64,
    last_ns: Option<u64>,
    buffer: Vec<u8>,
}

/// The topic of a decoded frame.
fn topic(line: &CandumpLine, value: &Value) -> String {
    let prefix = line
        .interface
        .as_deref()
        .map_or_else(String::new, |i| format!("/{i}"));
    match value.get("id").and_then(Value::as_u64) {
        Some(id) => {
            let side = if value.get("direction").and_then(Value::as_str) == Some("reply") {
                "replies"
            } else {
                "requests"
            };
            format!("{prefix}/motor{id}/{side}")
        }
        None => format!("{prefix}/multi_torque"),
    }
}

/// The JSON Schema of every channel: the decoder's object (its common members described, the
/// command's own fields allowed).
fn schema() -> Value {
    json!({
        "title": "rmd_rt.DecodedFrame",
        "description": "One CAN frame as `rmd decode` prints it: each field's raw value under its spec name and its physical value under <field>_<unit> (docs/cli.md)",
        "type": "object",
        "properties": {
            "timestamp": {"type": "number", "description": "the line's timestamp, seconds"},
            "interface": {"type": "string"},
            "id": {"type": "integer", "description": "motor id (absent for 0x280)"},
            "can_id": {"type": "string"},
            "direction": {"type": "string", "enum": ["request", "reply"]},
            "command": {"type": "string"},
            "errors": {"type": "array", "description": "fields out of range, left out"}
        },
        "required": ["can_id", "direction", "command"],
        "additionalProperties": true
    })
}

impl McapFrames {
    /// Creates (or truncates) `path`; `source` and the other metadata go into the file's
    /// `rmd_rt.decode` record.
    pub(crate) fn create(path: &Path, metadata: &[(&str, String)]) -> Result<Self, String> {
        let fail = |e: &dyn std::fmt::Display| format!("cannot write {}: {e}", path.display());
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|e| fail(&e))?;
        }
        let file = File::create(path).map_err(|e| fail(&e))?;
        let error = Arc::new(Mutex::new(None));
        let output = Output {
            file: BufWriter::new(file),
            error: Arc::clone(&error),
        };
        let context = Context::new();
        let options = McapWriteOptions::new()
            .compression(Some(McapCompression::Zstd))
            .compression_threads(0);
        let writer = context
            .mcap_writer_with_options(options)
            .create(output)
            .map_err(|e| fail(&e))?;
        let metadata: BTreeMap<String, String> = metadata
            .iter()
            .map(|(k, v)| ((*k).to_owned(), v.clone()))
            .collect();
        writer
            .write_metadata("rmd_rt.decode", metadata)
            .map_err(|e| fail(&e))?;
        Ok(Self {
            path: path.to_owned(),
            context,
            writer: Some(writer),
            error,
            channels: HashMap::new(),
            schema: serde_json::to_vec(&schema()).map_err(|e| fail(&e))?,
            messages: 0,
            last_ns: None,
            buffer: Vec::with_capacity(512),
        })
    }

    /// Writes one decoded frame (`value`, the object `rmd decode` prints for `line`).
    pub(crate) fn write(&mut self, line: &CandumpLine, value: &Value) -> Result<(), String> {
        let log_ns = match line.timestamp {
            Some(t) => u64::try_from(t.as_nanos()).unwrap_or(u64::MAX),
            None => self
                .last_ns
                .map_or(0, |t| t.saturating_add(UNTIMED_STEP_NS)),
        };
        self.last_ns = Some(log_ns);
        let topic = topic(line, value);
        let channel = match self.channels.get(&topic) {
            Some(channel) => channel,
            None => {
                let channel = self
                    .context
                    .channel_builder(&topic)
                    .message_encoding("json")
                    .schema(Schema::new(
                        "rmd_rt.DecodedFrame",
                        "jsonschema",
                        self.schema.clone(),
                    ))
                    .build_raw()
                    .map_err(|e| format!("creating channel {topic}: {e}"))?;
                self.channels.entry(topic).or_insert(channel)
            }
        };
        self.buffer.clear();
        serde_json::to_writer(&mut self.buffer, value).map_err(|e| e.to_string())?;
        channel.log_with_meta(&self.buffer, PartialMetadata::with_log_time(log_ns));
        self.messages += 1;
        Ok(())
    }

    /// Closes the file (last chunk, summary, footer) and says what it holds.
    pub(crate) fn finish(mut self) -> Result<McapSummary, String> {
        for channel in self.channels.values() {
            channel.close();
        }
        if let Some(writer) = self.writer.take() {
            let mut output = writer
                .close()
                .map_err(|e| format!("closing {}: {e}", self.path.display()))?;
            output
                .flush()
                .map_err(|e| format!("closing {}: {e}", self.path.display()))?;
        }
        if let Some(error) = self
            .error
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .take()
        {
            return Err(format!("writing {}: {error}", self.path.display()));
        }
        Ok(McapSummary {
            path: self.path.clone(),
            messages: self.messages,
            channels: self.channels.len(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line(interface: Option<&str>) -> CandumpLine {
        rmd_bus::candump::parse_line(match interface {
            Some(_) => "(1.000000) can0 141#9C00000000000000",
            None => "141#9C00000000000000",
        })
        .unwrap()
    }

    #[test]
    fn topics_name_the_interface_the_motor_and_the_direction() {
        let reply = json!({"id": 3, "direction": "reply", "command": "read-status-2"});
        let request = json!({"id": 3, "direction": "request", "command": "read-status-2"});
        let multi = json!({"direction": "request", "command": "multi-torque"});
        assert_eq!(topic(&line(Some("can0")), &reply), "/can0/motor3/replies");
        assert_eq!(topic(&line(None), &request), "/motor3/requests");
        assert_eq!(topic(&line(Some("can0")), &multi), "/can0/multi_torque");
    }
}
