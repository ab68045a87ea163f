//! Test fixtures on the real kernel: private vcan interfaces, a peer socket, and an slcan
//! interface driven through a pseudo-terminal. They need CAP_NET_ADMIN (root in the test VM).

#![allow(unreachable_pub)]

pub mod slcan;

use std::process::Command;
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::{Duration, Instant};

use socketcan::{CanSocket, EmbeddedFrame, Frame, Socket, StandardId};

/// Runs `ip ARGS...` (busybox in the VM, iproute2 natively), panicking with its output if it
/// fails.
pub fn ip(args: &[&str]) {
    let output = Command::new("ip")
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("cannot run `ip {}`: {e}", args.join(" ")));
    assert!(
        output.status.success(),
        "`ip {}` failed: {}{}",
        args.join(" "),
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr)
    );
}

/// A fresh interface name, unique in this process and unlikely to clash with another run.
pub fn unique_name(prefix: &str) -> String {
    static NEXT: AtomicU32 = AtomicU32::new(0);
    let n = NEXT.fetch_add(1, Ordering::Relaxed);
    format!("{prefix}{}x{n}", std::process::id() % 10_000)
}

/// A private vcan interface, deleted on drop.
pub struct Vcan {
    pub name: String,
}

impl Vcan {
    /// Creates a vcan interface and brings it up.
    pub fn up() -> Self {
        let vcan = Self::down();
        ip(&["link", "set", &vcan.name, "up"]);
        vcan
    }

    /// Creates a vcan interface and leaves it down.
    pub fn down() -> Self {
        let name = unique_name("rmdt");
        ip(&["link", "add", "dev", &name, "type", "vcan"]);
        Self { name }
    }

    pub fn set_up(&self, up: bool) {
        ip(&["link", "set", &self.name, if up { "up" } else { "down" }]);
    }
}

impl Drop for Vcan {
    fn drop(&mut self) {
        let _ = Command::new("ip")
            .args(["link", "del", "dev", &self.name])
            .output();
    }
}

/// Another program on the bus: a plain raw CAN socket (all frames, no echo of its own).
pub struct Peer {
    pub socket: CanSocket,
}

impl Peer {
    pub fn open(iface: &str) -> Self {
        let socket = CanSocket::open(iface).expect("peer socket");
        Self { socket }
    }

    /// Sends a standard data frame.
    pub fn send(&self, id: u16, data: &[u8]) {
        let frame =
            socketcan::CanFrame::new(StandardId::new(id).expect("standard id"), data).unwrap();
        self.socket.write_frame(&frame).expect("peer send");
    }

    /// Sends any frame.
    pub fn send_frame(&self, frame: &socketcan::CanFrame) {
        self.socket.write_frame(frame).expect("peer send");
    }

    /// The next frame within `timeout`: (raw id with flags, data).
    pub fn recv(&self, timeout: Duration) -> Option<(u32, Vec<u8>)> {
        self.socket
            .set_read_timeout(timeout)
            .expect("peer read timeout");
        match self.socket.read_frame() {
            Ok(frame) => Some((frame.id_word(), frame.data().to_vec())),
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                ) =>
            {
                None
            }
            Err(e) => panic!("peer receive failed: {e}"),
        }
    }
}

/// Polls `f` until it returns `Some`, for at most `limit`.
pub fn eventually<T>(limit: Duration, mut f: impl FnMut() -> Option<T>) -> Option<T> {
    let start = Instant::now();
    loop {
        if let Some(value) = f() {
            return Some(value);
        }
        if start.elapsed() > limit {
            return None;
        }
        std::thread::sleep(Duration::from_millis(2));
    }
}
