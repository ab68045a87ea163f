//! The verdict of a drill, from the simulated firmware's ground truth.

use rmd_bus::Timestamp;
use rmd_loop::LoopReport;
use rmd_rig::SharedSim;
use serde::Serialize;

/// One simulated motor, by bus and id.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Serialize)]
pub struct SimMotorRef {
    /// Bus index.
    pub bus: usize,
    /// Motor id.
    pub motor: u8,
}

/// What one drill found. The verdict fields come from the simulated firmware, not from the
/// loop's report: a motor counts as safe when its firmware applies and is commanded no torque
/// (off, stopped, tripped by a protection, or at zero torque).
#[derive(Clone, Debug, Serialize)]
pub struct Drill {
    /// The fault(s), as written (`bus-off:50`; several joined by ` + `).
    pub fault: String,
    /// Why the loop ended, in words (the report's).
    pub stop_reason: String,
    /// Simulated motors, on every bus (an undescribed one included).
    pub motors: usize,
    /// Motors whose firmware still applies, or is commanded to apply, non-zero current after
    /// the run ended.
    pub motors_energised_after: usize,
    /// Those motors.
    pub energised: Vec<SimMotorRef>,
    /// From the fault to the instant every motor's firmware was safe, milliseconds (0 when
    /// they were all safe already); `None` when some motor never was.
    pub time_to_safe_ms: Option<f64>,
    /// Motors the loop (or its supervisor) saw confirm motor-off.
    pub confirmed_off: usize,
    /// Motors the loop reported as confirmed off that the firmware says are energised (always
    /// empty unless the loop's belief is wrong).
    pub believed_off_but_energised: Vec<SimMotorRef>,
    /// The loop's report.
    pub report: LoopReport,
}

impl Drill {
    /// Whether every motor ended safe (`rmd drill` exits 0 exactly then).
    pub fn passed(&self) -> bool {
        self.motors_energised_after == 0
    }

    /// The drill as one JSON object (`rmd drill --json`).
    pub fn to_json(&self) -> String {
        serde_json::to_string(self).unwrap_or_else(|e| format!("{{\"error\":\"{e}\"}}"))
    }
}

/// Looks at every simulated motor of `sims` now and judges the run against `fault_at`.
pub(crate) fn judge(
    fault: String,
    fault_at: Timestamp,
    sims: &[SharedSim],
    report: LoopReport,
) -> Drill {
    let mut motors = 0;
    let mut energised = Vec::new();
    let mut safe_from = Some(fault_at);
    for (bus, sim) in sims.iter().enumerate() {
        let mut sim = sim.lock();
        let ids: Vec<_> = sim.motors().iter().map(|m| m.id()).collect();
        for id in ids {
            let Some(snapshot) = sim.snapshot(id) else {
                continue;
            };
            motors += 1;
            match snapshot.safe_since {
                Some(since) if !snapshot.energising => {
                    safe_from = safe_from.map(|t| t.max(since));
                }
                _ => {
                    energised.push(SimMotorRef {
                        bus,
                        motor: id.get(),
                    });
                    safe_from = None;
                }
            }
        }
    }
    let confirmed: Vec<SimMotorRef> = report
        .safe_stop
        .motors
        .iter()
        .filter(|m| m.off_confirmed)
        .map(|m| SimMotorRef {
            bus: m.bus,
            motor: m.motor.get(),
        })
        .collect();
    let believed_off_but_energised = confirmed
        .iter()
        .filter(|m| energised.contains(m))
        .copied()
        .collect();
    Drill {
        fault,
        stop_reason: report.stop_description.clone(),
        motors,
        motors_energised_after: energised.len(),
        energised,
        time_to_safe_ms: safe_from.map(|t| (t - fault_at).as_secs_f64() * 1e3),
        confirmed_off: confirmed.len(),
        believed_off_but_energised,
        report,
    }
}
