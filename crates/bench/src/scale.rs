//! `bench scale`: time and peak memory of `splatseg run` on a synthetic capture of a given size
//! (views × pixels × Gaussians), per stage. No Python: the capture is written by `splatseg-synth`.

use crate::error::{bail, Context};
use splatseg_pipeline::StageProfile;
use splatseg_synth::{Family, SynthConfig};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Most distinct views `bench scale` renders (further views repeat them): a 1,000-view capture
/// costs the disk and synthesis time of 100.
pub const DISTINCT_VIEWS: usize = 100;

/// The capture to measure on.
#[derive(Clone, Debug)]
pub struct ScaleRequest {
    /// Views of the capture.
    pub views: usize,
    /// Image size, `(width, height)`.
    pub size: (u32, u32),
    /// Gaussians in the PLY.
    pub gaussians: usize,
    /// Scene seed.
    pub seed: u64,
    /// Most distinct views rendered; further views repeat them (`bench scale`: [`DISTINCT_VIEWS`]).
    pub distinct_views: usize,
    /// Working folder (captures and outputs; several GB for large captures).
    pub dir: PathBuf,
}

/// Writes the capture of `args` (unless it is there), runs `exe run` on it in a child process
/// (`exe`: the `splatseg` binary) and returns the report: one row per stage with its wall time
/// and peak memory, and the whole run's.
pub fn scale(args: &ScaleRequest, exe: &Path) -> crate::Result<String> {
    if args.views == 0 || args.gaussians == 0 || args.distinct_views == 0 {
        bail!("--views, --gaussians and the distinct views must be at least 1");
    }
    let mut text = String::new();
    let (w, h) = args.size;
    let name = format!("scene-{}v-{w}x{h}-{}g-s{}", args.views, args.gaussians, args.seed);
    let scene = args.dir.join(&name);
    let started = Instant::now();
    let wanted = ready_marker(args);
    let ready = std::fs::read_to_string(scene.join("ready.json")).ok();
    if ready.as_deref() != Some(wanted.as_str()) {
        write_capture(args, &scene)?;
        writeln!(text, "wrote the capture {} in {:.1} s", scene.display(), started.elapsed().as_secs_f64())?;
    }
    let out = args.dir.join(format!("out-{name}"));
    if out.exists() {
        std::fs::remove_dir_all(&out).with_context(|| format!("cannot clear {}", out.display()))?;
    }
    let s = |p: &Path| p.to_string_lossy().to_string();
    let run_args = vec![
        "run".to_string(),
        s(&scene),
        "--masks".into(),
        s(&scene.join("sam")),
        "--features".into(),
        s(&scene.join("features")),
        "--depth".into(),
        s(&scene.join("depth")),
        "--out".into(),
        s(&out),
        "-q".into(),
    ];
    let (seconds, peak) = measure_child(exe, &run_args)?;
    let profile = out.join("cache").join("profile.json");
    let json =
        std::fs::read_to_string(&profile).with_context(|| format!("cannot read {}", profile.display()))?;
    let stages: Vec<StageProfile> = serde_json::from_str(&json)?;
    let threads = std::env::var("RAYON_NUM_THREADS").unwrap_or_else(|_| "all cores".into());
    writeln!(
        text,
        "\nrun on {} views × {w}×{h} × {} Gaussians (rayon threads: {threads}; load 1/5/15 min: {})\n",
        args.views,
        args.gaussians,
        load_average()
    )?;
    writeln!(text, "| stage | wall s | peak RSS MB |\n| --- | ---: | ---: |")?;
    for st in &stages {
        let mb = st.peak_rss_bytes.map_or("–".into(), |b| format!("{:.0}", b as f64 / 1048576.0));
        writeln!(text, "| {} | {:.2} | {mb} |", st.stage, st.seconds)?;
        for (part, secs) in &st.parts {
            writeln!(text, "| ↳ {part} (thread s, summed over threads) | {secs:.2} | |")?;
        }
    }
    // The child resets its peak at every stage, so the whole run's peak is the largest of the
    // stages'. The child's own maximum RSS from the kernel is only a fallback (no stage peaks
    // outside Linux): it also counts this process's peak at the moment the child was spawned (the
    // kernel records the spawning image's high-water mark at exec), which after writing a large
    // capture in this process is the capture writer's memory, not the run's.
    let stage_peak = stages.iter().filter_map(|s| s.peak_rss_bytes).max();
    let peak = stage_peak.or(peak);
    let peak_mb = peak.map_or("–".into(), |b| format!("{:.0}", b as f64 / 1048576.0));
    writeln!(text, "| **whole run** (child process) | **{seconds:.2}** | **{peak_mb}** |")?;
    writeln!(text, "\nrow: | {} | {w}×{h} | {} | {seconds:.1} | {peak_mb} |", args.views, args.gaussians)?;
    Ok(text)
}

/// The 1-, 5- and 15-minute load averages.
fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|t| t.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|_| "?".into())
}

