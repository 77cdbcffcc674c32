//! A run's output directory as one unit: staged, locked, and put in place whole.
//!
//! A run writes every file into a fresh hidden staging directory beside its destination, holding
//! an exclusive lock on the destination for the whole run. [`RunDir::commit`] then moves the
//! staging directory into place in one rename (the previous run's directory is moved aside first
//! and removed after), so the destination holds exactly one run's files: never the previous
//! run's CSVs beside the new summary, never a mix of two concurrent runs. A run that is dropped
//! without committing (an error, a panic) removes its staging directory and leaves the previous
//! results untouched; [`abandon_unfinished`] does the same from a signal handler.
//!
//! An existing destination is only ever replaced when fpsolve wrote it: it is empty, or holds
//! the marker file [`MARKER`] of an earlier run, or holds nothing but files with the names
//! fpsolve writes. `--out ~` is refused, not emptied.

use std::fs::{self, File, OpenOptions, TryLockError};
use std::path::{Component, Path, PathBuf};
use std::sync::Mutex;

use super::output::sync_dir;
use super::{OutputDir, ReportError};

/// The file that marks a directory as an fpsolve run's output (it holds the command line and
/// the program version).
pub const MARKER: &str = ".fpsolve-run";

/// Staging directories of runs in this process that have not been committed yet.
static UNFINISHED: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

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
        "{}: the directory exists and holds `{entry}`, which fpsolve did not write; choose \
         another --out (fpsolve replaces its output directory as a whole and will not delete \
         other files)",
        path.display()
    )]
    Foreign {
        /// The destination.
        path: PathBuf,
        /// One entry that fpsolve did not write.
        entry: String,
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
/// # std::fs::remove_dir_all(&tmp).unwrap();
/// # Ok::<(), fpsolve::report::ReportError>(())
/// ```
#[derive(Debug)]
pub struct RunDir {
    dest: PathBuf,
    staging: OutputDir,
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
        fs::create_dir(&staging).map_err(io(&staging))?;
        register(&staging);
        let staging = OutputDir::create(&staging)?.staged();
        let marker = format!(
            "fpsolve {}\ncommand: {command}\n",
            env!("CARGO_PKG_VERSION")
        );
        // Written now, so that the directory is marked as fpsolve's from the start; flushed
        // to disk beside the run's work, as every staged file is.
        staging.write_atomic(MARKER, marker.as_bytes())?;
        Ok(RunDir {
            dest,
            staging,
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
    /// Nothing is moved before every file's and the staging directory's flush to disk has
    /// ended (so a crash never leaves a directory with a missing or partial file in place),
    /// and the destination's new entry is on disk before this returns (so a result reported
    /// as written is not lost); the previous run's directory is removed last.
    ///
    /// # Errors
    /// [`ReportError::NotFlushed`] if a file or directory could not be flushed to disk: the
    /// files are complete and are put in place all the same (a finished result is never
    /// discarded), the error says which flush failed. [`ReportError::Io`] if a rename fails;
    /// the previous run's directory is then restored when possible, and the staged files are
    /// removed.
    pub fn commit(mut self) -> Result<PathBuf, ReportError> {
        // The files' flushes (started as each was written) and the directory's, side by
        // side: a journaling file system commits concurrent flushes together. The directory
        // is complete: the run wrote its last file before calling this.
        crate::study::timeline::mark("commit: start");
        self.wait_for_leftovers();
        let dir = sync_dir(self.staging.path());
        crate::study::timeline::mark("commit: staging synced");
        // A failed flush does not discard the finished result: the files are complete (the
        // run wrote them all), so they are put in place and the failure reported after.
        let flushed = self.staging.wait_for_syncs().and(dir);
        crate::study::timeline::mark("commit: files synced");
        let old = sibling(&self.dest, &format!("old-{}", std::process::id()));
        let had_old = self.dest.exists();
        if had_old {
            fs::rename(&self.dest, &old).map_err(|source| ReportError::Io {
                path: self.dest.clone(),
                source,
            })?;
        }
        if let Err(source) = fs::rename(self.staging.path(), &self.dest) {
            if had_old {
                let _ = fs::rename(&old, &self.dest);
            }
            return Err(ReportError::Io {
                path: self.dest.clone(),
                source,
            });
        }
        unregister(self.staging.path());
        self.committed = true;
        // The old directory's removal need not be durable (a later run removes what a crash
        // leaves of it): it runs beside the flush of the new entry, each waiting on the disk.
        let removal = had_old.then(|| std::thread::spawn(move || remove_side_by_side(&old)));
        if let Some(parent) = self.dest.parent() {
            // Best effort: the rename is done; durability of the new entry is all that is left.
            let _ = sync_dir(parent);
        }
        crate::study::timeline::mark("commit: parent synced");
        if let Some(removal) = removal {
            let _ = removal.join();
        }
        crate::study::timeline::mark("commit: old removed");
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
}

impl RunDir {
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
            let _ = fs::remove_dir_all(self.staging.path());
            unregister(self.staging.path());
        }
    }
}

/// Removes the staging directories of every run in this process that has not committed: for
/// a SIGINT/SIGTERM handler, so an interrupted run leaves the previous results as they were
/// and no partial files behind.
pub fn abandon_unfinished() {
    abandon_matching(|_| true);
}

fn abandon_matching(matches: impl Fn(&Path) -> bool) {
    let mut guard = match UNFINISHED.lock() {
        Ok(g) => g,
        Err(poisoned) => poisoned.into_inner(),
    };
    guard.retain(|d| {
        if matches(d) {
            let _ = fs::remove_dir_all(d);
            false
        } else {
            true
        }
    });
}

fn register(dir: &Path) {
    if let Ok(mut g) = UNFINISHED.lock() {
        g.push(dir.to_path_buf());
    }
}

fn unregister(dir: &Path) {
    if let Ok(mut g) = UNFINISHED.lock() {
        g.retain(|d| d != dir);
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

/// Whether a file name is one fpsolve writes into an output directory.
fn written_by_fpsolve(name: &str) -> bool {
    let ext = |e: &str| name.ends_with(e);
    name == MARKER
        || name == "summary.json"
        || name == "mc_summary.json"
        || (name.starts_with('.') && name.ends_with(".tmp"))
        || ((name.starts_with("pdf_")
            || name.starts_with("mc_")
            || name.starts_with("shard_")
            || name.starts_with("sweep"))
            && (ext(".csv") || ext(".json") || ext(".png") || ext(".svg")))
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
    let entries = fs::read_dir(dest).map_err(|source| ReportError::Io {
        path: dest.to_path_buf(),
        source,
    })?;
    let mut names = Vec::new();
    for e in entries {
        let e = e.map_err(|source| ReportError::Io {
            path: dest.to_path_buf(),
            source,
        })?;
        let is_file = e.file_type().map(|t| t.is_file()).unwrap_or(false);
        names.push((e.file_name().to_string_lossy().into_owned(), is_file));
    }
    if names.iter().any(|(n, _)| n == MARKER) {
        return Ok(());
    }
    match names
        .iter()
        .find(|(n, is_file)| !(*is_file && written_by_fpsolve(n)))
    {
        Some((entry, _)) => Err(RunDirError::Foreign {
            path: dest.to_path_buf(),
            entry: entry.clone(),
        }
        .into()),
        None => Ok(()),
    }
}

/// Removes the directory `dir`, its entries side by side on up to 16 threads: where freeing a
/// file's blocks waits for the file system's journal (4 ms a file measured on this project's
/// ext4 machine), removals issued together share the wait.
fn remove_side_by_side(dir: &Path) -> std::io::Result<()> {
    let entries: Vec<PathBuf> = fs::read_dir(dir)?
        .map(|e| e.map(|e| e.path()))
        .collect::<Result<_, _>>()?;
    let threads = entries.len().min(16);
    std::thread::scope(|s| {
        for k in 0..threads {
            let entries = &entries;
            s.spawn(move || {
                for path in entries.iter().skip(k).step_by(threads) {
                    let _ = match fs::symlink_metadata(path) {
                        Ok(m) if m.is_dir() => fs::remove_dir_all(path),
                        _ => fs::remove_file(path),
                    };
                }
            });
        }
    });
    fs::remove_dir_all(dir)
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
                let _ = fs::remove_dir_all(path);
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
        abandon_matching(|d| d.starts_with(&root));
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
        // Entries beyond the files fpsolve writes, in a marked directory: a subdirectory.
        fs::create_dir_all(dest.join("sub").join("deeper")).unwrap();
        fs::write(dest.join("sub").join("deeper").join("x"), b"x").unwrap();
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
        // An output directory of an older fpsolve (only its file names) is replaceable.
        let legacy = root.join("legacy");
        fs::create_dir_all(&legacy).unwrap();
        fs::write(legacy.join("pdf_y.csv"), b"x").unwrap();
        fs::write(legacy.join("summary.json"), b"{}").unwrap();
        RunDir::begin(&legacy, "t").unwrap().commit().unwrap();
        assert_eq!(names(&legacy), vec![MARKER.to_string()]);
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
