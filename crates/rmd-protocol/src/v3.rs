//! MyActuator V3 values: the firmware date and what depends on it, status 1 and its error
//! flags, the watchdog, function control, the model string, and V3's fields of shared commands.

use core::fmt;

use crate::error::ProtocolError;
use crate::field::Field;
use crate::mit_ranges::{MitRanges, MotorMaxTorque};
use crate::values::{Temperature, Voltage, wire_value};

/// The firmware version date a V3 motor reports to 0xB2 (`VersionDate`, u32 in DATA\[4..=7\];
/// V4.3 §2.30, V4.4 §2.31), kept as received.
///
/// The manuals write it `YYYYMMDD` (example reply `0x0134892E` = 20220206); motors in the field
/// report ten digits, `YYYYMMDDNN` (2025070202: github.com/2b-t/myactuator_rmd issue 24, an
/// X4-64, and issue 28, an X4-36). Comparisons use ten digits: an eight-digit date is read as
/// `YYYYMMDD00`.
///
/// ```
/// use rmd_protocol::{FirmwareDate, V3Revision};
/// assert_eq!(FirmwareDate::from_raw(2025070202).revision(), V3Revision::V4_3);
/// assert_eq!(FirmwareDate::from_raw(2026042402).revision(), V3Revision::V4_4);
/// assert_eq!(FirmwareDate::from_raw(20220206).ten_digits(), 2022020600);
/// ```
#[derive(Copy, Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct FirmwareDate(u32);

impl FirmwareDate {
    /// The first firmware that packs the motion-mode command with V4.4's ranges: 2026042402.
    /// Source: github.com/almond-bot/axol `almond_axol/motor/myactuator.py` (HEAD 3d3c09c),
    /// `_MA_FW_V44_VERSION = 2026042402`: "MyActuator firmware dated 2026042402 (VersionDate)
    /// and later implements protocol V4.4, which widened several MIT-command ranges". The
    /// manuals themselves name no firmware date.
    pub const FIRST_V4_4: Self = Self(2_026_042_402);

    /// The date as 0xB2 carries it.
    pub const fn from_raw(raw: u32) -> Self {
        Self(raw)
    }

    /// The raw `VersionDate`.
    pub const fn raw(self) -> u32 {
        self.0
    }

    /// The date as ten digits `YYYYMMDDNN` (an eight-digit `YYYYMMDD` gets `00`).
    pub const fn ten_digits(self) -> u64 {
        if self.0 < 100_000_000 {
            self.0 as u64 * 100
        } else {
            self.0 as u64
        }
    }

    /// Which manual revision this firmware follows where V4.3 and V4.4 differ: V4.4 from
    /// [`FIRST_V4_4`](Self::FIRST_V4_4) on.
    ///
    /// Only the motion-mode ranges are documented to change with this date (axol, above). That
    /// V4.4's other changes (0x94 as a signed i32, 0xB5 read in three parts) come with the same
    /// firmware is an assumption: the manuals give no firmware date for any change.
    pub const fn revision(self) -> V3Revision {
        if self.ten_digits() >= Self::FIRST_V4_4.ten_digits() {
            V3Revision::V4_4
        } else {
            V3Revision::V4_3
        }
    }
}

impl fmt::Display for FirmwareDate {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.0)
    }
}

/// The manual revision a V3 firmware follows where the V4.3 and V4.4 manuals differ.
///
/// | | V4.3 (and V4.2) | V4.4 |
/// |---|---|---|
/// | 0x94 reply | u16 in DATA\[6..=7\], 0..=35999 (V4.3 §2.13) | i32 in DATA\[4..=7\], ±18000 (±180°, V4.4 §2.12) |
/// | 0xB5 | 7 characters in DATA\[1..=7\] (V4.3 §2.33) | index 1..=3 in DATA\[2\], 5 characters in DATA\[3..=7\] (V4.4 §2.34) |
/// | motion mode | [`MitRanges::V4_3`] | [`MitRanges::v4_4`] |
#[derive(Copy, Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[allow(non_camel_case_types)]
pub enum V3Revision {
    /// Manual V4.3 (2025.05) and V4.2 (2024.05).
    V4_3,
    /// Manual V4.4 (2025.09, revised 2026.03.25).
    V4_4,
}

