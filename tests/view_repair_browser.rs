//! Issue 60's "Done when", through the viewer: on the scene of `tests/apply_repairs.rs`
//! (`blind_contact` seed 102, where `run` fuses a touching pair and splits a checkered box into
//! three ids), a person repairs both with the page's controls in three actions — (1) the pieces
//! picked and merged; (2) the pair split by a lasso drawn with the pointer around the blue box in
//! the view where it stands clear of its partner; Save, `splatseg apply`, and a second look at
//! the overlays: (3) in the view where part of the blue box still shows the pair's colour, brush
//! strokes (front-most only, among the pair's Gaussians) over those pixels, the selection moved
//! to the blue box — saves, and `splatseg apply` raises the run's mIoU by at least 95 % of what
//! the objects lost (measured: 0.7582 -> 0.8512, 98 %; after the first two actions 94 %), every
//! view agreeing (22 (view, object) pairs). An action is one edit made with the page's controls
//! (one operation of `edits.json`, what Undo takes back); the test counts them and asks at most
//! six. ≈ 40 s.
//!
//! The person's eye is played by the ground truth: the lasso is the convex hull of the blue box's
//! pixels in its ground-truth map of the view where the fewest of its partner's Gaussians
//! project inside that hull; the strokes cover, row by row, the blue box's pixels that the
//! applied label maps give the pair, in the view with most of them.

use crate::apply_repairs::{check_repair, ok, repair_scene, s, PAIR};
use crate::chromium::chromium_or_skip;
use crate::view_browser::serve;
use serde_json::json;
use splatseg_view::browser::Browser;

/// At most this many actions (issue 60).
const MAX_ACTIONS: usize = 6;
/// The share of the objects' loss the repair through the viewer must give back (measured: 0.98).
const RECOVERED_SHARE: f64 = 0.95;

/// The page's script: the repair through the panel's buttons and the lasso's pointer events.
const REPAIR_SCRIPT: &str = r#"
(async () => {
  const [pieces, fused, stem, hull] = ARGS;
  const click = (id) => document.getElementById(id).click();
  const settle = async () => { await viewer.editor.busy; return viewer.editor.state(); };
  const until = async (f) => { for (let k = 0; k < 400 && !f(); k++) await new Promise((res) => setTimeout(res, 25)); };
  const result = { actions: 0 };
  // 1. the checkered box's pieces, picked, merged
  viewer.select(pieces);
  click('edit-merge');
  result.actions++;
  result.merge = await settle();
  // 2. the pair split by a lasso around the blue box, in the view where it stands clear
  viewer.setCamera(viewer.manifest.cameras.findIndex((c) => c.name === stem));
  await viewer.whenDrawn();
  const before = new Set(viewer.state().objects);
  viewer.select([fused]);
  click('edit-lasso');
  const svg = document.getElementById('lasso');
  const r = viewer.canvas.getBoundingClientRect();
  const at = ([x, y]) => ({ clientX: r.left + x * r.width / viewer.canvas.width, clientY: r.top + y * r.height / viewer.canvas.height, pointerId: 3, bubbles: true });
  svg.dispatchEvent(new PointerEvent('pointerdown', at(hull[0])));
  for (const p of hull.slice(1)) svg.dispatchEvent(new PointerEvent('pointermove', at(p)));
  svg.dispatchEvent(new PointerEvent('pointerup', at(hull[hull.length - 1])));
  await until(() => viewer.editor.ops.length === 2 || viewer.editor.lastError);
  result.actions++;
  result.lasso = await settle();
  result.blue = viewer.state().objects.filter((id) => !before.has(id));
  click('edit-save');
  await until(() => !viewer.editor.dirty);
  result.saved = viewer.editor.state();
  return result;
})()
"#;

