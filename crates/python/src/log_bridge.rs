//! The pipeline's `tracing` events as records of Python's `logging` (logger `splatseg`), so a
//! notebook sees each stage start and end, warnings about the inputs, and what each stage decided.
//!
//! The extension is the application here (as the `splatseg` binary is for the command line), so
//! it installs the process's `tracing` subscriber once, at import; the level threshold lives in
//! that subscriber's layer (no static of ours). Events of any thread are
//! forwarded: a worker thread takes the GIL for the call to `logging`, which is why every call
//! into the pipeline releases the GIL while it runs. Which levels are forwarded follows the
//! logger's effective level, read at the start of every call ([`follow_python_level`]), so events
//! below it cost no GIL.

use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::fmt::Write as _;
use std::sync::atomic::{AtomicU8, Ordering};
use tracing::field::{Field, Visit};
use tracing::{Event, Level, Subscriber};
use tracing_subscriber::layer::{Context, Layer, SubscriberExt};

/// The logger every record goes to.
pub const LOGGER: &str = "splatseg";

/// Python's numeric levels.
const PY_DEBUG: u8 = 10;
const PY_INFO: u8 = 20;
const PY_WARNING: u8 = 30;
const PY_ERROR: u8 = 40;

fn python_level(level: &Level) -> u8 {
    match *level {
        Level::ERROR => PY_ERROR,
        Level::WARN => PY_WARNING,
        Level::INFO => PY_INFO,
        // TRACE goes to DEBUG too: Python's logging has no lower standard level.
        _ => PY_DEBUG,
    }
}

/// Forwards events at or above a Python level.
struct PythonLogging {
    /// The `splatseg` logger's effective level when a call started.
    threshold: AtomicU8,
}

/// The message and the other fields of an event, as one line.
#[derive(Default)]
struct Line {
    message: String,
    fields: String,
}

impl Visit for Line {
    fn record_debug(&mut self, field: &Field, value: &dyn std::fmt::Debug) {
        if field.name() == "message" {
            let _ = write!(self.message, "{value:?}");
        } else {
            let _ = write!(self.fields, " {}={value:?}", field.name());
        }
    }

    fn record_str(&mut self, field: &Field, value: &str) {
        if field.name() == "message" {
            self.message.push_str(value);
        } else {
            let _ = write!(self.fields, " {}={value}", field.name());
        }
    }
}

/// The Python level of an event: its own, but INFO for the start and end of each pipeline stage
/// (debug events of [`splatseg_pipeline::profile::STAGE_TARGET`]): a run's progress.
fn level_of(metadata: &tracing::Metadata<'_>) -> u8 {
    if metadata.target() == splatseg_pipeline::profile::STAGE_TARGET {
        PY_INFO
    } else {
        python_level(metadata.level())
    }
}

impl<S: Subscriber> Layer<S> for PythonLogging {
    fn register_callsite(&self, _: &'static tracing::Metadata<'static>) -> tracing::subscriber::Interest {
        // The threshold changes with the Python logger: decide per event, never cache.
        tracing::subscriber::Interest::sometimes()
    }

    fn enabled(&self, metadata: &tracing::Metadata<'_>, _: Context<'_, S>) -> bool {
        level_of(metadata) >= self.threshold.load(Ordering::Relaxed)
    }

    fn on_event(&self, event: &Event<'_>, _: Context<'_, S>) {
        let level = level_of(event.metadata());
        if level < self.threshold.load(Ordering::Relaxed) {
            return;
        }
        let mut line = Line::default();
        event.record(&mut line);
        let text = line.message + &line.fields;
        let target = event.metadata().target().to_string();
        Python::attach(|py| {
            let logged = (|| -> PyResult<()> {
                let logger = py.import("logging")?.call_method1("getLogger", (LOGGER,))?;
                let extra = PyDict::new(py);
                extra.set_item("rust_target", target)?;
                let kwargs = PyDict::new(py);
                kwargs.set_item("extra", extra)?;
                logger.call_method("log", (level, "%s", text), Some(&kwargs))?;
                Ok(())
            })();
            // A failing handler must not take the pipeline down; Python prints it.
            if let Err(e) = logged {
                e.print(py);
            }
        });
    }
}

/// Installs the forwarding subscriber as the process's default (once per process; a subscriber
/// some other code set first is left in place, and then nothing is forwarded).
pub fn install() {
    let layer = PythonLogging { threshold: AtomicU8::new(PY_WARNING) };
    let _ = tracing::subscriber::set_global_default(tracing_subscriber::registry().with(layer));
}

/// Reads the `splatseg` logger's effective level into the installed layer (found through the
/// default dispatcher, no state of our own), so events below it are not forwarded.
pub fn follow_python_level(py: Python<'_>) {
    let level = py
        .import("logging")
        .and_then(|l| l.call_method1("getLogger", (LOGGER,)))
        .and_then(|l| l.call_method0("getEffectiveLevel"))
        .and_then(|l| l.extract::<i64>());
    let level = level.map_or(PY_WARNING, |l| l.clamp(0, 255) as u8);
    tracing::dispatcher::get_default(|dispatch| {
        if let Some(layer) = dispatch.downcast_ref::<PythonLogging>() {
            layer.threshold.store(level, Ordering::Relaxed);
        }
    });
}
