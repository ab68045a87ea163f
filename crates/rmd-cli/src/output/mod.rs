//! What the commands print: errors and exit codes ([`report`]), frames and replies as JSON
//! ([`json`]), readings of motors as JSON objects or words ([`readings`]).

pub(crate) mod json;
pub(crate) mod readings;
pub(crate) mod report;