/// The second look, after `apply`: in the view whose overlay still shows part of the blue box in
/// the pair's colour, brush strokes over those pixels (front-most only, among the pair's
/// Gaussians) and the selection moved to the blue box: one action.
const TOUCH_UP_SCRIPT: &str = r#"
(async () => {
  const [fused, blue, stem, strokes, radius] = ARGS;
  const click = (id) => document.getElementById(id).click();
  const settle = async () => { await viewer.editor.busy; return viewer.editor.state(); };
  const until = async (f) => { for (let k = 0; k < 400 && !f(); k++) await new Promise((res) => setTimeout(res, 25)); };
  const result = { actions: 0, start: viewer.editor.state() };
  viewer.setCamera(viewer.manifest.cameras.findIndex((c) => c.name === stem));
  await viewer.whenDrawn();
  viewer.select([fused]);
  click('edit-brush');
  document.getElementById('brush-radius').value = String(radius);
  document.getElementById('lasso-front').checked = true;
  const svg = document.getElementById('lasso');
  const r = viewer.canvas.getBoundingClientRect();
  const at = ([x, y]) => ({ clientX: r.left + x * r.width / viewer.canvas.width, clientY: r.top + y * r.height / viewer.canvas.height, pointerId: 5, bubbles: true });
  for (const stroke of strokes) {
    const parts = viewer.editor.selection?.parts.length ?? 0;
    svg.dispatchEvent(new PointerEvent('pointerdown', at(stroke[0])));
    for (const p of stroke.slice(1)) svg.dispatchEvent(new PointerEvent('pointermove', at(p)));
    svg.dispatchEvent(new PointerEvent('pointerup', at(stroke[stroke.length - 1])));
    await until(() => (viewer.editor.selection?.parts.length ?? 0) > parts || document.getElementById('edit-status').textContent.includes('no Gaussian'));
  }
  result.selection = viewer.editor.selectionState();
  click('edit-brush');
  document.getElementById('move-to').value = String(blue);
  const ops = viewer.editor.ops.length;
  click('sel-move');
  await until(() => viewer.editor.ops.length > ops || viewer.editor.lastError);
  result.actions++;
  result.moved = await settle();
  click('edit-save');
  await until(() => !viewer.editor.dirty);
  result.saved = viewer.editor.state();
  return result;
})()
"#;

/// The convex hull of the pixels (their corners) of `gt` in `map`, counter-clockwise.
fn pixel_hull(map: &splatseg_scene::Plane<u32>, gt: u32) -> Vec<[f64; 2]> {
    let mut points: Vec<[i64; 2]> = Vec::new();
    for (i, &v) in map.data.iter().enumerate() {
        if v == gt {
            let (x, y) = ((i % map.width) as i64, (i / map.width) as i64);
            points.extend([[x, y], [x + 1, y], [x, y + 1], [x + 1, y + 1]]);
        }
    }
    points.sort_unstable();
    points.dedup();
    let cross =
        |o: [i64; 2], a: [i64; 2], b: [i64; 2]| (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]);
    let mut hull: Vec<[i64; 2]> = Vec::new();
    for pass in 0..2 {
        let start = hull.len();
        let ordered: Box<dyn Iterator<Item = &[i64; 2]>> =
            if pass == 0 { Box::new(points.iter()) } else { Box::new(points.iter().rev()) };
        for &p in ordered {
            while hull.len() >= start + 2 && cross(hull[hull.len() - 2], hull[hull.len() - 1], p) <= 0 {
                hull.pop();
            }
            hull.push(p);
        }
        hull.pop();
    }
    hull.into_iter().map(|[x, y]| [x as f64, y as f64]).collect()
}

/// Whether `p` lies inside `polygon` (even-odd rule, as `splatseg apply` tests a lasso).
fn inside(p: glam::DVec2, polygon: &[[f64; 2]]) -> bool {
    let mut inside = false;
    let mut j = polygon.len() - 1;
    for i in 0..polygon.len() {
        let ([xi, yi], [xj, yj]) = (polygon[i], polygon[j]);
        if (yi > p.y) != (yj > p.y) && p.x < (xj - xi) * (p.y - yi) / (yj - yi) + xi {
            inside = !inside;
        }
        j = i;
    }
    inside
}

