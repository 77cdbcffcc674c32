//! The output directory and atomic file replacement.

use std::fs::{self, File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;

use super::ReportError;

/// A directory that report files are written into, each one atomically.
///
/// ```
/// use fpsolve::report::OutputDir;
///
/// # let tmp = std::env::temp_dir().join(format!("fpsolve-doc-outdir-{}", std::process::id()));
/// let dir = OutputDir::create(tmp.join("run-1"))?; // parents are created too
/// let written = dir.write_atomic("notes.txt", b"first")?;
/// dir.write_atomic("notes.txt", b"second")?; // replaces the old content in one step
/// assert_eq!(std::fs::read(&written).unwrap(), b"second");
/// # std::fs::remove_dir_all(&tmp).unwrap();
/// # Ok::<(), fpsolve::report::ReportError>(())
/// ```
#[derive(Clone, Debug)]
pub struct OutputDir {
    path: PathBuf,
    /// In a run's staging directory ([`super::RunDir`]), the flushes to disk of the files
    /// written so far, each running on its own thread; `None` elsewhere. Nothing reads a
    /// staging directory before the run moves it into place, and the run waits for these
    /// flushes and syncs the directory once before that move (see [`OutputDir::write_atomic`]).
    staged: Option<Arc<PendingSyncs>>,
}

/// The flushes to disk of a staging directory's files, not yet waited for.
type PendingSyncs = Mutex<Vec<JoinHandle<Result<(), ReportError>>>>;

/// Two handles are equal when they name the same directory in the same role.
impl PartialEq for OutputDir {
    fn eq(&self, other: &Self) -> bool {
        self.path == other.path && self.staged.is_some() == other.staged.is_some()
    }
}

impl Eq for OutputDir {}

/// Distinguishes concurrent writers of the same name within one process; the process id
/// distinguishes processes.
static TEMP_COUNTER: AtomicU64 = AtomicU64::new(0);

impl OutputDir {
    /// Creates the directory (and its parents) if needed and returns a handle to it.
    ///
    /// # Errors
    /// [`ReportError::Io`] if the directory cannot be created or the path exists and is not a
    /// directory.
    pub fn create(path: impl AsRef<Path>) -> Result<Self, ReportError> {
        let path = path.as_ref().to_path_buf();
        fs::create_dir_all(&path).map_err(|source| ReportError::Io {
            path: path.clone(),
            source,
        })?;
        Ok(Self { path, staged: None })
    }

    /// A handle to the directory `path`, which the caller has created: unlike
    /// [`OutputDir::create`] it never creates it again (a staging directory removed by an
    /// interrupt must stay removed).
    pub(super) fn existing(path: &Path) -> Self {
        Self {
            path: path.to_path_buf(),
            staged: None,
        }
    }

    /// This directory as a run's staging directory (see the `staged` field).
    pub(super) fn staged(self) -> Self {
        Self {
            staged: Some(Arc::default()),
            ..self
        }
    }

    /// Records a flush to wait for, as [`write_staged`] does: for tests that stand in for a
    /// slow or failing disk.
    #[cfg(test)]
    pub(super) fn push_pending(&self, sync: JoinHandle<Result<(), ReportError>>) {
        if let Some(pending) = &self.staged {
            pending.lock().unwrap().push(sync);
        }
    }

    /// Waits for the flushes to disk of every file written into this staging directory so
    /// far, all of them even when one fails; the first failure is returned.
    pub(super) fn wait_for_syncs(&self) -> Result<(), ReportError> {
        let Some(pending) = &self.staged else {
            return Ok(());
        };
        let handles = std::mem::take(&mut *pending.lock().unwrap_or_else(|p| p.into_inner()));
        let mut first = Ok(());
        for handle in handles {
            let done = handle.join().unwrap_or_else(|_| {
                Err(ReportError::Io {
                    path: self.path.clone(),
                    source: std::io::Error::other("the thread flushing a file panicked"),
                })
            });
            if first.is_ok() {
                first = done;
            }
        }
        first
    }

    /// The directory's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Writes `bytes` to the file `name` in this directory, atomically: the bytes go to a
    /// hidden temporary file in the same directory, are flushed to disk, and the temporary file
    /// is then renamed over `name`. Readers (and a later run after a crash) see either the old
    /// file or the complete new one. Returns the final path.
    ///
    /// In a run's staging directory ([`super::RunDir::out`]), which nobody reads before the
    /// run's commit puts it in place as a whole, the bytes go straight to `name` and are
    /// flushed to disk on a thread of their own, beside the rest of the run; the commit waits
    /// for every such flush before it moves the directory ([`super::RunDir::commit`]).
    ///
    /// # Errors
    /// [`ReportError::BadFileName`] if `name` is not a plain file name (so nothing can be written
    /// outside the directory), [`ReportError::Io`] if any step fails; the temporary file is
    /// removed on failure.
    pub fn write_atomic(&self, name: &str, bytes: &[u8]) -> Result<PathBuf, ReportError> {
        self.check_name(name)?;
        let target = self.path.join(name);
        if let Some(pending) = &self.staged {
            return write_staged(pending, target, bytes);
        }
        let temp = self.path.join(format!(
            ".{name}.{}.{}.tmp",
            std::process::id(),
            TEMP_COUNTER.fetch_add(1, Ordering::Relaxed)
        ));
        let io_err = |path: &Path| {
            let path = path.to_path_buf();
            move |source| ReportError::Io { path, source }
        };
        let written = (|| {
            let mut file = OpenOptions::new()
                .write(true)
                .create_new(true)
                .open(&temp)
                .map_err(io_err(&temp))?;
            file.write_all(bytes).map_err(io_err(&temp))?;
            // Without the sync, a crash soon after the rename can leave `name` pointing at an
            // empty or partial file on some file systems.
            file.sync_all().map_err(io_err(&temp))?;
            drop(file);
            fs::rename(&temp, &target).map_err(io_err(&target))
        })();
        if let Err(err) = written {
            // Best effort: the temporary may not exist if creating it was what failed.
            let _ = fs::remove_file(&temp);
            return Err(err);
        }
        // The new entry made durable.
        sync_dir(&self.path)?;
        Ok(target)
    }

    pub(super) fn check_name(&self, name: &str) -> Result<(), ReportError> {
        let plain = !name.is_empty()
            && name != "."
            && name != ".."
            && !name.contains(['/', '\\', '\0'])
            && Path::new(name).file_name().is_some_and(|f| f == name);
        if plain {
            Ok(())
        } else {
            Err(ReportError::BadFileName {
                path: self.path.clone(),
                name: name.to_string(),
            })
        }
    }

    /// The path `name` would be written to, after checking it is a plain file name.
    pub(super) fn file_path(&self, name: &str) -> Result<PathBuf, ReportError> {
        self.check_name(name)?;
        Ok(self.path.join(name))
    }
}

/// Writes `bytes` to `target` in a staging directory and starts its flush to disk on a thread
/// of its own, recorded in `pending`. A file that cannot be written is removed, so that the
/// directory never holds a partial file under its final name.
fn write_staged(
    pending: &PendingSyncs,
    target: PathBuf,
    bytes: &[u8],
) -> Result<PathBuf, ReportError> {
    let written = OpenOptions::new()
        .write(true)
        .create(true)
        .truncate(true)
        .open(&target)
        .and_then(|mut file| file.write_all(bytes).map(|()| file));
    let file = match written {
        Ok(file) => file,
        Err(source) => {
            // Best effort: the file may not exist if creating it was what failed.
            let _ = fs::remove_file(&target);
            return Err(ReportError::Io {
                path: target,
                source,
            });
        }
    };
    let path = target.clone();
    // A flush waits on the disk, not on a core: on a thread of its own it overlaps the
    // run's remaining work and the other files' flushes (which a journaling file system
    // commits together).
    let sync = std::thread::spawn(move || {
        crate::base::timeline::mark("file: fsync start");
        let synced = file
            .sync_all()
            .map_err(|source| ReportError::Io { path, source });
        crate::base::timeline::mark("file: fsync end");
        synced
    });
    pending.lock().unwrap_or_else(|p| p.into_inner()).push(sync);
    Ok(target)
}

/// Makes the rename itself durable: the new directory entry is only on disk once the directory
/// is synced. Windows cannot open directories as files, and NTFS journals renames, so there it
/// is skipped.
pub(super) fn sync_dir(dir: &Path) -> Result<(), ReportError> {
    if cfg!(unix) {
        File::open(dir)
            .and_then(|d| d.sync_all())
            .map_err(|source| ReportError::Io {
                path: dir.to_path_buf(),
                source,
            })?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(tag: &str) -> PathBuf {
        std::env::temp_dir().join(format!("fpsolve-output-{tag}-{}", std::process::id()))
    }

    fn entries(dir: &Path) -> Vec<String> {
        let mut names: Vec<String> = fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }

    #[test]
    fn replaces_content_and_leaves_no_temporaries() {
        let root = scratch("replace");
        let dir = OutputDir::create(&root).unwrap();
        let long = vec![b'x'; 10_000];
        dir.write_atomic("a.csv", &long).unwrap();
        let path = dir.write_atomic("a.csv", b"short").unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"short");
        assert_eq!(entries(&root), vec!["a.csv".to_string()]);
        fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn refuses_names_that_leave_the_directory() {
        let root = scratch("names");
        let dir = OutputDir::create(&root).unwrap();
        for bad in [
            "",
            ".",
            "..",
            "../x.csv",
            "sub/x.csv",
            "/etc/passwd",
            "a\\b",
        ] {
            match dir.write_atomic(bad, b"x") {
                Err(ReportError::BadFileName { name, .. }) => assert_eq!(name, bad),
                other => panic!("{bad:?}: expected BadFileName, got {other:?}"),
            }
        }
        assert!(entries(&root).is_empty());
        fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn failed_write_names_the_path_and_cleans_up() {
        let root = scratch("fail");
        let dir = OutputDir::create(&root).unwrap();
        // A directory in the way makes the final rename fail after the temporary was written.
        fs::create_dir(root.join("taken")).unwrap();
        fs::write(root.join("taken").join("inner"), b"keep").unwrap();
        match dir.write_atomic("taken", b"new") {
            Err(ReportError::Io { path, .. }) => assert_eq!(path, root.join("taken")),
            other => panic!("expected Io error, got {other:?}"),
        }
        assert_eq!(entries(&root), vec!["taken".to_string()]);
        fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn create_fails_on_a_file() {
        let root = scratch("file");
        fs::create_dir_all(&root).unwrap();
        let file = root.join("plain");
        fs::write(&file, b"x").unwrap();
        match OutputDir::create(&file) {
            Err(ReportError::Io { path, .. }) => assert_eq!(path, file),
            other => panic!("expected Io error, got {other:?}"),
        }
        fs::remove_dir_all(&root).unwrap();
    }
}
