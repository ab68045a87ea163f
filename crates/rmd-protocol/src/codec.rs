//! The codec: a [`Dialect`] encodes requests and decodes replies (and the reverse, for the
//! simulator and for logs). Never panics, on any input; allocates nothing.
//!
//! Every encoder checks that the frame belongs to the dialect before building it: the command
//! is one of the family's, every current is in the family's scale, every field the family has
//! (and no other), every motion-mode value packed with the firmware's ranges. So no frame leaves
//! scaled for another family.
//!
//! Every decoder checks, in order: the CAN ID (the family's identifiers for that direction),
//! DLC 8, the command byte (one of the family's), for `decode_reply_to` / `decode_answer` that
//! the reply answers the pending command, then the field ranges. Reserved bytes are ignored.

use crate::command::Command;
use crate::dialect::Dialect;
use crate::error::{ExpectedIds, FrameKind, ProtocolError};
use crate::frame::CanFrame;
use crate::ids::{
    MULTI_TORQUE_CAN_ID, MotorId, V3_MOTION_BASE_ID, V3_MOTION_REPLY_BASE_ID, V3_REPLY_BASE_ID,
    motor_on,
};
use crate::mit::{MitCommand, MitFeedback};
use crate::mit_ranges::MitRanges;
use crate::multi::MultiTorque;
use crate::reply::Reply;
use crate::request::{DecodedRequest, Request};
use crate::status::StatusPosition;
use crate::status1::Status1;
use crate::v3::V3Revision;

/// The 8 data bytes, or [`ProtocolError::WrongDlc`].
#[inline]
fn data8(frame: &CanFrame) -> Result<&[u8; 8], ProtocolError> {
    frame.data8().ok_or(ProtocolError::WrongDlc {
        can_id: frame.id(),
        dlc: frame.dlc(),
    })
}

impl Dialect {
    /// The command in DATA\[0\] if it is one of this dialect's, else
    /// [`ProtocolError::UnknownCommand`].
    #[inline]
    fn command_of(self, frame: &CanFrame, d: &[u8; 8]) -> Result<Command, ProtocolError> {
        match Command::from_code(d[0]) {
            Some(command) if self.supports(command) => Ok(command),
            _ => Err(ProtocolError::UnknownCommand {
                can_id: frame.id(),
                code: d[0],
            }),
        }
    }

    /// Checks that `request` belongs to this dialect: its command, its current's scale, its
    /// fields.
    pub fn check_request(self, request: &Request) -> Result<(), ProtocolError> {
        let command = request.command();
        if !self.supports(command) {
            return Err(ProtocolError::UnsupportedCommand {
                command,
                family: self.family(),
            });
        }
        match *request {
            Request::Torque { iq_control } => {
                iq_control.expect_scale(self.iq_control_scale())?;
            }
            Request::Speed { max_torque, .. }
                if max_torque.is_set() && !matches!(self, Self::MyActuatorV3(_)) =>
            {
                return Err(ProtocolError::UnsupportedField {
                    field: crate::field::Field::MaxTorque,
                    family: self.family(),
                });
            }
            _ => {}
        }
        Ok(())
    }

    /// The frame that sends `request` to `motor` (`0x140 + id`, DLC 8), after
    /// [`check_request`](Self::check_request).
    ///
    /// ```
    /// use rmd_protocol::{CurrentScale, Dialect, MotorId, ProtocolError, Request, ScaledCurrent, V3Firmware};
    /// let v3 = Dialect::MyActuatorV3(V3Firmware::default());
    /// let m1 = MotorId::new(1)?;
    /// // V4.3 §2.19 / V4.4 §2.18: 1 A is 100 at 0.01 A per LSB.
    /// let one_amp = ScaledCurrent::from_amps(1.0, v3.iq_control_scale())?;
    /// let frame = v3.encode(m1, &Request::Torque { iq_control: one_amp })?;
    /// assert_eq!(frame.to_string(), "141#A100000064000000");
    /// // The same current in v1.61's scale is refused: it would run at another current.
    /// assert!(matches!(Dialect::V161.encode(m1, &Request::Torque { iq_control: one_amp }),
    ///     Err(ProtocolError::ScaleMismatch { .. })));
    /// // v1.61's clear-error is not a V3 command.
    /// assert!(matches!(v3.encode(m1, &Request::ClearError),
    ///     Err(ProtocolError::UnsupportedCommand { .. })));
    /// # Ok::<(), ProtocolError>(())
    /// ```
    #[inline]
    pub fn encode(self, motor: MotorId, request: &Request) -> Result<CanFrame, ProtocolError> {
        self.check_request(request)?;
        Ok(CanFrame::rmd(motor.can_id(), request.to_data()))
    }

