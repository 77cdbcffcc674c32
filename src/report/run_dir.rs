//! A run's output directory as one unit: staged, locked, and put in place whole.
//!
//! A run writes every file into a fresh hidden staging directory beside its destination, holding
//! an exclusive lock on the destination for the whole run. [`RunDir::commit`] then puts the
//! staging directory in place in one step: on Linux the two directories are swapped by one
//! `renameat2(RENAME_EXCHANGE)`, so the destination names either the previous run's directory
//! or the new one at every instant, never nothing; the previous run's directory is removed
//! after. Where the exchange is not supported (another system, a file system without it) the
//! previous directory is moved aside and the new one moved in, two renames that the interrupt
//! handler cannot come between (see below). So the destination holds exactly one run's files:
//! never the previous run's CSVs beside the new summary, never a mix of two concurrent runs. A
//! run that is dropped without committing (an error, a panic) removes its staging directory and
//! leaves the previous results untouched.
//!
//! An interrupt ([`abandon_unfinished`], called from the SIGINT/SIGTERM handler) and the
//! commit take one lock: the handler either comes before the commit (the staging directory is
//! removed, the previous results stay) or after it (the new results stay, the previous run's
//! directory is removed), and what it did is returned as [`Abandoned`], whose sentence is true.
//! Staging directories that killed processes left behind are removed by the next run on the
//! same destination, under the destination's lock.
//!
//! An existing destination is only ever replaced when it holds exactly one earlier fpsolve run
//! and nothing else: the marker file [`MARKER`] lists the files its run wrote, and every entry
//! of the directory must be in that list (a file the user deleted may be missing). An empty
//! directory is replaced too. Anything else is refused: files fpsolve did not write (`--out ~`,
//! `notes.txt`, `.git`), the shard files of `simulate --shard` (written without a marker, as
//! several runs share their directory), a marker without a list (an older fpsolve), and a
//! directory holding an input of the run (`--mc-from`, `merge`'s directories).

use std::fmt;
use std::fs::{self, File, OpenOptions, TryLockError};
use std::path::{Component, Path, PathBuf};
use std::sync::{Mutex, MutexGuard};

use super::output::sync_dir;
use super::{OutputDir, ReportError};

/// The file that marks a directory as an fpsolve run's output: the program version, the
/// command line, and the list of the files the run wrote (after a line `files:`, one a line).
pub const MARKER: &str = ".fpsolve-run";

/// The line of [`MARKER`] after which the run's files are listed.
const FILES_HEADER: &str = "files:";

/// What this process has staged, committed, and left to remove: shared by the runs and the
/// interrupt handler, which takes this lock and never gives it back.
static REGISTRY: Mutex<Registry> = Mutex::new(Registry {
    staging: Vec::new(),
    committed: Vec::new(),
    discarded: Vec::new(),
});

struct Registry {
    /// Staging directories of runs that have not committed.
    staging: Vec<PathBuf>,
    /// Destinations whose commit is done.
    committed: Vec<PathBuf>,
    /// Previous runs' directories moved aside by a commit and not removed yet.
    discarded: Vec<PathBuf>,
}

fn registry() -> MutexGuard<'static, Registry> {
    REGISTRY.lock().unwrap_or_else(|p| p.into_inner())
}

/// Why a destination cannot take a run's output. Each variant says what to do about it.
#[derive(Debug, thiserror::Error)]
pub enum RunDirError {
    /// Another process holds the destination's lock.
    #[error(
        "{}: another fpsolve run is writing this directory (lock {} is held); wait for it to \
         finish or choose another --out",
        path.display(),
        lock.display()
    )]
    Busy {
        /// The destination.
        path: PathBuf,
        /// The lock file.
        lock: PathBuf,
    },
    /// The destination exists and holds files fpsolve did not write.
    #[error(
        "{}: the directory exists and holds `{entry}`, which is not a file of one earlier \
         fpsolve run (its marker {MARKER} lists the files it wrote); choose another --out \
         (fpsolve replaces its output directory as a whole and will not delete other files)",
        path.display()
    )]
    Foreign {
        /// The destination.
        path: PathBuf,
        /// One entry that the directory's marker does not list.
        entry: String,
    },
    /// The destination holds a marker without the list of its run's files (written by an
    /// older fpsolve), so which files the run wrote is not known.
    #[error(
        "{}: the directory holds the output of an older fpsolve, whose marker does not list \
         its files; remove it yourself or choose another --out (fpsolve replaces its output \
         directory as a whole and deletes only files it knows it wrote)",
        path.display()
    )]
    Unlisted {
        /// The destination.
        path: PathBuf,
    },
    /// The destination is, or holds, one of the run's inputs.
    #[error(
        "{}: holds {}, an input of this command; choose another --out (fpsolve replaces its \
         output directory as a whole)",
        path.display(),
        input.display()
    )]
    HoldsInput {
        /// The destination.
        path: PathBuf,
        /// The input inside it (or the destination itself).
        input: PathBuf,
    },
    /// The destination exists and is not a directory.
    #[error("{}: exists and is not a directory", path.display())]
    NotADirectory {
        /// The destination.
        path: PathBuf,
    },
    /// The destination has no name to stage beside (`/`, `..`).
    #[error("{}: not usable as an output directory (it has no name of its own)", path.display())]
    NoName {
        /// The destination.
        path: PathBuf,
    },
}

