//! `splatseg view`: serve the interactive web viewer (crate `splatseg-view`) for a scene.

use anyhow::Context;
use splatseg_view::{Site, ViewArgs, ViewServer, ViewSource};
use std::io::Write;

/// Runs the command (until interrupted).
pub fn run(args: ViewArgs) -> anyhow::Result<()> {
    let source = ViewSource::open(&args.path, &args.source_options())?;
    for warning in &source.warnings {
        tracing::warn!("{warning}");
    }
    let (host, port) = &args.listen;
    if !args.is_loopback() {
        tracing::warn!(
            "listening on {}: other machines on the network can see this scene and write exports into {}",
            host,
            source.export_dir.display()
        );
    }
    let summary = format!(
        "{} Gaussians, {} objects, {} cameras from {}",
        source.gaussians.len(),
        splatseg_view::manifest::object_slots(&source.gaussians).1.len(),
        source.scene.as_ref().map_or(0, |s| s.views.len()),
        source.ply_path.display()
    );
    let mut site = Site::new(source);
    if let Some(search) = object_search(&args.path) {
        site = site.with_search(search);
    }
    let server = ViewServer::start(site, host, *port)?;
    println!("splatseg view: {summary}");
    println!("open {}", server.url());
    std::io::stdout().flush().context("writing to stdout")?;
    if args.open {
        if let Err(e) = splatseg_view::open_in_browser(server.url()) {
            tracing::warn!("cannot open a browser ({e}); open {} yourself", server.url());
        }
    }
    server.wait();
    Ok(())
}

/// The search box's ranking when PATH is (or holds the PLY of) a run with object embeddings
/// (`run --clip`): the text tower is loaded once, here.
fn object_search(path: &std::path::Path) -> Option<splatseg_view::search::Search> {
    let out = if path.is_dir() { path } else { path.parent()? };
    let index = out.join("objects").join("objects.json");
    if !index.is_file() {
        return None;
    }
    match splatseg_model_cues::clip_objects::ObjectSearch::open(out) {
        Ok(search) => Some(Box::new(move |query: &str, top: usize| {
            let found = search.find(query, top).map_err(|e| e.report())?;
            Ok(found
                .iter()
                .map(|f| splatseg_view::search::SearchHit { id: f.id, relevancy: f.relevancy })
                .collect())
        })),
        Err(e) => {
            tracing::warn!("no search box: {}", e.report());
            None
        }
    }
}
