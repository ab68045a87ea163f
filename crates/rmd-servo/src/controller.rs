//! The servo on the loop thread: takes the messages of the tick, follows each joint's mode,
//! commands torque (or, on a motion bus, gives the motor the law's setpoint), publishes its
//! state. Allocates nothing, takes no lock, never waits.

use std::sync::Arc;

use rmd_loop::MAX_SIGNALS;
use rmd_loop::mailbox::{Receiver, Sender, mailbox};
use rmd_loop::robot::JointSpec;
use rmd_loop::{
    CommandKind, Commands, Controller, Feedback, Flow, JointFeedback, JointId, StopReason,
    TickContext,
};

use crate::config::{JointOutput, JointServo, ServoConfig, StalePolicy};
use crate::handle::ServoHandle;
use crate::law::{self, Demand};
use crate::link::{Life, Message, ServoLink};
use crate::motion::motion_step;
use crate::setpoint::Setpoint;
use crate::state::{JointCounters, ServoMode, ServoState};
use crate::status::{self, Done};
use crate::step;
use crate::trajectory::TrajectoryStart;
use crate::trajectory::buffer::TrajectoryBuffer;
use crate::trajectory::plan::within_limits;
use crate::trajectory::segment::{Kin, Segment};

/// How far a joint's state at a trajectory's start may be from the state it was planned from
/// before the first segment is planned again (rad, rad/s, rad/s²).
const START_TOLERANCE: f64 = 1e-9;

/// What the servo does with one joint (the loop thread's form of [`ServoMode`]).
#[derive(Copy, Clone, Debug, PartialEq)]
enum Mode {
    Disabled,
    ZeroTorque,
    Hold {
        position: f64,
    },
    Position {
        position: f64,
        velocity_ff: f64,
        effort_ff: f64,
    },
    Velocity {
        velocity: f64,
        effort_ff: f64,
        reference: f64,
    },
    Effort {
        effort: f64,
    },
    Trajectory {
        slot: usize,
        column: usize,
        point: usize,
        /// Time shift of the segments after the first (its re-planned duration minus the
        /// planned one).
        shift: f64,
    },
}

impl Mode {
    fn public(&self) -> ServoMode {
        match self {
            Mode::Disabled => ServoMode::Disabled,
            Mode::ZeroTorque => ServoMode::ZeroTorque,
            Mode::Hold { .. } => ServoMode::Hold,
            Mode::Position { .. } => ServoMode::Position,
            Mode::Velocity { .. } => ServoMode::Velocity,
            Mode::Effort { .. } => ServoMode::Effort,
            Mode::Trajectory { .. } => ServoMode::Trajectory,
        }
    }

    /// Whether a streamed setpoint is in force (the modes that can go stale).
    fn streamed(&self) -> bool {
        matches!(
            self,
            Mode::Position { .. } | Mode::Velocity { .. } | Mode::Effort { .. }
        )
    }
}

/// One joint on the loop thread.
#[derive(Copy, Clone, Debug)]
struct JointRt {
    /// The joint of the robot.
    id: JointId,
    mode: Mode,
    /// Loop time of the last setpoint (or mode change that restarts the stale clock).
    since_s: f64,
    stale: bool,
    counters: JointCounters,
}

/// A trajectory buffer held by the loop thread: waiting for its start, or followed by `users`
/// joints.
#[derive(Debug)]
struct Slot {
    buffer: Box<TrajectoryBuffer>,
    users: usize,
    active: bool,
}

