//! The integration tests of `splatseg-models`, one test binary (`--test integration`): one module per
//! file beside this one. One binary links once and runs its tests side by side; a file added here
//! must be declared below (`autotests = false` in Cargo.toml; the root `tests/test_layout.rs`
//! checks that none is left out).

mod common;

mod clip_hf_parity;
mod clip_parity;
mod depth_anything_parity;
mod dinov2_parity;
mod mobile_sam_parity;
mod sam_decoder_without_avx512;
mod sam_parity;
mod sam_shared_decoder;
