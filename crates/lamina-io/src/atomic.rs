//! Atomic file writes: the target appears whole or not at all.
//!
//! [`write_file`] writes into a temporary file `.<name>.lamina-tmp-<pid>-<n>` in the target's
//! own folder (so the final rename never crosses a file system), flushes it to disk
//! (`fsync`), renames it over the target (atomic on POSIX: a reader sees the old file or the
//! new one, never a mix) and then syncs the folder so the rename itself survives a crash
//! (best effort). On any error the temporary file is removed and the target is untouched.
//!
//! Every temporary file and folder in flight is recorded, so that a Ctrl-C that ends the
//! process at once ([`crate::interrupt`]) removes them first: an interrupted command leaves
//! neither a half-written output nor a stray temporary file.

use std::collections::BTreeSet;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};

/// A file could not be written; the target was left as it was.
#[derive(Debug, thiserror::Error)]
#[error("cannot write '{path}': {what}: {source}")]
pub struct WriteError {
    /// The file the caller asked for (not the temporary name).
    pub path: PathBuf,
    /// The step that failed, in words.
    pub what: &'static str,
    /// The operating system's or the encoder's error.
    #[source]
    pub source: std::io::Error,
}

/// Temporary files and folders being written now: removed by [`remove_temporaries`].
static IN_FLIGHT: Mutex<BTreeSet<PathBuf>> = Mutex::new(BTreeSet::new());
static COUNTER: AtomicU64 = AtomicU64::new(0);

/// A temporary path that is removed when dropped unless [`Temporary::keep`] was called,
/// and removed by [`remove_temporaries`] if the process is interrupted meanwhile.
#[derive(Debug)]
pub(crate) struct Temporary {
    path: PathBuf,
    is_dir: bool,
    armed: bool,
}

impl Temporary {
    /// A fresh sibling name of `target`: `.<name>.lamina-tmp-<pid>-<n>` in the same folder.
    pub(crate) fn sibling_of(target: &Path, is_dir: bool) -> Result<Temporary, WriteError> {
        let Some(name) = target.file_name() else {
            return Err(WriteError {
                path: target.to_owned(),
                what: "the path names no file",
                source: std::io::ErrorKind::InvalidInput.into(),
            });
        };
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        let tmp_name = format!(
            ".{}.lamina-tmp-{}-{n}",
            name.to_string_lossy(),
            std::process::id()
        );
        let path = target.with_file_name(tmp_name);
        lock_in_flight().insert(path.clone());
        Ok(Temporary {
            path,
            is_dir,
            armed: true,
        })
    }

    pub(crate) fn path(&self) -> &Path {
        &self.path
    }

    /// The temporary path has been renamed away (or emptied by the caller): forget it.
    pub(crate) fn keep(mut self) {
        self.armed = false;
        lock_in_flight().remove(&self.path);
    }
}

impl Drop for Temporary {
    fn drop(&mut self) {
        if self.armed {
            remove_path(&self.path, self.is_dir);
            lock_in_flight().remove(&self.path);
        }
    }
}

fn lock_in_flight() -> std::sync::MutexGuard<'static, BTreeSet<PathBuf>> {
    // A panic while holding the lock cannot leave the set inconsistent (insert and remove
    // are single calls), so a poisoned lock is still usable.
    IN_FLIGHT.lock().unwrap_or_else(|p| p.into_inner())
}

fn remove_path(path: &Path, is_dir: bool) {
    // Only ever called on our own `.lamina-tmp-` names.
    if is_dir {
        let _ = std::fs::remove_dir_all(path);
    } else {
        let _ = std::fs::remove_file(path);
    }
}

/// Removes every temporary file and folder still in flight (called before the process
/// ends on Ctrl-C). Uses `try_lock` so that it never waits on a writer.
pub fn remove_temporaries() {
    remove_temporaries_where(|_| true);
}

fn remove_temporaries_where(select: impl Fn(&Path) -> bool) {
    let Ok(set) = IN_FLIGHT.try_lock() else {
        return;
    };
    for p in set.iter().filter(|p| select(p)) {
        remove_path(p, p.is_dir());
    }
}

