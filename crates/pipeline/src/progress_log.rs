//! Progress of long work when stderr is not a terminal (a piped or redirected log): instead of a
//! bar, the bar's text as a log line at least every [`LOG_EVERY`], so a log of a long run shows
//! that it moves and how far it is. The bars draw into [`LogLines`] (indicatif's `TermLike`), and
//! a steady tick redraws them while an item takes long, so a line comes even when no item ends.

use indicatif::{ProgressBar, ProgressDrawTarget, TermLike};
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// How often a log line is written while a bar runs on a stderr that is not a terminal.
pub const LOG_EVERY: Duration = Duration::from_secs(30);

/// Where the lines go and what time it is: `tracing` and the clock in a run, a buffer and a
/// hand-moved clock in tests.
pub struct LogSink {
    /// Writes one line.
    pub write: Box<dyn Fn(&str) + Send + Sync>,
    /// The time now.
    pub now: Box<dyn Fn() -> Instant + Send + Sync>,
}

impl LogSink {
    /// Lines to `tracing` at INFO, the system clock.
    pub fn tracing() -> Self {
        LogSink { write: Box::new(|line| tracing::info!("{line}")), now: Box::new(Instant::now) }
    }
}

/// A draw target that keeps the bar's last text and writes it as a line when `every` has passed
/// since the last line written, or since it was made (short work writes none).
pub struct LogLines {
    sink: LogSink,
    every: Duration,
    state: Mutex<LogState>,
}

struct LogState {
    /// The text drawn since the last flush.
    text: String,
    /// When the last line was written (at first: when the target was made).
    last: Instant,
}

impl LogLines {
    /// Lines every `every` into `sink`.
    pub fn new(sink: LogSink, every: Duration) -> Self {
        let last = (sink.now)();
        LogLines { sink, every, state: Mutex::new(LogState { text: String::new(), last }) }
    }

    fn keep(&self, s: &str) {
        if let Ok(mut state) = self.state.lock() {
            state.text.push_str(s);
        }
    }
}

impl std::fmt::Debug for LogLines {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LogLines").field("every", &self.every).finish()
    }
}

impl TermLike for LogLines {
    fn width(&self) -> u16 {
        100
    }
    fn move_cursor_up(&self, _: usize) -> std::io::Result<()> {
        Ok(())
    }
    fn move_cursor_down(&self, _: usize) -> std::io::Result<()> {
        Ok(())
    }
    fn move_cursor_right(&self, _: usize) -> std::io::Result<()> {
        Ok(())
    }
    fn move_cursor_left(&self, _: usize) -> std::io::Result<()> {
        Ok(())
    }
    fn write_line(&self, s: &str) -> std::io::Result<()> {
        self.keep(s);
        Ok(())
    }
    fn write_str(&self, s: &str) -> std::io::Result<()> {
        self.keep(s);
        Ok(())
    }
    fn clear_line(&self) -> std::io::Result<()> {
        Ok(())
    }
    /// The end of one draw: its text is written when a line is due.
    fn flush(&self) -> std::io::Result<()> {
        let Ok(mut state) = self.state.lock() else { return Ok(()) };
        let text = std::mem::take(&mut state.text);
        let line = text.trim();
        if line.is_empty() {
            return Ok(());
        }
        let now = (self.sink.now)();
        if now.saturating_duration_since(state.last) >= self.every {
            state.last = now;
            (self.sink.write)(line);
        }
        Ok(())
    }
}

/// Points `bar` at log lines every `every` into `sink` (drawn at most once a second, redrawn by
/// a steady tick so a line comes while one item takes long).
pub fn log_lines_into(bar: &ProgressBar, sink: LogSink, every: Duration) {
    bar.set_draw_target(ProgressDrawTarget::term_like_with_hz(Box::new(LogLines::new(sink, every)), 1));
    bar.enable_steady_tick(every.min(Duration::from_secs(1)).max(Duration::from_millis(100)));
}

/// When stderr is not a terminal, points `bar` at log lines every [`LOG_EVERY`] through `tracing`
/// (on a terminal the bar is drawn as it is).
pub fn log_when_piped(bar: &ProgressBar) {
    log_when_piped_every(bar, LOG_EVERY);
}

/// [`log_when_piped`] with lines at least every `every` (`splatseg cues` takes it from
/// `SPLATSEG_LOG_EVERY_SECS`).
pub fn log_when_piped_every(bar: &ProgressBar, every: Duration) {
    if !std::io::IsTerminal::is_terminal(&std::io::stderr()) {
        log_lines_into(bar, LogSink::tracing(), every);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::{Arc, Mutex};

    /// The lines a fake sink collected.
    type Lines = Arc<Mutex<Vec<String>>>;
    /// A clock moved by hand.
    type Clock = Arc<Mutex<Instant>>;

    /// A sink collecting its lines, and a clock moved by hand.
    fn fake() -> (LogSink, Lines, Clock) {
        let lines = Arc::new(Mutex::new(Vec::new()));
        let clock = Arc::new(Mutex::new(Instant::now()));
        let (l, c) = (lines.clone(), clock.clone());
        let sink = LogSink {
            write: Box::new(move |s| l.lock().expect("lines").push(s.to_string())),
            now: Box::new(move || *c.lock().expect("clock")),
        };
        (sink, lines, clock)
    }

    fn draw(target: &LogLines, text: &str) {
        target.clear_line().expect("clear");
        target.write_str(text).expect("write");
        target.flush().expect("flush");
    }

    #[test]
    fn a_line_once_every_interval_and_none_for_short_work() {
        let (sink, lines, clock) = fake();
        let target = LogLines::new(sink, LOG_EVERY);
        let advance = |secs: u64| *clock.lock().expect("clock") += Duration::from_secs(secs);
        draw(&target, "training [=>   ] 1/100");
        advance(10);
        draw(&target, "training [=>   ] 2/100");
        advance(19);
        draw(&target, "training [==>  ] 3/100");
        assert!(lines.lock().expect("lines").is_empty(), "a line before 30 s");
        advance(1);
        draw(&target, "training [===> ] 4/100");
        draw(&target, "   ");
        advance(29);
        draw(&target, "training [===> ] 5/100");
        advance(16);
        draw(&target, "training [====>] 6/100");
        let lines = lines.lock().expect("lines").clone();
        assert_eq!(lines, ["training [===> ] 4/100", "training [====>] 6/100"]);
    }

    #[test]
    fn a_progress_bar_draws_its_position_into_the_lines() {
        let (sink, lines, _clock) = fake();
        let bar = ProgressBar::new(3);
        bar.set_style(indicatif::ProgressStyle::with_template("{msg} {pos}/{len}").expect("template"));
        bar.set_message("merge");
        bar.set_draw_target(ProgressDrawTarget::term_like(Box::new(LogLines::new(sink, Duration::ZERO))));
        for _ in 0..3 {
            bar.inc(1);
        }
        bar.finish();
        let lines = lines.lock().expect("lines").clone();
        assert!(lines.iter().any(|l| l == "merge 3/3"), "{lines:?}");
    }
}
