//! Issue 30 end to end on a synthetic scene with a random-weight CLIP the test writes itself
//! (open_clip's hub layout: `open_clip_model.safetensors` with OpenAI names, `open_clip_config.json`,
//! and the tokenizer's merges beside): `run --clip` → `find` (`--top`, `--json`) → `extract --query` /
//! `remove --query`, deterministic (whatever the thread count), cached, the names `view --names`
//! gives, and the errors of a missing checkpoint, missing embeddings or a bad names file.
//!
//! The weights are random, so which object a query picks means nothing; what is checked is that
//! the binary's ranking is the one the library's towers and `rank_objects` give for the same files,
//! and that `extract --query` writes exactly what `extract --ids <the best>` writes.

use splatseg_models::clip::relevancy::{rank_objects, Embeddings, CANONICAL_NEGATIVES, LERF_SCALE};
use splatseg_models::clip::testing::{write_random_checkpoint, RandomClipSpec};
use splatseg_models::clip::{Clip, ClipHints, ClipTokenizer, MERGES_FILE};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn splatseg<S: AsRef<std::ffi::OsStr>>(args: &[S]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_splatseg")).args(args).output().expect("the splatseg binary runs")
}

/// `splatseg ARGS` with rayon's (and candle's) pool of `threads` threads; its stdout.
fn ok_with_threads(args: &[&str], threads: usize) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_splatseg"))
        .args(args)
        .env("RAYON_NUM_THREADS", threads.to_string())
        .output()
        .expect("the splatseg binary runs");
    assert!(out.status.success(), "splatseg {args:?}: {}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8_lossy(&out.stdout).into_owned()
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

    // --top K: the first K rows; --json: the same ranking as a JSON array with every field
    let top2 = parse_find(&ok(&["find", s(&out), query, "--top", "2"]));
    assert_eq!(top2, found[..2].to_vec());
    let json: serde_json::Value =
        serde_json::from_str(&ok(&["find", s(&out), query, "--json"])).expect("find --json prints JSON");
    let rows = json.as_array().expect("an array");
    assert_eq!(rows.len(), found.len());
    for (i, (row, e)) in rows.iter().zip(&expected).enumerate() {
        assert_eq!(row["rank"], i + 1, "{row}");
        assert_eq!(row["id"], e.id, "{row}");
        assert!((row["relevancy"].as_f64().unwrap() as f32 - e.relevancy).abs() < 1e-6, "{row} vs {e:?}");
        assert!((row["cosine"].as_f64().unwrap() as f32 - e.cosine).abs() < 1e-6, "{row} vs {e:?}");
        let object = objects.iter().find(|o| o["id"] == e.id).unwrap();
        assert_eq!(row["colour"], object["colour"], "{row}");
        let views: Vec<&serde_json::Value> =
            object["views"].as_array().unwrap().iter().map(|v| &v["stem"]).collect();
        assert_eq!(row["views"].as_array().unwrap().iter().collect::<Vec<_>>(), views, "{row}");
        let mut keys: Vec<&String> = row.as_object().unwrap().keys().collect();
        keys.sort();
        assert_eq!(keys, ["colour", "cosine", "id", "rank", "relevancy", "views"], "{row}");
    }
    // one object per line, its fields in a fixed order
    let text = ok(&["find", s(&out), query, "--json"]);
    let lines: Vec<&str> = text.lines().filter(|l| l.contains('{')).collect();
    assert_eq!(lines.len(), rows.len(), "{text}");
    assert!(lines.iter().all(|l| l.trim_start().starts_with("{\"rank\":")), "{text}");
    let one: serde_json::Value =
        serde_json::from_str(&ok(&["find", s(&out), query, "--json", "--top", "1"])).unwrap();
    assert_eq!(one.as_array().map(Vec::len), Some(1));
    assert_eq!(one[0], rows[0]);
    let err = failed(&["find", s(&out), query, "--top", "0"]);
    assert!(err.contains("at least 1"), "{err}");

    // the names of `view --names`: each object's best name is the one `find NAME` gives it the
    // highest relevancy (the first name of the list on a tie)
    let names: Vec<String> =
        ["chair", "a red mug", "lamp", "the floor", "a wooden table"].map(String::from).to_vec();
    let search =
        splatseg_model_cues::clip_objects::ObjectSearch::open(&out).expect("opens the run's embeddings");
    let named = search.name_objects(&names).expect("names the objects");
    assert_eq!(named.iter().map(|n| n.id).collect::<Vec<_>>(), ids, "every embedded object, by id");
    let by_name: Vec<serde_json::Value> = names
        .iter()
        .map(|n| serde_json::from_str(&ok(&["find", s(&out), n.as_str(), "--json"])).unwrap())
        .collect();
    for n in &named {
        let relevancy_to = |k: usize| -> f32 {
            let row = by_name[k].as_array().unwrap().iter().find(|r| r["id"] == n.id).unwrap();
            row["relevancy"].as_f64().unwrap() as f32
        };
        let best = (0..names.len()).map(relevancy_to).fold(f32::NEG_INFINITY, f32::max);
        let first_best = (0..names.len()).find(|&k| relevancy_to(k) == best).unwrap();
        assert_eq!(n.name, names[first_best], "object {}: {named:?}", n.id);
        assert!((n.relevancy - best).abs() < 1e-6, "{n:?}: find says {best}");
    }

    // extract / remove by query = by the best id
    let best = expected_ids[0].to_string();
    let ply = out.join("gaussians.ply");
    let (by_query, by_id) = (tmp.path().join("q.ply"), tmp.path().join("id.ply"));
    let said = ok(&["extract", s(&ply), "--query", query, "--out", s(&by_query)]);
    assert!(said.contains(&format!("object {best}")), "{said}");
    ok(&["extract", s(&ply), "--ids", best.as_str(), "--out", s(&by_id)]);
    let picked = std::fs::read(&by_query).unwrap();
    assert_eq!(picked, std::fs::read(&by_id).unwrap(), "extract QUERY = extract --ids best");
    let (rest_q, rest_id) = (tmp.path().join("rq.ply"), tmp.path().join("rid.ply"));
    ok(&["remove", s(&ply), "--query", query, "--out", s(&rest_q)]);
    ok(&["remove", s(&ply), "--ids", best.as_str(), "--out", s(&rest_id)]);
    assert_eq!(std::fs::read(&rest_q).unwrap(), std::fs::read(&rest_id).unwrap());
    // what extract kept is what remove took away, and it is not nothing
    let count = |text: &str, word: &str| -> usize {
        let at = text.find(word).unwrap_or_else(|| panic!("{word:?} in {text:?}"));
        text[at + word.len()..].split_whitespace().next().and_then(|n| n.parse().ok()).expect("a count")
    };
    let removed = ok(&["remove", s(&ply), "--query", query, "--out", s(&tmp.path().join("rq2.ply"))]);
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
    let err = failed(&["extract", ply, "--query", "a chair", "--out", s(&tmp.path().join("x.ply"))]);
    assert!(err.contains("objects.json"), "{err}");
    assert!(!tmp.path().join("x.ply").exists());
    let err =
        failed(&["extract", ply, "--query", "a chair", "--ids", "1", "--out", s(&tmp.path().join("x.ply"))]);
    assert!(err.contains("cannot be used with"), "{err}");
    for verb in ["extract", "remove"] {
        let err = failed(&[verb, ply, "--out", s(&tmp.path().join("x.ply"))]);
        assert!(err.contains("--ids") && err.contains("--query"), "{verb} without either: {err}");
        // the query is no longer a positional argument
        let err = failed(&[verb, ply, "a chair", "--out", s(&tmp.path().join("x.ply"))]);
        assert!(err.contains("unexpected argument"), "{err}");
    }
    assert!(!tmp.path().join("x.ply").exists());

    // `view --names` needs the embeddings, and a readable list with a name in it
    let names = tmp.path().join("names.txt");
    std::fs::write(&names, "chair\n").unwrap();
    let view = |names: &Path| failed(&["view", s(&out), "--listen", "127.0.0.1:0", "--names", s(names)]);
    let err = view(&names);
    assert!(err.contains("--names") && err.contains("objects.json"), "{err}");
    let err = view(&tmp.path().join("no_such_names.txt"));
    assert!(err.contains("no_such_names.txt"), "{err}");
    std::fs::write(&names, "# nothing\n\n").unwrap();
    let err = view(&names);
    assert!(err.contains("names.txt") && err.contains("holds no name"), "{err}");
}

