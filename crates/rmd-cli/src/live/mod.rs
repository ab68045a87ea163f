//! Talking to motors on a live bus: [`connect`] (`--iface`/`--sim` to a bus, `--log`),
//! [`exchange`] (one request, one reply: timeout, retries, typed errors), [`interrupt`]
//! (Ctrl-C), [`safe_stop`] (motors off when a motion ends), [`confirm`] (ROM writes).

pub(crate) mod confirm;
pub(crate) mod connect;
pub(crate) mod exchange;
pub(crate) mod interrupt;
pub(crate) mod safe_stop;
