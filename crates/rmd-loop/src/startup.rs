//! Starting a loop: the thread's real-time setup; the identification of every motor on every bus
//! before any torque (no undescribed motor, no firmware whose 0x280 frame is not per-motor
//! torque, no firmware other than the described one; a V3 motor's version date and model read);
//! and the probe that waits for every motor
//! to answer a zero-torque 0x280 frame once.

use core::time::Duration;

use rmd_bus::{BusMessage, CanBus, Clock};
use rmd_protocol::{
    Command, Dialect, Finding, FirmwareDate, Identification, MULTI_TORQUE_MOTORS, MotorId,
    MotorMaxTorque, ProbeAnswers, ProtocolFamily, Request, V3Firmware, find_model, identify,
    probe_requests,
};

use crate::exchange::motor::MotorMotion;
use crate::exchange::{Collected, Torque};
use crate::loop_parts::LoopParts;
use crate::os::{self, CpuLatencyRequest, RtRequest, RtSetup};
use crate::report::{Fault, IdentifiedMotor, MotorRef, StopReason};
use crate::robot::{ExchangeKind, LoopSettings};
use crate::versions::{self, V3Versions};

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

/// How long the identification waits for a described motor's answers at most (a motor that
/// does not answer then fails the start-up probe, which says so).
fn probe_timeout(settings: &LoopSettings) -> Duration {
    (settings.period.get() * 4).max(Duration::from_millis(250))
}

