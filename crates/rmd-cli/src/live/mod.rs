//! Talking to motors on a live bus: [`connect`] (`--iface`/`--sim` to a bus, `--log`, each
//! motor's protocol learned before anything that moves or writes is sent), [`family`] (how:
//! named or identified, and what each family lacks), [`probe`] (the identifying requests),
//! [`motors`] (the motors of a command: ids on a bus, or a robot's joints by name),
//! [`exchange`] (one request, one reply: timeout, retries, typed errors), [`hint`] (the
//! commands a message suggests: complete, and only where they can work), [`interrupt`]
//! (Ctrl-C), [`safe_stop`] (motors off when a motion ends), [`confirm`] (ROM writes),
//! [`recording`] (`--log`, never held by its reader), [`frames_mcap`] (`--mcap` of the commands
//! that move motors).

pub(crate) mod confirm;
pub(crate) mod connect;
pub(crate) mod exchange;
pub(crate) mod family;
pub(crate) mod frames_mcap;
pub(crate) mod hint;
pub(crate) mod interrupt;
pub(crate) mod motors;
pub(crate) mod probe;
pub(crate) mod recording;
pub(crate) mod safe_stop;
