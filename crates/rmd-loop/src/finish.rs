//! Ending a run: telling the controller, making every motor safe, and the final report.

use std::panic::{AssertUnwindSafe, catch_unwind};

use rmd_bus::{CanBus, Clock, Timestamp};

use crate::controller::Controller;
use crate::loop_parts::LoopParts;
use crate::os::RtStatus;
use crate::panics;
use crate::protection::MotorProtection;
use crate::report::{IdentifiedMotor, LoopReport, PanicReport, StopReason};
use crate::safe_stop;
use crate::vitals::{LoopPhase, Takeover};

/// The result of a run: the report, and the controller back.
#[derive(Debug)]
pub struct LoopOutcome<K> {
    /// The final report.
    pub report: LoopReport,
    /// The controller, as the loop left it.
    pub controller: K,
}

/// Tells the controller of a fault, makes every motor safe (unless the supervisor took over and
/// did), tells it the loop stopped, and reports. `start` is when tick 0 was due, if the loop got
/// that far.
pub(crate) fn finish<B: CanBus, C: Clock, K: Controller>(
    mut parts: LoopParts<B, C>,
    mut controller: K,
    reason: StopReason,
    realtime: RtStatus,
    start: Option<Timestamp>,
    takeover: Option<Takeover>,
    identified: Vec<IdentifiedMotor>,
) -> LoopOutcome<K> {
    // The supervisor's reason is the run's: the loop thread only noticed it had taken over.
    let reason = takeover.as_ref().map_or(reason, |t| t.reason.clone());
    if let StopReason::Fault(fault) = &reason {
        let _ = catch_unwind(AssertUnwindSafe(|| controller.fault(fault)));
    }
    let safe_stop = match takeover {
        Some(takeover) => takeover.report,
        None => {
            let ids: Vec<_> = parts.exchange.motors.iter().map(|m| m.id).collect();
            let vitals = &parts.shared.vitals;
            safe_stop::make_safe(
                &parts.clock,
                &mut parts.exchange.links,
                &ids,
                &parts.robot,
                parts.robot.safe_stop(),
                || vitals.set_motors_off_sent(),
            )
        }
    };
    let _ = catch_unwind(AssertUnwindSafe(|| controller.stop(&reason)));
    parts.shared.vitals.set_phase(LoopPhase::Finished);
    parts.shared.set_running(false);
    // After the motors are safe: what the panic left (its backtrace is resolved only here).
    let panic = match &reason {
        StopReason::ControllerPanic(message) => {
            let record = panics::take_record();
            Some(PanicReport {
                message: message.clone(),
                location: record.as_ref().and_then(|r| r.location.clone()),
                backtrace: record.and_then(|r| r.backtrace).map(|b| b.to_string()),
            })
        }
        _ => None,
    };
    panics::leave();
    let duration_s = start.map_or(0.0, |t0| (parts.clock.now() - t0).as_secs_f64());
    let robot = &parts.robot;
    let report = LoopReport {
        normal_stop: reason.is_normal(),
        stop_description: reason.describe(robot),
        stop_reason: reason,
        rate_hz: robot.settings().period.hz(),
        buses: robot.buses().len(),
        motors: robot.joint_count(),
        duration_s,
        stats: parts.stats.summary(),
        safe_stop,
        realtime_warnings: realtime.warnings().map(str::to_string).collect(),
        realtime,
        identified,
        protection: MotorProtection::of(robot),
        health_rotation: robot.buses().iter().map(|b| b.health_rotation).collect(),
        health_notes: (0..robot.buses().len())
            .filter_map(|b| robot.health_note(b))
            .collect(),
        panic,
    };
    LoopOutcome { report, controller }
}

/// The message of a panic payload, if it was a string.
pub(crate) fn panic_message(payload: &(dyn std::any::Any + Send)) -> String {
    if let Some(s) = payload.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s.clone()
    } else {
        "(non-string panic payload)".to_string()
    }
}
