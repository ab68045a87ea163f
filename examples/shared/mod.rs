//! Code the examples share: the 4-motor leg (kinematics, gravity, description, simulation), the
//! Cartesian impedance law, the step cycle, the command-line options and the run loop with its
//! live display. Each example (and each example's test) includes this module; not every one uses
//! every item, hence the `dead_code` allowance where it is included.

/// `println!` that ignores a closed standard output (`| head`): printing never stops a run.
macro_rules! say {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout(), $($arg)*);
    }};
}

/// `print!` that ignores a closed standard output.
macro_rules! say_raw {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = write!(std::io::stdout(), $($arg)*);
    }};
}

// Not every includer prints (the leg model's tests do not).
#[allow(unused_imports)]
pub(crate) use {say, say_raw};

pub(crate) mod cli;
pub(crate) mod impedance;
pub(crate) mod leg;
pub(crate) mod runner;
pub(crate) mod step_cycle;
