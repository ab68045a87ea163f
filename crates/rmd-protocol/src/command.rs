//! The single-motor commands of every family rmd-rt speaks, by command byte (DATA\[0\]): the 23
//! of protocol v1.61 (which LK-TECH V2.3x shares) and the MyActuator V3 commands rmd-rt
//! implements beyond them. No two families give one byte different meanings among these, so one
//! enum names them all; which family has which is [`Dialect::commands`](crate::Dialect::commands).

use core::fmt;

macro_rules! commands {
    ($( $(#[$doc:meta])* $variant:ident = $code:literal, $name:literal; )*) => {
        /// A single-motor command (the command byte in DATA\[0\] of requests and replies). The
        /// v1.61 0x280 multi-motor torque frame has no command byte and is modelled by
        /// [`MultiTorque`](crate::MultiTorque); its replies are [`Command::Torque`] replies.
        ///
        /// ```
        /// use rmd_protocol::Command;
        /// assert_eq!(Command::Torque.code(), 0xA1);
        /// assert_eq!(Command::from_code(0x9C), Some(Command::ReadStatus2));
        /// assert_eq!(Command::Position4.name(), "position-4");
        /// assert_eq!(Command::from_name("read-pid"), Some(Command::ReadPid));
        /// assert_eq!(Command::ALL.len(), 30);
        /// assert_eq!(Command::ReadFirmwareDate.code(), 0xB2);
        /// ```
        #[derive(Copy, Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
        #[repr(u8)]
        pub enum Command {
            $( $(#[$doc])* $variant = $code, )*
        }

        impl Command {
            /// Every command: v1.61's in the order of its spec's command list, then MyActuator
            /// V3's own.
            pub const ALL: [Command; 30] = [$(Command::$variant),*];

            /// The command byte (DATA\[0\]).
            pub const fn code(self) -> u8 {
                self as u8
            }

            /// The command with command byte `code`, if there is one.
            pub const fn from_code(code: u8) -> Option<Self> {
                match code {
                    $( $code => Some(Command::$variant), )*
                    _ => None,
                }
            }

            /// The kebab-case name the CLI uses (`read-pid`, `write-pid-ram`, ..., `position-4`).
            pub const fn name(self) -> &'static str {
                match self {
                    $( Command::$variant => $name, )*
                }
            }

            /// The command named `name` (kebab-case, as [`Command::name`] returns it).
            pub fn from_name(name: &str) -> Option<Self> {
                match name {
                    $( $name => Some(Command::$variant), )*
                    _ => None,
                }
            }
        }
    };
}

commands! {
    /// 0x30: read the PID parameters.
    ReadPid = 0x30, "read-pid";
    /// 0x31: write the PID parameters to RAM (lost at power off).
    WritePidRam = 0x31, "write-pid-ram";
    /// 0x32: write the PID parameters to ROM. Wears the flash: ask before sending.
    WritePidRom = 0x32, "write-pid-rom";
    /// 0x33: read the acceleration setting.
    ReadAccel = 0x33, "read-accel";
    /// 0x34: write the acceleration setting to RAM.
    WriteAccelRam = 0x34, "write-accel-ram";
    /// 0x90: read the encoder position, raw position and offset.
    ReadEncoder = 0x90, "read-encoder";
    /// 0x91: write the encoder offset.
    WriteEncoderOffset = 0x91, "write-encoder-offset";
    /// 0x19: write the current position to ROM as the motor zero. Wears the flash and only takes
    /// effect after a power cycle: ask before sending.
    WriteZeroRom = 0x19, "write-zero-rom";
    /// 0x92: read the multi-turn angle.
    ReadMultiTurnAngle = 0x92, "read-multi-turn-angle";
    /// 0x94: read the single-turn (circle) angle.
    ReadSingleTurnAngle = 0x94, "read-single-turn-angle";
    /// 0x9A: read status 1 (temperature, voltage, error state).
    ReadStatus1 = 0x9A, "read-status-1";
    /// 0x9B: clear the error flags (replies with status 1).
    ClearError = 0x9B, "clear-error";
    /// 0x9C: read status 2 (temperature, torque current, speed, encoder).
    ReadStatus2 = 0x9C, "read-status-2";
    /// 0x9D: read status 3 (phase currents).
    ReadStatus3 = 0x9D, "read-status-3";
    /// 0x80: motor off (clears the running state and previous commands).
    MotorOff = 0x80, "motor-off";
    /// 0x81: motor stop (keeps the running state).
    MotorStop = 0x81, "motor-stop";
    /// 0x88: motor run (resume after a stop).
    MotorRun = 0x88, "motor-run";
    /// 0xA1: torque closed loop (`iqControl`).
    Torque = 0xA1, "torque";
    /// 0xA2: speed closed loop (`speedControl`).
    Speed = 0xA2, "speed";
    /// 0xA3: position closed loop 1 (multi-turn `angleControl`).
    Position1 = 0xA3, "position-1";
    /// 0xA4: position closed loop 2 (`maxSpeed`, multi-turn `angleControl`).
    Position2 = 0xA4, "position-2";
    /// 0xA5: position closed loop 3 (`spinDirection`, single-turn `angleControl`).
    Position3 = 0xA5, "position-3";
    /// 0xA6: position closed loop 4 (`spinDirection`, `maxSpeed`, single-turn `angleControl`).
    Position4 = 0xA6, "position-4";
    /// 0xB2 (MyActuator V3): read the firmware version date (V4.3 §2.30, V4.4 §2.31).
    ReadFirmwareDate = 0xB2, "read-firmware-date";
    /// 0xB5 (MyActuator V3): read the motor model (V4.3 §2.33, V4.4 §2.34).
    ReadModel = 0xB5, "read-model";
    /// 0xB3 (MyActuator V3): set the communication-interruption protection time, stored in ROM
    /// (V4.3 §2.31, V4.4 §2.32). Ask before sending.
    SetWatchdog = 0xB3, "set-watchdog";
    /// 0x20 (MyActuator V3): function control, by index (V4.3 §2.35, V4.4 §2.36); most indexes
    /// write ROM.
    FunctionControl = 0x20, "function-control";
    /// 0x76 (MyActuator V3): system reset; the motor reboots and does not answer (V4.3 §2.26,
    /// V4.4 §2.27).
    Reset = 0x76, "reset";
    /// 0x77 (MyActuator V3): release the holding brake (V4.3 §2.27, V4.4 §2.28).
    BrakeRelease = 0x77, "brake-release";
    /// 0x78 (MyActuator V3): lock the holding brake (V4.3 §2.28, V4.4 §2.29).
    BrakeLock = 0x78, "brake-lock";
}

impl Command {
    /// Whether the command writes the motor's flash whatever its fields (0x19, 0x32, V3's 0xB3):
    /// a user-facing tool must ask before sending it. V3's 0x20 writes ROM for most function
    /// indexes: see [`Request::writes_flash`](crate::Request::writes_flash).
    pub const fn writes_flash(self) -> bool {
        matches!(
            self,
            Command::WriteZeroRom | Command::WritePidRom | Command::SetWatchdog
        )
    }
}

impl fmt::Display for Command {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}