/// The joint servo controller: run it in an [`RtLoop`](rmd_loop::RtLoop), drive it from any
/// thread through its [`ServoHandle`].
///
/// Per joint it follows a position, velocity or effort setpoint (with feed-forward), a
/// trajectory, or holds a position, with the joint's PD gains and limits from its
/// [`ServoConfig`]; it commands joint torque in N·m, clamped to the joint's `max_effort_nm`
/// (the loop then clamps the current to `current_limit_amps`). See the crate documentation for
/// the semantics of modes, trajectories, the stale-setpoint policy and enable / estop.
#[derive(Debug)]
pub struct ServoController {
    config: ServoConfig,
    shared: Arc<ServoLink>,
    inbox: Receiver<Message>,
    inbox_capacity: usize,
    free: Sender<Box<TrajectoryBuffer>>,
    /// Buffers the free queue would not take (never, by construction; kept rather than freed).
    /// Boxed on purpose: unboxing would free the box on the loop thread.
    #[allow(clippy::vec_box)]
    spare: Vec<Box<TrajectoryBuffer>>,
    slots: Vec<Option<Slot>>,
    joints: Vec<JointRt>,
    state: Box<ServoState>,
    outbox: Sender<ServoState>,
    epoch: u64,
    enabled: bool,
    halt: Option<&'static str>,
    dropped: u64,
    signals: usize,
    /// Loop time of the previous update, s: a velocity reference advances by the loop time
    /// between two updates (more than the period when the loop skipped ticks).
    previous_s: Option<f64>,
}

impl ServoController {
    /// A servo for the robot `config` was built for, and the handle that drives it. Everything
    /// the loop thread will use is allocated here: the queues, the trajectory buffers
    /// (`trajectory_buffers` of `max_trajectory_points` points of every joint), the state.
    pub fn new(config: ServoConfig) -> (ServoController, ServoHandle) {
        let options = *config.options();
        let joints = config.joints().len();
        let shared = Arc::new(ServoLink::new(options.enabled_at_start));
        let (tx, inbox) = mailbox(options.queue_capacity);
        let (free, free_rx) = mailbox(options.trajectory_buffers);
        for _ in 0..options.trajectory_buffers {
            let buffer = Box::new(TrajectoryBuffer::new(options.max_trajectory_points, joints));
            // The queue holds exactly this many.
            let _ = free.send(buffer);
        }
        let (outbox, states) = mailbox(2);
        let joint = |id| JointRt {
            id,
            mode: Mode::Disabled,
            since_s: 0.0,
            stale: false,
            counters: JointCounters::default(),
        };
        let handle = ServoHandle::new(
            config.clone(),
            Arc::clone(&shared),
            tx,
            free.clone(),
            free_rx,
            states,
        );
        let controller = ServoController {
            shared,
            inbox,
            inbox_capacity: options.queue_capacity,
            free,
            spare: Vec::with_capacity(options.trajectory_buffers),
            slots: (0..options.trajectory_buffers).map(|_| None).collect(),
            joints: config.ids().iter().copied().map(joint).collect(),
            state: Box::new(ServoState::new(joints)),
            outbox,
            epoch: 0,
            enabled: options.enabled_at_start,
            halt: None,
            dropped: 0,
            signals: joints.min(MAX_SIGNALS),
            previous_s: None,
            config,
        };
        (controller, handle)
    }

    /// The configuration.
    pub fn config(&self) -> &ServoConfig {
        &self.config
    }

    /// The state published at the last tick (also after the run, from
    /// [`LoopOutcome::controller`](rmd_loop::LoopOutcome)).
    pub fn state(&self) -> &ServoState {
        &self.state
    }

    /// Returns a buffer to the pool (no allocation, no free).
    fn give_back(&mut self, buffer: Box<TrajectoryBuffer>) {
        if let Err(buffer) = self.free.send(buffer) {
            self.spare.push(buffer);
        }
    }

    /// One joint fewer follows the trajectory in `slot`; the last one gives the buffer back.
    fn release(&mut self, slot: usize) {
        let done = match self.slots.get_mut(slot) {
            Some(Some(s)) => {
                s.users = s.users.saturating_sub(1);
                s.users == 0
            }
            _ => false,
        };
        if done && let Some(s) = self.slots[slot].take() {
            self.give_back(s.buffer);
        }
    }

