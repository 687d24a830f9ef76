//! Issue 60's "Done when": on a scene of the quality suite where `run` fuses a touching pair and
//! splits a patterned object, a person's repair — two operations (merge the object's pieces by
//! their ids; split the pair by a box placed around one of its objects, as the scene's placement
//! gives it) and two names — raises the run's mIoU by at least 90 % of what those objects lost
//! (their IoU short of the mean IoU of the run's other objects), and every view agrees on the
//! repaired objects.
//!
//! The scene: `synth --family blind_contact --seed 102 --views 10 --size 208x156` (the family's
//! 416×312 and 28 views reduced to keep the test short; `run` with features takes ≈ 2 s).
//! `run` gives the checkered foreground box (ground-truth id 9) three ids and the touching pair
//! (ids 14 and 15) one. Numbers: docs/benchmarks/36-repairs-by-edits.md.

use splatseg_edit::edits::{write_edits, Box3, Edits, Operation};
use splatseg_eval::{evaluate_folders, EvalConfig, Metrics};
use splatseg_scene::Plane;
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;
use std::process::{Command, Output};

/// The ground-truth ids of the patterned object and of the touching pair (synth's objects.json).
pub(crate) const PATTERNED: u32 = 9;
pub(crate) const PAIR: (u32, u32) = (14, 15);
/// A piece of an object: at least this share of its pixels over all views.
const PIECE_SHARE: f64 = 0.1;
/// The box is the object's cuboid grown by this much on every side (world units: metres).
const BOX_MARGIN: f64 = 0.01;
/// The share of the three objects' loss the repair must give back (measured: 0.0895 of 0.0949).
const RECOVERED_SHARE: f64 = 0.9;

fn splatseg(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_splatseg")).args(args).env_remove("RUST_LOG").output().expect("spawn")
}

