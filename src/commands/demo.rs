//! `splatseg demo`: the whole pipeline on the embedded synthetic scene, end to end.

use splatseg_pipeline::args::DemoArgs;

/// Runs the demo.
pub fn run(args: DemoArgs) -> anyhow::Result<()> {
    splatseg_pipeline::demo::run_demo(&args.request(super::run_options()), &mut |text| println!("{text}"))?;
    Ok(())
}
