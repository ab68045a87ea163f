//! The sinks' own failure paths: each is a typed error or a counted one, never a panic.

use std::net::SocketAddr;
use std::time::Duration;

use rmd_protocol::MotorId;
use rmd_telemetry::{
    CsvSink, Delivery, JointInfo, LiveOptions, LiveSink, McapOptions, McapSink, RunLayout,
    SinkError, Telemetry, TickRecord,
};

fn layout() -> RunLayout {
    RunLayout::builder(1000.0)
        .joint(JointInfo::new("knee", 0, MotorId::new(1).unwrap()))
        .build()
        .unwrap()
}

fn loopback_any_port() -> LiveOptions {
    LiveOptions {
        addr: SocketAddr::from(([127, 0, 0, 1], 0)),
        ..LiveOptions::default()
    }
}

#[test]
fn a_file_in_a_missing_directory_is_an_io_error_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("no/such/dir/run.mcap");
    let Err(err) = McapSink::create(&path, &layout(), McapOptions::default()) else {
        panic!("created a file in a missing directory");
    };
    assert!(matches!(err, SinkError::Io { .. }), "{err:?}");
    assert!(err.to_string().contains("no/such/dir/run.mcap"), "{err}");
    let Err(err) = CsvSink::create(dir.path().join("no/run.csv"), &layout()) else {
        panic!("created a CSV in a missing directory");
    };
    assert!(matches!(err, SinkError::Io { .. }), "{err:?}");
}

#[test]
fn a_taken_port_is_a_typed_error_and_the_first_server_keeps_serving() {
    let first = LiveSink::start(&layout(), loopback_any_port()).unwrap();
    let taken = first.local_addr();
    assert_ne!(taken.port(), 0);
    let Err(err) = LiveSink::start(
        &layout(),
        LiveOptions {
            addr: taken,
            ..LiveOptions::default()
        },
    ) else {
        panic!("bound {taken} twice");
    };
    assert!(matches!(err, SinkError::Io { .. }), "{err:?}");
    assert!(err.to_string().contains(&taken.to_string()), "{err}");
    assert!(std::net::TcpStream::connect(taken).is_ok());
}

#[test]
fn a_live_rate_that_is_not_a_positive_number_is_refused() {
    for rate_hz in [0.0, -5.0, f64::NAN, f64::INFINITY] {
        let Err(err) = LiveSink::start(
            &layout(),
            LiveOptions {
                rate_hz,
                ..loopback_any_port()
            },
        ) else {
            panic!("accepted a live rate of {rate_hz}");
        };
        assert!(matches!(err, SinkError::Config(_)), "{err:?}");
    }
}

/// `/dev/full` accepts the open and fails every write with ENOSPC: creating the sink already
/// writes (header, channels, metadata), so it is refused at once with the OS error.
#[cfg(target_os = "linux")]
#[test]
fn a_full_disk_at_the_start_is_a_typed_error() {
    let Err(err) = McapSink::create("/dev/full", &layout(), McapOptions::default()) else {
        panic!("wrote to /dev/full");
    };
    assert!(err.to_string().contains("No space left"), "{err}");
}

/// A writer that takes `room` bytes and then fails every write, like a disk filling up.
struct FillsUp {
    data: std::io::Cursor<Vec<u8>>,
    room: usize,
}

impl std::io::Write for FillsUp {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        if self.data.get_ref().len() + buf.len() > self.room {
            return Err(std::io::Error::new(
                std::io::ErrorKind::StorageFull,
                "disk full (test)",
            ));
        }
        self.data.write(buf)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl std::io::Seek for FillsUp {
    fn seek(&mut self, pos: std::io::SeekFrom) -> std::io::Result<u64> {
        self.data.seek(pos)
    }
}

/// Writes that fail mid-run are counted against the MCAP sink (the Foxglove SDK only logs them)
/// with the first error kept; the pipeline carries on.
#[test]
fn mcap_write_failures_mid_run_are_counted_not_hidden() {
    let options = McapOptions {
        chunk_size: 256,
        compress: false,
        flush_interval: Some(Duration::ZERO),
    };
    let writer = FillsUp {
        data: std::io::Cursor::new(Vec::new()),
        room: 8 * 1024,
    };
    let sink = McapSink::to_writer(writer, "test.mcap", &layout(), options).unwrap();
    let (producer, pipeline) = Telemetry::builder()
        .sink(sink)
        .delivery(Delivery::Lossless)
        .start()
        .unwrap();
    for tick in 0..200 {
        producer.push(&TickRecord::new(tick, tick * 1_000_000, 0));
    }
    let stats = pipeline.shutdown();
    let mcap = &stats.sinks[0];
    assert!(mcap.written > 0, "the first records fit: {mcap:?}");
    assert!(mcap.failed > 0, "{mcap:?}");
    assert_eq!(mcap.written + mcap.failed, 200, "{mcap:?}");
    // One failure, reported once: the records after it are failed without an error each.
    assert_eq!(mcap.errors, 1, "{mcap:?}");
    let first = mcap.first_error.as_deref().unwrap_or_default();
    assert!(
        first.contains("test.mcap") && first.contains("disk full (test)"),
        "{first}"
    );
}
