//! Fuzz target: the `--config` TOML file, through the pipeline crate's own
//! `PipelineConfig::from_toml`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        let _ = splatseg_pipeline::PipelineConfig::from_toml(text, std::path::Path::new("splatseg.toml"));
    }
});
