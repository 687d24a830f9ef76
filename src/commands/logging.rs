//! Where log lines go and how they look: stderr, the level set by `--quiet` / `-v` / `-vv` (or
//! `RUST_LOG` when no flag is given), colour only on a terminal and never with `NO_COLOR`.

use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, Ordering};
use tracing_subscriber::filter::{LevelFilter, Targets};
use tracing_subscriber::layer::SubscriberExt;
use tracing_subscriber::util::SubscriberInitExt;

/// True once `--quiet` was given: progress bars are hidden too.
static QUIET: AtomicBool = AtomicBool::new(false);

/// Whether `--quiet` was given (progress bars stay hidden).
pub fn quiet() -> bool {
    QUIET.load(Ordering::Relaxed)
}

/// The log filter: `--quiet` → warnings and errors, `-v` → debug, `-vv` (or more) → trace; with
/// none of them, `RUST_LOG` (directives read by [`parse_filter`], e.g. `splatseg_lift=debug`) when
/// set and valid, else info.
pub fn filter_directive(quiet: bool, verbose: u8, rust_log: Option<&str>) -> String {
    match (quiet, verbose) {
        (true, _) => "warn".to_string(),
        (false, 1) => "debug".to_string(),
        (false, v) if v >= 2 => "trace".to_string(),
        _ => match rust_log.map(str::trim).filter(|s| !s.is_empty()) {
            Some(directive) if parse_filter(directive).is_some() => directive.to_string(),
            _ => "info".to_string(),
        },
    }
}

/// The filter of comma-separated `RUST_LOG` directives, `None` if any is invalid. A directive is
/// `level` (for every target), `target` (every level) or `target=level` (`target=`: every level); a
/// target matches itself and what starts with it (`splatseg_lift` matches
/// `splatseg_lift::visibility`), the most specific one deciding; a level is `off`, `error`, `warn`,
/// `info`, `debug`, `trace` (any case) or 0-5. Empty directives are skipped, and with none at all only
/// errors are shown, as tracing-subscriber's `EnvFilter` does; its span and field directives
/// (`[span]`, `{field}`) are invalid here.
pub fn parse_filter(directives: &str) -> Option<Targets> {
    let mut filter = Targets::new();
    let mut any = false;
    for directive in directives.split(',').filter(|d| !d.is_empty()) {
        filter = match directive.split_once('=') {
            Some((target, "")) if is_target(target) => filter.with_target(target, LevelFilter::TRACE),
            Some((target, level)) if is_target(target) => {
                filter.with_target(target, level.parse::<LevelFilter>().ok()?)
            }
            Some(_) => return None,
            None => match directive.parse::<LevelFilter>() {
                Ok(level) => filter.with_default(level),
                Err(_) if is_target(directive) => filter.with_target(directive, LevelFilter::TRACE),
                Err(_) => return None,
            },
        };
        any = true;
    }
    Some(if any { filter } else { filter.with_default(LevelFilter::ERROR) })
}

/// A target as `RUST_LOG` names it: a module path such as `splatseg_lift::visibility` (it starts
/// with a letter, digit, `_`, `:` or `-`, and holds no whitespace, `[`, `]`, `{` or `}`).
fn is_target(target: &str) -> bool {
    target.starts_with(|c: char| c.is_alphanumeric() || "_:-".contains(c))
        && !target.contains(|c: char| c.is_whitespace() || "[]{}".contains(c))
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
    let filter = parse_filter(&filter_directive(quiet, verbose, rust_log.as_deref()))
        .expect("filter_directive returns a valid directive");
    let colour = use_colour(std::io::stderr().is_terminal(), std::env::var_os("NO_COLOR").as_deref());
    tracing_subscriber::fmt()
        // The filter decides; the builder's own level (info by default) must not cap it.
        .with_max_level(LevelFilter::TRACE)
        .with_writer(std::io::stderr)
        .with_ansi(colour)
        .with_target(false)
        .finish()
        .with(filter)
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
    fn rust_log_directives_set_levels_per_target() {
        use tracing::Level;
        let info = parse_filter("info").unwrap();
        assert!(info.would_enable("splatseg_lift::visibility", &Level::INFO));
        assert!(!info.would_enable("splatseg_lift::visibility", &Level::DEBUG));

        let lift = parse_filter("splatseg_lift=debug").unwrap();
        assert!(lift.would_enable("splatseg_lift::visibility", &Level::DEBUG));
        assert!(!lift.would_enable("splatseg_lift", &Level::TRACE));
        assert!(!lift.would_enable("splatseg_merge", &Level::ERROR), "no default: other targets are off");

        let mixed = parse_filter("warn,splatseg_pipeline=trace").unwrap();
        assert!(mixed.would_enable("splatseg_pipeline::run", &Level::TRACE));
        assert!(mixed.would_enable("splatseg_lift", &Level::WARN));
        assert!(!mixed.would_enable("splatseg_lift", &Level::INFO));

        let bare_target = parse_filter("DEBUG,splatseg_scene,splatseg_cues=").unwrap();
        assert!(bare_target.would_enable("splatseg_scene::ply", &Level::TRACE));
        assert!(bare_target.would_enable("splatseg_cues", &Level::TRACE));
        assert!(!bare_target.would_enable("splatseg_merge", &Level::TRACE));
        assert!(!parse_filter("0").unwrap().would_enable("a", &Level::ERROR));

        let only_commas = parse_filter(",").unwrap();
        assert!(only_commas.would_enable("splatseg", &Level::ERROR));
        assert!(!only_commas.would_enable("splatseg", &Level::WARN));
    }

    #[test]
    fn an_invalid_rust_log_is_ignored() {
        for invalid in [
            "splatseg_lift=loud",
            "a=b=c",
            "warn, splatseg_lift=debug",
            "[span]=debug",
            "splatseg_lift[{id}]=debug",
            "=debug",
            " ",
        ] {
            assert!(parse_filter(invalid).is_none(), "{invalid:?}");
            assert_eq!(
                filter_directive(false, 0, Some(&format!("debug,{invalid},warn"))),
                "info",
                "{invalid:?}"
            );
        }
        assert_eq!(filter_directive(false, 0, Some("debug,splatseg_lift=6")), "info");
        assert_eq!(
            filter_directive(false, 0, Some("  warn,splatseg_pipeline=trace ")),
            "warn,splatseg_pipeline=trace"
        );
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
