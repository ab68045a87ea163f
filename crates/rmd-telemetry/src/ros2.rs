//! The ROS 2 messages of the telemetry (`sensor_msgs/msg/JointState`,
//! `diagnostic_msgs/msg/DiagnosticArray`): their `ros2msg` schema texts as MCAP and Foxglove want
//! them (the type, then each dependency after a `MSG:` separator), and CDR encoding
//! (little-endian, with the 4-byte encapsulation header ROS 2 writes).

use serde::Serialize;

use crate::sink::SinkError;

/// The separator between a `ros2msg` schema's definitions.
const SEPARATOR: &str =
    "================================================================================";

/// `builtin_interfaces/Time` and `std_msgs/Header`, the dependencies both messages share.
fn header_definitions() -> String {
    format!(
        "{SEPARATOR}\nMSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n\
         {SEPARATOR}\nMSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n"
    )
}

/// The schema name of `/joint_states`.
pub(crate) const JOINT_STATE_NAME: &str = "sensor_msgs/msg/JointState";

/// The `ros2msg` schema text of `sensor_msgs/msg/JointState`.
pub(crate) fn joint_state_schema() -> String {
    format!(
        "std_msgs/Header header\n\nstring[] name\nfloat64[] position\nfloat64[] velocity\n\
         float64[] effort\n{}",
        header_definitions()
    )
}

/// The schema name of `/diagnostics`.
pub(crate) const DIAGNOSTIC_ARRAY_NAME: &str = "diagnostic_msgs/msg/DiagnosticArray";

/// The `ros2msg` schema text of `diagnostic_msgs/msg/DiagnosticArray`.
pub(crate) fn diagnostic_array_schema() -> String {
    format!(
        "std_msgs/Header header\nDiagnosticStatus[] status\n{}\
         {SEPARATOR}\nMSG: diagnostic_msgs/DiagnosticStatus\n\
         byte OK=0\nbyte WARN=1\nbyte ERROR=2\nbyte STALE=3\n\
         byte level\nstring name\nstring message\nstring hardware_id\nKeyValue[] values\n\
         {SEPARATOR}\nMSG: diagnostic_msgs/KeyValue\nstring key\nstring value\n",
        header_definitions()
    )
}

/// `builtin_interfaces/Time`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub(crate) struct Time {
    pub(crate) sec: i32,
    pub(crate) nanosec: u32,
}

impl Time {
    /// The time `unix_ns` nanoseconds after the Unix epoch (seconds saturate in 2038's place).
    pub(crate) fn from_unix_ns(unix_ns: u64) -> Self {
        let sec = i32::try_from(unix_ns / 1_000_000_000).unwrap_or(i32::MAX);
        // The remainder is below 1e9, so it fits.
        let nanosec = u32::try_from(unix_ns % 1_000_000_000).unwrap_or(0);
        Self { sec, nanosec }
    }
}

/// `std_msgs/Header`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub(crate) struct Header<'a> {
    pub(crate) stamp: Time,
    pub(crate) frame_id: &'a str,
}

/// `sensor_msgs/msg/JointState`, borrowing its arrays.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub(crate) struct JointState<'a> {
    pub(crate) header: Header<'a>,
    pub(crate) name: &'a [String],
    pub(crate) position: &'a [f64],
    pub(crate) velocity: &'a [f64],
    pub(crate) effort: &'a [f64],
}

/// The levels of `diagnostic_msgs/msg/DiagnosticStatus`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub(crate) enum Level {
    Ok = 0,
    Warn = 1,
    Error = 2,
    Stale = 3,
}

/// `diagnostic_msgs/msg/KeyValue`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub(crate) struct KeyValue {
    pub(crate) key: String,
    pub(crate) value: String,
}

/// `diagnostic_msgs/msg/DiagnosticStatus`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub(crate) struct DiagnosticStatus {
    pub(crate) level: u8,
    pub(crate) name: String,
    pub(crate) message: String,
    pub(crate) hardware_id: String,
    pub(crate) values: Vec<KeyValue>,
}

/// `diagnostic_msgs/msg/DiagnosticArray`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub(crate) struct DiagnosticArray<'a> {
    pub(crate) header: Header<'a>,
    pub(crate) status: Vec<DiagnosticStatus>,
}

