//! The HTTP server: a std `TcpListener` and a few threads, each taking one connection at a time
//! and running [`exchange`] on it (one request per connection). Every read is bounded: a head
//! within [`crate::wire::MAX_HEAD_BYTES`], a body within [`crate::routes::MAX_BODY_BYTES`]
//! whatever its `Content-Length` claims, and a connection gets [`CONNECTION_SECS`] in all.

use crate::access::{new_token, Access};
use crate::error::{ViewError, ViewResult};
use crate::routes::Site;
use crate::wire::exchange;
use std::io::{BufReader, BufWriter, Read};
use std::net::{Ipv4Addr, Ipv6Addr, Shutdown, SocketAddr, TcpListener, TcpStream, ToSocketAddrs};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// Threads answering requests (the page fetches chunks while the strip loads images).
const THREADS: usize = 8;

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
    threads: Vec<JoinHandle<()>>,
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
        let mut threads = Vec::with_capacity(THREADS);
        for _ in 0..THREADS {
            let listener = listener.try_clone().map_err(|e| ViewError::bind(&addr, &e))?;
            let (site, access, stopping) = (Arc::clone(&site), Arc::clone(&access), Arc::clone(&stopping));
            threads.push(std::thread::spawn(move || accept_loop(&listener, &site, &access, &stopping)));
        }
        Ok(ViewServer { bound, site, url, stopping, threads })
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
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }

    /// Stops answering and joins the threads.
    pub fn stop(mut self) {
        self.stopping.store(true, Ordering::SeqCst);
        let mut wake = self.bound;
        if wake.ip().is_unspecified() {
            wake.set_ip(if wake.is_ipv4() { Ipv4Addr::LOCALHOST.into() } else { Ipv6Addr::LOCALHOST.into() });
        }
        for _ in 0..self.threads.len() {
            let _ = TcpStream::connect_timeout(&wake, Duration::from_secs(1));
        }
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

fn accept_loop(listener: &TcpListener, site: &Site, access: &Access, stopping: &AtomicBool) {
    loop {
        let accepted = listener.accept();
        if stopping.load(Ordering::SeqCst) {
            return;
        }
        match accepted {
            Ok((stream, _)) => serve_connection(stream, site, access),
            // e.g. out of file descriptors: wait instead of spinning
            Err(_) => std::thread::sleep(Duration::from_millis(50)),
        }
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