/// Writes the file `path` atomically: `write` fills a buffered temporary file in the same
/// folder, which is then flushed, synced and renamed over `path`. The folder must exist.
/// An existing *folder* at `path` is an error (never replaced).
pub fn write_file(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> std::io::Result<()>,
) -> Result<(), WriteError> {
    let err = |what: &'static str| {
        move |source| WriteError {
            path: path.to_owned(),
            what,
            source,
        }
    };
    if path.is_dir() {
        return Err(err("it is a folder")(
            std::io::ErrorKind::IsADirectory.into(),
        ));
    }
    let tmp = Temporary::sibling_of(path, false)?;
    let file = File::create(tmp.path()).map_err(err("cannot create a temporary file"))?;
    let mut out = BufWriter::new(file);
    write(&mut out).map_err(err("cannot write"))?;
    let file = out
        .into_inner()
        .map_err(|e| err("cannot write")(e.into_error()))?;
    file.sync_all().map_err(err("cannot flush to disk"))?;
    drop(file);
    std::fs::rename(tmp.path(), path).map_err(err("cannot rename the temporary file"))?;
    tmp.keep();
    sync_parent(path);
    Ok(())
}

/// Writes `bytes` to `path` atomically (see [`write_file`]).
pub fn write_bytes(path: &Path, bytes: &[u8]) -> Result<(), WriteError> {
    write_file(path, |w| w.write_all(bytes))
}

/// Syncs the folder holding `path`, so that a rename into it is on disk (best effort: not
/// every platform or file system can open a folder for syncing).
pub(crate) fn sync_parent(path: &Path) {
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    if let Ok(d) = File::open(parent) {
        let _ = d.sync_all();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let d =
            std::env::temp_dir().join(format!("lamina-io-atomic-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    fn entries(d: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn writes_and_replaces_whole_files() {
        let d = scratch("replace");
        let p = d.join("a.txt");
        write_bytes(&p, b"one").unwrap();
        write_bytes(&p, b"two").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"two");
        assert_eq!(entries(&d), ["a.txt"]);
    }

    #[test]
    fn a_failing_writer_leaves_the_old_file_and_no_temporary() {
        let d = scratch("fail");
        let p = d.join("a.txt");
        std::fs::write(&p, b"precious").unwrap();
        let e = write_file(&p, |w| {
            w.write_all(b"half")?;
            Err(std::io::Error::other("encoder gave up"))
        })
        .unwrap_err();
        assert!(e.to_string().contains("a.txt"), "{e}");
        assert!(e.to_string().contains("encoder gave up"), "{e}");
        assert_eq!(std::fs::read(&p).unwrap(), b"precious");
        assert_eq!(entries(&d), ["a.txt"]);
        assert!(IN_FLIGHT.lock().unwrap().iter().all(|t| !t.starts_with(&d)));
    }

    #[test]
    fn a_folder_is_never_replaced_by_a_file() {
        let d = scratch("dir");
        let p = d.join("out.png");
        std::fs::create_dir(&p).unwrap();
        std::fs::write(p.join("keep"), b"x").unwrap();
        let e = write_bytes(&p, b"img").unwrap_err();
        assert!(e.to_string().contains("folder"), "{e}");
        assert!(p.join("keep").exists());
    }

    #[test]
    fn a_missing_folder_is_an_error_naming_the_file() {
        let d = scratch("missing");
        let p = d.join("no/such/dir/out.csv");
        let e = write_bytes(&p, b"x").unwrap_err();
        assert!(e.to_string().contains("out.csv"), "{e}");
    }

    #[test]
    fn interrupted_temporaries_are_removed() {
        let d = scratch("interrupt");
        let p = d.join("x.bin");
        let t = Temporary::sibling_of(&p, false).unwrap();
        std::fs::write(t.path(), b"partial").unwrap();
        assert_eq!(entries(&d).len(), 1);
        // (Only this test's folder: the other tests run in parallel in this process.)
        remove_temporaries_where(|t| t.starts_with(&d));
        assert!(entries(&d).is_empty());
        drop(t);
    }
}
