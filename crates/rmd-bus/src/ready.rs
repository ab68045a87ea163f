//! Waiting on several buses at once: the small operating-system layer of the receive path.
//!
//! A loop that drives several buses sends on every bus, then waits for replies from all of
//! them. Waiting on one bus after the other would let replies pile up on the others; so each
//! bus says what to watch ([`CanBus::readiness`](crate::CanBus::readiness): a file descriptor,
//! and/or the time its next item is known to arrive) and [`wait_any`] waits for the first of
//! them in **one** system call: `ppoll` over every file descriptor (every SocketCAN socket,
//! every simulator's [`Doorbell`]), with the earliest known arrival as its timeout, then a
//! short spin to that arrival when asked for.
//!
//! Nothing here allocates: the descriptors are gathered in a fixed array of
//! [`MAX_WAIT_FDS`].
//!
//! It says which of the waits woke ([`Woken`]), so that the caller receives only from those
//! buses.
//!
//! ```
//! use core::time::Duration;
//! use rmd_bus::ready::{Doorbell, wait_any};
//! use rmd_bus::{Clock, MonotonicClock, WaitOn};
//!
//! let a = Doorbell::new()?;
//! let b = Doorbell::new()?;
//! b.ring();
//! let deadline = MonotonicClock.now() + Duration::from_secs(5);
//! // Returns as soon as one of them is readable (here at once: b was rung).
//! let woken = wait_any(&MonotonicClock, [WaitOn::readable(a.as_fd()), WaitOn::readable(b.as_fd())], deadline)?;
//! assert!(woken.contains(1) && !woken.contains(0));
//! assert!(b.clear());
//! assert!(!a.clear());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use core::time::Duration;

use crate::bus::NO_ARRIVAL;
use crate::{BusError, Clock, Timestamp, WaitOn};

/// Most file descriptors one [`wait_any`] watches. Beyond them, the wait returns within
/// [`OVERFLOW_RECHECK`] so that the caller looks at every bus again soon.
pub const MAX_WAIT_FDS: usize = 16;

/// Longest wait when more than [`MAX_WAIT_FDS`] descriptors were given.
pub const OVERFLOW_RECHECK: Duration = Duration::from_micros(100);

/// Longest single `ppoll` (keeps the `timespec` in range; longer waits return and are
/// repeated by the caller).
const MAX_SINGLE_WAIT: Duration = Duration::from_secs(3600);

/// Which of the waits given to [`wait_any`] woke, by their position: a descriptor that became
/// readable (or reports an error), an arrival that came. The first 64 positions are told apart;
/// any position beyond them counts as woken, so that the caller looks at it every time.
///
/// ```
/// use rmd_bus::ready::Woken;
/// let woken = Woken::NONE.with(3);
/// assert!(woken.contains(3) && !woken.contains(2) && woken.contains(64));
/// assert_eq!(woken.iter().take(2).collect::<Vec<_>>(), vec![3]);
/// ```
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub struct Woken(u64);

impl Woken {
    /// Nothing woke (the deadline passed, or a signal ended the wait).
    pub const NONE: Self = Self(0);

    /// These and position `i` too.
    pub const fn with(self, i: usize) -> Self {
        if i < 64 { Self(self.0 | 1 << i) } else { self }
    }

    /// Whether the wait at position `i` woke (always true from 64 on).
    pub const fn contains(self, i: usize) -> bool {
        i >= 64 || self.0 & (1 << i) != 0
    }

    /// Whether none of the first 64 positions woke.
    pub const fn is_empty(self) -> bool {
        self.0 == 0
    }

    /// The positions below 64 that woke, ascending.
    pub fn iter(self) -> impl Iterator<Item = usize> {
        let mut bits = self.0;
        core::iter::from_fn(move || {
            if bits == 0 {
                return None;
            }
            let i = bits.trailing_zeros() as usize;
            bits &= bits - 1;
            Some(i)
        })
    }
}

