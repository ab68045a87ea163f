//! What goes wrong, by the stage that makes it happen: a motor's reply ([`ReplyFault`]), the
//! physics of a motor ([`PhysicalFault`]), the host's side of the bus ([`BusFault`]).
//!
//! Each stage of the fault engine takes the rules of its own level and matches on that level
//! exhaustively, so a new kind cannot compile without saying what it does.

use core::time::Duration;

/// What goes wrong: one fault of one of the three levels, each evaluated by its own stage.
///
/// Built from a level's fault with `From` (`FaultRule::new` takes either):
///
/// ```
/// use rmd_sim::{FaultKind, ReplyFault};
/// assert_eq!(FaultKind::from(ReplyFault::DropReply), FaultKind::Reply(ReplyFault::DropReply));
/// ```
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum FaultKind {
    /// A motor's answer to a matching request it receives goes wrong.
    Reply(ReplyFault),
    /// A physical cause is imposed on a motor while the window is open.
    Physical(PhysicalFault),
    /// The host's controller fails on a matching frame it sends (simulated bus only).
    Bus(BusFault),
}

/// What goes wrong with a motor's answer, drawn per matching request the motor receives.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum ReplyFault {
    /// The reply is not sent.
    DropReply,
    /// The reply is sent `delay` later than it would be.
    LateReply {
        /// Extra delay.
        delay: Duration,
    },
    /// `count` distinct data bytes of the reply (1..=8) are XORed with random non-zero values.
    CorruptBytes {
        /// Number of corrupted bytes.
        count: u8,
    },
    /// The reply is sent with this DLC (0..=7) instead of 8, its data truncated.
    WrongDlc {
        /// The DLC sent.
        dlc: u8,
    },
    /// The reply is sent twice, back to back.
    DuplicateReply,
    /// The motor ignores the request and sends nothing.
    Silent,
}

/// A physical cause imposed on a motor, continuously while the window is open; the firmware
/// raises its flag through its own thresholds.
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum PhysicalFault {
    /// The supply voltage at the motor drops to `volts` (physical cause of the low-voltage flag).
    LowVoltage {
        /// Forced open-circuit supply voltage, V.
        volts: f64,
    },
    /// The winding is held at or above `celsius` (physical cause of the over-temperature flag).
    OverTemperature {
        /// Forced minimum winding temperature, °C.
        celsius: f64,
    },
}

/// A failure of the host's side of a simulated bus, started by a matching frame the host sends.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum BusFault {
    /// The host's controller goes bus-off for `duration`: the client receives
    /// [`BusEvent::BusOff`](rmd_bus::BusEvent::BusOff), `send` fails with
    /// [`BusError::BusOff`](rmd_bus::BusError::BusOff), frames queued or arriving are lost,
    /// then [`BusEvent::Restarted`](rmd_bus::BusEvent::Restarted).
    BusOff {
        /// How long the controller stays bus-off.
        duration: Duration,
    },
    /// The host's controller cannot transmit for `duration` (as with a flood of higher-priority
    /// traffic): its transmit queue fills and `send` returns
    /// [`BusError::TxQueueFull`](rmd_bus::BusError::TxQueueFull).
    TxStall {
        /// How long the host cannot transmit.
        duration: Duration,
    },
    /// From the matching frame on, nothing the host sends reaches the motors, and `send` still
    /// succeeds: the host died (SIGKILL, a kernel hang, a power loss) or its cable was cut, as
    /// the motors see it. Only a motor-side watchdog (MyActuator V3's 0xB3) stops a motor then.
    HostSilent,
}

impl From<ReplyFault> for FaultKind {
    fn from(fault: ReplyFault) -> Self {
        FaultKind::Reply(fault)
    }
}

impl From<PhysicalFault> for FaultKind {
    fn from(fault: PhysicalFault) -> Self {
        FaultKind::Physical(fault)
    }
}

impl From<BusFault> for FaultKind {
    fn from(fault: BusFault) -> Self {
        FaultKind::Bus(fault)
    }
}

impl FaultKind {
    /// Whether the rule's probability is drawn per matching frame (reply and bus faults); a
    /// physical cause is on for its whole window instead.
    pub(crate) fn is_drawn_per_frame(self) -> bool {
        match self {
            FaultKind::Reply(_) | FaultKind::Bus(_) => true,
            FaultKind::Physical(_) => false,
        }
    }

    /// Why the fault's own arguments are not meaningful, if they are not.
    pub(crate) fn argument_error(self) -> Option<&'static str> {
        match self {
            FaultKind::Reply(fault) => fault.argument_error(),
            FaultKind::Physical(fault) => fault.argument_error(),
            FaultKind::Bus(fault) => fault.argument_error(),
        }
    }
}

impl ReplyFault {
    fn argument_error(self) -> Option<&'static str> {
        match self {
            ReplyFault::CorruptBytes { count } => {
                (!(1..=8).contains(&count)).then_some("CorruptBytes count must be 1..=8")
            }
            ReplyFault::WrongDlc { dlc } => (dlc >= 8).then_some("WrongDlc dlc must be 0..=7"),
            ReplyFault::DropReply
            | ReplyFault::LateReply { .. }
            | ReplyFault::DuplicateReply
            | ReplyFault::Silent => None,
        }
    }
}

impl PhysicalFault {
    fn argument_error(self) -> Option<&'static str> {
        match self {
            PhysicalFault::LowVoltage { volts } => (!(volts.is_finite() && volts >= 0.0))
                .then_some("LowVoltage volts must be a finite number >= 0"),
            PhysicalFault::OverTemperature { celsius } => {
                (!celsius.is_finite()).then_some("OverTemperature celsius must be finite")
            }
        }
    }
}

impl BusFault {
    fn argument_error(self) -> Option<&'static str> {
        match self {
            BusFault::BusOff { .. } | BusFault::TxStall { .. } | BusFault::HostSilent => None,
        }
    }
}
