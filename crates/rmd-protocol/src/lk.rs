//! LK-TECH V2.3x layouts that differ from v1.61: status 1 (0x9A / 0x9B) and the single-turn
//! angle (0x94).

use crate::bytes::{i16_at, put_i16, put_u16, u16_at};
use crate::error::ProtocolError;
use crate::field::Field;
use crate::status::ErrorState;
use crate::values::{Temperature, wire_value};

wire_value! {
    /// LK-TECH `voltage` of the 0x9A / 0x9B replies: u16 in DATA\[2..=3\], 0.01 V/LSB
    /// (`[LK235-CN]` §二.1: "母线电压voltage（uint16_t类型，单位0.01V/LSB）"; `[pyLKMotor]`).
    ///
    /// Not the scale of v1.61's [`Voltage`](crate::Voltage) (0.1 V/LSB in DATA\[3..=4\]).
    ///
    /// ```
    /// use rmd_protocol::LkVoltage;
    /// assert_eq!(LkVoltage::new(4870).unwrap().volts(), 48.7);
    /// assert_eq!(LkVoltage::from_volts(24.0).unwrap().raw(), 2400);
    /// ```
    LkVoltage(u16), field Field::Voltage, range 0, u16::MAX,
    unit volts / from_volts / from_volts_saturating ("volts"), scale 1 / 100
}

wire_value! {
    /// LK-TECH bus `current` of the 0x9A / 0x9B replies: DATA\[4..=5\], 0.01 A/LSB
    /// (`[LK235-CN]` §二.1: "母线电流current（... 单位0.01A/LSB）").
    ///
    /// The document types it uint16_t; `[pyLKMotor]` reads it as int16_t. rmd-rt reads it signed,
    /// so that a regenerating motor's negative bus current reads right; the two readings agree
    /// below 327.68 A.
    ///
    /// ```
    /// use rmd_protocol::LkBusCurrent;
    /// assert_eq!(LkBusCurrent::new(-150).unwrap().amps(), -1.5);
    /// ```
    LkBusCurrent(i16), field Field::BusCurrent, range i16::MIN, i16::MAX,
    unit amps / from_amps / from_amps_saturating ("amperes"), scale 1 / 100
}

wire_value! {
    /// LK-TECH `circleAngle` of the 0x94 reply: u32 in DATA\[4..=7\], 0.01°/LSB, counted from
    /// the encoder zero (`[LK235-CN]` §二.27: "circleAngle，为uint32_t类型 ... 单位0.01°/LSB，数值范围
    /// 0~36000*减速比-1", i.e. up to 36000 × gear ratio - 1 on geared motors).
    ///
    /// v1.61 sends a u16 in DATA\[6..=7\] instead: decoding an LK 0x94 reply as v1.61 reads the
    /// high half of this value (0 for angles below 655.36°).
    ///
    /// ```
    /// use rmd_protocol::LkCircleAngle;
    /// assert_eq!(LkCircleAngle::new(90_000).unwrap().degrees(), 900.0);
    /// ```
    LkCircleAngle(u32), field Field::CircleAngle, range 0, u32::MAX,
    unit degrees / from_degrees / from_degrees_saturating ("degrees"), scale 1 / 100
}

/// LK-TECH `motorState` (DATA\[6\] of the 0x9A / 0x9B replies): 0x00 motor on, 0x10 motor off
/// (`[LK235-CN]` §二.1, note 1). Other values are kept as received.
///
/// ```
/// use rmd_protocol::LkMotorState;
/// assert!(LkMotorState::OFF.is_off());
/// assert!(LkMotorState::ON.is_on());
/// assert!(!LkMotorState::from_raw(0x42).is_on() && !LkMotorState::from_raw(0x42).is_off());
/// ```
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct LkMotorState(u8);

impl LkMotorState {
    /// 0x00: the motor is on (its output follows commands).
    pub const ON: Self = Self(0x00);
    /// 0x10: the motor is off (after 0x80, or at power-up until 0x88 on some firmware).
    pub const OFF: Self = Self(0x10);

    /// The state from its raw byte.
    pub const fn from_raw(raw: u8) -> Self {
        Self(raw)
    }

    /// The raw byte.
    pub const fn raw(self) -> u8 {
        self.0
    }

    /// Whether the byte says "on" (0x00).
    pub const fn is_on(self) -> bool {
        self.0 == Self::ON.0
    }

    /// Whether the byte says "off" (0x10).
    pub const fn is_off(self) -> bool {
        self.0 == Self::OFF.0
    }
}

