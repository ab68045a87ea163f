//! The servo's remote control for ordinary threads: setpoints and trajectories in (checked
//! here, on the caller's thread), enable / disable / estop, the latest state out.

use std::sync::{Arc, Mutex, PoisonError};

use rmd_loop::JointId;
use rmd_loop::mailbox::{Receiver, Sender};

use crate::config::ServoConfig;
use crate::error::ServoError;
use crate::link::{Batch, Life, Message, ServoLink};
use crate::setpoint::{JointRef, Setpoint};
use crate::state::ServoState;
use crate::trajectory::buffer::TrajectoryBuffer;
use crate::trajectory::{JointTrajectory, TrajectoryReceipt, plan};

/// Drives a [`ServoController`](crate::ServoController) from any thread: cheap to clone,
/// `Send + Sync`. Nothing here blocks the loop thread: requests travel through a bounded
/// lock-free queue, the state comes back through another; names are resolved and values checked
/// here, so nothing invalid reaches the loop thread. Every refusal is a typed [`ServoError`],
/// counted.
///
/// ```
/// # use rmd_loop::robot::Robot;
/// # use rmd_servo::{ServoConfig, ServoController, ServoError, Setpoint};
/// # let robot = Robot::from_toml("[[bus]]\ninterface = \"sim\"\n[[bus.motor]]\nid = 1\nname = \"knee\"\ntorque_constant_nm_per_amp = 2.0\n[[bus.motor]]\nid = 2\nname = \"hip\"\ntorque_constant_nm_per_amp = 2.0")?;
/// let config = ServoConfig::from_toml(&robot, "[joint.knee]\nposition_max_rad = 1.5")?;
/// let (servo, handle) = ServoController::new(config);
/// // (run `servo` in an RtLoop; then, from any thread:)
/// handle.set_position("knee", 0.8, 0.0, 0.0)?;
/// handle.set_many([("knee", Setpoint::position(1.0)), ("hip", Setpoint::velocity(0.2))])?;
/// let refused = handle.set_position("knee", 2.0, 0.0, 0.0).unwrap_err();
/// assert!(matches!(refused, ServoError::OutOfLimit { .. }));
/// assert!(matches!(handle.set_effort("elbow", 1.0), Err(ServoError::UnknownJoint { .. })));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Debug)]
pub struct ServoHandle {
    inner: Arc<Inner>,
}

#[derive(Debug)]
struct Inner {
    config: ServoConfig,
    shared: Arc<ServoLink>,
    tx: Sender<Message>,
    capacity: usize,
    free_tx: Sender<Box<TrajectoryBuffer>>,
    free_rx: Receiver<Box<TrajectoryBuffer>>,
    buffers: usize,
    /// The readers' side of the state queue; only readers take this lock, never the loop.
    latest: Mutex<Latest>,
}

#[derive(Debug)]
struct Latest {
    rx: Receiver<ServoState>,
    last: Option<ServoState>,
}

impl ServoHandle {
    pub(crate) fn new(
        config: ServoConfig,
        shared: Arc<ServoLink>,
        tx: Sender<Message>,
        free_tx: Sender<Box<TrajectoryBuffer>>,
        free_rx: Receiver<Box<TrajectoryBuffer>>,
        states: Receiver<ServoState>,
    ) -> Self {
        let options = *config.options();
        Self {
            inner: Arc::new(Inner {
                config,
                shared,
                tx,
                capacity: options.queue_capacity,
                free_tx,
                free_rx,
                buffers: options.trajectory_buffers,
                latest: Mutex::new(Latest {
                    rx: states,
                    last: None,
                }),
            }),
        }
    }

    /// The servo's configuration (joints, gains, limits).
    pub fn config(&self) -> &ServoConfig {
        &self.inner.config
    }

    /// The joints' names, in the robot's joint order.
    pub fn joint_names(&self) -> impl Iterator<Item = &str> {
        self.inner.config.joints().iter().map(|j| j.name.as_str())
    }

    /// The joint named `name`.
    pub fn joint(&self, name: &str) -> Result<JointId, ServoError> {
        self.inner
            .config
            .joints()
            .iter()
            .zip(self.inner.config.ids())
            .find(|(j, _)| j.name == name)
            .map(|(_, &id)| id)
            .ok_or_else(|| ServoError::UnknownJoint {
                name: name.to_string(),
                known: self.joint_names().collect::<Vec<_>>().join(", "),
            })
    }