/// Formats as the manual's version, `V4.3` or `V4.4`.
impl fmt::Display for V3Revision {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::V4_3 => "V4.3",
            Self::V4_4 => "V4.4",
        })
    }
}

/// MyActuator V3 values: the firmware date and what depends on it, status 1 and its error
/// flags, the watchdog, function control, the model string, and the fields V3 adds to commands
/// v1.61 also has.
///
/// Sources, cited at each item as `V4.3 §n` / `V4.4 §n`: MyActuator "Servo Motor Control
/// Protocol", applicable driver V3, version V4.3 (2025.05) and version V4.4 (2025.09, changelog
/// revision 2026.03.25), public Markdown transcriptions of the manufacturer's PDFs (the V4.4 one
/// made from `CAN BUS Motor Motion Protocol V4.4 260425.pdf`), cross-checked with V4.2
/// (2024.05, "Motor Motion Protocol V4.2-250208.pdf"). Section numbers differ between the two:
/// V4.4 removed 0x90, so most of its §2 numbers are V4.3's minus one.
///
/// What rmd-rt knows of one V3 motor's firmware: its date (which decides the V4.3 / V4.4
/// layouts and ranges) and its maximum torque (V4.4's motion-mode torque range).
///
/// Without a date the V4.3 layouts and ranges are assumed: every firmware reported in the
/// field so far (2025070202) predates V4.4. Read the date with 0xB2 before relying on it.
///
/// ```
/// use rmd_protocol::{FirmwareDate, MitRanges, MotorMaxTorque, V3Firmware, V3Revision};
/// assert_eq!(V3Firmware::default().revision(), V3Revision::V4_3);
/// assert_eq!(V3Firmware::default().mit_ranges(), Ok(MitRanges::V4_3));
/// let v44 = V3Firmware::dated(FirmwareDate::from_raw(2026050101));
/// assert!(v44.mit_ranges().is_err()); // the maximum torque is missing
/// let x6 = v44.with_max_torque(MotorMaxTorque::from_milli_nm(60_000));
/// assert_eq!(x6.mit_ranges()?.torque_nm(), 60.0);
/// # Ok::<(), rmd_protocol::ProtocolError>(())
/// ```
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct V3Firmware {
    /// The firmware date, if known.
    pub date: Option<FirmwareDate>,
    /// The motor's maximum torque, if known.
    pub max_torque: Option<MotorMaxTorque>,
}

impl V3Firmware {
    /// Firmware of date `date`, maximum torque unknown.
    pub const fn dated(date: FirmwareDate) -> Self {
        Self {
            date: Some(date),
            max_torque: None,
        }
    }

    /// The same firmware on a motor of maximum torque `max_torque`.
    pub const fn with_max_torque(mut self, max_torque: MotorMaxTorque) -> Self {
        self.max_torque = Some(max_torque);
        self
    }

    /// The manual revision it follows (V4.3 without a date).
    pub const fn revision(self) -> V3Revision {
        match self.date {
            Some(date) => date.revision(),
            None => V3Revision::V4_3,
        }
    }

    /// The motion-mode ranges; [`ProtocolError::MissingMaxTorque`] for V4.4 firmware without
    /// the maximum torque.
    pub const fn mit_ranges(self) -> Result<MitRanges, ProtocolError> {
        match (self.revision(), self.max_torque) {
            (V3Revision::V4_3, _) => Ok(MitRanges::V4_3),
            (V3Revision::V4_4, Some(max)) => Ok(MitRanges::v4_4(max)),
            (V3Revision::V4_4, None) => Err(ProtocolError::MissingMaxTorque),
        }
    }
}

