//! Where log lines go and how they look: stderr, the level set by `--quiet` / `-v` / `-vv` (or
//! `RUST_LOG` when no flag is given), colour only on a terminal and never with `NO_COLOR`.

use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, Ordering};

/// True once `--quiet` was given: progress bars are hidden too.
static QUIET: AtomicBool = AtomicBool::new(false);

/// Whether `--quiet` was given (progress bars stay hidden).
pub fn quiet() -> bool {
    QUIET.load(Ordering::Relaxed)
}

/// The log filter: `--quiet` → warnings and errors, `-v` → debug, `-vv` (or more) → trace; with
/// none of them, `RUST_LOG` (any `EnvFilter` directive, e.g. `splatseg_lift=debug`) when set and
/// valid, else info.
pub fn filter_directive(quiet: bool, verbose: u8, rust_log: Option<&str>) -> String {
    match (quiet, verbose) {
        (true, _) => "warn".to_string(),
        (false, 1) => "debug".to_string(),
        (false, v) if v >= 2 => "trace".to_string(),
        _ => match rust_log.map(str::trim).filter(|s| !s.is_empty()) {
            Some(directive) if tracing_subscriber::EnvFilter::try_new(directive).is_ok() => {
                directive.to_string()
            }
            _ => "info".to_string(),
        },
    }
}

/// Colour escapes only when stderr is a terminal and `NO_COLOR` is unset or empty
/// (<https://no-color.org>).
pub fn use_colour(stderr_is_terminal: bool, no_color: Option<&std::ffi::OsStr>) -> bool {
    stderr_is_terminal && no_color.is_none_or(|v| v.is_empty())
}

/// Installs the stderr logger for the process.
pub fn init(quiet: bool, verbose: u8) {
    QUIET.store(quiet, Ordering::Relaxed);
    let rust_log = std::env::var("RUST_LOG").ok();
    let filter = tracing_subscriber::EnvFilter::new(filter_directive(quiet, verbose, rust_log.as_deref()));
    let colour = use_colour(std::io::stderr().is_terminal(), std::env::var_os("NO_COLOR").as_deref());
    tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_ansi(colour)
        .with_target(false)
        .init();
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flags_win_over_rust_log_which_wins_over_the_default() {
        assert_eq!(filter_directive(false, 0, None), "info");
        assert_eq!(filter_directive(false, 0, Some("splatseg_lift=debug")), "splatseg_lift=debug");
        assert_eq!(filter_directive(false, 0, Some("")), "info");
        assert_eq!(filter_directive(true, 0, Some("debug")), "warn");
        assert_eq!(filter_directive(false, 1, Some("warn")), "debug");
        assert_eq!(filter_directive(false, 2, None), "trace");
        assert_eq!(filter_directive(false, 5, None), "trace");
    }

    #[test]
    fn colour_needs_a_terminal_and_no_no_color() {
        use std::ffi::OsStr;
        assert!(use_colour(true, None));
        assert!(use_colour(true, Some(OsStr::new(""))));
        assert!(!use_colour(true, Some(OsStr::new("1"))));
        assert!(!use_colour(false, None));
    }
}
