//! Sharded per-view stages and thread counts: `merge --shard K/N` and `cues --shard K/N` run as
//! separate processes at once on one output folder, then `run` does only the global steps; the
//! outputs (label maps, overlays, labelled PLY, report, metrics) are byte-identical to one
//! unsharded run, with `RAYON_NUM_THREADS` = 1 and 2. A missing shard is named in `run`'s error.
//! Unsharded `merge` is the same per-view merge with the same cache keys: `run` after it merges
//! nothing and writes the same bytes.
//!
//! Every run writes to the same `--out` path (moved aside afterwards), since `metrics.json`
//! records the output folder.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn splatseg(args: &[&str], threads: usize) -> Command {
    let mut command = Command::new(env!("CARGO_BIN_EXE_splatseg"));
    command.args(args).arg("-q").env("RAYON_NUM_THREADS", threads.to_string()).env_remove("RUST_LOG");
    command
}

fn check(output: Output, what: &str) -> Output {
    assert!(
        output.status.success(),
        "{what} failed: {}\n{}",
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr)
    );
    output
}

/// Every file under `dir` except the cache and the lock, by relative path.
fn outputs(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    fn walk(root: &Path, dir: &Path, out: &mut BTreeMap<PathBuf, Vec<u8>>) {
        for entry in std::fs::read_dir(dir).expect("listable").flatten() {
            let path = entry.path();
            let rel = path.strip_prefix(root).expect("under root").to_path_buf();
            if rel.starts_with("cache") || rel.ends_with(".splatseg.lock") {
                continue;
            }
            if path.is_dir() {
                walk(root, &path, out);
            } else {
                out.insert(rel, std::fs::read(&path).expect("readable"));
            }
        }
    }
    let mut out = BTreeMap::new();
    walk(dir, dir, &mut out);
    out
}

fn assert_same(a: &BTreeMap<PathBuf, Vec<u8>>, b: &BTreeMap<PathBuf, Vec<u8>>, what: &str) {
    assert_eq!(a.keys().collect::<Vec<_>>(), b.keys().collect::<Vec<_>>(), "{what}: the same files");
    for (path, bytes) in a {
        assert!(bytes == &b[path], "{what}: {} differs", path.display());
    }
}

struct Scene {
    _tmp: tempfile::TempDir,
    root: PathBuf,
    out: PathBuf,
}

impl Scene {
    fn new() -> Scene {
        let tmp = tempfile::tempdir().expect("temp dir");
        let root = tmp.path().join("scene");
        let args = ["synth", "--out", root.to_str().expect("utf-8"), "--views", "6", "--size", "160x120"];
        check(splatseg(&args, 2).args(["--seed", "3"]).output().expect("spawn"), "synth");
        let out = tmp.path().join("out");
        Scene { _tmp: tmp, root, out }
    }

    /// `run`'s (and `merge --shard`'s) input arguments.
    fn inputs(&self) -> Vec<String> {
        let s = |p: PathBuf| p.to_string_lossy().to_string();
        vec![
            s(self.root.clone()),
            "--masks".into(),
            s(self.root.join("sam")),
            "--features".into(),
            s(self.root.join("features")),
            "--out".into(),
            s(self.out.clone()),
        ]
    }

    fn command(&self, stage: &str, extra: &[&str], threads: usize) -> Command {
        let mut args: Vec<String> = vec![stage.to_string()];
        args.extend(self.inputs());
        args.extend(extra.iter().map(|s| s.to_string()));
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        splatseg(&args, threads)
    }

    /// `merge --shard K/N` for the given shards, all at once as separate processes.
    fn shards(&self, count: usize, which: &[usize], threads: usize) {
        let children: Vec<_> = which
            .iter()
            .map(|k| {
                let shard = format!("{k}/{count}");
                let mut command = self.command("merge", &["--shard", &shard], threads);
                command.stdout(std::process::Stdio::piped()).stderr(std::process::Stdio::piped());
                (shard, command.spawn().expect("spawn shard"))
            })
            .collect();
        for (shard, child) in children {
            check(child.wait_with_output().expect("shard ends"), &format!("merge --shard {shard}"));
        }
    }

    fn run(&self, threads: usize) -> Output {
        self.command("run", &[], threads).output().expect("spawn run")
    }

    /// The outputs of the last run, with `--out` moved aside for the next.
    fn take_outputs(&self, name: &str) -> BTreeMap<PathBuf, Vec<u8>> {
        let files = outputs(&self.out);
        std::fs::rename(&self.out, self.out.with_file_name(name)).expect("move aside");
        files
    }
}

