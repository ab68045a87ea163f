//! The ranges MyActuator V3's motion-mode (MIT) fields are packed into, which depend on the
//! firmware: plain data, so that a packed value can say which ranges it was packed with.

use core::fmt;

/// A motor's maximum torque at the output, the motion-mode torque range of V4.4 firmware
/// ("-Motor Max Torque to +Motor Max Torque ... the Max Torque parameter can be viewed in the
/// host software", MyActuator Servo Motor Control Protocol V4.4 §4.1). Held in milli-N·m.
///
/// ```
/// use rmd_protocol::MotorMaxTorque;
/// assert_eq!(MotorMaxTorque::from_nm(60.0)?.nm(), 60.0);
/// assert!(MotorMaxTorque::from_nm(0.0).is_err());
/// # Ok::<(), rmd_protocol::ProtocolError>(())
/// ```
#[derive(Copy, Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct MotorMaxTorque(u32);

impl MotorMaxTorque {
    /// A maximum torque of `milli_nm` milli-N·m (0 is taken as 1: a range must not be empty).
    pub const fn from_milli_nm(milli_nm: u32) -> Self {
        Self(if milli_nm == 0 { 1 } else { milli_nm })
    }

    /// The torque in milli-N·m.
    pub const fn milli_nm(self) -> u32 {
        self.0
    }

    /// The torque in N·m.
    pub fn nm(self) -> f64 {
        f64::from(self.0) / 1000.0
    }
}

/// The ranges of the five motion-mode fields: each field is a linear map of its range onto its
/// unsigned bits (16 for the position, 12 for the others), minimum to 0, maximum to all ones.
///
/// | field | bits | V4.2 / V4.3 (2024.05, 2025.05) | V4.4 (2025.09) |
/// |---|---|---|---|
/// | `p_des`, `p` | 16 | ±12.5 rad | ±12.566 rad |
/// | `v_des`, `v` | 12 | ±45 rad/s | ±45 rad/s |
/// | `kp` | 12 | 0..=500 | 0..=500 |
/// | `kd` | 12 | 0..=5 | 0..=50 |
/// | `t_ff`, `t` | 12 | ±24 N·m | ± the motor's maximum torque |
///
/// Sources: MyActuator "Servo Motor Control Protocol" V4.2 §5.1 and V4.3 §5.1 (the left
/// column; the reply uses the command's ranges, §5.3 / §5.4); V4.4 §4.1, §4.4 and §8 ("Expanded
/// the value range of the kd parameter in the MIT command from 0-5 to 0-50", "Changed the value
/// range of the t_ff parameter ... to -Motor Max Torque~+Motor Max Torque", "Changed the p_des
/// value range ... to -12.566 to 12.566 rad"). V4.4's §4.1 prose says kp 0..=1000 and kd 0..=5,
/// but its worked example (§4.4), its Chinese text and its changelog say kp 0..=500 and kd
/// 0..=50: those are used. Which firmware uses which: see
/// [`FirmwareDate::revision`](crate::FirmwareDate::revision).
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub struct MitRanges {
    p_max_milli: u32,
    v_max_milli: u32,
    kp_max_milli: u32,
    kd_max_milli: u32,
    t_max_milli: u32,
}

impl MitRanges {
    /// The ranges of V4.2 / V4.3 firmware: ±12.5 rad, ±45 rad/s, kp 0..=500, kd 0..=5,
    /// ±24 N·m.
    pub const V4_3: Self = Self {
        p_max_milli: 12_500,
        v_max_milli: 45_000,
        kp_max_milli: 500_000,
        kd_max_milli: 5_000,
        t_max_milli: 24_000,
    };

    /// The ranges of V4.4 firmware for a motor of maximum torque `max_torque`: ±12.566 rad,
    /// ±45 rad/s, kp 0..=500, kd 0..=50, ± `max_torque`.
    pub const fn v4_4(max_torque: MotorMaxTorque) -> Self {
        Self {
            p_max_milli: 12_566,
            v_max_milli: 45_000,
            kp_max_milli: 500_000,
            kd_max_milli: 50_000,
            t_max_milli: max_torque.milli_nm(),
        }
    }

    /// `p_des` / `p`: ± this many rad.
    pub fn position_rad(self) -> f64 {
        f64::from(self.p_max_milli) / 1000.0
    }

    /// `v_des` / `v`: ± this many rad/s.
    pub fn velocity_rad_s(self) -> f64 {
        f64::from(self.v_max_milli) / 1000.0
    }

    /// `kp`: 0 to this (N·m per rad).
    pub fn kp(self) -> f64 {
        f64::from(self.kp_max_milli) / 1000.0
    }

    /// `kd`: 0 to this (N·m per rad/s).
    pub fn kd(self) -> f64 {
        f64::from(self.kd_max_milli) / 1000.0
    }

    /// `t_ff` / `t`: ± this many N·m.
    pub fn torque_nm(self) -> f64 {
        f64::from(self.t_max_milli) / 1000.0
    }
}

/// Formats as `p ±12.5 rad, v ±45 rad/s, kp 0..=500, kd 0..=5, t ±24 N·m`.
impl fmt::Display for MitRanges {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "p ±{} rad, v ±{} rad/s, kp 0..={}, kd 0..={}, t ±{} N·m",
            self.position_rad(),
            self.velocity_rad_s(),
            self.kp(),
            self.kd(),
            self.torque_nm()
        )
    }
}