/// Waits until one of `waits` may have something to receive, its known arrival comes, or
/// `deadline` passes; whichever is first, and says which woke ([`Woken`], by position in
/// `waits`; a default [`WaitOn`] watches nothing and holds its position). Returns early on a
/// signal: callers loop on their own deadline and look at their buses again after every return.
///
/// The wait is one `ppoll` over every file descriptor, its timeout the earliest of `deadline`
/// and each known arrival minus its spin margin; when the timeout was an arrival's, the rest
/// is a busy-wait to that arrival on `clock` (the descriptors are not watched during that short
/// spin: what they bring is taken right after it). Without any descriptor it only sleeps on `clock`
/// (a virtual clock then simply moves). Descriptors imply the real time line: `clock` must be
/// the [`MonotonicClock`](crate::MonotonicClock) (or one on the same time line) when any is
/// given. The waits whose arrival is the earliest woke once it has come; so did one whose
/// descriptor is readable, and one beyond the [`MAX_WAIT_FDS`] descriptors a wait watches.
///
/// Errors: a descriptor that is not open ([`BusError::Io`] with `EBADF`), or `ppoll` failing.
pub fn wait_any<'a, C: Clock + ?Sized>(
    clock: &C,
    waits: impl IntoIterator<Item = WaitOn<'a>>,
    deadline: Timestamp,
) -> Result<Woken, BusError> {
    // The earliest known arrival (ns), its spin margin, and the positions whose arrival it is.
    let (mut earliest, mut spin_ns) = (NO_ARRIVAL, 0);
    let mut at_earliest = Woken::NONE;
    // Made on the first descriptor: a wait on arrivals alone (simulated buses) needs none.
    let mut fds: Option<FdSet<'a>> = None;
    for (i, wait) in waits.into_iter().enumerate() {
        let at = wait.arrival_ns();
        if at < earliest {
            (earliest, spin_ns) = (at, wait.spin_ns());
            at_earliest = Woken::NONE.with(i);
        } else if at == earliest && at != NO_ARRIVAL {
            at_earliest = at_earliest.with(i);
        }
        #[cfg(target_os = "linux")]
        if let Some(fd) = wait.fd() {
            fds.get_or_insert_with(FdSet::new).push(fd, i);
        }
    }
    let earliest = (earliest != NO_ARRIVAL).then(|| {
        (
            Timestamp::from_nanos(earliest),
            Duration::from_nanos(spin_ns),
        )
    });
    // Wake for the earliest known arrival (its spin margin early), or at the deadline.
    let arrival = earliest.filter(|&(at, _)| at <= deadline);
    let mut woken = Woken::NONE;
    match fds {
        None => match arrival {
            Some((at, spin)) => clock.wait_until(at, spin),
            None => clock.sleep_until(deadline),
        },
        Some(fds) => {
            let wake = arrival.map_or(deadline, |(at, spin)| at.saturating_sub(spin));
            let mut timeout = wake - clock.now();
            if fds.overflowed() {
                timeout = timeout.min(OVERFLOW_RECHECK);
            }
            woken = fds.beyond;
            let readable = if timeout.is_zero() {
                Woken::NONE
            } else {
                fds.poll(timeout)?
            };
            if readable.is_empty() {
                if let Some((at, _)) = arrival
                    && clock.now() >= wake
                {
                    clock.spin_until(at);
                }
            } else {
                woken = Woken(woken.0 | readable.0); // something to receive: no spin
            }
        }
    }
    // The earliest arrival has come: those waits woke. (A later one that has come meanwhile is
    // the earliest of the next wait, which then returns at once.)
    if let Some((at, _)) = arrival
        && clock.now() >= at
    {
        woken = Woken(woken.0 | at_earliest.0);
    }
    Ok(woken)
}