    /// The motor-off frame (0x80, no fields) to `motor`: every family has it, in the same bytes,
    /// so it cannot fail (v1.61 "motor off"; LK-TECH V2.35 motor off; V3 V4.3 §2.17, V4.4
    /// §2.16). What a safe stop sends.
    ///
    /// ```
    /// use rmd_protocol::{Dialect, MotorId, Request, V3Firmware};
    /// let m = MotorId::new(3)?;
    /// for d in [Dialect::V161, Dialect::MyActuatorV3(V3Firmware::default())] {
    ///     assert_eq!(Ok(d.motor_off(m)), d.encode(m, &Request::MotorOff));
    /// }
    /// # Ok::<(), rmd_protocol::ProtocolError>(())
    /// ```
    #[inline]
    pub const fn motor_off(self, motor: MotorId) -> CanFrame {
        CanFrame::rmd(motor.can_id(), Request::MotorOff.to_data())
    }

    /// The MyActuator V3 0x280 frame that has every motor of the bus execute `request` (V4.3
    /// §3, V4.4 §3: "multiple motors respond to the same command at the same time"; each
    /// answers on its own `0x240 + id`). Motors with the CAN ID filter on (0x20 index 2) do not
    /// receive it. [`ProtocolError::UnsupportedFrame`] in v1.61 and LK-TECH, whose 0x280 frame
    /// is torque ([`encode_multi_torque`](Self::encode_multi_torque)).
    pub fn encode_broadcast(self, request: &Request) -> Result<CanFrame, ProtocolError> {
        if !matches!(self, Self::MyActuatorV3(_)) {
            return Err(ProtocolError::UnsupportedFrame {
                kind: FrameKind::Broadcast,
                family: self.family(),
            });
        }
        self.check_request(request)?;
        Ok(CanFrame::rmd(MULTI_TORQUE_CAN_ID, request.to_data()))
    }

    /// The v1.61 / LK-TECH 0x280 torque frame, after checking that every current uses this
    /// dialect's `iqControl` scale. [`ProtocolError::UnsupportedFrame`] for MyActuator V3, where
    /// 0x280 carries one command for every motor: a torque-shaped 0x280 would be read there as
    /// the command byte in DATA\[0\].
    pub fn encode_multi_torque(self, frame: &MultiTorque) -> Result<CanFrame, ProtocolError> {
        if !self.multi_torque_is_per_motor_torque() {
            return Err(ProtocolError::UnsupportedFrame {
                kind: FrameKind::MultiTorque,
                family: self.family(),
            });
        }
        let scale = self.iq_control_scale();
        for current in frame.iq_control {
            current.expect_scale(scale)?;
        }
        Ok(frame.encode())
    }

    /// The motion-mode ranges of this dialect: V3's firmware's ([`V3Firmware::mit_ranges`](
    /// crate::V3Firmware::mit_ranges)); [`ProtocolError::UnsupportedFrame`] in other families.
    pub const fn mit_ranges(self) -> Result<MitRanges, ProtocolError> {
        match self {
            Self::MyActuatorV3(firmware) => firmware.mit_ranges(),
            Self::V161 | Self::LkV23x(_) => Err(ProtocolError::UnsupportedFrame {
                kind: FrameKind::Motion,
                family: self.family(),
            }),
        }
    }

