//! The integration tests of `splatseg-scene`, one test binary (`--test integration`): one module per
//! file beside this one. One binary links once and runs its tests side by side; a file added here
//! must be declared below (`autotests = false` in Cargo.toml; the root `tests/test_layout.rs`
//! checks that none is left out).

mod colmap_fixture;

mod bad_format_input;
mod bad_scene_input;
mod colmap_reference;
mod colmap_round_trip;
mod fuzz_corpus_replay;
mod hostile_masks;
mod image_io_parity;
mod labels_png;
mod npy_read_write;
mod ply_reference;
mod ply_roundtrip;
mod real_data;
mod rle_codec;
mod sam_masks;
mod splat_formats;
mod transforms_load;