impl MotorMaxTorque {
    /// A maximum torque in N·m, rounded to the milli-N·m; [`ProtocolError::NotFinite`], or
    /// [`ProtocolError::ValueOutOfRange`] unless above 0 and at most 4 000 000 N·m.
    pub fn from_nm(nm: f64) -> Result<Self, ProtocolError> {
        if !nm.is_finite() {
            return Err(ProtocolError::NotFinite {
                field: Field::MotorMaxTorque,
            });
        }
        let milli = crate::round::round_half_away(nm * 1000.0);
        if !(1..=4_000_000_000).contains(&milli) {
            return Err(ProtocolError::ValueOutOfRange {
                field: Field::MotorMaxTorque,
                value: milli,
                min: 1,
                max: 4_000_000_000,
            });
        }
        Ok(Self::from_milli_nm(milli as u32))
    }
}

/// V3's error flags (`errorState`, u16 in DATA\[6..=7\] of 0x9A; V4.3 §2.14, V4.4 §2.13),
/// OR-combined ("0x0016 = stall + low voltage + over current"). Every bit is kept as received.
///
/// ```
/// use rmd_protocol::V3ErrorState;
/// let e = V3ErrorState::from_raw(0x0016);
/// assert!(e.contains(V3ErrorState::STALL | V3ErrorState::LOW_VOLTAGE | V3ErrorState::OVER_CURRENT));
/// assert_eq!(V3ErrorState::from_raw(0x8001).unknown_bits(), 0x8001);
/// ```
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct V3ErrorState(u16);

impl V3ErrorState {
    /// No flag.
    pub const NONE: Self = Self(0);
    /// 0x0002: motor stall (current above the stall current for the stall time); not
    /// auto-recoverable (V4.4 §2.13), level 1.
    pub const STALL: Self = Self(0x0002);
    /// 0x0004: low voltage; clears itself above the undervoltage threshold (V4.4 §2.13).
    pub const LOW_VOLTAGE: Self = Self(0x0004);
    /// 0x0008: over voltage; clears itself below the overvoltage threshold (V4.4 §2.13).
    pub const OVER_VOLTAGE: Self = Self(0x0008);
    /// 0x0010: phase over current; latched (V4.4 §2.13).
    pub const OVER_CURRENT: Self = Self(0x0010);
    /// 0x0040: power overrun.
    pub const POWER_OVERRUN: Self = Self(0x0040);
    /// 0x0080: calibration parameter writing error.
    pub const CALIBRATION_WRITE: Self = Self(0x0080);
    /// 0x0100: over speed; clears itself below the maximum speed (V4.4 §2.13).
    pub const OVER_SPEED: Self = Self(0x0100);
    /// 0x0800: component (PCB) over-temperature, above 110 °C; clears below 90 °C (V4.4 §2.13).
    pub const COMPONENT_OVER_TEMPERATURE: Self = Self(0x0800);
    /// 0x1000: motor (stator) over-temperature; clears below the recovery temperature
    /// (V4.4 §2.13).
    pub const MOTOR_OVER_TEMPERATURE: Self = Self(0x1000);
    /// 0x2000: encoder calibration error; not auto-recoverable (V4.4 §2.13).
    pub const ENCODER_CALIBRATION: Self = Self(0x2000);
    /// 0x4000: encoder data error; not auto-recoverable (V4.4 §2.13; added in V4.3, §9).
    pub const ENCODER_DATA: Self = Self(0x4000);
    const KNOWN: u16 = 0x0002
        | 0x0004
        | 0x0008
        | 0x0010
        | 0x0040
        | 0x0080
        | 0x0100
        | 0x0800
        | 0x1000
        | 0x2000
        | 0x4000;

    /// The flags from their raw value.
    pub const fn from_raw(raw: u16) -> Self {
        Self(raw)
    }

    /// The raw value.
    pub const fn raw(self) -> u16 {
        self.0
    }

    /// Whether every bit of `other` is set.
    pub const fn contains(self, other: Self) -> bool {
        self.0 & other.0 == other.0
    }

    /// Whether no bit is set.
    pub const fn is_clear(self) -> bool {
        self.0 == 0
    }

