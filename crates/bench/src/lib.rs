//! splatseg's measurements, callable from Rust (the binary's `bench` and `ablate` print them):
//!
//! - [`quality`]: the stress suite's quality over many synthetic scenes ([`suite`] scores one
//!   scene end to end, [`ceiling`] the oracle ceilings of its region maps); the reduced suite with
//!   its CI floors and golden digests is this crate's test `reduced_stress_suite_meets_its_floors_on_the_worst_decile`;
//! - [`scale`]: time and peak memory of `splatseg run` on a synthetic capture of a given size;
//! - [`ablate`]: the merge stage's ablation and sensitivity tables on a synthetic scene;
//! - [`args`]: the commands' arguments (clap's `Args` with the `cli` feature) and their requests.
//!
//! Errors are [`BenchError`].

pub mod ablate;
pub mod args;
#[cfg(test)]
mod blind_suite_tests;
pub mod ceiling;
mod error;
pub mod quality;
#[cfg(test)]
mod reduced;
pub mod scale;
pub mod suite;
#[cfg(test)]
mod suite_tests;

pub use args::{AblateArgs, BenchArgs, QualityArgs, ScaleArgs};
pub use error::{BenchError, Context, Result};
