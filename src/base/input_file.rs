//! Reading an input file the user named: a regular file of bounded size, or a refusal that
//! says why. Every reader of a model, a Monte Carlo result, a shard or a sweep shard goes
//! through [`read_regular_file`], so that `/dev/zero`, a FIFO, a directory or a file larger
//! than any real one is refused at once instead of read until the kernel stops the process
//! (or, for a FIFO, waited on forever).

use std::fs::{File, Metadata, OpenOptions};
use std::io::{self, Read};
use std::path::Path;

/// Largest result file (`mc_summary.json`, `mc_<quantity>.csv`, `shard_*.json`,
/// `sweep_shard_*.json`) a reader accepts, in bytes (16 GiB). The largest shard a run can
/// write is bounded by [`crate::base::limits::MEMORY_LIMIT_BYTES`] (4 GiB of counts, 8 bytes a bin of
/// a batch) and is written at up to about 18 bytes a bin of a batch (measured: 36.2 MB for
/// 20 batches of 10⁵ bins), about 9 GB; a summary takes about 76 bytes a bin (76 MB for
/// 10⁶ bins).
pub const MAX_RESULT_FILE_BYTES: u64 = 16 * 1024 * 1024 * 1024;

/// Why an input file was refused before its contents were read; carried inside the
/// [`io::Error`] [`read_regular_file`] returns (kind `InvalidInput` or `FileTooLarge`),
/// recovered with `error.get_ref().and_then(|e| e.downcast_ref::<FileRefusal>())`.
///
/// ```
/// use fpsolve::base::input_file::FileRefusal;
/// let e = FileRefusal::NotRegular { kind: "a directory" };
/// assert_eq!(e.to_string(), "not a regular file (a directory)");
/// ```
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum FileRefusal {
    /// A directory, a device, a FIFO or a socket: nothing a run writes.
    #[error("not a regular file ({kind})")]
    NotRegular {
        /// What it is instead.
        kind: &'static str,
    },
    /// Larger than any file of its kind has reason to be.
    #[error("{bytes} bytes, more than the {limit} a file of this kind can hold")]
    TooLarge {
        /// The file's size (at least; it may have grown while read).
        bytes: u64,
        /// The limit.
        limit: u64,
    },
}

impl From<FileRefusal> for io::Error {
    fn from(r: FileRefusal) -> io::Error {
        let kind = match r {
            FileRefusal::NotRegular { .. } => io::ErrorKind::InvalidInput,
            FileRefusal::TooLarge { .. } => io::ErrorKind::FileTooLarge,
        };
        io::Error::new(kind, r)
    }
}

/// The refusal inside an error of [`read_regular_file`], if it is one.
///
/// ```
/// use fpsolve::base::input_file::{read_regular_file, refusal, FileRefusal};
/// let e = read_regular_file("/dev/null".as_ref(), 10).unwrap_err();
/// assert!(matches!(refusal(&e), Some(FileRefusal::NotRegular { .. })));
/// ```
pub fn refusal(e: &io::Error) -> Option<&FileRefusal> {
    e.get_ref().and_then(|inner| inner.downcast_ref())
}

fn kind_of(meta: &Metadata) -> &'static str {
    let t = meta.file_type();
    if t.is_dir() {
        return "a directory";
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_fifo() {
            return "a FIFO";
        }
        if t.is_socket() {
            return "a socket";
        }
        if t.is_char_device() {
            return "a character device";
        }
        if t.is_block_device() {
            return "a block device";
        }
    }
    "not a file"
}

fn check(meta: &Metadata, limit: u64) -> Result<(), FileRefusal> {
    if !meta.is_file() {
        return Err(FileRefusal::NotRegular {
            kind: kind_of(meta),
        });
    }
    if meta.len() > limit {
        return Err(FileRefusal::TooLarge {
            bytes: meta.len(),
            limit,
        });
    }
    Ok(())
}

/// Opens without waiting: a FIFO with no writer would otherwise block the open itself.
fn open(path: &Path) -> io::Result<File> {
    let mut options = OpenOptions::new();
    options.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        options.custom_flags(libc::O_NONBLOCK);
    }
    options.open(path)
}