/// What an interrupt found in this process and did about it ([`abandon_unfinished`]): the
/// sentence the signal handler prints.
///
/// ```
/// use fpsolve::report::Abandoned;
///
/// let before = Abandoned { removed: 1, committed: vec![] };
/// assert!(before.to_string().contains("earlier results are untouched"));
/// let after = Abandoned { removed: 0, committed: vec!["out/linear".into()] };
/// assert!(after.to_string().contains("out/linear"));
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Abandoned {
    /// Staging directories removed (runs that had not committed).
    pub removed: usize,
    /// Destinations whose commit was done before the interrupt: their new results stay.
    pub committed: Vec<PathBuf>,
}

impl fmt::Display for Abandoned {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for dest in &self.committed {
            write!(
                f,
                "the results were already written to {}; ",
                dest.display()
            )?;
        }
        match (self.removed, self.committed.is_empty()) {
            (0, true) => write!(f, "no output had been written"),
            (0, false) => write!(f, "nothing else was unfinished"),
            (_, true) => write!(
                f,
                "the unfinished output was removed (earlier results are untouched)"
            ),
            (_, false) => write!(
                f,
                "the other, unfinished output was removed (its earlier results are untouched)"
            ),
        }
    }
}

/// A run's output directory, staged until [`RunDir::commit`].
///
/// ```
/// use fpsolve::report::{write_json, RunDir};
///
/// # let tmp = std::env::temp_dir().join(format!("fpsolve-doc-rundir-{}", std::process::id()));
/// let dest = tmp.join("run");
/// let run = RunDir::begin(&dest, "fpsolve doc")?;
/// write_json(run.out(), "summary.json", &serde_json::json!({ "ok": true }))?;
/// assert!(!dest.exists()); // nothing is visible before the commit
/// run.commit()?;
/// assert!(dest.join("summary.json").is_file());
///
/// // A second run replaces the first one's files as a whole.
/// let run = RunDir::begin(&dest, "fpsolve doc")?;
/// write_json(run.out(), "other.json", &serde_json::json!({}))?;
/// run.commit()?;
/// assert!(!dest.join("summary.json").exists() && dest.join("other.json").is_file());
///
/// // A directory holding a file of someone else's is never replaced.
/// std::fs::write(dest.join("notes.txt"), "mine")?;
/// assert!(RunDir::begin(&dest, "fpsolve doc").is_err());
/// # std::fs::remove_dir_all(&tmp).unwrap();
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug)]
pub struct RunDir {
    dest: PathBuf,
    staging: OutputDir,
    /// The command line, recorded in the marker file.
    command: String,
    /// Held (locked) for the run's lifetime; the lock goes with the handle.
    _lock: File,
    committed: bool,
    /// The removal of earlier runs' leftovers beside the destination, running beside this
    /// run's work (listing a large parent directory takes milliseconds); waited for before
    /// the commit renames anything and before the lock is released.
    leftovers: Option<std::thread::JoinHandle<()>>,
}

impl RunDir {
    /// Locks `dest` against other runs, checks that it can be replaced, and creates the staging
    /// directory beside it (parents of `dest` are created). `command` is recorded in the
    /// marker file. Takes milliseconds: call it before any computation, so that an unusable
    /// `--out` is a usage error, not a lost result.
    ///
    /// # Errors
    /// [`ReportError::RunDir`] when the destination is locked by another run, holds foreign
    /// files or is not a directory; [`ReportError::Io`] when a directory cannot be created
    /// (e.g. not writable).
    pub fn begin(dest: impl AsRef<Path>, command: &str) -> Result<RunDir, ReportError> {
        Self::begin_reading(dest, command, &[])
    }

    /// [`RunDir::begin`] for a run that reads `inputs` (files or directories): a destination
    /// that is one of them or holds one is refused ([`RunDirError::HoldsInput`]), so that
    /// `merge S --out S` or `--mc-from M --out M` cannot replace what they read.
    ///
    /// # Errors
    /// As [`RunDir::begin`], and [`RunDirError::HoldsInput`].
    pub fn begin_reading(
        dest: impl AsRef<Path>,
        command: &str,
        inputs: &[&Path],
    ) -> Result<RunDir, ReportError> {
        let dest = absolute(dest.as_ref())?;
        let parent = match (dest.parent(), dest.file_name()) {
            (Some(p), Some(_)) => p.to_path_buf(),
            _ => return Err(RunDirError::NoName { path: dest }.into()),
        };
        let io = |path: &Path| {
            let path = path.to_path_buf();
            move |source| ReportError::Io { path, source }
        };
        // Checked before anything is created, so a refused --out leaves no trace; checked
        // again under the lock, as another run may have written it in between.
        check_inputs(&dest, inputs)?;
        check_replaceable(&dest)?;
        fs::create_dir_all(&parent).map_err(io(&parent))?;
        let lock_path = sibling(&dest, "lock");
        let lock = OpenOptions::new()
            .create(true)
            .truncate(false)
            .write(true)
            .open(&lock_path)
            .map_err(io(&lock_path))?;
        match lock.try_lock() {
            Ok(()) => {}
            Err(TryLockError::WouldBlock) => {
                return Err(RunDirError::Busy {
                    path: dest,
                    lock: lock_path,
                }
                .into())
            }
            Err(TryLockError::Error(source)) => {
                return Err(ReportError::Io {
                    path: lock_path,
                    source,
                })
            }
        }
        check_replaceable(&dest)?;
        let staging = sibling(&dest, &format!("partial-{}", std::process::id()));
        // A leftover of an earlier process with this process's id (ids are reused).
        let _ = fs::remove_dir_all(&staging);
        // Leftovers of runs killed without a chance to clean up (SIGKILL, power loss): the
        // lock proves no live run owns them. Removed beside the run; this run's own staging
        // directory is created after the listing starts, so it is spared by name.
        let leftovers = {
            let (dest, ours) = (dest.clone(), staging.clone());
            std::thread::spawn(move || remove_leftovers(&dest, &ours))
        };
        {
            // Registered and created under the handler's lock: an interrupt finds every
            // staging directory that exists, and none is created after it.
            let mut reg = registry();
            fs::create_dir(&staging).map_err(io(&staging))?;
            reg.staging.push(staging.clone());
        }
        Ok(RunDir {
            dest,
            staging: OutputDir::existing(&staging).staged(),
            command: command.to_string(),
            _lock: lock,
            committed: false,
            leftovers: Some(leftovers),
        })
    }

