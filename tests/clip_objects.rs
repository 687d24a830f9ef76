//! Issue 30 end to end on a synthetic scene with a random-weight CLIP the test writes itself
//! (open_clip's hub layout: `open_clip_model.safetensors` with OpenAI names, `open_clip_config.json`,
//! and the tokenizer's merges beside): `run --clip` → `find` → `extract QUERY` / `remove QUERY`,
//! deterministic, cached, and the errors of a missing checkpoint or missing embeddings.
//!
//! The weights are random, so which object a query picks means nothing; what is checked is that
//! the binary's ranking is the one the library's towers and `rank_objects` give for the same files,
//! and that `extract QUERY` writes exactly what `extract --ids <the best>` writes.

use splatseg_models::clip::relevancy::{rank_objects, Embeddings, CANONICAL_NEGATIVES, LERF_SCALE};
use splatseg_models::clip::testing::{write_random_checkpoint, RandomClipSpec};
use splatseg_models::clip::{Clip, ClipHints, ClipTokenizer, MERGES_FILE};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn splatseg<S: AsRef<std::ffi::OsStr>>(args: &[S]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_splatseg")).args(args).output().expect("the splatseg binary runs")
}

fn ok<S: AsRef<std::ffi::OsStr> + std::fmt::Debug>(args: &[S]) -> String {
    let out = splatseg(args);
    assert!(
        out.status.success(),
        "splatseg {args:?} failed:\n{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn failed<S: AsRef<std::ffi::OsStr> + std::fmt::Debug>(args: &[S]) -> String {
    let out = splatseg(args);
    assert!(!out.status.success(), "splatseg {args:?} should fail");
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!err.contains("panicked"), "{err}");
    err
}

fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

/// A tiny random CLIP (vocabulary of the committed tiny merges, 651 ids) in `dir`.
fn random_clip(dir: &Path) -> PathBuf {
    write_random_checkpoint(dir, RandomClipSpec::tiny(651), 30).expect("writes the checkpoint");
    let merges =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("crates/models/tests/fixtures/clip_bpe_tiny.txt.gz");
    std::fs::copy(merges, dir.join(MERGES_FILE)).expect("copies the merges");
    dir.to_path_buf()
}

/// A synthetic scene (3 views, 96×72) in `dir/scene`.
fn scene(dir: &Path) -> PathBuf {
    let scene = dir.join("scene");
    ok(&["synth", "--out", s(&scene), "--views", "3", "--size", "96x72"]);
    scene
}

fn run_clip(scene: &Path, out: &Path, clip: &Path) -> String {
    ok(&["run", s(scene), "--masks", s(&scene.join("sam")), "--out", s(out), "--clip", s(clip)])
}

/// `find`'s rows as (id, relevancy).
fn parse_find(text: &str) -> Vec<(u32, f32)> {
    text.lines()
        .skip(2)
        .map(|l| {
            let cols: Vec<&str> = l.split_whitespace().collect();
            (cols[1].parse().expect("an id"), cols[2].parse().expect("a relevancy"))
        })
        .collect()
}

