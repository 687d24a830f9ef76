//! Crash safety: `run`, `cues`, `train` and `apply` are killed with SIGKILL at random (seeded) moments.
//! After every kill, no file where a complete output is expected is truncated or half-written
//! (every PNG, PLY, JSON and .npy in the output folder reads whole; temporary files may remain);
//! a rerun then resumes and gives byte-identical outputs to an uninterrupted run.
//!
//! CI runs until 3 kills per command have landed while the command ran (kills that come after it
//! finished are retried, and counted apart). The harness mode asks for more and prints a table:
//! `SPLATSEG_KILLS=20 cargo test --release --test integration kill_harness -- --nocapture`.
#![cfg(unix)]

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn binary() -> Command {
    let mut command = Command::new(env!("CARGO_BIN_EXE_splatseg"));
    command.env_remove("RUST_LOG").stdout(Stdio::null()).stderr(Stdio::null());
    command
}

fn kills_per_command() -> usize {
    std::env::var("SPLATSEG_KILLS").ok().and_then(|v| v.parse().ok()).unwrap_or(3)
}

/// A seeded xorshift64* stream of uniform numbers in [0, 1).
struct Uniform(u64);

impl Uniform {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn files_under(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let Ok(entries) = std::fs::read_dir(dir) else { return out };
    for entry in entries.flatten() {
        let path = entry.path();
        if path.is_dir() {
            out.extend(files_under(&path));
        } else {
            out.push(path);
        }
    }
    out.sort();
    out
}

fn is_temp_or_lock(path: &Path) -> bool {
    let name = path.file_name().map(|n| n.to_string_lossy().to_string()).unwrap_or_default();
    name.starts_with(".tmp") || name == ".splatseg.lock"
}

/// Every output file reads whole; returns how many files were checked.
fn check_complete(out: &Path) -> usize {
    let mut checked = 0;
    for path in files_under(out).into_iter().filter(|p| !is_temp_or_lock(p)) {
        let bytes = std::fs::read(&path).expect("readable");
        let ext = path.extension().map(|e| e.to_string_lossy().to_string()).unwrap_or_default();
        let problem = match ext.as_str() {
            "png" => splatseg_scene::image_io::decode_rgb8_alpha(&bytes).err().map(|e| e.to_string()),
            "ply" => splatseg_scene::ply::parse_ply_bytes_rows(&bytes).err(),
            "json" => serde_json::from_slice::<serde_json::Value>(&bytes).err().map(|e| e.to_string()),
            "npy" => splatseg_scene::npy::parse_npy(&bytes).err(),
            "md" => (!bytes.ends_with(b"\n")).then(|| "does not end with a newline".to_string()),
            _ => bytes.is_empty().then(|| "empty".to_string()),
        };
        if let Some(problem) = problem {
            panic!("{} is incomplete after a kill: {problem}", path.display());
        }
        checked += 1;
    }
    checked
}

/// `(relative path, bytes)` of every output outside `cache/` (the cache only has to be usable).
fn outputs(out: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    files_under(out)
        .into_iter()
        .filter(|p| !is_temp_or_lock(p))
        .map(|p| p.strip_prefix(out).expect("under out").to_path_buf())
        .filter(|rel| !rel.starts_with("cache"))
        .map(|rel| {
            let bytes = std::fs::read(out.join(&rel)).expect("output");
            (rel, bytes)
        })
        .collect()
}

struct Report {
    command: &'static str,
    /// Processes started and then sent SIGKILL.
    attempts: usize,
    /// Of those, the ones still running when the signal came (the count asked for).
    mid_run: usize,
    files_checked: usize,
    temp_left: usize,
    reference_secs: f64,
}

/// Kills `args(out)` `kills` times and checks each time (see the module docs).
fn harness(command: &'static str, work: &Path, args: impl Fn(&Path) -> Vec<String>, seed: u64) -> Report {
    let out = work.join(format!("{command}_out"));
    let run_to_end = |what: &str| {
        let status = binary().args(args(&out)).status().expect("spawn");
        assert!(status.success(), "{command}: {what} failed");
    };
    let start = Instant::now();
    run_to_end("the uninterrupted run");
    let reference_secs = start.elapsed().as_secs_f64();
    let reference = outputs(&out);
    assert!(!reference.is_empty(), "{command} wrote nothing");
    let mut uniform = Uniform(seed | 1);
    let wanted = kills_per_command();
    let mut report =
        Report { command, attempts: 0, mid_run: 0, files_checked: 0, temp_left: 0, reference_secs };
    while report.mid_run < wanted {
        let k = report.attempts;
        assert!(
            k < 10 * wanted + 10,
            "{command}: too few kills landed while it ran ({} of {k})",
            report.mid_run
        );
        report.attempts += 1;
        // Even kills start from nothing; odd kills hit a rerun resuming from the last one.
        if k.is_multiple_of(2) {
            std::fs::remove_dir_all(&out).expect("clear the output folder");
        }
        let delay = Duration::from_secs_f64(uniform.next() * 0.9 * reference_secs);
        let mut child = binary().args(args(&out)).spawn().expect("spawn");
        std::thread::sleep(delay);
        if child.try_wait().expect("status").is_none() {
            report.mid_run += 1;
        }
        child.kill().ok(); // SIGKILL
        child.wait().expect("reap");
        report.files_checked += check_complete(&out);
        let is_temp = |p: &&PathBuf| p.file_name().is_some_and(|n| n.to_string_lossy().starts_with(".tmp"));
        report.temp_left += files_under(&out).iter().filter(is_temp).count();
        run_to_end("the rerun after a kill");
        let again = outputs(&out);
        let names = |o: &[(PathBuf, Vec<u8>)]| o.iter().map(|(p, _)| p.clone()).collect::<Vec<_>>();
        assert_eq!(names(&again), names(&reference), "{command}: the rerun after kill {k} wrote other files");
        for ((path, bytes), (_, expected)) in again.iter().zip(&reference) {
            assert!(bytes == expected, "{command}: {} differs after kill {k} and a rerun", path.display());
        }
    }
    report
}

fn synth(scene: &Path) {
    let status = binary()
        .args(["synth", "--out", scene.to_str().expect("utf-8"), "--views", "3", "--size", "96x72"])
        .status()
        .expect("synth");
    assert!(status.success());
}

#[test]
fn run_cues_and_train_survive_sigkill_and_resume_to_identical_outputs() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let scene = tmp.path().join("scene");
    synth(&scene);
    let s = |p: &Path| p.to_str().expect("utf-8").to_string();
    let scene_str = s(&scene);
    let save_config = tmp.path().join("save.toml");
    std::fs::write(&save_config, "[train]\nsave_iterations = [20, 40]\n").expect("config");
    let reports = [
        harness(
            "run",
            tmp.path(),
            |out| {
                let masks = s(&scene.join("sam"));
                vec!["run".into(), scene_str.clone(), "--masks".into(), masks, "--out".into(), s(out)]
            },
            0x5eed_0001,
        ),
        harness(
            "cues",
            tmp.path(),
            |out| {
                // SAM's masks (the tiny random-weight fixture) and the LoG maps
                let sam =
                    s(&Path::new(env!("CARGO_MANIFEST_DIR"))
                        .join("crates/models/tests/fixtures/sam_tiny.pth"));
                vec!["cues".into(), scene_str.clone(), "--out".into(), s(out), "--sam".into(), sam]
            },
            0x5eed_0002,
        ),
        harness(
            "train",
            tmp.path(),
            |out| {
                let ply = s(&scene.join("gaussians.ply"));
                let config = s(&save_config);
                let args = ["train", &scene_str, "--gaussians", &ply, "--out", &s(out), "--iterations", "40"];
                let mut args: Vec<String> = args.iter().map(|a| a.to_string()).collect();
                args.extend(["--config".into(), config]);
                args
            },
            0x5eed_0003,
        ),
    ];
    println!("| command | SIGKILLs sent | landed mid-run | output files checked after kills | temp files left by the kills (removed by the rerun) | uninterrupted run (s) |");
    println!("| --- | ---: | ---: | ---: | ---: | ---: |");
    for r in &reports {
        println!(
            "| {} | {} | {} | {} | {} | {:.2} |",
            r.command, r.attempts, r.mid_run, r.files_checked, r.temp_left, r.reference_secs
        );
        assert_eq!(r.mid_run, kills_per_command(), "{}", r.command);
    }
}

