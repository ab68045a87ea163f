//! RMD CAN frames as text for people and programs, shared by the `rmd` tool and the Python
//! package so that both read and build a frame the same way.
//!
//! - [`json`]: the JSON object of one frame, as `rmd decode` prints it ([`json::FrameJson`]);
//! - [`partial`]: the fields of a reply whose strict decoding failed on one field's range;
//! - [`decode`]: one candump line, read as a request or as a reply, to its object;
//! - [`encode`]: the values of `rmd encode` whose range depends on the protocol dialect (the
//!   torque current) or on the encoder (the encoder offset), checked with its messages.
//!
//! ```
//! use rmd_bus::candump;
//! use rmd_protocol::{Dialect, EncoderWidth};
//!
//! let line = candump::parse_line("141#A100000064000000")?;
//! let object = rmd_frames::decode::request(&line, EncoderWidth::DEFAULT, Dialect::V161)?;
//! assert_eq!(object.value["command"], "torque");
//! assert_eq!(object.value["iq_control"], 100);
//! assert_eq!(object.value["iq_control_amps"], 1.6);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod decode;
pub mod encode;
pub mod json;
pub mod partial;