    /// Sets a joint's mode, leaving its trajectory if it followed one.
    fn set_mode(&mut self, joint: usize, mode: Mode) {
        if let Mode::Trajectory { slot, .. } = self.joints[joint].mode {
            self.joints[joint].mode = Mode::Disabled;
            self.release(slot);
        }
        self.joints[joint].mode = mode;
    }

    /// Where the servo wants the joint now (its reference), or where it is for the modes
    /// without one; the state a trajectory starting now starts from.
    fn current(&self, joint: usize, now: f64, fb: &Feedback<'_>) -> Kin {
        let measured = || {
            let f = fb[self.joints[joint].id].joint;
            Kin {
                p: f.angle_rad(),
                v: f.velocity_rad_s(),
                a: 0.0,
            }
        };
        match self.joints[joint].mode {
            Mode::Hold { position } => Kin {
                p: position,
                v: 0.0,
                a: 0.0,
            },
            Mode::Position {
                position,
                velocity_ff,
                ..
            } => Kin {
                p: position,
                v: velocity_ff,
                a: 0.0,
            },
            Mode::Velocity {
                velocity,
                reference,
                ..
            } => Kin {
                p: reference,
                v: velocity,
                a: 0.0,
            },
            Mode::Trajectory {
                slot,
                column,
                point,
                shift,
            } => match &self.slots[slot] {
                Some(s) => step::sample(&s.buffer, column, point, shift, now).0,
                None => measured(),
            },
            Mode::Disabled | Mode::ZeroTorque | Mode::Effort { .. } => measured(),
        }
    }

    /// An enable or disable since the last tick: every joint holds where it is (enabled) or
    /// goes to zero torque (disabled); trajectories are dropped.
    fn sync_control(&mut self, now: f64, fb: &Feedback<'_>) {
        let control = self.shared.control();
        if control.epoch == self.epoch {
            return;
        }
        self.epoch = control.epoch;
        self.enabled = control.enabled;
        for i in 0..self.joints.len() {
            let mode = if self.enabled {
                Mode::Hold {
                    position: fb[self.joints[i].id].joint.angle_rad(),
                }
            } else {
                Mode::Disabled
            };
            self.set_mode(i, mode);
            let j = &mut self.joints[i];
            j.since_s = now;
            j.stale = false;
        }
        for slot in 0..self.slots.len() {
            if let Some(s) = self.slots[slot].take() {
                self.give_back(s.buffer);
            }
        }
    }

    /// The messages waiting for this tick, in order (at most the queue's capacity).
    fn take_messages(&mut self, now: f64, fb: &Feedback<'_>) {
        for _ in 0..self.inbox_capacity {
            let Some(message) = self.inbox.try_recv() else {
                break;
            };
            match message {
                Message::Setpoints { epoch, batch } => {
                    if epoch != self.epoch || !self.enabled {
                        self.dropped += 1;
                        continue;
                    }
                    let n = self.joints.len();
                    for (joint, setpoint) in batch.entries[..n].iter().enumerate() {
                        if let Some(setpoint) = setpoint {
                            self.apply(joint, *setpoint, now, fb);
                        }
                    }
                }
                Message::Trajectory(buffer) => {
                    if buffer.epoch != self.epoch || !self.enabled {
                        self.dropped += 1;
                        self.give_back(buffer);
                        continue;
                    }
                    self.accept(buffer, now, fb);
                }
            }
        }
    }

    fn apply(&mut self, joint: usize, setpoint: Setpoint, now: f64, fb: &Feedback<'_>) {
        let mode = match setpoint {
            Setpoint::Position {
                position_rad,
                velocity_ff_rad_s,
                effort_ff_nm,
            } => Mode::Position {
                position: position_rad,
                velocity_ff: velocity_ff_rad_s,
                effort_ff: effort_ff_nm,
            },
            Setpoint::Velocity {
                velocity_rad_s,
                effort_ff_nm,
            } => Mode::Velocity {
                velocity: velocity_rad_s,
                effort_ff: effort_ff_nm,
                // The moving reference starts where the servo wanted the joint.
                reference: self.current(joint, now, fb).p,
            },
            Setpoint::Effort { effort_nm } => Mode::Effort { effort: effort_nm },
        };
        self.set_mode(joint, mode);
        let j = &mut self.joints[joint];
        j.since_s = now;
        j.stale = false;
        j.counters.setpoints += 1;
    }