/// Identifies every motor that answers on ids 1..=4 of every bus (read-only requests 0x9A and
/// 0x9C, answers on `0x140 + id` and `0x240 + id`), before anything else is sent; refuses a
/// described motor whose firmware is not the described dialect's family or whose 0x280 frame
/// would not mean per-motor torque, and a motor that answers but is not described (unless the
/// bus lists it in `zero_torque_ids`). Returns what was found.
pub(crate) fn identify_motors<B: CanBus, C: Clock>(
    parts: &mut LoopParts<B, C>,
) -> Result<Vec<IdentifiedMotor>, StopReason> {
    let timeout = probe_timeout(parts.robot.settings());
    let LoopParts {
        exchange,
        clock,
        robot,
        shared,
        ..
    } = parts;
    let mut found = Vec::new();
    for (b, link) in exchange.links.iter_mut().enumerate() {
        if let Some(request) = shared.stop.pending() {
            return Err(request.into());
        }
        // A 0x280 frame reaches ids 1..=4, described or not; a per-motor bus, and a multi-torque
        // bus beyond id 4, addresses its described motors only.
        let ids: Vec<MotorId> = match link.exchange {
            // And the described motors beyond them, driven by 0xA1 requests of their own.
            ExchangeKind::MultiTorque => {
                let beyond = link
                    .joints()
                    .map(|j| robot.joints()[j].motor)
                    .filter(|id| usize::from(id.get()) > MULTI_TORQUE_MOTORS);
                multi_torque_ids().into_iter().chain(beyond).collect()
            }
            ExchangeKind::PerMotor | ExchangeKind::Motion => {
                link.joints().map(|j| robot.joints()[j].motor).collect()
            }
        };
        let multi_torque = link.exchange == ExchangeKind::MultiTorque;
        let mut answers = vec![ProbeAnswers::new(); ids.len()];
        for &id in &ids {
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
        // Wait until every described motor of the bus has answered both probes (or the
        // timeout), then until the bus has been quiet for a while after the last answer, so an
        // undescribed motor is heard too: at least QUIET, and as long as the slowest answer took
        // (a loaded or emulated host answers in tens of milliseconds), so that no answer comes
        // in after the identification and is mistaken for something else.
        let spec = &robot.buses()[b];
        let described: Vec<usize> = ids
            .iter()
            .enumerate()
            .filter(|(_, id)| spec.joints().any(|j| robot.spec(j).motor == **id))
            .map(|(i, _)| i)
            .collect();
        let sent_at = clock.now();
        let give_up = sent_at + timeout;
        let mut quiet = QUIET;
        let mut last = sent_at;
        loop {
            let all_heard = described
                .iter()
                .all(|&i| answers[i].status1().is_some() && answers[i].status2().is_some());
            let until = if all_heard {
                (last + quiet).min(give_up)
            } else {
                give_up
            };
            let Ok(Some(received)) = link.bus.recv_until(until) else {
                break;
            };
            if let BusMessage::Frame(frame) = received.message {
                let mut taken = false;
                for (id, answer) in ids.iter().zip(&mut answers) {
                    taken |= answer.offer(*id, &frame);
                }
                if taken {
                    quiet = quiet.max(received.at - sent_at);
                }
            }
            last = received.at;
        }
        for (id, answer) in ids.iter().zip(&answers) {
            let identification = identify(*id, answer);
            let joint = spec.joints().find(|&j| robot.spec(j).motor == *id);
            let answered = identification.evidence.finding != Finding::NoAnswer;
            if !answered && joint.is_none() {
                continue;
            }
            check(robot, b, *id, joint, &identification, multi_torque)?;
            // A described V3 motor (checked above) says what it runs: read-only requests.
            let versions = match joint {
                Some(j) if identification.family == ProtocolFamily::MyActuatorV3 => {
                    versions::read_v3(&mut link.bus, &*clock, robot.spec(j).dialect, *id, timeout)
                }
                _ => V3Versions::default(),
            };
            if let Some(j) = joint
                && let Some(motion) = &mut exchange.motors[j.index()].motion
            {
                let at = exchange_motor_ref(robot, j.index());
                *motion = motion_firmware(robot.spec(j), *motion, &versions).ok_or(
                    StopReason::Fault(Fault::MotionRanges {
                        at,
                        firmware_date: versions.firmware_date,
                    }),
                )?;
            }
            found.push(IdentifiedMotor {
                bus: b,
                motor: *id,
                joint: joint.map(|j| robot.spec(j).name.clone()),
                family: identification.family,
                finding: identification.evidence.finding.to_string(),
                firmware_date: versions.firmware_date,
                model: versions.model,
            });
        }
    }
    Ok(found)
}

/// A `motion` bus motor's motion state for the firmware it reported (its version date decides
/// the ranges; V4.4's torque range is the maximum torque of the described model), or `None`
/// when those ranges cannot be known.
fn motion_firmware(
    joint: &crate::robot::JointSpec,
    motion: MotorMotion,
    versions: &V3Versions,
) -> Option<MotorMotion> {
    let max_torque = joint
        .model
        .and_then(|name| find_model(name).ok())
        .and_then(|model| model.max_torque_nm)
        .and_then(|t| MotorMaxTorque::from_nm(t.value).ok());
    let firmware = V3Firmware {
        date: versions.firmware_date.map(FirmwareDate::from_raw),
        max_torque,
    };
    let ranges = firmware.mit_ranges().ok()?;
    Some(motion.with_firmware(Dialect::MyActuatorV3(firmware), ranges))
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

/// Whether the loop may start with motor `id` of bus `b` identified as `identification`, the bus
/// exchanging torque with 0x280 frames when `multi_torque`.
fn check(
    robot: &crate::robot::Robot,
    b: usize,
    id: MotorId,
    joint: Option<crate::joint::JointId>,
    identification: &Identification,
    multi_torque: bool,
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
        // reply ids): never drive it with 0x280 frames. On a per-motor bus it is driven with its
        // own 0xA1 requests if it is described as V3.
        ProtocolFamily::MyActuatorV3 => multi_torque || described != family,
        // Answers that identify no family: what 0x280 means to it is not known. (No answer at
        // all is left to the start-up probe, which names a motor that never answers.)
        ProtocolFamily::Unknown => identification.evidence.finding != Finding::NoAnswer,
        // Identified, and not the described one (the current scales would be wrong).
        known => known != described,
    };
    if refuse {
        return Err(StopReason::Fault(Fault::Firmware {
            at,
            family,
            described,
            finding: identification.evidence.finding,
        }));
    }
    Ok(())
}

/// Releases the holding brake (0x77) of every motor described with one (MyActuator V3) before
/// any torque (a locked brake keeps the output off: "this command cannot open the brake
/// directly", V4.4 §2.18), each confirmed by its echo within the identification's timeout; a
/// motor that does not confirm stops the start. Its bus then counts as commanded: the safe stop
/// locks the brake again.
pub(crate) fn release_brakes<B: CanBus, C: Clock>(
    parts: &mut LoopParts<B, C>,
) -> Result<(), StopReason> {
    let timeout = probe_timeout(parts.robot.settings());
    let LoopParts {
        exchange,
        clock,
        robot,
        shared,
        ..
    } = parts;
    for (b, link) in exchange.links.iter_mut().enumerate() {
        let braked: Vec<usize> = link.joints().filter(|&j| robot.joints()[j].brake).collect();
        if braked.is_empty() {
            continue;
        }
        if let Some(request) = shared.stop.pending() {
            return Err(request.into());
        }
        link.commanded = true;
        for &j in &braked {
            let spec = &robot.joints()[j];
            // Only V3 motors have a brake (checked with the description).
            let Ok(frame) = spec.dialect.encode(spec.motor, &Request::BrakeRelease) else {
                continue;
            };
            match link.bus.send(&frame) {
                Ok(()) | Err(rmd_bus::BusError::TxQueueFull | rmd_bus::BusError::Io(_)) => {}
                Err(rmd_bus::BusError::BusOff) => {
                    return Err(StopReason::Fault(Fault::BusOff { bus: b }));
                }
                Err(error) => return Err(StopReason::Fault(Fault::Bus { bus: b, error })),
            }
        }
        let give_up = clock.now() + timeout;
        let mut released = vec![false; braked.len()];
        while !released.iter().all(|r| *r) {
            let Ok(Some(received)) = link.bus.recv_until(give_up) else {
                break;
            };
            if let BusMessage::Frame(frame) = received.message {
                for (&j, done) in braked.iter().zip(&mut released) {
                    let spec = &robot.joints()[j];
                    *done |= spec
                        .dialect
                        .decode_answer(&frame, spec.motor, Command::BrakeRelease)
                        .is_ok();
                }
            }
        }
        let missing = released.iter().filter(|r| !**r).count();
        if let Some(j) = braked
            .iter()
            .zip(&released)
            .find(|(_, r)| !**r)
            .map(|(j, _)| *j)
        {
            return Err(StopReason::Fault(Fault::StartupTimeout {
                at: exchange_motor_ref(robot, j),
                missing,
            }));
        }
    }
    Ok(())
}

/// Joint `j`'s motor, as faults name it.
fn exchange_motor_ref(robot: &crate::robot::Robot, j: usize) -> MotorRef {
    let spec = &robot.joints()[j];
    MotorRef {
        joint: crate::joint::JointId::from_index(j),
        bus: spec.bus,
        motor: spec.motor,
    }
}

/// The start-up probe: one zero-torque exchange at a time, waiting generously for replies,
/// until every motor has answered (which also measures each motor's round trip).
pub(crate) fn probe<B: CanBus, C: Clock>(parts: &mut LoopParts<B, C>) -> Result<(), StopReason> {
    let settings = *parts.robot.settings();
    let timeout = probe_timeout(&settings);
    let LoopParts {
        exchange,
        stats,
        clock,
        shared,
        ..
    } = parts;
    exchange.begin_tick();
    // The buses the probe asked more than once: a reply may still be owed to any of its
    // requests (0x280 replies carry no sequence number, and the firmware answers each request).
    let mut asked_again = vec![false; exchange.links.len()];
    for round in 0..settings.startup_probes.get() {
        if let Some(request) = shared.stop.pending() {
            return Err(request.into());
        }
        let sent_at = clock.now();
        for (b, again) in asked_again.iter_mut().enumerate() {
            if !exchange.bus_complete(b) {
                *again |= round > 0;
                exchange
                    .send(b, Torque::Zero, 0, sent_at, stats)
                    .map_err(StopReason::Fault)?;
            }
        }
        let deadline = sent_at + timeout;
        let mut collected = Collected::default();
        for b in 0..exchange.links.len() {
            exchange
                .collect(b, 0, deadline, u64::MAX, stats, &mut collected)
                .map_err(StopReason::Fault)?;
        }
        if (0..exchange.links.len()).all(|b| exchange.bus_complete(b)) {
            // Asked again, a bus may still owe replies (a stall longer than the timeout delayed
            // the first, not lost it): wait for them, up to the timeout, so none is taken for
            // the first tick's; and measure the round trips afresh from them, not across the
            // stall.
            for (b, _) in asked_again.iter().enumerate().filter(|(_, again)| **again) {
                exchange.forget_round_trips(b);
                exchange
                    .settle(b, deadline, stats)
                    .map_err(StopReason::Fault)?;
            }
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