/// Runs this binary with `args`; wall seconds and the child's peak resident memory (bytes).
fn measure_child(exe: &Path, args: &[String]) -> crate::Result<(f64, Option<u64>)> {
    let started = Instant::now();
    let child = std::process::Command::new(exe)
        .args(args)
        .stdout(std::process::Stdio::null())
        .spawn()
        .context("cannot start `splatseg run`")?;
    let (ok, peak) = wait_with_peak(child)?;
    let seconds = started.elapsed().as_secs_f64();
    if !ok {
        bail!("`splatseg {}` failed", args.join(" "));
    }
    Ok((seconds, peak))
}

#[cfg(unix)]
fn wait_with_peak(child: std::process::Child) -> crate::Result<(bool, Option<u64>)> {
    let pid = child.id() as libc::pid_t;
    let mut status = 0;
    // SAFETY: an all-zero rusage is a valid value; wait4 fills it for our own child.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    // SAFETY: pid is our child, not yet waited for; the pointers are valid for the call.
    let r = unsafe { libc::wait4(pid, &mut status, 0, &mut usage) };
    if r != pid {
        bail!("waiting for `splatseg run`: {}", std::io::Error::last_os_error());
    }
    let ok = libc::WIFEXITED(status) && libc::WEXITSTATUS(status) == 0;
    Ok((ok, Some(usage.ru_maxrss as u64 * 1024)))
}

#[cfg(not(unix))]
fn wait_with_peak(mut child: std::process::Child) -> crate::Result<(bool, Option<u64>)> {
    Ok((child.wait()?.success(), None))
}

/// Writes the capture into `dir`.
fn write_capture(args: &ScaleRequest, dir: &Path) -> crate::Result<()> {
    let (w, h) = args.size;
    let distinct = args.views.min(args.distinct_views);
    let mut config: SynthConfig = Family::Rooms.config(args.seed);
    config.sam = config.sam.scaled(w as f64 / config.width as f64);
    config.views = distinct;
    config.width = w;
    config.height = h;
    if dir.exists() {
        std::fs::remove_dir_all(dir).with_context(|| format!("cannot clear {}", dir.display()))?;
    }
    let mut scene = splatseg_synth::generate(&config)?;
    resize_gaussians(&mut scene, args.gaussians);
    let base: Vec<splatseg_scene::View> = scene.scene.views.clone();
    for v in distinct..args.views {
        let mut view = base[v % distinct].clone();
        view.stem = splatseg_synth::view_stem(v);
        view.name = format!("{}.png", view.stem);
        view.image_path = Path::new("images").join(&view.name);
        view.image_id = v as u32 + 1;
        scene.scene.views.push(view);
    }
    splatseg_synth::write(dir, &scene)?;
    for v in distinct..args.views {
        let (from, to) = (splatseg_synth::view_stem(v % distinct), splatseg_synth::view_stem(v));
        for (folder, ext) in [("images", "png"), ("sam", "json"), ("features", "npy"), ("depth", "npy")] {
            let src = dir.join(folder).join(format!("{from}.{ext}"));
            let dst = dir.join(folder).join(format!("{to}.{ext}"));
            if std::fs::hard_link(&src, &dst).is_err() {
                std::fs::copy(&src, &dst).with_context(|| format!("cannot copy {}", src.display()))?;
            }
        }
    }
    splatseg_scene::atomic::write_bytes_atomic(&dir.join("ready.json"), ready_marker(args).as_bytes())?;
    Ok(())
}

/// What `DIR/<scene>/ready.json` holds once the capture for `args` is complete.
fn ready_marker(args: &ScaleRequest) -> String {
    let distinct = args.views.min(args.distinct_views);
    serde_json::json!({
        "views": args.views,
        "distinct_views": distinct,
        "size": [args.size.0, args.size.1],
        "gaussians": args.gaussians,
        "seed": args.seed,
    })
    .to_string()
}

/// Subsamples the Gaussians evenly to `target`, or repeats them (each copy offset by a small,
/// deterministic fraction of its own scale) up to `target`; ground-truth ids follow.
fn resize_gaussians(scene: &mut splatseg_synth::SynthScene, target: usize) {
    let n = scene.gaussians.len();
    if n == 0 || n == target {
        return;
    }
    let indices: Vec<usize> = if target < n {
        (0..target).map(|i| i * n / target).collect()
    } else {
        (0..target).map(|i| i % n).collect()
    };
    let mut g = scene.gaussians.select(&indices);
    for (i, mean) in g.means.iter_mut().enumerate().skip(n.min(target)) {
        let scale = g.log_scales[i].iter().copied().fold(f32::MIN, f32::max).exp();
        let h = (i as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15);
        for (k, m) in mean.iter_mut().enumerate() {
            let u = ((h >> (16 * k)) & 0xffff) as f32 / 65535.0 - 0.5;
            *m += u * scale;
        }
    }
    scene.gaussian_ids = indices.iter().map(|&i| scene.gaussian_ids[i]).collect();
    scene.gaussians = g;
}
