//! One loop tick as plain, fixed-size data: what the producer pushes and every sink reads.

use rmd_protocol::ErrorState;

/// The most joints a [`TickRecord`] carries.
pub const MAX_JOINTS: usize = 32;

/// The most user signals a [`TickRecord`] carries.
pub const MAX_SIGNALS: usize = 16;

/// How old the last reply of a motor is when the tick's record is taken.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ReplyAge {
    /// Whole ticks since the tick the reply belongs to: 0 means fresh (received this tick).
    pub ticks: u32,
    /// Microseconds since the reply was received.
    pub micros: u32,
}

impl ReplyAge {
    /// A reply received this tick, `micros` µs ago.
    pub const fn fresh(micros: u32) -> Self {
        Self { ticks: 0, micros }
    }

    /// Whether the reply was received this tick.
    pub const fn is_fresh(self) -> bool {
        self.ticks == 0
    }
}

/// One joint (and its motor) in one tick. Joint-side values are in joint units (after gear ratio,
/// direction and zero offset); motor-side values are as the motor reports them.
///
/// [`JointRecord::reply`] is `None` until the motor has answered once; the sinks then write "no
/// value" (NaN, `null` or an empty cell) for every measured field of the joint, whatever they
/// hold.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointRecord {
    /// Joint position (rad).
    pub position_rad: f64,
    /// Joint velocity (rad/s).
    pub velocity_rad_s: f64,
    /// Joint torque (N·m); `None` when the motor's torque constant is unknown.
    pub effort_nm: Option<f64>,
    /// Measured motor current, q axis (A).
    pub current_a: f64,
    /// The current commanded this tick (A).
    pub commanded_a: f64,
    /// Motor temperature (°C).
    pub temperature_c: f64,
    /// Supply voltage (V), when a reply carrying it has been received.
    pub voltage_v: Option<f64>,
    /// The motor's error flags, when a reply carrying them has been received.
    pub error_flags: Option<ErrorState>,
    /// Age of the last reply; `None` if the motor has never replied.
    pub reply: Option<ReplyAge>,
}

impl JointRecord {
    /// A joint whose motor has never replied and that is commanded nothing.
    pub const EMPTY: Self = Self {
        position_rad: 0.0,
        velocity_rad_s: 0.0,
        effort_nm: None,
        current_a: 0.0,
        commanded_a: 0.0,
        temperature_c: 0.0,
        voltage_v: None,
        error_flags: None,
        reply: None,
    };

    /// Whether the motor replied this tick.
    pub fn is_fresh(&self) -> bool {
        self.reply.is_some_and(ReplyAge::is_fresh)
    }

    /// Whether the motor has replied at least once (so the measured fields mean something).
    pub fn has_reply(&self) -> bool {
        self.reply.is_some()
    }
}

impl Default for JointRecord {
    fn default() -> Self {
        Self::EMPTY
    }
}

/// The loop's timing in one tick.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct LoopTiming {
    /// How late the loop woke after the tick's scheduled time (µs).
    pub wake_latency_us: f64,
    /// From the first frame sent to the last reply received (µs); `None` when no reply came.
    pub round_trip_us: Option<f64>,
    /// Time spent in the controller (µs).
    pub controller_us: f64,
    /// The tick's whole work, wake to done (µs).
    pub work_us: f64,
    /// Whether this tick missed its deadline.
    pub deadline_missed: bool,
    /// Deadline misses since the start.
    pub misses: u64,
    /// Replies that never came, since the start.
    pub missing_replies: u64,
    /// Replies that came after their tick's deadline, since the start.
    pub late_replies: u64,
}

/// Everything about one loop tick. Fixed size and [`Copy`]: pushing one allocates nothing.
///
/// Entries of [`TickRecord::joints`] and [`TickRecord::signals`] follow the
/// [`RunLayout`](crate::RunLayout)'s order; entries past the layout's counts are ignored.
///
/// ```
/// use rmd_telemetry::{JointRecord, ReplyAge, TickRecord};
///
/// let mut record = TickRecord::new(7, 7_000_000, 123_456_789);
/// record.joints[0] = JointRecord {
///     position_rad: 0.5,
///     reply: Some(ReplyAge::fresh(120)),
///     ..JointRecord::EMPTY
/// };
/// record.signals[0] = 1.25;
/// assert!(record.joints[0].is_fresh());
/// assert_eq!(record.time_s(), 0.007);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TickRecord {
    /// The tick's index (0 for the first tick).
    pub tick: u64,
    /// Time since the run's start (ns), on the loop's clock.
    pub since_start_ns: u64,
    /// The loop clock's monotonic timestamp of the tick (ns).
    pub monotonic_ns: u64,
    /// Per joint, in layout order.
    pub joints: [JointRecord; MAX_JOINTS],
    /// The tick's timing.
    pub timing: LoopTiming,
    /// The user signals, in layout order.
    pub signals: [f64; MAX_SIGNALS],
}

impl TickRecord {
    /// A record for tick `tick` at `since_start_ns` (and monotonic time `monotonic_ns`) with every
    /// joint [`JointRecord::EMPTY`], zero timing and zero signals.
    pub const fn new(tick: u64, since_start_ns: u64, monotonic_ns: u64) -> Self {
        Self {
            tick,
            since_start_ns,
            monotonic_ns,
            joints: [JointRecord::EMPTY; MAX_JOINTS],
            timing: LoopTiming {
                wake_latency_us: 0.0,
                round_trip_us: None,
                controller_us: 0.0,
                work_us: 0.0,
                deadline_missed: false,
                misses: 0,
                missing_replies: 0,
                late_replies: 0,
            },
            signals: [0.0; MAX_SIGNALS],
        }
    }

    /// Time since the start (s).
    pub fn time_s(&self) -> f64 {
        self.since_start_ns as f64 * 1e-9
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn freshness_follows_the_reply_age() {
        let mut j = JointRecord::EMPTY;
        assert!(!j.is_fresh() && !j.has_reply());
        j.reply = Some(ReplyAge {
            ticks: 2,
            micros: 2100,
        });
        assert!(!j.is_fresh() && j.has_reply());
        j.reply = Some(ReplyAge::fresh(90));
        assert!(j.is_fresh());
    }

    #[test]
    fn a_record_is_a_few_kilobytes_and_copy() {
        fn assert_copy<T: Copy + Send>() {}
        assert_copy::<TickRecord>();
        // A queue slot is one record: keep it small enough to copy every tick.
        assert!(std::mem::size_of::<TickRecord>() <= 4096);
    }
}
