//! [`ServoPort`]: the [`RobotPort`] of a real robot, over `rmd-servo`'s joint servo running in
//! the real-time loop.
//!
//! The node's thread talks to the servo only through its [`ServoHandle`] (setpoints and
//! trajectories through the servo's bounded lock-free queue, checked again on this thread by
//! the servo; the state of the newest tick through the servo's state queue) and to the loop's
//! statistics through a [`LoopFeed`] the loop's owner fills. Nothing here touches the loop
//! thread: it never waits for this thread, and this thread never waits for it.
//!
//! ```
//! use rmd_loop::{RunLimit, robot::Robot};
//! use rmd_rig::{Placement, Rig, SimTime, sim};
//! use rmd_ros2::RobotPort;
//! use rmd_ros2::servo::{LoopFeed, ServoPort};
//! use rmd_servo::{ServoConfig, ServoController};
//!
//! let robot = Robot::from_toml(
//!     "[[bus]]\ninterface = \"sim\"\n[[bus.motor]]\nid = 1\nname = \"knee\"\n\
//!      torque_constant_nm_per_amp = 2.0",
//! )?;
//! let (servo, handle) = ServoController::new(ServoConfig::defaults(&robot)?);
//! let rig = Rig::open(&robot, &Placement::simulated(&robot, SimTime::Real), sim::sim_configs(&robot, 1))?;
//! let feed = LoopFeed::new();
//! let mut port = ServoPort::new(handle, &robot, rig.clock.clone())?.with_feed(feed.clone());
//! assert_eq!(port.joints()[0].name, "knee");
//! assert_eq!(port.joints()[0].limits.velocity_max_rad_s, Some(2.0));
//! let running = rig.into_loop(robot.clone(), servo)?.spawn(RunLimit::Forever)?;
//! // (start a `Ros2Node` with `port` here; the loop's owner feeds snapshots:)
//! while port.latest_state().is_none() {
//!     std::thread::sleep(std::time::Duration::from_millis(1));
//! }
//! if let Some(stats) = running.snapshot(std::time::Duration::from_millis(100)) {
//!     feed.set_stats(stats);
//! }
//! let outcome = running.stop()?;
//! feed.set_ended(&outcome.report, &robot);
//! assert!(port.diagnostics().stopped.is_some_and(|end| end.normal));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod feed;
mod health;
mod refusal;

use std::time::{Duration, SystemTime};

use rmd_bus::{Clock, Timestamp};
use rmd_loop::{JointId, robot::Robot};
use rmd_servo::{JointTrajectory, JointTrajectoryPoint, ServoHandle, TrajectoryStart};

pub use feed::{LoopEnded, LoopFeed};
use health::Motor;

use crate::port::{
    Enable, JointInfo, JointLimits, PortError, RobotDiagnostics, RobotPort, RobotState, Setpoints,
    Trajectory,
};

/// What `false` on the enable topic does to the servo.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum EstopAction {
    /// Disable the servo: every joint at zero torque at the next tick, the loop keeps running
    /// (motors in torque mode at zero current, feedback and `joint_states` keep coming);
    /// setpoints and trajectories are refused until `true` arrives, which holds every joint
    /// where it is then. The default: an estop you can come back from over ROS.
    #[default]
    Disable,
    /// End the run: the servo's emergency stop (zero torque, then the loop's safe stop sends
    /// motor-off to every motor and confirms it). Final: `true` cannot undo it.
    EndRun,
}

/// The port could not be made.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ServoPortError {
    /// The servo was configured for a robot with other joints.
    #[error(
        "the servo's joints ({servo}) are not the robot's ({robot}): build the servo \
         configuration from the same robot description"
    )]
    OtherRobot {
        /// The servo's joints.
        servo: String,
        /// The robot's joints.
        robot: String,
    },
    /// As many bus labels as buses are needed.
    #[error("{given} bus labels for {buses} buses: give one per bus, in description order")]
    BusLabels {
        /// Labels given.
        given: usize,
        /// Buses of the robot.
        buses: usize,
    },
}

