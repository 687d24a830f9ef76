//! `splatseg view`: serve the interactive web viewer (crate `splatseg-view`) for a scene.

use anyhow::Context;
use splatseg_model_cues::clip_objects::ObjectSearch;
use splatseg_pipeline::viewer_edits;
use splatseg_view::editing::EditSetup;
use splatseg_view::search::{ObjectName, SearchHit};
use splatseg_view::{Listening, Site, ViewArgs, ViewServer, ViewSource};
use std::io::Write;
use std::path::Path;

/// Runs the command (until interrupted).
pub fn run(args: ViewArgs) -> anyhow::Result<()> {
    // The paths checked, then bound: a bad argument is one error, with no warning or "listening"
    // line before it.
    ViewSource::check_paths(&args.path, &args.source_options())?;
    let (host, port) = &args.listen;
    let listening = Listening::bind(host, *port)?;
    let names = args.names.as_deref().map(splatseg_model_cues::object_names::read_names).transpose()?;
    let source = ViewSource::open(&args.path, &args.source_options())?;
    for warning in &source.warnings {
        tracing::warn!("{warning}");
    }
    if !listening.is_loopback() {
        tracing::warn!(
            "listening on {} ({}): other machines on the network can see this scene and write exports into {}",
            host,
            listening.address(),
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
    let ply_path = source.ply_path.clone();
    let mut site = Site::new(source);
    enable_editing(&mut site, &ply_path);
    let search = object_search(&ply_path, names.is_some())?;
    if let (Some(names), Some(search)) = (&names, &search) {
        let named = search.name_objects(names).map_err(|e| anyhow::anyhow!(e.report()))?;
        let named: Vec<ObjectName> = named
            .into_iter()
            .map(|n| ObjectName { id: n.id, name: n.name, relevancy: n.relevancy })
            .collect();
        site = site.with_names(&named);
    }
    if let Some(search) = search {
        site = site.with_search(Box::new(move |query: &str, top: usize| {
            let found = search.find(query, top).map_err(|e| e.report())?;
            Ok(found.iter().map(|f| SearchHit { id: f.id, relevancy: f.relevancy }).collect())
        }));
    }
    let server = ViewServer::serve(listening, site)?;
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

/// Editing (merge, split, rename; Save writes `OUT/edits.json`) when the served PLY is a run's
/// `gaussians.ply`; otherwise, or when the run cannot be read, the viewer only views (a warning
/// says why for a run folder).
fn enable_editing(site: &mut Site, ply: &Path) {
    let out = ply.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new(".")).to_path_buf();
    if ply.file_name() != Some("gaussians.ply".as_ref()) || !viewer_edits::is_run_folder(&out) {
        return;
    }
    let run = match viewer_edits::run_to_edit(&out) {
        Ok(run) => run,
        Err(e) => {
            tracing::warn!("no editing: {}", e.report());
            return;
        }
    };
    let watch = run.watch;
    let setup = EditSetup {
        inputs: run.inputs,
        base_ids: run.base_ids,
        map_only_ids: run.map_only_ids,
        edits_path: out.join(splatseg_edit::EDITS_FILE),
        identity_now: Box::new(move || watch.identity().map_err(|e| e.report())),
    };
    if let Err(e) = site.enable_editing(setup) {
        tracing::warn!("no editing: {e}: {}", ply.display());
    }
}

/// The object embeddings and text tower of the run that wrote the served PLY (in its folder) when it
/// has them (`run --clip`) and they belong to that PLY and run (`ObjectIndex::check_belongs`), loaded
/// once for the search box and the names. Without them: no search box (a warning says why when an
/// index is there but stale), or an error when `--names` asked for them.
fn object_search(ply: &Path, needed: bool) -> anyhow::Result<Option<ObjectSearch>> {
    let out = ply.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let index = out.join("objects").join("objects.json");
    if !index.is_file() && !needed {
        return Ok(None);
    }
    match ObjectSearch::open_beside(ply) {
        Ok(search) => Ok(Some(search)),
        Err(e) if needed => Err(anyhow::anyhow!("--names needs the object embeddings: {}", e.report())),
        Err(e) => {
            tracing::warn!("no search box: {}", e.report());
            Ok(None)
        }
    }
}
