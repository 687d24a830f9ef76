//! Finding headless Chromium for the browser tests: where it is missing, a test skips with a
//! message, except on CI (the environment variable `CI` set and not empty, as CI services and
//! `.ci/run` set it), where it fails: a newcomer's `cargo test` says the browser tests were
//! skipped, and a CI run never passes without running them.

use splatseg_view::browser::{find_chromium, ChromiumPaths};

/// Chromium and chromedriver, or `None` after saying that `test` is skipped; panics (the test
/// fails) when they are missing on CI.
pub fn chromium_or_skip(test: &str) -> Option<ChromiumPaths> {
    if let Some(paths) = find_chromium() {
        return Some(paths);
    }
    let missing = "chromium and chromedriver are not installed (Debian: apt-get install chromium \
                   chromium-driver; .ci/run installs them)";
    if std::env::var_os("CI").is_some_and(|v| !v.is_empty()) {
        panic!("{test}: {missing}, and CI is set: browser tests must run on CI");
    }
    eprintln!("SKIPPED {test}: {missing}");
    None
}
