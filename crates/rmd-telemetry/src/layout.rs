//! The run layout: what is known before the first tick (rate, joints, buses, signal names).

use std::collections::HashSet;
use std::time::{SystemTime, UNIX_EPOCH};

use rmd_protocol::MotorId;
use thiserror::Error;

use crate::record::{MAX_JOINTS, MAX_SIGNALS};

/// One joint of the run, in the order the records carry it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct JointInfo {
    name: String,
    bus: usize,
    motor: MotorId,
    torque_constant_known: bool,
}

impl JointInfo {
    /// A joint named `name` (from the robot description, e.g. `"hip_flexion"`) driven by motor
    /// `motor` on bus number `bus` (0-based, in the description's order). Its torque constant is
    /// unknown until [`JointInfo::with_torque_constant`] says otherwise.
    ///
    /// ```
    /// use rmd_protocol::MotorId;
    /// use rmd_telemetry::JointInfo;
    ///
    /// let knee = JointInfo::new("knee", 0, MotorId::new(2)?).with_torque_constant(true);
    /// assert!(knee.torque_constant_known());
    /// # Ok::<(), rmd_protocol::ProtocolError>(())
    /// ```
    pub fn new(name: impl Into<String>, bus: usize, motor: MotorId) -> Self {
        Self {
            name: name.into(),
            bus,
            motor,
            torque_constant_known: false,
        }
    }

    /// Whether the motor's torque constant is known, i.e. whether the records carry the joint's
    /// torque (`effort`).
    #[must_use]
    pub fn with_torque_constant(mut self, known: bool) -> Self {
        self.torque_constant_known = known;
        self
    }

    /// The joint's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The bus number (0-based).
    pub fn bus(&self) -> usize {
        self.bus
    }

    /// The motor's id on its bus.
    pub fn motor(&self) -> MotorId {
        self.motor
    }

    /// Whether the records carry this joint's torque.
    pub fn torque_constant_known(&self) -> bool {
        self.torque_constant_known
    }
}

/// Why a [`RunLayout`] cannot be built. Each names what to change.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum LayoutError {
    /// The rate is zero, negative or not a number.
    #[error("the loop rate must be a positive number of Hz, got {0}")]
    BadRate(f64),
    /// More joints than a record carries.
    #[error("{count} joints: a telemetry record carries at most {max}; describe fewer joints")]
    TooManyJoints {
        /// Joints given.
        count: usize,
        /// [`MAX_JOINTS`].
        max: usize,
    },
    /// More user signals than a record carries.
    #[error("{count} user signals: a telemetry record carries at most {max}; name fewer signals")]
    TooManySignals {
        /// Signals given.
        count: usize,
        /// [`MAX_SIGNALS`].
        max: usize,
    },
    /// A joint or signal name is empty or is not printable text.
    #[error(
        "the {what} name {name:?} is not usable: names must be non-empty and free of control characters"
    )]
    BadName {
        /// `"joint"` or `"signal"`.
        what: &'static str,
        /// The name given.
        name: String,
    },
    /// Two joints, or two signals, share a name.
    #[error("the {what} name {name:?} is used twice; names must be unique")]
    DuplicateName {
        /// `"joint"` or `"signal"`.
        what: &'static str,
        /// The repeated name.
        name: String,
    },
    /// A joint names a bus the run does not have.
    #[error(
        "joint {joint:?} is on bus {bus}, but the run has {bus_count} bus(es) (numbered from 0)"
    )]
    NoSuchBus {
        /// The joint.
        joint: String,
        /// Its bus number.
        bus: usize,
        /// The run's bus count.
        bus_count: usize,
    },
    /// Two joints are driven by the same motor.
    #[error("joints {first:?} and {second:?} both use motor {motor} on bus {bus}")]
    SharedMotor {
        /// The first joint.
        first: String,
        /// The second joint.
        second: String,
        /// The bus.
        bus: usize,
        /// The motor id.
        motor: u8,
    },
    /// The start time is before 1970.
    #[error("the run's start time is before the Unix epoch")]
    StartBeforeEpoch,
}

