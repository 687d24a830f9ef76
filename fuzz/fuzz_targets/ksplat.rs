//! Fuzz target: `splatseg_scene::fuzzing::ksplat` (see its docs for what the bytes are).
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| splatseg_scene::fuzzing::ksplat(data));
