//! The HTTP server: a std `TcpListener`, one thread accepting and one thread per connection
//! running [`read_head`] then [`reply_to`] on it (one request per connection). A connection that
//! sends nothing holds only its own thread: browsers open connections ahead of need, and with a
//! fixed pool of threads such idle sockets kept the page's real requests waiting until they timed
//! out (the viewer took 30–60 s to show its first frame in headless Chromium).
//!
//! Every read is bounded: a head within [`crate::wire::MAX_HEAD_BYTES`] and [`HEAD_SECS`] of the
//! connection's start (a connection that has sent nothing by then is closed without a word, one
//! that sent part of its head gets 408), a body within [`crate::routes::body_limit`] (64 KiB, 4 MiB for edits) whatever
//! its `Content-Length` claims, and a connection gets [`CONNECTION_SECS`] in all. At most
//! [`MAX_CONNECTIONS`] are open at once: beyond, the connections waiting for their client are
//! closed for room, oldest first among the peer holding the most ([`crate::connections`]), so
//! dozens of half-sent requests from one client do not keep another's request waiting.

use crate::access::{new_token, Access};
pub use crate::connections::MAX_CONNECTIONS;
use crate::connections::{Connections, Status, Ticket};
use crate::error::{ViewError, ViewResult};
use crate::routes::Site;
use crate::wire::{read_head, reply_to, write_reply};
use std::io::{BufReader, BufWriter, ErrorKind, Read};
use std::net::{Ipv4Addr, Ipv6Addr, Shutdown, SocketAddr, TcpListener, TcpStream, ToSocketAddrs};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// Longest a connection may take to send its request line and headers, seconds (from its start).
pub const HEAD_SECS: u64 = 5;

/// Longest a connection may take to send its whole request, seconds (from its start).
pub const CONNECTION_SECS: u64 = 30;

/// After the reply, unread request bytes drained at most (so closing does not reset the
/// connection before the client reads a 413).
const DRAIN_BYTES: usize = 1 << 20;

/// A bound listening socket, not yet answering: `splatseg view` binds before it says anything,
/// so a bad `--listen` is one error with no "listening" line or warning before it.
pub struct Listening {
    listener: TcpListener,
    bound: SocketAddr,
    host: String,
}

impl Listening {
    /// Resolves and binds `host:port` (port 0 = any free port); the error names the host or the
    /// address and says what to try.
    pub fn bind(host: &str, port: u16) -> ViewResult<Listening> {
        let addr = if host.contains(':') { format!("[{host}]:{port}") } else { format!("{host}:{port}") };
        let candidates: Vec<SocketAddr> = (host, port)
            .to_socket_addrs()
            .map_err(|e| ViewError::Resolve { host: host.to_string(), reason: e.to_string() })?
            .collect();
        if candidates.is_empty() {
            return Err(ViewError::Resolve { host: host.to_string(), reason: "no address".into() });
        }
        let listener = TcpListener::bind(&candidates[..]).map_err(|e| ViewError::bind(&addr, &e))?;
        let bound = listener.local_addr().map_err(|e| ViewError::bind(&addr, &e))?;
        Ok(Listening { listener, bound, host: host.to_string() })
    }

    /// The address bound.
    pub fn address(&self) -> SocketAddr {
        self.bound
    }

    /// Whether only this machine can connect (a loopback address).
    pub fn is_loopback(&self) -> bool {
        self.bound.ip().is_loopback()
    }
}

/// A running viewer server.
pub struct ViewServer {
    bound: SocketAddr,
    site: Arc<Site>,
    url: String,
    stopping: Arc<AtomicBool>,
    acceptor: Option<JoinHandle<()>>,
}

impl ViewServer {
    /// Binds `host:port` (port 0 = any free port) and starts answering: [`Listening::bind`] then
    /// [`ViewServer::serve`].
    pub fn start(site: Site, host: &str, port: u16) -> ViewResult<ViewServer> {
        ViewServer::serve(Listening::bind(host, port)?, site)
    }

    /// Starts answering on `listening` in the background; the page's token is drawn here, one
    /// per server.
    pub fn serve(listening: Listening, site: Site) -> ViewResult<ViewServer> {
        let Listening { listener, bound, host } = listening;
        let access = Arc::new(Access::new(bound, &host, new_token()?));
        let url_host = if host.contains(':') { format!("[{host}]") } else { host };
        let url = format!("http://{url_host}:{}/", bound.port());
        let site = Arc::new(site);
        let stopping = Arc::new(AtomicBool::new(false));
        let acceptor = {
            let (site, stopping) = (Arc::clone(&site), Arc::clone(&stopping));
            std::thread::spawn(move || accept_loop(&listener, &site, &access, &stopping))
        };
        Ok(ViewServer { bound, site, url, stopping, acceptor: Some(acceptor) })
    }

    /// The page's URL.
    pub fn url(&self) -> &str {
        &self.url
    }

    /// What is served.
    pub fn site(&self) -> &Site {
        &self.site
    }

    /// Blocks until the server stops (it does not on its own: the command runs until Ctrl-C).
    pub fn wait(mut self) {
        if let Some(acceptor) = self.acceptor.take() {
            let _ = acceptor.join();
        }
    }