#[test]
fn run_clip_then_find_then_extract_by_query() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let clip = random_clip(&tmp.path().join("clip"));
    let scene = scene(tmp.path());
    let out = tmp.path().join("out");
    let said = run_clip(&scene, &out, &clip);
    assert!(said.contains("object embeddings:") && said.contains("crops"), "{said}");

    // the index and the embeddings agree, rows are unit vectors, at most 5 views per object
    let index: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("objects/objects.json")).unwrap()).unwrap();
    let npy = splatseg_scene::npy::read_npy(&out.join("objects/clip.npy")).unwrap();
    let objects = index["objects"].as_array().unwrap();
    let embedded: Vec<&serde_json::Value> = objects.iter().filter(|o| !o["row"].is_null()).collect();
    assert!(embedded.len() >= 3, "{index}");
    assert_eq!(npy.shape, vec![embedded.len(), 16]);
    assert_eq!(index["dim"], 16);
    assert_eq!(index["checkpoint"].as_str(), Some(s(&clip)));
    for (r, o) in embedded.iter().enumerate() {
        assert_eq!(o["row"].as_u64(), Some(r as u64), "rows in id order");
        let views = o["views"].as_array().unwrap();
        assert!(!views.is_empty() && views.len() <= 5, "{o}");
        let row = &npy.data[r * 16..(r + 1) * 16];
        let norm = row.iter().map(|v| v * v).sum::<f32>().sqrt();
        assert!((norm - 1.0).abs() < 1e-5, "row {r} has length {norm}");
    }
    let ids: Vec<u32> = embedded.iter().map(|o| o["id"].as_u64().unwrap() as u32).collect();
    let labels = splatseg_scene::labels::read_label_png(&out.join("masks/view_000.png")).unwrap();
    assert!(ids.iter().any(|id| labels.data.contains(id)), "the ids are the label maps' ids");

    // a rerun with the same inputs does nothing; the same inputs elsewhere give the same bytes
    let again = run_clip(&scene, &out, &clip);
    assert!(again.contains("unchanged (cached)"), "{again}");
    let npy_bytes = std::fs::read(out.join("objects/clip.npy")).unwrap();
    let index_bytes = std::fs::read(out.join("objects/objects.json")).unwrap();
    std::fs::remove_dir_all(out.join("objects")).unwrap();
    run_clip(&scene, &out, &clip);
    assert_eq!(npy_bytes, std::fs::read(out.join("objects/clip.npy")).unwrap(), "clip.npy differs");
    assert_eq!(index_bytes, std::fs::read(out.join("objects/objects.json")).unwrap(), "objects.json differs");
    let elsewhere = tmp.path().join("out2");
    run_clip(&scene, &elsewhere, &clip);
    assert_eq!(npy_bytes, std::fs::read(elsewhere.join("objects/clip.npy")).unwrap());

    // find ranks as the library does with the same towers and files
    let query = "a red mug";
    let found = parse_find(&ok(&["find", s(&out), query]));
    assert_eq!(found.len(), ids.len(), "every embedded object is listed");
    let model = Clip::load(&clip, ClipHints::default()).unwrap();
    let tokenizer = ClipTokenizer::load(&clip.join(MERGES_FILE)).unwrap();
    let q = model.embed_texts_flat(&tokenizer, &[query]).unwrap();
    let negatives = model.embed_texts_flat(&tokenizer, &CANONICAL_NEGATIVES).unwrap();
    let expected = rank_objects(
        &ids,
        Embeddings::new(&npy.data, 16, "objects").unwrap(),
        &q,
        Embeddings::new(&negatives, 16, "negatives").unwrap(),
        LERF_SCALE,
        usize::MAX,
    )
    .unwrap();
    let expected_ids: Vec<u32> = expected.iter().map(|r| r.id).collect();
    assert_eq!(found.iter().map(|f| f.0).collect::<Vec<_>>(), expected_ids);
    for (f, e) in found.iter().zip(&expected) {
        assert!((f.1 - e.relevancy).abs() < 1e-4, "{f:?} vs {e:?}");
    }
    assert!(found.windows(2).all(|w| w[0].1 >= w[1].1), "best first: {found:?}");
    assert_eq!(ok(&["find", s(&out), query]), ok(&["find", s(&out), query]), "find is deterministic");

    // extract / remove by query = by the best id
    let best = expected_ids[0].to_string();
    let ply = out.join("gaussians.ply");
    let (by_query, by_id) = (tmp.path().join("q.ply"), tmp.path().join("id.ply"));
    let said = ok(&["extract", s(&ply), query, "--out", s(&by_query)]);
    assert!(said.contains(&format!("object {best}")), "{said}");
    ok(&["extract", s(&ply), "--ids", best.as_str(), "--out", s(&by_id)]);
    let picked = std::fs::read(&by_query).unwrap();
    assert_eq!(picked, std::fs::read(&by_id).unwrap(), "extract QUERY = extract --ids best");
    let (rest_q, rest_id) = (tmp.path().join("rq.ply"), tmp.path().join("rid.ply"));
    ok(&["remove", s(&ply), query, "--out", s(&rest_q)]);
    ok(&["remove", s(&ply), "--ids", best.as_str(), "--out", s(&rest_id)]);
    assert_eq!(std::fs::read(&rest_q).unwrap(), std::fs::read(&rest_id).unwrap());
    // what extract kept is what remove took away, and it is not nothing
    let count = |text: &str, word: &str| -> usize {
        let at = text.find(word).unwrap_or_else(|| panic!("{word:?} in {text:?}"));
        text[at + word.len()..].split_whitespace().next().and_then(|n| n.parse().ok()).expect("a count")
    };
    let removed = ok(&["remove", s(&ply), query, "--out", s(&tmp.path().join("rq2.ply"))]);
    assert_eq!(count(&said, "wrote "), count(&removed, "removed "), "{said}\n{removed}");
    assert!(count(&said, "wrote ") > 0, "{said}");
}

#[test]
fn run_without_clip_writes_no_objects_and_queries_name_the_missing_index() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let scene = scene(tmp.path());
    let out = tmp.path().join("out");
    ok(&["run", s(&scene), "--masks", s(&scene.join("sam")), "--out", s(&out)]);
    assert!(!out.join("objects").exists(), "run without --clip writes what it wrote before");
    let err = failed(&["find", s(&out), "a chair"]);
    assert!(err.contains("objects.json") && err.contains("run --clip"), "{err}");
    let ply_path = out.join("gaussians.ply");
    let ply = s(&ply_path);
    let err = failed(&["extract", ply, "a chair", "--out", s(&tmp.path().join("x.ply"))]);
    assert!(err.contains("objects.json"), "{err}");
    assert!(!tmp.path().join("x.ply").exists());
    let err = failed(&["extract", ply, "a chair", "--ids", "1", "--out", s(&tmp.path().join("x.ply"))]);
    assert!(err.contains("cannot be used with"), "{err}");
}

#[test]
fn a_missing_or_broken_checkpoint_is_an_error_naming_it() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let scene = scene(tmp.path());
    let missing = tmp.path().join("no_such_clip.safetensors");
    let out = tmp.path().join("out");
    let err = failed(&[
        "run",
        s(&scene),
        "--masks",
        s(&scene.join("sam")),
        "--out",
        s(&out),
        "--clip",
        s(&missing),
    ]);
    assert!(err.contains("no_such_clip.safetensors"), "{err}");
    assert!(!out.join("objects/objects.json").exists());

    // a checkpoint whose merges are missing: run embeds, find says which file it lacks
    let clip = random_clip(&tmp.path().join("clip"));
    run_clip(&scene, &out, &clip);
    std::fs::remove_file(clip.join(MERGES_FILE)).unwrap();
    let err = failed(&["find", s(&out), "a chair"]);
    assert!(err.contains(MERGES_FILE) && err.contains(s(&clip)), "{err}");
    // embeddings that do not match their index
    splatseg_scene::npy::write_npy_f32(&out.join("objects/clip.npy"), &[1, 3], &[1.0, 0.0, 0.0]).unwrap();
    std::fs::copy(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("crates/models/tests/fixtures/clip_bpe_tiny.txt.gz"),
        clip.join(MERGES_FILE),
    )
    .unwrap();
    let err = failed(&["find", s(&out), "a chair"]);
    assert!(err.contains("clip.npy") && err.contains("[1, 3]"), "{err}");
}
