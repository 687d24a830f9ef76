//! Damaged inputs and hostile conditions, as a user meets them through the binary: the message
//! and exit code for a camera larger than its image, non-finite Gaussians (skipped with one
//! warning, or refused with --strict), the log format off a terminal, and the lock on --out.

use splatseg_scene::ply::{read_ply, read_ply_rows};
use std::ffi::OsStr;
use std::path::Path;
use std::process::{Command, Output};

fn splatseg<S: AsRef<OsStr>>(args: &[S]) -> Output {
    splatseg_with_env(args, &[])
}

fn splatseg_with_env<S: AsRef<OsStr>>(args: &[S], env: &[(&str, &str)]) -> Output {
    let mut command = Command::new(env!("CARGO_BIN_EXE_splatseg"));
    command.args(args).env_remove("RUST_LOG").env_remove("NO_COLOR");
    for (k, v) in env {
        command.env(k, v);
    }
    command.output().expect("the splatseg binary runs")
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

fn utf8(path: &Path) -> &str {
    path.to_str().expect("utf-8 path")
}

/// A tiny synthetic capture (COLMAP text model, 64×48 images, SAM masks, gaussians.ply).
fn tiny_scene(dir: &Path) {
    let out = splatseg(&["synth", "--out", utf8(dir), "--views", "2", "--size", "64x48"]);
    assert!(out.status.success(), "synth failed: {}", stderr(&out));
}

fn run_args(scene: &Path, out: &Path) -> Vec<String> {
    let masks = scene.join("sam");
    ["run", utf8(scene), "--masks", utf8(&masks), "--out", utf8(out)].map(String::from).to_vec()
}

fn set_camera_line(scene: &Path, line: &str) {
    let path = scene.join("sparse/0/cameras.txt");
    let text = std::fs::read_to_string(&path).expect("cameras.txt");
    let kept: Vec<&str> = text.lines().filter(|l| l.starts_with('#')).collect();
    std::fs::write(&path, format!("{}\n{line}\n", kept.join("\n"))).expect("write cameras.txt");
}

#[test]
fn a_camera_declaring_a_huge_size_is_an_error_naming_cameras_txt_not_an_abort() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let scene = tmp.path().join("scene");
    tiny_scene(&scene);
    set_camera_line(&scene, "1 PINHOLE 3200000000 240000000 55.4 55.4 32.0 24.0");
    let out = splatseg(&run_args(&scene, &tmp.path().join("out")));
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "a clear error, not an abort (134): {err}");
    assert!(err.contains("camera 1 is 3200000000x240000000"), "{err}");
    assert!(err.contains("2^28"), "{err}");
    assert!(err.contains("cameras.txt"), "{err}");
    assert!(!err.contains("memory allocation"), "{err}");
}

#[test]
fn a_camera_larger_than_its_image_on_disk_is_refused_before_the_run_allocates() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let scene = tmp.path().join("scene");
    tiny_scene(&scene);
    set_camera_line(&scene, "1 PINHOLE 6400 4800 5540.0 5540.0 3200.0 2400.0");
    let out = splatseg(&run_args(&scene, &tmp.path().join("out")));
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("image is 64x48 but its camera 1 is 6400x4800"), "{err}");
    assert!(err.contains("view_000.png"), "{err}");
}

/// Writes the scene's PLY back with NaN / Inf in rows 0 (x), 5 (scale_1) and 7 (opacity);
/// returns the number of rows.
fn poison_ply(scene: &Path) -> usize {
    let path = scene.join("gaussians.ply");
    // `write_ply` refuses non-finite values, so patch the bytes of the clean file synth wrote.
    let n = read_ply(&path).expect("synthetic PLY").len();
    let bytes = std::fs::read(&path).expect("ply bytes");
    let body = bytes.windows(11).position(|w| w == b"end_header\n").expect("header end") + 11;
    let stride = (bytes.len() - body) / n;
    let header = String::from_utf8_lossy(&bytes[..body]).to_string();
    let props: Vec<&str> = header.lines().filter_map(|l| l.strip_prefix("property float ")).collect();
    let offset = |name: &str| 4 * props.iter().position(|p| *p == name).expect("float property");
    let mut patched = bytes.clone();
    for (row, prop, value) in
        [(0, "x", f32::NAN), (5, "scale_1", f32::INFINITY), (7, "opacity", f32::NEG_INFINITY)]
    {
        let at = body + row * stride + offset(prop);
        patched[at..at + 4].copy_from_slice(&value.to_le_bytes());
    }
    std::fs::write(&path, patched).expect("write poisoned PLY");
    n
}

