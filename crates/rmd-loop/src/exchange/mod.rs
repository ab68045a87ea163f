//! The exchange of one tick: one 0x280 frame out on every bus, the motors' replies in, matched
//! to their requests, and the accounting of what did not come.
//!
//! - [`frames`]: the torque frame, and the one decode-and-match of incoming frames;
//! - [`pending`]: which of a motor's requests a reply answers;
//! - [`motor`]: what the loop keeps per motor, and what a reply does to it;
//! - `send`, `collect`, `account`: the three steps, as methods of [`Exchange`].

mod account;
mod collect;
pub(crate) mod frames;
pub(crate) mod motor;
pub(crate) mod pending;
mod send;

use crate::bus_link::BusLink;
use crate::feedback::JointFeedback;
use crate::robot::{ReplyMode, Robot};

use frames::{TorqueSlots, ZERO_TORQUE};
use motor::MotorLink;

/// The buses, the per-motor link state and feedback, and the staged commands.
#[derive(Debug)]
pub(crate) struct Exchange<B> {
    pub(crate) links: Vec<BusLink<B>>,
    pub(crate) motors: Vec<MotorLink>,
    pub(crate) feedback: Vec<JointFeedback>,
    /// The torque commands each bus sends in the next tick.
    pub(crate) staged: Vec<TorqueSlots>,
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
                bus,
                joints: spec.joint_range(),
                commanded: false,
            })
            .collect::<Vec<_>>();
        Self {
            staged: vec![ZERO_TORQUE; links.len()],
            links,
            motors: robot
                .joints()
                .iter()
                .enumerate()
                .map(|(i, j)| MotorLink::new(i, j, robot.buses()[j.bus].bitrate))
                .collect(),
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
    }

    /// Whether every joint of bus `b` has fresh feedback.
    pub(crate) fn bus_complete(&self, b: usize) -> bool {
        self.feedback[self.links[b].joints()]
            .iter()
            .all(JointFeedback::is_fresh)
    }

    /// Forgets every outstanding request (after the probe, whose replies were waited for).
    /// Pipelined, the probe's replies then stand as the first tick's feedback: in that mode a
    /// tick is answered by the request before it, and the probe's was the one before tick 0.
    pub(crate) fn forget_pending(&mut self) {
        for m in &mut self.motors {
            m.pending.clear();
        }
        self.carry_probe = self.max_age > 0;
    }
}
