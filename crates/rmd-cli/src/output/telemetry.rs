//! What each telemetry sink of a run got, as JSON (the `telemetry` member of `rmd bench loop
//! --json` and `rmd drill --json`).

use rmd_rig::telemetry::TelemetryReport;
use serde_json::{Value, json};

/// `[{"name", "written", "dropped", "failed", "errors", "first_error", "note"}, ...]`, one per
/// sink.
pub(crate) fn report_json(report: &TelemetryReport) -> Value {
    Value::Array(
        report
            .sinks()
            .iter()
            .map(|s| {
                json!({
                    "name": s.name,
                    "written": s.written,
                    "dropped": s.dropped,
                    "failed": s.failed,
                    "errors": s.errors,
                    "first_error": s.first_error,
                    "note": s.note,
                })
            })
            .collect(),
    )
}
