//! A wall-clock timeline of one run, for finding where a process's time goes (which phase
//! runs while a core idles, how long a flush to disk waits): off unless the environment
//! variable `FPSOLVE_TIMELINE` is set, then each [`mark`] records the time since the first
//! mark and the thread, and [`print()`] writes them to stderr.
//!
//! A mark costs one relaxed atomic load when the timeline is off.

use std::sync::atomic::{AtomicU8, Ordering};
use std::sync::{Mutex, OnceLock};
use std::time::Instant;

/// 0: not read yet, 1: off, 2: on.
static STATE: AtomicU8 = AtomicU8::new(0);
static START: OnceLock<Instant> = OnceLock::new();
static MARKS: Mutex<Vec<(f64, String, &'static str)>> = Mutex::new(Vec::new());

fn on() -> bool {
    match STATE.load(Ordering::Relaxed) {
        1 => false,
        2 => true,
        _ => {
            let on = std::env::var_os("FPSOLVE_TIMELINE").is_some();
            STATE.store(if on { 2 } else { 1 }, Ordering::Relaxed);
            on
        }
    }
}

/// Records that `phase` was reached now (when `FPSOLVE_TIMELINE` is set).
///
/// ```
/// fpsolve::base::timeline::mark("start");
/// fpsolve::base::timeline::print(); // nothing unless FPSOLVE_TIMELINE is set
/// ```
pub fn mark(phase: &'static str) {
    if !on() {
        return;
    }
    let start = *START.get_or_init(Instant::now);
    let ms = start.elapsed().as_secs_f64() * 1e3;
    let thread = std::thread::current().name().map_or_else(
        || format!("{:?}", std::thread::current().id()),
        str::to_string,
    );
    if let Ok(mut marks) = MARKS.lock() {
        marks.push((ms, thread, phase));
    }
}

/// Writes the marks so far to stderr, in time order (when `FPSOLVE_TIMELINE` is set).
pub fn print() {
    if !on() {
        return;
    }
    if let Ok(mut marks) = MARKS.lock() {
        marks.sort_by(|a, b| a.0.total_cmp(&b.0));
        for (ms, thread, phase) in marks.iter() {
            eprintln!("timeline {ms:8.3} ms  {thread:<12} {phase}");
        }
    }
}
