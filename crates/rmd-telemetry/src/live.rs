//! The live sink: a Foxglove WebSocket server with the MCAP file's channels, decimated, behind
//! a front door that admits at most [`LiveOptions::max_clients`] clients at once.
//!
//! The Foxglove SDK's server has no connection limit, so it listens on an ephemeral loopback
//! port, and the address the user asked for is a small TCP relay of ours (on the sink's own
//! runtime): a connection over the limit, or one that sends nothing within
//! [`FIRST_BYTES_WITHIN`], is answered `503 Service Unavailable` (a WebSocket client reports
//! the refusal) and closed, and counted; the others are relayed byte for byte.

use std::net::{IpAddr, Ipv4Addr, SocketAddr};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::time::Duration;

use foxglove::{Context, WebSocketServer, WebSocketServerHandle};
use tokio::io::AsyncWriteExt;
use tokio::net::{TcpListener, TcpStream};

use crate::channels::Channels;
use crate::layout::RunLayout;
use crate::record::TickRecord;
use crate::sink::{Sink, SinkError};

/// The default address of the live server: loopback, Foxglove's usual port.
pub const DEFAULT_LIVE_ADDR: SocketAddr = SocketAddr::new(IpAddr::V4(Ipv4Addr::LOCALHOST), 8765);

/// The default live publishing rate (Hz).
pub const DEFAULT_LIVE_RATE_HZ: f64 = 100.0;

/// The default number of clients served at once.
pub const DEFAULT_MAX_CLIENTS: usize = 8;

/// A client that sends nothing for this long after connecting is refused (it would hold a
/// place without ever becoming a viewer).
pub const FIRST_BYTES_WITHIN: Duration = Duration::from_secs(5);

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
    /// Clients served at once (default [`DEFAULT_MAX_CLIENTS`]); one more is refused with
    /// `503 Service Unavailable` and counted. At least 1.
    pub max_clients: usize,
}

impl Default for LiveOptions {
    fn default() -> Self {
        Self {
            addr: DEFAULT_LIVE_ADDR,
            rate_hz: DEFAULT_LIVE_RATE_HZ,
            server_name: "rmd-rt".to_owned(),
            max_clients: DEFAULT_MAX_CLIENTS,
        }
    }
}

impl LiveOptions {
    /// A warning for a server other hosts can reach (any address but loopback): anyone who
    /// reaches it sees the robot's telemetry, without authentication or encryption. `None` on
    /// loopback.
    ///
    /// ```
    /// use rmd_telemetry::LiveOptions;
    /// assert!(LiveOptions::default().exposure_warning().is_none());
    /// let open = LiveOptions { addr: "0.0.0.0:8765".parse()?, ..LiveOptions::default() };
    /// assert!(open.exposure_warning().unwrap().contains("0.0.0.0:8765"));
    /// # Ok::<(), std::net::AddrParseError>(())
    /// ```
    pub fn exposure_warning(&self) -> Option<String> {
        let ip = self.addr.ip();
        (!ip.is_loopback()).then(|| {
            let reach = if ip.is_unspecified() {
                "every network interface of this host"
            } else {
                "the network of that address"
            };
            format!(
                "the live telemetry server listens on {} ({reach}): anyone who can reach it sees \
                 the robot's telemetry, without authentication or encryption (at most {} \
                 clients at once); serve on 127.0.0.1 unless other hosts must watch",
                self.addr, self.max_clients
            )
        })
    }
}

/// The front door's counts, shared with its tasks.
#[derive(Debug, Default)]
struct Door {
    /// Clients being relayed now.
    active: AtomicUsize,
    /// Clients relayed since the start.
    served: AtomicU64,
    /// Connections refused: over the limit.
    over_limit: AtomicU64,
    /// Connections refused: nothing sent within [`FIRST_BYTES_WITHIN`].
    silent: AtomicU64,
}

/// The refusal a client over the limit reads (an HTTP response: a WebSocket client reports
/// the status).
fn refusal(max_clients: usize) -> Vec<u8> {
    let body = format!(
        "rmd-rt live telemetry: {max_clients} client(s) already connected, the limit; try again \
         later\n"
    );
    format!(
        "HTTP/1.1 503 Service Unavailable\r\nContent-Type: text/plain\r\nContent-Length: {}\r\n\
         Connection: close\r\n\r\n{body}",
        body.len()
    )
    .into_bytes()
}

/// Takes connections on `front` and relays them to the server on `back`, at most `max` at once.
async fn admit(front: TcpListener, back: SocketAddr, max: usize, door: Arc<Door>) {
    loop {
        let Ok((client, _)) = front.accept().await else {
            // Out of file descriptors or the like: wait, then take connections again.
            tokio::time::sleep(Duration::from_millis(100)).await;
            continue;
        };
        let _ = client.set_nodelay(true);
        // Only this task admits, so the count cannot grow between the check and the increment.
        if door.active.load(Ordering::Acquire) >= max {
            door.over_limit.fetch_add(1, Ordering::Relaxed);
            tokio::spawn(refuse(client, refusal(max)));
            continue;
        }
        door.active.fetch_add(1, Ordering::AcqRel);
        tokio::spawn(relay(client, back, Arc::clone(&door)));
    }
}