/// The descriptors of one wait, in a fixed array, each with the position of its wait.
struct FdSet<'a> {
    #[cfg(target_os = "linux")]
    fds: [Option<(std::os::fd::BorrowedFd<'a>, usize)>; MAX_WAIT_FDS],
    len: usize,
    /// The positions of the descriptors beyond the set (woken every time).
    beyond: Woken,
    _fds: core::marker::PhantomData<&'a ()>,
}

impl<'a> FdSet<'a> {
    fn new() -> Self {
        Self {
            #[cfg(target_os = "linux")]
            fds: [None; MAX_WAIT_FDS],
            len: 0,
            beyond: Woken::NONE,
            _fds: core::marker::PhantomData,
        }
    }

    fn overflowed(&self) -> bool {
        !self.beyond.is_empty()
    }

    /// Adds `fd`, the descriptor of the wait at `position`.
    #[cfg(target_os = "linux")]
    fn push(&mut self, fd: std::os::fd::BorrowedFd<'a>, position: usize) {
        if self.len == MAX_WAIT_FDS {
            self.beyond = self.beyond.with(position);
        } else {
            self.fds[self.len] = Some((fd, position));
            self.len += 1;
        }
    }

    /// `ppoll` over the descriptors for at most `timeout`: the positions of those readable (or
    /// with an error pending, which the next receive reports).
    #[cfg(target_os = "linux")]
    fn poll(&self, timeout: Duration) -> Result<Woken, BusError> {
        use nix::errno::Errno;
        use nix::poll::{PollFd, PollFlags, ppoll};
        use nix::sys::time::TimeSpec;
        let Some((first, _)) = self.fds[0] else {
            return Ok(Woken::NONE);
        };
        let mut set: [PollFd<'_>; MAX_WAIT_FDS] =
            core::array::from_fn(|_| PollFd::new(first, PollFlags::POLLIN));
        for (slot, fd) in set.iter_mut().zip(&self.fds[..self.len]).skip(1) {
            if let Some((fd, _)) = fd {
                *slot = PollFd::new(*fd, PollFlags::POLLIN);
            }
        }
        let set = &mut set[..self.len];
        let timeout = TimeSpec::from_duration(timeout.min(MAX_SINGLE_WAIT));
        match ppoll(set, Some(timeout), None) {
            Ok(0) | Err(Errno::EINTR) => Ok(Woken::NONE),
            Ok(_) => {
                let mut woken = Woken::NONE;
                for (fd, watched) in set.iter().zip(&self.fds) {
                    let revents = fd.revents().unwrap_or(PollFlags::empty());
                    if revents.contains(PollFlags::POLLNVAL) {
                        return Err(BusError::Io(Errno::EBADF as i32));
                    }
                    if let Some((_, position)) = watched
                        && !revents.is_empty()
                    {
                        woken = woken.with(*position);
                    }
                }
                Ok(woken)
            }
            Err(errno) => Err(BusError::Io(errno as i32)),
        }
    }

    #[cfg(not(target_os = "linux"))]
    fn poll(&self, _timeout: Duration) -> Result<Woken, BusError> {
        Ok(Woken::NONE)
    }
}

/// A doorbell between two threads that a `ppoll` can wait on (an `eventfd`): one thread
/// [`ring`](Doorbell::ring)s it when it has put something where the other will look (a
/// lock-free queue), the other waits for it among its buses ([`WaitOn::readable`]) and
/// [`clear`](Doorbell::clear)s it before it looks.
///
/// Ringing and clearing never block and never allocate (one `write` or `read` of 8 bytes).
#[cfg(target_os = "linux")]
#[derive(Debug)]
pub struct Doorbell(nix::sys::eventfd::EventFd);

#[cfg(target_os = "linux")]
impl Doorbell {
    /// A doorbell, not rung.
    pub fn new() -> std::io::Result<Self> {
        use nix::sys::eventfd::{EfdFlags, EventFd};
        EventFd::from_flags(EfdFlags::EFD_NONBLOCK | EfdFlags::EFD_CLOEXEC)
            .map(Self)
            .map_err(std::io::Error::from)
    }

    /// Rings it: a wait on it returns (now, or when it starts).
    pub fn ring(&self) {
        // The only failure of a non-blocking write is a counter at its maximum (EAGAIN): it is
        // rung already.
        let _ = self.0.write(1);
    }

    /// Clears it; returns whether it was rung.
    pub fn clear(&self) -> bool {
        self.0.read().is_ok_and(|count| count > 0)
    }

    /// What a wait watches.
    pub fn as_fd(&self) -> std::os::fd::BorrowedFd<'_> {
        use std::os::fd::AsFd;
        self.0.as_fd()
    }

    /// Waits until it is rung or `timeout` passes (it stays rung: [`clear`](Self::clear) it).
    /// Returns whether it is rung.
    pub fn wait(&self, timeout: Duration) -> Result<bool, BusError> {
        let mut set = FdSet::new();
        set.push(self.as_fd(), 0);
        Ok(!set.poll(timeout)?.is_empty())
    }
}

#[cfg(all(test, target_os = "linux"))]
mod tests {
    use super::*;
    use crate::{MonotonicClock, VirtualClock};

    fn us(n: u64) -> Duration {
        Duration::from_micros(n)
    }

    #[test]
    fn without_descriptors_it_sleeps_to_the_earliest_arrival_or_the_deadline() {
        let clock = VirtualClock::new();
        let deadline = clock.now() + us(1000);
        let a = WaitOn::arrival(Timestamp::ZERO + us(300), us(20));
        let b = WaitOn::arrival(Timestamp::ZERO + us(200), us(0));
        // A default wait watches nothing and keeps its position.
        let woken = wait_any(&clock, [a, WaitOn::default(), b], deadline).unwrap();
        assert_eq!(clock.now(), Timestamp::ZERO + us(200));
        assert_eq!(woken.iter().collect::<Vec<_>>(), vec![2]);
        // b's arrival has come: it wakes at once, a not yet.
        let woken = wait_any(&clock, [a, b], deadline).unwrap();
        assert_eq!(clock.now(), Timestamp::ZERO + us(200));
        assert_eq!(woken.iter().collect::<Vec<_>>(), vec![1]);
        // Once both have come, the earliest woke; the other is the earliest of the next wait
        // (without b), which returns at once.
        clock.sleep_until(Timestamp::ZERO + us(300));
        let woken = wait_any(&clock, [a, b], deadline).unwrap();
        assert_eq!(woken.iter().collect::<Vec<_>>(), vec![1]);
        let woken = wait_any(&clock, [a, WaitOn::default()], deadline).unwrap();
        assert_eq!(clock.now(), Timestamp::ZERO + us(300));
        assert_eq!(woken.iter().collect::<Vec<_>>(), vec![0]);
        // Arrivals at the same instant wake together.
        let c = WaitOn::arrival(Timestamp::ZERO + us(400), us(0));
        let woken = wait_any(&clock, [c, a, c], deadline).unwrap();
        assert_eq!(woken.iter().collect::<Vec<_>>(), vec![1]);
        let woken = wait_any(&clock, [c, WaitOn::default(), c], deadline).unwrap();
        assert_eq!(woken.iter().collect::<Vec<_>>(), vec![0, 2]);
        // An arrival after the deadline does not count.
        let woken = wait_any(
            &clock,
            [WaitOn::arrival(Timestamp::ZERO + us(5000), us(0))],
            deadline,
        )
        .unwrap();
        assert_eq!(clock.now(), deadline);
        assert!(woken.is_empty());
        wait_any(&clock, [], deadline + us(1)).unwrap();
        assert_eq!(clock.now(), deadline + us(1));
    }

    #[test]
    fn a_rung_doorbell_among_several_ends_the_wait_and_stays_rung_until_cleared() {
        let bells: Vec<Doorbell> = (0..3).map(|_| Doorbell::new().unwrap()).collect();
        bells[2].ring();
        bells[2].ring();
        let clock = MonotonicClock;
        let deadline = clock.now() + Duration::from_secs(30);
        let woken = wait_any(
            &clock,
            bells.iter().map(|b| WaitOn::readable(b.as_fd())),
            deadline,
        )
        .unwrap();
        assert!(clock.now() < deadline);
        assert_eq!(woken.iter().collect::<Vec<_>>(), vec![2]);
        assert!(bells[2].wait(Duration::ZERO).unwrap());
        assert!(bells[2].clear());
        assert!(!bells[2].clear());
        assert!(!bells[0].clear() && !bells[1].clear());
    }

    #[test]
    fn a_ring_from_another_thread_wakes_the_wait() {
        let bell = std::sync::Arc::new(Doorbell::new().unwrap());
        let ringer = std::sync::Arc::clone(&bell);
        let t = std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(5));
            ringer.ring();
        });
        let clock = MonotonicClock;
        let deadline = clock.now() + Duration::from_secs(30);
        while !bell.clear() {
            assert!(clock.now() < deadline, "never woken");
            wait_any(&clock, [WaitOn::readable(bell.as_fd())], deadline).unwrap();
        }
        t.join().unwrap();
    }

    #[test]
    fn nothing_rung_waits_for_the_arrival_and_spins_to_it() {
        let bell = Doorbell::new().unwrap();
        let clock = MonotonicClock;
        let now = clock.now();
        let at = now + us(3000);
        let wait = WaitOn::readable(bell.as_fd()).with_arrival(at, us(500));
        let woken = wait_any(&clock, [wait], now + Duration::from_secs(30)).unwrap();
        // Never before the arrival (no upper bound: shared machine).
        assert!(clock.now() >= at);
        assert!(woken.contains(0));
        // Nothing rung, nothing known: the deadline, and nothing woke.
        let deadline = clock.now() + us(2000);
        let woken = wait_any(&clock, [WaitOn::readable(bell.as_fd())], deadline).unwrap();
        assert!(clock.now() >= deadline);
        assert!(woken.is_empty());
    }

    #[test]
    fn more_descriptors_than_the_set_holds_are_rechecked_soon() {
        let bells: Vec<Doorbell> = (0..MAX_WAIT_FDS + 1)
            .map(|_| Doorbell::new().unwrap())
            .collect();
        let clock = MonotonicClock;
        let deadline = clock.now() + Duration::from_secs(30);
        // The last one is beyond the set: the wait still returns (within OVERFLOW_RECHECK,
        // not asserted) so that the caller sees it.
        bells[MAX_WAIT_FDS].ring();
        let woken = wait_any(
            &clock,
            bells.iter().map(|b| WaitOn::readable(b.as_fd())),
            deadline,
        )
        .unwrap();
        assert!(clock.now() < deadline);
        // Not watched, so counted as woken: the caller looks at it.
        assert!(woken.contains(MAX_WAIT_FDS));
        assert!(!woken.contains(0));
    }
}
