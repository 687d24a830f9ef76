//! `splatseg view` as users meet it: bad input fails clearly, and the server answers only for
//! the scene it was given (404 for anything else, 413 for large bodies, exports only into --out).

use splatseg_view::browser::http::request;
use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, Output, Stdio};
use std::time::Duration;

fn splatseg(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_splatseg")).args(args).output().expect("the splatseg binary runs")
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

fn utf8(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

/// A tiny synthetic capture (with its unlabelled gaussians.ply) written by `splatseg synth`.
fn tiny_scene(dir: &Path) {
    let out = splatseg(&["synth", "--out", utf8(dir), "--views", "2", "--size", "64x48"]);
    assert!(out.status.success(), "synth failed: {}", stderr(&out));
}

#[test]
fn view_of_a_folder_without_a_ply_fails_and_says_what_it_expected() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let empty = tmp.path().join("empty_run_folder");
    std::fs::create_dir_all(&empty).expect("mkdir");
    let out = splatseg(&["view", utf8(&empty), "--listen", "127.0.0.1:0"]);
    assert!(!out.status.success());
    let err = stderr(&out);
    assert!(err.contains("no 3DGS PLY") && err.contains("empty_run_folder"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn view_of_a_ply_without_positions_fails_and_names_the_file() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let ply = tmp.path().join("no_positions.ply");
    let mut bytes = b"ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float f_dc_0\nproperty float opacity\nend_header\n".to_vec();
    bytes.extend_from_slice(&[0u8; 8]);
    std::fs::write(&ply, bytes).expect("write");
    let out = splatseg(&["view", utf8(&ply), "--listen", "127.0.0.1:0"]);
    assert!(!out.status.success());
    let err = stderr(&out);
    assert!(err.contains("no_positions.ply") && err.contains("'x' is missing"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn view_on_a_port_in_use_fails_and_names_the_address() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let scene = tmp.path().join("scene");
    tiny_scene(&scene);
    let taken = std::net::TcpListener::bind("127.0.0.1:0").expect("bind");
    let port = taken.local_addr().expect("addr").port().to_string();
    let out =
        splatseg(&["view", utf8(&scene.join("gaussians.ply")), "--listen", &format!("127.0.0.1:{port}")]);
    assert!(!out.status.success());
    let err = stderr(&out);
    assert!(err.contains("cannot listen") && err.contains(&port), "{err}");
}

/// The server of `splatseg view PATH --listen 127.0.0.1:0 …`, stopped on drop.
struct Served {
    child: Child,
    url: String,
}

impl Drop for Served {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn serve(args: &[&str]) -> Served {
    let mut child = Command::new(env!("CARGO_BIN_EXE_splatseg"))
        .arg("view")
        .args(args)
        .args(["--listen", "127.0.0.1:0"])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("splatseg view starts");
    let stdout = child.stdout.take().expect("stdout");
    let mut served = Served { child, url: String::new() };
    for line in BufReader::new(stdout).lines() {
        let line = line.expect("stdout line");
        if let Some(url) = line.strip_prefix("open ") {
            served.url = url.trim_end_matches('/').to_string();
            break;
        }
    }
    assert!(served.url.starts_with("http://127.0.0.1:"), "no URL printed");
    served
}

fn get(url: &str) -> (u16, Vec<u8>) {
    let r = request("GET", url, None, Duration::from_secs(30)).expect("request");
    (r.status, r.body)
}

#[test]
fn the_server_serves_only_the_scene_and_writes_only_into_out() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let scene = tmp.path().join("scene");
    tiny_scene(&scene);
    let exports = tmp.path().join("exports");
    let server =
        serve(&[utf8(&scene.join("gaussians.ply")), "--scene", utf8(&scene), "--out", utf8(&exports)]);
    let base = &server.url;

    let (status, page) = get(&format!("{base}/"));
    assert_eq!(status, 200);
    assert!(String::from_utf8_lossy(&page).contains("/assets/viewer.js"));
    let (status, manifest) = get(&format!("{base}/api/scene.json"));
    assert_eq!(status, 200);
    let manifest: serde_json::Value = serde_json::from_slice(&manifest).expect("json");
    assert_eq!(manifest["cameras"].as_array().map(Vec::len), Some(2));
    let n = manifest["gaussians"].as_u64().expect("count") as usize;
    let (status, chunk) = get(&format!("{base}/api/gaussians/0.bin"));
    assert_eq!((status, chunk.len()), (200, 48 * n.min(65536)));

    for path in [
        "/../Cargo.toml",
        "/assets/../../scene/gaussians.ply",
        "/views/0/../../gaussians.ply",
        "/gaussians.ply",
        "/views/99/overlay.png",
        "/api/gaussians/999.bin",
        "/exports/..%2Fgaussians.ply",
        "/%2e%2e/%2e%2e/etc/passwd",
    ] {
        assert_eq!(get(&format!("{base}{path}")).0, 404, "{path}");
    }

    let big = vec![b' '; 200_000];
    let r =
        request("POST", &format!("{base}/api/export"), Some(&big), Duration::from_secs(30)).expect("post");
    assert_eq!(r.status, 413);

    // The synthetic scene's own PLY has no object ids: export (from the page: its token and
    // Origin) explains, writes nothing.
    let page = String::from_utf8_lossy(&page).into_owned();
    let token = page.split(r#"name="splatseg-token" content=""#).nth(1).and_then(|t| t.split('"').next());
    let host = base.trim_start_matches("http://");
    let body = r#"{"ids":[1],"mode":"extract"}"#;
    let post = format!(
        "POST /api/export HTTP/1.1\r\nHost: {host}\r\nOrigin: {base}\r\nX-Splatseg-Token: {}\r\n\
         Content-Length: {}\r\n\r\n{body}",
        token.expect("the page's token"),
        body.len()
    );
    let answer = raw(host, post.as_bytes());
    assert!(answer.starts_with("HTTP/1.1 400") && answer.contains("splatseg run"), "{answer}");
    assert!(!exports.exists() || std::fs::read_dir(&exports).expect("dir").next().is_none());
}

/// Sends `bytes` as they are on a fresh connection to `addr` (`host:port`) and returns the whole
/// answer as text.
fn raw(addr: &str, bytes: &[u8]) -> String {
    use std::io::{Read, Write};
    let mut stream = std::net::TcpStream::connect(addr).expect("connect");
    stream.set_read_timeout(Some(Duration::from_secs(30))).expect("timeout");
    stream.write_all(bytes).expect("send");
    let mut answer = Vec::new();
    let _ = stream.read_to_end(&mut answer);
    String::from_utf8_lossy(&answer).into_owned()
}

/// `splatseg view PLY --listen LISTEN`, which must fail: its stderr, after checking that it
/// says nothing of listening and that the PLY and the folder are as they were.
fn view_refused(scene: &Path, listen: &str) -> String {
    let ply = scene.join("gaussians.ply");
    let before = std::fs::read(&ply).expect("the PLY");
    let files = std::fs::read_dir(scene).expect("scene").count();
    let out = splatseg(&["view", utf8(&ply), "--listen", listen]);
    let err = stderr(&out);
    assert!(!out.status.success(), "--listen {listen}: {err}");
    assert!(!String::from_utf8_lossy(&out.stdout).contains("open http"), "--listen {listen}");
    assert!(!err.contains("other machines") && !err.contains("panicked"), "--listen {listen}: {err}");
    assert_eq!(std::fs::read(&ply).expect("the PLY"), before, "--listen {listen}: the PLY changed");
    assert_eq!(std::fs::read_dir(scene).expect("scene").count(), files, "--listen {listen}: a file appeared");
    err
}

#[test]
fn an_unresolvable_listen_host_is_reported_as_such() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let scene = tmp.path().join("scene");
    tiny_scene(&scene);
    let err = view_refused(&scene, "no-such-host.invalid:0");
    assert!(err.contains("no-such-host.invalid") && err.contains("does not resolve"), "{err}");
    assert!(!err.contains("another program"), "{err}");
}

/// Issue 59: `127.0.0.1:80:80` was read as the IPv6 host `127.0.0.1:80`, warned that other
/// machines could see the scene, then failed to resolve; an unresolvable or taken address on all
/// interfaces warned before its error too.
#[test]
fn a_bad_listen_address_is_one_error_with_no_warning_before_it() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let scene = tmp.path().join("scene");
    tiny_scene(&scene);
    let err = view_refused(&scene, "127.0.0.1:80:80");
    assert!(err.contains("expected HOST:PORT") && err.contains("`127.0.0.1:80:80`"), "{err}");
    let err = view_refused(&scene, "[::1:8080");
    assert!(err.contains("expected HOST:PORT") && err.contains("[::1]:8080"), "{err}");
    let taken = std::net::TcpListener::bind("0.0.0.0:0").expect("bind");
    let port = taken.local_addr().expect("addr").port();
    let err = view_refused(&scene, &format!("0.0.0.0:{port}"));
    assert!(err.contains("cannot listen") && err.contains(&format!("0.0.0.0:{port}")), "{err}");
}