/// The [`RobotPort`] over a [`ServoHandle`] (see the [module](self) documentation).
///
/// - `joints`: the robot's joints in description order, with the servo's limits (position
///   range when configured, `max_velocity_rad_s`, `max_effort_nm`), so that the node rejects
///   what the servo would refuse before it gets here;
/// - `latest_state`: the servo's newest tick (measured position, velocity and effort), once per
///   tick (`None` when no new tick came since the last call), stamped with the time its newest
///   reply was received, mapped from the loop's clock to wall-clock time;
/// - `send_setpoints` / `send_trajectory`: the servo's `set_many` (every joint of a message in
///   the same tick) and `send_trajectory` (planned here, jerk-limited); the servo's refusals
///   come back as [`PortError`]s counted under the kind that says what was wrong;
/// - `set_enable`: enable, or [`EstopAction`];
/// - `diagnostics`: the servo's state (temperature, current, mode, counters, freshness) and the
///   loop's statistics and end from the [`LoopFeed`]. The supply voltage is not measured: the
///   loop's torque reply (0xA1) does not carry it, and asking the motors for it (0x9A) on the
///   loop's bus would put frames between the loop's exchanges; the diagnostics say so.
pub struct ServoPort {
    handle: ServoHandle,
    joints: Vec<JointInfo>,
    motors: Vec<Motor>,
    bus_labels: Vec<String>,
    period: Duration,
    feed: LoopFeed,
    clock: Box<dyn Clock>,
    anchor: (Timestamp, SystemTime),
    last_tick: Option<u64>,
    estop: EstopAction,
    last_trajectory: Option<String>,
}

impl std::fmt::Debug for ServoPort {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ServoPort")
            .field("joints", &self.joints)
            .field("bus_labels", &self.bus_labels)
            .field("period", &self.period)
            .field("estop", &self.estop)
            .finish_non_exhaustive()
    }
}

impl ServoPort {
    /// The port of the servo `handle` drives, on `robot` (the description the servo was
    /// configured from), whose loop runs on `clock` (the rig's clock: replies are stamped on
    /// it).
    pub fn new(
        handle: ServoHandle,
        robot: &Robot,
        clock: impl Clock + 'static,
    ) -> Result<Self, ServoPortError> {
        let names: Vec<&str> = robot.joints().iter().map(|j| j.name.as_str()).collect();
        if !handle.joint_names().eq(names.iter().copied()) {
            return Err(ServoPortError::OtherRobot {
                servo: handle.joint_names().collect::<Vec<_>>().join(", "),
                robot: names.join(", "),
            });
        }
        let joints = handle
            .config()
            .joints()
            .iter()
            .map(|j| {
                let l = &j.limits;
                let finite = |x: f64| x.is_finite().then_some(x);
                JointInfo {
                    name: j.name.clone(),
                    limits: JointLimits {
                        position_min_rad: finite(l.position_min_rad),
                        position_max_rad: finite(l.position_max_rad),
                        velocity_max_rad_s: Some(l.max_velocity_rad_s),
                        effort_max_nm: Some(l.max_effort_nm),
                    },
                }
            })
            .collect();
        let motors = robot
            .joints()
            .iter()
            .map(|j| Motor {
                bus: j.bus,
                id: j.motor.get(),
                can_id: j.motor.can_id(),
                temperature_limit_c: j.temperature_limit_celsius,
            })
            .collect();
        let bus_labels = robot
            .buses()
            .iter()
            .map(|b| format!("{} ({})", b.name, b.interface))
            .collect();
        let anchor = (clock.now(), SystemTime::now());
        Ok(ServoPort {
            handle,
            joints,
            motors,
            bus_labels,
            period: robot.settings().period.get(),
            feed: LoopFeed::new(),
            clock: Box::new(clock),
            anchor,
            last_tick: None,
            estop: EstopAction::default(),
            last_trajectory: None,
        })
    }

    /// The port reading the loop's statistics and end from `feed`.
    pub fn with_feed(mut self, feed: LoopFeed) -> Self {
        self.feed = feed;
        self
    }

    /// The port doing `action` on `false` from the enable topic.
    pub fn with_estop(mut self, action: EstopAction) -> Self {
        self.estop = action;
        self
    }

    /// How each bus is named in the motors' `hardware_id` (one label per bus, in description
    /// order; by default `NAME (INTERFACE)` from the description), e.g. where this run placed
    /// it (`leg (simulated)`).
    pub fn with_bus_labels(
        mut self,
        labels: impl IntoIterator<Item = String>,
    ) -> Result<Self, ServoPortError> {
        let labels: Vec<String> = labels.into_iter().collect();
        if labels.len() != self.bus_labels.len() {
            return Err(ServoPortError::BusLabels {
                given: labels.len(),
                buses: self.bus_labels.len(),
            });
        }
        self.bus_labels = labels;
        Ok(self)
    }

