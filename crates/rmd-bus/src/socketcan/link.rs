//! What the kernel says about a network interface before a socket is bound to it.

use nix::net::if_::InterfaceFlags;

/// `ARPHRD_CAN`: the link type of every CAN interface (real, vcan, slcan, ...).
pub(crate) const ARPHRD_CAN: u16 = 280;

/// The state of an existing interface.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub(crate) struct LinkState {
    /// Its ARP hardware type, if the kernel reported a link-layer address entry for it.
    pub(crate) link_type: Option<u16>,
    /// Administratively up (`IFF_UP`).
    pub(crate) up: bool,
    /// Operationally up (`IFF_RUNNING`): for CAN, the controller is started and not bus-off.
    pub(crate) running: bool,
}

/// Looks `iface` up; `Ok(None)` if no interface has that name.
pub(crate) fn inspect(iface: &str) -> nix::Result<Option<LinkState>> {
    let mut state: Option<LinkState> = None;
    for entry in nix::ifaddrs::getifaddrs()? {
        if entry.interface_name != iface {
            continue;
        }
        let link_type = entry
            .address
            .as_ref()
            .and_then(|address| address.as_link_addr())
            .map(|link| link.hatype());
        let current = state.get_or_insert(LinkState {
            link_type: None,
            up: entry.flags.contains(InterfaceFlags::IFF_UP),
            running: entry.flags.contains(InterfaceFlags::IFF_RUNNING),
        });
        if current.link_type.is_none() {
            current.link_type = link_type;
        }
    }
    if state.is_none() && nix::net::if_::if_nametoindex(iface).is_ok() {
        // Listed by index but not by getifaddrs (should not happen): report what we know.
        state = Some(LinkState {
            link_type: None,
            up: true,
            running: true,
        });
    }
    Ok(state)
}

/// Whether `iface` can be a Linux interface name (`IFNAMSIZ` is 16 with the NUL).
pub(crate) fn valid_name(iface: &str) -> bool {
    !iface.is_empty()
        && iface.len() <= 15
        && iface != "."
        && iface != ".."
        && !iface
            .chars()
            .any(|c| c == '/' || c == ':' || c.is_whitespace() || c == '\0')
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interface_names_are_checked() {
        for good in ["can0", "vcan0", "slcan12", "a", "can_left-arm.1"] {
            assert!(valid_name(good), "{good}");
        }
        for bad in [
            "",
            "a/b",
            "can 0",
            "x:1",
            "sixteen-chars-xx",
            ".",
            "..",
            "a\0",
        ] {
            assert!(!valid_name(bad), "{bad:?}");
        }
    }

    #[test]
    fn the_loopback_is_not_a_can_interface_and_a_missing_one_is_none() {
        if let Some(lo) = inspect("lo").unwrap() {
            assert_ne!(lo.link_type, Some(ARPHRD_CAN));
        }
        assert_eq!(inspect("rmd-nope-xyz").unwrap(), None);
    }
}