/// What the telemetry knows before the run: the loop rate, the joints in record order, the bus
/// count, the user signal names and the wall-clock time of the run's start. Built once, checked
/// once ([`RunLayoutBuilder::build`]); every sink names its channels and columns from it.
///
/// ```
/// use rmd_protocol::MotorId;
/// use rmd_telemetry::{JointInfo, RunLayout};
///
/// let layout = RunLayout::builder(1000.0)
///     .bus_count(1)
///     .joint(JointInfo::new("hip", 0, MotorId::new(1)?).with_torque_constant(true))
///     .joint(JointInfo::new("knee", 0, MotorId::new(2)?))
///     .signal("knee_target_rad")
///     .build()?;
/// assert_eq!(layout.joints().len(), 2);
/// assert_eq!(layout.signals(), ["knee_target_rad"]);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct RunLayout {
    rate_hz: f64,
    bus_count: usize,
    joints: Vec<JointInfo>,
    signals: Vec<String>,
    start_unix_ns: u64,
}

impl RunLayout {
    /// Starts a layout for a loop running at `rate_hz`.
    pub fn builder(rate_hz: f64) -> RunLayoutBuilder {
        RunLayoutBuilder {
            rate_hz,
            bus_count: None,
            joints: Vec::new(),
            signals: Vec::new(),
            start: None,
        }
    }

    /// The loop rate (Hz).
    pub fn rate_hz(&self) -> f64 {
        self.rate_hz
    }

    /// The number of buses.
    pub fn bus_count(&self) -> usize {
        self.bus_count
    }

    /// The joints, in the order of [`TickRecord::joints`](crate::TickRecord::joints).
    pub fn joints(&self) -> &[JointInfo] {
        &self.joints
    }

    /// The user signal names, in the order of
    /// [`TickRecord::signals`](crate::TickRecord::signals).
    pub fn signals(&self) -> &[String] {
        &self.signals
    }

    /// The wall-clock time of the run's start (tick time 0) in nanoseconds since the Unix epoch.
    /// A record's time stamp in the sinks is this plus its
    /// [`since_start_ns`](crate::TickRecord::since_start_ns).
    pub fn start_unix_ns(&self) -> u64 {
        self.start_unix_ns
    }

    /// The Unix time (ns) of a record taken `since_start_ns` after the start.
    pub fn unix_ns(&self, since_start_ns: u64) -> u64 {
        self.start_unix_ns.saturating_add(since_start_ns)
    }

    /// Whether any joint carries a torque.
    pub fn any_torque(&self) -> bool {
        self.joints.iter().any(JointInfo::torque_constant_known)
    }
}

/// Builds a [`RunLayout`]; see [`RunLayout::builder`].
#[derive(Debug, Clone)]
#[must_use]
pub struct RunLayoutBuilder {
    rate_hz: f64,
    bus_count: Option<usize>,
    joints: Vec<JointInfo>,
    signals: Vec<String>,
    start: Option<SystemTime>,
}

impl RunLayoutBuilder {
    /// The number of buses (default: one more than the highest bus a joint uses, at least 1).
    pub fn bus_count(mut self, count: usize) -> Self {
        self.bus_count = Some(count);
        self
    }

    /// Adds the next joint.
    pub fn joint(mut self, joint: JointInfo) -> Self {
        self.joints.push(joint);
        self
    }

    /// Adds joints in order.
    pub fn joints(mut self, joints: impl IntoIterator<Item = JointInfo>) -> Self {
        self.joints.extend(joints);
        self
    }

    /// Adds the next user signal name.
    pub fn signal(mut self, name: impl Into<String>) -> Self {
        self.signals.push(name.into());
        self
    }

    /// The wall-clock time of tick time 0 (default: the time [`RunLayoutBuilder::build`] runs).
    pub fn start_time(mut self, start: SystemTime) -> Self {
        self.start = Some(start);
        self
    }

