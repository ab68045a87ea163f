//! Argument types and value parsers shared by the commands: motor id lists ([`ids`]), the
//! protocol's typed values ([`parse`]), the bus options of the live commands ([`bus`]) and the
//! CLI's own rates and whole-unit times ([`timing`]). The run flags and durations are the
//! library's (`rmd_rig::args`), shared with the examples.

pub(crate) mod bus;
pub(crate) mod ids;
pub(crate) mod parse;
pub(crate) mod timing;
