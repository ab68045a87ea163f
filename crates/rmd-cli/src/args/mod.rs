//! Argument types and value parsers shared by the commands: motor id lists ([`ids`]), the
//! protocol's typed values ([`parse`]), durations ([`duration`]), the run flags of the loop and
//! benchmarks ([`run`]) and the bus options of the live commands ([`bus`]).

pub(crate) mod bus;
pub(crate) mod duration;
pub(crate) mod ids;
pub(crate) mod parse;
pub(crate) mod run;