    /// The motion-mode frame to `motor` on `0x400 + id` (V4.3 §5, V4.4 §4), after checking that
    /// `command` was packed with this firmware's ranges ([`ProtocolError::MitRangesMismatch`]).
    ///
    /// ```
    /// use rmd_protocol::{Dialect, MitCommand, MotorId, V3Firmware};
    /// let v3 = Dialect::MyActuatorV3(V3Firmware::default());
    /// let c = MitCommand::from_si(v3.mit_ranges()?, 10.0, 1.021, 10.012, 1.0, 10.004)?;
    /// assert_eq!(v3.encode_mit(MotorId::new(1)?, &c)?.to_string(), "401#E66682E052333B55");
    /// # Ok::<(), rmd_protocol::ProtocolError>(())
    /// ```
    pub fn encode_mit(
        self,
        motor: MotorId,
        command: &MitCommand,
    ) -> Result<CanFrame, ProtocolError> {
        self.expect_mit_ranges(command.ranges())?;
        Ok(CanFrame::rmd(
            V3_MOTION_BASE_ID + motor.get() as u16,
            command.to_data(),
        ))
    }

    fn expect_mit_ranges(self, got: MitRanges) -> Result<(), ProtocolError> {
        let expected = self.mit_ranges()?;
        if expected == got {
            Ok(())
        } else {
            Err(ProtocolError::MitRangesMismatch { expected, got })
        }
    }

    /// The frame of any decoded host frame (the inverse of
    /// [`decode_request`](Self::decode_request)), through the encoder of its kind.
    pub fn encode_request(self, request: &DecodedRequest) -> Result<CanFrame, ProtocolError> {
        match request {
            DecodedRequest::Single { motor, request } => self.encode(*motor, request),
            DecodedRequest::Multi(m) => self.encode_multi_torque(m),
            DecodedRequest::Broadcast(request) => self.encode_broadcast(request),
            DecodedRequest::Mit { motor, command } => self.encode_mit(*motor, command),
        }
    }

    /// Decodes a frame sent by the host (to read logs, and for the simulator): a single-motor
    /// request on `0x140 + id`; the 0x280 frame (v1.61 / LK-TECH: four torque currents in this
    /// dialect's scale; V3: one request for every motor); a V3 motion-mode command on
    /// `0x400 + id`.
    ///
    /// ```
    /// use rmd_protocol::{CanFrame, DecodedRequest, Dialect, Request};
    /// let frame = CanFrame::new(0x141, &[0xA1, 0, 0, 0, 0x64, 0, 0, 0])?;
    /// let DecodedRequest::Single { motor, request } = Dialect::V161.decode_request(&frame)? else {
    ///     unreachable!()
    /// };
    /// assert_eq!(motor.get(), 1);
    /// assert!(matches!(request, Request::Torque { iq_control } if iq_control.amps() == 1.6));
    /// # Ok::<(), rmd_protocol::ProtocolError>(())
    /// ```
    #[inline]
    pub fn decode_request(self, frame: &CanFrame) -> Result<DecodedRequest, ProtocolError> {
        let id = frame.id();
        if id == MULTI_TORQUE_CAN_ID {
            let d = data8(frame)?;
            return match self {
                Self::V161 | Self::LkV23x(_) => Ok(DecodedRequest::Multi(MultiTorque::from_data(
                    d,
                    self.iq_control_scale(),
                )?)),
                Self::MyActuatorV3(_) => {
                    let command = self.command_of(frame, d)?;
                    Ok(DecodedRequest::Broadcast(Request::from_data(
                        command, d, self,
                    )?))
                }
            };
        }
        if let Self::MyActuatorV3(_) = self
            && let Ok(motor) = motor_on(id, V3_MOTION_BASE_ID, ExpectedIds::MyActuatorV3Request)
        {
            let d = data8(frame)?;
            return Ok(DecodedRequest::Mit {
                motor,
                command: MitCommand::from_data(self.mit_ranges()?, d),
            });
        }
        let motor = MotorId::from_can_id(id).map_err(|_| ProtocolError::UnexpectedCanId {
            can_id: id,
            expected: match self {
                Self::V161 | Self::LkV23x(_) => ExpectedIds::MotorOrMultiTorque,
                Self::MyActuatorV3(_) => ExpectedIds::MyActuatorV3Request,
            },
        })?;
        let d = data8(frame)?;
        let command = self.command_of(frame, d)?;
        Ok(DecodedRequest::Single {
            motor,
            request: Request::from_data(command, d, self)?,
        })
    }

