//! `splatseg info PATH`: what splatseg finds in a scene folder, before running anything on it.

use splatseg_pipeline::args::InfoArgs;

/// Runs the command: prints the report, and fails (exit code 1) when some image (at full size, or
/// a down-scaled copy in `images_<f>/`) cannot be loaded at its camera's size.
pub fn run(args: InfoArgs) -> anyhow::Result<()> {
    let report = splatseg_pipeline::scene_info::inspect(&args.request(super::run_options().strict))?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        print!("{}", report.to_text());
    }
    // Images the pipeline cannot load make the scene unusable: say so with the exit code too.
    let problems =
        report.downscaled.iter().map(|d| (format!(" at --resolution {}", d.factor), &d.image_problems));
    for (at, found) in std::iter::once((String::new(), &report.image_problems)).chain(problems) {
        if let Some(first) = found.first() {
            anyhow::bail!("{} image(s) cannot be used{at} as they are; the first: {first}", found.len());
        }
    }
    Ok(())
}