    /// Checks everything once and returns the layout.
    ///
    /// # Errors
    /// A [`LayoutError`] naming the first problem: bad rate, too many joints or signals, an empty,
    /// odd or repeated name, a joint on a bus the run does not have, two joints on one motor, a
    /// start time before 1970.
    pub fn build(self) -> Result<RunLayout, LayoutError> {
        if !(self.rate_hz.is_finite() && self.rate_hz > 0.0) {
            return Err(LayoutError::BadRate(self.rate_hz));
        }
        if self.joints.len() > MAX_JOINTS {
            return Err(LayoutError::TooManyJoints {
                count: self.joints.len(),
                max: MAX_JOINTS,
            });
        }
        if self.signals.len() > MAX_SIGNALS {
            return Err(LayoutError::TooManySignals {
                count: self.signals.len(),
                max: MAX_SIGNALS,
            });
        }
        check_names("joint", self.joints.iter().map(JointInfo::name))?;
        check_names("signal", self.signals.iter().map(String::as_str))?;
        let needed_buses = self.joints.iter().map(|j| j.bus + 1).max().unwrap_or(1);
        let bus_count = self.bus_count.unwrap_or(needed_buses);
        for joint in &self.joints {
            if joint.bus >= bus_count {
                return Err(LayoutError::NoSuchBus {
                    joint: joint.name.clone(),
                    bus: joint.bus,
                    bus_count,
                });
            }
        }
        for (i, first) in self.joints.iter().enumerate() {
            if let Some(second) = self.joints[i + 1..]
                .iter()
                .find(|j| j.bus == first.bus && j.motor == first.motor)
            {
                return Err(LayoutError::SharedMotor {
                    first: first.name.clone(),
                    second: second.name.clone(),
                    bus: first.bus,
                    motor: first.motor.get(),
                });
            }
        }
        let start = self.start.unwrap_or_else(SystemTime::now);
        let since_epoch = start
            .duration_since(UNIX_EPOCH)
            .map_err(|_| LayoutError::StartBeforeEpoch)?;
        Ok(RunLayout {
            rate_hz: self.rate_hz,
            bus_count,
            joints: self.joints,
            signals: self.signals,
            start_unix_ns: u64::try_from(since_epoch.as_nanos()).unwrap_or(u64::MAX),
        })
    }
}

fn check_names<'a>(
    what: &'static str,
    names: impl Iterator<Item = &'a str>,
) -> Result<(), LayoutError> {
    let mut seen = HashSet::new();
    for name in names {
        if name.trim().is_empty() || name.chars().any(char::is_control) {
            return Err(LayoutError::BadName {
                what,
                name: name.to_owned(),
            });
        }
        if !seen.insert(name) {
            return Err(LayoutError::DuplicateName {
                what,
                name: name.to_owned(),
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn id(n: u8) -> MotorId {
        MotorId::new(n).unwrap()
    }

    #[test]
    fn builds_a_layout_and_infers_the_bus_count() {
        let layout = RunLayout::builder(500.0)
            .joint(JointInfo::new("a", 0, id(1)))
            .joint(JointInfo::new("b", 1, id(1)).with_torque_constant(true))
            .start_time(UNIX_EPOCH + std::time::Duration::from_secs(10))
            .build()
            .unwrap();
        assert_eq!(layout.bus_count(), 2);
        assert_eq!(layout.start_unix_ns(), 10_000_000_000);
        assert_eq!(layout.unix_ns(5), 10_000_000_005);
        assert!(layout.any_torque());
    }

    #[test]
    fn rejects_each_bad_input_with_its_own_error() {
        let ok = || RunLayout::builder(1000.0);
        assert_eq!(
            ok().bus_count(1).build().map(|l| l.joints().len()),
            Ok(0),
            "an empty layout is valid"
        );
        assert!(matches!(
            RunLayout::builder(0.0).build(),
            Err(LayoutError::BadRate(_))
        ));
        assert!(matches!(
            RunLayout::builder(f64::NAN).build(),
            Err(LayoutError::BadRate(_))
        ));
        let many = (0..33).map(|i| JointInfo::new(format!("j{i}"), i, id(1)));
        assert!(matches!(
            ok().joints(many).build(),
            Err(LayoutError::TooManyJoints { count: 33, .. })
        ));
        let mut b = ok();
        for i in 0..17 {
            b = b.signal(format!("s{i}"));
        }
        assert!(matches!(
            b.build(),
            Err(LayoutError::TooManySignals { count: 17, .. })
        ));
        assert!(matches!(
            ok().joint(JointInfo::new(" ", 0, id(1))).build(),
            Err(LayoutError::BadName { what: "joint", .. })
        ));
        assert!(matches!(
            ok().signal("a\nb").build(),
            Err(LayoutError::BadName { what: "signal", .. })
        ));
        assert!(matches!(
            ok().signal("x").signal("x").build(),
            Err(LayoutError::DuplicateName { what: "signal", .. })
        ));
        assert!(matches!(
            ok().joint(JointInfo::new("k", 0, id(1)))
                .joint(JointInfo::new("k", 0, id(2)))
                .build(),
            Err(LayoutError::DuplicateName { what: "joint", .. })
        ));
        assert!(matches!(
            ok().bus_count(1)
                .joint(JointInfo::new("k", 1, id(1)))
                .build(),
            Err(LayoutError::NoSuchBus { bus: 1, .. })
        ));
        assert!(matches!(
            ok().joint(JointInfo::new("a", 0, id(3)))
                .joint(JointInfo::new("b", 0, id(3)))
                .build(),
            Err(LayoutError::SharedMotor { motor: 3, .. })
        ));
    }
}