    /// Checks that `reply` can be sent by a motor of this dialect: its command and layout.
    fn check_reply(self, reply: &Reply) -> Result<(), ProtocolError> {
        let command = reply.command();
        let not_here = |from| ProtocolError::NotRepresentable {
            command,
            from,
            to: self.family(),
        };
        if !self.supports(command) {
            return Err(ProtocolError::UnsupportedCommand {
                command,
                family: self.family(),
            });
        }
        if let Some(status) = reply.status1() {
            let from = match status {
                Status1::V161(_) => Self::V161,
                Status1::Lk(_) => Self::LkV23x(crate::dialect::LkSeries::Mg),
                Status1::V3(_) => Self::MyActuatorV3(crate::v3::V3Firmware::default()),
            };
            if from.family() != self.family() {
                return Err(not_here(from.family()));
            }
        }
        if let Some(status) = reply.status2() {
            status.iq.expect_scale(self.iq_scale())?;
            let output = matches!(status.position, StatusPosition::OutputDegrees(_));
            if output != self.reports_output_shaft() {
                return Err(not_here(if output {
                    crate::family::ProtocolFamily::MyActuatorV3
                } else {
                    crate::family::ProtocolFamily::V161
                }));
            }
        }
        let single_turn_family = match (reply, self) {
            (Reply::LkSingleTurnAngle { .. }, Self::LkV23x(_)) => None,
            (Reply::LkSingleTurnAngle { .. }, _) => Some(crate::family::ProtocolFamily::LkV23x),
            (Reply::V3SingleTurnAngle { .. }, Self::MyActuatorV3(f))
                if f.revision() == V3Revision::V4_4 =>
            {
                None
            }
            (Reply::V3SingleTurnAngle { .. }, _) => {
                Some(crate::family::ProtocolFamily::MyActuatorV3)
            }
            (Reply::ReadSingleTurnAngle { .. }, Self::LkV23x(_)) => {
                Some(crate::family::ProtocolFamily::V161)
            }
            (Reply::ReadSingleTurnAngle { .. }, Self::MyActuatorV3(f))
                if f.revision() == V3Revision::V4_4 =>
            {
                Some(crate::family::ProtocolFamily::V161)
            }
            _ => None,
        };
        if let Some(from) = single_turn_family {
            return Err(not_here(from));
        }
        if let (Reply::ReadMultiTurnAngle { motor_angle }, Self::MyActuatorV3(_)) = (reply, self)
            && i32::try_from(motor_angle.raw()).is_err()
        {
            return Err(ProtocolError::ValueOutOfRange {
                field: crate::field::Field::MotorAngle,
                value: motor_angle.raw(),
                min: i64::from(i32::MIN),
                max: i64::from(i32::MAX),
            });
        }
        Ok(())
    }

    /// The frame `motor` answers with `reply` (on [`reply_id`](Self::reply_id)): the
    /// simulator's side. Checks that the reply belongs to this dialect (its command, its
    /// layout, its current's scale) first.
    pub fn encode_reply(self, motor: MotorId, reply: &Reply) -> Result<CanFrame, ProtocolError> {
        self.check_reply(reply)?;
        Ok(CanFrame::rmd(self.reply_id(motor), reply.to_data(self)))
    }

    /// The motion-mode reply frame of `motor` on `0x500 + id`, after checking its ranges.
    pub fn encode_mit_reply(
        self,
        motor: MotorId,
        feedback: &MitFeedback,
    ) -> Result<CanFrame, ProtocolError> {
        self.expect_mit_ranges(feedback.ranges())?;
        Ok(CanFrame::rmd(
            V3_MOTION_REPLY_BASE_ID + motor.get() as u16,
            feedback.to_data(motor.get()),
        ))
    }