    /// The bits the manuals give no meaning to.
    pub const fn unknown_bits(self) -> u16 {
        self.0 & !Self::KNOWN
    }
}

impl core::ops::BitOr for V3ErrorState {
    type Output = Self;
    fn bitor(self, rhs: Self) -> Self {
        Self(self.0 | rhs.0)
    }
}

/// DATA\[3\] of V3's 0x9A: the brake command last executed, "1 represents the brake release
/// command, 0 represents the brake lock command" (V4.3 §2.14, V4.4 §2.13). Kept as received.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct BrakeState(u8);

impl BrakeState {
    /// 0: the brake is locked.
    pub const LOCKED: Self = Self(0);
    /// 1: the brake is released.
    pub const RELEASED: Self = Self(1);

    /// The state from its raw byte.
    pub const fn from_raw(raw: u8) -> Self {
        Self(raw)
    }

    /// The raw byte.
    pub const fn raw(self) -> u8 {
        self.0
    }

    /// Whether the byte says released (1).
    pub const fn is_released(self) -> bool {
        self.0 == 1
    }
}

/// V3 status 1, the reply to 0x9A (V4.3 §2.14, V4.4 §2.13; identical in both): DATA\[1\] motor
/// temperature, DATA\[2\] MOS temperature, DATA\[3\] brake, DATA\[4..=5\] voltage (0.1 V),
/// DATA\[6..=7\] error flags.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct V3Status1 {
    /// Motor temperature, DATA\[1\], int8, 1 °C/LSB.
    pub temperature: Temperature,
    /// Driver (MOS) temperature, DATA\[2\].
    pub mos_temperature: Temperature,
    /// The brake command last executed, DATA\[3\].
    pub brake: BrakeState,
    /// Supply voltage, DATA\[4..=5\], 0.1 V/LSB.
    pub voltage: Voltage,
    /// Error flags, DATA\[6..=7\].
    pub error_state: V3ErrorState,
}

/// `maxTorque` of V3's 0xA2 (DATA\[1\]): the torque limit in percent of the rated current,
/// 0..=255 (V4.3 §2.20, V4.4 §2.19). 0 (or a value above the stall current) sets no limit: the
/// configured stall current applies. v1.61 and LK-TECH have no such field (DATA\[1\] is
/// reserved): a request for them must leave it at [`NONE`](Self::NONE).
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct MaxTorquePercent(u8);

impl MaxTorquePercent {
    /// No limit (0).
    pub const NONE: Self = Self(0);

    /// A limit of `percent` % of the rated current (0: none).
    pub const fn new(percent: u8) -> Self {
        Self(percent)
    }

    /// The raw byte (percent).
    pub const fn raw(self) -> u8 {
        self.0
    }

    /// Whether a limit is set.
    pub const fn is_set(self) -> bool {
        self.0 != 0
    }
}

/// The communication-interruption protection time of 0xB3 (`CanRecvTime_MS`, u32 ms in
/// DATA\[4..=7\]; V4.3 §2.31, V4.4 §2.32): when no frame arrives for longer, "the drive cuts off
/// the output and locks the brake. To run again, stable and continuous communication must first
/// be re-established" (V4.4). 0 disables it. Stored in ROM; "avoid writing this parameter right
/// when the motor has just started or is in motion".
///
/// ```
/// use rmd_protocol::WatchdogTimeout;
/// assert_eq!(WatchdogTimeout::from_millis(1000).millis(), 1000);
/// assert!(WatchdogTimeout::OFF.is_off());
/// ```
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct WatchdogTimeout(u32);

impl WatchdogTimeout {
    /// Protection off (0).
    pub const OFF: Self = Self(0);

    /// A protection time of `ms` milliseconds (0: off).
    pub const fn from_millis(ms: u32) -> Self {
        Self(ms)
    }

    /// The time in milliseconds (0: off).
    pub const fn millis(self) -> u32 {
        self.0
    }

    /// Whether the protection is off.
    pub const fn is_off(self) -> bool {
        self.0 == 0
    }
}

