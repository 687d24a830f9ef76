//! The integration tests of `splatseg`, one test binary (`--test integration`): one module per
//! file beside this one. One binary links once and runs its tests side by side; a file added here
//! must be declared below (`autotests = false` in Cargo.toml; the root `tests/test_layout.rs`
//! checks that none is left out).

mod apply_edits;
mod apply_repairs;
mod architecture_doc;
mod bad_inputs;
mod bench_scale;
mod chromium;
mod cli;
mod clip_objects;
mod compact_formats;
mod cues_models;
mod golden_outputs;
mod kill_harness;
mod lift_api;
mod mask_input;
mod no_overwrite;
mod no_process_state;
mod reliability;
mod render_garden_cli;
mod rerun_commit;
mod settings_budget;
mod shards;
mod test_layout;
mod thin_binary;
mod view_browser;
mod view_cli;
mod view_edit_browser;
mod view_repair_browser;
mod view_server;
