//! The HTTP server: `tiny_http` (synchronous, no async runtime) with a few threads answering
//! [`Site::respond`]. Bodies over [`MAX_BODY_BYTES`] are refused with 413 before being read.

use crate::error::{ViewError, ViewResult};
use crate::routes::{Reply, Site, MAX_BODY_BYTES};
use std::io::Read;
use std::sync::Arc;
use std::thread::JoinHandle;

/// Threads answering requests (the page fetches chunks while the strip loads images).
const THREADS: usize = 4;

/// A running viewer server.
pub struct ViewServer {
    server: Arc<tiny_http::Server>,
    site: Arc<Site>,
    url: String,
    threads: Vec<JoinHandle<()>>,
}

impl ViewServer {
    /// Binds `host:port` (port 0 = any free port) and starts answering in the background.
    pub fn start(site: Site, host: &str, port: u16) -> ViewResult<ViewServer> {
        let addr = if host.contains(':') { format!("[{host}]:{port}") } else { format!("{host}:{port}") };
        let server = tiny_http::Server::http(addr.as_str())
            .map_err(|e| ViewError::Bind { addr: addr.clone(), reason: e.to_string() })?;
        let bound = server.server_addr().to_ip().map(|a| a.port()).unwrap_or(port);
        let url_host = if host.contains(':') { format!("[{host}]") } else { host.to_string() };
        let url = format!("http://{url_host}:{bound}/");
        let server = Arc::new(server);
        let site = Arc::new(site);
        let threads = (0..THREADS)
            .map(|_| {
                let (server, site) = (Arc::clone(&server), Arc::clone(&site));
                std::thread::spawn(move || serve(&server, &site))
            })
            .collect();
        Ok(ViewServer { server, site, url, threads })
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
        for _ in 0..self.threads.len() {
            self.server.unblock();
        }
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

fn serve(server: &tiny_http::Server, site: &Site) {
    while let Ok(mut request) = server.recv() {
        let too_large = request.body_length().is_some_and(|n| n > MAX_BODY_BYTES);
        let mut body = Vec::new();
        let read_ok = !too_large
            && request.as_reader().take(MAX_BODY_BYTES as u64 + 1).read_to_end(&mut body).is_ok()
            && body.len() <= MAX_BODY_BYTES;
        let method = request.method().as_str().to_string();
        let reply = if read_ok { site.respond(&method, request.url(), &body) } else { Reply::too_large() };
        let _ = request.respond(to_response(reply));
    }
}

fn to_response(reply: Reply<'_>) -> tiny_http::Response<std::io::Cursor<Vec<u8>>> {
    let mut response = tiny_http::Response::from_data(reply.body.into_owned()).with_status_code(reply.status);
    let header = |k: &str, v: &str| tiny_http::Header::from_bytes(k.as_bytes(), v.as_bytes()).ok();
    for h in [
        header("Content-Type", reply.content_type),
        header("Cache-Control", "no-store"),
        header("X-Content-Type-Options", "nosniff"),
        reply
            .download_name
            .as_deref()
            .and_then(|n| header("Content-Disposition", &format!("attachment; filename=\"{n}\""))),
    ]
    .into_iter()
    .flatten()
    {
        response.add_header(h);
    }
    response
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