/// A function of V3's 0x20 function control command, by index (DATA\[1\]; V4.3 §2.35, V4.4
/// §2.36). "The parameter can only be successfully saved to ROM while the motor is disabled."
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum V3Function {
    /// 0x01: clear the multi-turn value, update the zero point and save it; after a restart.
    ClearMultiTurn = 0x01,
    /// 0x02: CAN ID filter, 1 on, 0 off; saved to flash. With the filter on, 0x280 (and 0x300)
    /// frames are not received.
    CanIdFilter = 0x02,
    /// 0x03: error-status transmission, 1 on: a motor in error sends 0x9A every 100 ms.
    ErrorStatusTransmission = 0x03,
    /// 0x04: save the multi-turn value at power-off (0: single-turn mode); after a restart.
    SaveMultiTurnAtPowerOff = 0x04,
    /// 0x05: set the CAN ID (1..=32), saved to ROM, effective after a reboot.
    SetCanId = 0x05,
    /// 0x06: maximum positive angle of position mode, saved to ROM.
    MaxPositiveAngle = 0x06,
    /// 0x07: maximum negative angle of position mode, saved to ROM.
    MaxNegativeAngle = 0x07,
    /// 0x08 (V4.4 only): over/under-voltage and over-speed errors recover automatically.
    ErrorAutoRecovery = 0x08,
}

impl V3Function {
    /// Every function, by index.
    pub const ALL: [Self; 8] = [
        Self::ClearMultiTurn,
        Self::CanIdFilter,
        Self::ErrorStatusTransmission,
        Self::SaveMultiTurnAtPowerOff,
        Self::SetCanId,
        Self::MaxPositiveAngle,
        Self::MaxNegativeAngle,
        Self::ErrorAutoRecovery,
    ];

    /// The function of index `index`; [`ProtocolError::ValueOutOfRange`] for another index.
    pub const fn from_index(index: u8) -> Result<Self, ProtocolError> {
        match index {
            0x01 => Ok(Self::ClearMultiTurn),
            0x02 => Ok(Self::CanIdFilter),
            0x03 => Ok(Self::ErrorStatusTransmission),
            0x04 => Ok(Self::SaveMultiTurnAtPowerOff),
            0x05 => Ok(Self::SetCanId),
            0x06 => Ok(Self::MaxPositiveAngle),
            0x07 => Ok(Self::MaxNegativeAngle),
            0x08 => Ok(Self::ErrorAutoRecovery),
            _ => Err(ProtocolError::ValueOutOfRange {
                field: Field::FunctionIndex,
                value: index as i64,
                min: 1,
                max: 8,
            }),
        }
    }

    /// The index (DATA\[1\]).
    pub const fn index(self) -> u8 {
        self as u8
    }

    /// The kebab-case name.
    pub const fn name(self) -> &'static str {
        match self {
            Self::ClearMultiTurn => "clear-multi-turn",
            Self::CanIdFilter => "can-id-filter",
            Self::ErrorStatusTransmission => "error-status-transmission",
            Self::SaveMultiTurnAtPowerOff => "save-multi-turn-at-power-off",
            Self::SetCanId => "set-can-id",
            Self::MaxPositiveAngle => "max-positive-angle",
            Self::MaxNegativeAngle => "max-negative-angle",
            Self::ErrorAutoRecovery => "error-auto-recovery",
        }
    }

    /// Whether the function writes ROM (flash) per the manuals: 0x01, 0x02, 0x04..=0x07.
    pub const fn writes_flash(self) -> bool {
        !matches!(
            self,
            Self::ErrorStatusTransmission | Self::ErrorAutoRecovery
        )
    }
}

/// A 0x20 function control command or its echo: a function and its value (DATA\[4..=7\], u32).
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub struct FunctionControl {
    /// The function (DATA\[1\]).
    pub function: V3Function,
    /// Its value (DATA\[4..=7\]).
    pub value: u32,
}

