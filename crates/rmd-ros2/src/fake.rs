//! A test double of a robot: joints that follow setpoints with a first-order response and
//! trajectories by linear interpolation, stepped at 1 kHz on their own thread.
//!
//! It exists to test the node and to demonstrate it without hardware. It is not a model of an
//! RMD motor (that is `rmd-sim`) and not a driver (that is the real-time loop behind a
//! [`RobotPort`] the lead's crate implements).
//!
//! ```
//! use rmd_ros2::fake::FakeRobot;
//! use rmd_ros2::RobotPort;
//! let mut robot = FakeRobot::start(FakeRobot::demo_joints(), true);
//! let handle = robot.handle();
//! assert_eq!(robot.joints().len(), 3);
//! assert_eq!(handle.positions(), vec![0.0, 0.0, 0.0]);
//! ```

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant, SystemTime};

use crate::port::{
    Enable, JointInfo, JointLimits, LoopTiming, MotorDiagnostics, PortError, RobotDiagnostics,
    RobotPort, RobotState, Setpoint, Setpoints, Trajectory,
};

/// Time constant of the first-order response.
const TAU: f64 = 0.05;
/// Step of the simulation thread.
const STEP: Duration = Duration::from_millis(1);

#[derive(Clone, Copy, Debug)]
enum Target {
    Hold(f64),
    Position(f64),
    Velocity(f64),
    Effort(f64),
}

struct FollowedTrajectory {
    received: Instant,
    from: Vec<f64>,
    trajectory: Trajectory,
}

struct Sim {
    joints: Vec<JointInfo>,
    stamp: SystemTime,
    position: Vec<f64>,
    velocity: Vec<f64>,
    effort: Vec<f64>,
    target: Vec<Target>,
    trajectory: Option<FollowedTrajectory>,
    enabled: bool,
    cycles: u64,
    overruns: u64,
    setpoints: u64,
    trajectories: u64,
}

impl Sim {
    /// The trajectory's position for joint slot `k` at `elapsed`, by linear interpolation
    /// (before the first point: from where the joints were on receipt).
    fn trajectory_position(f: &FollowedTrajectory, k: usize, elapsed: Duration) -> f64 {
        let points = f.trajectory.points();
        let mut t0 = Duration::ZERO;
        let mut p0 = f.from[k];
        for p in points {
            if elapsed <= p.time_from_start {
                let span = (p.time_from_start - t0).as_secs_f64();
                let s = if span > 0.0 {
                    (elapsed - t0).as_secs_f64() / span
                } else {
                    1.0
                };
                return p0 + (p.position_rad[k] - p0) * s;
            }
            t0 = p.time_from_start;
            p0 = p.position_rad[k];
        }
        p0
    }

    fn step(&mut self, dt: f64) {
        if let Some(f) = &self.trajectory {
            let elapsed = f.received.elapsed();
            let done = f
                .trajectory
                .points()
                .last()
                .is_none_or(|p| elapsed >= p.time_from_start);
            for (k, joint) in f.trajectory.joints().iter().enumerate() {
                let p = Self::trajectory_position(f, k, elapsed);
                self.target[joint.0] = Target::Position(p);
            }
            if done {
                self.trajectory = None;
            }
        }
        for i in 0..self.joints.len() {
            let limits = self.joints[i].limits;
            let target = if self.enabled {
                self.target[i]
            } else {
                Target::Hold(self.position[i])
            };
            let (v, e) = match target {
                Target::Hold(p) | Target::Position(p) => {
                    let v = (p - self.position[i]) / TAU;
                    (v, 2.0 * (p - self.position[i]))
                }
                Target::Velocity(v) => (
                    self.velocity[i] + (v - self.velocity[i]) * dt / TAU,
                    0.1 * v,
                ),
                Target::Effort(e) => (self.velocity[i] + (e - self.velocity[i]) * dt / TAU, e),
            };
            let vmax = limits.velocity_max_rad_s.unwrap_or(f64::INFINITY);
            let emax = limits.effort_max_nm.unwrap_or(f64::INFINITY);
            let v = v.clamp(-vmax, vmax);
            let p = (self.position[i] + v * dt).clamp(
                limits.position_min_rad.unwrap_or(f64::NEG_INFINITY),
                limits.position_max_rad.unwrap_or(f64::INFINITY),
            );
            self.velocity[i] = v;
            self.position[i] = p;
            self.effort[i] = e.clamp(-emax, emax);
        }
        self.stamp = SystemTime::now();
        self.cycles += 1;
    }
}