    /// The feed the port reads.
    pub fn feed(&self) -> &LoopFeed {
        &self.feed
    }

    /// The servo's handle.
    pub fn handle(&self) -> &ServoHandle {
        &self.handle
    }

    /// A time on the loop's clock as wall-clock time.
    fn wall_time(&self, at: Timestamp) -> SystemTime {
        let (clock0, wall0) = self.anchor;
        let nanos = at.signed_nanos_since(clock0);
        let offset = Duration::from_nanos(nanos.unsigned_abs());
        if nanos >= 0 {
            wall0 + offset
        } else {
            wall0.checked_sub(offset).unwrap_or(wall0)
        }
    }

    /// A trajectory's start on the loop's time line: `None` (or a stamp already past) starts
    /// at the tick that takes it, a future stamp that much later than the servo's newest tick.
    fn start_of(&self, start: Option<SystemTime>) -> TrajectoryStart {
        let delay = start.and_then(|t| t.duration_since(SystemTime::now()).ok());
        match (delay, self.handle.loop_time_s()) {
            (Some(delay), Some(now_s)) if !delay.is_zero() => {
                TrajectoryStart::AtLoopTime(now_s + delay.as_secs_f64())
            }
            _ => TrajectoryStart::Now,
        }
    }
}

impl RobotPort for ServoPort {
    fn joints(&self) -> &[JointInfo] {
        &self.joints
    }

    fn latest_state(&mut self) -> Option<RobotState> {
        let state = self.handle.state()?;
        if self.last_tick == Some(state.tick) {
            return None;
        }
        self.last_tick = Some(state.tick);
        let joints = state.joints();
        let received = joints
            .iter()
            .map(|j| j.received_at)
            .max()
            .filter(|&t| t != Timestamp::ZERO)
            .unwrap_or_else(|| self.clock.now());
        Some(RobotState {
            stamp: self.wall_time(received),
            position_rad: joints.iter().map(|j| j.position_rad).collect(),
            velocity_rad_s: joints.iter().map(|j| j.velocity_rad_s).collect(),
            effort_nm: joints.iter().map(|j| j.effort_nm).collect(),
        })
    }

    fn diagnostics(&mut self) -> RobotDiagnostics {
        health::diagnostics(&health::Sources {
            handle: &self.handle,
            joints: &self.joints,
            motors: &self.motors,
            bus_labels: &self.bus_labels,
            period: self.period,
            feed: &self.feed,
            last_trajectory: self.last_trajectory.as_deref(),
        })
    }

    fn send_setpoints(&mut self, setpoints: &Setpoints) -> Result<(), PortError> {
        self.handle
            .set_many(
                setpoints
                    .joints()
                    .iter()
                    .map(|&(joint, setpoint)| (JointId::from_index(joint.0), setpoint)),
            )
            .map_err(refusal::port_error)
    }

    fn send_trajectory(&mut self, trajectory: &Trajectory) -> Result<(), PortError> {
        let names = trajectory
            .joints()
            .iter()
            .map(|j| self.joints[j.0].name.clone());
        let mut t = JointTrajectory::new(names).starting(self.start_of(trajectory.start()));
        for p in trajectory.points() {
            let mut point = JointTrajectoryPoint::at(p.time_from_start, p.position_rad.clone());
            point.velocities = p.velocity_rad_s.clone();
            point.accelerations = p.acceleration_rad_s2.clone();
            t = t.point(point);
        }
        let receipt = self
            .handle
            .send_trajectory(&t)
            .map_err(refusal::port_error)?;
        self.last_trajectory = Some(match &receipt.latest {
            Some((joint, point)) => format!(
                "{:.3} s, {:.3} s late at point {point} of {joint} (the limits allow no faster)",
                receipt.duration_s, receipt.max_lateness_s
            ),
            None => format!("{:.3} s, every point on time", receipt.duration_s),
        });
        Ok(())
    }

