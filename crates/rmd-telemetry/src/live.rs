//! The live sink: a Foxglove WebSocket server with the MCAP file's channels, decimated.

use std::net::{IpAddr, Ipv4Addr, SocketAddr};
use std::sync::Arc;
use std::time::Duration;

use foxglove::{Context, WebSocketServer, WebSocketServerHandle};

use crate::channels::Channels;
use crate::layout::RunLayout;
use crate::record::TickRecord;
use crate::sink::{Sink, SinkError};

/// The default address of the live server: loopback, Foxglove's usual port.
pub const DEFAULT_LIVE_ADDR: SocketAddr = SocketAddr::new(IpAddr::V4(Ipv4Addr::LOCALHOST), 8765);

/// The default live publishing rate (Hz).
pub const DEFAULT_LIVE_RATE_HZ: f64 = 100.0;

/// How the live server runs.
#[derive(Debug, Clone, PartialEq)]
pub struct LiveOptions {
    /// Where to listen (default [`DEFAULT_LIVE_ADDR`], loopback only). Port 0 picks a free port;
    /// [`LiveSink::local_addr`] tells which.
    pub addr: SocketAddr,
    /// Per-tick channels are published at most this often, by run time (default
    /// [`DEFAULT_LIVE_RATE_HZ`]); `/diagnostics` stays at 1 Hz and counts every tick.
    pub rate_hz: f64,
    /// The server's name as Foxglove shows it.
    pub server_name: String,
}

impl Default for LiveOptions {
    fn default() -> Self {
        Self {
            addr: DEFAULT_LIVE_ADDR,
            rate_hz: DEFAULT_LIVE_RATE_HZ,
            server_name: "rmd-rt".to_owned(),
        }
    }
}

/// Keeps one record per period of run time: the first, then the first at or after each period.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Decimator {
    period_ns: u64,
    next_ns: Option<u64>,
}

impl Decimator {
    pub(crate) fn new(rate_hz: f64) -> Self {
        Self {
            period_ns: (1e9 / rate_hz).round().max(1.0) as u64,
            next_ns: None,
        }
    }

    /// Whether to publish the record taken at `since_start_ns`.
    pub(crate) fn keep(&mut self, since_start_ns: u64) -> bool {
        match self.next_ns {
            Some(next) if since_start_ns < next => false,
            Some(next) => {
                // Stay on the grid unless the records jumped past a whole period. Saturating: a
                // rate of almost nothing makes a period of centuries (u64::MAX ns at most).
                let on_grid = next.saturating_add(self.period_ns);
                self.next_ns = Some(if on_grid > since_start_ns {
                    on_grid
                } else {
                    since_start_ns.saturating_add(self.period_ns)
                });
                true
            }
            None => {
                self.next_ns = Some(since_start_ns.saturating_add(self.period_ns));
                true
            }
        }
    }
}

/// Serves the telemetry live over the Foxglove WebSocket protocol (subprotocol
/// `foxglove.sdk.v1`, which the Foxglove app speaks): the same channels as the MCAP file, the
/// per-tick ones decimated to [`LiveOptions::rate_hz`]. A client that cannot keep up loses
/// messages inside the server; the loop never notices.
///
/// ```no_run
/// use rmd_telemetry::{LiveOptions, LiveSink, RunLayout};
///
/// let layout = RunLayout::builder(1000.0).bus_count(1).build()?;
/// let live = LiveSink::start(&layout, LiveOptions::default())?;
/// println!("open ws://{} in Foxglove", live.local_addr());
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub struct LiveSink {
    name: String,
    channels: Channels,
    server: Option<WebSocketServerHandle>,
    runtime: Option<tokio::runtime::Runtime>,
    _context: Arc<Context>,
    decimator: Decimator,
    addr: SocketAddr,
}

