//! The HTTP server: a std `TcpListener`, one thread accepting and one thread per connection
//! (at most [`MAX_CONNECTIONS`] at once) running [`exchange`] on it (one request per
//! connection). A connection that sends nothing holds only its own thread: browsers open
//! connections ahead of need, and with a fixed pool of threads such idle sockets kept the page's
//! real requests waiting until they timed out (the viewer took 30–60 s to show its first frame
//! in headless Chromium). Every read is bounded: a head
//! within [`crate::wire::MAX_HEAD_BYTES`], a body within [`crate::routes::MAX_BODY_BYTES`]
//! whatever its `Content-Length` claims, and a connection gets [`CONNECTION_SECS`] in all.

use crate::access::{new_token, Access};
use crate::error::{ViewError, ViewResult};
use crate::routes::Site;
use crate::wire::exchange;
use std::io::{BufReader, BufWriter, Read};
use std::net::{Ipv4Addr, Ipv6Addr, Shutdown, SocketAddr, TcpListener, TcpStream, ToSocketAddrs};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// Connections answered at once, each on its own thread; a further connection waits in the
/// listener's backlog until one ends (each ends within [`CONNECTION_SECS`] and a second).
pub const MAX_CONNECTIONS: usize = 64;

/// Longest a connection may take to send its request, seconds.
pub const CONNECTION_SECS: u64 = 30;

/// After the reply, unread request bytes drained at most (so closing does not reset the
/// connection before the client reads a 413).
const DRAIN_BYTES: usize = 1 << 20;

/// A running viewer server.
pub struct ViewServer {
    bound: SocketAddr,
    site: Arc<Site>,
    url: String,
    stopping: Arc<AtomicBool>,
    acceptor: Option<JoinHandle<()>>,
}

impl ViewServer {
    /// Binds `host:port` (port 0 = any free port) and starts answering in the background; the
    /// page's token is drawn here, one per server.
    pub fn start(site: Site, host: &str, port: u16) -> ViewResult<ViewServer> {
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
        let access = Arc::new(Access::new(bound, host, new_token()?));
        let url_host = if host.contains(':') { format!("[{host}]") } else { host.to_string() };
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
    let open = Arc::new(AtomicUsize::new(0));
    loop {
        while open.load(Ordering::SeqCst) >= MAX_CONNECTIONS && !stopping.load(Ordering::SeqCst) {
            std::thread::sleep(Duration::from_millis(10));
        }
        let accepted = listener.accept();
        if stopping.load(Ordering::SeqCst) {
            return;
        }
        match accepted {
            Ok((stream, _)) => {
                open.fetch_add(1, Ordering::SeqCst);
                let slot = Slot(Arc::clone(&open));
                let (site, access) = (Arc::clone(site), Arc::clone(access));
                let spawned = std::thread::Builder::new().spawn(move || {
                    let _slot = slot;
                    serve_connection(stream, &site, &access);
                });
                // Out of threads: the connection is closed (its slot freed with the closure).
                if spawned.is_err() {
                    std::thread::sleep(Duration::from_millis(50));
                }
            }
            // e.g. out of file descriptors: wait instead of spinning
            Err(_) => std::thread::sleep(Duration::from_millis(50)),
        }
    }
}

/// One of the [`MAX_CONNECTIONS`], given back when the connection's thread ends (or never starts).
struct Slot(Arc<AtomicUsize>);

impl Drop for Slot {
    fn drop(&mut self) {
        self.0.fetch_sub(1, Ordering::SeqCst);
    }
}

fn serve_connection(stream: TcpStream, site: &Site, access: &Access) {
    let _ = stream.set_nodelay(true);
    let _ = stream.set_write_timeout(Some(Duration::from_secs(CONNECTION_SECS)));
    let deadline = Instant::now() + Duration::from_secs(CONNECTION_SECS);
    let mut reader = BufReader::new(Deadline { stream: &stream, deadline });
    let mut writer = BufWriter::new(&stream);
    if exchange(site, access, &mut reader, &mut writer).is_err() {
        return;
    }
    drop(writer);
    let _ = stream.shutdown(Shutdown::Write);
    // Drain what the client is still sending (bounded), so the close is not a reset.
    let mut rest = Deadline { stream: &stream, deadline: Instant::now() + Duration::from_secs(1) };
    let _ = std::io::copy(&mut (&mut rest).take(DRAIN_BYTES as u64), &mut std::io::sink());
}

/// Reads from the stream until `deadline`, then fails (a client sending a byte at a time cannot
/// hold a thread longer).
struct Deadline<'s> {
    stream: &'s TcpStream,
    deadline: Instant,
}

impl Read for Deadline<'_> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let left = self.deadline.saturating_duration_since(Instant::now());
        if left.is_zero() {
            return Err(std::io::Error::new(std::io::ErrorKind::TimedOut, "connection took too long"));
        }
        self.stream.set_read_timeout(Some(left))?;
        let mut stream: &TcpStream = self.stream;
        stream.read(buf)
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
