//! A global allocator that counts allocations and frees, for the tests that prove a path
//! allocates nothing.
//!
//! Three ways to count, each for a kind of test:
//! - [`this_thread`]: the calling thread's own totals, right whatever other threads (other
//!   tests of the binary included) do meanwhile;
//! - [`count_this_thread`]: the threads that switch it on add to the shared count
//!   ([`counted`]), for a test that reads from one thread what another (a loop's) did;
//! - [`count_every_thread`]: every thread of the process adds to the shared count (a loop's
//!   supervisor, simulator threads), which is right only while no other test runs in the
//!   process: such a test starts with [`ran_in_own_process`](crate::ran_in_own_process).
//!
//! A counter that counts nothing proves nothing: each of them first checks that
//! [`CountingAllocator`] is the binary's global allocator, and panics saying how to install it
//! otherwise.
//!
//! `GlobalAlloc` is an unsafe trait: the only `unsafe` of the test support is here.
#![allow(unsafe_code)]

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

/// Allocations (`alloc`, `alloc_zeroed`, `realloc`) and frees counted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Counts {
    /// Blocks allocated or reallocated.
    pub allocations: u64,
    /// Blocks freed.
    pub frees: u64,
}

impl Counts {
    /// Allocations and frees together (a real-time thread must do neither).
    pub fn total(self) -> u64 {
        self.allocations + self.frees
    }
}

thread_local! {
    // Const-initialised and without a destructor: usable from inside the allocator, on a
    // thread being torn down too.
    static THIS_THREAD: Cell<Counts> = const {
        Cell::new(Counts {
            allocations: 0,
            frees: 0,
        })
    };
    static THIS_THREAD_COUNTED: Cell<bool> = const { Cell::new(false) };
}

static EVERY_THREAD_COUNTED: AtomicBool = AtomicBool::new(false);
static COUNTED_ALLOCATIONS: AtomicU64 = AtomicU64::new(0);
static COUNTED_FREES: AtomicU64 = AtomicU64::new(0);
static INSTALLED: AtomicBool = AtomicBool::new(false);

/// Whether the calling thread's events go to the shared count.
fn shared() -> bool {
    EVERY_THREAD_COUNTED.load(Ordering::Relaxed)
        || THIS_THREAD_COUNTED.try_with(Cell::get) == Ok(true)
}

fn count_allocation() {
    let _ = THIS_THREAD.try_with(|c| {
        let mut counts = c.get();
        counts.allocations += 1;
        c.set(counts);
    });
    if shared() {
        COUNTED_ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
    }
}

fn count_free() {
    let _ = THIS_THREAD.try_with(|c| {
        let mut counts = c.get();
        counts.frees += 1;
        c.set(counts);
    });
    if shared() {
        COUNTED_FREES.fetch_add(1, Ordering::Relaxed);
    }
}

/// The system allocator, counting every allocation and free. A test binary installs it once,
/// in its `main.rs`:
///
/// ```
/// #[global_allocator]
/// static ALLOCATOR: rmd_test_support::alloc::CountingAllocator =
///     rmd_test_support::alloc::CountingAllocator;
///
/// # fn main() {
/// let before = rmd_test_support::alloc::this_thread();
/// let v = vec![1, 2, 3];
/// assert_eq!(rmd_test_support::alloc::this_thread().allocations, before.allocations + 1);
/// # drop(v);
/// # }
/// ```
pub struct CountingAllocator;

// SAFETY: every method forwards to `System` with the caller's arguments unchanged, so the
// `GlobalAlloc` contract holds exactly as it does for `System`; the counting touches only
// const-initialised thread-local cells and atomics, which neither allocate nor unwind.
unsafe impl GlobalAlloc for CountingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count_allocation();
        // SAFETY: the caller upholds `alloc`'s contract, passed on unchanged.
        unsafe { System.alloc(layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        count_allocation();
        // SAFETY: as for `alloc`.
        unsafe { System.alloc_zeroed(layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count_allocation();
        // SAFETY: `ptr` came from `System` (every allocation goes there) with `layout`; the
        // caller upholds the rest of `realloc`'s contract.
        unsafe { System.realloc(ptr, layout, new_size) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        count_free();
        // SAFETY: `ptr` came from `System` (every allocation goes there) with `layout`.
        unsafe { System.dealloc(ptr, layout) }
    }
}

/// Panics unless [`CountingAllocator`] counts this binary's allocations (checked once).
fn assert_installed() {
    if INSTALLED.load(Ordering::Acquire) {
        return;
    }
    let before = THIS_THREAD.with(Cell::get);
    drop(std::hint::black_box(Box::new(0_u8)));
    let after = THIS_THREAD.with(Cell::get);
    assert!(
        after.allocations > before.allocations && after.frees > before.frees,
        "CountingAllocator is not this binary's global allocator, so it counts nothing: add \
         `#[global_allocator] static ALLOCATOR: rmd_test_support::alloc::CountingAllocator = \
         rmd_test_support::alloc::CountingAllocator;` to the test binary's main.rs"
    );
    INSTALLED.store(true, Ordering::Release);
}

/// The calling thread's allocations and frees since it started (subtract two readings for
/// what happened between them).
///
/// # Panics
///
/// When [`CountingAllocator`] is not the global allocator.
pub fn this_thread() -> Counts {
    assert_installed();
    THIS_THREAD.with(Cell::get)
}

/// From now on (`true`) or no longer (`false`), the calling thread's allocations and frees
/// also go to the shared count ([`counted`]).
///
/// # Panics
///
/// When [`CountingAllocator`] is not the global allocator.
pub fn count_this_thread(on: bool) {
    assert_installed();
    THIS_THREAD_COUNTED.with(|c| c.set(on));
}

/// From now on (`true`) or no longer (`false`), every thread's allocations and frees go to the
/// shared count ([`counted`]). Only right in a process running no other test: start the test
/// with [`ran_in_own_process`](crate::ran_in_own_process).
///
/// # Panics
///
/// When [`CountingAllocator`] is not the global allocator.
pub fn count_every_thread(on: bool) {
    assert_installed();
    EVERY_THREAD_COUNTED.store(on, Ordering::SeqCst);
}

/// The shared count: allocations and frees of the counted threads since the start of the
/// process or the last [`reset_counted`].
pub fn counted() -> Counts {
    Counts {
        allocations: COUNTED_ALLOCATIONS.load(Ordering::SeqCst),
        frees: COUNTED_FREES.load(Ordering::SeqCst),
    }
}

/// Sets the shared count back to zero.
pub fn reset_counted() {
    COUNTED_ALLOCATIONS.store(0, Ordering::SeqCst);
    COUNTED_FREES.store(0, Ordering::SeqCst);
}

#[cfg(test)]
mod tests {
    // This crate's own unit tests do not install the allocator: every count must refuse.
    #[test]
    #[should_panic(expected = "is not this binary's global allocator")]
    fn a_count_without_the_allocator_installed_panics() {
        let _ = super::this_thread();
    }
}