impl LiveSink {
    /// Starts the server on its own async runtime (one worker thread, `rmd-tlm-live`, plus
    /// the threads the runtime starts for blocking work) and advertises the channels.
    ///
    /// The runtime's threads inherit the calling thread's CPU affinity: start the sink before
    /// pinning the calling thread to the real-time CPU, or from another thread.
    ///
    /// # Errors
    /// [`SinkError::Config`] for a rate that is not a positive number; [`SinkError::Io`] if the
    /// runtime cannot start; [`SinkError::Foxglove`] if the address cannot be bound or a channel
    /// cannot be created.
    pub fn start(layout: &RunLayout, options: LiveOptions) -> Result<Self, SinkError> {
        if !(options.rate_hz.is_finite() && options.rate_hz > 0.0) {
            return Err(SinkError::Config(format!(
                "the live rate must be a positive number of Hz, got {}",
                options.rate_hz
            )));
        }
        let runtime = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(1)
            .thread_name("rmd-tlm-live")
            .enable_io()
            .enable_time()
            .build()
            .map_err(|e| SinkError::io("starting the live server's runtime", e))?;
        let context = Context::new();
        // Started inside our runtime, the server runs its tasks there (not on the SDK's own
        // runtime, which would take a worker thread per CPU).
        let server = runtime
            .block_on(
                WebSocketServer::new()
                    .name(options.server_name.clone())
                    .bind(options.addr.ip().to_string(), options.addr.port())
                    .context(&context)
                    .start(),
            )
            .map_err(|e| SinkError::foxglove(format!("serving on {}", options.addr), e))?;
        let addr = SocketAddr::new(options.addr.ip(), server.port());
        let channels = Channels::new(&context, Arc::new(layout.clone()))?;
        Ok(Self {
            name: format!("foxglove ws://{addr}"),
            channels,
            server: Some(server),
            runtime: Some(runtime),
            _context: context,
            decimator: Decimator::new(options.rate_hz),
            addr,
        })
    }

    /// The address the server listens on.
    pub fn local_addr(&self) -> SocketAddr {
        self.addr
    }

    /// Clients connected now.
    pub fn client_count(&self) -> usize {
        self.server
            .as_ref()
            .map_or(0, WebSocketServerHandle::client_count)
    }
}

impl Sink for LiveSink {
    fn name(&self) -> &str {
        &self.name
    }

    fn write(&mut self, record: &TickRecord) -> Result<(), SinkError> {
        self.channels.observe(record)?;
        if self.decimator.keep(record.since_start_ns) {
            self.channels.publish(record)?;
        }
        Ok(())
    }

    fn close(mut self: Box<Self>) -> Result<(), SinkError> {
        let health = self.channels.flush_health();
        self.channels.close();
        if let Some(server) = self.server.take() {
            server.stop().wait_blocking();
        }
        if let Some(runtime) = self.runtime.take() {
            runtime.shutdown_timeout(Duration::from_secs(1));
        }
        health
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimation_keeps_one_record_per_period() {
        let mut d = Decimator::new(100.0); // 10 ms
        let kept: Vec<u64> = (0..50)
            .map(|tick| tick * 1_000_000) // 1 kHz
            .filter(|&t| d.keep(t))
            .collect();
        assert_eq!(kept, [0, 10_000_000, 20_000_000, 30_000_000, 40_000_000]);
    }

    #[test]
    fn decimation_survives_gaps_and_jitter() {
        let mut d = Decimator::new(100.0);
        assert!(d.keep(0));
        assert!(!d.keep(9_999_999));
        assert!(d.keep(10_000_001)); // late: next due stays at 20 ms
        assert!(d.keep(20_000_000));
        assert!(d.keep(95_000_000)); // a gap: restart the grid from here
        assert!(!d.keep(104_999_999));
        assert!(d.keep(105_000_000));
    }

    #[test]
    fn a_rate_of_almost_nothing_keeps_the_first_record_and_never_overflows() {
        let mut d = Decimator::new(1e-300); // a period beyond u64::MAX ns
        assert!(d.keep(5));
        assert!(!d.keep(6));
        assert!(!d.keep(u64::MAX - 1));
    }
}