    /// A trajectory arrived: it cancels waiting ones that share a joint with it, then starts
    /// now or waits for its start time.
    fn accept(&mut self, buffer: Box<TrajectoryBuffer>, now: f64, fb: &Feedback<'_>) {
        for slot in 0..self.slots.len() {
            let cancel =
                matches!(&self.slots[slot], Some(s) if !s.active && s.buffer.overlaps(&buffer));
            if cancel && let Some(s) = self.slots[slot].take() {
                self.give_back(s.buffer);
            }
        }
        let Some(free) = self.slots.iter().position(Option::is_none) else {
            // Cannot happen (a slot per buffer); refuse rather than fail.
            self.dropped += 1;
            self.give_back(buffer);
            return;
        };
        let due = match buffer.start {
            TrajectoryStart::Now => true,
            TrajectoryStart::AtLoopTime(t) => t <= now,
        };
        self.slots[free] = Some(Slot {
            buffer,
            users: 0,
            active: false,
        });
        if due {
            self.activate(free, now, fb);
        }
    }

    /// Starts the waiting trajectories whose time has come.
    fn start_due(&mut self, now: f64, fb: &Feedback<'_>) {
        for slot in 0..self.slots.len() {
            let due = matches!(&self.slots[slot], Some(s) if !s.active
                && matches!(s.buffer.start, TrajectoryStart::AtLoopTime(t) if t <= now));
            if due {
                self.activate(slot, now, fb);
            }
        }
    }

    /// Its joints switch to the trajectory in `slot`, starting now. A joint whose current state
    /// is not the one the caller planned from gets its first segment planned again from where
    /// it is (one single-axis calculation, no allocation).
    fn activate(&mut self, slot: usize, now: f64, fb: &Feedback<'_>) {
        let columns = match &mut self.slots[slot] {
            Some(s) => {
                s.active = true;
                s.buffer.started_at = now;
                s.buffer.joints().len()
            }
            None => return,
        };
        for column in 0..columns {
            let joint = match &self.slots[slot] {
                Some(s) => s.buffer.joints()[column].index(),
                None => return,
            };
            let here = self.current(joint, now, fb);
            self.set_mode(joint, Mode::Hold { position: here.p });
            let shift = self.first_segment_from(slot, column, joint, here);
            let j = &mut self.joints[joint];
            j.since_s = now;
            j.stale = false;
            match shift {
                Some(shift) => {
                    j.mode = Mode::Trajectory {
                        slot,
                        column,
                        point: 0,
                        shift,
                    };
                    j.counters.trajectories += 1;
                    if let Some(s) = &mut self.slots[slot] {
                        s.users += 1;
                    }
                }
                None => j.counters.trajectory_failures += 1,
            }
        }
        if matches!(&self.slots[slot], Some(s) if s.users == 0) {
            self.release_unused(slot);
        }
    }

    fn release_unused(&mut self, slot: usize) {
        if let Some(s) = self.slots[slot].take() {
            self.give_back(s.buffer);
        }
    }

    /// The time shift of the later segments when the first starts from `here`; `None` when no
    /// motion within the limits reaches the first point from there.
    fn first_segment_from(
        &mut self,
        slot: usize,
        column: usize,
        joint: usize,
        here: Kin,
    ) -> Option<f64> {
        let servo: &JointServo = &self.config.joints()[joint];
        let Some(s) = &mut self.slots[slot] else {
            return None;
        };
        let first = *s.buffer.segment(0, column);
        if here.close_to(&first.from, START_TOLERANCE) {
            return Some(0.0);
        }
        let again = Segment::plan(here, first.to, first.due_s, &servo.limits, 0.0, first.due_s)
            .ok()
            .filter(|segment| within_limits(segment, servo))?;
        *s.buffer.segment_mut(0, column) = again;
        self.joints[joint].counters.replans += 1;
        Some(again.duration_s - first.duration_s)
    }