#[test]
fn sharded_runs_and_thread_counts_give_byte_identical_outputs() {
    let scene = Scene::new();
    check(scene.run(2), "unsharded run, 2 threads");
    let reference = scene.take_outputs("unsharded-2");
    assert!(reference.keys().any(|p| p.starts_with("masks")), "label maps written");
    assert!(reference.contains_key(Path::new("gaussians.ply")), "labelled PLY written");

    check(scene.run(1), "unsharded run, 1 thread");
    assert_same(&reference, &scene.take_outputs("unsharded-1"), "RAYON_NUM_THREADS=1 vs 2");

    for (count, threads) in [(3, 1), (2, 2)] {
        scene.shards(count, &(0..count).collect::<Vec<_>>(), threads);
        let output = check(scene.run(threads), "run after the shards");
        let stdout = String::from_utf8_lossy(&output.stdout);
        assert!(stdout.contains("6 of 6 views' merges came from the cache"), "{stdout}");
        let what = format!("{count} shards, RAYON_NUM_THREADS={threads}");
        assert_same(&reference, &scene.take_outputs(&format!("sharded-{count}")), &what);
    }
}

#[test]
fn unsharded_merge_fills_the_cache_run_reads() {
    let scene = Scene::new();
    check(scene.run(2), "run alone");
    let reference = scene.take_outputs("run-alone");
    check(scene.command("merge", &[], 2).output().expect("spawn merge"), "merge");
    let log = scene.out.join("merge").join("view_000.json");
    let first = std::fs::read(&log).expect("merge wrote its decisions");
    let masks = std::fs::read(scene.out.join("masks").join("view_000.png")).expect("merged regions");
    let text = String::from_utf8_lossy(&first).to_string();
    assert!(text.contains("\"decisions\"") && text.contains("\"input_regions\""), "{text}");
    // A rerun takes every view from the cache, decisions included, and writes the same bytes.
    check(scene.command("merge", &[], 2).output().expect("spawn merge"), "merge again");
    assert!(std::fs::read(&log).expect("log") == first, "the cached decisions differ");
    let merged = scene.out.join("cache").join("merge").join("view_000.merged.png");
    assert!(std::fs::read(merged).expect("cached merge") == masks, "merge's label map is run's merged map");
    let output = check(scene.run(2), "run after merge");
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(stdout.contains("6 of 6 views' merges came from the cache"), "{stdout}");
    std::fs::remove_dir_all(scene.out.join("merge")).expect("merge's own logs");
    assert_same(&reference, &scene.take_outputs("run-after-merge"), "run after merge");
}

#[test]
fn a_missing_shard_is_named_in_the_error() {
    let scene = Scene::new();
    scene.shards(3, &[0, 2], 2);
    let output = scene.run(2);
    assert!(!output.status.success(), "run must refuse while shard 1/3 is missing");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(stderr.contains("shard(s) 1/3 of 3"), "{stderr}");
    assert!(!scene.out.join("metrics.json").exists(), "nothing written");
    scene.shards(3, &[1], 2);
    check(scene.run(2), "run once every shard is there");
    // Settings the shards were not run with: the view and its shard are named, nothing is merged.
    let config = scene.out.with_file_name("other.toml");
    std::fs::write(&config, "[merge]\ntau_merge = 0.5\n").expect("config");
    let output =
        scene.command("run", &["--config", config.to_str().expect("utf-8")], 2).output().expect("run");
    assert!(!output.status.success(), "run must refuse merges made with other settings");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(stderr.contains("view `view_000`") && stderr.contains("shard 0/3"), "{stderr}");
}

#[test]
fn sharded_cues_write_what_one_run_writes() {
    let scene = Scene::new();
    let cues = |extra: &[&str]| {
        let mut args = vec!["cues", scene.root.to_str().expect("utf-8"), "--out"];
        args.push(scene.out.to_str().expect("utf-8"));
        args.extend(extra);
        splatseg(&args, 1)
    };
    check(cues(&[]).output().expect("spawn"), "unsharded cues");
    let reference = scene.take_outputs("cues-unsharded");
    assert_eq!(reference.keys().filter(|p| p.starts_with("log")).count(), 6, "one LoG map per view");
    let children: Vec<_> = ["0/2", "1/2"]
        .iter()
        .map(|s| cues(&["--shard", s]).stdout(std::process::Stdio::piped()).spawn().expect("spawn"))
        .collect();
    for child in children {
        check(child.wait_with_output().expect("shard ends"), "cues --shard");
    }
    assert_same(&reference, &scene.take_outputs("cues-sharded"), "cues in 2 shards");
}