#[test]
fn non_finite_gaussians_are_skipped_with_one_warning_and_labelled_minus_one_in_order() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let scene = tmp.path().join("scene");
    tiny_scene(&scene);
    let n = poison_ply(&scene);
    let input = read_ply_rows(&scene.join("gaussians.ply")).expect("lenient read");
    assert_eq!(input.non_finite, vec![0, 5, 7]);

    let out_dir = tmp.path().join("out");
    let out = splatseg(&run_args(&scene, &out_dir));
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(0), "{err}");
    let warnings: Vec<&str> = err.lines().filter(|l| l.contains("non-finite")).collect();
    assert_eq!(warnings.len(), 1, "one warning per file: {err}");
    assert!(warnings[0].contains(&format!("skipping 3 of {n} Gaussians")), "{err}");
    assert!(warnings[0].contains("non-finite value NaN in property 'x' at Gaussian 0"), "{err}");
    assert!(warnings[0].contains("gaussians.ply"), "{err}");

    // Same rows, same order, the skipped ones labelled -1 and kept as they were.
    let labelled = read_ply_rows(&out_dir.join("gaussians.ply")).expect("output PLY");
    assert_eq!(labelled.gaussians.len(), n);
    assert_eq!(labelled.non_finite, vec![0, 5, 7]);
    let ids = labelled.gaussians.object_ids.as_ref().expect("object_id");
    for &row in &[0, 5, 7] {
        assert_eq!(ids[row], -1, "row {row}");
    }
    assert!(ids.iter().any(|&id| id > 0), "the finite Gaussians are labelled");
    for i in (0..n).filter(|i| ![0, 5, 7].contains(i)) {
        assert_eq!(labelled.gaussians.means[i], input.gaussians.means[i], "row {i} kept in place");
    }

    // Edits leave the skipped rows out of what they write, with the same single warning.
    let picked = tmp.path().join("unlabelled.ply");
    let out =
        splatseg(&["extract", utf8(&out_dir.join("gaussians.ply")), "--ids", "-1", "--out", utf8(&picked)]);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(0), "{err}");
    assert_eq!(err.lines().filter(|l| l.contains("non-finite")).count(), 1, "{err}");
    let unlabelled = read_ply(&picked).expect("extract output is finite");
    let expected = ids.iter().enumerate().filter(|(i, &id)| id == -1 && ![0, 5, 7].contains(i)).count();
    assert_eq!(unlabelled.len(), expected);
}

#[test]
fn strict_refuses_a_ply_with_non_finite_values_naming_the_first() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let scene = tmp.path().join("scene");
    tiny_scene(&scene);
    poison_ply(&scene);
    let mut args = run_args(&scene, &tmp.path().join("out"));
    args.push("--strict".into());
    let out = splatseg(&args);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("non-finite value NaN in property 'x' at Gaussian 0"), "{err}");
    assert!(err.contains("gaussians.ply"), "{err}");
    assert!(!tmp.path().join("out/gaussians.ply").exists());
    let out = splatseg(&["objects", utf8(&scene.join("gaussians.ply")), "--strict"]);
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
}

#[test]
fn logs_off_a_terminal_carry_no_colour_and_the_flags_set_the_level() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let scene = tmp.path().join("scene");
    tiny_scene(&scene);
    let out_dir = tmp.path().join("out");
    let run = |extra: &[&str], env: &[(&str, &str)]| {
        let _ = std::fs::remove_dir_all(&out_dir);
        let mut args = run_args(&scene, &out_dir);
        args.extend(extra.iter().map(|a| a.to_string()));
        let out = splatseg_with_env(&args, env);
        assert!(out.status.success(), "{}", stderr(&out));
        stderr(&out)
    };
    let default = run(&[], &[]);
    assert!(default.contains(" INFO "), "{default}");
    assert!(!default.contains('\x1b'), "no ANSI escapes in a pipe: {default:?}");
    assert!(!default.contains("DEBUG"), "{default}");
    let quiet = run(&["--quiet"], &[]);
    assert!(!quiet.contains("INFO"), "{quiet}");
    let verbose = run(&["-v"], &[]);
    assert!(verbose.contains("DEBUG") && verbose.contains("inputs and settings key"), "{verbose}");
    assert!(!verbose.contains("TRACE"), "{verbose}");
    let from_env = run(&[], &[("RUST_LOG", "warn")]);
    assert!(!from_env.contains("INFO"), "RUST_LOG=warn: {from_env}");
    let from_env = run(&[], &[("RUST_LOG", "debug")]);
    assert!(from_env.contains("DEBUG"), "RUST_LOG=debug: {from_env}");
    let flag_wins = run(&["-q"], &[("RUST_LOG", "debug")]);
    assert!(!flag_wins.contains("DEBUG") && !flag_wins.contains("INFO"), "{flag_wins}");
}

