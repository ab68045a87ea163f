//! The loop thread's vital signs (what the supervisor watches of it), and the handshake that
//! keeps the two from sending at the same time. Everything the loop thread touches here is a
//! lock-free atomic.
//!
//! The loop's phase decides who may send. The loop moves `Running -> Finishing` and the
//! supervisor `Running -> TakenOver`, each with a compare-and-swap, so exactly one of them makes
//! the motors safe. Before each frame it sends, the loop raises `sending` and checks the phase
//! (and the supervisor, after its swap, waits for `sending` to fall): either the loop sees the
//! takeover and sends nothing more, or the supervisor's frames go out after the loop's last one.

use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicU8, AtomicU64, Ordering};

use rmd_bus::Timestamp;

use crate::report::{SafeStopReport, StopReason};
use crate::stall::TickStage;

/// The loop's phase.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[repr(u8)]
pub(crate) enum LoopPhase {
    /// Built, or probing the motors.
    Starting = 0,
    /// Ticking.
    Running = 1,
    /// The loop thread is ending the run (it makes the motors safe).
    Finishing = 2,
    /// The supervisor took over (it makes the motors safe; the loop sends nothing more).
    TakenOver = 3,
    /// The run is over.
    Finished = 4,
}

impl LoopPhase {
    fn from_u8(v: u8) -> Self {
        match v {
            0 => LoopPhase::Starting,
            1 => LoopPhase::Running,
            2 => LoopPhase::Finishing,
            3 => LoopPhase::TakenOver,
            _ => LoopPhase::Finished,
        }
    }
}

/// What the supervisor did when it took over.
#[derive(Debug)]
pub(crate) struct Takeover {
    /// Why.
    pub(crate) reason: StopReason,
    /// Its safe stop.
    pub(crate) report: SafeStopReport,
}

/// The loop thread's vital signs as the supervisor sees them (its phase, last sign of life, tick
/// and stage), the sending handshake and the takeover.
#[derive(Debug)]
pub(crate) struct LoopVitals {
    phase: AtomicU8,
    /// Loop-clock time (ns) of the last sign of life: a tick started or ended.
    last_progress_ns: AtomicU64,
    /// The tick in progress (for the report of a stall).
    tick: AtomicU64,
    /// Where in its tick the loop thread is (a [`TickStage`]).
    stage: AtomicU8,
    sending: AtomicBool,
    /// Motor-off went out on every bus (by the loop or the supervisor).
    motors_off_sent: AtomicBool,
    /// Written by the supervisor, read at the end of the run (never by a tick).
    takeover: Mutex<Option<Takeover>>,
}

impl LoopVitals {
    pub(crate) fn new() -> Self {
        Self {
            phase: AtomicU8::new(LoopPhase::Starting as u8),
            last_progress_ns: AtomicU64::new(0),
            tick: AtomicU64::new(0),
            stage: AtomicU8::new(TickStage::Waiting as u8),
            sending: AtomicBool::new(false),
            motors_off_sent: AtomicBool::new(false),
            takeover: Mutex::new(None),
        }
    }

    #[inline]
    pub(crate) fn phase(&self) -> LoopPhase {
        LoopPhase::from_u8(self.phase.load(Ordering::SeqCst))
    }

    pub(crate) fn set_phase(&self, phase: LoopPhase) {
        self.phase.store(phase as u8, Ordering::SeqCst);
    }

    /// Moves `from -> to` if the phase is `from`; whether it did.
    pub(crate) fn swap_phase(&self, from: LoopPhase, to: LoopPhase) -> bool {
        self.phase
            .compare_exchange(from as u8, to as u8, Ordering::SeqCst, Ordering::SeqCst)
            .is_ok()
    }

    /// A sign of life of the loop thread at `now`, in `tick`.
    #[inline]
    pub(crate) fn progress(&self, now: Timestamp, tick: u64) {
        self.tick.store(tick, Ordering::Relaxed);
        self.last_progress_ns
            .store(now.as_nanos(), Ordering::Release);
    }

    /// The loop thread enters `stage` of its tick (a relaxed store: the supervisor only reads
    /// it to say where a stall happened).
    #[inline]
    pub(crate) fn enter(&self, stage: TickStage) {
        self.stage.store(stage as u8, Ordering::Relaxed);
    }

    /// Where in its tick the loop thread is.
    pub(crate) fn stage(&self) -> TickStage {
        TickStage::from_u8(self.stage.load(Ordering::Relaxed))
    }

    /// The last sign of life, and the tick it was in.
    pub(crate) fn last_progress(&self) -> (Timestamp, u64) {
        let at = Timestamp::from_nanos(self.last_progress_ns.load(Ordering::Acquire));
        (at, self.tick.load(Ordering::Relaxed))
    }

    /// Called by the loop thread before it sends: whether it may (the supervisor has not taken
    /// over). If it may, [`end_send`](Self::end_send) must follow the send.
    #[inline]
    pub(crate) fn begin_send(&self) -> bool {
        self.sending.store(true, Ordering::SeqCst);
        if self.phase() == LoopPhase::Running {
            true
        } else {
            self.sending.store(false, Ordering::SeqCst);
            false
        }
    }

    #[inline]
    pub(crate) fn end_send(&self) {
        // Release is enough here (a plain store on x86, not a locked one): the supervisor that
        // reads `false` sees the send completed. Only `begin_send`'s store-then-load needs
        // SeqCst, against the supervisor's phase change followed by its read of `sending`.
        self.sending.store(false, Ordering::Release);
    }

    /// Called by the supervisor after taking over: waits until the loop thread is out of a send.
    pub(crate) fn wait_for_send(&self) {
        while self.sending.load(Ordering::SeqCst) {
            std::hint::spin_loop();
        }
    }

    pub(crate) fn set_motors_off_sent(&self) {
        self.motors_off_sent.store(true, Ordering::SeqCst);
    }

    /// Whether motor-off went out on every bus.
    pub(crate) fn motors_off_sent(&self) -> bool {
        self.motors_off_sent.load(Ordering::SeqCst)
    }

    pub(crate) fn put_takeover(&self, takeover: Takeover) {
        *self
            .takeover
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner) = Some(takeover);
    }

    pub(crate) fn take_takeover(&self) -> Option<Takeover> {
        self.takeover
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .take()
    }
}
