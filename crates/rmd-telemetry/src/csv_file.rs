//! The CSV sink: one row per tick, columns named after the joints and signals; on a write
//! error, cut back to its last complete row.

use std::fmt::Write as _;
use std::fs::File;
use std::path::{Path, PathBuf};

use crate::layout::RunLayout;
use crate::output::{SealableOutput, Units};
use crate::record::TickRecord;
use crate::sink::{Sink, SinkError};

/// The per-joint columns, after the joint's name and a dot.
const JOINT_COLUMNS: [&str; 7] = [
    "position_rad",
    "velocity_rad_s",
    "effort_nm",
    "current_a",
    "commanded_a",
    "temperature_c",
    "fresh",
];

/// The loop timing columns, at the end of a row.
const LOOP_COLUMNS: [&str; 4] = [
    "loop.wake_latency_us",
    "loop.work_us",
    "loop.deadline_missed",
    "loop.misses",
];

/// Writes one CSV row per record:
/// `time_s,tick,<joint>.position_rad,<joint>.velocity_rad_s,<joint>.effort_nm,<joint>.current_a,
/// <joint>.commanded_a,<joint>.temperature_c,<joint>.fresh` for each joint, then one column per
/// user signal (its name), then `loop.wake_latency_us,loop.work_us,loop.deadline_missed,
/// loop.misses`. A value that does not exist (no reply yet, no torque constant, NaN) is an empty
/// cell; `fresh` is 1 or 0.
///
/// When a write fails (a full disk), the file is cut back to its last complete row: every row
/// in it is whole, the sink [breaks](Sink::is_broken), and the rows it had taken that did not
/// reach the file count as failed ([`Sink::lost`]).
///
/// ```no_run
/// use rmd_telemetry::{CsvSink, RunLayout};
///
/// let layout = RunLayout::builder(1000.0).bus_count(1).build()?;
/// let csv = CsvSink::create("run.csv", &layout)?;
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub struct CsvSink {
    name: String,
    path: PathBuf,
    writer: csv::Writer<SealableOutput>,
    output: SealableOutput,
    /// Line breaks of the header row (a name may hold one, quoted).
    header_lines: u64,
    /// Rows accepted.
    accepted: u64,
    /// The file was cut back after a write error.
    broken: bool,
    joints: usize,
    torque: Vec<bool>,
    signals: usize,
    cell: String,
}

impl CsvSink {
    /// Creates (or truncates) the file at `path` and writes the header row.
    ///
    /// # Errors
    /// [`SinkError::Io`] if the file cannot be created, [`SinkError::Csv`] if the header cannot
    /// be written.
    pub fn create(path: impl AsRef<Path>, layout: &RunLayout) -> Result<Self, SinkError> {
        let path = path.as_ref().to_owned();
        let file = File::create(&path)
            .map_err(|e| SinkError::io(format!("creating {}", path.display()), e))?;
        let output = SealableOutput::file(file, Units::Lines);
        // The csv writer buffers (8 KiB) and writes whole buffers: the output marks row ends.
        let mut writer = csv::Writer::from_writer(output.clone());
        let mut header = vec!["time_s".to_owned(), "tick".to_owned()];
        for joint in layout.joints() {
            header.extend(
                JOINT_COLUMNS
                    .iter()
                    .map(|c| format!("{}.{c}", joint.name())),
            );
        }
        header.extend(layout.signals().iter().cloned());
        header.extend(LOOP_COLUMNS.iter().map(|c| (*c).to_owned()));
        writer
            .write_record(&header)
            .map_err(|source| SinkError::Csv {
                context: format!("writing {}", path.display()),
                source,
            })?;
        writer
            .flush()
            .map_err(|e| SinkError::io(format!("writing {}", path.display()), e))?;
        Ok(Self {
            name: format!("csv {}", path.display()),
            path,
            writer,
            header_lines: output.lines(),
            output,
            accepted: 0,
            broken: false,
            joints: layout.joints().len(),
            torque: layout
                .joints()
                .iter()
                .map(|j| j.torque_constant_known())
                .collect(),
            signals: layout.signals().len(),
            cell: String::with_capacity(32),
        })
    }