/// A copy of the folder `from` at `to` (files and folders; `to` must not exist).
fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).expect("mkdir");
    for entry in std::fs::read_dir(from).expect("list").flatten() {
        let (source, target) = (entry.path(), to.join(entry.file_name()));
        if source.is_dir() {
            copy_dir(&source, &target);
        } else {
            std::fs::copy(&source, &target).expect("copy");
        }
    }
}

/// Issue 60: `apply` killed with SIGKILL at seeded moments, half of the time on the run's own
/// outputs and half on outputs an earlier (killed, then finished) apply left. After every kill each
/// file reads whole, and while the run's manifest is there the outputs are all the previous ones or
/// all the edited ones (a kill between removing and writing it back leaves it pending in the
/// staging folder); a rerun of apply then gives the bytes of an uninterrupted apply.
#[test]
fn apply_survives_sigkill_and_a_rerun_gives_the_uninterrupted_bytes() {
    use splatseg_edit::edits::{write_edits, Box3, Edits, Operation, EDITS_VERSION};
    let tmp = tempfile::tempdir().expect("temp dir");
    let scene = tmp.path().join("scene");
    let status = binary()
        .args(["synth", "--out", scene.to_str().expect("utf-8"), "--views", "6", "--size", "192x144"])
        .status()
        .expect("synth");
    assert!(status.success());
    let s = |p: &Path| p.to_str().expect("utf-8").to_string();
    let pristine = tmp.path().join("pristine");
    let run = ["run", &s(&scene), "--masks", &s(&scene.join("sam")), "--out", &s(&pristine)];
    assert!(binary().args(run).status().expect("spawn").success(), "run");
    // A merge of the two largest objects, a box split of the next and a name.
    let g = splatseg_scene::ply::read_ply_rows(&pristine.join("gaussians.ply")).expect("PLY").gaussians;
    let ids = g.object_ids.clone().expect("ids");
    let mut counts = std::collections::BTreeMap::<i32, usize>::new();
    for &id in ids.iter().filter(|&&id| id > 0) {
        *counts.entry(id).or_default() += 1;
    }
    let mut by_size: Vec<(usize, i32)> = counts.into_iter().map(|(id, n)| (n, id)).collect();
    by_size.sort_unstable_by(|a, b| b.cmp(a));
    let (a, b, c) = (by_size[0].1, by_size[1].1, by_size[2].1);
    let first = ids.iter().position(|&id| id == c).expect("a Gaussian of c");
    let region = Box3 { centre: g.means[first].map(f64::from), half_size: [0.3; 3], rotation: None };
    let operations = vec![
        Operation::Merge { ids: vec![a, b], into: None },
        Operation::SplitBox { object: c, region, new_id: None },
        Operation::Rename { id: a.min(b), name: "the pair".into() },
    ];
    let inputs = splatseg_pipeline::apply::edit_inputs(&pristine).expect("the run's identity");
    write_edits(&pristine.join("edits.json"), &Edits { version: EDITS_VERSION, inputs, operations })
        .expect("edits");
    let previous = outputs(&pristine);

    let out = tmp.path().join("out");
    let apply = |what: &str| {
        assert!(binary().args(["apply", &s(&out)]).status().expect("spawn").success(), "apply: {what}");
    };
    copy_dir(&pristine, &out);
    let start = Instant::now();
    apply("the uninterrupted apply");
    let reference_secs = start.elapsed().as_secs_f64();
    let reference = outputs(&out);
    assert!(reference != previous, "the edits changed the outputs");
    let whole = |o: &[(PathBuf, Vec<u8>)]| -> Vec<(PathBuf, Vec<u8>)> {
        o.iter().filter(|(p, _)| !p.starts_with(".staging")).cloned().collect()
    };

    let mut uniform = Uniform(0x5eed_0060);
    let (wanted, mut landed, mut attempts) = (kills_per_command(), 0, 0);
    while landed < wanted {
        assert!(
            attempts < 10 * wanted + 10,
            "apply: too few kills landed while it ran ({landed} of {attempts})"
        );
        if attempts % 2 == 0 {
            std::fs::remove_dir_all(&out).expect("clear");
            copy_dir(&pristine, &out);
        }
        attempts += 1;
        let before = whole(&outputs(&out));
        let delay = Duration::from_secs_f64(uniform.next() * 0.9 * reference_secs);
        let mut child = binary().args(["apply", &s(&out)]).spawn().expect("spawn");
        std::thread::sleep(delay);
        landed += usize::from(child.try_wait().expect("status").is_none());
        child.kill().ok(); // SIGKILL
        child.wait().expect("reap");
        check_complete(&out);
        let now = whole(&outputs(&out));
        if out.join("cache/run.json").exists() {
            assert!(
                now == before || now == whole(&reference),
                "apply: after kill {attempts} the outputs are neither the previous ones nor the edited ones"
            );
        } else {
            assert!(out.join(".staging/manifest.pending").is_file(), "kill {attempts}: the manifest is lost");
        }
        apply("the rerun after a kill");
        let again = outputs(&out);
        let names = |o: &[(PathBuf, Vec<u8>)]| o.iter().map(|(p, _)| p.clone()).collect::<Vec<_>>();
        assert_eq!(
            names(&again),
            names(&reference),
            "apply: the rerun after kill {attempts} wrote other files"
        );
        for ((path, bytes), (_, expected)) in again.iter().zip(&reference) {
            assert!(bytes == expected, "apply: {} differs after kill {attempts} and a rerun", path.display());
        }
    }
    println!("apply: {attempts} SIGKILLs sent, {landed} mid-run; uninterrupted apply {reference_secs:.2} s");
}
