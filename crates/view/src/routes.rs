//! Request routing: a pure function from (method, URL, body) to a reply, so every rule (what is
//! served, 404 for anything else, export) is tested without a socket. Who may ask (`Host`, the
//! token) and the page itself are [`crate::request`]'s, in front of this. Nothing here builds a file
//! path from the URL: files are looked up in tables made at start, so `..` and unknown paths are
//! simply not found.

use crate::assets::asset;
use crate::editing::{preview_body, EditSetup, Editing, PreviewRequest, SaveRequest, SelectRequest};
use crate::export::{export, ExportRequest};
use crate::manifest::{self, Manifest};
use crate::pack::{pack, BYTES_PER_GAUSSIAN, CHUNK_GAUSSIANS};
use crate::search::{query_param, Search, FIND_PATH, MAX_QUERY_CHARS, SEARCH_TOP};
use crate::source::ViewSource;
use std::borrow::Cow;
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::Mutex;

/// Largest request body accepted, bytes (an export request is a list of ids), but for edits.
pub const MAX_BODY_BYTES: usize = 64 * 1024;

/// Largest body of `POST /api/edits` and `/api/edits/preview`, bytes: a page's whole list of
/// operations (a lasso of 128 vertices is ≈ 3 KB; an `assign` of scattered rows can be long).
pub const MAX_EDITS_BODY_BYTES: usize = 4 << 20;

/// The largest body accepted at `path`.
pub fn body_limit(path: &str) -> usize {
    if path == "/api/edits" || path == "/api/edits/preview" || path == "/api/edits/select" {
        MAX_EDITS_BODY_BYTES
    } else {
        MAX_BODY_BYTES
    }
}

/// An HTTP reply.
#[derive(Debug)]
pub struct Reply<'a> {
    /// Status code.
    pub status: u16,
    /// `Content-Type`.
    pub content_type: &'static str,
    /// Body.
    pub body: Cow<'a, [u8]>,
    /// `Content-Disposition` file name (downloads).
    pub download_name: Option<String>,
}

impl<'a> Reply<'a> {
    fn ok(content_type: &'static str, body: Cow<'a, [u8]>) -> Self {
        Reply { status: 200, content_type, body, download_name: None }
    }

    fn json(status: u16, value: &serde_json::Value) -> Self {
        let body = serde_json::to_vec(value).unwrap_or_default();
        Reply { status, content_type: "application/json", body: Cow::Owned(body), download_name: None }
    }

    /// An error as `{"error": message}`.
    pub fn error(status: u16, message: &str) -> Self {
        Self::json(status, &serde_json::json!({ "error": message }))
    }

    /// The page (`index.html`).
    pub fn page(body: Cow<'a, [u8]>) -> Self {
        Self::ok("text/html; charset=utf-8", body)
    }

    /// 404.
    pub fn not_found() -> Self {
        Self::error(404, "not found")
    }

    /// 413: the body is over `limit` bytes.
    pub fn too_large(limit: usize) -> Self {
        Self::error(413, &format!("request body over {limit} bytes"))
    }
}

/// What the server holds: the source, its packed Gaussians, the manifest, and the exports written.
pub struct Site {
    source: ViewSource,
    manifest: Manifest,
    manifest_json: Vec<u8>,
    packed: Vec<u8>,
    exports: Mutex<BTreeMap<String, PathBuf>>,
    search: Option<Search>,
    editing: Option<Editing>,
}

impl Site {
    /// Packs the Gaussians and builds the manifest.
    pub fn new(source: ViewSource) -> Site {
        let (slots, objects) = manifest::object_slots(&source.gaussians);
        let packed = pack(&source.gaussians, &slots);
        let manifest = manifest::build(&source, objects);
        let manifest_json = serde_json::to_vec(&manifest).unwrap_or_default();
        Site {
            source,
            manifest,
            manifest_json,
            packed,
            exports: Mutex::new(BTreeMap::new()),
            search: None,
            editing: None,
        }
    }

    /// The site with a search box: `/api/find?q=` answered by `search` (and `search: true` in the
    /// manifest).
    pub fn with_search(mut self, search: Search) -> Site {
        self.manifest.search = true;
        self.manifest_json = serde_json::to_vec(&self.manifest).unwrap_or_default();
        self.search = Some(search);
        self
    }

    /// The site with the objects' names of `view --names` in the manifest (objects not named
    /// keep none).
    pub fn with_names(mut self, names: &[crate::search::ObjectName]) -> Site {
        for object in &mut self.manifest.objects {
            if let Some(n) = names.iter().find(|n| i64::from(n.id) == i64::from(object.id)) {
                object.name = Some(n.name.clone());
                object.name_relevancy = Some(n.relevancy);
            }
        }
        self.manifest_json = serde_json::to_vec(&self.manifest).unwrap_or_default();
        self
    }