    /// A streamed setpoint not renewed in time turns into a hold or zero torque.
    fn check_stale(&mut self, joint: usize, now: f64, measured: f64) {
        let rule = self.config.joints()[joint].stale;
        let j = &mut self.joints[joint];
        if rule.policy == StalePolicy::Never
            || !j.mode.streamed()
            || now - j.since_s < rule.after.as_secs_f64()
        {
            return;
        }
        j.mode = match (rule.policy, j.mode) {
            (StalePolicy::ZeroTorque, _) => Mode::ZeroTorque,
            (_, Mode::Position { position, .. }) => Mode::Hold { position },
            (_, Mode::Velocity { reference, .. }) => Mode::Hold {
                position: reference,
            },
            _ => Mode::Hold { position: measured },
        };
        j.stale = true;
        j.counters.stale_events += 1;
    }

    /// This tick's command for joint `id` (measured `f`): its mode's step, turned into torque
    /// or a motion setpoint, sent; its status written.
    fn run_joint(
        &mut self,
        id: JointId,
        f: &JointFeedback,
        now: f64,
        dt: f64,
        cmd: &mut Commands<'_>,
    ) {
        let joint = id.index();
        let (p, v) = (f.joint.angle_rad(), f.joint.velocity_rad_s());
        self.check_stale(joint, now, p);
        let (demand, finished) = self.step(joint, now, dt, p);
        let servo = &self.config.joints()[joint];
        let (effort_nm, clamped) = match self.config.outputs()[joint] {
            JointOutput::Torque => {
                let (effort, clamped) = law::torque(servo, &demand, p, v);
                cmd.set_torque(id, effort);
                (effort, clamped)
            }
            JointOutput::Motion(limits) => {
                let out = motion_step(servo, &limits, &demand, p, v);
                cmd.set_motion(id, out.command);
                (out.effort_nm, out.clamped)
            }
        };
        if let Some(position) = finished {
            // The trajectory is over: hold its last point.
            self.set_mode(joint, Mode::Hold { position });
            self.joints[joint].since_s = now;
        }
        let j = &mut self.joints[joint];
        if clamped {
            j.counters.clamped += 1;
        }
        let error_rad = demand.reference.map(|r| r.p - p);
        if joint < self.signals {
            cmd.set_signal(joint, error_rad.unwrap_or(0.0));
        }
        let done = Done {
            mode: j.mode.public(),
            demand,
            effort_nm,
            error_rad,
            stale: j.stale,
            counters: j.counters,
        };
        status::write(&mut self.state.joints_mut()[joint], f, &done);
    }

    /// The step of `joint`'s mode at `now`, measured at position `p`: what it asks of the law,
    /// and the last point of a trajectory that ended this tick. Advances a velocity reference
    /// and a trajectory's point.
    fn step(&mut self, joint: usize, now: f64, dt: f64, p: f64) -> (Demand, Option<f64>) {
        let servo = &self.config.joints()[joint];
        match self.joints[joint].mode {
            Mode::Disabled | Mode::ZeroTorque => (Demand::NONE, None),
            Mode::Hold { position } => (step::hold(position), None),
            Mode::Position {
                position,
                velocity_ff,
                effort_ff,
            } => (step::position(position, velocity_ff, effort_ff), None),
            Mode::Velocity {
                velocity,
                effort_ff,
                reference,
            } => {
                let (demand, reference) =
                    step::velocity(servo, velocity, effort_ff, reference, dt, p);
                self.joints[joint].mode = Mode::Velocity {
                    velocity,
                    effort_ff,
                    reference,
                };
                (demand, None)
            }
            Mode::Effort { effort } => (step::effort(effort), None),
            Mode::Trajectory {
                slot,
                column,
                point,
                shift,
            } => match &self.slots[slot] {
                Some(s) => {
                    let t = step::trajectory(&s.buffer, column, point, shift, now);
                    if t.finished {
                        return (t.demand, t.demand.reference.map(|k| k.p));
                    }
                    self.joints[joint].mode = Mode::Trajectory {
                        slot,
                        column,
                        point: t.point,
                        shift,
                    };
                    (t.demand, None)
                }
                None => (Demand::NONE, Some(p)),
            },
        }
    }