    /// The staging directory the run writes into.
    pub fn out(&self) -> &OutputDir {
        &self.staging
    }

    /// Puts the run's files in place as a whole, replacing the previous run's directory, and
    /// returns the destination.
    ///
    /// The marker file listing the run's files is written first. Nothing is moved before
    /// every file's and the staging directory's flush to disk has ended (so a crash never
    /// leaves a directory with a missing or partial file in place), and the destination's new
    /// entry is on disk before this returns (so a result reported as written is not lost);
    /// the previous run's directory is removed last, only the files its marker lists (a file
    /// put there in the meantime stays, in the hidden directory beside the destination).
    ///
    /// # Errors
    /// [`ReportError::NotFlushed`] if a file or directory could not be flushed to disk: the
    /// files are complete and are put in place all the same (a finished result is never
    /// discarded), the error says which flush failed. [`ReportError::Io`] if the marker
    /// cannot be written or a rename fails; the previous run's directory is then in place,
    /// and the staged files are removed.
    pub fn commit(mut self) -> Result<PathBuf, ReportError> {
        crate::base::timeline::mark("commit: start");
        self.wait_for_leftovers();
        // The run wrote its last file before calling this: the listing is complete.
        let marker = marker_text(&self.command, &entries(self.staging.path())?);
        self.staging.write_atomic(MARKER, marker.as_bytes())?;
        // The files' flushes (started as each was written) and the directory's, side by
        // side: a journaling file system commits concurrent flushes together.
        let dir = sync_dir(self.staging.path());
        crate::base::timeline::mark("commit: staging synced");
        // A failed flush does not discard the finished result: the files are complete (the
        // run wrote them all), so they are put in place and the failure reported after.
        let flushed = self.staging.wait_for_syncs().and(dir);
        crate::base::timeline::mark("commit: files synced");
        let old = self.swap_in()?;
        self.committed = true;
        // The old directory's removal need not be durable (a later run removes what a crash
        // leaves of it): it runs beside the flush of the new entry, each waiting on the disk.
        let removal = old.map(|old| {
            std::thread::spawn(move || {
                remove_replaced(&old);
                registry().discarded.retain(|d| *d != old);
            })
        });
        if let Some(parent) = self.dest.parent() {
            // Best effort: the rename is done; durability of the new entry is all that is left.
            let _ = sync_dir(parent);
        }
        crate::base::timeline::mark("commit: parent synced");
        if let Some(removal) = removal {
            let _ = removal.join();
        }
        crate::base::timeline::mark("commit: old removed");
        match flushed {
            Ok(()) => Ok(self.dest.clone()),
            Err(ReportError::Io { path, source }) => Err(ReportError::NotFlushed {
                dest: self.dest.clone(),
                path,
                source,
            }),
            Err(e) => Err(e),
        }
    }

    /// Puts the staging directory at the destination, under the handler's lock; returns where
    /// the previous run's directory now is (to be removed), if there was one.
    fn swap_in(&self) -> Result<Option<PathBuf>, ReportError> {
        let staging = self.staging.path().to_path_buf();
        let io = |source| ReportError::Io {
            path: self.dest.clone(),
            source,
        };
        let mut reg = registry();
        let had_old = match fs::symlink_metadata(&self.dest) {
            Ok(_) => true,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => false,
            Err(source) => return Err(io(source)),
        };
        let old = if !had_old {
            fs::rename(&staging, &self.dest).map_err(io)?;
            None
        } else if !two_renames_forced() && exchange(&staging, &self.dest).map_err(io)? {
            // The previous run's directory is now at the staging path.
            Some(staging.clone())
        } else {
            // No exchange here: two renames, which the interrupt handler (waiting for this
            // lock) cannot come between.
            let aside = sibling(&self.dest, &format!("old-{}", std::process::id()));
            fs::rename(&self.dest, &aside).map_err(io)?;
            if let Err(source) = fs::rename(&staging, &self.dest) {
                let _ = fs::rename(&aside, &self.dest);
                return Err(io(source));
            }
            Some(aside)
        };
        reg.staging.retain(|d| *d != staging);
        reg.committed.push(self.dest.clone());
        reg.discarded.extend(old.iter().cloned());
        Ok(old)
    }

