//! The integration tests of `splatseg-merge`, one test binary (`--test integration`): one module per
//! file beside this one. One binary links once and runs its tests side by side; a file added here
//! must be declared below (`autotests = false` in Cargo.toml; the root `tests/test_layout.rs`
//! checks that none is left out).

mod hand_built;
mod kept_apart;
mod separate_wholes;
mod synthetic;