/// transformers' `CLIPModel` folder (`model.safetensors` + `config.json`) with its `tokenizer.json` (the
/// models crate's fixture, copied): `run --clip` embeds the objects with it, and `find` reads the
/// query's tokens from `tokenizer.json` and ranks as the library does with the same files.
#[test]
fn a_transformers_checkpoint_with_its_tokenizer_json_runs_end_to_end() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let fixture = Path::new(env!("CARGO_MANIFEST_DIR")).join("crates/models/tests/fixtures/clip_tiny_hf");
    let clip = tmp.path().join("hf_clip");
    std::fs::create_dir_all(&clip).unwrap();
    for file in ["model.safetensors", "config.json", "tokenizer.json"] {
        std::fs::copy(fixture.join(file), clip.join(file)).expect("copies the fixture");
    }
    let scene = scene(tmp.path());
    let out = tmp.path().join("out");
    run_clip(&scene, &out, &clip);
    let index: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("objects/objects.json")).unwrap()).unwrap();
    let ids: Vec<u32> = index["objects"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|o| !o["row"].is_null())
        .map(|o| o["id"].as_u64().unwrap() as u32)
        .collect();
    assert!(ids.len() >= 3, "{index}");
    let npy = splatseg_scene::npy::read_npy(&out.join("objects/clip.npy")).unwrap();
    let query = "a red mug";
    let found: serde_json::Value = serde_json::from_str(&ok(&["find", s(&out), query, "--json"])).unwrap();
    let model = Clip::load(&clip, ClipHints::default()).unwrap();
    let tokenizer = ClipTokenizer::load(&clip.join("tokenizer.json")).unwrap();
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
    let got: Vec<u64> = found.as_array().unwrap().iter().map(|r| r["id"].as_u64().unwrap()).collect();
    assert_eq!(got, expected.iter().map(|r| u64::from(r.id)).collect::<Vec<_>>());
    // without its tokenizer file, find names both file names it looks for
    std::fs::remove_file(clip.join("tokenizer.json")).unwrap();
    let err = failed(&["find", s(&out), query]);
    assert!(err.contains("tokenizer.json") && err.contains(MERGES_FILE), "{err}");
}

