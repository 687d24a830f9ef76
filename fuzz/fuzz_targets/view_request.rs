//! The viewer's server on raw bytes: one connection's request (head, framing, `Host`, token and
//! `Origin`, routing, export) through `splatseg_view::fuzzing::request_bytes`, which checks the
//! reply's invariants. Exports are written under the temp folder.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::sync::OnceLock;

static SITE: OnceLock<(splatseg_view::Site, splatseg_view::access::Access)> = OnceLock::new();

fuzz_target!(|data: &[u8]| {
    let (site, access) = SITE.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("splatseg-fuzz-view-{}", std::process::id()));
        splatseg_view::fuzzing::site(dir)
    });
    splatseg_view::fuzzing::request_bytes(site, access, data);
});
