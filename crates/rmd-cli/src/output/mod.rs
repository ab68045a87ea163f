//! What the commands print: stdout and stderr without panics ([`console`], with the
//! [`outln!`] and [`errln!`] macros), errors and exit codes ([`report`]), frames and replies as
//! JSON ([`json`], from `rmd-frames`, shared with the Python package), readings of motors as JSON objects or words ([`readings`]), tables
//! ([`table`]), progress on a terminal ([`progress`]).

pub(crate) mod console;
pub(crate) mod progress;
pub(crate) mod readings;
pub(crate) mod report;
pub(crate) mod table;

/// `println!` that returns `Err(WriteError::Closed)` instead of panicking when stdout's reader
/// is gone (see [`console`]); use `?` in a command, which then ends quietly.
macro_rules! outln {
    () => {
        $crate::output::console::out_line(format_args!(""))
    };
    ($($arg:tt)*) => {
        $crate::output::console::out_line(format_args!($($arg)*))
    };
}

/// `print!` to stdout, returning `Err(WriteError::Closed)` instead of panicking.
macro_rules! out {
    ($($arg:tt)*) => {
        $crate::output::console::out_text(format_args!($($arg)*))
    };
}

/// `eprintln!` that never panics: a closed stderr is ignored.
macro_rules! errln {
    () => {
        $crate::output::console::err_line(format_args!(""))
    };
    ($($arg:tt)*) => {
        $crate::output::console::err_line(format_args!($($arg)*))
    };
}

pub(crate) use {errln, out, outln};

/// Frames and replies as JSON objects: `rmd-frames`' builder, shared with the Python package.
pub(crate) use rmd_frames::json;
