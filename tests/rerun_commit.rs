//! `run`'s outputs are committed as a whole (issue 28.2): a rerun with other settings, killed
//! with SIGKILL after it staged its first label map, while it commits, or at a random moment,
//! followed by a rerun with the first settings, leaves exactly the outputs of a clean run with
//! the first settings (no mixture, no staging folder, no temporary file); and a rerun on a scene
//! with fewer views leaves no label map of the views that are gone.
#![cfg(unix)]

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

fn binary() -> Command {
    let mut command = Command::new(env!("CARGO_BIN_EXE_splatseg"));
    command.env_remove("RUST_LOG").stdout(Stdio::null()).stderr(Stdio::null());
    command
}

fn s(p: &Path) -> String {
    p.to_str().expect("utf-8 path").to_string()
}

fn synth(scene: &Path, views: usize) {
    let status = binary()
        .args(["synth", "--out", &s(scene), "--views", &views.to_string(), "--size", "320x240"])
        .status()
        .expect("synth");
    assert!(status.success(), "synth failed");
}

fn run_args(scene: &Path, out: &Path, config: Option<&Path>) -> Vec<String> {
    let mut args = vec!["run".to_string(), s(scene), "--out".into(), s(out)];
    args.extend(["--masks".into(), s(&scene.join("sam")), "--features".into(), s(&scene.join("features"))]);
    if let Some(c) = config {
        args.extend(["--config".into(), s(c)]);
    }
    args
}

fn run_to_end(args: &[String]) {
    let status = binary().args(args).status().expect("spawn");
    assert!(status.success(), "splatseg {} failed", args.join(" "));
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

/// Every file of `out` outside `cache/` (the lock file excepted), with its bytes.
fn outputs(out: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    files_under(out)
        .into_iter()
        .map(|p| p.strip_prefix(out).expect("under out").to_path_buf())
        .filter(|rel| !rel.starts_with("cache") && !rel.ends_with(".splatseg.lock"))
        .map(|rel| {
            let bytes = std::fs::read(out.join(&rel)).expect("output");
            (rel, bytes)
        })
        .collect()
}

fn signal(child: &Child, sig: libc::c_int) {
    // SAFETY: `kill` on the pid of a child we have not reaped.
    unsafe { libc::kill(child.id() as libc::pid_t, sig) };
}

/// Where a kill is aimed.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Moment {
    /// After the first label map of the new run is staged, before the commit.
    FirstMapStaged,
    /// After the manifest was removed, during the renames.
    Committing,
    /// After this many milliseconds.
    After(u64),
}

/// Starts `args`, stops it (SIGSTOP) at `moment` and kills it (SIGKILL); returns whether the
/// stop landed at that moment (the process may have finished first).
fn kill_at(args: &[String], out: &Path, moment: Moment) -> bool {
    let staged_map = || {
        std::fs::read_dir(out.join(".staging/masks"))
            .map(|d| d.flatten().any(|e| e.file_name().to_string_lossy().ends_with(".png")))
            .unwrap_or(false)
    };
    let manifest = out.join("cache/run.json");
    let mut child = binary().args(args).spawn().expect("spawn");
    let start = Instant::now();
    let landed = loop {
        if child.try_wait().expect("status").is_some() || start.elapsed() > Duration::from_secs(120) {
            break false;
        }
        let now = match moment {
            Moment::FirstMapStaged => staged_map(),
            Moment::Committing => !manifest.exists() && staged_map(),
            Moment::After(ms) => start.elapsed() >= Duration::from_millis(ms),
        };
        if now {
            signal(&child, libc::SIGSTOP);
            // The condition still holds with the process frozen (it did not move on meanwhile).
            let still = match moment {
                Moment::FirstMapStaged => staged_map() && manifest.exists(),
                Moment::Committing => !manifest.exists(),
                Moment::After(_) => true,
            };
            break still && child.try_wait().expect("status").is_none();
        }
        std::thread::sleep(Duration::from_micros(200));
    };
    child.kill().ok();
    child.wait().expect("reap");
    landed
}

#[test]
fn a_killed_rerun_with_other_settings_never_leaves_a_mixture() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let scene = tmp.path().join("scene");
    synth(&scene, 6);
    let other = tmp.path().join("other.toml");
    std::fs::write(&other, "[merge]\ntau_merge = 0.7\n\n[lift]\ntau_var = 0.05\n").expect("config");

    // The outputs name their folder (`metrics.json`): every run below writes into `out`.
    let out = tmp.path().join("out");
    run_to_end(&run_args(&scene, &out, None));
    let reference = outputs(&out);
    let maps = |o: &[(PathBuf, Vec<u8>)]| {
        o.iter().filter(|(p, _)| p.starts_with("masks")).cloned().collect::<Vec<_>>()
    };
    assert_eq!(maps(&reference).len(), 6, "6 label maps");
    let changed = tmp.path().join("changed");
    run_to_end(&run_args(&scene, &changed, Some(&other)));
    assert_ne!(maps(&outputs(&changed)), maps(&reference), "the other settings must change the label maps");

    let mut landed = Vec::new();
    let moments = [
        Moment::FirstMapStaged,
        Moment::Committing,
        Moment::After(50),
        Moment::After(300),
        Moment::After(900),
    ];
    for moment in moments {
        // Up to 8 tries for each moment, each from the clean run's outputs (what the last rerun
        // left, checked below).
        let mut hit = false;
        for _ in 0..8 {
            hit = kill_at(&run_args(&scene, &out, Some(&other)), &out, moment);
            run_to_end(&run_args(&scene, &out, None));
            let again = outputs(&out);
            let names = |o: &[(PathBuf, Vec<u8>)]| o.iter().map(|(p, _)| p.clone()).collect::<Vec<_>>();
            assert_eq!(names(&again), names(&reference), "files after a kill at {moment:?} and a rerun");
            for ((path, bytes), (_, expected)) in again.iter().zip(&reference) {
                assert!(
                    bytes == expected,
                    "{} differs after a kill at {moment:?} and a rerun",
                    path.display()
                );
            }
            let temps = files_under(&out)
                .into_iter()
                .filter(|p| p.file_name().is_some_and(|n| n.to_string_lossy().starts_with(".tmp")))
                .count();
            assert_eq!(temps, 0, "temporary files survived the rerun after a kill at {moment:?}");
            if hit {
                break;
            }
        }
        println!("kill at {moment:?}: {}", if hit { "landed" } else { "missed (the run was past it)" });
        landed.push((moment, hit));
    }
    assert!(
        landed.iter().any(|&(m, hit)| m == Moment::FirstMapStaged && hit),
        "no kill landed after the first label map was staged: {landed:?}"
    );
}

#[test]
fn a_rerun_on_fewer_views_leaves_no_label_map_of_the_views_gone() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let (more, fewer) = (tmp.path().join("more"), tmp.path().join("fewer"));
    synth(&more, 5);
    synth(&fewer, 3);
    let out = tmp.path().join("out");
    run_to_end(&run_args(&more, &out, None));
    let maps = |dir: &str| std::fs::read_dir(out.join(dir)).expect("maps").count();
    assert_eq!((maps("masks"), maps("overlays")), (5, 5));
    run_to_end(&run_args(&fewer, &out, None));
    assert_eq!((maps("masks"), maps("overlays")), (3, 3), "label maps of views the scene no longer has");
    let rerun = outputs(&out);
    std::fs::remove_dir_all(&out).expect("clear");
    run_to_end(&run_args(&fewer, &out, None));
    assert_eq!(rerun, outputs(&out), "the rerun's outputs equal a clean run's");
}
