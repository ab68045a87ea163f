//! Starting a loop: the thread's real-time setup, and the probe that waits for every motor to
//! answer once before any torque is commanded.

use core::time::Duration;

use rmd_bus::{CanBus, Clock};

use crate::engine::Parts;
use crate::exchange::frames::ZERO_TORQUE;
use crate::os::{self, RtRequest, RtStatus};
use crate::report::{Fault, StopReason};
use crate::robot::LoopSettings;

/// Stack pre-faulted at start.
const PREFAULT_STACK_BYTES: usize = 512 * 1024;

/// Applies the real-time settings to the calling thread; what was not granted is in the status
/// (and the final report), never printed.
pub(crate) fn prepare_thread(settings: &LoopSettings) -> RtStatus {
    let rt = settings.realtime;
    os::apply_to_current_thread(&RtRequest {
        cpu: rt.cpu,
        fifo_priority: rt.fifo_priority.map(|p| p.get()),
        lock_memory: rt.lock_memory,
        prefault_stack_bytes: PREFAULT_STACK_BYTES,
    })
}

/// The start-up probe: one zero-torque exchange at a time, waiting generously for replies,
/// until every motor has answered (which also measures each motor's round trip).
pub(crate) fn probe<B: CanBus, C: Clock>(parts: &mut Parts<B, C>) -> Result<(), StopReason> {
    let settings = *parts.robot.settings();
    let timeout = (settings.period.get() * 4).max(Duration::from_millis(20));
    let Parts {
        exchange,
        stats,
        clock,
        shared,
        ..
    } = parts;
    exchange.begin_tick();
    for _ in 0..settings.startup_probes.get() {
        if let Some(request) = shared.stop.pending() {
            return Err(request.into());
        }
        let sent_at = clock.now();
        for b in 0..exchange.links.len() {
            if !exchange.bus_complete(b) {
                exchange
                    .send(b, &ZERO_TORQUE, 0, sent_at, stats)
                    .map_err(StopReason::Fault)?;
            }
        }
        let deadline = sent_at + timeout;
        for b in 0..exchange.links.len() {
            exchange
                .collect(b, 0, deadline, u64::MAX, stats)
                .map_err(StopReason::Fault)?;
        }
        if (0..exchange.links.len()).all(|b| exchange.bus_complete(b)) {
            exchange.forget_pending();
            return Ok(());
        }
    }
    let mut silent = exchange
        .motors
        .iter()
        .zip(&exchange.feedback)
        .filter(|(_, f)| !f.is_fresh())
        .map(|(m, _)| m.at);
    let missing = silent.clone().count();
    let first = silent
        .next()
        .map(|at| Fault::StartupTimeout { at, missing });
    Err(StopReason::Fault(
        first.unwrap_or(Fault::DeadlineMisses { consecutive: 0 }),
    ))
}
