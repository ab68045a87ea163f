//! The drill's controller: a PD hold of every joint where it powered up, which misbehaves as
//! the drill's controller faults say, when they say.

use core::time::Duration;
use std::sync::{Arc, OnceLock};

use rmd_bus::{Timestamp, VirtualClock};
use rmd_loop::{Commands, Controller, Feedback, Flow, JointArray, Robot, Stopper, TickContext};

use crate::fault::DrillFault;

/// How time passes for the controller while it hangs or works slowly.
#[derive(Clone, Debug)]
pub(crate) enum Pace {
    /// Real time: it sleeps (or, for short spans, keeps the CPU busy as real work would).
    Real,
    /// Virtual time: it moves the run's clock on, a millisecond at a time, pausing briefly in
    /// real time at each step so the supervisor, which looks in real time, sees time pass.
    Virtual(VirtualClock),
}

impl Pace {
    fn pass(&self, d: Duration) {
        match self {
            Pace::Real if d <= Duration::from_millis(2) => {
                let until = std::time::Instant::now() + d;
                while std::time::Instant::now() < until {
                    core::hint::spin_loop();
                }
            }
            Pace::Real => std::thread::sleep(d),
            Pace::Virtual(clock) => {
                let mut left = d;
                while !left.is_zero() {
                    let step = left.min(Duration::from_millis(1));
                    clock.advance(step);
                    left -= step;
                    if d > Duration::from_millis(2) {
                        std::thread::sleep(Duration::from_micros(250));
                    }
                }
            }
        }
    }
}

/// A controller fault and the instant it strikes.
#[derive(Clone, Debug)]
struct Injection {
    at: Timestamp,
    fault: DrillFault,
    done: bool,
}

/// Holds every joint at its power-up angle: current = kp * error - kd * velocity (0.8 A per
/// degree, 0.03 A per degree per second, as the `pd_hold` example).
pub(crate) struct DrillController {
    targets: JointArray<f64>,
    injections: Vec<Injection>,
    pace: Pace,
    stopper: Arc<OnceLock<Stopper>>,
    nan: bool,
    slow: Duration,
}

impl DrillController {
    /// The controller for `robot`, with the controller faults among `faults` (each with its
    /// absolute instant); `stopper` is filled in once the loop exists.
    pub(crate) fn new(
        robot: &Robot,
        faults: impl IntoIterator<Item = (DrillFault, Timestamp)>,
        pace: Pace,
        stopper: Arc<OnceLock<Stopper>>,
    ) -> Self {
        Self {
            targets: JointArray::new(robot, 0.0),
            injections: faults
                .into_iter()
                .filter(|(fault, _)| fault.is_controller_fault())
                .map(|(fault, at)| Injection {
                    at,
                    fault,
                    done: false,
                })
                .collect(),
            pace,
            stopper,
            nan: false,
            slow: Duration::ZERO,
        }
    }

    fn inject(&mut self, now: Timestamp) {
        for i in 0..self.injections.len() {
            let injection = &mut self.injections[i];
            if injection.done || now < injection.at {
                continue;
            }
            injection.done = true;
            match injection.fault {
                DrillFault::ControllerHang(d) => self.pace.pass(d),
                DrillFault::ControllerPanic => panic!("drill: the controller panics"),
                DrillFault::NanCommand => self.nan = true,
                DrillFault::SlowController(d) => self.slow = d,
                DrillFault::Estop => {
                    if let Some(stopper) = self.stopper.get() {
                        stopper.emergency_stop();
                    }
                }
                DrillFault::Stop => {
                    if let Some(stopper) = self.stopper.get() {
                        stopper.stop();
                    }
                }
                _ => {}
            }
        }
    }
}

impl Controller for DrillController {
    fn start(&mut self, _: &TickContext, feedback: &Feedback<'_>) {
        for (joint, state) in feedback.iter() {
            self.targets[joint] = state.joint.angle_deg;
        }
    }

    fn update(
        &mut self,
        ctx: &TickContext,
        feedback: &Feedback<'_>,
        cmd: &mut Commands<'_>,
    ) -> Flow {
        for (joint, state) in feedback.iter() {
            let error = self.targets[joint] - state.joint.angle_deg;
            cmd.set_current(joint, 0.8 * error - 0.03 * state.joint.velocity_dps);
        }
        if self.nan
            && let Some((joint, _)) = feedback.iter().next()
        {
            cmd.set_current(joint, f64::NAN);
        }
        self.inject(ctx.woke);
        if !self.slow.is_zero() {
            self.pace.pass(self.slow);
        }
        Flow::Continue
    }
}