/// Answers `client` with `refusal` and closes the connection (best effort).
async fn refuse(mut client: TcpStream, refusal: Vec<u8>) {
    let answer = async {
        client.write_all(&refusal).await?;
        client.shutdown().await
    };
    let _ = tokio::time::timeout(FIRST_BYTES_WITHIN, answer).await;
}

/// Relays one admitted client to the server until either side closes.
async fn relay(mut client: TcpStream, back: SocketAddr, door: Arc<Door>) {
    /// Gives the client's place back however the relay ends.
    struct Place(Arc<Door>);
    impl Drop for Place {
        fn drop(&mut self) {
            self.0.active.fetch_sub(1, Ordering::AcqRel);
        }
    }
    let _place = Place(Arc::clone(&door));
    if !matches!(
        tokio::time::timeout(FIRST_BYTES_WITHIN, client.readable()).await,
        Ok(Ok(()))
    ) {
        door.silent.fetch_add(1, Ordering::Relaxed);
        return;
    }
    let Ok(mut server) = TcpStream::connect(back).await else {
        return;
    };
    let _ = server.set_nodelay(true);
    door.served.fetch_add(1, Ordering::Relaxed);
    let _ = tokio::io::copy_bidirectional(&mut client, &mut server).await;
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
/// messages inside the server; the loop never notices. At most [`LiveOptions::max_clients`]
/// clients are served at once; the refused ones are counted ([`Sink::note`]).
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
    door: Arc<Door>,
    max_clients: usize,
}

impl LiveSink {
    /// Starts the server on its own async runtime (one worker thread, `rmd-tlm-live`, plus
    /// the threads the runtime starts for blocking work) and advertises the channels.
    ///
    /// The runtime's threads inherit the calling thread's CPU affinity: start the sink before
    /// pinning the calling thread to the real-time CPU, or from another thread.
    ///
    /// # Errors
    /// [`SinkError::Config`] for a rate that is not a positive number or a client limit of 0;
    /// [`SinkError::Io`] if the runtime cannot start or the address cannot be bound;
    /// [`SinkError::Foxglove`] if the server or a channel cannot be created.
    pub fn start(layout: &RunLayout, options: LiveOptions) -> Result<Self, SinkError> {
        if !(options.rate_hz.is_finite() && options.rate_hz > 0.0) {
            return Err(SinkError::Config(format!(
                "the live rate must be a positive number of Hz, got {}",
                options.rate_hz
            )));
        }
        if options.max_clients == 0 {
            return Err(SinkError::Config(
                "the live server must admit at least 1 client".to_owned(),
            ));
        }
        let runtime = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(1)
            .thread_name("rmd-tlm-live")
            .enable_io()
            .enable_time()
            .build()
            .map_err(|e| SinkError::io("starting the live server's runtime", e))?;
        let front = runtime
            .block_on(TcpListener::bind(options.addr))
            .map_err(|e| SinkError::io(format!("serving on {}", options.addr), e))?;
        let addr = front
            .local_addr()
            .map_err(|e| SinkError::io(format!("serving on {}", options.addr), e))?;
        let context = Context::new();
        // Started inside our runtime, the server runs its tasks there (not on the SDK's own
        // runtime, which would take a worker thread per CPU). Only the front door reaches it.
        let server = runtime
            .block_on(
                WebSocketServer::new()
                    .name(options.server_name.clone())
                    .bind(Ipv4Addr::LOCALHOST.to_string(), 0)
                    .context(&context)
                    .start(),
            )
            .map_err(|e| SinkError::foxglove(format!("serving on {addr}"), e))?;
        let back = SocketAddr::new(IpAddr::V4(Ipv4Addr::LOCALHOST), server.port());
        let door = Arc::new(Door::default());
        runtime.spawn(admit(front, back, options.max_clients, Arc::clone(&door)));
        let channels = Channels::new(&context, Arc::new(layout.clone()))?;
        Ok(Self {
            name: format!("foxglove ws://{addr}"),
            channels,
            server: Some(server),
            runtime: Some(runtime),
            _context: context,
            decimator: Decimator::new(options.rate_hz),
            addr,
            door,
            max_clients: options.max_clients,
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

    /// Connections refused so far: over the client limit, and silent for
    /// [`FIRST_BYTES_WITHIN`].
    pub fn refused(&self) -> (u64, u64) {
        (
            self.door.over_limit.load(Ordering::Relaxed),
            self.door.silent.load(Ordering::Relaxed),
        )
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

    fn note(&self) -> Option<String> {
        let (over_limit, silent) = self.refused();
        let served = self.door.served.load(Ordering::Relaxed);
        Some(format!(
            "{served} client(s) served, {over_limit} refused over the limit of {}, {silent} \
             refused for sending nothing",
            self.max_clients
        ))
    }

    fn close(&mut self) -> Result<(), SinkError> {
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
