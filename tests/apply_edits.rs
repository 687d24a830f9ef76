//! `splatseg apply OUT` (issue 60): a run's edits rewrite its outputs through the production
//! path. On a small synthetic scene: a merge leaves one id where there were two in every view's
//! label map and in gaussians.ply; a box split gives the Gaussians inside a new id in the PLY and
//! in the label maps; applying twice gives the same bytes; every bad edit exits non-zero naming
//! the file and changes nothing.

use splatseg_edit::edits::{write_edits, Box3, Edits, Operation, EDITS_VERSION};
use splatseg_scene::Plane;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn splatseg(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_splatseg")).args(args).env_remove("RUST_LOG").output().expect("spawn")
}

fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

/// A small synthetic scene and `run`'s outputs on it: (tmp, out).
fn run_scene() -> (tempfile::TempDir, PathBuf) {
    let tmp = tempfile::tempdir().expect("temp dir");
    let (scene, out) = (tmp.path().join("scene"), tmp.path().join("out"));
    let synth = splatseg(&["synth", "--out", s(&scene), "--views", "4", "--size", "160x120", "--seed", "2"]);
    assert!(synth.status.success(), "synth: {}", String::from_utf8_lossy(&synth.stderr));
    let run = splatseg(&[
        "-q",
        "run",
        s(&scene),
        "--masks",
        s(&scene.join("sam")),
        "--features",
        s(&scene.join("features")),
        "--out",
        s(&out),
    ]);
    assert!(run.status.success(), "run: {}", String::from_utf8_lossy(&run.stderr));
    (tmp, out)
}

fn ids(out: &Path) -> Vec<i32> {
    let g = splatseg_scene::ply::read_ply_rows(&out.join("gaussians.ply")).expect("PLY").gaussians;
    g.object_ids.expect("object ids")
}

fn maps(out: &Path) -> BTreeMap<String, Plane<u32>> {
    let mut maps = BTreeMap::new();
    for entry in std::fs::read_dir(out.join("masks")).expect("masks").flatten() {
        let path = entry.path();
        let stem = path.file_stem().expect("stem").to_string_lossy().to_string();
        maps.insert(stem, splatseg_scene::labels::read_label_png(&path).expect("label map"));
    }
    maps
}

/// Every output file outside `cache/` with its bytes (the lock file and the edits, an input, excepted).
fn outputs(out: &Path) -> BTreeMap<String, Vec<u8>> {
    let skip =
        |rel: &str| rel.starts_with("cache/") || rel.ends_with(".splatseg.lock") || rel == "edits.json";
    let mut files = BTreeMap::new();
    let mut stack = vec![out.to_path_buf()];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).expect("list").flatten() {
            let path = entry.path();
            let rel = path.strip_prefix(out).expect("inside").to_string_lossy().to_string();
            if path.is_dir() {
                stack.push(path);
            } else if !skip(&rel) {
                files.insert(rel, std::fs::read(&path).expect("read"));
            }
        }
    }
    files
}

fn edits(out: &Path, operations: Vec<Operation>) -> Edits {
    let inputs = splatseg_pipeline::apply::edit_inputs(out).expect("the run's identity");
    Edits { version: EDITS_VERSION, inputs, operations }
}

fn apply(out: &Path, edits: &Edits) -> Output {
    write_edits(&out.join("edits.json"), edits).expect("write edits");
    splatseg(&["apply", s(out)])
}

/// The two objects owning the most Gaussians, largest first.
fn two_largest(ids: &[i32]) -> (i32, i32) {
    let mut counts: BTreeMap<i32, usize> = BTreeMap::new();
    for &id in ids.iter().filter(|&&id| id > 0) {
        *counts.entry(id).or_default() += 1;
    }
    let mut by_size: Vec<(usize, i32)> = counts.into_iter().map(|(id, n)| (n, id)).collect();
    by_size.sort_unstable_by(|a, b| b.cmp(a));
    (by_size[0].1, by_size[1].1)
}