/// The test double; a [`RobotPort`].
pub struct FakeRobot {
    joints: Vec<JointInfo>,
    sim: Arc<Mutex<Sim>>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

/// A view of a [`FakeRobot`] for tests (what the joints do, what reached the port).
#[derive(Clone)]
pub struct FakeRobotHandle {
    sim: Arc<Mutex<Sim>>,
}

fn lock(sim: &Mutex<Sim>) -> MutexGuard<'_, Sim> {
    // The simulation keeps no invariant a panic could break halfway.
    sim.lock().unwrap_or_else(|e| e.into_inner())
}

impl FakeRobot {
    /// Three joints: `hip` and `knee` limited to [-2, 2] rad, 6 rad/s, 4 N·m, and `wrist`
    /// without limits.
    pub fn demo_joints() -> Vec<JointInfo> {
        let limits = JointLimits {
            position_min_rad: Some(-2.0),
            position_max_rad: Some(2.0),
            velocity_max_rad_s: Some(6.0),
            effort_max_nm: Some(4.0),
        };
        vec![
            JointInfo {
                name: "hip".into(),
                limits,
            },
            JointInfo {
                name: "knee".into(),
                limits,
            },
            JointInfo {
                name: "wrist".into(),
                limits: JointLimits::default(),
            },
        ]
    }

    /// Starts the joints at 0 rad, holding, on a 1 kHz thread; `enabled` is the initial
    /// enable state.
    pub fn start(joints: Vec<JointInfo>, enabled: bool) -> Self {
        let n = joints.len();
        let sim = Arc::new(Mutex::new(Sim {
            joints: joints.clone(),
            stamp: SystemTime::now(),
            position: vec![0.0; n],
            velocity: vec![0.0; n],
            effort: vec![0.0; n],
            target: vec![Target::Hold(0.0); n],
            trajectory: None,
            enabled,
            cycles: 0,
            overruns: 0,
            setpoints: 0,
            trajectories: 0,
        }));
        let stop = Arc::new(AtomicBool::new(false));
        let thread = {
            let sim = Arc::clone(&sim);
            let stop = Arc::clone(&stop);
            std::thread::spawn(move || {
                let mut last = Instant::now();
                let mut next = last + STEP;
                while !stop.load(Ordering::Relaxed) {
                    std::thread::sleep(next.saturating_duration_since(Instant::now()));
                    let now = Instant::now();
                    let mut s = lock(&sim);
                    if now > next + STEP {
                        s.overruns += 1;
                    }
                    s.step((now - last).as_secs_f64().min(0.02));
                    drop(s);
                    last = now;
                    next = (next + STEP).max(now);
                }
            })
        };
        FakeRobot {
            joints,
            sim,
            stop,
            thread: Some(thread),
        }
    }

    /// A handle to watch the robot from a test.
    pub fn handle(&self) -> FakeRobotHandle {
        FakeRobotHandle {
            sim: Arc::clone(&self.sim),
        }
    }
}

impl Drop for FakeRobot {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl FakeRobotHandle {
    /// Joint positions now, rad.
    pub fn positions(&self) -> Vec<f64> {
        lock(&self.sim).position.clone()
    }

    /// Setpoint messages the port accepted.
    pub fn setpoints_received(&self) -> u64 {
        lock(&self.sim).setpoints
    }

    /// Trajectories the port accepted.
    pub fn trajectories_received(&self) -> u64 {
        lock(&self.sim).trajectories
    }

    /// Whether the robot is enabled.
    pub fn enabled(&self) -> bool {
        lock(&self.sim).enabled
    }
}

impl RobotPort for FakeRobot {
    fn joints(&self) -> &[JointInfo] {
        &self.joints
    }

    fn latest_state(&mut self) -> Option<RobotState> {
        let s = lock(&self.sim);
        Some(RobotState {
            stamp: s.stamp,
            position_rad: s.position.clone(),
            velocity_rad_s: s.velocity.clone(),
            effort_nm: s.effort.clone(),
        })
    }

    fn diagnostics(&mut self) -> RobotDiagnostics {
        let s = lock(&self.sim);
        RobotDiagnostics {
            timing: LoopTiming {
                period: STEP,
                cycles: s.cycles,
                deadline_misses: s.overruns,
                ..LoopTiming::default()
            },
            enabled: s.enabled,
            motors: self
                .joints
                .iter()
                .enumerate()
                .map(|(i, j)| MotorDiagnostics {
                    joint: j.name.clone(),
                    hardware_id: format!("fake:{}", i + 1),
                    temperature_c: Some(30.0 + s.effort[i].abs()),
                    voltage_v: Some(24.0),
                    faults: Vec::new(),
                })
                .collect(),
        }
    }

