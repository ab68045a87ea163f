//! Argument types and value parsers shared by the commands: motor id lists ([`ids`]), the
//! protocol's typed values ([`parse`]) and the bus options of the live commands ([`bus`]). The
//! run flags and durations are the library's (`rmd_rig::args`), shared with the examples.

pub(crate) mod bus;
pub(crate) mod ids;
pub(crate) mod parse;
