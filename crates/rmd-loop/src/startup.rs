//! Starting a loop: the thread's real-time setup; the identification of every motor on every bus
//! before any torque (no undescribed motor, no firmware whose 0x280 frame is not per-motor
//! torque, no firmware other than the described one); and the probe that waits for every motor
//! to answer a zero-torque 0x280 frame once.

use core::time::Duration;

use rmd_bus::{BusMessage, CanBus, Clock};
use rmd_protocol::identify::{Finding, Identification, ProbeAnswers, identify, probe_requests};
use rmd_protocol::{MULTI_TORQUE_MOTORS, MotorId, ProtocolFamily};

use crate::engine::Parts;
use crate::exchange::frames::ZERO_TORQUE;
use crate::os::{self, CpuLatencyRequest, RtRequest, RtSetup};
use crate::report::{Fault, IdentifiedMotor, MotorRef, StopReason};
use crate::robot::LoopSettings;

/// Stack pre-faulted at start.
const PREFAULT_STACK_BYTES: usize = 512 * 1024;

/// Applies the real-time settings to the calling thread; what was not granted is in the status
/// (and the final report), never printed. The CPU latency request is held until the returned
/// setup's hold is dropped (after the loop's safe stop).
pub(crate) fn prepare_thread(settings: &LoopSettings) -> RtSetup {
    let rt = settings.realtime;
    os::apply_to_current_thread(&RtRequest {
        cpu: rt.cpu,
        fifo_priority: rt.fifo_priority.map(|p| p.get()),
        lock_memory: rt.lock_memory,
        prefault_stack_bytes: PREFAULT_STACK_BYTES,
        cpu_latency: rt.cpu_dma_latency.map(CpuLatencyRequest::new),
    })
}

/// How long the bus must be quiet after the last answer for the identification to stop waiting.
const QUIET: Duration = Duration::from_millis(3);

/// How long the identification waits for answers at most.
fn probe_timeout(settings: &LoopSettings) -> Duration {
    (settings.period.get() * 4).max(Duration::from_millis(20))
}

/// Identifies every motor that answers on ids 1..=4 of every bus (read-only requests 0x9A and
/// 0x9C, answers on `0x140 + id` and `0x240 + id`), before anything else is sent; refuses a
/// described motor whose firmware is not the described dialect's family or whose 0x280 frame
/// would not mean per-motor torque, and a motor that answers but is not described (unless the
/// bus lists it in `zero_torque_ids`). Returns what was found.
pub(crate) fn identify_motors<B: CanBus, C: Clock>(
    parts: &mut Parts<B, C>,
) -> Result<Vec<IdentifiedMotor>, StopReason> {
    let timeout = probe_timeout(parts.robot.settings());
    let Parts {
        exchange,
        clock,
        robot,
        shared,
        ..
    } = parts;
    let ids = multi_torque_ids();
    let mut found = Vec::new();
    for (b, link) in exchange.links.iter_mut().enumerate() {
        if let Some(request) = shared.stop.pending() {
            return Err(request.into());
        }
        let mut answers = [ProbeAnswers::new(); MULTI_TORQUE_MOTORS];
        for id in ids {
            for frame in probe_requests(id) {
                // A refused frame leaves that motor unidentified (the 0x280 probe still waits for
                // it); only bus-off or a lost interface stop the start.
                match link.bus.send(&frame) {
                    Ok(()) | Err(rmd_bus::BusError::TxQueueFull | rmd_bus::BusError::Io(_)) => {}
                    Err(rmd_bus::BusError::BusOff) => {
                        return Err(StopReason::Fault(Fault::BusOff { bus: b }));
                    }
                    Err(error) => return Err(StopReason::Fault(Fault::Bus { bus: b, error })),
                }
            }
        }
        // Answers come within a millisecond or so: wait until the bus has been quiet for a
        // while after the last one (absent motors never answer), at most the timeout.
        let give_up = clock.now() + timeout;
        let mut quiet_until = (clock.now() + QUIET).min(give_up);
        while let Ok(Some(received)) = link.bus.recv_until(quiet_until) {
            if let BusMessage::Frame(frame) = received.message {
                for (id, answer) in ids.iter().zip(&mut answers) {
                    answer.offer(*id, &frame);
                }
            }
            quiet_until = (received.at + QUIET).min(give_up);
        }
        let spec = &robot.buses()[b];
        for (id, answer) in ids.iter().zip(&answers) {
            let identification = identify(*id, answer);
            let joint = spec.joints().find(|&j| robot.spec(j).motor == *id);
            let answered = identification.evidence.finding != Finding::NoAnswer;
            if !answered && joint.is_none() {
                continue;
            }
            check(robot, b, *id, joint, &identification)?;
            found.push(IdentifiedMotor {
                bus: b,
                motor: *id,
                joint: joint.map(|j| robot.spec(j).name.clone()),
                family: identification.family,
                finding: identification.evidence.finding.to_string(),
            });
        }
    }
    Ok(found)
}

/// Motor ids 1..=4, the ones a 0x280 frame addresses.
fn multi_torque_ids() -> [MotorId; MULTI_TORQUE_MOTORS] {
    const fn id(n: u8) -> MotorId {
        match MotorId::new(n) {
            Ok(id) => id,
            Err(_) => panic!("1..=4 are motor ids"),
        }
    }
    [id(1), id(2), id(3), id(4)]
}

/// Whether the loop may start with motor `id` of bus `b` identified as `identification`.
fn check(
    robot: &crate::robot::Robot,
    b: usize,
    id: MotorId,
    joint: Option<crate::joint::JointId>,
    identification: &Identification,
) -> Result<(), StopReason> {
    let family = identification.family;
    let Some(joint) = joint else {
        // Answering, but not described.
        if robot.buses()[b].zero_torque_ids.contains(&id) {
            return Ok(());
        }
        return Err(StopReason::Fault(Fault::UndescribedMotor {
            bus: b,
            motor: id,
            family,
        }));
    };
    let at = MotorRef {
        joint,
        bus: b,
        motor: id,
    };
    let described = robot.spec(joint).dialect.family();
    let refuse = match family {
        // Its 0x280 frame is a command byte for every motor, or nothing is known (answers on both
        // reply ids): never drive it with 0x280 frames.
        ProtocolFamily::MyActuatorV3 => true,
        ProtocolFamily::Unknown => identification.evidence.finding == Finding::AnsweredOnBothIds,
        // Identified, and not the described one (the current scales would be wrong).
        known => known != described,
    };
    if refuse {
        return Err(StopReason::Fault(Fault::Firmware {
            at,
            family,
            described,
        }));
    }
    Ok(())
}

/// The start-up probe: one zero-torque exchange at a time, waiting generously for replies,
/// until every motor has answered (which also measures each motor's round trip).
pub(crate) fn probe<B: CanBus, C: Clock>(parts: &mut Parts<B, C>) -> Result<(), StopReason> {
    let settings = *parts.robot.settings();
    let timeout = probe_timeout(&settings);
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
