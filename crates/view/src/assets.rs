//! The page's files, embedded in the binary: no CDN, no network, no build step.

/// The page, with the placeholder `SPLATSEG_TOKEN` that [`crate::access::Access::page`] replaces
/// by the server's token; served at `/` and `/index.html` by [`crate::request`].
pub const INDEX_HTML: &[u8] = include_bytes!("../assets/index.html");

/// `(URL path, content type, bytes)` of every asset but the page.
pub const ASSETS: &[(&str, &str, &[u8])] = &[
    ("/assets/style.css", "text/css; charset=utf-8", include_bytes!("../assets/style.css")),
    ("/assets/viewer.js", "text/javascript; charset=utf-8", include_bytes!("../assets/viewer.js")),
    ("/assets/camera.js", "text/javascript; charset=utf-8", include_bytes!("../assets/camera.js")),
    ("/assets/splats.js", "text/javascript; charset=utf-8", include_bytes!("../assets/splats.js")),
    ("/assets/panel.js", "text/javascript; charset=utf-8", include_bytes!("../assets/panel.js")),
    ("/assets/edit.js", "text/javascript; charset=utf-8", include_bytes!("../assets/edit.js")),
    ("/assets/sort-worker.js", "text/javascript; charset=utf-8", include_bytes!("../assets/sort-worker.js")),
    ("/assets/splat.vert", "text/plain; charset=utf-8", include_bytes!("../assets/splat.vert")),
    ("/assets/splat.frag", "text/plain; charset=utf-8", include_bytes!("../assets/splat.frag")),
    ("/assets/lines.vert", "text/plain; charset=utf-8", include_bytes!("../assets/lines.vert")),
    ("/assets/lines.frag", "text/plain; charset=utf-8", include_bytes!("../assets/lines.frag")),
];

/// The asset at `path`, if any (not the page).
pub fn asset(path: &str) -> Option<(&'static str, &'static [u8])> {
    ASSETS.iter().find(|(p, _, _)| *p == path).map(|(_, t, b)| (*t, *b))
}

/// Total bytes of the page and its assets.
pub fn total_bytes() -> usize {
    INDEX_HTML.len() + ASSETS.iter().map(|(_, _, b)| b.len()).sum::<usize>()
}
