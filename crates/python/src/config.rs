//! The pipeline's settings from Python: a `--config` TOML path, or a dict with the TOML's tables
//! (`{"merge": {"tau_merge": 0.8}}`), which goes through the same reader, so the same keys,
//! ranges and messages apply.

use crate::errors;
use pyo3::PyResult;
use splatseg_pipeline::PipelineConfig;
use std::path::{Path, PathBuf};

/// What names a dict config in error messages.
const DICT_NAME: &str = "<config dict>";

/// The settings from a TOML file, a dict passed as JSON text by the Python layer, or the defaults.
pub fn pipeline_config(path: Option<PathBuf>, json: Option<String>) -> PyResult<PipelineConfig> {
    match (path, json) {
        (Some(path), _) => PipelineConfig::from_file(&path).map_err(errors::from_pipeline),
        (None, Some(json)) => {
            let value: toml::Value = serde_json::from_str(&json).map_err(|e| {
                errors::value(format!(
                    "config dict: {e} (values must be numbers, strings, booleans, lists or dicts)"
                ))
            })?;
            if !value.is_table() {
                return Err(errors::value(
                    "config must be a dict of tables, e.g. {\"merge\": {\"tau_merge\": 0.8}}",
                ));
            }
            let text = toml::to_string(&value).map_err(|e| errors::value(format!("config dict: {e}")))?;
            PipelineConfig::from_toml(&text, Path::new(DICT_NAME)).map_err(errors::from_pipeline)
        }
        (None, None) => Ok(PipelineConfig::default()),
    }
}
