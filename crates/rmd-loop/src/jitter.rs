//! Timer jitter, measured the way `cyclictest` measures the kernel's: the wake latency of every
//! tick (actual wake minus the absolute deadline), with no bus and no controller, on the same
//! [`Scheduler`] and OS setup the real-time loop uses.

use core::time::Duration;

use rmd_bus::{Clock, MonotonicClock};
use serde::Serialize;

use crate::os::{self, RtRequest, RtStatus};
use crate::schedule::{OverrunPolicy, Period, Scheduler};
use crate::stats::{LatencyHistogram, Percentiles};

/// What to measure.
#[derive(Clone, Debug, PartialEq)]
pub struct JitterConfig {
    /// Tick period.
    pub period: Period,
    /// How long to measure.
    pub duration: Duration,
    /// Sleep until this long before each deadline, then spin (zero: sleep only).
    pub spin_margin: Duration,
    /// CPU pinning, `SCHED_FIFO` priority, memory locking and the CPU latency request of the
    /// measuring thread (the request is held for the measurement, as the loop holds it).
    pub rt: RtRequest,
}

/// The result of a jitter measurement.
#[derive(Clone, Debug, Serialize)]
pub struct JitterReport {
    /// Ticks measured.
    pub ticks: u64,
    /// Ticks that woke after the next tick was already due.
    pub deadline_misses: u64,
    /// Wake latency percentiles, microseconds.
    pub wake_latency_us: Percentiles,
    /// Period, microseconds.
    pub period_us: f64,
    /// Spin margin, microseconds.
    pub spin_us: f64,
    /// What the OS granted.
    #[serde(skip)]
    pub rt: RtStatus,
    /// The histogram, for plots.
    #[serde(skip)]
    pub histogram: LatencyHistogram,
}

/// Measures on the calling thread (which it pins and prioritises as asked) with `clock`.
pub fn measure<C: Clock + ?Sized>(clock: &C, config: &JitterConfig) -> JitterReport {
    measure_while(clock, config, || true)
}

/// [`measure`], ending early at the first tick `go_on` returns false (asked once a tick,
/// after the wake is measured): the report has the ticks measured until then.
pub fn measure_while<C: Clock + ?Sized>(
    clock: &C,
    config: &JitterConfig,
    go_on: impl Fn() -> bool,
) -> JitterReport {
    let setup = os::apply_to_current_thread(&config.rt);
    let planned = (config.duration.as_nanos() / config.period.get().as_nanos()).max(1) as u64;
    let mut histogram = LatencyHistogram::new();
    let mut deadline_misses = 0;
    let t0 = clock.now() + config.period.get();
    let mut scheduler = Scheduler::new(
        config.period,
        config.spin_margin,
        OverrunPolicy::Continue,
        t0,
    );
    let mut ticks = 0;
    while ticks < planned {
        let tick = scheduler.wait_next(clock);
        histogram.record(tick.wake_latency());
        if scheduler.end_tick(clock.now()).missed_deadline {
            deadline_misses += 1;
        }
        ticks += 1;
        if !go_on() {
            break;
        }
    }
    JitterReport {
        ticks,
        deadline_misses,
        wake_latency_us: histogram.percentiles(),
        period_us: config.period.get().as_secs_f64() * 1e6,
        spin_us: config.spin_margin.as_secs_f64() * 1e6,
        // The measurement is over: the CPU latency request is withdrawn here.
        rt: setup.status,
        histogram,
    }
}

/// Measures in real time on a dedicated thread (so that pinning and priority do not touch the
/// caller's thread).
pub fn measure_real_time(config: JitterConfig) -> std::io::Result<JitterReport> {
    measure_real_time_while(config, || true)
}

/// [`measure_real_time`], ending early when `go_on` returns false (see [`measure_while`]).
pub fn measure_real_time_while(
    config: JitterConfig,
    go_on: impl Fn() -> bool + Send + 'static,
) -> std::io::Result<JitterReport> {
    let thread = std::thread::Builder::new()
        .name("rmd-rt-jitter".to_string())
        .stack_size(crate::handle::LOOP_STACK_BYTES)
        .spawn(move || measure_while(&MonotonicClock, &config, go_on))?;
    thread
        .join()
        .map_err(|_| std::io::Error::other("the jitter measurement thread panicked"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rmd_bus::VirtualClock;

    #[test]
    fn virtual_time_has_no_jitter_and_counts_ticks() {
        let config = JitterConfig {
            period: Period::from_hz(1000.0).unwrap(),
            duration: Duration::from_millis(250),
            spin_margin: Duration::from_micros(20),
            rt: RtRequest::default(),
        };
        let report = measure(&VirtualClock::new(), &config);
        assert_eq!(report.ticks, 250);
        assert_eq!(report.deadline_misses, 0);
        assert_eq!(report.wake_latency_us.count, 250);
        assert_eq!(report.wake_latency_us.max, 0.0);
    }

    #[test]
    fn a_measurement_ends_at_the_first_tick_told_to_stop() {
        let config = JitterConfig {
            period: Period::from_hz(1000.0).unwrap(),
            duration: Duration::from_millis(250),
            spin_margin: Duration::ZERO,
            rt: RtRequest::default(),
        };
        let asked = core::cell::Cell::new(0);
        let report = measure_while(&VirtualClock::new(), &config, || {
            asked.set(asked.get() + 1);
            asked.get() < 10
        });
        assert_eq!(report.ticks, 10);
        assert_eq!(report.wake_latency_us.count, 10);
    }

    #[test]
    fn real_time_measures_every_tick() {
        // No assertion on the latency values (shared VM): only that each tick was measured.
        let report = measure_real_time(JitterConfig {
            period: Period::from_hz(2000.0).unwrap(),
            duration: Duration::from_millis(50),
            spin_margin: Duration::ZERO,
            rt: RtRequest::default(),
        })
        .unwrap();
        assert_eq!(report.ticks, 100);
        assert_eq!(report.wake_latency_us.count, 100);
        assert!(report.wake_latency_us.max >= report.wake_latency_us.p50);
    }
}
