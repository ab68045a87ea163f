//! Every tick's telemetry as CSV: time, each joint's state and command (columns named after the
//! joints), the user signals.

use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

use rmd_loop::{Freshness, TelemetrySample};

use crate::error::RigError;

/// A CSV file being written; write errors are remembered, not fatal (the run goes on).
#[derive(Debug)]
pub(crate) struct CsvWriter {
    path: PathBuf,
    out: BufWriter<File>,
    rows: u64,
    error: Option<io::Error>,
}

/// The columns of one joint, after its name.
const JOINT_COLUMNS: [&str; 8] = [
    "angle_deg",
    "velocity_dps",
    "torque_nm",
    "current_a",
    "command_a",
    "temperature_c",
    "fresh",
    "reply_age_ticks",
];

impl CsvWriter {
    /// Creates `path` (and its folder) and writes the header.
    pub(crate) fn create(
        path: &Path,
        joints: &[String],
        signals: &[String],
    ) -> Result<Self, RigError> {
        let fail = |source| RigError::Output {
            path: path.display().to_string(),
            source,
        };
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(fail)?;
        }
        let mut out = BufWriter::new(File::create(path).map_err(fail)?);
        let mut header = String::from("tick,time_s");
        for joint in joints {
            for column in JOINT_COLUMNS {
                header += &format!(",{joint}_{column}");
            }
        }
        for signal in signals {
            header += &format!(",{signal}");
        }
        writeln!(out, "{header}").map_err(fail)?;
        Ok(Self {
            path: path.to_path_buf(),
            out,
            rows: 0,
            error: None,
        })
    }

    /// Writes one row.
    pub(crate) fn write(&mut self, sample: &TelemetrySample) {
        if self.error.is_some() {
            return;
        }
        match write_row(&mut self.out, sample) {
            Ok(()) => self.rows += 1,
            Err(e) => self.error = Some(e),
        }
    }

    /// Flushes; returns the rows written, or the first write error.
    pub(crate) fn finish(mut self) -> (PathBuf, Result<u64, io::Error>) {
        if self.error.is_none()
            && let Err(e) = self.out.flush()
        {
            self.error = Some(e);
        }
        match self.error {
            Some(e) => (self.path, Err(e)),
            None => (self.path, Ok(self.rows)),
        }
    }
}

fn write_row(out: &mut impl Write, s: &TelemetrySample) -> io::Result<()> {
    write!(out, "{},{:.6}", s.tick, s.time_s)?;
    for j in s.joints() {
        let f = &j.feedback;
        let (fresh, age) = match f.freshness {
            Freshness::Fresh { age_ticks } => (1, age_ticks),
            Freshness::Late { age_ticks } => (0, age_ticks),
            Freshness::Missing { ticks_since_reply } => (0, ticks_since_reply),
        };
        write!(
            out,
            ",{:.4},{:.3},",
            f.joint.angle_deg, f.joint.velocity_dps
        )?;
        if let Some(nm) = f.joint.torque_nm {
            write!(out, "{nm:.4}")?;
        }
        write!(
            out,
            ",{:.4},{:.4},{:.0},{fresh},{age}",
            f.motor.current_amps, j.command_amps, f.motor.temperature_celsius
        )?;
    }
    for v in s.signals() {
        write!(out, ",{v:.6}")?;
    }
    writeln!(out)
}
