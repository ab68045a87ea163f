//! The cost of one producer push (ns), as the real-time loop would pay it: one push per tick at
//! the loop rate, with every sink on (MCAP file, live server with a subscribed client or not,
//! CSV), each push timed on its own. Also the same with no sink (the disabled producer).
//!
//! Not a criterion bench: criterion repeats the measured call back to back, which fills any
//! bounded queue in microseconds and then measures only the "queue full, record dropped" path.
//! The loop pushes once per period; so does this bench.
//!
//! ```text
//! cargo bench -p rmd-telemetry --bench push            # 1 kHz, 10 s, 12 joints
//! PUSH_SECONDS=30 PUSH_RATE_HZ=2000 cargo bench -p rmd-telemetry --bench push
//! ```
//!
//! Run it on a quiet machine: every figure is a wall-clock time.

use std::hint::black_box;
use std::net::SocketAddr;
use std::time::{Duration, Instant};

use rmd_protocol::MotorId;
use rmd_telemetry::{
    CsvSink, JointInfo, JointRecord, LiveOptions, LiveSink, McapOptions, McapSink, Producer,
    PushOutcome, ReplyAge, RunLayout, Telemetry, TickRecord,
};

fn env_or<T: std::str::FromStr>(name: &str, default: T) -> T {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

/// Nanoseconds of an empty `Instant::now()` pair, to subtract from each timing.
fn timer_overhead_ns() -> u64 {
    let mut samples: Vec<u64> = (0..10_000)
        .map(|_| {
            let t = Instant::now();
            black_box(());
            t.elapsed().as_nanos() as u64
        })
        .collect();
    samples.sort_unstable();
    samples[samples.len() / 2]
}

struct Run {
    samples: Vec<u64>,
    queued: u64,
    dropped: u64,
}

fn paced(producer: &Producer, joints: usize, rate_hz: f64, seconds: f64, overhead: u64) -> Run {
    let period = Duration::from_secs_f64(1.0 / rate_hz);
    let ticks = (seconds * rate_hz) as u64;
    let mut record = TickRecord::new(0, 0, 0);
    let mut run = Run {
        samples: Vec::with_capacity(ticks as usize),
        queued: 0,
        dropped: 0,
    };
    let start = Instant::now();
    for tick in 0..ticks {
        let due = start + period * u32::try_from(tick).unwrap_or(u32::MAX);
        while Instant::now() < due {
            std::hint::spin_loop();
        }
        record.tick = tick;
        record.since_start_ns = tick * period.as_nanos() as u64;
        for (j, joint) in record.joints[..joints].iter_mut().enumerate() {
            *joint = JointRecord {
                position_rad: (tick as f64 * 1e-3 + j as f64).sin(),
                velocity_rad_s: 0.1,
                effort_nm: Some(0.2),
                current_a: 1.0,
                commanded_a: 1.1,
                temperature_c: 35.0,
                voltage_v: Some(24.0),
                error_flags: None,
                reply: Some(ReplyAge::fresh(120)),
            };
        }
        let t = Instant::now();
        let outcome = producer.push(black_box(&record));
        run.samples
            .push((t.elapsed().as_nanos() as u64).saturating_sub(overhead));
        match outcome {
            PushOutcome::Queued => run.queued += 1,
            PushOutcome::Dropped => run.dropped += 1,
            PushOutcome::NoSinks | PushOutcome::Closed => {}
        }
    }
    run
}

fn report(label: &str, mut run: Run) {
    run.samples.sort_unstable();
    let at = |q: f64| run.samples[((run.samples.len() - 1) as f64 * q) as usize];
    println!(
        "{label:<34} n={:<6} p50={:>5} ns  p90={:>5} ns  p99={:>6} ns  p99.9={:>6} ns  max={:>7} ns  \
         queued={} dropped={}",
        run.samples.len(),
        at(0.5),
        at(0.9),
        at(0.99),
        at(0.999),
        run.samples.last().copied().unwrap_or(0),
        run.queued,
        run.dropped
    );
}

fn main() {
    // `cargo test --benches` runs this with `--bench`-less args; keep that quick.
    let quick = !std::env::args().any(|a| a == "--bench");
    let seconds: f64 = if quick {
        0.2
    } else {
        env_or("PUSH_SECONDS", 10.0)
    };
    let rate_hz: f64 = env_or("PUSH_RATE_HZ", 1000.0);
    let joints: usize = env_or("PUSH_JOINTS", 12);
    let overhead = timer_overhead_ns();
    println!(
        "push cost: {joints} joints, {rate_hz} Hz, {seconds} s per case; timer overhead {overhead} ns \
         subtracted; record size {} bytes",
        std::mem::size_of::<TickRecord>()
    );

    report(
        "no sink (disabled producer)",
        paced(&Producer::disabled(), joints, rate_hz, seconds, overhead),
    );

    let mut layout = RunLayout::builder(rate_hz).bus_count(3);
    for j in 0..joints {
        let id =
            MotorId::new(u8::try_from(j % 4 + 1).unwrap_or(1)).unwrap_or(MotorId::new(1).unwrap());
        layout =
            layout.joint(JointInfo::new(format!("joint{j}"), j / 4, id).with_torque_constant(true));
    }
    let layout = layout
        .signal("a")
        .signal("b")
        .build()
        .expect("a valid layout");
    let dir = std::env::temp_dir().join(format!("rmd-telemetry-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("a temporary directory");
    let live = LiveSink::start(
        &layout,
        LiveOptions {
            addr: SocketAddr::from(([127, 0, 0, 1], 0)),
            ..LiveOptions::default()
        },
    )
    .expect("the live server");
    let (producer, pipeline) = Telemetry::builder()
        .sink(
            McapSink::create(dir.join("bench.mcap"), &layout, McapOptions::default())
                .expect("mcap"),
        )
        .sink(live)
        .sink(CsvSink::create(dir.join("bench.csv"), &layout).expect("csv"))
        .start()
        .expect("the pipeline");
    report(
        "all sinks (mcap, live, csv)",
        paced(&producer, joints, rate_hz, seconds, overhead),
    );
    let stats = pipeline.shutdown();
    println!("{stats}");
    let _ = std::fs::remove_dir_all(&dir);
}