/// Which part of the model string a 0xB5 request asks for.
///
/// V4.3 (§2.33): `B5 00 ..`, answered with seven characters. V4.4 (§2.34): `B5 01 idx ..`
/// with index 1..=3, answered with five characters of the up to fifteen (indexes 1, 2, 3:
/// characters 1..=5, 6..=10, 11..=15).
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum ModelPart {
    /// The V4.3 form: the whole (seven-character) model.
    Whole,
    /// The V4.4 form: characters `5 (index - 1) + 1 ..= 5 index`, index 1..=3.
    Chars(ModelIndex),
}

/// The index 1..=3 of the V4.4 0xB5 form.
#[derive(Copy, Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct ModelIndex(u8);

impl ModelIndex {
    /// Index `index`; [`ProtocolError::ValueOutOfRange`] outside 1..=3.
    pub const fn new(index: u8) -> Result<Self, ProtocolError> {
        if index >= 1 && index <= 3 {
            Ok(Self(index))
        } else {
            Err(ProtocolError::ValueOutOfRange {
                field: Field::ModelIndex,
                value: index as i64,
                min: 1,
                max: 3,
            })
        }
    }

    /// The index.
    pub const fn get(self) -> u8 {
        self.0
    }
}

/// The model characters of a 0xB5 reply, in either manual's form.
///
/// ```
/// use rmd_protocol::ModelText;
/// // V4.3 §2.33: "X8S2V10"; V4.4 §2.34: "X8S2V", characters 1..=5.
/// assert_eq!(ModelText::Whole(*b"X8S2V10").text(), Some("X8S2V10"));
/// ```
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum ModelText {
    /// V4.3: seven ASCII characters in DATA\[1..=7\].
    Whole([u8; 7]),
    /// V4.4: DATA\[1\] = 1, DATA\[2\] = the index, five ASCII characters in DATA\[3..=7\].
    Chars {
        /// Which five characters.
        index: ModelIndex,
        /// The characters.
        chars: [u8; 5],
    },
}

impl ModelText {
    /// The characters as text, without trailing NUL or space; `None` unless ASCII.
    pub fn text(&self) -> Option<&str> {
        let bytes: &[u8] = match self {
            Self::Whole(b) => b,
            Self::Chars { chars, .. } => chars,
        };
        if !bytes.is_ascii() {
            return None;
        }
        core::str::from_utf8(bytes)
            .ok()
            .map(|s| s.trim_end_matches(['\0', ' ']))
    }
}

wire_value! {
    /// V4.4's single-turn angle of 0x94: i32 in DATA\[4..=7\], 0.01°/LSB, the output shaft's,
    /// "-180° to +180°" (V4.4 §2.12; the §8 changelog: "range of ±180°, data type int32_t").
    /// V4.3 firmware sends v1.61's u16 0..=35999 in DATA\[6..=7\] instead (V4.3 §2.13).
    ///
    /// ```
    /// use rmd_protocol::V3CircleAngle;
    /// assert_eq!(V3CircleAngle::new(7500).unwrap().degrees(), 75.0);
    /// assert!(V3CircleAngle::new(18_001).is_err());
    /// ```
    V3CircleAngle(i32), field Field::CircleAngle, range -18_000, 18_000,
    unit degrees / from_degrees / from_degrees_saturating ("degrees"), scale 1 / 100
}

wire_value! {
    /// The output-shaft angle of V3's status 2 (DATA\[6..=7\] of 0x9C and of the replies to
    /// 0xA1, 0xA2, 0xA4): int16, 1°/LSB, from the zero position, "maximum range ±32767 degree"
    /// (V4.3 §2.15, V4.4 §2.14: the example `0x002D` is +45°, `0xFFD3` -45°). v1.61 and
    /// LK-TECH send the motor's encoder there instead.
    ///
    /// ```
    /// use rmd_protocol::OutputAngle;
    /// assert_eq!(OutputAngle::new(-45).unwrap().degrees(), -45.0);
    /// ```
    OutputAngle(i16), field Field::OutputAngle, range i16::MIN, i16::MAX,
    unit degrees / from_degrees / from_degrees_saturating ("degrees"), scale 1 / 1
}
