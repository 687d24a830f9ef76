//! Editing in `splatseg view` (issue 60), in a real headless Chromium on the production page, on a
//! synthetic scene's `run` result: merge two objects, split one by a box (placed from the
//! selection's bounds with the Box button, then narrowed in its numeric fields) and one by a lasso
//! drawn with the pointer in the current view, rename with a mistake undone, redone and undone
//! again, save; the page opened again starts from the saved edits; then `splatseg apply` and the outputs checked against the edits: the merged ids
//! are one id in every view's label map and in the PLY, each split's new object holds exactly
//! the Gaussians its box or lasso selects (projected in the test with the scene's camera), the
//! new objects show in the maps, and `splatseg objects` lists the name. The exports of the
//! selection's box (a crop of every Gaussian in it) and of a PLY coloured by object are checked
//! on the way.
//!
//! `SPLATSEG_UPDATE_SCREENSHOT=1 cargo test --release --test integration view_edit_browser`
//! also writes `docs/viewer-edit.png` (the page after the edits) for the README.

use crate::chromium::chromium_or_skip;
use crate::view_browser::{label_centres, serve, splatseg, state, utf8};
use serde_json::{json, Value};
use splatseg_view::browser::Browser;
use std::collections::BTreeSet;
use std::path::Path;

/// The brush's radius in the test, canvas pixels.
const BRUSH_RADIUS_PX: f64 = 3.0;

/// The page's script: the edits through the panel's buttons and the lasso's pointer events.
const EDIT_SCRIPT: &str = r#"
(async () => {
  const click = (id) => document.getElementById(id).click();
  const settle = async () => { await viewer.editor.busy; return viewer.editor.state(); };
  const [a, b, c, d, lasso, around, threshold, stroke, brushRadius, e] = arguments_;
  const steps = {};
  const until = async (f) => { for (let k = 0; k < 400 && !f(); k++) await new Promise((res) => setTimeout(res, 25)); };
  viewer.select([a, b]);
  click('edit-merge');
  steps.merge = await settle();
  steps.afterMerge = viewer.state().objects;
  viewer.select([c]);
  click('edit-box');
  const f = ['box-cx', 'box-cy', 'box-cz', 'box-hx', 'box-hy', 'box-hz'].map((id) => document.getElementById(id));
  const hx = Number(f[3].value);
  f[0].value = String(Number(f[0].value) - hx / 2);
  f[3].value = String(hx / 2);
  f.forEach((field) => field.dispatchEvent(new Event('input')));
  click('edit-split-box');
  steps.box = await settle();
  const svg = document.getElementById('lasso');
  const r = viewer.canvas.getBoundingClientRect();
  const at = ([x, y]) => ({ clientX: r.left + x * r.width / viewer.canvas.width, clientY: r.top + y * r.height / viewer.canvas.height, pointerId: 7, bubbles: true });
  const draw = (polygon) => {
    click('edit-lasso');
    svg.dispatchEvent(new PointerEvent('pointerdown', at(polygon[0])));
    for (const p of polygon.slice(1)) svg.dispatchEvent(new PointerEvent('pointermove', at(p)));
    svg.dispatchEvent(new PointerEvent('pointerup', at(polygon[polygon.length - 1])));
  };
  // front-most only, around all of d in this view, then undone with Ctrl+Z
  viewer.select([d]);
  document.getElementById('lasso-front').checked = true;
  draw(around);
  steps.front = await settle();
  document.getElementById('lasso-front').checked = false;
  window.dispatchEvent(new KeyboardEvent('keydown', { key: 'z', ctrlKey: true }));
  await settle();
  // the merged object's Gaussians less opaque than a threshold, to none, then undone
  viewer.select([a]);
  document.getElementById('filter-opacity').value = String(threshold);
  click('edit-filter-none');
  await new Promise((res) => setTimeout(res, 50));
  for (let k = 0; k < 200 && viewer.editor.ops.length < 3; k++) await new Promise((res) => setTimeout(res, 25));
  steps.filtered = await settle();
  steps.filterStatus = document.getElementById('edit-status').textContent;
  click('edit-undo');
  await settle();
  viewer.select([d]);
  draw(lasso);
  steps.lasso = await settle();
  // a Gaussian selection: a brush stroke across e, grown twice (+ +) and shrunk once (-) by 3D
  // neighbours within e, moved to a
  viewer.select([e]);
  click('edit-brush');
  document.getElementById('brush-radius').value = String(brushRadius);
  svg.dispatchEvent(new PointerEvent('pointerdown', at(stroke[0])));
  for (const p of stroke.slice(1)) svg.dispatchEvent(new PointerEvent('pointermove', at(p)));
  svg.dispatchEvent(new PointerEvent('pointerup', at(stroke[stroke.length - 1])));
  await until(() => viewer.editor.selection);
  steps.brushed = viewer.editor.selectionState();
  for (const [key, n] of [['+', 1], ['+', 2], ['-', 3]]) {
    window.dispatchEvent(new KeyboardEvent('keydown', { key }));
    await until(() => viewer.editor.selection?.neighbours.length === n);
    steps[`key${n}`] = viewer.editor.selectionState().count;
  }
  steps.selectionStatus = document.getElementById('selection-status').textContent;
  click('edit-brush');
  document.getElementById('move-to').value = String(a);
  click('sel-move');
  await until(() => viewer.editor.ops.length === 4);
  steps.moved = await settle();
  viewer.select([a]);
  const name = document.getElementById('edit-name');
  name.value = 'wrong';
  click('edit-rename');
  steps.renamed = (await settle(), viewer.state().names);
  click('edit-undo');
  steps.undone = (await settle(), viewer.state().names);
  click('edit-redo');
  steps.redone = (await settle(), viewer.state().names);
  click('edit-undo');
  await settle();
  name.value = 'room';
  click('edit-rename');
  steps.final = await settle();
  steps.names = viewer.state().names;
  click('edit-save');
  for (let k = 0; k < 400 && viewer.editor.dirty; k++) await new Promise((res) => setTimeout(res, 25));
  steps.saved = viewer.editor.state();
  steps.status = document.getElementById('edit-status').textContent;
  return steps;
})()
"#;

