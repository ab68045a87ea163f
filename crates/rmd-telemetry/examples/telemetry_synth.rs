//! Feeds synthetic tick records (a three-joint leg waving) through the telemetry pipeline into
//! any of the sinks, and writes what it fed as a JSON "truth" file first. The Python tests of
//! tests/telemetry/ read the outputs with independent readers and compare them to the truth.
//!
//! ```text
//! cargo run -p rmd-telemetry --example telemetry_synth -- \
//!     --ticks 5000 --mcap run.mcap --csv run.csv --foxglove 127.0.0.1:8765 --realtime
//! ```
//!
//! Prints `foxglove ws://ADDR` once the live server listens, and the final statistics as one
//! JSON line. Without `--realtime` the records are pushed as fast as the sinks take them
//! (lossless delivery); with it, one per tick period, lossy, as the real loop does. SIGINT and
//! SIGTERM stop the run early and still close every sink cleanly.

use std::io::Write as _;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use clap::Parser;
use rmd_protocol::{ErrorState, MotorId};
use rmd_telemetry::{
    CsvSink, Delivery, JointInfo, JointRecord, LiveOptions, LiveSink, McapOptions, McapSink,
    ReplyAge, RunLayout, Telemetry, TickRecord,
};
use serde_json::json;

#[derive(Parser)]
struct Args {
    /// Number of ticks to produce.
    #[arg(long, default_value_t = 2000)]
    ticks: u64,
    /// Loop rate (Hz).
    #[arg(long, default_value_t = 1000.0)]
    rate: f64,
    /// Pace the records at the loop rate (lossy delivery, like the real loop).
    #[arg(long)]
    realtime: bool,
    /// MCAP output.
    #[arg(long)]
    mcap: Option<PathBuf>,
    /// MCAP chunk size (bytes).
    #[arg(long, default_value_t = 1024 * 1024)]
    chunk_size: u64,
    /// Write MCAP chunks uncompressed.
    #[arg(long)]
    no_compression: bool,
    /// CSV output.
    #[arg(long)]
    csv: Option<PathBuf>,
    /// Serve live on this address (port 0: any free port).
    #[arg(long)]
    foxglove: Option<SocketAddr>,
    /// Live publishing rate (Hz).
    #[arg(long, default_value_t = 100.0)]
    live_rate: f64,
    /// Where to write the truth (what was fed), before the run starts.
    #[arg(long)]
    truth: Option<PathBuf>,
    /// Write the Foxglove layout of this run here.
    #[arg(long)]
    foxglove_layout: Option<PathBuf>,
    /// The run's start as Unix nanoseconds (default: now).
    #[arg(long)]
    start_unix_ns: Option<u64>,
}

const JOINTS: [(&str, bool); 3] = [("hip_flexion", true), ("knee", true), ("ankle", false)];
const SIGNALS: [&str; 2] = ["knee_target_rad", "phase"];

/// The record of tick `tick`: deterministic, with every case the sinks must handle.
fn synth(tick: u64, period_ns: u64) -> TickRecord {
    let since = tick * period_ns;
    let t = since as f64 * 1e-9;
    let mut record = TickRecord::new(tick, since, 1_000_000_000 + since);
    for (j, (_, torque)) in JOINTS.iter().enumerate() {
        let phase = std::f64::consts::TAU * 0.5 * t + j as f64;
        // The ankle's motor answers only from tick 10 on; the knee misses every 7th tick.
        let reply = if j == 2 && tick < 10 {
            None
        } else if j == 1 && tick % 7 == 3 {
            Some(ReplyAge {
                ticks: 1,
                micros: 1150,
            })
        } else {
            Some(ReplyAge::fresh(150 + j as u32))
        };
        record.joints[j] = JointRecord {
            position_rad: 0.4 * phase.sin(),
            velocity_rad_s: 0.4 * std::f64::consts::TAU * 0.5 * phase.cos(),
            effort_nm: torque.then_some(1.5 * phase.sin()),
            current_a: 2.0 * phase.sin(),
            commanded_a: 2.1 * phase.sin(),
            temperature_c: 30.0 + j as f64 + t * 0.01,
            voltage_v: tick.is_multiple_of(10).then_some(24.0),
            error_flags: Some(ErrorState::NONE),
            reply,
        };
    }
    record.timing.wake_latency_us = 5.0 + (tick % 13) as f64;
    record.timing.round_trip_us = (tick % 100 != 50).then_some(300.0 + (tick % 5) as f64);
    record.timing.controller_us = 2.5;
    record.timing.work_us = 40.0 + (tick % 17) as f64;
    record.timing.deadline_missed = tick % 500 == 499;
    record.timing.misses = (tick + 1) / 500;
    record.timing.missing_replies = tick / 7;
    record.timing.late_replies = tick / 1000;
    record.signals[0] = record.joints[1].position_rad + 0.01;
    record.signals[1] = (t * 0.5).fract();
    record
}

