//! The integration tests of `splatseg-render`, one test binary (`--test integration`): one module per
//! file beside this one. One binary links once and runs its tests side by side; a file added here
//! must be declared below (`autotests = false` in Cargo.toml; the root `tests/test_layout.rs`
//! checks that none is left out).

mod common;

mod bad_input;
mod determinism;
mod finite_differences;
mod garden;
mod optimise;
mod parity;