#[test]
fn a_merge_shows_one_id_in_every_view_and_the_ply_and_applying_again_gives_the_same_bytes() {
    let (_tmp, out) = run_scene();
    let (before_ids, before_maps) = (ids(&out), maps(&out));
    let (a, b) = two_largest(&before_ids);
    let (into, gone) = (a.min(b), a.max(b));
    assert!(
        before_maps.values().any(|m| m.data.contains(&(gone as u32))),
        "object {gone} shows in some view"
    );
    let e = edits(
        &out,
        vec![
            Operation::Merge { ids: vec![a, b], into: None },
            Operation::Rename { id: into, name: "the two largest".into() },
        ],
    );
    let done = apply(&out, &e);
    assert!(done.status.success(), "apply: {}", String::from_utf8_lossy(&done.stderr));
    let after_ids = ids(&out);
    for (i, (&was, &now)) in before_ids.iter().zip(&after_ids).enumerate() {
        let want = if was == gone { into } else { was };
        assert_eq!(now, want, "Gaussian {i}: was {was}");
    }
    let after_maps = maps(&out);
    assert_eq!(after_maps.keys().collect::<Vec<_>>(), before_maps.keys().collect::<Vec<_>>());
    for (stem, before) in &before_maps {
        let after = &after_maps[stem];
        assert!(!after.data.contains(&(gone as u32)), "view {stem} still shows {gone}");
        for (p, (&was, &now)) in before.data.iter().zip(&after.data).enumerate() {
            if was == a as u32 || was == b as u32 {
                assert_eq!(now, into as u32, "view {stem} pixel {p}");
            } else {
                assert!(now == was || now == into as u32, "view {stem} pixel {p}: {was} -> {now}");
            }
        }
    }
    let objects = std::fs::read_to_string(out.join("objects.json")).expect("objects.json");
    assert!(objects.contains("\"name\": \"the two largest\""), "{objects}");
    assert!(std::fs::read_to_string(out.join("report.md"))
        .expect("report")
        .contains("Edits (splatseg apply)"));
    // `objects` shows the name, `extract --query` takes it.
    let ply = out.join("gaussians.ply");
    let listed = splatseg(&["objects", s(&ply)]);
    assert!(String::from_utf8_lossy(&listed.stdout).contains("| the two largest |"), "{listed:?}");
    let one = out.join("named.ply");
    let extracted = splatseg(&["extract", s(&ply), "--query", "the two largest", "--out", s(&one)]);
    assert!(extracted.status.success(), "extract: {}", String::from_utf8_lossy(&extracted.stderr));
    let count = splatseg_scene::ply::read_ply(&one).expect("extracted").len();
    assert_eq!(count, after_ids.iter().filter(|&&id| id == into).count());
    std::fs::remove_file(&one).expect("remove");
    // Applied again, from the run's own result: the same bytes.
    let first = outputs(&out);
    let again = apply(&out, &e);
    assert!(again.status.success(), "apply again: {}", String::from_utf8_lossy(&again.stderr));
    assert!(first == outputs(&out), "a second apply changed the outputs");
    assert!(!out.join(".staging").exists());
}

#[test]
fn a_box_split_gives_the_gaussians_inside_a_new_id_in_the_ply_and_the_label_maps() {
    let (_tmp, out) = run_scene();
    let (before_ids, before_maps) = (ids(&out), maps(&out));
    let (object, _) = two_largest(&before_ids);
    let means = splatseg_scene::ply::read_ply_rows(&out.join("gaussians.ply")).expect("PLY").gaussians.means;
    let mine: Vec<[f32; 3]> =
        before_ids.iter().zip(&means).filter(|(&id, _)| id == object).map(|(_, m)| *m).collect();
    // A box around the object's Gaussians on the low-x side of their median.
    let mut xs: Vec<f32> = mine.iter().map(|m| m[0]).collect();
    xs.sort_by(f32::total_cmp);
    let median = xs[xs.len() / 2] as f64;
    let lo = |k: usize| mine.iter().map(|m| m[k]).fold(f32::INFINITY, f32::min) as f64 - 0.01;
    let hi = |k: usize| mine.iter().map(|m| m[k]).fold(f32::NEG_INFINITY, f32::max) as f64 + 0.01;
    let (min, max) = ([lo(0), lo(1), lo(2)], [median, hi(1), hi(2)]);
    let region = Box3 {
        centre: [0, 1, 2].map(|k| (min[k] + max[k]) / 2.0),
        half_size: [0, 1, 2].map(|k| (max[k] - min[k]) / 2.0),
        rotation: None,
    };
    let new_id = before_ids.iter().copied().max().expect("ids") + 1;
    let done = apply(&out, &edits(&out, vec![Operation::SplitBox { object, region, new_id: None }]));
    assert!(done.status.success(), "apply: {}", String::from_utf8_lossy(&done.stderr));
    let after_ids = ids(&out);
    let inside = |m: &[f32; 3]| (0..3).all(|k| (m[k] as f64) >= min[k] && (m[k] as f64) <= max[k]);
    let mut moved = 0;
    for (i, ((&was, &now), m)) in before_ids.iter().zip(&after_ids).zip(&means).enumerate() {
        let want = if was == object && inside(m) { new_id } else { was };
        assert_eq!(now, want, "Gaussian {i}");
        moved += usize::from(now != was);
    }
    assert!(moved * 4 > mine.len() && moved * 4 < 3 * mine.len(), "{moved} of {} moved", mine.len());
    let after_maps = maps(&out);
    // Where the object's votes were split in two, a third object may now win a pixel: rarely.
    let (mut new_px, mut new_px_of_object, mut other_changes) = (0usize, 0usize, 0usize);
    for (stem, before) in &before_maps {
        for (&was, &now) in before.data.iter().zip(&after_maps[stem].data) {
            if now == new_id as u32 {
                new_px += 1;
                new_px_of_object += usize::from(was == object as u32);
            } else {
                other_changes += usize::from(now != was);
            }
        }
    }
    assert!(new_px > 0, "the new object shows in no view");
    assert!(other_changes * 50 <= new_px, "{other_changes} pixels changed to another object");
    assert!(new_px_of_object * 10 >= new_px * 9, "{new_px_of_object} of {new_px} pixels were the object's");
    assert!(after_maps.values().any(|m| m.data.contains(&(object as u32))), "the rest of the object stays");
}

