//! What a controller reads every tick: each joint's latest state, grouped by side (joint,
//! motor, raw wire values) with how fresh it is.
//!
//! The loop starts the controller only once every motor has answered (the start-up probe), so a
//! controller never sees a joint without feedback: [`JointFeedback`] always holds a reply's
//! values, and [`Freshness`] says whether they came in this tick.

use rmd_bus::Timestamp;

use crate::health::MotorHealth;
use crate::joint::JointId;
use crate::robot::JointSpec;

/// The joint side of a joint's state: after the gear ratio, direction and zero offset.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct JointSide {
    /// Joint angle, degrees (continuous: unwrapped by the loop).
    pub angle_deg: f64,
    /// Joint velocity, deg/s.
    pub velocity_dps: f64,
    /// Joint torque from the measured current, N*m; `None` without a torque constant in the
    /// description.
    pub torque_nm: Option<f64>,
}

impl JointSide {
    /// Joint angle in radians.
    pub fn angle_rad(&self) -> f64 {
        self.angle_deg.to_radians()
    }

    /// Joint velocity in rad/s.
    pub fn velocity_rad_s(&self) -> f64 {
        self.velocity_dps.to_radians()
    }
}

/// The motor side of a joint's state, in the motor's own frame and units.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct MotorSide {
    /// Continuous rotor angle, degrees (the single-turn encoder unwrapped by the loop; for a
    /// MyActuator V3 motor, which reports its output shaft in whole degrees, that angle times
    /// the gear ratio).
    pub angle_deg: f64,
    /// Rotor speed, deg/s (1 dps resolution; V3: the output's 1 dps times the gear ratio).
    pub speed_dps: f64,
    /// Torque current, amperes (motor sign).
    pub current_amps: f64,
    /// Temperature, degrees Celsius.
    pub temperature_celsius: f64,
}

/// The 0xA1 reply's fields as the motor sent them (the spec's names).
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub struct RawStatus {
    /// `temperature`, 1 degC per LSB.
    pub temperature: i8,
    /// `iq`, torque current, in the motor family's scale (v1.61: -2048..=2048 for -33..=33 A;
    /// MyActuator V3: 0.01 A per LSB).
    pub iq: i16,
    /// `speed`, 1 dps per LSB (V3: the output shaft's).
    pub speed: i16,
    /// `encoder`, single-turn position; for MyActuator V3 the output shaft's angle (int16, 1
    /// degree per LSB) as its two's-complement bits.
    pub encoder: u16,
}

/// A motion-mode reply's packed fields as the motor sent them (MyActuator V3, `0x500 + id`),
/// read with the ranges of the motor's firmware (see `rmd_protocol::MitFeedback`).
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub struct RawMotion {
    /// Position, 16 bits over the position range.
    pub position: u16,
    /// Velocity, 12 bits over the velocity range.
    pub velocity: u16,
    /// Torque, 12 bits over the torque range.
    pub torque: u16,
}

/// The wire values of a joint's newest reply.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum RawReply {
    /// A torque reply (0xA1's status): every exchange but `motion`.
    Torque(RawStatus),
    /// A motion-mode reply (`exchange = "motion"`): it carries no temperature; the motor's
    /// temperature comes from its status replies ([`JointFeedback::health`]).
    Motion(RawMotion),
}

/// How current a joint's feedback is in this tick.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Freshness {
    /// A reply answering this tick's frame (or, in pipelined mode, the previous tick's) came in
    /// this tick. `age_ticks` is 0 in same-tick mode, 1 in pipelined mode.
    Fresh {
        /// Ticks between the frame the reply answers and this tick.
        age_ticks: u32,
    },
    /// The newest reply came in this tick but answers an older frame than accepted: its values
    /// are used, `age_ticks` old.
    Late {
        /// Ticks between the frame the reply answers and this tick.
        age_ticks: u32,
    },
    /// No reply came in this tick: the values are from an earlier tick.
    Missing {
        /// Ticks since the last reply was received.
        ticks_since_reply: u32,
    },
}

