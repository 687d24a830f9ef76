//! Fuzz target: the `--config` TOML file, through the binary's own `PipelineConfig::from_toml`
//! (the file is included, not copied).
#![no_main]

#[allow(dead_code)]
#[path = "../../src/pipeline/config.rs"]
mod config;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        let _ = config::PipelineConfig::from_toml(text, std::path::Path::new("splatseg.toml"));
    }
});