    /// The file's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    fn field(&mut self, value: Option<f64>) -> Result<(), csv::Error> {
        self.cell.clear();
        if let Some(v) = value.filter(|v| v.is_finite()) {
            let _ = write!(self.cell, "{v}");
        }
        self.writer.write_field(&self.cell)
    }

    fn integer(&mut self, value: u64) -> Result<(), csv::Error> {
        self.cell.clear();
        let _ = write!(self.cell, "{value}");
        self.writer.write_field(&self.cell)
    }

    fn row(&mut self, record: &TickRecord) -> Result<(), csv::Error> {
        self.field(Some(record.time_s()))?;
        self.integer(record.tick)?;
        for i in 0..self.joints {
            let joint = record.joints[i];
            let replied = joint.has_reply();
            let measured = |v: f64| replied.then_some(v);
            self.field(measured(joint.position_rad))?;
            self.field(measured(joint.velocity_rad_s))?;
            let effort = joint.effort_nm.filter(|_| replied && self.torque[i]);
            self.field(effort)?;
            self.field(measured(joint.current_a))?;
            self.field(Some(joint.commanded_a))?;
            self.field(measured(joint.temperature_c))?;
            self.integer(u64::from(joint.is_fresh()))?;
        }
        for i in 0..self.signals {
            self.field(Some(record.signals[i]))?;
        }
        let t = record.timing;
        self.field(Some(t.wake_latency_us))?;
        self.field(Some(t.work_us))?;
        self.integer(u64::from(t.deadline_missed))?;
        self.integer(t.misses)?;
        self.writer.write_record(None::<&[u8]>)
    }
}

impl CsvSink {
    /// `result`, or, after a write error, the file cut back to its last complete row (the sink
    /// takes no more).
    fn check<T>(&mut self, result: Result<T, SinkError>) -> Result<T, SinkError> {
        if result.is_err() || self.output.errors().0 > 0 {
            self.broken = true;
            // A failed cut leaves the file where the failing write left it; the first error is
            // the one reported either way.
            let _ = self.output.seal(b"");
        }
        result
    }
}

impl Sink for CsvSink {
    fn name(&self) -> &str {
        &self.name
    }

    fn write(&mut self, record: &TickRecord) -> Result<(), SinkError> {
        let written = self.row(record).map_err(|source| SinkError::Csv {
            context: format!("writing {}", self.path.display()),
            source,
        });
        self.check(written)?;
        self.accepted += 1;
        Ok(())
    }

    fn idle(&mut self) -> Result<(), SinkError> {
        let flushed = self
            .writer
            .flush()
            .map_err(|e| SinkError::io(format!("flushing {}", self.path.display()), e));
        self.check(flushed)
    }

    fn close(&mut self) -> Result<(), SinkError> {
        if self.broken {
            return Ok(());
        }
        let flushed = self
            .writer
            .flush()
            .map_err(|e| SinkError::io(format!("closing {}", self.path.display()), e));
        self.check(flushed)
    }

    fn is_broken(&self) -> bool {
        self.broken
    }

    fn lost(&self) -> u64 {
        if self.broken {
            let rows = self.output.lines().saturating_sub(self.header_lines);
            self.accepted.saturating_sub(rows)
        } else {
            0
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::layout::JointInfo;
    use crate::record::{JointRecord, ReplyAge};
    use rmd_protocol::MotorId;

    #[test]
    fn writes_a_header_and_one_row_per_record_with_empty_cells_for_missing_values() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("run.csv");
        let layout = RunLayout::builder(1000.0)
            .joint(JointInfo::new("hip", 0, MotorId::new(1).unwrap()).with_torque_constant(true))
            .joint(JointInfo::new("knee", 0, MotorId::new(2).unwrap()))
            .signal("target")
            .build()
            .unwrap();
        let mut sink = CsvSink::create(&path, &layout).unwrap();
        let mut record = TickRecord::new(2, 2_000_000, 0);
        record.joints[0] = JointRecord {
            position_rad: 0.25,
            effort_nm: Some(1.5),
            reply: Some(ReplyAge::fresh(10)),
            ..JointRecord::EMPTY
        };
        record.joints[1].effort_nm = Some(9.0); // never replied: nothing is written
        record.signals[0] = -1.0;
        record.timing.work_us = 12.5;
        sink.write(&record).unwrap();
        sink.close().unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(
            lines[0],
            "time_s,tick,hip.position_rad,hip.velocity_rad_s,hip.effort_nm,hip.current_a,\
             hip.commanded_a,hip.temperature_c,hip.fresh,knee.position_rad,knee.velocity_rad_s,\
             knee.effort_nm,knee.current_a,knee.commanded_a,knee.temperature_c,knee.fresh,target,\
             loop.wake_latency_us,loop.work_us,loop.deadline_missed,loop.misses"
        );
        assert_eq!(
            lines[1],
            "0.002,2,0.25,0,1.5,0,0,0,1,,,,,0,,0,-1,0,12.5,0,0"
        );
        assert_eq!(lines.len(), 2);
    }
}