impl Freshness {
    /// Whether this tick's feedback is fresh.
    pub fn is_fresh(self) -> bool {
        matches!(self, Freshness::Fresh { .. })
    }
}

/// One joint's latest feedback.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct JointFeedback {
    /// Joint side: angle, velocity, torque.
    pub joint: JointSide,
    /// Motor side: rotor angle and speed, current, temperature (in motion mode the newest
    /// status reply's temperature, 0 before the first).
    pub motor: MotorSide,
    /// The reply's wire values.
    pub raw: RawReply,
    /// Whether it came in this tick.
    pub freshness: Freshness,
    /// When the reply was received (bus clock).
    pub received_at: Timestamp,
    /// The motor's latest status-1 reply (supply voltage, temperature, error flags), read in
    /// rotation when `loop.health_rotation` is on and the bus has room; `None` until the first.
    pub health: Option<MotorHealth>,
}

impl JointFeedback {
    /// Feedback slot before a reply (never shown to a controller).
    pub(crate) const UNSET: Self = Self {
        joint: JointSide {
            angle_deg: 0.0,
            velocity_dps: 0.0,
            torque_nm: None,
        },
        motor: MotorSide {
            angle_deg: 0.0,
            speed_dps: 0.0,
            current_amps: 0.0,
            temperature_celsius: 0.0,
        },
        raw: RawReply::Torque(RawStatus {
            temperature: 0,
            iq: 0,
            speed: 0,
            encoder: 0,
        }),
        freshness: Freshness::Missing {
            ticks_since_reply: 0,
        },
        received_at: Timestamp::ZERO,
        health: None,
    };

    /// Whether it came in this tick.
    pub fn is_fresh(&self) -> bool {
        self.freshness.is_fresh()
    }
}

/// The feedback of every joint in this tick, indexed by [`JointId`].
///
/// ```
/// # use rmd_loop::{Feedback, Commands, Controller, Flow, TickContext};
/// struct Hold;
/// impl Controller for Hold {
///     fn update(&mut self, _: &TickContext, feedback: &Feedback<'_>, cmd: &mut Commands<'_>) -> Flow {
///         for (joint, state) in feedback.iter() {
///             cmd.set_current(joint, -0.5 * state.joint.angle_deg - 0.02 * state.joint.velocity_dps);
///         }
///         Flow::Continue
///     }
/// }
/// ```
#[derive(Copy, Clone, Debug)]
pub struct Feedback<'a> {
    joints: &'a [JointFeedback],
    specs: &'a [JointSpec],
}

impl<'a> Feedback<'a> {
    pub(crate) fn new(joints: &'a [JointFeedback], specs: &'a [JointSpec]) -> Self {
        Self { joints, specs }
    }

    /// Number of joints.
    pub fn len(&self) -> usize {
        self.joints.len()
    }

    /// Whether there are no joints.
    pub fn is_empty(&self) -> bool {
        self.joints.is_empty()
    }

    /// Joint `id`'s feedback, if the robot has it.
    pub fn get(&self, id: JointId) -> Option<&'a JointFeedback> {
        self.joints.get(id.index())
    }

    /// Every joint with its feedback, in description order.
    pub fn iter(&self) -> impl ExactSizeIterator<Item = (JointId, &'a JointFeedback)> + 'a {
        self.joints
            .iter()
            .enumerate()
            .map(|(i, f)| (JointId::from_index(i), f))
    }

    /// The description of joint `id` (its name, motor, limits), if the robot has it.
    pub fn spec(&self, id: JointId) -> Option<&'a JointSpec> {
        self.specs.get(id.index())
    }

    /// Whether every joint's feedback is fresh this tick.
    pub fn all_fresh(&self) -> bool {
        self.joints.iter().all(JointFeedback::is_fresh)
    }

    /// All joints' feedback as a slice, in description order.
    pub fn as_slice(&self) -> &'a [JointFeedback] {
        self.joints
    }
}

impl core::ops::Index<JointId> for Feedback<'_> {
    type Output = JointFeedback;
    /// # Panics
    /// If `id` belongs to a larger robot.
    fn index(&self, id: JointId) -> &JointFeedback {
        &self.joints[id.index()]
    }
}
