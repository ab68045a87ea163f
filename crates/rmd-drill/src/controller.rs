//! The drill's controller: a PD hold of every joint where it powered up, which misbehaves as
//! the drill's controller faults say, when they say.

use core::time::Duration;
use std::sync::{Arc, OnceLock};

use rmd_bus::{Clock, MonotonicClock, Timestamp, VirtualClock};
use rmd_loop::{
    Commands, Controller, Feedback, Flow, JointArray, Stopper, TickContext, robot::Robot,
};

use crate::fault::DrillFault;

/// How time passes for the controller while it hangs or works slowly.
#[derive(Clone, Debug)]
pub(crate) enum TimeBase {
    /// Real time: a hang sleeps, slow work keeps the CPU busy.
    Real,
    /// Virtual time: the controller moves the run's clock on; a hang does so a millisecond at a
    /// time, pausing briefly in real time at each step so the supervisor, which looks in real
    /// time, sees time pass.
    Virtual(VirtualClock),
}

impl TimeBase {
    fn now(&self) -> Timestamp {
        match self {
            TimeBase::Real => MonotonicClock.now(),
            TimeBase::Virtual(clock) => clock.now(),
        }
    }

    /// Lets `d` pass as work on the CPU would (short spans busy-wait in real time).
    fn work(&self, d: Duration) {
        match self {
            TimeBase::Real => {
                let until = std::time::Instant::now() + d;
                while std::time::Instant::now() < until {
                    core::hint::spin_loop();
                }
            }
            TimeBase::Virtual(clock) => clock.advance(d),
        }
    }

    /// Lets one step of at most a millisecond of a hang pass, never beyond `until`.
    fn hang_step(&self, until: Timestamp) {
        let step = (until - self.now()).min(Duration::from_millis(1));
        match self {
            TimeBase::Real => std::thread::sleep(step),
            TimeBase::Virtual(clock) => {
                clock.advance(step);
                std::thread::sleep(Duration::from_micros(250));
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
    time: TimeBase,
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
        time: TimeBase,
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
            time,
            stopper,
            nan: false,
            slow: Duration::ZERO,
        }
    }

    /// Strikes the faults due at `now`. An operator's stop and emergency stop are struck
    /// even while the controller hangs (the drill plays the operator, who does not wait for the
    /// controller).
    fn inject(&mut self, now: Timestamp) {
        self.operator(now);
        for i in 0..self.injections.len() {
            let injection = &mut self.injections[i];
            if injection.done || now < injection.at || injection.is_operator() {
                continue;
            }
            injection.done = true;
            match injection.fault {
                DrillFault::ControllerHang(d) => {
                    let until = now + d;
                    while self.time.now() < until {
                        self.time.hang_step(until);
                        self.operator(self.time.now());
                    }
                }
                DrillFault::ControllerPanic => panic!("drill: the controller panics"),
                DrillFault::NanCommand => self.nan = true,
                DrillFault::SlowController(d) => self.slow = d,
                _ => {}
            }
        }
    }

    /// The operator's requests due at `now`.
    fn operator(&mut self, now: Timestamp) {
        for injection in &mut self.injections {
            if injection.done || now < injection.at || !injection.is_operator() {
                continue;
            }
            injection.done = true;
            if let Some(stopper) = self.stopper.get() {
                match injection.fault {
                    DrillFault::Estop => stopper.emergency_stop(),
                    _ => stopper.stop(),
                }
            }
        }
    }
}

impl Injection {
    fn is_operator(&self) -> bool {
        matches!(self.fault, DrillFault::Estop | DrillFault::Stop)
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
            self.time.work(self.slow);
        }
        Flow::Continue
    }
}