    fn set_enable(&mut self, enable: Enable) -> Result<(), PortError> {
        if self.handle.is_estopped() {
            return Err(PortError::NotRunning(
                "the servo was emergency-stopped: the run has ended".into(),
            ));
        }
        if self.handle.has_stopped() {
            return Err(PortError::NotRunning("the loop has ended".into()));
        }
        match (enable, self.estop) {
            (Enable::Enabled, _) => self.handle.enable(),
            (Enable::Estop, EstopAction::Disable) => self.handle.disable(),
            (Enable::Estop, EstopAction::EndRun) => self.handle.estop(),
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rmd_bus::VirtualClock;
    use rmd_servo::{ServoConfig, ServoController};

    fn robot() -> Robot {
        Robot::from_toml(
            "[[bus]]\nname = \"leg\"\ninterface = \"can3\"\n[[bus.motor]]\nid = 1\nname = \"hip\"\n\
             torque_constant_nm_per_amp = 2.0\ncurrent_limit_amps = 3.0\n\
             [[bus.motor]]\nid = 2\nname = \"knee\"\ntorque_constant_nm_per_amp = 2.0",
        )
        .unwrap()
    }

    #[test]
    fn joints_carry_the_servos_limits() {
        let robot = robot();
        let config = ServoConfig::from_toml(
            &robot,
            "[joint.hip]\nposition_min_rad = -0.5\nposition_max_rad = 1.5\nmax_velocity_rad_s = 3.0",
        )
        .unwrap();
        let (_servo, handle) = ServoController::new(config);
        let port = ServoPort::new(handle, &robot, VirtualClock::new()).unwrap();
        let hip = &port.joints()[0];
        assert_eq!(hip.name, "hip");
        assert_eq!(hip.limits.position_min_rad, Some(-0.5));
        assert_eq!(hip.limits.position_max_rad, Some(1.5));
        assert_eq!(hip.limits.velocity_max_rad_s, Some(3.0));
        assert!((hip.limits.effort_max_nm.unwrap() - 6.0).abs() < 1e-12);
        let knee = &port.joints()[1];
        assert_eq!(knee.limits.position_min_rad, None);
        assert_eq!(knee.limits.position_max_rad, None);
        assert_eq!(port.bus_labels, ["leg (can3)"]);
    }

    #[test]
    fn joints_carry_the_robot_descriptions_limits() {
        // The description's knee turns 5..165 degrees; the servo configuration says nothing:
        // commands beyond them are refused here, before they reach the servo.
        let robot = Robot::from_toml(
            "[[bus]]\ninterface = \"can3\"\n[[bus.motor]]\nid = 1\nname = \"knee\"\n\
             torque_constant_nm_per_amp = 2.0\nposition_min_deg = 5.0\nposition_max_deg = 165.0",
        )
        .unwrap();
        let (_servo, handle) = ServoController::new(ServoConfig::defaults(&robot).unwrap());
        let port = ServoPort::new(handle, &robot, VirtualClock::new()).unwrap();
        let knee = &port.joints()[0].limits;
        assert_eq!(knee.position_min_rad, Some(5f64.to_radians()));
        assert_eq!(knee.position_max_rad, Some(165f64.to_radians()));
    }

    #[test]
    fn a_servo_of_another_robot_and_wrong_labels_are_refused() {
        let other = Robot::from_toml(
            "[[bus]]\ninterface = \"sim\"\n[[bus.motor]]\nid = 1\nname = \"elbow\"\n\
             torque_constant_nm_per_amp = 2.0",
        )
        .unwrap();
        let (_servo, handle) = ServoController::new(ServoConfig::defaults(&other).unwrap());
        let e = ServoPort::new(handle.clone(), &robot(), VirtualClock::new()).unwrap_err();
        assert!(matches!(e, ServoPortError::OtherRobot { .. }), "{e}");
        let port = ServoPort::new(handle, &other, VirtualClock::new()).unwrap();
        let e = port
            .with_bus_labels(["a".to_string(), "b".to_string()])
            .unwrap_err();
        assert_eq!(e, ServoPortError::BusLabels { given: 2, buses: 1 });
    }

    #[test]
    fn loop_clock_times_map_to_wall_clock_times() {
        let robot = robot();
        let (_servo, handle) = ServoController::new(ServoConfig::defaults(&robot).unwrap());
        let clock = VirtualClock::starting_at(Timestamp::from_nanos(5_000_000_000));
        let port = ServoPort::new(handle, &robot, clock).unwrap();
        let (_, wall0) = port.anchor;
        assert_eq!(
            port.wall_time(Timestamp::from_nanos(5_250_000_000)),
            wall0 + Duration::from_millis(250)
        );
        assert_eq!(
            port.wall_time(Timestamp::from_nanos(4_000_000_000)),
            wall0 - Duration::from_secs(1)
        );
    }
}