    /// Waits for the removal of earlier runs' leftovers (see the `leftovers` field).
    fn wait_for_leftovers(&mut self) {
        if let Some(removal) = self.leftovers.take() {
            let _ = removal.join();
        }
    }
}

impl Drop for RunDir {
    fn drop(&mut self) {
        self.wait_for_leftovers();
        if !self.committed {
            let staging = self.staging.path();
            let mut reg = registry();
            remove_all(staging);
            reg.staging.retain(|d| d != staging);
        }
    }
}

#[cfg(test)]
thread_local! {
    /// Set by tests of the commit where the exchange is not supported.
    static TWO_RENAMES: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Whether the commit skips the exchange (only ever in this module's tests).
fn two_renames_forced() -> bool {
    #[cfg(test)]
    return TWO_RENAMES.with(|t| t.get());
    #[cfg(not(test))]
    false
}

/// Swaps the directories `a` and `b` in one step; `Ok(false)` where the system or the file
/// system cannot (the caller falls back to two renames).
#[cfg(target_os = "linux")]
fn exchange(a: &Path, b: &Path) -> std::io::Result<bool> {
    use std::ffi::CString;
    use std::os::unix::ffi::OsStrExt;
    let c = |p: &Path| {
        CString::new(p.as_os_str().as_bytes())
            .map_err(|_| std::io::Error::other("a path with a NUL byte"))
    };
    let (a, b) = (c(a)?, c(b)?);
    // SAFETY: both are valid NUL-terminated paths; AT_FDCWD with absolute paths.
    let done = unsafe {
        libc::renameat2(
            libc::AT_FDCWD,
            a.as_ptr(),
            libc::AT_FDCWD,
            b.as_ptr(),
            libc::RENAME_EXCHANGE,
        )
    };
    if done == 0 {
        return Ok(true);
    }
    let err = std::io::Error::last_os_error();
    match err.raw_os_error() {
        Some(libc::EINVAL) | Some(libc::ENOSYS) | Some(libc::EOPNOTSUPP) => Ok(false),
        _ => Err(err),
    }
}

#[cfg(not(target_os = "linux"))]
fn exchange(_: &Path, _: &Path) -> std::io::Result<bool> {
    Ok(false)
}

/// Removes the staging directories of every run in this process that has not committed, and
/// the previous runs' directories that commits moved aside: for a SIGINT/SIGTERM handler
/// that exits right after. The handler's lock is kept, so no run commits (or creates a
/// staging directory) after this: what it returns stays true.
pub fn abandon_unfinished() -> Abandoned {
    let (abandoned, guard) = abandon_matching(|_| true);
    std::mem::forget(guard);
    abandoned
}

fn abandon_matching(matches: impl Fn(&Path) -> bool) -> (Abandoned, MutexGuard<'static, Registry>) {
    let mut reg = registry();
    let mut removed = 0;
    reg.staging.retain(|d| {
        if matches(d) {
            remove_all(d);
            removed += 1;
            false
        } else {
            true
        }
    });
    reg.discarded.retain(|d| {
        if matches(d) {
            // The commit's removal may be at work on it too: what it has not removed yet
            // when this pass ends is removed by the next.
            for _ in 0..100 {
                remove_replaced(d);
                if fs::symlink_metadata(d).is_err() {
                    break;
                }
                std::thread::yield_now();
            }
            false
        } else {
            true
        }
    });
    let committed = reg
        .committed
        .iter()
        .filter(|d| matches(d))
        .cloned()
        .collect();
    (Abandoned { removed, committed }, reg)
}

/// Removes the directory `dir` and everything in it, again while the run's other threads
/// still create files in it (a removal that meets a new entry fails with "not empty").
fn remove_all(dir: &Path) {
    for _ in 0..100 {
        match fs::remove_dir_all(dir) {
            Ok(()) => return,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return,
            Err(_) => std::thread::yield_now(),
        }
    }
}

/// `path` made absolute and free of `.`/`..` components, so that `--out .` or `--out ..`
/// name the directory they mean (and get refused if it holds foreign files).
fn absolute(path: &Path) -> Result<PathBuf, ReportError> {
    let abs = std::path::absolute(path).map_err(|source| ReportError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let mut out = PathBuf::new();
    for c in abs.components() {
        match c {
            Component::ParentDir => {
                out.pop();
            }
            Component::CurDir => {}
            other => out.push(other),
        }
    }
    Ok(out)
}

/// The hidden entry `.<name>.fpsolve-<kind>` beside `dest` (lock file, staging and old
/// directories).
fn sibling(dest: &Path, kind: &str) -> PathBuf {
    let name = dest
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    dest.with_file_name(format!(".{name}.fpsolve-{kind}"))
}

/// The entries of `dir`, each a name with `/` after a directory's, sorted; `None` for a name
/// that is not UTF-8 or holds a line break (a marker cannot list it).
fn entries(dir: &Path) -> Result<Vec<Option<String>>, ReportError> {
    let io = |source| ReportError::Io {
        path: dir.to_path_buf(),
        source,
    };
    let mut names = Vec::new();
    for e in fs::read_dir(dir).map_err(io)? {
        let e = e.map_err(io)?;
        let is_dir = e.file_type().map(|t| t.is_dir()).unwrap_or(false);
        names.push(
            e.file_name()
                .into_string()
                .ok()
                .filter(|n| !n.contains(['\n', '\r']))
                .map(|n| if is_dir { format!("{n}/") } else { n }),
        );
    }
    names.sort();
    Ok(names)
}

/// The marker's text: version, command (one line), and the run's files but the marker.
fn marker_text(command: &str, files: &[Option<String>]) -> String {
    let mut text = format!(
        "fpsolve {}\ncommand: {}\n{FILES_HEADER}\n",
        env!("CARGO_PKG_VERSION"),
        command.replace(['\n', '\r'], " ")
    );
    for name in files.iter().flatten().filter(|n| *n != MARKER) {
        text.push_str(name);
        text.push('\n');
    }
    text
}

/// The files a marker lists; `None` for a marker without a list (an older fpsolve) or one
/// that cannot be read.
fn listed_files(marker: &Path) -> Option<Vec<String>> {
    let text = fs::read_to_string(marker).ok()?;
    let mut lines = text.lines();
    lines.find(|l| *l == FILES_HEADER)?;
    Some(lines.map(str::to_string).collect())
}

/// Refuses a destination that is one of `inputs` or holds one.
fn check_inputs(dest: &Path, inputs: &[&Path]) -> Result<(), ReportError> {
    // A destination that does not exist holds nothing.
    let Ok(dest_real) = fs::canonicalize(dest) else {
        return Ok(());
    };
    for input in inputs {
        if let Ok(real) = fs::canonicalize(input) {
            if real.starts_with(&dest_real) {
                return Err(RunDirError::HoldsInput {
                    path: dest.to_path_buf(),
                    input: input.to_path_buf(),
                }
                .into());
            }
        }
    }
    Ok(())
}

fn check_replaceable(dest: &Path) -> Result<(), ReportError> {
    let meta = match fs::symlink_metadata(dest) {
        Ok(m) => m,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
        Err(source) => {
            return Err(ReportError::Io {
                path: dest.to_path_buf(),
                source,
            })
        }
    };
    if !meta.is_dir() {
        return Err(RunDirError::NotADirectory {
            path: dest.to_path_buf(),
        }
        .into());
    }
    let names = entries(dest)?;
    if names.is_empty() {
        return Ok(());
    }
    let has_marker = names.iter().any(|n| n.as_deref() == Some(MARKER));
    let listed = if has_marker {
        match listed_files(&dest.join(MARKER)) {
            Some(listed) => listed,
            None => {
                return Err(RunDirError::Unlisted {
                    path: dest.to_path_buf(),
                }
                .into())
            }
        }
    } else {
        Vec::new()
    };
    let foreign = |n: &Option<String>| match n {
        Some(n) => n != MARKER && !listed.contains(n),
        None => true,
    };
    match names.iter().find(|n| foreign(n)) {
        Some(entry) => Err(RunDirError::Foreign {
            path: dest.to_path_buf(),
            entry: entry.clone().unwrap_or_else(|| "an entry".to_string()),
        }
        .into()),
        None => Ok(()),
    }
}

/// Removes a run's directory `dir`: with a marker that lists its files, those files (side by
/// side on up to 16 threads: where freeing a file's blocks waits for the file system's
/// journal, 4 ms a file measured on this project's ext4 machine, removals issued together
/// share the wait), the marker, and the directory if nothing else is left in it; without
/// one (a staging directory of a killed run, which only fpsolve writes), all of it.
fn remove_run(dir: &Path) {
    let Some(listed) = listed_files(&dir.join(MARKER)) else {
        remove_all(dir);
        return;
    };
    let threads = listed.len().clamp(1, 16);
    std::thread::scope(|s| {
        for k in 0..threads {
            let listed = &listed;
            s.spawn(move || {
                for name in listed.iter().skip(k).step_by(threads) {
                    let path = dir.join(name.trim_end_matches('/'));
                    let _ = if name.ends_with('/') {
                        fs::remove_dir_all(path)
                    } else {
                        fs::remove_file(path)
                    };
                }
            });
        }
    });
    let _ = fs::remove_file(dir.join(MARKER));
    // Fails, keeping them, when someone put files in it since.
    let _ = fs::remove_dir(dir);
}

/// Removes a directory that a commit replaced: an earlier run's ([`remove_run`]), or an
/// empty directory (it was empty when the run began; whatever was put in it since stays).
fn remove_replaced(dir: &Path) {
    if dir.join(MARKER).exists() {
        remove_run(dir);
    } else {
        let _ = fs::remove_dir(dir);
    }
}

/// Removes the staging and old directories that earlier runs on `dest` left behind, except
/// `ours` (this run's staging directory).
fn remove_leftovers(dest: &Path, ours: &Path) {
    let prefixes = [sibling(dest, "partial-"), sibling(dest, "old-")];
    let Some(parent) = dest.parent() else { return };
    if let Ok(entries) = fs::read_dir(parent) {
        for e in entries.flatten() {
            let path = e.path();
            let leftover = path != ours
                && prefixes
                    .iter()
                    .any(|p| path.to_string_lossy().starts_with(&*p.to_string_lossy()));
            if leftover {
                remove_run(&path);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(tag: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("fpsolve-rundir-{tag}-{}", std::process::id()));
        let _ = fs::remove_dir_all(&d);
        d
    }

    fn names(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn a_new_run_replaces_every_file_of_the_old_one() {
        let root = scratch("replace");
        let dest = root.join("out");
        let run = RunDir::begin(&dest, "t").unwrap();
        run.out().write_atomic("pdf_y.csv", b"old").unwrap();
        run.out().write_atomic("pdf_z.csv", b"old").unwrap();
        run.commit().unwrap();
        let run = RunDir::begin(&dest, "t").unwrap();
        run.out().write_atomic("pdf_y.csv", b"new").unwrap();
        run.commit().unwrap();
        assert_eq!(names(&dest), vec![MARKER.to_string(), "pdf_y.csv".into()]);
        assert_eq!(fs::read(dest.join("pdf_y.csv")).unwrap(), b"new");
        // Only the lock file is left beside the destination.
        assert_eq!(
            names(&root),
            vec![".out.fpsolve-lock".to_string(), "out".into()]
        );
        fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn without_the_exchange_two_renames_replace_the_run_and_leave_nothing_beside() {
        TWO_RENAMES.with(|t| t.set(true));
        let root = scratch("two-renames");
        let dest = root.join("out");
        for content in [b"old", b"new"] {
            let run = RunDir::begin(&dest, "t").unwrap();
            run.out().write_atomic("pdf_y.csv", content).unwrap();
            run.commit().unwrap();
        }
        TWO_RENAMES.with(|t| t.set(false));
        assert_eq!(fs::read(dest.join("pdf_y.csv")).unwrap(), b"new");
        assert_eq!(
            names(&root),
            vec![".out.fpsolve-lock".to_string(), "out".into()]
        );
        fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn a_dropped_run_leaves_the_old_results_and_no_partial_files() {
        let root = scratch("drop");
        let dest = root.join("out");
        let run = RunDir::begin(&dest, "t").unwrap();
        run.out().write_atomic("pdf_y.csv", b"old").unwrap();
        run.commit().unwrap();
        {
            let run = RunDir::begin(&dest, "t").unwrap();
            run.out().write_atomic("pdf_y.csv", b"half").unwrap();
        }
        assert_eq!(fs::read(dest.join("pdf_y.csv")).unwrap(), b"old");
        assert_eq!(
            names(&root),
            vec![".out.fpsolve-lock".to_string(), "out".into()]
        );
        // The same after abandon_unfinished (what the signal handler calls; limited here to
        // this test's directory, as other tests run in parallel in this process).
        let run = RunDir::begin(&dest, "t").unwrap();
        run.out().write_atomic("pdf_y.csv", b"half").unwrap();
        let (abandoned, guard) = abandon_matching(|d| d.starts_with(&root));
        drop(guard);
        assert_eq!(abandoned.removed, 1);
        assert_eq!(
            names(&root),
            vec![".out.fpsolve-lock".to_string(), "out".into()]
        );
        drop(run);
        fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn the_commit_waits_for_every_flush_before_the_directory_is_moved() {
        use std::sync::atomic::{AtomicBool, Ordering};
        use std::sync::Arc;
        let root = scratch("flush-wait");
        let dest = root.join("out");
        let run = RunDir::begin(&dest, "t").unwrap();
        run.out().write_atomic("pdf_y.csv", b"new").unwrap();
        // A slow disk: the flush ends 50 ms after the run is done writing.
        let flushed = Arc::new(AtomicBool::new(false));
        let done = Arc::clone(&flushed);
        run.out().push_pending(std::thread::spawn(move || {
            std::thread::sleep(std::time::Duration::from_millis(50));
            done.store(true, Ordering::SeqCst);
            Ok(())
        }));
        assert!(!dest.exists());
        run.commit().unwrap();
        assert!(flushed.load(Ordering::SeqCst));
        assert_eq!(fs::read(dest.join("pdf_y.csv")).unwrap(), b"new");
        fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn a_failed_flush_keeps_the_new_results_and_says_so() {
        let root = scratch("flush-fail");
        let dest = root.join("out");
        let run = RunDir::begin(&dest, "t").unwrap();
        run.out().write_atomic("pdf_y.csv", b"old").unwrap();
        run.commit().unwrap();
        let run = RunDir::begin(&dest, "t").unwrap();
        run.out().write_atomic("pdf_y.csv", b"new").unwrap();
        // The disk refuses one file's flush: the run's files are complete, so they are put in
        // place (a finished result is never discarded) and the failure is reported.
        let failing = run.out().path().join("pdf_v.csv");
        let reported = failing.clone();
        run.out().push_pending(std::thread::spawn(move || {
            Err(ReportError::Io {
                path: failing,
                source: std::io::Error::other("simulated EIO"),
            })
        }));
        match run.commit() {
            Err(ReportError::NotFlushed { dest: d, path, .. }) => {
                assert_eq!(d, dest);
                assert_eq!(path, reported);
            }
            other => panic!("expected the flush's error, got {other:?}"),
        }
        assert_eq!(fs::read(dest.join("pdf_y.csv")).unwrap(), b"new");
        assert_eq!(
            names(&root),
            vec![".out.fpsolve-lock".to_string(), "out".into()]
        );
        fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn replacing_a_run_removes_every_entry_of_the_old_one() {
        let root = scratch("old-removed");
        let dest = root.join("out");
        let run = RunDir::begin(&dest, "t").unwrap();
        for k in 0..40 {
            run.out()
                .write_atomic(&format!("pdf_q{k}.csv"), b"old")
                .unwrap();
        }
        run.commit().unwrap();
        let run = RunDir::begin(&dest, "t").unwrap();
        run.out().write_atomic("pdf_y.csv", b"new").unwrap();
        run.commit().unwrap();
        assert_eq!(names(&dest), vec![MARKER.to_string(), "pdf_y.csv".into()]);
        assert_eq!(
            names(&root),
            vec![".out.fpsolve-lock".to_string(), "out".into()]
        );
        fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn the_marker_lists_the_runs_files_and_nothing_else_is_replaced() {
        let root = scratch("listed");
        let dest = root.join("out");
        let run = RunDir::begin(&dest, "fpsolve solve m.sde").unwrap();
        run.out().write_atomic("pdf_y.csv", b"old").unwrap();
        run.out().write_atomic("summary.json", b"{}").unwrap();
        run.commit().unwrap();
        let marker = fs::read_to_string(dest.join(MARKER)).unwrap();
        assert_eq!(
            listed_files(&dest.join(MARKER)).unwrap(),
            ["pdf_y.csv", "summary.json"]
        );
        assert!(
            marker.contains("command: fpsolve solve m.sde\n"),
            "{marker}"
        );
        // Beside one run's files, anything else makes the directory someone else's: a file
        // with a name fpsolve could write, a note, a repository, a subdirectory.
        for extra in ["pdf_z.csv", "notes.txt", ".git/", "sub/"] {
            let path = dest.join(extra.trim_end_matches('/'));
            if extra.ends_with('/') {
                fs::create_dir(&path).unwrap();
            } else {
                fs::write(&path, b"keep").unwrap();
            }
            match RunDir::begin(&dest, "t") {
                Err(ReportError::RunDir(RunDirError::Foreign { entry, .. })) => {
                    assert_eq!(entry, extra)
                }
                other => panic!("{extra}: expected Foreign, got {other:?}"),
            }
            assert!(path.exists());
            let _ = fs::remove_dir(&path).or_else(|_| fs::remove_file(&path));
        }
        // A file of the run that the user deleted leaves it replaceable.
        fs::remove_file(dest.join("pdf_y.csv")).unwrap();
        RunDir::begin(&dest, "t").unwrap().commit().unwrap();
        assert_eq!(names(&dest), vec![MARKER.to_string()]);
        // A marker without a list (an older fpsolve): which files it wrote is not known.
        fs::write(dest.join(MARKER), b"fpsolve 0.0.9\ncommand: x\n").unwrap();
        fs::write(dest.join("pdf_y.csv"), b"x").unwrap();
        assert!(matches!(
            RunDir::begin(&dest, "t"),
            Err(ReportError::RunDir(RunDirError::Unlisted { .. }))
        ));
        fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn shard_directories_and_inputs_are_never_replaced() {
        let root = scratch("inputs");
        // What `simulate --shard` writes: shard files and no marker.
        let shards = root.join("S");
        fs::create_dir_all(&shards).unwrap();
        for k in 1..=3 {
            fs::write(shards.join(format!("shard_{k}_of_3.json")), b"{}").unwrap();
        }
        assert!(matches!(
            RunDir::begin(&shards, "t"),
            Err(ReportError::RunDir(RunDirError::Foreign { .. }))
        ));
        // A finished run read by this one (`--mc-from M --out M`), or holding its input.
        let source = root.join("M");
        let run = RunDir::begin(&source, "t").unwrap();
        run.out().write_atomic("mc_summary.json", b"{}").unwrap();
        run.commit().unwrap();
        let inner = source.join("mc_summary.json");
        for input in [source.as_path(), inner.as_path()] {
            match RunDir::begin_reading(&source, "t", &[input]) {
                Err(ReportError::RunDir(RunDirError::HoldsInput { input: i, .. })) => {
                    assert_eq!(i, input)
                }
                other => panic!("expected HoldsInput, got {other:?}"),
            }
        }
        // Spelled another way, still the same directory.
        let dotted = root.join("S").join("..").join("M");
        assert!(RunDir::begin_reading(&dotted, "t", &[&source]).is_err());
        assert_eq!(
            names(&source),
            vec![MARKER.to_string(), "mc_summary.json".into()]
        );
        // An input elsewhere is no obstacle.
        RunDir::begin_reading(&source, "t", &[&shards]).unwrap();
        fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn a_file_put_in_the_old_run_during_the_run_is_kept() {
        let root = scratch("late-file");
        let dest = root.join("out");
        let run = RunDir::begin(&dest, "t").unwrap();
        run.out().write_atomic("pdf_y.csv", b"old").unwrap();
        run.commit().unwrap();
        let run = RunDir::begin(&dest, "t").unwrap();
        fs::write(dest.join("notes.txt"), b"keep").unwrap();
        run.out().write_atomic("pdf_y.csv", b"new").unwrap();
        run.commit().unwrap();
        assert_eq!(fs::read(dest.join("pdf_y.csv")).unwrap(), b"new");
        // The old run's directory, moved aside, keeps what fpsolve did not write.
        let kept: Vec<_> = names(&root)
            .into_iter()
            .filter(|n| n.starts_with(".out.fpsolve-") && n != ".out.fpsolve-lock")
            .collect();
        assert_eq!(kept.len(), 1, "{:?}", names(&root));
        assert_eq!(names(&root.join(&kept[0])), vec!["notes.txt".to_string()]);
        // The same for a destination that was empty when the run began.
        let empty = root.join("empty");
        fs::create_dir(&empty).unwrap();
        let run = RunDir::begin(&empty, "t").unwrap();
        fs::write(empty.join("notes.txt"), b"keep").unwrap();
        run.commit().unwrap();
        let kept: Vec<_> = names(&root)
            .into_iter()
            .filter(|n| n.starts_with(".empty.fpsolve-") && n != ".empty.fpsolve-lock")
            .collect();
        assert_eq!(kept.len(), 1, "{:?}", names(&root));
        assert_eq!(
            fs::read(root.join(&kept[0]).join("notes.txt")).unwrap(),
            b"keep"
        );
        fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn an_interrupt_after_the_commit_says_the_results_were_written() {
        let root = scratch("after-commit");
        let dest = root.join("out");
        let run = RunDir::begin(&dest, "t").unwrap();
        run.out().write_atomic("pdf_y.csv", b"new").unwrap();
        run.commit().unwrap();
        let (abandoned, guard) = abandon_matching(|d| d.starts_with(&root));
        drop(guard);
        assert_eq!(
            abandoned,
            Abandoned {
                removed: 0,
                committed: vec![dest.clone()]
            }
        );
        assert!(!abandoned.to_string().contains("untouched"));
        fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn leftovers_of_killed_runs_are_removed_and_this_runs_files_kept() {
        let root = scratch("leftovers");
        let dest = root.join("out");
        fs::create_dir_all(&root).unwrap();
        // What runs killed mid-way (SIGKILL, power loss) leave: a staging directory and a
        // previous result moved aside.
        for kind in ["partial-999999", "old-999998"] {
            let d = sibling(&dest, kind);
            fs::create_dir_all(&d).unwrap();
            fs::write(d.join("pdf_y.csv"), b"stale").unwrap();
        }
        let run = RunDir::begin(&dest, "t").unwrap();
        run.out().write_atomic("pdf_y.csv", b"new").unwrap();
        run.commit().unwrap();
        assert_eq!(fs::read(dest.join("pdf_y.csv")).unwrap(), b"new");
        assert_eq!(
            names(&root),
            vec![".out.fpsolve-lock".to_string(), "out".into()]
        );
        fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn a_second_concurrent_run_is_refused() {
        let root = scratch("busy");
        let dest = root.join("out");
        let first = RunDir::begin(&dest, "t").unwrap();
        match RunDir::begin(&dest, "t") {
            Err(ReportError::RunDir(RunDirError::Busy { .. })) => {}
            other => panic!("expected Busy, got {other:?}"),
        }
        drop(first);
        // Released with the handle.
        RunDir::begin(&dest, "t").unwrap();
        fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn foreign_directories_are_never_replaced() {
        let root = scratch("foreign");
        let dest = root.join("home");
        fs::create_dir_all(dest.join("projects")).unwrap();
        fs::write(dest.join("notes.txt"), b"keep").unwrap();
        match RunDir::begin(&dest, "t") {
            Err(ReportError::RunDir(RunDirError::Foreign { .. })) => {}
            other => panic!("expected Foreign, got {other:?}"),
        }
        assert_eq!(fs::read(dest.join("notes.txt")).unwrap(), b"keep");
        // `--out .` inside it resolves to the same directory and is refused too.
        let dotted = dest.join("projects").join("..");
        assert!(matches!(
            RunDir::begin(&dotted, "t"),
            Err(ReportError::RunDir(RunDirError::Foreign { .. }))
        ));
        // An output directory of an older fpsolve (only its file names, no marker) is not:
        // nothing says which of its files fpsolve wrote.
        let legacy = root.join("legacy");
        fs::create_dir_all(&legacy).unwrap();
        fs::write(legacy.join("pdf_y.csv"), b"x").unwrap();
        fs::write(legacy.join("summary.json"), b"{}").unwrap();
        assert!(matches!(
            RunDir::begin(&legacy, "t"),
            Err(ReportError::RunDir(RunDirError::Foreign { .. }))
        ));
        assert_eq!(
            names(&legacy),
            vec!["pdf_y.csv".to_string(), "summary.json".into()]
        );
        fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn a_file_in_the_way_is_refused() {
        let root = scratch("file");
        fs::create_dir_all(&root).unwrap();
        fs::write(root.join("out"), b"x").unwrap();
        assert!(matches!(
            RunDir::begin(root.join("out"), "t"),
            Err(ReportError::RunDir(RunDirError::NotADirectory { .. }))
        ));
        fs::remove_dir_all(&root).unwrap();
    }
}
