//! Which process an object belongs to. A loop, a bus and a simulator own threads, sockets and
//! locks that live in the process that made them: after `os.fork()` the child has copies of
//! the Python objects but none of the threads (a lock a thread of the parent held stays held
//! forever in the child). The child may neither drive nor stop them, and must not tear them
//! down at exit (joining a thread it does not have); the parent's go on untouched.

use pyo3::PyResult;

use crate::errors::ForkedProcessError;

/// The process that made an object.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub(crate) struct Owner(u32);

impl Owner {
    /// This process.
    pub(crate) fn here() -> Self {
        Self(std::process::id())
    }

    /// Whether this is the process that made the object.
    pub(crate) fn is_here(self) -> bool {
        self == Self::here()
    }

    /// `ForkedProcessError` naming `what` unless this is the process that made it.
    pub(crate) fn check(self, what: &str) -> PyResult<()> {
        if self.is_here() {
            return Ok(());
        }
        Err(ForkedProcessError::new_err(format!(
            "this {what} belongs to process {} and this is its child {} (made by os.fork()): \
             its threads and sockets are in the parent, which keeps running it. Make a new \
             one in the child (or start the child with multiprocessing's \"spawn\" method)",
            self.0,
            std::process::id()
        )))
    }
}
