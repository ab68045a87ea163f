//! The producer's push allocates nothing, with every sink on (MCAP file, live server, CSV).
//! A counting global allocator counts the allocations of the pushing thread only; the sink
//! threads allocate as they like.

use std::net::SocketAddr;
use std::time::Duration;

use rmd_protocol::MotorId;
use rmd_telemetry::{
    CsvSink, JointInfo, JointRecord, LiveOptions, LiveSink, McapOptions, McapSink, PushOutcome,
    ReplyAge, RunLayout, Telemetry, TickRecord,
};

/// Allocations of the calling thread so far.
fn allocations() -> u64 {
    rmd_test_support::alloc::this_thread().allocations
}

#[test]
fn pushing_allocates_nothing_with_every_sink_on() {
    // The probe itself sees this thread's allocations.
    let before = allocations();
    let probe = std::hint::black_box(Box::new(1_u64));
    assert!(allocations() > before, "the counting allocator counts");
    drop(probe);

    let dir = tempfile::tempdir().unwrap();
    let layout = RunLayout::builder(1000.0)
        .joint(JointInfo::new("hip", 0, MotorId::new(1).unwrap()).with_torque_constant(true))
        .joint(JointInfo::new("knee", 0, MotorId::new(2).unwrap()))
        .signal("target")
        .build()
        .unwrap();
    let live = LiveSink::start(
        &layout,
        LiveOptions {
            addr: SocketAddr::from(([127, 0, 0, 1], 0)),
            ..LiveOptions::default()
        },
    )
    .unwrap();
    let (producer, pipeline) = Telemetry::builder()
        .sink(
            McapSink::create(dir.path().join("run.mcap"), &layout, McapOptions::default()).unwrap(),
        )
        .sink(live)
        .sink(CsvSink::create(dir.path().join("run.csv"), &layout).unwrap())
        .start()
        .unwrap();

    let mut record = TickRecord::new(0, 0, 0);
    let mut counted = 0;
    let mut queued = 0;
    for tick in 0..3000_u64 {
        // Fill the record as a loop would (not counted: the loop owns this part).
        record.tick = tick;
        record.since_start_ns = tick * 1_000_000;
        record.joints[0] = JointRecord {
            position_rad: tick as f64 * 1e-3,
            effort_nm: Some(0.1),
            reply: Some(ReplyAge::fresh(100)),
            ..JointRecord::EMPTY
        };
        let before = allocations();
        let outcome = producer.push(&record);
        counted += allocations() - before;
        queued += u64::from(outcome == PushOutcome::Queued);
        if tick % 100 == 0 {
            // Let the sinks work now and then, so both the queued and the full path run.
            std::thread::sleep(Duration::from_millis(1));
        }
    }
    let stats = pipeline.shutdown();
    assert_eq!(counted, 0, "the producer's push allocated {counted} times");
    assert!(queued > 0);
    assert_eq!(stats.offered, 3000);
    for sink in &stats.sinks {
        assert_eq!(sink.written + sink.failed + sink.dropped, 3000, "{sink:?}");
        assert_eq!(sink.errors, 0, "{sink:?}");
    }
}