/// The object embeddings and `find`'s ranking, made with rayon's and candle's pools of 1 and of 2
/// threads (`RAYON_NUM_THREADS`, which both read), are byte for byte the same.
#[test]
fn embeddings_and_rankings_do_not_depend_on_the_thread_count() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let clip = random_clip(&tmp.path().join("clip"));
    let scene = scene(tmp.path());
    let mut results = Vec::new();
    for threads in [1, 2] {
        let out = tmp.path().join(format!("out-{threads}"));
        ok_with_threads(
            &["run", s(&scene), "--masks", s(&scene.join("sam")), "--out", s(&out), "--clip", s(&clip)],
            threads,
        );
        let npy = std::fs::read(out.join("objects/clip.npy")).expect("clip.npy");
        let found: Vec<String> = ["a red mug", "chair"]
            .iter()
            .map(|q| ok_with_threads(&["find", s(&out), q, "--json"], threads))
            .collect();
        results.push((npy, found));
    }
    assert!(results[0].0.len() > 128, "embeddings were written");
    assert!(results[0].0 == results[1].0, "clip.npy differs between 1 and 2 threads");
    assert_eq!(results[0].1, results[1].1, "find's ranking differs between 1 and 2 threads");
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

/// Issue 60: `apply` on a run made with `--clip` embeds the edited objects again (the merged-away id
/// gone from the index, the merged object in it), `find` ranks them and shows the name the edits
/// gave, and `extract`/`remove --query NAME` take it. With the checkpoint gone, `apply` still applies
/// and warns; `find` then says to embed again, and `run --clip` on the applied folder embeds the
/// edited objects without undoing the edits.
#[test]
fn apply_embeds_the_edited_objects_again_and_find_shows_their_names() {
    use splatseg_edit::edits::{write_edits, Edits, Operation, EDITS_VERSION};
    let tmp = tempfile::tempdir().expect("temp dir");
    let clip = random_clip(&tmp.path().join("clip"));
    let scene = scene(tmp.path());
    let out = tmp.path().join("out");
    run_clip(&scene, &out, &clip);
    let ply = out.join("gaussians.ply");
    let ids = || splatseg_scene::ply::read_ply_rows(&ply).unwrap().gaussians.object_ids.unwrap();
    let before = ids();
    // the two objects with the most Gaussians (large enough to be embedded)
    let mut counts = std::collections::BTreeMap::<i32, usize>::new();
    for &id in before.iter().filter(|&&id| id > 0) {
        *counts.entry(id).or_default() += 1;
    }
    let mut by_size: Vec<(usize, i32)> = counts.into_iter().map(|(id, n)| (n, id)).collect();
    by_size.sort_unstable_by(|a, b| b.cmp(a));
    assert!(by_size.len() >= 3, "{by_size:?}");
    let (into, gone) = (by_size[0].1.min(by_size[1].1), by_size[0].1.max(by_size[1].1));
    let inputs = splatseg_pipeline::apply::edit_inputs(&out).expect("the run's identity");
    let operations = vec![
        Operation::Merge { ids: vec![into, gone], into: None },
        Operation::Rename { id: into, name: "the pair".into() },
    ];
    write_edits(&out.join("edits.json"), &Edits { version: EDITS_VERSION, inputs, operations }).unwrap();
    let said = ok(&["apply", s(&out)]);
    assert!(said.contains("object embeddings:") && said.contains("crops"), "{said}");
    let edited = ids();
    assert!(!edited.contains(&gone) && edited.contains(&into));

    // the index names the edited objects: those of the edited label maps
    let index = || -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(out.join("objects/objects.json")).unwrap()).unwrap()
    };
    let indexed = || -> Vec<u32> {
        index()["objects"].as_array().unwrap().iter().map(|o| o["id"].as_u64().unwrap() as u32).collect()
    };
    let mut shown: Vec<u32> = Vec::new();
    for entry in std::fs::read_dir(out.join("masks")).unwrap().flatten() {
        let map = splatseg_scene::labels::read_label_png(&entry.path()).unwrap();
        shown.extend(splatseg_edit::ids_in_label_map(&map));
    }
    shown.sort_unstable();
    shown.dedup();
    assert_eq!(indexed(), shown, "the index holds the edited maps' objects");
    assert!(!shown.contains(&(gone as u32)) && shown.contains(&(into as u32)));

    // find ranks them and names the named one, in the table and the JSON
    let found: serde_json::Value =
        serde_json::from_str(&ok(&["find", s(&out), "a chair", "--json"])).unwrap();
    let rows = found.as_array().unwrap();
    let mut ranked: Vec<u64> = rows.iter().map(|r| r["id"].as_u64().unwrap()).collect();
    ranked.sort_unstable();
    let embedded: Vec<u64> = index()["objects"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|o| !o["row"].is_null())
        .map(|o| o["id"].as_u64().unwrap())
        .collect();
    assert_eq!(ranked, embedded, "find ranks every embedded edited object");
    assert!(ranked.contains(&(into as u64)) && !ranked.contains(&(gone as u64)), "{found}");
    for r in rows {
        let named = r["id"].as_u64() == Some(into as u64);
        assert_eq!(r.get("name").and_then(|n| n.as_str()), named.then_some("the pair"), "{r}");
    }
    let table = ok(&["find", s(&out), "a chair"]);
    assert!(table.lines().nth(1).unwrap().ends_with("name"), "{table}");
    let line = table.lines().find(|l| l.split_whitespace().nth(1) == Some(&into.to_string())).unwrap();
    assert!(line.ends_with("\"the pair\""), "{table}");

    // extract / remove by the name; objects shows it
    let one = tmp.path().join("pair.ply");
    ok(&["extract", s(&ply), "--query", "the pair", "--out", s(&one)]);
    let count = edited.iter().filter(|&&id| id == into).count();
    assert_eq!(splatseg_scene::ply::read_ply(&one).unwrap().len(), count);
    let rest = tmp.path().join("rest.ply");
    ok(&["remove", s(&ply), "--query", "the pair", "--out", s(&rest)]);
    assert_eq!(splatseg_scene::ply::read_ply(&rest).unwrap().len(), edited.len() - count);
    assert!(ok(&["objects", s(&ply)]).contains("| the pair |"));

    // the checkpoint gone: apply applies and warns; find says to embed again
    let moved = tmp.path().join("clip_moved");
    std::fs::rename(&clip, &moved).unwrap();
    let again = splatseg(&["apply", s(&out)]);
    let warned = String::from_utf8_lossy(&again.stderr);
    assert!(again.status.success(), "{warned}");
    assert!(warned.contains("could not be embedded again") && warned.contains("--clip"), "{warned}");
    assert_eq!(ids(), edited, "the edits are applied");
    let err = failed(&["find", s(&out), "a chair"]);
    assert!(err.contains("run --clip"), "{err}");
    // run --clip on the applied folder: up to date, the edited objects embedded, the edits kept
    std::fs::rename(&moved, &clip).unwrap();
    run_clip(&scene, &out, &clip);
    assert_eq!(ids(), edited, "run --clip kept the edits");
    assert_eq!(indexed(), shown);
    assert!(ok(&["find", s(&out), "a chair"]).contains("\"the pair\""));
}
