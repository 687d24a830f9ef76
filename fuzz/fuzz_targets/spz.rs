//! Fuzz target: `splatseg_scene::fuzzing::spz` (see its docs for what the bytes are).
#![no_main]

libfuzzer_sys::fuzz_target!(init: splatseg_scene::fuzzing::spz_init(), |data: &[u8]| splatseg_scene::fuzzing::spz(data));
