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
    let server = ViewServer::start(Site::new(source), host, *port)?;
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