    fn resolve(&self, joint: JointRef<'_>) -> Result<JointId, ServoError> {
        match joint {
            JointRef::Name(name) => self.joint(name),
            JointRef::Id(id) if id.index() < self.inner.config.joints().len() => Ok(id),
            JointRef::Id(id) => Err(ServoError::UnknownJointId {
                id,
                count: self.inner.config.joints().len(),
            }),
        }
    }

    /// Counts a refusal (per joint when it names one) and hands it back.
    fn refuse<T>(&self, error: ServoError) -> Result<T, ServoError> {
        let joint = error.joint().and_then(|name| self.joint(name).ok());
        self.inner.shared.count_rejection(joint.map(JointId::index));
        Err(error)
    }

    /// The epoch to send in, if the servo takes requests.
    fn accepting(&self) -> Result<u64, ServoError> {
        let shared = &self.inner.shared;
        if shared.estopped() {
            return Err(ServoError::EStopped);
        }
        if shared.life() == Life::Ended {
            return Err(ServoError::Stopped);
        }
        let control = shared.control();
        if !control.enabled {
            return Err(ServoError::Disabled);
        }
        Ok(control.epoch)
    }

    /// Sets one joint's setpoint (applied at the next tick).
    pub fn set<'a>(
        &self,
        joint: impl Into<JointRef<'a>>,
        setpoint: Setpoint,
    ) -> Result<(), ServoError> {
        self.set_many([(joint.into(), setpoint)])
    }

    /// Position `position_rad` with velocity and effort feed-forward.
    pub fn set_position<'a>(
        &self,
        joint: impl Into<JointRef<'a>>,
        position_rad: f64,
        velocity_ff_rad_s: f64,
        effort_ff_nm: f64,
    ) -> Result<(), ServoError> {
        self.set(
            joint,
            Setpoint::Position {
                position_rad,
                velocity_ff_rad_s,
                effort_ff_nm,
            },
        )
    }

    /// Velocity `velocity_rad_s` with effort feed-forward.
    pub fn set_velocity<'a>(
        &self,
        joint: impl Into<JointRef<'a>>,
        velocity_rad_s: f64,
        effort_ff_nm: f64,
    ) -> Result<(), ServoError> {
        self.set(
            joint,
            Setpoint::Velocity {
                velocity_rad_s,
                effort_ff_nm,
            },
        )
    }

    /// Torque `effort_nm`.
    pub fn set_effort<'a>(
        &self,
        joint: impl Into<JointRef<'a>>,
        effort_nm: f64,
    ) -> Result<(), ServoError> {
        self.set(joint, Setpoint::Effort { effort_nm })
    }

    /// Setpoints for several joints, applied in the same tick. All or nothing: if one entry is
    /// refused (unknown joint, a joint twice, a value not finite or beyond the joint's limits)
    /// none is sent. An empty batch sends nothing.
    pub fn set_many<'a, J: Into<JointRef<'a>>>(
        &self,
        setpoints: impl IntoIterator<Item = (J, Setpoint)>,
    ) -> Result<(), ServoError> {
        let epoch = match self.accepting() {
            Ok(epoch) => epoch,
            Err(e) => return self.refuse(e),
        };
        let mut batch = Batch::EMPTY;
        let mut any = false;
        for (joint, setpoint) in setpoints {
            let id = match self.resolve(joint.into()) {
                Ok(id) => id,
                Err(e) => return self.refuse(e),
            };
            let servo = self.inner.config.joint(id);
            let slot = &mut batch.entries[id.index()];
            if slot.is_some() {
                return self.refuse(ServoError::DuplicateJoint {
                    joint: servo.name.clone(),
                });
            }
            if let Err(e) = setpoint.check(servo) {
                return self.refuse(e);
            }
            *slot = Some(setpoint);
            any = true;
        }
        if !any {
            return Ok(());
        }
        match self.inner.tx.send(Message::Setpoints { epoch, batch }) {
            Ok(()) => Ok(()),
            Err(_) => self.refuse(ServoError::QueueFull {
                capacity: self.inner.capacity,
            }),
        }
    }

    /// Checks and plans a trajectory on this thread (from the joints' state the servo last
    /// published), and hands it to the loop thread. Returns when it was planned (not when it
    /// runs), with what the plan found (its duration, points reached late).
    pub fn send_trajectory(
        &self,
        trajectory: &JointTrajectory,
    ) -> Result<TrajectoryReceipt, ServoError> {
        let epoch = match self.accepting() {
            Ok(epoch) => epoch,
            Err(e) => return self.refuse(e),
        };
        let mut joints = Vec::with_capacity(trajectory.joint_names.len());
        for name in &trajectory.joint_names {
            let id = match self.joint(name) {
                Ok(id) => id,
                Err(e) => return self.refuse(e),
            };
            if joints.contains(&id) {
                return self.refuse(ServoError::DuplicateJoint {
                    joint: name.clone(),
                });
            }
            joints.push(id);
        }
        let Some(state) = self.state() else {
            return self.refuse(ServoError::NoState);
        };
        let Some(mut buffer) = self.inner.free_rx.try_recv() else {
            return self.refuse(ServoError::NoTrajectoryBuffer {
                count: self.inner.buffers,
            });
        };
        let receipt = match plan::plan(trajectory, &joints, &self.inner.config, &state, &mut buffer)
        {
            Ok(receipt) => receipt,
            Err(refusal) => {
                self.give_back(buffer);
                return self.refuse(refusal.into());
            }
        };
        buffer.epoch = epoch;
        match self.inner.tx.send(Message::Trajectory(buffer)) {
            Ok(()) => Ok(receipt),
            Err(message) => {
                if let Message::Trajectory(buffer) = message {
                    self.give_back(buffer);
                }
                self.refuse(ServoError::QueueFull {
                    capacity: self.inner.capacity,
                })
            }
        }
    }

    fn give_back(&self, buffer: Box<TrajectoryBuffer>) {
        // The pool's queue holds every buffer: it always has room for this one.
        let _ = self.inner.free_tx.send(buffer);
    }

    /// Enables the servo: every joint holds the position it is at (never a target from before),
    /// and setpoints and trajectories are taken again.
    pub fn enable(&self) {
        self.inner.shared.set_enabled(true);
    }

    /// Disables the servo: every joint goes to zero torque at the next tick (the loop keeps
    /// running), running and waiting trajectories and setpoints still queued are dropped, and
    /// new ones are refused ([`ServoError::Disabled`]) until [`enable`](Self::enable).
    pub fn disable(&self) {
        self.inner.shared.set_enabled(false);
    }

    /// [`enable`](Self::enable) or [`disable`](Self::disable).
    pub fn set_enabled(&self, enabled: bool) {
        self.inner.shared.set_enabled(enabled);
    }

    /// Whether the servo is enabled.
    pub fn is_enabled(&self) -> bool {
        self.inner.shared.control().enabled
    }

    /// Emergency stop: at the next tick the servo commands zero torque and ends the loop with
    /// `Flow::Halt("estop")`, whose safe stop sends zero torque and motor-off to every motor.
    /// Final: everything is refused afterwards ([`ServoError::EStopped`]).
    pub fn estop(&self) {
        self.inner.shared.estop();
    }

    /// Whether [`estop`](Self::estop) was called.
    pub fn is_estopped(&self) -> bool {
        self.inner.shared.estopped()
    }

    /// Whether the servo's loop has ended.
    pub fn has_stopped(&self) -> bool {
        self.inner.shared.life() == Life::Ended
    }

    /// The state of the latest tick (`None` before the first), with each joint's
    /// [`rejected`](crate::JointCounters::rejected) counter filled in. Never blocks the loop
    /// thread (readers share a lock among themselves only).
    pub fn state(&self) -> Option<ServoState> {
        let mut latest = self
            .inner
            .latest
            .lock()
            .unwrap_or_else(PoisonError::into_inner);
        if let Some(newest) = latest.rx.latest() {
            latest.last = Some(newest);
        }
        let mut state = latest.last?;
        drop(latest);
        for (i, joint) in state.joints_mut().iter_mut().enumerate() {
            joint.counters.rejected = self.inner.shared.rejected(i);
        }
        Some(state)
    }

    /// The loop time of the latest tick, s since tick 0 (for
    /// [`TrajectoryStart::AtLoopTime`](crate::TrajectoryStart::AtLoopTime)).
    pub fn loop_time_s(&self) -> Option<f64> {
        self.state().map(|s| s.time_s)
    }

    /// Refusals that named no joint of the robot (unknown names, disabled, queue full, ...).
    pub fn rejected_unattributed(&self) -> u64 {
        self.inner.shared.rejected_unattributed()
    }
}