    /// Turns editing on (`crate::editing`: `POST /api/edits/preview` and `POST /api/edits`, and
    /// `editing` in the manifest); `Err` says why it stays off (the served PLY is not the run's).
    pub fn enable_editing(&mut self, setup: EditSetup) -> Result<(), String> {
        let editing = Editing::new(&self.source.gaussians, setup)?;
        self.manifest.editing = Some(editing.entry());
        self.manifest_json = serde_json::to_vec(&self.manifest).unwrap_or_default();
        self.editing = Some(editing);
        Ok(())
    }

    /// The manifest served at `/api/scene.json`.
    pub fn manifest(&self) -> &Manifest {
        &self.manifest
    }

    /// The source shown.
    pub fn source(&self) -> &ViewSource {
        &self.source
    }

    /// Answers one request.
    pub fn respond(&self, method: &str, url: &str, body: &[u8]) -> Reply<'_> {
        let path = url.split(['?', '#']).next().unwrap_or("");
        match method {
            "GET" | "HEAD" if path == FIND_PATH => self.find(url),
            "GET" | "HEAD" => self.get(path),
            "POST" if path == "/api/export" => self.export(body),
            "POST" if path == "/api/edits/preview" => self.preview_edits(body),
            "POST" if path == "/api/edits" => self.save_edits(body),
            "POST" if path == "/api/edits/select" => self.select_gaussians(body),
            _ => Reply::not_found(),
        }
    }

    fn get(&self, path: &str) -> Reply<'_> {
        if let Some((content_type, bytes)) = asset(path) {
            return Reply::ok(content_type, Cow::Borrowed(bytes));
        }
        let parts: Vec<&str> = path.trim_start_matches('/').split('/').collect();
        match parts[..] {
            ["api", "scene.json"] => self.scene_json(),
            ["api", "gaussians", chunk] => self.chunk(chunk),
            ["views", view, "overlay.png"] => self.overlay(view),
            ["api", "label", view, x, y] => self.label(view, x, y),
            ["exports", name] => self.exported(name),
            _ => Reply::not_found(),
        }
    }

    /// The manifest; with editing, its operations as last saved (a page opened again starts from them).
    fn scene_json(&self) -> Reply<'_> {
        match &self.editing {
            Some(editing) => {
                let mut manifest = self.manifest.clone();
                manifest.editing = Some(editing.entry());
                Reply::ok("application/json", Cow::Owned(serde_json::to_vec(&manifest).unwrap_or_default()))
            }
            None => Reply::ok("application/json", Cow::Borrowed(&self.manifest_json)),
        }
    }

    fn chunk(&self, name: &str) -> Reply<'_> {
        let Some(k) = name.strip_suffix(".bin").and_then(|k| k.parse::<usize>().ok()) else {
            return Reply::not_found();
        };
        let n = self.source.gaussians.len();
        let start = k.saturating_mul(CHUNK_GAUSSIANS);
        if start >= n {
            return Reply::not_found();
        }
        let end = (start + CHUNK_GAUSSIANS).min(n);
        let bytes = &self.packed[start * BYTES_PER_GAUSSIAN..end * BYTES_PER_GAUSSIAN];
        Reply::ok("application/octet-stream", Cow::Borrowed(bytes))
    }

    fn view_index(&self, view: &str) -> Option<usize> {
        view.parse::<usize>().ok().filter(|&i| i < self.source.views.len())
    }

    fn overlay(&self, view: &str) -> Reply<'_> {
        let Some(path) = self.view_index(view).and_then(|i| self.source.views[i].overlay.as_ref()) else {
            return Reply::not_found();
        };
        match std::fs::read(path) {
            Ok(bytes) => Reply::ok("image/png", Cow::Owned(bytes)),
            Err(_) => Reply::not_found(),
        }
    }

    fn label(&self, view: &str, x: &str, y: &str) -> Reply<'_> {
        let Some(path) = self.view_index(view).and_then(|i| self.source.views[i].mask.as_ref()) else {
            return Reply::not_found();
        };
        let (Ok(x), Ok(y)) = (x.parse::<usize>(), y.parse::<usize>()) else {
            return Reply::not_found();
        };
        match splatseg_scene::labels::read_label_png(path) {
            Ok(map) if x < map.width && y < map.height => {
                let id = map.data[y * map.width + x];
                Reply::json(200, &serde_json::json!({ "id": if id == 0 { None } else { Some(id) } }))
            }
            Ok(_) => Reply::error(400, "pixel outside the label map"),
            Err(e) => Reply::error(500, &e.to_string()),
        }
    }

    fn export(&self, body: &[u8]) -> Reply<'_> {
        if body.len() > MAX_BODY_BYTES {
            return Reply::too_large(MAX_BODY_BYTES);
        }
        let request: ExportRequest = match serde_json::from_slice(body) {
            Ok(r) => r,
            Err(e) => return Reply::error(400, &format!("bad export request: {e}")),
        };
        let source = &self.source;
        // one export at a time: each picks a free name and empties the staging folder
        let mut exports = self.exports.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
        match export(&source.gaussians, &source.ply_path, &source.export_dir, &request) {
            Ok(done) => {
                exports.insert(done.name.clone(), done.path.clone());
                Reply::json(
                    200,
                    &serde_json::json!({
                        "path": done.path.display().to_string(),
                        "url": format!("/exports/{}", done.name),
                        "count": done.count,
                    }),
                )
            }
            Err(e) => Reply::error(400, &e.to_string()),
        }
    }

    fn editing(&self) -> Result<&Editing, Reply<'static>> {
        self.editing.as_ref().ok_or_else(|| {
            Reply::error(
                404,
                "no editing here: open the output folder of `splatseg run` (its gaussians.ply and cache/run.json)",
            )
        })
    }

    /// The scene's cameras, for lassos drawn in a view.
    fn cameras(&self) -> Vec<(&splatseg_scene::Camera, &splatseg_scene::Pose)> {
        self.source
            .scene
            .as_ref()
            .map_or_else(Vec::new, |s| s.views.iter().map(|v| (s.camera(v), &v.world_from_cam)).collect())
    }

    fn preview_edits(&self, body: &[u8]) -> Reply<'_> {
        let editing = match self.editing() {
            Ok(e) => e,
            Err(reply) => return reply,
        };
        let request: PreviewRequest = match serde_json::from_slice(body) {
            Ok(r) => r,
            Err(e) => {
                return Reply::error(
                    400,
                    &format!("bad edits preview request (expected {{\"operations\": [...]}}): {e}"),
                )
            }
        };
        match editing.preview(&self.source.gaussians.means, &self.cameras(), &request.operations) {
            Ok(preview) => Reply::ok("application/octet-stream", Cow::Owned(preview_body(&preview))),
            Err(refused) => Reply::error(refused.status, &refused.message),
        }
    }

    fn select_gaussians(&self, body: &[u8]) -> Reply<'_> {
        let editing = match self.editing() {
            Ok(e) => e,
            Err(reply) => return reply,
        };
        let request: SelectRequest = match serde_json::from_slice(body) {
            Ok(r) => r,
            Err(e) => {
                return Reply::error(
                    400,
                    &format!(
                        "bad selection (expected {{\"operations\": [...], \"objects\": [ids], \"opacity_below\": x, \"size_above\": y}} or {{\"operations\": [...], \"selection\": {{...}}}}): {e}"
                    ),
                )
            }
        };
        match editing.select(&self.source.gaussians, &self.cameras(), &request) {
            Ok(ranges) => {
                let count: u64 = ranges.iter().map(|r| r[1] - r[0]).sum();
                Reply::json(200, &serde_json::json!({ "ranges": ranges, "count": count }))
            }
            Err(refused) => Reply::error(refused.status, &refused.message),
        }
    }

    fn save_edits(&self, body: &[u8]) -> Reply<'_> {
        let editing = match self.editing() {
            Ok(e) => e,
            Err(reply) => return reply,
        };
        let request: SaveRequest = match serde_json::from_slice(body) {
            Ok(r) => r,
            Err(e) => {
                return Reply::error(
                    400,
                    &format!("bad edits (expected {{\"inputs\": {{...}}, \"operations\": [...]}}): {e}"),
                )
            }
        };
        let operations = request.operations.len();
        match editing.save(&self.source.gaussians.means, &self.cameras(), request) {
            Ok(path) => Reply::json(
                200,
                &serde_json::json!({ "path": path.display().to_string(), "operations": operations }),
            ),
            Err(refused) => Reply::error(refused.status, &refused.message),
        }
    }

    fn find(&self, url: &str) -> Reply<'_> {
        let Some(search) = &self.search else {
            return Reply::error(
                404,
                "no object search here: open the output folder of `splatseg run --clip CKPT` (its objects/)",
            );
        };
        let Some(query) = query_param(url) else {
            return Reply::error(400, "expected /api/find?q=TEXT (percent-encoded UTF-8)");
        };
        let trimmed = query.trim();
        if trimmed.is_empty() {
            return Reply::error(
                400,
                &format!(
                    "the query {query:?} is empty or blank: give the words to look for, e.g. \"a red mug\""
                ),
            );
        }
        let chars = trimmed.chars().count();
        if chars > MAX_QUERY_CHARS {
            return Reply::error(
                400,
                &format!(
                    "the query is {chars} characters long, more than the {MAX_QUERY_CHARS} searched (and CLIP \
                     reads 75 tokens at most): shorten it"
                ),
            );
        }
        match search(trimmed, SEARCH_TOP) {
            Ok(matches) => Reply::json(200, &serde_json::json!({ "query": trimmed, "matches": matches })),
            // the function's words, as `splatseg find` says them (e.g. longer than CLIP's context)
            Err(e) => Reply::error(400, &e),
        }
    }

    fn exported(&self, name: &str) -> Reply<'_> {
        let path = self.exports.lock().ok().and_then(|e| e.get(name).cloned());
        match path.map(std::fs::read) {
            Some(Ok(bytes)) => Reply {
                download_name: Some(name.to_string()),
                ..Reply::ok("application/octet-stream", Cow::Owned(bytes))
            },
            _ => Reply::not_found(),
        }
    }
}