    /// The motor that sent `frame`, by its identifier: `0x140 + id` (v1.61, LK-TECH) or
    /// `0x240 + id` (V3).
    #[inline]
    fn replying_motor(self, can_id: u16) -> Result<MotorId, ProtocolError> {
        match self {
            Self::V161 | Self::LkV23x(_) => MotorId::from_can_id(can_id),
            Self::MyActuatorV3(_) => {
                motor_on(can_id, V3_REPLY_BASE_ID, ExpectedIds::MyActuatorV3Reply)
            }
        }
    }

    /// The command byte of a reply, if it is one of this dialect's replies (0x76 has none).
    #[inline]
    fn reply_command_of(self, frame: &CanFrame, d: &[u8; 8]) -> Result<Command, ProtocolError> {
        match self.command_of(frame, d)? {
            Command::Reset => Err(ProtocolError::UnknownCommand {
                can_id: frame.id(),
                code: d[0],
            }),
            command => Ok(command),
        }
    }

    /// Decodes a frame sent by a motor, whatever request it answers.
    ///
    /// In v1.61 and LK-TECH a frame with DATA\[0\] = 0x9A decodes as [`Reply::ReadStatus1`]; use
    /// [`decode_reply_to`](Self::decode_reply_to) to read it as the answer to a pending 0x9B.
    #[inline]
    pub fn decode_reply(self, frame: &CanFrame) -> Result<(MotorId, Reply), ProtocolError> {
        let motor = self.replying_motor(frame.id())?;
        let d = data8(frame)?;
        let command = self.reply_command_of(frame, d)?;
        Ok((motor, Reply::from_data(command, d, self)?))
    }

    /// Decodes a frame sent by a motor as the reply to the pending request `pending` (for a
    /// v1.61 / LK-TECH 0x280 frame, [`Command::Torque`]).
    ///
    /// Like [`decode_reply`](Self::decode_reply), and rejects a reply to another command with
    /// [`ProtocolError::ReplyMismatch`] (checked before the field ranges). As v1.61's reading
    /// notes require, DATA\[0\] = 0x9A is accepted as the reply to a pending 0x9B (the spec's
    /// table shows 0x9A there) and decodes as [`Reply::ClearError`]. MyActuator V3 accepts
    /// only the pending command's own byte: a V3 motor answers a command it does not know with
    /// its previous reply (github.com/2b-t/myactuator_rmd issue 24: a 0x79 request answered
    /// with a stale 0xB2 reply). It does not check which motor answered: see
    /// [`decode_answer`](Self::decode_answer).
    ///
    /// ```
    /// use rmd_protocol::{CanFrame, Command, Dialect, ProtocolError, Reply};
    /// let status1 = CanFrame::new(0x141, &[0x9A, 30, 0, 0xF0, 0, 0, 0, 0])?;
    /// let (_, reply) = Dialect::V161.decode_reply_to(&status1, Command::ClearError)?;
    /// assert!(matches!(reply, Reply::ClearError(s) if s.volts() == 24.0));
    /// assert!(matches!(
    ///     Dialect::V161.decode_reply_to(&status1, Command::Torque),
    ///     Err(ProtocolError::ReplyMismatch { .. })
    /// ));
    /// # Ok::<(), ProtocolError>(())
    /// ```
    #[inline]
    pub fn decode_reply_to(
        self,
        frame: &CanFrame,
        pending: Command,
    ) -> Result<(MotorId, Reply), ProtocolError> {
        let motor = self.replying_motor(frame.id())?;
        let d = data8(frame)?;
        let got = self.reply_command_of(frame, d)?;
        let command = self.answered_command(frame, got, pending)?;
        Ok((motor, Reply::from_data(command, d, self)?))
    }

