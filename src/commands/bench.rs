//! `splatseg bench` and `splatseg ablate`: measurements that take minutes, printed as tables
//! (`splatseg_bench`).

use anyhow::Context;
use splatseg_bench::args::What;
use splatseg_bench::{ablate, quality, scale, AblateArgs, BenchArgs};
use std::io::Write;

/// Runs the chosen benchmark: the quality suite (progress on stderr), the scale run or the identity
/// study.
pub fn run(args: BenchArgs) -> anyhow::Result<()> {
    match args.what {
        What::Quality(a) => {
            a.refuse_overwrite()?;
            let text = quality::quality(&a.into_request()?, &mut |line| eprintln!("{line}"))?;
            let _ = std::io::stdout().write_all(text.as_bytes());
        }
        What::Scale(a) => {
            let exe = std::env::current_exe().context("cannot find the splatseg binary")?;
            print!("{}", scale::scale(&a.request(), &exe)?);
        }
        What::Identity(a) => {
            for request in a.requests(super::run_options()) {
                splatseg_pipeline::demo::run_demo(&request, &mut |text| println!("{text}"))?;
            }
        }
    }
    Ok(())
}

/// Runs `splatseg ablate`.
pub fn ablate(args: AblateArgs) -> anyhow::Result<()> {
    print!("{}", ablate::ablate(&args.request()?)?);
    Ok(())
}