/// The bytes of `path`, which must be a regular file (symbolic links followed) of at most
/// `limit` bytes. The kind and size are checked before the file is opened (no device is
/// opened) and again on the open file (so a file swapped in between is caught), and at most
/// `limit + 1` bytes are ever read.
///
/// # Errors
/// The operating system's error, or a [`FileRefusal`] inside an [`io::Error`] (see
/// [`refusal`]).
///
/// ```
/// use fpsolve::base::input_file::{read_regular_file, refusal, FileRefusal};
/// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
/// assert!(read_regular_file(&path, 1 << 20).is_ok());
/// let e = read_regular_file(&path, 10).unwrap_err();
/// assert!(matches!(refusal(&e), Some(FileRefusal::TooLarge { limit: 10, .. })));
/// let e = read_regular_file("/dev/zero".as_ref(), 1 << 20).unwrap_err();
/// assert_eq!(e.to_string(), "not a regular file (a character device)");
/// ```
pub fn read_regular_file(path: &Path, limit: u64) -> io::Result<Vec<u8>> {
    check(&std::fs::metadata(path)?, limit)?;
    let file = open(path)?;
    let meta = file.metadata()?;
    check(&meta, limit)?;
    let mut bytes = Vec::with_capacity(meta.len() as usize);
    file.take(limit.saturating_add(1)).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > limit {
        return Err(FileRefusal::TooLarge {
            bytes: bytes.len() as u64,
            limit,
        }
        .into());
    }
    Ok(bytes)
}

/// [`read_regular_file`] as UTF-8 text.
///
/// # Errors
/// Those of [`read_regular_file`], and `InvalidData` when the bytes are not UTF-8.
///
/// ```
/// use fpsolve::base::input_file::read_regular_text;
/// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
/// assert!(read_regular_text(&path, 1 << 20).unwrap().contains("model"));
/// ```
pub fn read_regular_text(path: &Path, limit: u64) -> io::Result<String> {
    String::from_utf8(read_regular_file(path, limit)?)
        .map_err(|e| io::Error::new(io::ErrorKind::InvalidData, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("fpsolve-input-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[test]
    fn refuses_what_is_not_a_regular_file_at_once() {
        let dir = scratch("kinds");
        let link = dir.join("zero.json");
        std::os::unix::fs::symlink("/dev/zero", &link).unwrap();
        let fifo = dir.join("fifo.json");
        let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
        // SAFETY: a valid NUL-terminated path.
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
        let t = std::time::Instant::now();
        for (path, kind) in [
            (link.as_path(), "a character device"),
            (fifo.as_path(), "a FIFO"),
            (dir.as_path(), "a directory"),
        ] {
            let e = read_regular_file(path, MAX_RESULT_FILE_BYTES).unwrap_err();
            assert_eq!(
                refusal(&e),
                Some(&FileRefusal::NotRegular { kind }),
                "{path:?}"
            );
        }
        assert!(t.elapsed().as_secs_f64() < 1.0);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn refuses_a_file_over_the_limit_without_reading_it() {
        let dir = scratch("size");
        let big = dir.join("big.json");
        // Sparse: 64 GiB claimed, nothing written; reading it would take minutes.
        File::create(&big).unwrap().set_len(64 << 30).unwrap();
        let t = std::time::Instant::now();
        let e = read_regular_file(&big, MAX_RESULT_FILE_BYTES).unwrap_err();
        assert_eq!(
            refusal(&e),
            Some(&FileRefusal::TooLarge {
                bytes: 64 << 30,
                limit: MAX_RESULT_FILE_BYTES
            })
        );
        assert!(t.elapsed().as_secs_f64() < 1.0);
        let small = dir.join("small.json");
        std::fs::write(&small, b"{}").unwrap();
        assert_eq!(read_regular_file(&small, 2).unwrap(), b"{}");
        assert!(refusal(&read_regular_file(&small, 1).unwrap_err()).is_some());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
