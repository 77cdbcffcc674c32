//! Progress on stderr for the long commands: a live bar on a terminal, plain status lines at
//! most once a minute otherwise (a batch log, a Slurm output file).

use std::io::{IsTerminal, Write};
use std::sync::{Arc, Condvar, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use fpsolve::job::Progress;

/// The plain lines' interval when `FPSOLVE_PROGRESS_EVERY` (seconds) does not set another.
const EVERY: Duration = Duration::from_secs(60);

/// Progress on stderr: a spinner per stage and a bar with ETA for Monte Carlo on a
/// terminal; a status line at most once a minute when stderr is not a terminal; nothing with
/// `--quiet`.
pub(crate) enum Bar {
    Quiet,
    Terminal(indicatif::ProgressBar),
    Plain(Plain),
}

impl Bar {
    pub(crate) fn new(quiet: bool) -> Bar {
        if quiet {
            return Bar::Quiet;
        }
        if !std::io::stderr().is_terminal() {
            return Bar::Plain(Plain::start(interval()));
        }
        let bar = indicatif::ProgressBar::new_spinner();
        bar.enable_steady_tick(Duration::from_millis(120));
        Bar::Terminal(bar)
    }

    pub(crate) fn finish(&self) {
        match self {
            Bar::Quiet => {}
            Bar::Terminal(b) => b.finish_and_clear(),
            Bar::Plain(p) => p.stop(),
        }
    }
}

/// `FPSOLVE_PROGRESS_EVERY` in seconds (a positive number), else a minute.
fn interval() -> Duration {
    std::env::var("FPSOLVE_PROGRESS_EVERY")
        .ok()
        .and_then(|s| s.trim().parse::<f64>().ok())
        .filter(|s| s.is_finite() && *s > 0.0)
        .map_or(EVERY, Duration::from_secs_f64)
}

impl Progress for Bar {
    fn stage(&self, message: &str) {
        match self {
            Bar::Quiet => {}
            Bar::Terminal(b) => {
                b.set_style(indicatif::ProgressStyle::default_spinner());
                b.set_message(message.to_string());
            }
            Bar::Plain(p) => p.update(|s| {
                s.stage = message.to_string();
                s.parts = None;
            }),
        }
    }

    fn advance(&self, done: u64, total: u64) {
        match self {
            Bar::Quiet => {}
            Bar::Terminal(b) => {
                if b.length() != Some(total) {
                    b.set_length(total);
                    if let Ok(style) = indicatif::ProgressStyle::with_template(
                        "{msg} [{bar:40}] {pos}/{len} parts, {elapsed} elapsed, ETA {eta}",
                    ) {
                        b.set_style(style.progress_chars("=> "));
                    }
                }
                b.set_position(done);
            }
            Bar::Plain(p) => p.update(|s| {
                if s.parts.is_none_or(|(_, t, _)| t != total) {
                    s.parts = Some((done, total, Instant::now()));
                } else if let Some(parts) = &mut s.parts {
                    parts.0 = done;
                }
            }),
        }
    }
}

/// What the plain lines report: the stage, and the parts done of a stage that counts them
/// (with when the count started, for the ETA).
#[derive(Default)]
struct Status {
    stage: String,
    parts: Option<(u64, u64, Instant)>,
    stopped: bool,
}

/// A thread that writes the status every interval until stopped.
pub(crate) struct Plain {
    shared: Arc<(Mutex<Status>, Condvar)>,
    ticker: Mutex<Option<JoinHandle<()>>>,
}

impl Plain {
    fn start(every: Duration) -> Plain {
        let shared = Arc::new((Mutex::new(Status::default()), Condvar::new()));
        let theirs = Arc::clone(&shared);
        let started = Instant::now();
        let ticker = std::thread::spawn(move || {
            let (lock, wake) = &*theirs;
            let Ok(mut status) = lock.lock() else { return };
            loop {
                let Ok((s, timeout)) = wake.wait_timeout(status, every) else {
                    return;
                };
                status = s;
                if status.stopped {
                    return;
                }
                if timeout.timed_out() {
                    let _ = writeln!(std::io::stderr(), "{}", line(&status, started.elapsed()));
                }
            }
        });
        Plain {
            shared,
            ticker: Mutex::new(Some(ticker)),
        }
    }

    fn update(&self, f: impl FnOnce(&mut Status)) {
        if let Ok(mut s) = self.shared.0.lock() {
            f(&mut s);
        }
    }

    fn stop(&self) {
        self.update(|s| s.stopped = true);
        self.shared.1.notify_all();
        if let Some(t) = self.ticker.lock().ok().and_then(|mut t| t.take()) {
            let _ = t.join();
        }
    }
}

impl Drop for Plain {
    fn drop(&mut self) {
        self.stop();
    }
}

/// `fpsolve [12m05s] Monte Carlo: 12/64 parts, ETA 48m20s`.
fn line(status: &Status, elapsed: Duration) -> String {
    let stage = if status.stage.is_empty() {
        "working"
    } else {
        status.stage.as_str()
    };
    let mut s = format!("fpsolve [{}] {stage}", clock(elapsed));
    if let Some((done, total, since)) = status.parts {
        s += &format!(": {done}/{total} parts");
        if done > 0 && done < total {
            let per = since.elapsed().as_secs_f64() / done as f64;
            let left = Duration::from_secs_f64(per * (total - done) as f64);
            s += &format!(", ETA {}", clock(left));
        }
    }
    s
}

/// `1h02m03s`, `12m05s`, `7s`.
fn clock(d: Duration) -> String {
    let t = d.as_secs();
    let (h, m, s) = (t / 3600, t / 60 % 60, t % 60);
    match (h, m) {
        (0, 0) => format!("{s}s"),
        (0, _) => format!("{m}m{s:02}s"),
        _ => format!("{h}h{m:02}m{s:02}s"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn status_lines_say_the_stage_the_parts_and_the_time_left() {
        let mut status = Status {
            stage: "Monte Carlo".into(),
            ..Status::default()
        };
        assert_eq!(
            line(&status, Duration::from_secs(725)),
            "fpsolve [12m05s] Monte Carlo"
        );
        status.parts = Some((0, 64, Instant::now()));
        assert_eq!(
            line(&status, Duration::from_secs(3723)),
            "fpsolve [1h02m03s] Monte Carlo: 0/64 parts"
        );
        status.parts = Some((16, 64, Instant::now() - Duration::from_secs(60)));
        let l = line(&status, Duration::from_secs(7));
        // 16 parts in a minute: 48 left take three minutes (give or take the test's own time).
        assert!(
            l.starts_with("fpsolve [7s] Monte Carlo: 16/64 parts, ETA 3m0"),
            "{l}"
        );
    }
}
