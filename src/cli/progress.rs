//! Progress on stderr for the long commands.

use std::io::IsTerminal;

use fpsolve::job::Progress;

/// Progress on stderr: a spinner per stage and a bar with ETA for Monte Carlo; silent when
/// stderr is not a terminal or with `--quiet`.
pub(crate) struct Bar(Option<indicatif::ProgressBar>);

impl Bar {
    pub(crate) fn new(quiet: bool) -> Bar {
        if quiet || !std::io::stderr().is_terminal() {
            return Bar(None);
        }
        let bar = indicatif::ProgressBar::new_spinner();
        bar.enable_steady_tick(std::time::Duration::from_millis(120));
        Bar(Some(bar))
    }
    pub(crate) fn finish(&self) {
        if let Some(b) = &self.0 {
            b.finish_and_clear();
        }
    }
}

impl Progress for Bar {
    fn stage(&self, message: &str) {
        if let Some(b) = &self.0 {
            b.set_style(indicatif::ProgressStyle::default_spinner());
            b.set_message(message.to_string());
        }
    }
    fn advance(&self, done: u64, total: u64) {
        if let Some(b) = &self.0 {
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
    }
}