    /// Decodes `frame` as `motor`'s answer to `pending`: the identifier must be `motor`'s
    /// [`reply_id`](Self::reply_id) ([`ProtocolError::UnexpectedCanId`] otherwise), then as
    /// [`decode_reply_to`](Self::decode_reply_to). The one question a control loop asks of
    /// each frame; allocation-free.
    ///
    /// ```
    /// use rmd_protocol::{CanFrame, Command, Dialect, MotorId, V3Firmware};
    /// let v3 = Dialect::MyActuatorV3(V3Firmware::default());
    /// // V4.3 §2.19: the reply to the 1 A request, from motor 1.
    /// let frame = CanFrame::new(0x241, &[0xA1, 0x32, 0x64, 0x00, 0xF4, 0x01, 0x2D, 0x00])?;
    /// let reply = v3.decode_answer(&frame, MotorId::new(1)?, Command::Torque)?;
    /// let s = reply.status2().unwrap();
    /// assert_eq!((s.iq.amps(), s.speed.dps()), (1.0, 500.0));
    /// // Not motor 2's answer, and not the answer to 0x9C.
    /// assert!(v3.decode_answer(&frame, MotorId::new(2)?, Command::Torque).is_err());
    /// assert!(v3.decode_answer(&frame, MotorId::new(1)?, Command::ReadStatus2).is_err());
    /// # Ok::<(), rmd_protocol::ProtocolError>(())
    /// ```
    #[inline]
    pub fn decode_answer(
        self,
        frame: &CanFrame,
        motor: MotorId,
        pending: Command,
    ) -> Result<Reply, ProtocolError> {
        let expected = self.reply_id(motor);
        if frame.id() != expected {
            return Err(ProtocolError::UnexpectedCanId {
                can_id: frame.id(),
                expected: ExpectedIds::ReplyOf(expected),
            });
        }
        self.decode_reply_to(frame, pending).map(|(_, reply)| reply)
    }

    /// The command a reply carrying `got` answers when `pending` is waiting: `got` itself, or
    /// (v1.61, LK-TECH) 0x9B for a 0x9A reply to a pending 0x9B; else
    /// [`ProtocolError::ReplyMismatch`].
    #[inline]
    fn answered_command(
        self,
        frame: &CanFrame,
        got: Command,
        pending: Command,
    ) -> Result<Command, ProtocolError> {
        if got == pending {
            Ok(got)
        } else if pending == Command::ClearError && got == Command::ReadStatus1 {
            Ok(Command::ClearError)
        } else {
            Err(ProtocolError::ReplyMismatch {
                can_id: frame.id(),
                expected: pending,
                got,
            })
        }
    }

    /// Decodes a MyActuator V3 motion-mode reply (`0x500 + id`; DATA\[0\] must name the same
    /// motor, [`ProtocolError::MotorIdMismatch`] otherwise), read with the firmware's ranges.
    ///
    /// ```
    /// use rmd_protocol::{CanFrame, Dialect, V3Firmware};
    /// let v3 = Dialect::MyActuatorV3(V3Firmware::default());
    /// // V4.3 §5.4's reply: 10 rad, 1.021 rad/s, 10.004 N·m.
    /// let frame = CanFrame::new(0x501, &[0x01, 0xE6, 0x66, 0x82, 0xEB, 0x55, 0x00, 0x00])?;
    /// let (motor, feedback) = v3.decode_mit_reply(&frame)?;
    /// assert_eq!(motor.get(), 1);
    /// assert!((feedback.torque_nm() - 10.004).abs() < 1e-3);
    /// # Ok::<(), rmd_protocol::ProtocolError>(())
    /// ```
    pub fn decode_mit_reply(
        self,
        frame: &CanFrame,
    ) -> Result<(MotorId, MitFeedback), ProtocolError> {
        let ranges = self.mit_ranges()?;
        let motor = motor_on(
            frame.id(),
            V3_MOTION_REPLY_BASE_ID,
            ExpectedIds::MyActuatorV3MotionReply,
        )?;
        let d = data8(frame)?;
        if d[0] != motor.get() {
            return Err(ProtocolError::MotorIdMismatch {
                can_id: frame.id(),
                data_id: d[0],
            });
        }
        Ok((motor, MitFeedback::from_data(ranges, d)))
    }
}