#[test]
fn a_person_repairs_the_fused_pair_and_the_split_object_in_the_viewer_within_six_actions() {
    let Some(paths) = chromium_or_skip("the browser repair test") else { return };
    let repair = repair_scene();
    let (scene_dir, out) = (&repair.scene, &repair.out);
    let scene = splatseg_scene::load_scene(scene_dir, &Default::default()).expect("the scene");
    let ply = splatseg_scene::ply::read_ply(&out.join("gaussians.ply")).expect("the run's PLY");
    let ids = ply.object_ids.clone().expect("ids");
    let truth = splatseg_eval::read_gaussian_ids_npy(&scene_dir.join("gt/gaussian_ids.npy")).expect("gt ids");
    // the view where the hull of the blue box's pixels holds most of its Gaussians of the fused
    // id and fewest of its partner's
    let mut best: Option<(i64, String, Vec<[f64; 2]>)> = None;
    for (stem, gt_map, _) in &repair.run_views {
        let Some(view) = scene.views.iter().find(|v| &v.stem == stem) else { continue };
        let hull = pixel_hull(gt_map, PAIR.1);
        if hull.len() < 3 {
            continue;
        }
        let (camera, cam_from_world) = (scene.camera(view), view.world_from_cam.inverse());
        let mut score = 0i64;
        for (i, m) in ply.means.iter().enumerate().filter(|&(i, _)| ids[i] == repair.fused) {
            let p = glam::DVec3::new(m[0] as f64, m[1] as f64, m[2] as f64);
            if camera.project(cam_from_world.transform_point(p)).is_some_and(|uv| inside(uv, &hull)) {
                score += if truth[i] == PAIR.1 as i64 { 1 } else { -1 };
            }
        }
        if best.as_ref().is_none_or(|b| score > b.0) {
            best = Some((score, stem.clone(), hull));
        }
    }
    let (score, stem, hull) = best.expect("a view shows the blue box");
    println!("lasso in view {stem}: {} vertices, score {score}", hull.len());

    let exports = repair._tmp.path().join("exports");
    let server = serve(out, &exports);
    let browser = Browser::launch(&paths, 1024, 640).expect("headless chromium starts");
    browser.goto(&format!("{}?canvas=native", server.url)).expect("page opens");
    let ready = browser.await_promise("viewer.whenReady(120000)").expect("ready");
    assert!(ready["error"].is_null(), "the page failed: {ready}");
    let script = REPAIR_SCRIPT.replace("ARGS", &json!([repair.split, repair.fused, stem, hull]).to_string());
    let result = browser.await_promise(&script).expect("the repair script runs");
    println!("the repair in the page: {result}");
    for step in ["merge", "lasso", "saved"] {
        assert!(result[step]["error"].is_null(), "{step}: {result}");
    }
    assert_eq!(result["saved"]["dirty"], false, "{result}");
    let actions = result["actions"].as_u64().expect("actions") as usize;
    let operations = result["saved"]["operations"].as_array().expect("operations").len();
    assert_eq!(actions, operations, "one operation per action: {result}");
    assert!(actions <= MAX_ACTIONS, "{actions} actions");
    let blue = result["blue"].as_array().expect("new ids");
    assert_eq!(blue.len(), 1, "the lasso made one new object: {result}");
    let blue_id = blue[0].as_i64().expect("id") as i32;
    drop(browser);
    drop(server);

    ok(&["apply", s(out)]);
    let merged = *repair.split.iter().min().expect("pieces") as i32;
    let after_two = crate::apply_repairs::views(scene_dir, out);
    // the person looks at the overlays again: the view where most of the blue box's pixels still
    // show the pair's id, those pixels painted over in row strokes
    let wrong_in = |(_, gt, pred): &(String, splatseg_scene::Plane<u32>, splatseg_scene::Plane<u32>)| {
        gt.data.iter().zip(&pred.data).filter(|&(&t, &p)| t == PAIR.1 && p == repair.fused as u32).count()
    };
    let worst =
        after_two.iter().max_by_key(|v| (wrong_in(v), std::cmp::Reverse(v.0.clone()))).expect("views");
    let (stem, gt_map, pred_map) = worst;
    let mut strokes: Vec<[[f64; 2]; 2]> = Vec::new();
    for y in 0..gt_map.height {
        let wrong = |x: usize| {
            gt_map.data[y * gt_map.width + x] == PAIR.1
                && pred_map.data[y * gt_map.width + x] == repair.fused as u32
        };
        let mut x = 0;
        while x < gt_map.width {
            if !wrong(x) {
                x += 1;
                continue;
            }
            let start = x;
            while x < gt_map.width && wrong(x) {
                x += 1;
            }
            strokes.push([[start as f64 + 0.5, y as f64 + 0.5], [x as f64 - 0.5, y as f64 + 0.5]]);
        }
    }
    println!(
        "after two actions: {} px of the blue box show the pair's id in {stem}; {} strokes",
        wrong_in(worst),
        strokes.len()
    );
    let server = serve(out, &exports);
    let browser = Browser::launch(&paths, 1024, 640).expect("headless chromium starts");
    browser.goto(&format!("{}?canvas=native", server.url)).expect("page opens");
    let ready = browser.await_promise("viewer.whenReady(120000)").expect("ready");
    assert!(ready["error"].is_null(), "the page failed: {ready}");
    let script =
        TOUCH_UP_SCRIPT.replace("ARGS", &json!([repair.fused, blue_id, stem, strokes, 0.75]).to_string());
    let touch_up = browser.await_promise(&script).expect("the touch-up script runs");
    println!("the touch-up in the page: {}", touch_up["selection"]["count"]);
    for step in ["moved", "saved"] {
        assert!(touch_up[step]["error"].is_null(), "{step}: {touch_up}");
    }
    let actions = actions + touch_up["actions"].as_u64().expect("actions") as usize;
    let operations = touch_up["saved"]["operations"].as_array().expect("operations").len();
    assert_eq!(actions, operations, "one operation per action: {touch_up}");
    assert!(actions <= MAX_ACTIONS, "{actions} actions");
    drop(browser);
    drop(server);
    ok(&["apply", s(out)]);
    let (gain, lost) = check_repair(&repair, merged, blue_id, RECOVERED_SHARE);
    println!("{actions} actions in the viewer gave back {:.0} % of the loss", 100.0 * gain / lost);
}