    fn send_setpoints(&mut self, setpoints: &Setpoints) -> Result<(), PortError> {
        let mut s = lock(&self.sim);
        if !s.enabled {
            return Err(PortError::Estopped);
        }
        for &(joint, setpoint) in setpoints.joints() {
            s.target[joint.0] = match setpoint {
                Setpoint::Position { position_rad, .. } => Target::Position(position_rad),
                Setpoint::Velocity { velocity_rad_s, .. } => Target::Velocity(velocity_rad_s),
                Setpoint::Effort { effort_nm } => Target::Effort(effort_nm),
            };
        }
        // A setpoint replaces the trajectory being followed.
        s.trajectory = None;
        s.setpoints += 1;
        Ok(())
    }

    fn send_trajectory(&mut self, trajectory: &Trajectory) -> Result<(), PortError> {
        let mut s = lock(&self.sim);
        if !s.enabled {
            return Err(PortError::Estopped);
        }
        let from = trajectory
            .joints()
            .iter()
            .map(|j| s.position[j.0])
            .collect();
        s.trajectory = Some(FollowedTrajectory {
            received: Instant::now(),
            from,
            trajectory: trajectory.clone(),
        });
        s.trajectories += 1;
        Ok(())
    }

    fn set_enable(&mut self, enable: Enable) -> Result<(), PortError> {
        let mut s = lock(&self.sim);
        s.enabled = enable == Enable::Enabled;
        if !s.enabled {
            s.trajectory = None;
            for i in 0..s.position.len() {
                s.target[i] = Target::Hold(s.position[i]);
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msg;
    use crate::validate::{CommandMode, Validator};

    fn wait_until(what: &str, f: impl Fn() -> bool) {
        let t0 = Instant::now();
        while !f() {
            assert!(t0.elapsed() < Duration::from_secs(10), "timed out: {what}");
            std::thread::sleep(Duration::from_millis(5));
        }
    }

    #[test]
    fn follows_setpoints_and_trajectories_and_stops_on_estop() {
        let mut robot = FakeRobot::start(FakeRobot::demo_joints(), true);
        let h = robot.handle();
        let v = Validator::new(robot.joints(), CommandMode::Auto);
        let cmd = msg::JointState {
            name: vec!["knee".into()],
            position: vec![1.0],
            ..Default::default()
        };
        robot
            .send_setpoints(&v.joint_command(&cmd).unwrap())
            .unwrap();
        wait_until("knee at 1 rad", || (h.positions()[1] - 1.0).abs() < 1e-3);
        assert_eq!(h.positions()[0], 0.0);
        let traj = msg::JointTrajectory {
            joint_names: vec!["hip".into()],
            points: vec![msg::JointTrajectoryPoint {
                positions: vec![-0.5],
                time_from_start: msg::Duration {
                    sec: 0,
                    nanosec: 200_000_000,
                },
                ..Default::default()
            }],
            ..Default::default()
        };
        robot
            .send_trajectory(&v.trajectory(&traj).unwrap())
            .unwrap();
        wait_until("hip at -0.5 rad", || (h.positions()[0] + 0.5).abs() < 1e-3);
        assert_eq!(h.trajectories_received(), 1);
        robot.set_enable(Enable::Estop).unwrap();
        assert!(!h.enabled());
        assert_eq!(
            robot.send_setpoints(&v.joint_command(&cmd).unwrap()),
            Err(PortError::Estopped)
        );
        assert_eq!(h.setpoints_received(), 1);
    }

    #[test]
    fn interpolates_linearly_between_points() {
        let v = Validator::new(&FakeRobot::demo_joints(), CommandMode::Auto);
        let point = |t_ms: u32, p: f64| msg::JointTrajectoryPoint {
            positions: vec![p],
            time_from_start: msg::Duration {
                sec: 0,
                nanosec: t_ms * 1_000_000,
            },
            ..Default::default()
        };
        let t = v
            .trajectory(&msg::JointTrajectory {
                joint_names: vec!["hip".into()],
                points: vec![point(100, 1.0), point(300, -1.0)],
                ..Default::default()
            })
            .unwrap();
        let f = FollowedTrajectory {
            received: Instant::now(),
            from: vec![0.5],
            trajectory: t,
        };
        let at = |ms: u64| Sim::trajectory_position(&f, 0, Duration::from_millis(ms));
        assert_eq!(at(0), 0.5);
        assert!((at(50) - 0.75).abs() < 1e-12);
        assert_eq!(at(100), 1.0);
        assert!((at(200) - 0.0).abs() < 1e-12);
        assert_eq!(at(1000), -1.0);
    }
}
