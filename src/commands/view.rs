//! `splatseg view`: serve the interactive web viewer (crate `splatseg-view`) for a scene.

use anyhow::Context;
use clap::Args as ClapArgs;
use splatseg_view::{Site, SourceOptions, ViewServer, ViewSource};
use std::io::Write;
use std::path::PathBuf;

/// Open a labelled scene in the browser: see it, click objects, hide / isolate / recolour them
/// and export a selection as a PLY.
///
/// PATH is `splatseg run`'s or `train`'s output folder (e.g. `out/demo/run`), an INRIA 3DGS output
/// folder, or any 3DGS PLY (without `object_id` it is one object). The viewer starts at the
/// capture's first camera: the scene `run` recorded in its report.md, a `scene/` folder beside
/// PATH, or --scene. The page (HTML, JS, WebGL2 shaders) is built into the binary: no network, no
/// GPU toolkit, any browser with WebGL2.
///
/// The server listens on 127.0.0.1 only, answers only requests addressed to it (`Host`), serves
/// nothing but this scene's files, and writes exports (the same bytes as `splatseg extract` /
/// `remove`), asked for by its own page only, into --out, or PATH's folder.
/// Stop it with Ctrl-C.
#[derive(Debug, ClapArgs)]
pub struct Args {
    /// Output folder of `run` / `train`, or a 3DGS PLY.
    pub path: PathBuf,
    /// Scene folder with the cameras (COLMAP or transforms.json), if not found automatically.
    #[arg(long)]
    pub scene: Option<PathBuf>,
    /// Address and port to listen on, `HOST:PORT` (port 0 = any free port). Any host but
    /// 127.0.0.1 / localhost exposes the scene and its export endpoint to other machines.
    #[arg(long, default_value = "127.0.0.1:8080", value_parser = parse_listen, value_name = "HOST:PORT")]
    pub listen: (String, u16),
    /// Folder for exported PLYs (default: PATH's folder).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Open the page in the default browser.
    #[arg(long)]
    pub open: bool,
}

/// Runs the command (until interrupted).
pub fn run(args: Args) -> anyhow::Result<()> {
    let options = SourceOptions { scene: args.scene.clone(), out: args.out.clone() };
    let source = ViewSource::open(&args.path, &options)?;
    for warning in &source.warnings {
        tracing::warn!("{warning}");
    }
    let (host, port) = &args.listen;
    if !matches!(host.as_str(), "127.0.0.1" | "localhost" | "::1") {
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

/// Parses `HOST:PORT` (an IPv6 host in brackets: `[::1]:8080`).
fn parse_listen(text: &str) -> Result<(String, u16), String> {
    let (host, port) = text.rsplit_once(':').ok_or_else(|| format!("expected HOST:PORT, got `{text}`"))?;
    let port = port.parse::<u16>().map_err(|_| format!("`{port}` is not a port number (0–65535)"))?;
    let host = host.trim_start_matches('[').trim_end_matches(']');
    if host.is_empty() {
        return Err(format!("expected HOST:PORT, got `{text}`"));
    }
    Ok((host.to_string(), port))
}
