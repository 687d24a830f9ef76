//! Benchmark of an edit's preview in the page at 1M Gaussians (issue 60), in headless Chromium
//! (SwiftShader: software WebGL on the CPU): from the page's request to the slots uploaded —
//! `POST /api/edits/preview` answered and read (4 MB of slots), then `Viewer::setObjects` (the
//! slot texture uploaded, the object table rebuilt) — for a merge and for the merge, a box split
//! and a rename; and a brush selection grown once by 3D neighbours (`POST /api/edits/select`,
//! then the highlighted rows uploaded). The redraw after them is not counted: the page's frame
//! loop is stopped first (software rasterisation of 1M quads takes tens of seconds here, and
//! the replies would wait behind it; `view_bench`'s first frame). Prints a Markdown table for BENCHMARKS.md.
//!
//! `cargo run --release -p splatseg-view --features bench --example edit_preview_bench -- [N]`

use splatseg_edit::edits::centres_digest;
use splatseg_edit::EditInputs;
use splatseg_scene::Gaussians;
use splatseg_view::browser::{find_chromium, Browser};
use splatseg_view::editing::EditSetup;
use splatseg_view::{Site, ViewServer, ViewSource};
use std::path::PathBuf;

/// `n` Gaussians with pseudo-random centres in a 2-unit cube, in 100 objects by x–y cell (as
/// `edit_bench`).
fn scene(n: usize) -> Gaussians {
    let mut seed = 0x2545_f491_u64;
    let mut next = move || {
        seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
        (seed >> 40) as f32 / (1u64 << 24) as f32
    };
    let mut g = Gaussians::default();
    let mut ids = Vec::with_capacity(n);
    for _ in 0..n {
        let p = [2.0 * next() - 1.0, 2.0 * next() - 1.0, 2.0 * next() - 1.0];
        let cell = |v: f32| ((v + 1.0) * 5.0).clamp(0.0, 9.0) as i32;
        ids.push(1 + cell(p[0]) * 10 + cell(p[1]));
        g.means.push(p);
        g.log_scales.push([-6.0; 3]);
        g.rotations.push([1.0, 0.0, 0.0, 0.0]);
        g.raw_opacities.push(0.0);
        g.sh_dc.push([0.0; 3]);
    }
    g.object_ids = Some(ids);
    g
}

/// The page's script: each case timed `repeats` times, [reply ms, upload ms] per run.
const SCRIPT: &str = r#"
(async () => {
  const repeats = REPEATS;
  const ed = viewer.editor;
  // no more frames: a frame of 1M quads software rasterised holds the page's thread for tens of
  // seconds, and the replies would wait behind it
  viewer.frame = () => {};
  await new Promise((res) => setTimeout(res, 100));
  let uploadMs = 0;
  const setObjects = viewer.setObjects.bind(viewer);
  viewer.setObjects = (objects, slots) => { const t = performance.now(); setObjects(objects, slots); uploadMs = performance.now() - t; };
  const setPicked = viewer.setPickedRows.bind(viewer);
  viewer.setPickedRows = (ranges) => { const t = performance.now(); setPicked(ranges); uploadMs = performance.now() - t; };
  const time = async (f) => {
    const out = [];
    for (let k = 0; k < repeats; k++) {
      uploadMs = 0;
      const t = performance.now();
      await f();
      const total = performance.now() - t;
      out.push([total - uploadMs, uploadMs]);
    }
    return out;
  };
  const merge = { op: 'merge', ids: [12, 13, 22, 23] };
  const box = { op: 'split_box', object: 45, box: { centre: [-0.1, -0.1, 0], half_size: [0.05, 0.05, 0.5] } };
  const rename = { op: 'rename', id: 12, name: 'table' };
  const c = viewer.canvas;
  const brush = { parts: [{ by: 'brush', camera: ed.lassoCamera(), stroke_px: [[0.4 * c.width, 0.4 * c.height], [0.6 * c.width, 0.6 * c.height]], radius_px: 0.02 * c.width }],
    neighbours: [{ grow: ed.neighbourRadius }] };
  return {
    merge: await time(() => ed.preview([merge])),
    three: await time(() => ed.preview([merge, box, rename])),
    brush: await time(() => ed.showSelection(brush)),
    count: ed.selectionCount,
    radius: ed.neighbourRadius,
  };
})()
"#;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let n: usize = std::env::args().nth(1).map(|a| a.parse()).transpose()?.unwrap_or(1_000_000);
    let repeats = 5;
    let paths = find_chromium().ok_or("install chromium and chromium-driver")?;
    let dir = std::env::temp_dir().join(format!("splatseg-edit-preview-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let gaussians = scene(n);
    let inputs =
        EditInputs { gaussians: n as u64, ply_digest: centres_digest(&gaussians.means), run: "bench".into() };
    let source = ViewSource {
        ply_path: PathBuf::from("bench.ply"),
        gaussians,
        scene: None,
        views: Vec::new(),
        export_dir: dir.clone(),
        warnings: Vec::new(),
    };
    let mut site = Site::new(source);
    let identity = inputs.clone();
    let started = std::time::Instant::now();
    site.enable_editing(EditSetup {
        inputs,
        base_ids: None,
        map_only_ids: Default::default(),
        edits_path: dir.join("edits.json"),
        identity_now: Box::new(move || Ok(identity.clone())),
    })?;
    let enable_ms = started.elapsed().as_secs_f64() * 1e3;
    let server = ViewServer::start(site, "127.0.0.1", 0)?;
    // a small window: the frames drawn while loading are software rasterised
    let browser = Browser::launch(&paths, 480, 360)?;
    browser.goto(server.url())?;
    let ready = browser.await_promise("viewer.whenReady(1800000)")?;
    if !ready["error"].is_null() {
        return Err(format!("page failed: {ready}").into());
    }
    let got = browser.await_promise(&SCRIPT.replace("REPEATS", &repeats.to_string()))?;
    let column = |case: &str, k: usize| -> f64 {
        median(
            got[case]
                .as_array()
                .map_or_else(Vec::new, |runs| runs.iter().filter_map(|r| r[k].as_f64()).collect()),
        )
    };
    println!("| in the page, {n} Gaussians (100 objects), median of {repeats} | request → reply read | upload (+ table) | in all |");
    println!("| --- | ---: | ---: | ---: |");
    for (case, what) in [
        ("merge", "preview of a merge of 4 objects (4 MB of slots)"),
        ("three", "preview of the merge, a box split and a rename"),
        ("brush", "brush selection grown once by neighbours (rows highlighted)"),
    ] {
        let (reply, upload) = (column(case, 0), column(case, 1));
        println!("| {what} | {reply:.0} ms | {upload:.0} ms | {:.0} ms |", reply + upload);
    }
    println!(
        "\nbrush selection: {} Gaussians, neighbour radius {}; editing turned on (neighbour radius computed) in {enable_ms:.0} ms",
        got["count"], got["radius"]
    );
    server.stop();
    std::fs::remove_dir_all(&dir)?;
    Ok(())
}