/// LK-TECH V2.3x layouts that differ from v1.61: status 1 (0x9A / 0x9B) and the single-turn
/// angle (0x94).
///
/// Sources:
///
/// - `[LK235-CN]`: LK-TECH "电机CAN总线通讯协议（V2.35）" (motor CAN bus protocol V2.35), a
///   Markdown transcription of the manufacturer's document found in the public code index
///   (repository not named by the index; the transcription says parts may be machine-generated),
///   §二.1 "读取电机状态1和错误标志命令" (read motor status 1 and error flags) and §二.27 "读取单圈角度命令"
///   (read single-turn angle).
/// - `[pyLKMotor]`: github.com/han-xudong/pyLKMotor `pylkmotor/LKMotor.py`, `_parse_response_1`:
///   the same status-1 layout, read by a driver for real motors.
/// - `[issue14]`: rmd-rt issue 14: captures from real LK motors of 48.7 V read as 1.9 V by a v1.61
///   decoder, which is what the layout below predicts (0x1306 = 4870 in DATA\[2..=3\]; v1.61 reads
///   DATA\[3..=4\] = 0x0013 = 19 × 0.1 V).
///
/// Older LK firmware answers 0x9A with v1.61's layout (voltage in DATA\[3..=4\] at 0.1 V: e.g.
/// github.com/offisaac/23_Balance_Second `digital_chassis/USP/Drivers/MF9025_v2/MF9025_v2.cpp`,
/// `updateMotorState1`). Such a motor cannot be told from a v1.61 motor by its status 1; see
/// [`identify`](crate::identify()).
///
/// LK-TECH status 1: the reply to 0x9A and 0x9B (`[LK235-CN]` §二.1 and §二.2, `[pyLKMotor]`).
///
/// Layout: DATA\[1\] temperature (int8, 1 °C/LSB), DATA\[2..=3\] voltage (0.01 V/LSB),
/// DATA\[4..=5\] bus current (0.01 A/LSB), DATA\[6\] motor state, DATA\[7\] error state (bit 0 low
/// voltage, bit 3 over-temperature, as in v1.61; `[pyLKMotor]` lists meanings for the other bits
/// on newer firmware, which [`ErrorState`] keeps as raw bits).
///
/// ```
/// use rmd_protocol::{LkStatus1, LkVoltage};
/// // A capture of the shape issue 14 reports: 48.7 V in DATA[2..=3].
/// let data = [0x9A, 30, 0x06, 0x13, 0x00, 0x00, 0x00, 0x00];
/// let s = LkStatus1::from_data(&data)?;
/// assert_eq!(s.voltage, LkVoltage::new(4870)?);
/// assert!(s.motor_state.is_on());
/// let mut out = [0u8; 8];
/// out[0] = 0x9A;
/// s.write_to(&mut out);
/// assert_eq!(out, data);
/// # Ok::<(), rmd_protocol::ProtocolError>(())
/// ```
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct LkStatus1 {
    /// Motor temperature (`temperature`, int8_t, 1 °C/LSB).
    pub temperature: Temperature,
    /// Supply voltage (`voltage`, 0.01 V/LSB).
    pub voltage: LkVoltage,
    /// Bus current (`current`, 0.01 A/LSB).
    pub bus_current: LkBusCurrent,
    /// Motor on / off (`motorState`).
    pub motor_state: LkMotorState,
    /// Protection flags (`errorState`).
    pub error_state: ErrorState,
}

impl LkStatus1 {
    /// Reads DATA\[1..=7\] of a 0x9A / 0x9B reply (DATA\[0\] is not looked at). Every field's
    /// range is its wire type's, so this cannot fail today; it returns a `Result` to keep the
    /// decoders' shape.
    pub fn from_data(d: &[u8; 8]) -> Result<Self, ProtocolError> {
        Ok(Self {
            temperature: Temperature::new(i64::from(d[1] as i8))?,
            voltage: LkVoltage::new(i64::from(u16_at::<2>(d)))?,
            bus_current: LkBusCurrent::new(i64::from(i16_at::<4>(d)))?,
            motor_state: LkMotorState::from_raw(d[6]),
            error_state: ErrorState::from_raw(d[7]),
        })
    }

    /// Writes DATA\[1..=7\] (DATA\[0\], the command byte, is left as it is).
    pub fn write_to(&self, d: &mut [u8; 8]) {
        d[1] = self.temperature.raw() as u8;
        put_u16::<2>(d, self.voltage.raw());
        put_i16::<4>(d, self.bus_current.raw());
        d[6] = self.motor_state.raw();
        d[7] = self.error_state.raw();
    }
}
