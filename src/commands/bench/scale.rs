//! `splatseg bench scale`: time and peak memory of `run` on a synthetic capture of a given size
//! (views × pixels × Gaussians), per stage. No Python: the capture is written by `splatseg-synth`.

use anyhow::{bail, Context};
use clap::Args as ClapArgs;
use splatseg_pipeline::StageProfile;
use splatseg_synth::{Family, SynthConfig};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Measure `splatseg run` on a synthetic capture of N views × W×H pixels × G Gaussians.
pub const LONG_ABOUT: &str = "Measure `splatseg run` on a synthetic capture of N views × W×H pixels × G Gaussians.

Writes the capture once into DIR/scene-<N>v-<W>x<H>-<G>g-s<seed>/ (a `rooms` scene with SAM JSON masks, \
`.npy` features and depth, as a user brings them; reused when it is there), then runs `splatseg run` on it \
in a child process with a fresh output folder, and prints the wall time and peak resident memory of the whole \
run and of each stage (from its --profile: VmHWM reset at each stage; the run's peak is the largest), \
with the thread time of each stage's parts (surface depth and visibility, merge, votes, render back…; \
summed over threads, so parts may add up to more than the stage's wall time).

The scene has min(N, --distinct-views) distinct views; beyond that, views repeat the distinct ones (same \
image, masks, cues and pose under a new name), so a 1,000-view capture costs the disk of 100. The Gaussians \
are the synthetic ones subsampled evenly to G, or repeated with a small deterministic offset up to G.

Example: splatseg bench scale --views 100 --size 1280x960 --gaussians 1000000 --dir /tmp/scale";

/// Seed of the synthetic capture (one fixed scene, so runs compare).
const SCENE_SEED: u64 = 0;

/// Arguments of `bench scale`.
#[derive(Debug, ClapArgs)]
pub struct Args {
    /// Views of the capture.
    #[arg(long, default_value_t = 100)]
    pub views: usize,
    /// Image size, WIDTHxHEIGHT.
    #[arg(long, value_parser = crate::commands::parse_size, default_value = "1280x960")]
    pub size: (u32, u32),
    /// Gaussians in the PLY.
    #[arg(long, default_value_t = 1_000_000)]
    pub gaussians: usize,
    /// Most distinct views rendered; further views repeat them.
    #[arg(long, default_value_t = 100)]
    pub distinct_views: usize,
    /// Working folder (captures and outputs; several GB for large captures).
    #[arg(long, default_value = "bench-scale")]
    pub dir: PathBuf,
}

/// Runs the benchmark.
pub fn run(args: Args) -> anyhow::Result<()> {
    if args.views == 0 || args.gaussians == 0 || args.distinct_views == 0 {
        bail!("--views, --gaussians and --distinct-views must be at least 1");
    }
    let (w, h) = args.size;
    let name = format!("scene-{}v-{w}x{h}-{}g-s{}", args.views, args.gaussians, SCENE_SEED);
    let scene = args.dir.join(&name);
    let started = Instant::now();
    let wanted = ready_marker(&args);
    let ready = std::fs::read_to_string(scene.join("ready.json")).ok();
    if ready.as_deref() != Some(wanted.as_str()) {
        write_capture(&args, &scene)?;
        println!("wrote the capture {} in {:.1} s", scene.display(), started.elapsed().as_secs_f64());
    }
    let out = args.dir.join(format!("out-{name}"));
    if out.exists() {
        std::fs::remove_dir_all(&out).with_context(|| format!("cannot clear {}", out.display()))?;
    }
    let profile = args.dir.join(format!("profile-{name}.json"));
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
        "--profile".into(),
        s(&profile),
        "-q".into(),
    ];
    let (seconds, peak) = measure_child(&run_args)?;
    let text =
        std::fs::read_to_string(&profile).with_context(|| format!("cannot read {}", profile.display()))?;
    let stages: Vec<StageProfile> = serde_json::from_str(&text)?;
    let threads = std::env::var("RAYON_NUM_THREADS").unwrap_or_else(|_| "all cores".into());
    println!(
        "\nrun on {} views × {w}×{h} × {} Gaussians (rayon threads: {threads}; load 1/5/15 min: {})\n",
        args.views,
        args.gaussians,
        load_average()
    );
    println!("| stage | wall s | peak RSS MB |\n| --- | ---: | ---: |");
    for st in &stages {
        let mb = st.peak_rss_bytes.map_or("–".into(), |b| format!("{:.0}", b as f64 / 1048576.0));
        println!("| {} | {:.2} | {mb} |", st.stage, st.seconds);
        for (part, secs) in &st.parts {
            println!("| ↳ {part} (thread s, summed over threads) | {secs:.2} | |");
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
    println!("| **whole run** (child process) | **{seconds:.2}** | **{peak_mb}** |");
    println!("\nrow: | {} | {w}×{h} | {} | {seconds:.1} | {peak_mb} |", args.views, args.gaussians);
    Ok(())
}

/// The 1-, 5- and 15-minute load averages.
fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|t| t.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|_| "?".into())
}

/// Runs this binary with `args`; wall seconds and the child's peak resident memory (bytes).
fn measure_child(args: &[String]) -> anyhow::Result<(f64, Option<u64>)> {
    let exe = std::env::current_exe().context("cannot find the splatseg binary")?;
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
fn wait_with_peak(child: std::process::Child) -> anyhow::Result<(bool, Option<u64>)> {
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
fn wait_with_peak(mut child: std::process::Child) -> anyhow::Result<(bool, Option<u64>)> {
    Ok((child.wait()?.success(), None))
}

/// Writes the capture into `dir`.
fn write_capture(args: &Args, dir: &Path) -> anyhow::Result<()> {
    let (w, h) = args.size;
    let distinct = args.views.min(args.distinct_views);
    let mut config: SynthConfig = Family::Rooms.config(SCENE_SEED);
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
fn ready_marker(args: &Args) -> String {
    let distinct = args.views.min(args.distinct_views);
    serde_json::json!({
        "views": args.views,
        "distinct_views": distinct,
        "size": [args.size.0, args.size.1],
        "gaussians": args.gaussians,
        "seed": SCENE_SEED,
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