/// Encodes `message` as CDR (little-endian, encapsulation header first) into `out`, which is
/// cleared first so one buffer serves every message.
pub(crate) fn encode_cdr<T: Serialize>(
    message: &T,
    what: &'static str,
    out: &mut Vec<u8>,
) -> Result<(), SinkError> {
    out.clear();
    cdr::serialize_into::<_, _, _, cdr::CdrLe>(&mut *out, message, cdr::Infinite).map_err(|e| {
        SinkError::Encode {
            what,
            detail: e.to_string(),
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn joint_state_cdr_layout_is_what_ros2_writes() {
        let names = ["a".to_owned()];
        let msg = JointState {
            header: Header {
                stamp: Time { sec: 1, nanosec: 2 },
                frame_id: "",
            },
            name: &names,
            position: &[1.5],
            velocity: &[],
            effort: &[],
        };
        let mut out = Vec::new();
        encode_cdr(&msg, "test", &mut out).unwrap();
        let mut expected = vec![0, 1, 0, 0]; // CDR_LE encapsulation, options 0
        expected.extend(1_i32.to_le_bytes()); // sec
        expected.extend(2_u32.to_le_bytes()); // nanosec
        expected.extend(1_u32.to_le_bytes()); // frame_id: length 1 (the NUL)
        expected.push(0);
        expected.extend([0, 0, 0]); // align to 4
        expected.extend(1_u32.to_le_bytes()); // 1 name
        expected.extend(2_u32.to_le_bytes()); // "a\0"
        expected.extend(b"a\0");
        expected.extend([0, 0]); // align to 4
        expected.extend(1_u32.to_le_bytes()); // 1 position (offset 28 after the header)
        expected.extend(1.5_f64.to_le_bytes()); // offset 32: already 8-aligned
        expected.extend(0_u32.to_le_bytes()); // no velocity
        expected.extend(0_u32.to_le_bytes()); // no effort
        assert_eq!(out, expected);
    }

    #[test]
    fn doubles_are_aligned_to_eight_bytes_after_the_header() {
        let msg = JointState {
            header: Header {
                stamp: Time { sec: 0, nanosec: 0 },
                frame_id: "",
            },
            name: &[],
            position: &[-2.0],
            velocity: &[],
            effort: &[],
        };
        let mut out = Vec::new();
        encode_cdr(&msg, "test", &mut out).unwrap();
        // Header 4, stamp 8, frame_id 4+1 (+3 pad), names 4, positions 4: the f64 starts at data
        // offset 24, i.e. byte 28, with no padding since 24 is 8-aligned.
        assert_eq!(out.len(), 4 + 24 + 8 + 4 + 4);
        assert_eq!(out[28..36], (-2.0_f64).to_le_bytes());
        let with_frame = JointState {
            header: Header {
                stamp: Time { sec: 0, nanosec: 0 },
                frame_id: "base",
            },
            ..msg
        };
        encode_cdr(&with_frame, "test", &mut out).unwrap();
        // frame_id 4+5 (+3 pad) ends at 20, names 20..24, positions 24..28: 4 bytes of padding
        // put the f64 at data offset 32.
        assert_eq!(out[4 + 28..4 + 32], [0, 0, 0, 0]);
        assert_eq!(out[4 + 32..4 + 40], (-2.0_f64).to_le_bytes());
    }

    #[test]
    fn time_splits_seconds_and_nanoseconds() {
        assert_eq!(
            Time::from_unix_ns(1_700_000_000_123_456_789),
            Time {
                sec: 1_700_000_000,
                nanosec: 123_456_789
            }
        );
    }

    #[test]
    fn schemas_list_every_dependency() {
        let js = joint_state_schema();
        assert!(js.contains("MSG: std_msgs/Header") && js.contains("MSG: builtin_interfaces/Time"));
        let da = diagnostic_array_schema();
        for dep in [
            "MSG: diagnostic_msgs/DiagnosticStatus",
            "MSG: diagnostic_msgs/KeyValue",
            "MSG: std_msgs/Header",
        ] {
            assert!(da.contains(dep), "{dep}");
        }
    }
}