    /// Stops accepting connections and joins the accepting thread; a connection being answered
    /// finishes on its own thread (within [`CONNECTION_SECS`] and a second).
    pub fn stop(mut self) {
        self.stopping.store(true, Ordering::SeqCst);
        let mut wake = self.bound;
        if wake.ip().is_unspecified() {
            wake.set_ip(if wake.is_ipv4() { Ipv4Addr::LOCALHOST.into() } else { Ipv6Addr::LOCALHOST.into() });
        }
        let _ = TcpStream::connect_timeout(&wake, Duration::from_secs(1));
        if let Some(acceptor) = self.acceptor.take() {
            let _ = acceptor.join();
        }
    }
}

fn accept_loop(listener: &TcpListener, site: &Arc<Site>, access: &Arc<Access>, stopping: &AtomicBool) {
    let table = Arc::new(Connections::default());
    loop {
        let accepted = listener.accept();
        if stopping.load(Ordering::SeqCst) {
            return;
        }
        let (stream, peer) = match accepted {
            Ok(accepted) => accepted,
            // e.g. out of file descriptors: wait instead of spinning
            Err(_) => {
                std::thread::sleep(Duration::from_millis(50));
                continue;
            }
        };
        // A socket that cannot be shared is dropped (closed) here.
        let Ok(ticket) = table.admit(&stream, peer.ip()) else { continue };
        // Room for it: over the limit, a connection waiting for its client is closed; when every
        // one is answering, this one waits (unread, in the table) until one ends.
        while table.len() > MAX_CONNECTIONS
            && !table.close_one_waiting(ticket.id())
            && !stopping.load(Ordering::SeqCst)
        {
            std::thread::sleep(Duration::from_millis(10));
        }
        let (site, access) = (Arc::clone(site), Arc::clone(access));
        let spawned =
            std::thread::Builder::new().spawn(move || serve_connection(stream, &site, &access, &ticket));
        // Out of threads: the connection is closed (its ticket given back with the closure).
        if spawned.is_err() {
            std::thread::sleep(Duration::from_millis(50));
        }
    }
}

fn serve_connection(stream: TcpStream, site: &Site, access: &Access, ticket: &Ticket) {
    let started = Instant::now();
    let _ = stream.set_nodelay(true);
    let _ = stream.set_write_timeout(Some(Duration::from_secs(CONNECTION_SECS)));
    let status = ticket.status();
    let head_deadline = started + Duration::from_secs(HEAD_SECS);
    let mut reader = BufReader::new(Deadline { stream: &stream, deadline: head_deadline, status });
    let mut writer = BufWriter::new(&stream);
    let replied = match read_head(&mut reader) {
        Ok(None) => return,
        Ok(Some(head)) => {
            reader.get_mut().deadline = started + Duration::from_secs(CONNECTION_SECS);
            reply_to(site, access, &head, &mut reader, &mut writer)
        }
        Err(reply) => write_reply(&mut writer, &reply, false),
    };
    if replied.is_err() {
        return;
    }
    drop(writer);
    let _ = stream.shutdown(Shutdown::Write);
    // Drain what the client is still sending (bounded), so the close is not a reset.
    let mut rest = Deadline { stream: &stream, deadline: Instant::now() + Duration::from_secs(1), status };
    let _ = std::io::copy(&mut (&mut rest).take(DRAIN_BYTES as u64), &mut std::io::sink());
}

/// Reads from the stream until `deadline`, then fails with `TimedOut` (a client sending a byte
/// at a time cannot hold a thread longer). While blocked it marks the connection as waiting for
/// its client, which may then be closed for room: its end of stream becomes `ConnectionAborted`
/// (so [`crate::wire::unreadable`] answers 503, not "the request ended early").
struct Deadline<'s> {
    stream: &'s TcpStream,
    deadline: Instant,
    status: &'s Status,
}

impl Read for Deadline<'_> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let closed_for_room =
            || std::io::Error::new(ErrorKind::ConnectionAborted, "closed to make room for other connections");
        if self.status.closed_for_room() {
            return Err(closed_for_room());
        }
        let left = self.deadline.saturating_duration_since(Instant::now());
        if left.is_zero() {
            return Err(std::io::Error::new(ErrorKind::TimedOut, "connection took too long"));
        }
        self.stream.set_read_timeout(Some(left))?;
        let mut stream: &TcpStream = self.stream;
        self.status.set_waiting(true);
        let read = stream.read(buf);
        self.status.set_waiting(false);
        match read {
            _ if self.status.closed_for_room() => Err(closed_for_room()),
            // the socket's own timeout (`WouldBlock` on Unix)
            Err(e) if e.kind() == ErrorKind::WouldBlock => Err(std::io::Error::new(ErrorKind::TimedOut, e)),
            read => read,
        }
    }
}

/// Asks the desktop to open `url` in the default browser (`open`, `start` or `xdg-open`); the
/// error names the program that failed.
pub fn open_in_browser(url: &str) -> std::io::Result<()> {
    let (program, args): (&str, Vec<&str>) = if cfg!(target_os = "macos") {
        ("open", vec![url])
    } else if cfg!(windows) {
        ("cmd", vec!["/C", "start", "", url])
    } else {
        ("xdg-open", vec![url])
    };
    match std::process::Command::new(program).args(&args).spawn() {
        Ok(_) => Ok(()),
        Err(e) => Err(std::io::Error::new(e.kind(), format!("{program}: {e}"))),
    }
}