#[test]
fn objects_merged_split_by_box_and_lasso_and_renamed_in_the_page_are_what_apply_writes() {
    let Some(paths) = chromium_or_skip("the browser edit test") else { return };
    let tmp = tempfile::tempdir().expect("temp dir");
    let [scene, run, exports] = ["scene", "run", "exports"].map(|d| tmp.path().join(d));
    let synth_config = tmp.path().join("synth.toml");
    std::fs::write(&synth_config, "gaussian_spacing_px = 5.0\n").expect("write the synth config");
    splatseg(&["synth", "--out", utf8(&scene), "--views", "4", "--config", utf8(&synth_config)]);
    splatseg(&[
        "run",
        utf8(&scene),
        "--masks",
        utf8(&scene.join("sam")),
        "--features",
        utf8(&scene.join("features")),
        "--out",
        utf8(&run),
    ]);
    let loaded = splatseg_scene::load_scene(&scene, &Default::default()).expect("the scene");
    let first = &loaded.views[0];
    let before = splatseg_scene::ply::read_ply(&run.join("gaussians.ply")).expect("the run's PLY");
    let ids_before = before.object_ids.clone().expect("object ids");
    let maps_before = label_maps(&run);
    // four objects well seen in the first view, largest first
    let map0 = &maps_before[&first.stem];
    let mut seen: Vec<_> =
        label_centres(map0).into_iter().filter(|&(_, _, d, area)| d >= 4 && area >= 300).collect();
    seen.sort_by_key(|v| std::cmp::Reverse(v.3));
    assert!(seen.len() >= 4, "only {} objects well seen in {}", seen.len(), first.stem);
    let [a, b, c, d] = [0, 1, 2, 3].map(|k| seen[k].0 as i32);
    let (a, b) = (a.min(b), a.max(b));
    // the lasso: the left half of object d's pixels' bounding box in the first view
    let [[x0, y0], [x1, _], [_, y1], _] = bounding_rectangle(map0, d);
    let xm = (x0 + x1) / 2;
    let lasso = [[x0, y0], [xm, y0], [xm, y1], [x0, y1]];
    let around = bounding_rectangle(map0, d);
    // the brush: a stroke across the middle of the pixels of a fifth object (one Gaussians carry,
    // not one only the label maps show) in the first view
    let e = seen[4..].iter().map(|v| v.0 as i32).find(|id| ids_before.contains(id)).expect("a fifth object");
    let [[cx0, cy0], [cx1, _], [_, cy1], _] = bounding_rectangle(map0, e);
    let stroke = [[cx0 as f64, (cy0 + cy1) as f64 / 2.0], [cx1 as f64, (cy0 + cy1) as f64 / 2.0]];

    // an opacity threshold just above the least opaque of a's and b's Gaussians (synth's opacities
    // take few values)
    let opacity = |i: usize| 1.0 / (1.0 + (-before.raw_opacities[i]).exp());
    let least = (0..ids_before.len())
        .filter(|&i| ids_before[i] == a || ids_before[i] == b)
        .map(opacity)
        .fold(f32::INFINITY, f32::min);
    let threshold = least + 1e-4;

    let server = serve(&run, &exports);
    let browser = Browser::launch(&paths, 1024, 640).expect("headless chromium starts");
    browser.goto(&format!("{}?canvas=native", server.url)).expect("page opens");
    let ready = browser.await_promise("viewer.whenReady(120000)").expect("ready");
    assert!(ready["error"].is_null(), "the page failed: {ready}");
    let script = EDIT_SCRIPT.replace(
        "arguments_",
        &json!([a, b, c, d, lasso, around, threshold, stroke, BRUSH_RADIUS_PX, e]).to_string(),
    );
    let steps = browser.await_promise(&script).expect("the edit script runs");
    println!("edits in the page: {steps}");
    for step in ["merge", "box", "lasso", "moved", "final", "saved"] {
        assert!(steps[step]["error"].is_null(), "{step}: {steps}");
    }
    let objects_after_merge: BTreeSet<i64> =
        steps["afterMerge"].as_array().expect("ids").iter().filter_map(Value::as_i64).collect();
    assert!(
        objects_after_merge.contains(&(a as i64)) && !objects_after_merge.contains(&(b as i64)),
        "{steps}"
    );
    let kinds = |step: &str| -> Vec<String> {
        steps[step]["operations"]
            .as_array()
            .expect("ops")
            .iter()
            .map(|o| o["op"].as_str().unwrap_or("").to_string())
            .collect()
    };
    assert_eq!(kinds("lasso"), ["merge", "split_box", "split_lasso"], "{steps}");
    assert_eq!(steps["renamed"], json!({ a.to_string(): "wrong" }));
    assert_eq!(steps["undone"], json!({}), "undo takes the rename back");
    assert_eq!(steps["redone"], json!({ a.to_string(): "wrong" }), "redo gives it again");
    assert_eq!(steps["names"], json!({ a.to_string(): "room" }));
    assert_eq!(steps["saved"]["dirty"], false, "{steps}");
    // the page opened again starts from the saved edits.json
    browser.goto(&server.url).expect("page opens again");
    let ready = browser.await_promise("viewer.whenReady(120000)").expect("ready again");
    assert!(ready["error"].is_null(), "the page failed: {ready}");
    assert_eq!(ready["edits"]["operations"], steps["saved"]["operations"], "the page starts from edits.json");
    assert_eq!(ready["names"], json!({ a.to_string(): "room" }));
    assert!(!ready["objects"].as_array().expect("ids").contains(&json!(b)), "{ready}");
    // exports: the selection's box as a crop (every object's Gaussians in it), and everything coloured by object
    let crop = browser
        .await_promise(&format!(
            "(async () => {{ viewer.select([{c}]); const box = viewer.boxAround([{c}]); \
             const done = await viewer.exportSelection('crop'); \
             const coloured = await viewer.exportSelection('coloured'); const count = viewer.manifest.objects[viewer.slotOfId.get({c})].count; \
             return {{ box, done, coloured, count }}; }})()"
        ))
        .expect("the exports");
    let centre: Vec<f64> = serde_json::from_value(crop["box"]["centre"].clone()).expect("centre");
    let half: Vec<f64> = serde_json::from_value(crop["box"]["half_size"].clone()).expect("half size");
    let in_crop =
        before.means.iter().filter(|p| (0..3).all(|k| (p[k] as f64 - centre[k]).abs() <= half[k])).count();
    assert_eq!(crop["done"]["count"], json!(in_crop), "{crop}");
    let cropped = splatseg_scene::ply::read_ply(Path::new(crop["done"]["path"].as_str().expect("path")))
        .expect("crop PLY");
    assert_eq!(cropped.len(), in_crop);
    let c_now = crop["count"].as_u64().expect("count") as usize;
    assert!(in_crop >= c_now && c_now > 0, "the crop holds at least the selected object's {c_now}: {crop}");
    assert_eq!(crop["coloured"]["count"], json!(before.len()), "{crop}");
    if std::env::var_os("SPLATSEG_UPDATE_SCREENSHOT").is_some() {
        browser
            .execute("viewer.setPalette(true); viewer.select([arguments[0]]);", json!([c]))
            .expect("state");
        browser.await_promise("viewer.whenDrawn()").expect("drawn");
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs").join("viewer-edit.png");
        std::fs::write(&path, browser.screenshot_png().expect("screenshot")).expect("write the screenshot");
        println!("wrote {}", path.display());
    }
    assert!(state(&browser)["error"].is_null());
    drop(browser);
    drop(server);

    // edits.json: the four operations, made on this run
    let edits = splatseg_edit::read_edits(&run.join("edits.json")).expect("the saved edits.json");
    let saved_kinds: Vec<&str> = edits.operations.iter().map(|o| o.kind()).collect();
    assert_eq!(saved_kinds, ["merge", "split_box", "split_lasso", "move", "rename"]);
    assert_eq!(edits.version, 2, "a move is version 2");
    let splatseg_edit::Operation::SplitBox { region, .. } = &edits.operations[1] else { unreachable!() };
    let in_box = |p: &[f32; 3]| (0..3).all(|k| (p[k] as f64 - region.centre[k]).abs() <= region.half_size[k]);
    let boxed: BTreeSet<usize> =
        (0..ids_before.len()).filter(|&i| ids_before[i] == c && in_box(&before.means[i])).collect();
    let c_count = ids_before.iter().filter(|&&id| id == c).count();
    assert!(
        !boxed.is_empty() && boxed.len() < c_count,
        "the box holds {} of object {c}'s {c_count} Gaussians",
        boxed.len()
    );

    // front-most only: an `assign` of rows of object d to a new id (undone)
    assert_eq!(kinds("front"), ["merge", "split_box", "assign"], "{steps}");
    let front = &steps["front"]["operations"][2];
    let d_count = ids_before.iter().filter(|&&id| id == d).count();
    let mut front_rows = 0;
    for range in front["ranges"].as_array().expect("ranges") {
        let (start, end) =
            (range[0].as_u64().expect("start") as usize, range[1].as_u64().expect("end") as usize);
        for (row, &was) in ids_before.iter().enumerate().take(end).skip(start) {
            assert_eq!(was, d, "row {row} of the front-most lasso: {front}");
            front_rows += 1;
        }
    }
    println!("front-most lasso: {front_rows} of object {d}'s {d_count} Gaussians");
    assert!(front_rows > 0 && front_rows < d_count, "{front_rows} front-most of {d_count}");
    assert_eq!(steps["lasso"]["undone"], 0, "a new edit clears what was undone");
    // by opacity: exactly the merged object's Gaussians under the threshold, to none (undone)
    assert_eq!(kinds("filtered"), ["merge", "split_box", "assign"], "{steps}");
    let filtered = &steps["filtered"]["operations"][2];
    assert_eq!(filtered["id"], -1);
    let mut rows = BTreeSet::new();
    for range in filtered["ranges"].as_array().expect("ranges") {
        rows.extend(range[0].as_u64().expect("start") as usize..range[1].as_u64().expect("end") as usize);
    }
    let expected: BTreeSet<usize> = (0..ids_before.len())
        .filter(|&i| (ids_before[i] == a || ids_before[i] == b) && opacity(i) < threshold)
        .collect();
    assert!(!expected.is_empty());
    assert_eq!(rows, expected, "the rows the opacity filter moved");

    splatseg(&["apply", utf8(&run)]);
    let after = splatseg_scene::ply::read_ply(&run.join("gaussians.ply")).expect("the applied PLY");
    let ids_after = after.object_ids.expect("object ids");
    // merge: a and b are a in the PLY
    for i in 0..ids_before.len() {
        if ids_before[i] == a || ids_before[i] == b {
            assert_eq!(ids_after[i], a, "row {i} was {}", ids_before[i]);
        }
    }
    // the box: exactly its Gaussians of c took one new id
    let new_box: BTreeSet<i32> = boxed.iter().map(|&i| ids_after[i]).collect();
    assert_eq!(new_box.len(), 1, "{new_box:?}");
    let box_id = *new_box.iter().next().expect("an id");
    assert!(!ids_before.contains(&box_id));
    let rows_box: BTreeSet<usize> = (0..ids_after.len()).filter(|&i| ids_after[i] == box_id).collect();
    assert_eq!(rows_box, boxed, "the box's new object is exactly the Gaussians of {c} in the box");
    // the lasso: object d's Gaussians whose centres project inside the rectangle, in the first view
    let camera = loaded.camera(first);
    let cam_from_world = first.world_from_cam.inverse();
    let projected = |p: &[f32; 3]| {
        camera.project(cam_from_world.transform_point(glam::DVec3::new(
            p[0] as f64,
            p[1] as f64,
            p[2] as f64,
        )))
    };
    let inside = |p: &[f32; 3], margin: f64| {
        projected(p).is_some_and(|uv| {
            uv.x > x0 as f64 + margin
                && uv.x < xm as f64 - margin
                && uv.y > y0 as f64 + margin
                && uv.y < y1 as f64 - margin
        })
    };
    let lasso_ids: BTreeSet<i32> = (0..ids_after.len())
        .filter(|&i| ids_before[i] == d && ids_after[i] != d)
        .map(|i| ids_after[i])
        .collect();
    assert_eq!(lasso_ids.len(), 1, "the lasso made one new object: {lasso_ids:?}");
    let lasso_id = *lasso_ids.iter().next().expect("an id");
    let mut moved = 0;
    for i in 0..ids_before.len() {
        let p = &before.means[i];
        if ids_after[i] == lasso_id {
            assert_eq!(ids_before[i], d, "row {i} of the lasso's object was not object {d}'s");
            assert!(inside(p, -0.01), "row {i} projects outside the lasso: {:?}", projected(p));
            moved += 1;
        } else if ids_before[i] == d && inside(p, 0.01) {
            panic!("row {i} of object {d} projects inside the lasso but was not moved: {:?}", projected(p));
        }
    }
    assert!(moved > 0 && moved < ids_before.iter().filter(|&&id| id == d).count());
    // the brush: e's Gaussians whose centres project within the brush's radius of the stroke in
    // the first view (as the page drew it: the saved stroke), then grown twice and shrunk once
    // within e, moved to a
    let splatseg_edit::Operation::Move { select, to } = &edits.operations[3] else { panic!("{edits:?}") };
    assert_eq!(*to, splatseg_edit::MoveTarget::Id(a));
    assert_eq!(select.objects, Some(vec![e]));
    let steps_taken: Vec<&str> = select
        .neighbours
        .iter()
        .map(|n| if matches!(n, splatseg_edit::NeighbourStep::Grow(_)) { "grow" } else { "shrink" })
        .collect();
    assert_eq!(steps_taken, ["grow", "grow", "shrink"]);
    let [splatseg_edit::SelectPart::Brush { stroke_px, radius_px, .. }] = &select.parts[..] else {
        panic!("one brush stroke: {select:?}")
    };
    assert_eq!(*radius_px, BRUSH_RADIUS_PX);
    let from_stroke = |p: &[f32; 3]| {
        projected(p).map_or(f64::INFINITY, |uv| {
            stroke_px
                .windows(2)
                .map(|w| {
                    let (a, b) = (glam::DVec2::from(w[0]), glam::DVec2::from(w[1]));
                    let t = ((uv - a).dot(b - a) / (b - a).length_squared().max(1e-12)).clamp(0.0, 1.0);
                    uv.distance(a + t * (b - a))
                })
                .fold(f64::INFINITY, f64::min)
        })
    };
    let e_rows: Vec<usize> = (0..ids_before.len()).filter(|&i| ids_before[i] == e).collect();
    let within = |r: f64| e_rows.iter().filter(|&&i| from_stroke(&before.means[i]) <= r).count();
    let brushed = steps["brushed"]["count"].as_u64().expect("count") as usize;
    println!(
        "brush: {brushed} Gaussians ({} to {} by the test's projection), grown {} and {}, shrunk {}; {}",
        within(BRUSH_RADIUS_PX - 0.01),
        within(BRUSH_RADIUS_PX + 0.01),
        steps["key1"],
        steps["key2"],
        steps["key3"],
        steps["selectionStatus"]
    );
    assert!(
        brushed > 0 && within(BRUSH_RADIUS_PX - 0.01) <= brushed && brushed <= within(BRUSH_RADIUS_PX + 0.01)
    );
    let counts = ["key1", "key2", "key3"].map(|k| steps[k].as_u64().expect("count") as usize);
    assert!(
        brushed < counts[0] && counts[0] < counts[1] && counts[2] < counts[1] && counts[2] > 0,
        "{steps}"
    );
    let moved_to_a: Vec<usize> = e_rows.iter().copied().filter(|&i| ids_after[i] == a).collect();
    assert_eq!(moved_to_a.len(), counts[2], "apply moved exactly the Gaussians the page's selection held");
    assert!(e_rows.iter().any(|&i| ids_after[i] == e), "the rest of e stays e");
    // every view's label map: b is gone, its pixels are a's; the new objects show
    let maps_after = label_maps(&run);
    let (mut b_pixels, mut b_to_a, mut shown) = (0usize, 0usize, BTreeSet::new());
    for (stem, map) in &maps_after {
        let was = &maps_before[stem];
        assert!(!map.data.contains(&(b as u32)), "view {stem} still shows object {b}");
        for (i, &id) in was.data.iter().enumerate() {
            if id == b as u32 {
                b_pixels += 1;
                b_to_a += usize::from(map.data[i] == a as u32);
            }
        }
        shown.extend(map.data.iter().copied());
    }
    assert!(b_pixels > 0 && b_to_a * 100 >= b_pixels * 95, "{b_to_a} of {b_pixels} pixels of {b} became {a}");
    assert!(
        shown.contains(&(box_id as u32)) && shown.contains(&(lasso_id as u32)),
        "the new objects show in the maps"
    );
    // the applied outputs without their edits.json: the page shows the run's own objects (edits
    // start from them), not the applied PLY's ids
    std::fs::rename(run.join("edits.json"), tmp.path().join("edits.json")).expect("move edits.json away");
    let server = serve(&run, &exports);
    let browser = Browser::launch(&paths, 1024, 640).expect("headless chromium starts");
    browser.goto(&server.url).expect("page opens");
    let ready = browser.await_promise("viewer.whenReady(120000)").expect("ready");
    assert!(ready["error"].is_null(), "the page failed: {ready}");
    assert_eq!(ready["edits"]["operations"], json!([]));
    let shown: BTreeSet<i64> =
        ready["objects"].as_array().expect("ids").iter().filter_map(Value::as_i64).collect();
    let run_own: BTreeSet<i64> = ids_before.iter().map(|&id| id as i64).collect();
    assert_eq!(shown, run_own, "the run's own objects, {b} among them");
    drop(browser);
    drop(server);

    let objects =
        String::from_utf8(splatseg(&["objects", utf8(&run.join("gaussians.ply"))]).stdout).expect("utf-8");
    assert!(
        objects.lines().any(|l| l.starts_with(&format!("| {a} |")) && l.trim_end().ends_with("| room |")),
        "{objects}"
    );
}

/// Every view's label map of a run, by stem.
fn label_maps(run: &Path) -> std::collections::BTreeMap<String, splatseg_scene::Plane<u32>> {
    std::fs::read_dir(run.join("masks"))
        .expect("masks")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "png"))
        .map(|p| {
            let stem = p.file_stem().expect("stem").to_string_lossy().into_owned();
            (stem, splatseg_scene::labels::read_label_png(&p).expect("label map"))
        })
        .collect()
}

/// The corners of the bounding rectangle of `id`'s pixels in `map` (pixel corners: `[x0, y0]`
/// to `[x1, y1]` exclusive).
fn bounding_rectangle(map: &splatseg_scene::Plane<u32>, id: i32) -> [[usize; 2]; 4] {
    let (mut x0, mut y0, mut x1, mut y1) = (usize::MAX, usize::MAX, 0, 0);
    for (i, &v) in map.data.iter().enumerate() {
        if v as i32 == id {
            let (x, y) = (i % map.width, i / map.width);
            (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x + 1), y1.max(y + 1));
        }
    }
    [[x0, y0], [x1, y0], [x1, y1], [x0, y1]]
}
