//! A reply of one family in another family's shape: exactly, or as near as that family can say
//! it. The one place rmd-rt converts between families (a tool that prints v1.61 replies can show
//! an LK-TECH motor's through [`Conversion::Nearest`]).

use crate::command::Command;
use crate::current::ScaledCurrent;
use crate::dialect::Dialect;
use crate::error::ProtocolError;
use crate::reply::Reply;
use crate::status::{ErrorState, Status2, V161Status1};
use crate::status1::Status1;
use crate::v3::V3ErrorState;
use crate::values::{CircleAngle, Voltage};

/// How [`Dialect::convert_reply`] carries a value the target family writes differently.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum Conversion {
    /// Only exact conversions: the same raw meaning, or an error
    /// ([`ProtocolError::ScaleMismatch`], [`ProtocolError::NotRepresentable`]).
    Exact,
    /// The nearest value the target family can carry, dropping what it has no field for (see
    /// [`Dialect::convert_reply`] for each rule).
    Nearest,
}

impl Dialect {
    /// `reply`, decoded in this dialect, in the shape and scales of `to`.
    ///
    /// Replies whose layout both families share pass unchanged. Otherwise:
    ///
    /// | reply | exact | nearest |
    /// |---|---|---|
    /// | status 2, `iq` in another scale | [`ProtocolError::ScaleMismatch`] | the nearest step of `to`'s scale, clamped |
    /// | status 1, LK-TECH to v1.61 | not representable | voltage to 0.1 V; bus current and motor state dropped |
    /// | status 1, V3 to v1.61 | not representable | voltage (same 0.1 V); low voltage and motor over-temperature to v1.61's two flags, other flags and MOS temperature and brake dropped |
    /// | single-turn angle, LK-TECH to v1.61 | not representable | within one turn (`raw mod 36000`), as v1.61's `circleAngle` |
    /// | single-turn angle, any other change of family | not representable | not representable |
    ///
    /// Never converted ([`ProtocolError::NotRepresentable`] in both modes): a V3 output-shaft
    /// angle or speed to a motor-side family or back (the gear ratio is not in the frame), a
    /// status 1 into a layout with fields the source lacks (v1.61 to LK-TECH or V3). A command
    /// `to` does not have is [`ProtocolError::UnsupportedCommand`].
    ///
    /// ```
    /// use rmd_protocol::{CanFrame, Conversion, Dialect, LkSeries, ProtocolError};
    /// let mf = Dialect::LkV23x(LkSeries::Mf);
    /// // An LK MF status 2: iq 1024 = 8.25 A at 16.5 A over 2048.
    /// let frame = CanFrame::new(0x141, &[0x9C, 30, 0x00, 0x04, 0, 0, 0, 0])?;
    /// let (_, reply) = mf.decode_reply(&frame)?;
    /// assert!(matches!(mf.convert_reply(&reply, Dialect::V161, Conversion::Exact),
    ///     Err(ProtocolError::ScaleMismatch { .. })));
    /// let v161 = mf.convert_reply(&reply, Dialect::V161, Conversion::Nearest)?;
    /// assert_eq!(v161.status2().unwrap().iq.raw(), 512); // 8.25 A at 33 A over 2048
    /// # Ok::<(), ProtocolError>(())
    /// ```
    pub fn convert_reply(
        self,
        reply: &Reply,
        to: Dialect,
        how: Conversion,
    ) -> Result<Reply, ProtocolError> {
        let command = reply.command();
        if !to.supports(command) {
            return Err(ProtocolError::UnsupportedCommand {
                command,
                family: to.family(),
            });
        }
        let not_representable = ProtocolError::NotRepresentable {
            command,
            from: self.family(),
            to: to.family(),
        };
        let nearest = how == Conversion::Nearest;
        Ok(match *reply {
            Reply::ReadStatus1(s) => Reply::ReadStatus1(self.status1_to(s, to, nearest)?),
            Reply::ClearError(s) => Reply::ClearError(self.status1_to(s, to, nearest)?),
            Reply::ReadStatus2(s) => Reply::ReadStatus2(self.status2_to(s, command, to, how)?),
            Reply::Torque(s) => Reply::Torque(self.status2_to(s, command, to, how)?),
            Reply::Speed(s) => Reply::Speed(self.status2_to(s, command, to, how)?),
            Reply::Position1(s) => Reply::Position1(self.status2_to(s, command, to, how)?),
            Reply::Position2(s) => Reply::Position2(self.status2_to(s, command, to, how)?),
            Reply::Position3(s) => Reply::Position3(self.status2_to(s, command, to, how)?),
            Reply::Position4(s) => Reply::Position4(self.status2_to(s, command, to, how)?),
            Reply::ReadMultiTurnAngle { .. }
                if self.reports_output_shaft() != to.reports_output_shaft() =>
            {
                return Err(not_representable);
            }
            Reply::LkSingleTurnAngle { circle_angle } => match to {
                Dialect::LkV23x(_) => *reply,
                Dialect::V161 if nearest => Reply::ReadSingleTurnAngle {
                    circle_angle: CircleAngle::new(i64::from(circle_angle.raw() % 36_000))?,
                },
                _ => return Err(not_representable),
            },
            Reply::V3SingleTurnAngle { .. } | Reply::ReadSingleTurnAngle { .. }
                if self.family() != to.family() =>
            {
                // Other layouts or other shafts (V3's is the output's, v1.61's the motor's).
                return Err(not_representable);
            }
            other => other,
        })
    }

    fn status1_to(self, s: Status1, to: Dialect, nearest: bool) -> Result<Status1, ProtocolError> {
        let not_representable = ProtocolError::NotRepresentable {
            command: Command::ReadStatus1,
            from: self.family(),
            to: to.family(),
        };
        Ok(match (s, to) {
            (Status1::V161(_), Dialect::V161)
            | (Status1::Lk(_), Dialect::LkV23x(_))
            | (Status1::V3(_), Dialect::MyActuatorV3(_)) => s,
            (Status1::Lk(lk), Dialect::V161) if nearest => Status1::V161(V161Status1 {
                temperature: lk.temperature,
                voltage: Voltage::from_volts_saturating(lk.voltage.volts()),
                error_state: lk.error_state,
            }),
            (Status1::V3(v3), Dialect::V161) if nearest => {
                let mut flags = ErrorState::NONE;
                if v3.error_state.contains(V3ErrorState::LOW_VOLTAGE) {
                    flags = flags | ErrorState::LOW_VOLTAGE;
                }
                if v3
                    .error_state
                    .contains(V3ErrorState::MOTOR_OVER_TEMPERATURE)
                {
                    flags = flags | ErrorState::OVER_TEMPERATURE;
                }
                Status1::V161(V161Status1 {
                    temperature: v3.temperature,
                    voltage: v3.voltage,
                    error_state: flags,
                })
            }
            _ => return Err(not_representable),
        })
    }

    fn status2_to(
        self,
        s: Status2,
        command: Command,
        to: Dialect,
        how: Conversion,
    ) -> Result<Status2, ProtocolError> {
        if self.reports_output_shaft() != to.reports_output_shaft() {
            return Err(ProtocolError::NotRepresentable {
                command,
                from: self.family(),
                to: to.family(),
            });
        }
        let scale = to.iq_scale();
        let iq = match how {
            Conversion::Exact => s.iq.expect_scale(scale)?,
            Conversion::Nearest if s.iq.scale().same_as(scale) => s.iq,
            Conversion::Nearest => ScaledCurrent::from_amps_saturating(s.iq.amps(), scale),
        };
        Ok(Status2 { iq, ..s })
    }
}
