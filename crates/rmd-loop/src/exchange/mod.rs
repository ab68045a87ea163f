//! The exchange of one tick: every bus's requests out (one 0x280 frame on a `multi-torque` bus,
//! one 0xA1 request per motor on a `per-motor` bus, one motion-mode command per motor on a
//! `motion` bus), the motors' replies in, matched to their
//! requests by reply id and command byte, and the accounting of what did not come.
//!
//! - [`frames`]: the torque frame, and what each motor's reply looks like (decided once);
//! - [`pending`]: which of a motor's requests a reply answers;
//! - [`motor`]: what the loop keeps per motor, and what a reply does to it;
//! - `send`, `collect`, `account`: the three steps, as methods of [`Exchange`];
//! - `motion_reply`: a motion-mode reply, matched and turned into feedback like a torque reply;
//! - `status`: the health rotation (one status request per bus per tick, to each motor in
//!   turn, after the torque requests) and its replies, told from torque replies on the same id
//!   by their command byte and matched to their own requests.
//!
//! Each bus keeps the number of its motors still owing fresh feedback in this tick (`owed`): a
//! bus is complete when it reaches zero, and the collection receives only from buses that owe
//! something and may have something to give.

mod account;
mod collect;
pub(crate) mod frames;
mod motion_reply;
pub(crate) mod motor;
pub(crate) mod pending;
mod send;
mod status;

use crate::bus_link::BusLink;
use crate::feedback::JointFeedback;
use crate::robot::{ReplyMode, Robot};

use frames::{TorqueSlots, ZERO_TORQUE};
use motor::MotorLink;

pub(crate) use collect::Collected;
pub(crate) use send::Torque;

/// The buses, the per-motor link state and feedback, and the staged commands.
#[derive(Debug)]
pub(crate) struct Exchange<B> {
    pub(crate) links: Vec<BusLink<B>>,
    pub(crate) motors: Vec<MotorLink>,
    pub(crate) feedback: Vec<JointFeedback>,
    /// The torque commands each `multi-torque` bus sends in the next tick (a `per-motor` bus
    /// sends each motor's [`MotorLink::staged`], a `motion` bus each motor's staged motion
    /// command).
    pub(crate) staged: Vec<TorqueSlots>,
    /// Per bus: its motors without fresh feedback yet in this tick.
    owed: Vec<usize>,
    /// Their sum over every bus.
    owed_total: usize,
    /// Per bus: which motor a frame comes from, by the low five bits of its CAN id (a reply id
    /// is a multiple of 32 plus the motor id, 1..=32, so they tell a bus's motors apart): the
    /// motor's index + 1, or 0 for none. The frame's id is then checked against the motor's.
    reply_motors: Vec<[u8; 32]>,
    /// How many ticks old a reply may be and still count as this tick's (0, or 1 pipelined).
    pub(crate) max_age: u64,
    /// Pipelined: the first tick's feedback is the start-up probe's replies (the request
    /// before it), not missing.
    carry_probe: bool,
}

impl<B> Exchange<B> {
    /// The exchange of `robot` over `buses` (in description order; the count was checked).
    pub(crate) fn new(robot: &Robot, buses: Vec<B>) -> Self {
        let links = robot
            .buses()
            .iter()
            .zip(buses)
            .map(|(spec, bus)| BusLink {
                health_next: (spec.health_rotation && spec.motor_count() > 0)
                    .then_some(spec.joint_range().start),
                ..BusLink::new(bus, spec)
            })
            .collect::<Vec<_>>();
        let motors: Vec<MotorLink> = robot
            .joints()
            .iter()
            .enumerate()
            .map(|(i, j)| {
                let bus = &robot.buses()[j.bus];
                MotorLink::new(i, j, bus.bitrate, bus.exchange)
            })
            .collect();
        let reply_motors = links
            .iter()
            .map(|link| {
                let mut table = [0u8; 32];
                for m in link.joints() {
                    // At most MAX_JOINTS motors (far below 255): the index fits.
                    table[usize::from(motors[m].expect.can_id) % 32] = (m + 1) as u8;
                }
                table
            })
            .collect();
        Self {
            staged: vec![ZERO_TORQUE; links.len()],
            owed: vec![0; links.len()],
            owed_total: 0,
            reply_motors,
            links,
            motors,
            feedback: vec![JointFeedback::UNSET; robot.joint_count()],
            max_age: match robot.settings().reply_mode {
                ReplyMode::SameTick => 0,
                ReplyMode::Pipelined => 1,
            },
            carry_probe: false,
        }
    }

    /// Starts a tick (or the probe): every joint's feedback is missing until a reply comes
    /// (except, pipelined, in the first tick: its answers are the probe's).
    pub(crate) fn begin_tick(&mut self) {
        if core::mem::take(&mut self.carry_probe) {
            return;
        }
        for (motor, feedback) in self.motors.iter_mut().zip(&mut self.feedback) {
            motor.begin_tick(feedback);
        }
        for (owed, link) in self.owed.iter_mut().zip(&self.links) {
            *owed = link.joints.len();
        }
        self.owed_total = self.motors.len();
    }

    /// The motor of bus `b` whose torque replies come on CAN id `id`, if any.
    #[inline]
    fn reply_motor(&self, b: usize, id: u16) -> Option<usize> {
        let m = self.motor_by_id(b, id)?;
        (self.motors[m].expect.can_id == id).then_some(m)
    }

    /// The motor of bus `b` whose id (the low five bits of a CAN id) `id` carries, if any.
    #[inline]
    fn motor_by_id(&self, b: usize, id: u16) -> Option<usize> {
        let entry = self.reply_motors[b][usize::from(id) % 32];
        usize::from(entry).checked_sub(1)
    }

    /// The motor of bus `b` whose status replies come on `id` where its torque replies do not
    /// (a `motion` bus motor's), if any.
    fn status_only_motor(&self, b: usize, id: u16) -> Option<usize> {
        let m = self.motor_by_id(b, id)?;
        let motor = &self.motors[m];
        (motor.status_reply_id == id && motor.expect.can_id != id).then_some(m)
    }

    /// Whether every joint of bus `b` has fresh feedback.
    pub(crate) fn bus_complete(&self, b: usize) -> bool {
        self.owed[b] == 0
    }

    /// Notes that a motor of bus `b`, without fresh feedback until now in this tick, has it.
    #[inline]
    fn became_fresh(&mut self, b: usize) {
        // Never below zero: each motor is counted once per tick (begin_tick), and only its
        // first fresh reply of the tick gets here.
        self.owed[b] = self.owed[b].saturating_sub(1);
        self.owed_total = self.owed_total.saturating_sub(1);
    }

    /// Whether a motor of bus `b` has a request outstanding.
    pub(crate) fn bus_awaits_replies(&self, b: usize) -> bool {
        self.links[b]
            .joints()
            .any(|m| !self.motors[m].pending.is_empty())
    }

    /// Forgets the round trips measured on bus `b` (after the probe asked again, a reply may
    /// have been matched across the stall that made it ask).
    pub(crate) fn forget_round_trips(&mut self, b: usize) {
        for m in self.links[b].joints() {
            self.motors[m].forget_round_trip();
        }
    }

    /// Forgets every outstanding request (after the probe, whose replies were waited for).
    /// Pipelined, the probe's replies then stand as the first tick's feedback: in that mode a
    /// tick is answered by the request before it, and the probe's was the one before tick 0.
    pub(crate) fn forget_pending(&mut self) {
        for m in &mut self.motors {
            m.pending.clear();
            m.status_pending.clear();
        }
        self.carry_probe = self.max_age > 0;
    }
}
