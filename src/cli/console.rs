//! The console's standard output, which the reader may close (`fpsolve … | head -1`) or
//! which may fail (`> /dev/full`): Rust ignores SIGPIPE, so `println!` would panic there.
//!
//! Everything the commands print goes through [`print`] (the `say!` macro). A closed pipe
//! ends the printing quietly, the run going on to commit its files; any other write error is
//! reported once on stderr, and [`Console::state`] tells `main` which exit status it makes.

use std::io::Write;
use std::sync::atomic::{AtomicU8, Ordering};

/// What became of standard output.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Console {
    /// Every write went through.
    Open,
    /// The reader closed the pipe: nothing more is printed, and that is no error.
    Closed,
    /// A write failed otherwise (a full disk, an I/O error); reported once on stderr.
    Failed,
}

static STATE: AtomicU8 = AtomicU8::new(0);

impl Console {
    fn code(self) -> u8 {
        match self {
            Console::Open => 0,
            Console::Closed => 1,
            Console::Failed => 2,
        }
    }

    /// The state of standard output so far.
    pub(crate) fn state() -> Console {
        match STATE.load(Ordering::SeqCst) {
            0 => Console::Open,
            1 => Console::Closed,
            _ => Console::Failed,
        }
    }
}

/// Prints to standard output and flushes; after the first failed write, prints nothing.
pub(crate) fn print(args: std::fmt::Arguments<'_>) {
    if Console::state() != Console::Open {
        return;
    }
    let mut out = std::io::stdout().lock();
    let Err(e) = out.write_fmt(args).and_then(|()| out.flush()) else {
        return;
    };
    let state = if e.kind() == std::io::ErrorKind::BrokenPipe {
        Console::Closed
    } else {
        Console::Failed
    };
    // Only the first failure is recorded (and reported).
    if STATE
        .compare_exchange(0, state.code(), Ordering::SeqCst, Ordering::SeqCst)
        .is_ok()
        && state == Console::Failed
    {
        let _ = writeln!(
            std::io::stderr(),
            "error: writing to stdout: {e} (nothing more is printed; the run goes on and \
             writes its files)"
        );
    }
}

/// `print!` through [`print`]: never panics on a closed or failing stdout.
macro_rules! say {
    ($($arg:tt)*) => {
        $crate::cli::console::print(format_args!($($arg)*))
    };
}
pub(crate) use say;

/// `println!` through [`print`].
macro_rules! sayln {
    ($($arg:tt)*) => {
        $crate::cli::console::print(format_args!("{}\n", format_args!($($arg)*)))
    };
}
pub(crate) use sayln;