pub(crate) fn ok(args: &[&str]) -> String {
    let out = splatseg(args);
    assert!(out.status.success(), "splatseg {args:?}: {}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8_lossy(&out.stdout).into_owned()
}

pub(crate) fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

/// `(stem, ground truth, prediction)` of every view.
pub(crate) fn views(scene: &Path, out: &Path) -> Vec<(String, Plane<u32>, Plane<u32>)> {
    let gt = splatseg_eval::list_label_maps(&scene.join("gt/instance")).expect("gt maps");
    gt.iter()
        .map(|(stem, path)| {
            let read = |p: &Path| splatseg_scene::labels::read_label_png(p).expect("label map");
            (stem.clone(), read(path), read(&out.join("masks").join(format!("{stem}.png"))))
        })
        .collect()
}

/// Over all views: pixels of ground-truth object `gt` per predicted id (0 = none).
fn shares(views: &[(String, Plane<u32>, Plane<u32>)], gt: u32) -> BTreeMap<u32, u64> {
    let mut px = BTreeMap::new();
    for (_, truth, pred) in views {
        for (&t, &p) in truth.data.iter().zip(&pred.data) {
            if t == gt {
                *px.entry(p).or_default() += 1;
            }
        }
    }
    px
}

/// The predicted ids holding at least [`PIECE_SHARE`] of `gt`'s pixels, most pixels first.
fn pieces(views: &[(String, Plane<u32>, Plane<u32>)], gt: u32) -> Vec<u32> {
    let px = shares(views, gt);
    let total: u64 = px.values().sum();
    let mut ids: Vec<(u64, u32)> = px
        .into_iter()
        .filter(|&(id, n)| id > 0 && n as f64 >= PIECE_SHARE * total as f64)
        .map(|(id, n)| (n, id))
        .collect();
    ids.sort_unstable_by(|a, b| b.cmp(a));
    ids.into_iter().map(|(_, id)| id).collect()
}

fn iou(m: &Metrics, gt: u32) -> f64 {
    m.instances.iter().find(|i| i.gt_id == gt).map(|i| i.iou).expect("a ground-truth instance")
}

/// The box of a synth cuboid (`objects.json`'s shape: base centre, size, yaw about +z), grown by
/// [`BOX_MARGIN`].
fn cuboid_box(scene: &Path, gt: u32) -> Box3 {
    let text = std::fs::read_to_string(scene.join("gt/objects.json")).expect("objects.json");
    let objects: serde_json::Value = serde_json::from_str(&text).expect("json");
    let object =
        objects["objects"].as_array().expect("objects").iter().find(|o| o["id"] == gt).expect("object");
    let shape = &object["shape"];
    assert_eq!(shape["type"], "cuboid", "{object}");
    let v = |key: &str| -> [f64; 3] {
        let a = shape[key].as_array().expect("vector");
        [0, 1, 2].map(|k| a[k].as_f64().expect("number"))
    };
    let (base, size, yaw) = (v("base_centre"), v("size"), shape["yaw"].as_f64().expect("yaw"));
    Box3 {
        centre: [base[0], base[1], base[2] + size[2] / 2.0],
        half_size: size.map(|x| x / 2.0 + BOX_MARGIN),
        rotation: Some([(yaw / 2.0).cos(), 0.0, 0.0, (yaw / 2.0).sin()]),
    }
}

/// The scene and `run` of the repair, with what a person sees in the run's label maps.
pub(crate) struct Repair {
    /// Holds the folders.
    pub(crate) _tmp: tempfile::TempDir,
    pub(crate) scene: std::path::PathBuf,
    pub(crate) out: std::path::PathBuf,
    /// The run's metrics against the ground truth.
    pub(crate) before: Metrics,
    /// `(stem, ground truth, run's map)` of every view.
    pub(crate) run_views: Vec<(String, Plane<u32>, Plane<u32>)>,
    /// The ids the patterned object shows in (its pieces), most pixels first.
    pub(crate) split: Vec<u32>,
    /// The id of the fused pair.
    pub(crate) fused: i32,
}

/// Synthesises the scene and runs `splatseg run` on it (≈ 3 s); panics when the scene no longer
/// shows the two failures.
pub(crate) fn repair_scene() -> Repair {
    let tmp = tempfile::tempdir().expect("temp dir");
    let (scene, out) = (tmp.path().join("scene"), tmp.path().join("out"));
    ok(&[
        "-q",
        "synth",
        "--family",
        "blind_contact",
        "--seed",
        "102",
        "--views",
        "10",
        "--size",
        "208x156",
        "--out",
        s(&scene),
    ]);
    let (masks, features) = (scene.join("sam"), scene.join("features"));
    ok(&["-q", "run", s(&scene), "--masks", s(&masks), "--features", s(&features), "--out", s(&out)]);
    let before = eval(&scene, &out);
    let run_views = views(&scene, &out);
    // What a person sees: the patterned object in pieces, the pair under one id.
    let split = pieces(&run_views, PATTERNED);
    let (first, second) = (pieces(&run_views, PAIR.0), pieces(&run_views, PAIR.1));
    assert!(
        split.len() >= 2 && first.first() == second.first(),
        "the scene no longer shows the two failures (pieces of {PATTERNED}: {split:?}; of the pair: {first:?}, \
         {second:?}): pick another scene for this test"
    );
    let fused = first[0] as i32;
    Repair { _tmp: tmp, scene, out, before, run_views, split, fused }
}

fn eval(scene: &Path, out: &Path) -> Metrics {
    evaluate_folders(&scene.join("gt/instance"), &out.join("masks"), &EvalConfig::default()).expect("eval")
}

/// After `splatseg apply`: asserts the mIoU gain is at least `share` of what the three objects
/// lost (their IoU short of the mean IoU of the run's other objects), the merged object at or
/// above that mean, and that every view agrees (in each view where the run showed a repaired
/// object mostly under a wrong id, it now shows mostly under the id the repair gave it: the
/// merged one, the fused id for the striped box, `blue_id` for the blue one). Returns the gain
/// and the loss.
pub(crate) fn check_repair(repair: &Repair, merged: i32, blue_id: i32, share: f64) -> (f64, f64) {
    let Repair { scene, out, before, run_views, split, fused, .. } = repair;
    let after = eval(scene, out);
    let repaired = [PATTERNED, PAIR.0, PAIR.1];
    let others: Vec<f64> =
        before.instances.iter().filter(|i| !repaired.contains(&i.gt_id)).map(|i| i.iou).collect();
    let typical = others.iter().sum::<f64>() / others.len() as f64;
    let lost: f64 = repaired.iter().map(|&g| (typical - iou(before, g)).max(0.0)).sum::<f64>()
        / before.gt_instances as f64;
    let gain = after.miou - before.miou;
    println!(
        "mIoU {:.4} -> {:.4} (+{gain:.4}; lost {lost:.4}, {:.0} % given back); IoU of {PATTERNED}: {:.3} -> {:.3}, {}: {:.3} -> {:.3}, {}: {:.3} -> {:.3}",
        before.miou,
        after.miou,
        100.0 * gain / lost,
        iou(before, PATTERNED),
        iou(&after, PATTERNED),
        PAIR.0,
        iou(before, PAIR.0),
        iou(&after, PAIR.0),
        PAIR.1,
        iou(before, PAIR.1),
        iou(&after, PAIR.1)
    );
    assert!(iou(&after, PATTERNED) >= typical, "the merged object: {:.3}", iou(&after, PATTERNED));
    assert!(
        gain >= share * lost,
        "mIoU {:.4} -> {:.4}: +{gain:.4}, under {share} of the {lost:.4} the objects lost",
        before.miou,
        after.miou
    );
    let after_views = views(scene, out);
    let wrong: BTreeMap<u32, Vec<u32>> =
        [(PATTERNED, split.clone()), (PAIR.0, vec![*fused as u32]), (PAIR.1, vec![*fused as u32])].into();
    let want: BTreeMap<u32, u32> =
        [(PATTERNED, merged as u32), (PAIR.0, *fused as u32), (PAIR.1, blue_id as u32)].into();
    let majority =
        |px: &BTreeMap<u32, u64>| px.iter().filter(|(&p, _)| p > 0).max_by_key(|(_, &n)| n).map(|(&p, _)| p);
    let mut checked = 0;
    for ((stem, truth, run_pred), (_, _, pred)) in run_views.iter().zip(&after_views) {
        for (&gt, &id) in &want {
            let was = shares(&[(stem.clone(), truth.clone(), run_pred.clone())], gt);
            if was.values().sum::<u64>() < 20 || !majority(&was).is_some_and(|p| wrong[&gt].contains(&p)) {
                continue;
            }
            let now = shares(&[(stem.clone(), truth.clone(), pred.clone())], gt);
            assert_eq!(majority(&now), Some(id), "view {stem}: object {gt} showed {was:?}, shows {now:?}");
            checked += 1;
        }
    }
    println!("{checked} (view, object) pairs agree");
    assert!(checked >= 2 * run_views.len(), "{checked} (view, object) pairs checked");
    let shown: BTreeSet<u32> = after_views.iter().flat_map(|(_, _, p)| p.data.iter().copied()).collect();
    assert!(split.iter().all(|&id| id == merged as u32 || !shown.contains(&id)), "a piece is left");
    (gain, lost)
}

#[test]
fn a_fused_touching_pair_and_a_split_patterned_object_repaired_by_two_edits_raise_the_miou() {
    let repair = repair_scene();
    let (out, split, fused) = (&repair.out, &repair.split, repair.fused);
    let merged = *split.iter().min().expect("pieces") as i32;
    let ply = splatseg_scene::ply::read_ply_rows(&out.join("gaussians.ply")).expect("PLY").gaussians;
    let in_maps = repair.run_views.iter().flat_map(|(_, _, p)| p.data.iter().map(|&id| id as i32));
    let new_id = ply.object_ids.expect("ids").into_iter().chain(in_maps).max().expect("ids") + 1;
    let operations = vec![
        Operation::Merge { ids: split.iter().map(|&id| id as i32).collect(), into: None },
        Operation::SplitBox {
            object: fused,
            region: cuboid_box(&repair.scene, PAIR.1),
            new_id: Some(new_id),
        },
        Operation::Rename { id: merged, name: "checkered box".into() },
        Operation::Rename { id: new_id, name: "blue box".into() },
    ];
    assert!(operations.len() <= 6);
    let inputs = splatseg_pipeline::apply::edit_inputs(out).expect("the run's identity");
    write_edits(&out.join("edits.json"), &Edits::new(inputs, operations)).expect("edits");
    ok(&["apply", s(out)]);
    // The merge gives the patterned object back whole; the box split gives back most of what the
    // pair lost (158 of the blue box's 1,183 pixels keep the pair's id, where the remaining
    // Gaussians of its partner render over it): at least 90 % of the loss in all.
    check_repair(&repair, merged, new_id, RECOVERED_SHARE);
    // and the names
    let listed = ok(&["objects", s(&out.join("gaussians.ply"))]);
    assert!(listed.contains("| checkered box |") && listed.contains("| blue box |"), "{listed}");

    // Idempotent with splits and fills too: applied again, every output has the same bytes.
    let files = || -> BTreeMap<String, Vec<u8>> {
        let mut files = BTreeMap::new();
        for name in ["gaussians.ply", "objects.json", "report.md", "metrics.json"] {
            files.insert(name.to_string(), std::fs::read(out.join(name)).expect("output"));
        }
        for dir in ["masks", "overlays"] {
            for entry in std::fs::read_dir(out.join(dir)).expect("folder").flatten() {
                let name = format!("{dir}/{}", entry.file_name().to_string_lossy());
                files.insert(name, std::fs::read(entry.path()).expect("output"));
            }
        }
        files
    };
    let first = files();
    ok(&["apply", s(out)]);
    assert!(files() == first, "a second apply changed the outputs");
}