#[test]
fn bad_edits_exit_non_zero_naming_the_file_and_change_nothing() {
    let (_tmp, out) = run_scene();
    let ids_now = ids(&out);
    let n = ids_now.len() as u64;
    let absent = ids_now.iter().copied().max().expect("ids") + 5;
    let good = edits(&out, vec![]);
    let path = out.join("edits.json");
    let mut cases: Vec<(String, &str)> = Vec::new();
    let with = |ops: Vec<Operation>| {
        serde_json::to_string(&Edits { operations: ops, ..good.clone() }).expect("json")
    };
    cases.push((with(vec![Operation::Merge { ids: vec![1, absent], into: None }]), "no object has id"));
    cases.push((
        with(vec![Operation::Assign { ranges: vec![[n - 1, n + 3]], id: 1 }]),
        "is not a non-empty range",
    ));
    cases.push(("{\"version\": 1, \"operations\": [".to_string(), "not a valid edits file"));
    let future = serde_json::to_string(&Edits { version: EDITS_VERSION + 1, ..good.clone() }).expect("json");
    cases.push((future, "written by a later splatseg"));
    let mut other_ply = good.clone();
    other_ply.inputs.ply_digest = "0123456789abcdef".into();
    cases.push((
        serde_json::to_string(&other_ply).expect("json"),
        "made on a PLY with digest 0123456789abcdef",
    ));
    let before = outputs(&out);
    for (text, expected) in &cases {
        std::fs::write(&path, text).expect("write edits");
        let failed = splatseg(&["apply", s(&out)]);
        let stderr = String::from_utf8_lossy(&failed.stderr);
        assert!(!failed.status.success(), "{expected}: apply succeeded");
        assert!(stderr.contains(expected) && stderr.contains(s(&path)), "{expected}: {stderr}");
        assert!(before == outputs(&out), "{expected}: the outputs changed");
    }
    std::fs::remove_file(&path).expect("remove");
    let missing = splatseg(&["apply", s(&out)]);
    assert!(!missing.status.success() && String::from_utf8_lossy(&missing.stderr).contains("edits.json"));
}

#[test]
fn a_lasso_split_moves_the_gaussians_whose_centres_project_inside_it() {
    let (tmp, out) = run_scene();
    let before_ids = ids(&out);
    let (object, _) = two_largest(&before_ids);
    let scene = splatseg_scene::load_scene(&tmp.path().join("scene"), &Default::default()).expect("scene");
    let (view, camera) = (&scene.views[1], scene.camera(&scene.views[1]));
    // The left half of view 1.
    let (w, h) = (camera.width as f64, camera.height as f64);
    let polygon_px = vec![[0.0, 0.0], [w / 2.0, 0.0], [w / 2.0, h], [0.0, h]];
    let means = splatseg_scene::ply::read_ply_rows(&out.join("gaussians.ply")).expect("PLY").gaussians.means;
    let cam_from_world = view.world_from_cam.inverse();
    let inside = |m: &[f32; 3]| {
        let p = cam_from_world.transform_point(glam::DVec3::new(m[0] as f64, m[1] as f64, m[2] as f64));
        camera.project(p).is_some_and(|uv| uv.x >= 0.0 && uv.x < w / 2.0 && uv.y >= 0.0 && uv.y < h)
    };
    let selected = before_ids.iter().zip(&means).filter(|(&id, m)| id == object && inside(m)).count();
    assert!(selected > 0, "the lasso holds some of object {object}");
    let lasso = Operation::SplitLasso {
        object,
        camera: splatseg_edit::edits::LassoCamera::View { view: 1 },
        polygon_px,
        new_id: Some(900),
    };
    let done = apply(&out, &edits(&out, vec![lasso]));
    assert!(done.status.success(), "apply: {}", String::from_utf8_lossy(&done.stderr));
    for (i, ((&was, &now), m)) in before_ids.iter().zip(&ids(&out)).zip(&means).enumerate() {
        let want = if was == object && inside(m) { 900 } else { was };
        assert_eq!(now, want, "Gaussian {i}");
    }
    assert!(maps(&out).values().any(|m| m.data.contains(&900)), "the new object shows in the label maps");
}