fn truth(layout: &RunLayout, ticks: u64, period_ns: u64) -> serde_json::Value {
    let records: Vec<serde_json::Value> = (0..ticks)
        .map(|tick| {
            let r = synth(tick, period_ns);
            let joints = &r.joints[..JOINTS.len()];
            json!({
                "tick": r.tick,
                "since_start_ns": r.since_start_ns,
                "replied": joints.iter().map(JointRecord::has_reply).collect::<Vec<_>>(),
                "fresh": joints.iter().map(JointRecord::is_fresh).collect::<Vec<_>>(),
                "position": joints.iter().map(|j| j.position_rad).collect::<Vec<_>>(),
                "velocity": joints.iter().map(|j| j.velocity_rad_s).collect::<Vec<_>>(),
                "effort": joints.iter().map(|j| j.effort_nm).collect::<Vec<_>>(),
                "current": joints.iter().map(|j| j.current_a).collect::<Vec<_>>(),
                "commanded": joints.iter().map(|j| j.commanded_a).collect::<Vec<_>>(),
                "signals": &r.signals[..SIGNALS.len()],
                "work_us": r.timing.work_us,
                "misses": r.timing.misses,
            })
        })
        .collect();
    json!({
        "start_unix_ns": layout.start_unix_ns(),
        "rate_hz": layout.rate_hz(),
        "joints": JOINTS.iter().map(|(n, _)| n).collect::<Vec<_>>(),
        "torque_known": JOINTS.iter().map(|(_, t)| t).collect::<Vec<_>>(),
        "signals": SIGNALS,
        "records": records,
    })
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args = Args::parse();
    let start = args
        .start_unix_ns
        .map_or_else(SystemTime::now, |ns| UNIX_EPOCH + Duration::from_nanos(ns));
    let mut builder = RunLayout::builder(args.rate).bus_count(1).start_time(start);
    for (i, (name, torque)) in JOINTS.iter().enumerate() {
        let id = MotorId::new(u8::try_from(i + 1)?)?;
        builder = builder.joint(JointInfo::new(*name, 0, id).with_torque_constant(*torque));
    }
    for signal in SIGNALS {
        builder = builder.signal(signal);
    }
    let layout = builder.build()?;
    let period_ns = (1e9 / args.rate).round() as u64;

    if let Some(path) = &args.foxglove_layout {
        std::fs::write(path, rmd_telemetry::foxglove_layout(&layout).to_string())?;
    }
    if let Some(path) = &args.truth {
        std::fs::write(path, truth(&layout, args.ticks, period_ns).to_string())?;
    }

    let mcap = match &args.mcap {
        Some(path) => Some(McapSink::create(
            path,
            &layout,
            McapOptions {
                chunk_size: args.chunk_size,
                compress: !args.no_compression,
                ..McapOptions::default()
            },
        )?),
        None => None,
    };
    let csv = match &args.csv {
        Some(path) => Some(CsvSink::create(path, &layout)?),
        None => None,
    };
    let live = match args.foxglove {
        Some(addr) => {
            let live = LiveSink::start(
                &layout,
                LiveOptions {
                    addr,
                    rate_hz: args.live_rate,
                    ..LiveOptions::default()
                },
            )?;
            println!("foxglove ws://{}", live.local_addr());
            std::io::stdout().flush()?;
            Some(live)
        }
        None => None,
    };
    let delivery = if args.realtime {
        Delivery::Lossy
    } else {
        Delivery::Lossless
    };
    let (producer, pipeline) = Telemetry::builder()
        .sink_opt(mcap)
        .sink_opt(csv)
        .sink_opt(live)
        .delivery(delivery)
        .start()?;

    let stop = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&stop);
    ctrlc::set_handler(move || flag.store(true, Ordering::Release))?;

    let began = Instant::now();
    let mut produced = 0;
    for tick in 0..args.ticks {
        if stop.load(Ordering::Acquire) {
            break;
        }
        if args.realtime {
            let due = began + Duration::from_nanos(tick * period_ns);
            if let Some(wait) = due.checked_duration_since(Instant::now()) {
                std::thread::sleep(wait);
            }
        }
        producer.push(&synth(tick, period_ns));
        produced += 1;
    }
    let stats = pipeline.shutdown();
    let sinks: Vec<serde_json::Value> = stats
        .sinks
        .iter()
        .map(|s| {
            json!({
                "name": s.name,
                "written": s.written,
                "failed": s.failed,
                "dropped": s.dropped,
                "errors": s.errors,
                "first_error": s.first_error,
            })
        })
        .collect();
    println!(
        "{}",
        json!({ "produced": produced, "offered": stats.offered, "sinks": sinks })
    );
    eprintln!("{stats}");
    Ok(())
}
