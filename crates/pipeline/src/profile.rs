//! Wall time and peak resident memory per stage of a run (`splatseg run` writes them to
//! `OUT/cache/profile.json`; `splatseg bench scale` prints them). On Linux the peak is the process's `VmHWM`, reset at the start of
//! every stage (`/proc/self/clear_refs`), so each stage reports its own peak; elsewhere it is
//! absent.

use serde::{Deserialize, Serialize};
use std::time::Instant;

/// One stage's cost.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct StageProfile {
    /// Stage name.
    pub stage: String,
    /// Wall time, seconds.
    pub seconds: f64,
    /// Peak resident memory during the stage, bytes (Linux only).
    pub peak_rss_bytes: Option<u64>,
    /// Thread time of named parts of the stage, seconds summed over threads (parts run in
    /// parallel, so they may add up to more than the wall time).
    #[serde(default)]
    pub parts: Vec<(String, f64)>,
}

/// Thread time spent in named parts of a stage, summed over the threads that run them.
#[derive(Debug, Default)]
pub struct PartTimes {
    seconds: std::sync::Mutex<Vec<(&'static str, f64)>>,
}

impl PartTimes {
    /// Runs `f`, adding its time to part `name`.
    pub fn time<T>(&self, name: &'static str, f: impl FnOnce() -> T) -> T {
        let started = Instant::now();
        let out = f();
        let dt = started.elapsed().as_secs_f64();
        if let Ok(mut parts) = self.seconds.lock() {
            match parts.iter_mut().find(|(n, _)| *n == name) {
                Some((_, s)) => *s += dt,
                None => parts.push((name, dt)),
            }
        }
        out
    }

    /// The parts timed so far, in order of first use; resets them.
    pub fn take(&self) -> Vec<(String, f64)> {
        self.seconds
            .lock()
            .map(|mut p| p.drain(..).map(|(n, s)| (n.to_string(), s)).collect())
            .unwrap_or_default()
    }
}

/// The `tracing` target of the events marking each stage's start and end (debug level; the
/// Python binding shows them at INFO as the run's progress).
pub const STAGE_TARGET: &str = "splatseg_pipeline::stage";

/// Times stages one after another.
pub struct Profiler {
    stages: Vec<StageProfile>,
    current: Option<(String, Instant)>,
    parts: Vec<(String, f64)>,
}

impl Profiler {
    /// Starts with `first`.
    pub fn start(first: &str) -> Profiler {
        let mut p = Profiler { stages: Vec::new(), current: None, parts: Vec::new() };
        p.next(first);
        p
    }

    /// Ends the current stage and starts `name`.
    pub fn next(&mut self, name: &str) {
        self.end();
        release_freed_memory();
        reset_peak_rss();
        tracing::debug!(target: STAGE_TARGET, "stage {name}: started");
        self.current = Some((name.to_string(), Instant::now()));
    }

    /// Attaches the thread time of the current stage's parts ([`PartTimes::take`]).
    pub fn parts(&mut self, parts: Vec<(String, f64)>) {
        self.parts.extend(parts);
    }

    fn end(&mut self) {
        if let Some((stage, started)) = self.current.take() {
            let seconds = started.elapsed().as_secs_f64();
            let peak_rss_bytes = peak_rss_bytes();
            tracing::debug!(
                target: STAGE_TARGET,
                "stage {stage}: {seconds:.2} s, peak {} MB",
                peak_rss_bytes.map_or("?".to_string(), |b| (b >> 20).to_string())
            );
            for (part, s) in &self.parts {
                tracing::debug!("  {part}: {s:.2} thread s");
            }
            let parts = std::mem::take(&mut self.parts);
            self.stages.push(StageProfile { stage, seconds, peak_rss_bytes, parts });
        }
    }

    /// Ends the current stage; every stage's cost.
    pub fn finish(mut self) -> Vec<StageProfile> {
        self.end();
        self.stages
    }
}

/// Returns the heap memory the finished stage freed to the operating system (glibc keeps freed
/// chunks resident otherwise: after matching on 1,000 views that was ~70 MB the later stages
/// never used). No-op where the allocator is not glibc's.
pub fn release_freed_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: malloc_trim only returns free heap pages to the kernel; it touches no live
    // allocation and may be called at any time from any thread.
    unsafe {
        libc::malloc_trim(0);
    }
}

/// Resets the process's peak resident memory to its current value (Linux; ignored elsewhere).
pub fn reset_peak_rss() {
    let _ = std::fs::write("/proc/self/clear_refs", "5");
}

/// The process's peak resident memory since start or the last reset (`VmHWM`), bytes.
pub fn peak_rss_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stages_are_recorded_in_order_with_their_peaks() {
        let mut p = Profiler::start("a");
        let block = vec![1u8; 64 << 20];
        std::hint::black_box(&block);
        p.next("b");
        drop(block);
        let stages = p.finish();
        assert_eq!(stages.iter().map(|s| s.stage.as_str()).collect::<Vec<_>>(), ["a", "b"]);
        if let Some(a) = stages[0].peak_rss_bytes {
            assert!(a >= 64 << 20, "stage a held 64 MB: {a}");
        }
        assert!(stages.iter().all(|s| s.seconds >= 0.0));
    }
}
