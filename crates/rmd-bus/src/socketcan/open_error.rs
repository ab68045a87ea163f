//! Why a SocketCAN interface could not be opened, each with the command that fixes it.

use super::options::IdFilter;

/// Why [`SocketCanBus::open`](super::SocketCanBus::open) failed. Opening is not on the real-time
/// path, so this error owns the interface name; its message says how to fix the problem.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum OpenError {
    /// The name cannot be a network interface name.
    #[error(
        "{iface:?} is not a valid network interface name (1 to 15 characters, none of them '/', \
         ':' or whitespace)"
    )]
    InvalidName {
        /// The name as given.
        iface: String,
    },
    /// No interface has this name.
    #[error("CAN interface `{iface}` does not exist: {}", missing_hint(iface))]
    InterfaceMissing {
        /// The interface name.
        iface: String,
    },
    /// The interface exists but is not a CAN interface.
    #[error(
        "`{iface}` is not a CAN interface (link type {link_type}, CAN is 280): list the CAN \
         interfaces with `ip -brief link show type can` (virtual ones: `type vcan`)"
    )]
    NotCan {
        /// The interface name.
        iface: String,
        /// Its ARP hardware type (`ARPHRD_*`; 772 is the loopback, 1 Ethernet).
        link_type: u16,
    },
    /// The interface is administratively down.
    #[error("CAN interface `{iface}` is down: {}", up_hint(iface))]
    InterfaceDown {
        /// The interface name.
        iface: String,
    },
    /// The interface is up but its controller is not running (stopped, or bus-off without
    /// automatic restart).
    #[error(
        "CAN interface `{iface}` is up but not running (controller stopped or bus-off): check \
         wiring, termination and bit rate, then restart it with \
         `ip link set {iface} type can restart`, or enable automatic restart with \
         `ip link set {iface} down && ip link set {iface} up type can bitrate 1000000 restart-ms 100`"
    )]
    NotRunning {
        /// The interface name.
        iface: String,
    },
    /// The operating system refused the operation.
    #[error(
        "permission denied while {action} on `{iface}` ({errno}): CAN raw sockets normally need \
         no privilege, so a security policy (container seccomp profile, SELinux, AppArmor) is \
         blocking AF_CAN; allow the `can` socket family for this program or run it outside \
         that confinement"
    )]
    PermissionDenied {
        /// The interface name.
        iface: String,
        /// What was being done.
        action: &'static str,
        /// The error (`EPERM` or `EACCES`).
        errno: nix::errno::Errno,
    },
    /// The kernel has no CAN raw socket support loaded.
    #[error(
        "this kernel has no CAN raw socket support loaded: run `modprobe can_raw` (Debian and \
         Ubuntu ship it in the kernel image package; some distributions in a \
         linux-modules-extra package)"
    )]
    CanUnsupported,
    /// An extra identifier filter cannot be expressed (id or mask above 0x7FF, or an empty
    /// range).
    #[error(
        "invalid CAN identifier filter {filter:?}: standard identifiers and masks are at most \
         0x7FF and a range's first id must not be after its last"
    )]
    InvalidFilter {
        /// The offending filter.
        filter: IdFilter,
    },
    /// More filters than the kernel accepts on one socket.
    #[error(
        "{count} kernel CAN filters needed, the kernel accepts at most 512: use masks or wider \
         ranges"
    )]
    TooManyFilters {
        /// How many filters the options need.
        count: usize,
    },
    /// Any other operating-system error.
    #[error("{action} on CAN interface `{iface}` failed: {source}")]
    Io {
        /// The interface name.
        iface: String,
        /// What was being done.
        action: &'static str,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
}

fn is_virtual(iface: &str) -> bool {
    iface.starts_with("vcan")
}

fn missing_hint(iface: &str) -> String {
    if is_virtual(iface) {
        format!(
            "create it with `modprobe vcan && ip link add dev {iface} type vcan && \
             ip link set {iface} up`"
        )
    } else {
        "is the adapter plugged in and its driver loaded? `ip -brief link show type can` lists \
         the CAN interfaces (a USB adapter can come back under another name after a reconnect)"
            .to_owned()
    }
}

fn up_hint(iface: &str) -> String {
    if is_virtual(iface) {
        format!("bring it up with `ip link set {iface} up`")
    } else {
        format!(
            "bring it up with `ip link set {iface} up type can bitrate 1000000 restart-ms 100` \
             (RMD motors default to 1 Mbit/s; a virtual interface needs only \
             `ip link set {iface} up`)"
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_carry_the_fix() {
        let missing = OpenError::InterfaceMissing {
            iface: "vcan0".into(),
        };
        assert!(
            missing
                .to_string()
                .contains("ip link add dev vcan0 type vcan")
        );
        let down = OpenError::InterfaceDown {
            iface: "can0".into(),
        };
        assert!(
            down.to_string()
                .contains("ip link set can0 up type can bitrate 1000000")
        );
        let down = OpenError::InterfaceDown {
            iface: "vcan1".into(),
        };
        assert!(down.to_string().contains("ip link set vcan1 up"));
        let not_can = OpenError::NotCan {
            iface: "lo".into(),
            link_type: 772,
        };
        assert!(not_can.to_string().contains("not a CAN interface"));
        let not_running = OpenError::NotRunning {
            iface: "can1".into(),
        };
        assert!(not_running.to_string().contains("restart-ms"));
        assert!(
            OpenError::CanUnsupported
                .to_string()
                .contains("modprobe can_raw")
        );
    }
}
