//! `splatseg synth`: write a synthetic scene with ground truth as a capture folder.

use anyhow::Context;
use splatseg_synth::{generate, write, SynthArgs};
use std::io::Write;
use std::time::Instant;

/// Runs the command.
pub fn run(args: SynthArgs) -> anyhow::Result<()> {
    args.refuse_overwrite()?;
    let config = args.config()?;
    let started = Instant::now();
    let scene = generate(&config).context("generating the synthetic scene")?;
    let generated = started.elapsed();
    let summary = write(&args.out, &scene)
        .with_context(|| format!("writing the synthetic scene to {}", args.out.display()))?;
    let mut text = format!(
        "wrote {} files to {}: {} views of {}x{}, {} instances, {} Gaussians, {} simulated SAM masks \
         (generated in {:.2} s, written in {:.2} s)\n",
        summary.files,
        summary.root.display(),
        summary.views,
        config.width,
        config.height,
        summary.instances,
        summary.gaussians,
        summary.sam_masks,
        generated.as_secs_f64(),
        (started.elapsed() - generated).as_secs_f64()
    );
    text.push_str(&scene.hard_case_lines());
    // A closed pipe (e.g. `| head`) is not an error of the command: the files are written.
    let _ = std::io::stdout().write_all(text.as_bytes());
    Ok(())
}
