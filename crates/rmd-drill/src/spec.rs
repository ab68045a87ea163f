//! What one drill runs: the faults and when, the robot's size, the run's length and time.

use core::time::Duration;

use rmd_loop::robot::ExchangeKind;
use rmd_protocol::ProtocolFamily;
use rmd_rig::SimTime;
use rmd_rig::signals::Signals;

use crate::fault::DrillFault;

/// The most buses a drill simulates.
pub const MAX_BUSES: u8 = 8;
/// The longest drill, seconds.
pub const MAX_SECONDS: u64 = 3600;

/// One drill: a PD position hold on `buses` x `motors` simulated motors for `seconds`, with
/// each fault injected at its time after the start.
///
/// ```
/// use core::time::Duration;
/// use rmd_drill::{DrillFault, DrillSpec};
/// let spec = DrillSpec::new("bus-off:50".parse::<DrillFault>()?)
///     .buses(2)
///     .at(Duration::from_millis(300))
///     .seconds(Duration::from_secs(1));
/// assert_eq!(spec.faults()[0].1, Duration::from_millis(300));
/// # Ok::<(), rmd_drill::FaultParseError>(())
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct DrillSpec {
    pub(crate) faults: Vec<(DrillFault, Duration)>,
    pub(crate) buses: u8,
    pub(crate) motors: u8,
    pub(crate) seconds: Duration,
    pub(crate) seed: u64,
    pub(crate) time: SimTime,
    pub(crate) signals: Option<Signals>,
    pub(crate) firmware: ProtocolFamily,
    pub(crate) mixed_with: Option<ProtocolFamily>,
    pub(crate) exchange: Option<ExchangeKind>,
    pub(crate) tell_waits: bool,
}

impl DrillSpec {
    /// `fault` at 0.5 s of a 2 s run, one bus of four motors, real time, seed 1: the defaults
    /// of `rmd drill`.
    pub fn new(fault: DrillFault) -> Self {
        Self {
            faults: vec![(fault, Duration::from_millis(500))],
            buses: 1,
            motors: 4,
            seconds: Duration::from_secs(2),
            seed: 1,
            time: SimTime::Real,
            signals: None,
            firmware: ProtocolFamily::V161,
            mixed_with: None,
            exchange: None,
            tell_waits: false,
        }
    }

    /// Injects the (first) fault `at` after the start instead.
    pub fn at(mut self, at: Duration) -> Self {
        if let Some(first) = self.faults.first_mut() {
            first.1 = at;
        }
        self
    }

    /// Injects another fault too, `at` after the start.
    pub fn and(mut self, fault: DrillFault, at: Duration) -> Self {
        self.faults.push((fault, at));
        self
    }

    /// Runs on `buses` buses (1..=8).
    pub fn buses(mut self, buses: u8) -> Self {
        self.buses = buses;
        self
    }

    /// Simulates `motors` motors per bus (1..=4).
    pub fn motors(mut self, motors: u8) -> Self {
        self.motors = motors;
        self
    }

    /// Simulates motors of this firmware family (v1.61 by default; LK-TECH motors are MG
    /// series). A MyActuator V3 bus is driven by the per-motor exchange, whose wire budget
    /// carries at most 3 motors at the drill's 1 kHz on 1 Mbit/s.
    pub fn firmware(mut self, firmware: ProtocolFamily) -> Self {
        self.firmware = firmware;
        self
    }

    /// Makes every bus mix families: the motors of even ids run `other`'s firmware (described
    /// so), the others [`firmware`](Self::firmware)'s. A bus with a MyActuator V3 motor among
    /// them is driven per motor, each motor in its own family's scale.
    pub fn mixed_with(mut self, other: ProtocolFamily) -> Self {
        self.mixed_with = Some(other);
        self
    }

    /// The firmware family of motor `id`.
    pub(crate) fn family_of(&self, id: u8) -> ProtocolFamily {
        match self.mixed_with {
            Some(other) if id.is_multiple_of(2) => other,
            Some(_) | None => self.firmware,
        }
    }

    /// Exchanges with every bus's motors this way (`motion`: MyActuator V3's motion mode, the
    /// drill's torques as feed-forward torque) instead of the family's default; the robot
    /// description refuses what the motors cannot take.
    pub fn exchange(mut self, exchange: ExchangeKind) -> Self {
        self.exchange = Some(exchange);
        self
    }

    /// Runs for `seconds` at most (the loop may stop earlier).
    pub fn seconds(mut self, seconds: Duration) -> Self {
        self.seconds = seconds;
        self
    }

    /// Seeds the simulated motors' and faults' random draws.
    pub fn seed(mut self, seed: u64) -> Self {
        self.seed = seed;
        self
    }

    /// Runs in real or virtual time.
    pub fn time(mut self, time: SimTime) -> Self {
        self.time = time;
        self
    }

    /// Lets the program's signals stop the drill's loop, by the project's policy
    /// (`rmd_rig::signals`): the first stops it (zero torque, motor off), the second is an
    /// emergency stop; the verdict is still taken from the simulated firmware.
    pub fn stopped_by(mut self, signals: Signals) -> Self {
        self.signals = Some(signals);
        self
    }

    /// Before waiting in real time for the motors' watchdogs (after a `host-silent` fault),
    /// writes one line to stderr saying how long, and that Ctrl-C ends the wait (a write that
    /// fails is ignored).
    pub fn tell_waits(mut self) -> Self {
        self.tell_waits = true;
        self
    }

    /// The faults and when each is injected.
    pub fn faults(&self) -> &[(DrillFault, Duration)] {
        &self.faults
    }

    /// Checks the numbers before anything is built.
    pub(crate) fn check(&self) -> Result<(), crate::DrillError> {
        use crate::DrillError;
        if !(1..=MAX_BUSES).contains(&self.buses) {
            return Err(DrillError::Buses(self.buses));
        }
        if !(1..=4).contains(&self.motors) {
            return Err(DrillError::Motors(self.motors));
        }
        if self.seconds.is_zero() || self.seconds > Duration::from_secs(MAX_SECONDS) {
            return Err(DrillError::Seconds);
        }
        for &(fault, at) in &self.faults {
            if at >= self.seconds && !matches!(fault, DrillFault::UnknownMotor(_)) {
                return Err(DrillError::AtAfterEnd {
                    at: at.as_secs_f64(),
                    seconds: self.seconds.as_secs_f64(),
                });
            }
            match fault {
                DrillFault::SilentMotor(id) if id.get() > self.motors => {
                    return Err(DrillError::NoSuchMotor {
                        fault: fault.to_string(),
                        motors: self.motors,
                    });
                }
                DrillFault::UnknownMotor(id) if id.get() <= self.motors && self.motors == 1 => {
                    return Err(DrillError::NothingDescribed {
                        fault: fault.to_string(),
                    });
                }
                _ => {}
            }
        }
        Ok(())
    }
}
