//! The loop's telemetry mailbox: what a consumer gets, overwritten or waited for.

use crate::common;

use core::time::Duration;

use common::*;
use rmd_bus::VirtualClock;
use rmd_loop::{RtLoop, RunLimit, StopReason, telemetry::TelemetryDelivery};

/// Runs 2000 ticks of the leg on virtual time with a telemetry mailbox of 8 samples, `delivery`,
/// and a consumer that takes one sample every `every` (none at all if `None`); returns the
/// report and the samples' (tick, ticks run, time) the consumer got.
fn run(
    delivery: TelemetryDelivery,
    every: Option<Duration>,
) -> (rmd_loop::LoopReport, Vec<(u64, u64, f64)>) {
    let clock = VirtualClock::new();
    let mut bus = sim(&clock, 4, 3, &[]);
    let mut config = robot_config(1000.0, 1, 4);
    config.loop_config.telemetry_capacity = 8;
    let robot = rmd_loop::robot::Robot::try_from(config).unwrap();
    let mut rt = RtLoop::unsupervised(robot, clock, vec![&mut bus], PdTo::hold(4)).unwrap();
    let rx = rt.telemetry_with(delivery);
    let consumer = match every {
        // Nobody will ever read: the receiver is gone before the run.
        None => {
            drop(rx);
            None
        }
        Some(every) => Some(std::thread::spawn(move || {
            let mut got = Vec::new();
            // Until the loop has finished (its sender is gone) and everything is taken.
            while rx.has_senders() || !rx.is_empty() {
                match rx.try_recv() {
                    Some(s) => got.push((s.tick, s.totals.ticks, s.time_s)),
                    None => std::thread::sleep(Duration::from_micros(20)),
                }
                std::thread::sleep(every);
            }
            got
        })),
    };
    let out = rt.run(RunLimit::Ticks(2000));
    let got = consumer.map(|c| c.join().unwrap()).unwrap_or_default();
    (out.report, got)
}

#[test]
fn waiting_delivery_hands_a_slow_consumer_every_tick() {
    let (report, got) = run(TelemetryDelivery::Wait, Some(Duration::from_micros(30)));
    assert_eq!(report.stop_reason, StopReason::TickLimit);
    assert_eq!(report.stats.telemetry_drops, 0);
    assert_eq!(got.len(), 2000, "one sample per tick");
    for (k, &(tick, ticks_run, time_s)) in got.iter().enumerate() {
        assert_eq!(tick, k as u64);
        assert_eq!(ticks_run, k as u64 + 1, "ticks run, this one included");
        assert!((time_s - k as f64 * 1e-3).abs() < 1e-9);
    }
}

#[test]
fn overwriting_delivery_counts_what_a_slow_consumer_missed() {
    let (report, got) = run(
        TelemetryDelivery::Overwrite,
        Some(Duration::from_micros(200)),
    );
    assert_eq!(report.stats.ticks, 2000);
    // The consumer is far slower than virtual time: most samples were overwritten, counted.
    assert!(report.stats.telemetry_drops > 0);
    assert_eq!(got.len() as u64 + report.stats.telemetry_drops, 2000);
    // What it got is in order, and the gaps in `ticks` say where samples were lost.
    assert!(got.windows(2).all(|w| w[0].1 < w[1].1));
}

#[test]
fn a_waiting_loop_without_a_receiver_never_hangs() {
    let (report, got) = run(TelemetryDelivery::Wait, None);
    assert_eq!(report.stop_reason, StopReason::TickLimit);
    assert!(got.is_empty());
    // The first 8 fill the mailbox; every later one finds no receiver and is counted.
    assert_eq!(report.stats.telemetry_drops, 2000 - 8);
}