/// Runs `splatseg info SCENE` under a pseudo-terminal with `script` (util-linux), when that
/// works here, and returns what reached the terminal.
fn on_a_terminal(env: &[(&str, &str)], scene: &Path) -> Option<String> {
    let binary = env!("CARGO_BIN_EXE_splatseg");
    let command = format!("{binary} info {}", scene.display());
    let mut script = Command::new("script");
    script.args(["-qec", &command, "/dev/null"]).env_remove("NO_COLOR").env_remove("RUST_LOG");
    for (k, v) in env {
        script.env(k, v);
    }
    let out = script.output().ok()?;
    out.status.success().then(|| String::from_utf8_lossy(&out.stdout).into_owned())
}

#[test]
fn a_terminal_gets_colour_unless_no_color_is_set() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let scene = tmp.path().join("scene");
    tiny_scene(&scene);
    // Make `info` log something: a PLY with a non-finite row gives one warning.
    poison_ply(&scene);
    let Some(coloured) = on_a_terminal(&[], &scene) else {
        eprintln!("skipping: `script` (util-linux) cannot give this test a pseudo-terminal here");
        return;
    };
    assert!(coloured.contains("non-finite"), "{coloured}");
    assert!(coloured.contains('\x1b'), "colour on a terminal: {coloured:?}");
    let plain = on_a_terminal(&[("NO_COLOR", "1")], &scene).expect("ran once already");
    assert!(plain.contains("non-finite"), "{plain}");
    assert!(!plain.contains("\x1b["), "NO_COLOR: {plain:?}");
}

#[cfg(unix)]
#[test]
fn a_second_writer_on_the_same_out_is_refused_and_a_stale_lock_does_not_block() {
    use std::os::unix::io::AsRawFd;
    let tmp = tempfile::tempdir().expect("temp dir");
    let scene = tmp.path().join("scene");
    tiny_scene(&scene);
    let out_dir = tmp.path().join("out");
    std::fs::create_dir_all(&out_dir).expect("out");
    let lock_path = out_dir.join(".splatseg.lock");
    // A lock file left by a killed run (its pid long gone) does not block.
    std::fs::write(&lock_path, "splatseg run (pid 999999999)").expect("stale lock");
    let out = splatseg(&run_args(&scene, &out_dir));
    assert!(out.status.success(), "a stale lock file must not block: {}", stderr(&out));
    assert_eq!(std::fs::read_to_string(&lock_path).expect("lock file"), "", "emptied on exit");

    // A live holder (this test, standing in for a concurrent run) makes run, cues and train fail.
    let holder = std::fs::OpenOptions::new().read(true).write(true).open(&lock_path).expect("open");
    std::fs::write(&lock_path, "splatseg run (pid 4242)").expect("holder name");
    // SAFETY: flock on a descriptor `holder` keeps open.
    assert_eq!(unsafe { libc::flock(holder.as_raw_fd(), libc::LOCK_EX | libc::LOCK_NB) }, 0);
    let own = |args: &[&str]| args.iter().map(|a| a.to_string()).collect::<Vec<String>>();
    for args in [
        run_args(&scene, &out_dir),
        own(&["cues", utf8(&scene), "--out", utf8(&out_dir)]),
        own(&["train", utf8(&scene), "--out", utf8(&out_dir), "--iterations", "2"]),
    ] {
        let out = splatseg(&args);
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(1), "{} must be refused: {err}", args[0]);
        assert!(err.contains("in use by splatseg run (pid 4242)"), "{err}");
        assert!(err.contains("same --out"), "{err}");
    }
    drop(holder);
    // The other tests of this binary spawn processes: a child forked while `holder` was open
    // shares its lock until it execs (microseconds, longer on a loaded machine). Retry briefly.
    let mut out = splatseg(&run_args(&scene, &out_dir));
    for _ in 0..20 {
        if out.status.success() || !stderr(&out).contains("in use by") {
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(100));
        out = splatseg(&run_args(&scene, &out_dir));
    }
    assert!(out.status.success(), "free again: {}", stderr(&out));
}
