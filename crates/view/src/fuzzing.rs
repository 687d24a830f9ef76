//! The bytes entry point of the `view_request` fuzz target (`fuzz/fuzz_targets/view_request.rs`)
//! and of the corpus replay test: raw bytes as one connection's request, through
//! [`exchange`] — head, framing, `Host`, token and `Origin`, routing, export — against a small
//! in-memory scene, with the server's invariants checked on the reply.

use crate::access::Access;
use crate::routes::Site;
use crate::source::ViewSource;
use crate::wire::exchange;
use splatseg_scene::Gaussians;
use std::io::Cursor;
use std::path::PathBuf;

/// The token of [`site`]'s server (fixed, so seeds can carry it).
pub const TOKEN: &str = "00112233445566778899aabbccddeeff";

/// The address [`site`]'s server pretends to listen on.
pub const ADDR: &str = "127.0.0.1:8080";

/// Three Gaussians (objects 1 and 2) served as if bound to [`ADDR`]; exports go to `export_dir`.
pub fn site(export_dir: PathBuf) -> (Site, Access) {
    let gaussians = Gaussians {
        means: vec![[0.0; 3], [1.0; 3], [2.0; 3]],
        sh_dc: vec![[0.0; 3]; 3],
        raw_opacities: vec![0.0; 3],
        log_scales: vec![[0.0; 3]; 3],
        rotations: vec![[1.0, 0.0, 0.0, 0.0]; 3],
        object_ids: Some(vec![1, 2, 1]),
        ..Gaussians::default()
    };
    let source = ViewSource {
        ply_path: PathBuf::from("fuzz.ply"),
        gaussians,
        scene: None,
        views: Vec::new(),
        export_dir,
        warnings: Vec::new(),
    };
    let bound = ADDR.parse().unwrap_or_else(|_| unreachable!("a socket address literal"));
    (Site::new(source), Access::new(bound, "127.0.0.1", TOKEN.to_string()))
}

/// Runs `data` as one connection's bytes and returns the reply's bytes. Panics (a bug) when the
/// reply is not one well-formed HTTP/1.1 answer, or a change succeeded without the token.
pub fn request_bytes(site: &Site, access: &Access, data: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    if exchange(site, access, &mut Cursor::new(data), &mut out).is_err() {
        unreachable!("writing into a Vec does not fail");
    }
    if data.is_empty() {
        assert!(out.is_empty(), "a reply to nothing");
        return out;
    }
    let end = out.windows(4).position(|w| w == b"\r\n\r\n").expect("a reply head");
    let head = std::str::from_utf8(&out[..end]).expect("an ASCII reply head");
    assert!(head.starts_with("HTTP/1.1 "), "{head}");
    let status: u16 = head[9..12].parse().expect("a status code");
    let length: usize = head
        .lines()
        .find_map(|l| l.strip_prefix("Content-Length: "))
        .and_then(|n| n.parse().ok())
        .expect("a Content-Length");
    let body = out.len() - end - 4;
    assert!(body == length || body == 0, "Content-Length {length}, body {body}");
    let method = data.split(|&b| b == b' ').next().unwrap_or_default();
    if status == 200 && method != b"GET" && method != b"HEAD" {
        let token = TOKEN.as_bytes();
        assert!(data.windows(token.len()).any(|w| w == token), "a change without the token succeeded");
    }
    out
}