    fn publish(&mut self, ctx: &TickContext) {
        let s = &mut self.state;
        s.tick = ctx.index;
        s.time_s = ctx.time_s();
        s.enabled = self.enabled;
        s.estopped = self.shared.estopped();
        s.dropped_messages = self.dropped;
        let _ = self.outbox.send_overwrite(**s);
    }

    /// Zero torque everywhere; the joints' measured state still published.
    fn zero(&mut self, ctx: &TickContext, fb: &Feedback<'_>, cmd: &mut Commands<'_>) {
        cmd.zero_all();
        for (status, (_, f)) in self.state.joints_mut().iter_mut().zip(fb.iter()) {
            status::write_zero(status, f);
        }
        self.publish(ctx);
    }
}

impl Controller for ServoController {
    fn signals(&self) -> Vec<String> {
        self.config
            .joints()
            .iter()
            .take(self.signals)
            .map(|j| format!("servo_{}_error_rad", j.name))
            .collect()
    }

    /// [`CommandKind::Motion`] for a joint on an `exchange = "motion"` bus: the motor runs the
    /// PD law with the servo's gains and targets ([`ServoConfig::command_kind`]).
    fn command_kind(&self, joint: &JointSpec) -> CommandKind {
        self.config
            .joints()
            .iter()
            .zip(self.config.ids())
            .find(|(servo, _)| servo.name == joint.name)
            .map_or(CommandKind::Current, |(_, &id)| {
                self.config.command_kind(id)
            })
    }

    fn start(&mut self, ctx: &TickContext, fb: &Feedback<'_>) {
        self.shared.set_life(Life::Running);
        let control = self.shared.control();
        self.epoch = control.epoch;
        self.enabled = control.enabled;
        let now = ctx.time_s();
        let same_robot = fb.len() == self.joints.len()
            && fb.iter().all(|(id, _)| {
                fb.spec(id)
                    .is_some_and(|spec| spec.name == self.config.joint(id).name)
            });
        if !same_robot {
            self.halt = Some("the servo's configuration was built for another robot");
            return;
        }
        for i in 0..self.joints.len() {
            let position = fb[self.joints[i].id].joint.angle_rad();
            if !self.config.joints()[i].limits.allows_position(position) {
                self.halt = Some("a joint is outside its position limits at start");
            }
            let j = &mut self.joints[i];
            j.mode = if self.enabled {
                Mode::Hold { position }
            } else {
                Mode::Disabled
            };
            j.since_s = now;
        }
    }

    fn update(&mut self, ctx: &TickContext, fb: &Feedback<'_>, cmd: &mut Commands<'_>) -> Flow {
        if self.shared.estopped() {
            self.zero(ctx, fb, cmd);
            return Flow::Halt("estop");
        }
        if let Some(why) = self.halt {
            self.zero(ctx, fb, cmd);
            return Flow::Halt(why);
        }
        let now = ctx.time_s();
        self.sync_control(now, fb);
        self.take_messages(now, fb);
        self.start_due(now, fb);
        // The loop time since the previous update: the period, or more after skipped ticks (a
        // velocity setpoint is a speed in loop time, whatever the loop could not run).
        let dt = self
            .previous_s
            .map_or(ctx.dt(), |previous| (now - previous).max(0.0));
        self.previous_s = Some(now);
        for (id, f) in fb.iter() {
            self.run_joint(id, f, now, dt, cmd);
        }
        self.publish(ctx);
        Flow::Continue
    }

    fn stop(&mut self, _reason: &StopReason) {
        self.shared.set_life(Life::Ended);
    }
}
