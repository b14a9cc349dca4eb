//! Output files and directories that appear whole or not at all.
//!
//! Every output of frameid goes through this crate:
//!
//! - [`write_file`] writes a file atomically: a temporary file next to the
//!   target, flushed to disk, then renamed over it. If the target is a
//!   symbolic link, its final target is written (the link stays a link);
//!   a target that exists and is not a regular file (a directory, a device,
//!   a pipe) is refused. The file gets the permissions of any file the
//!   program creates (`0666` minus the umask), not the private `0600` of
//!   temporary files.
//! - [`OutputDir`] builds a directory of results in a sibling temporary
//!   directory and renames it into place in one step ([`OutputDir::commit`]):
//!   an interrupted run leaves no half-written directory, only a hidden
//!   sibling (`.NAME.frameid-tmp-*`) that the next run removes
//!   ([`OutputDir::create`] cleans them). An existing directory is replaced
//!   only if it is empty or holds a previous output of the same kind (it
//!   contains the `marker` file); anything else is refused, so that a user's
//!   directory is never deleted by mistake.
//! - [`interrupted`] tells whether SIGINT/SIGTERM arrived after
//!   [`on_interrupt_remove`] registered the temporary paths to remove.
//!
//! # Example
//!
//! ```
//! let dir = tempfile::tempdir().expect("a temporary directory");
//! let target = dir.path().join("out.txt");
//! fsio::write_file(&target, b"hello\n")?;
//! assert_eq!(std::fs::read(&target).unwrap(), b"hello\n");
//!
//! let out = fsio::OutputDir::create(&dir.path().join("sweep"), "sweep.json")?;
//! fsio::write_file(&out.path().join("sweep.json"), b"{}\n")?;
//! let done = out.commit()?;
//! assert!(done.join("sweep.json").exists());
//! # Ok::<(), fsio::FsError>(())
//! ```

#![deny(missing_docs)]

use std::io::Write as _;
use std::path::{Path, PathBuf};

/// What could not be written, and why. Messages name the path.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FsError {
    /// The operating system refused an operation. The message is
    /// self-contained (the I/O error is a field, not a chained source, so
    /// error chains do not print it twice).
    #[error("{}: cannot {op}: {error}", path.display())]
    Io {
        /// The file or directory.
        path: PathBuf,
        /// What was attempted.
        op: &'static str,
        /// The operating system's error.
        error: std::io::Error,
    },
    /// The target exists and is not what can be replaced.
    #[error("{}: {problem}", path.display())]
    Refused {
        /// The target.
        path: PathBuf,
        /// Why it is not replaced.
        problem: String,
    },
}

impl FsError {
    fn io(path: &Path, op: &'static str, error: std::io::Error) -> Self {
        FsError::Io {
            path: path.to_path_buf(),
            op,
            error,
        }
    }

    /// The underlying I/O error, if any (to tell a full disk or a broken
    /// pipe from other failures).
    pub fn io_error(&self) -> Option<&std::io::Error> {
        match self {
            FsError::Io { error, .. } => Some(error),
            FsError::Refused { .. } => None,
        }
    }
}

/// The path to write for `path`: the final target of a symbolic link (a
/// relative link resolved against the link's directory), else `path`.
/// Refuses a target that exists and is not a regular file.
pub fn resolve_target(path: &Path) -> Result<PathBuf, FsError> {
    let mut current = path.to_path_buf();
    for _ in 0..40 {
        match std::fs::symlink_metadata(&current) {
            Ok(m) if m.file_type().is_symlink() => {
                let link = std::fs::read_link(&current)
                    .map_err(|e| FsError::io(&current, "read link", e))?;
                current = match current.parent() {
                    Some(dir) if link.is_relative() => dir.join(link),
                    _ => link,
                };
            }
            Ok(m) if m.is_file() => return Ok(current),
            Ok(m) => {
                let kind = if m.is_dir() {
                    "a directory"
                } else {
                    "not a regular file (a device, pipe or socket)"
                };
                return Err(FsError::Refused {
                    path: path.to_path_buf(),
                    problem: format!("is {kind}; give a file name to write"),
                });
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(current),
            Err(e) => return Err(FsError::io(&current, "inspect", e)),
        }
    }
    Err(FsError::Refused {
        path: path.to_path_buf(),
        problem: "too many levels of symbolic links".into(),
    })
}

/// Writes `bytes` to `path` atomically (see the crate docs).
pub fn write_file(path: &Path, bytes: &[u8]) -> Result<(), FsError> {
    let target = resolve_target(path)?;
    let dir = match target.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let Some(name) = target.file_name() else {
        return Err(FsError::Refused {
            path: path.to_path_buf(),
            problem: "the path names no file".into(),
        });
    };
    let mut builder = tempfile::Builder::new();
    let prefix = format!(".{}.", name.to_string_lossy());
    builder.prefix(&prefix).suffix(".tmp");
    #[cfg(unix)]
    {
        // 0666 at creation: the kernel applies the umask, as for any file.
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(0o666));
    }
    let mut tmp = builder
        .tempfile_in(&dir)
        .map_err(|e| FsError::io(path, "create a temporary file next to it", e))?;
    tmp.write_all(bytes)
        .and_then(|()| tmp.flush())
        .and_then(|()| tmp.as_file().sync_all())
        .map_err(|e| FsError::io(path, "write the temporary file", e))?;
    tmp.persist(&target)
        .map_err(|e| FsError::io(path, "move the temporary file into place", e.error))?;
    Ok(())
}

/// A directory of results being built next to its final place.
#[derive(Debug)]
pub struct OutputDir {
    target: PathBuf,
    tmp: Option<PathBuf>,
}

const TMP_TAG: &str = ".frameid-tmp-";
const OLD_TAG: &str = ".frameid-old-";

impl OutputDir {
    /// Starts building `target`. Refuses a target that is not a directory,
    /// or a non-empty directory without `marker` (not an output of this
    /// kind). Removes temporary siblings left by interrupted runs.
    pub fn create(target: &Path, marker: &str) -> Result<OutputDir, FsError> {
        let parent = match target.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        let name = target
            .file_name()
            .ok_or_else(|| FsError::Refused {
                path: target.to_path_buf(),
                problem: "the path names no directory".into(),
            })?
            .to_string_lossy()
            .into_owned();
        check_replaceable(target, marker)?;
        std::fs::create_dir_all(&parent)
            .map_err(|e| FsError::io(&parent, "create directory", e))?;
        remove_stale(&parent, &name);
        let tmp = tempfile::Builder::new()
            .prefix(&format!(".{name}{TMP_TAG}"))
            .tempdir_in(&parent)
            .map_err(|e| FsError::io(target, "create a temporary directory next to it", e))?
            .keep();
        #[cfg(unix)]
        {
            // tempdir creates 0700: give the directory the permissions of
            // any directory the program creates (0777 minus the umask).
            use std::os::unix::fs::PermissionsExt;
            let mode = 0o777 & !umask();
            std::fs::set_permissions(&tmp, std::fs::Permissions::from_mode(mode))
                .map_err(|e| FsError::io(&tmp, "set permissions", e))?;
        }
        register(&tmp);
        Ok(OutputDir {
            target: target.to_path_buf(),
            tmp: Some(tmp),
        })
    }

    /// Where to write the files now.
    pub fn path(&self) -> &Path {
        self.tmp.as_deref().expect("not committed yet")
    }

    /// The final place.
    pub fn target(&self) -> &Path {
        &self.target
    }

    /// Moves the directory into place (replacing a previous output) and
    /// returns its final path.
    pub fn commit(mut self) -> Result<PathBuf, FsError> {
        let tmp = self.tmp.take().expect("committed once");
        let target = self.target.clone();
        let result = (|| {
            if target.exists() {
                let old = sibling(&target, OLD_TAG);
                std::fs::rename(&target, &old)
                    .map_err(|e| FsError::io(&target, "move the previous output aside", e))?;
                register(&old);
                std::fs::rename(&tmp, &target)
                    .map_err(|e| FsError::io(&target, "move the new output into place", e))?;
                let _ = std::fs::remove_dir_all(&old);
                unregister(&old);
            } else {
                std::fs::rename(&tmp, &target)
                    .map_err(|e| FsError::io(&target, "move the new output into place", e))?;
            }
            Ok(target.clone())
        })();
        if result.is_err() {
            let _ = std::fs::remove_dir_all(&tmp);
        }
        unregister(&tmp);
        result
    }
}

impl Drop for OutputDir {
    /// An output that was not committed (an error, a panic) is removed.
    fn drop(&mut self) {
        if let Some(tmp) = self.tmp.take() {
            let _ = std::fs::remove_dir_all(&tmp);
            unregister(&tmp);
        }
    }
}

fn sibling(target: &Path, tag: &str) -> PathBuf {
    let name = target
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let unique = format!(
        "{}-{}",
        std::process::id(),
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos())
    );
    target.with_file_name(format!(".{name}{tag}{unique}"))
}

/// Refuses a target that is not a directory, or a non-empty one without
/// `marker`.
fn check_replaceable(target: &Path, marker: &str) -> Result<(), FsError> {
    match std::fs::symlink_metadata(target) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
        Err(e) => Err(FsError::io(target, "inspect", e)),
        Ok(m) if !m.is_dir() => Err(FsError::Refused {
            path: target.to_path_buf(),
            problem: "exists and is not a directory".into(),
        }),
        Ok(_) => {
            let mut entries =
                std::fs::read_dir(target).map_err(|e| FsError::io(target, "list directory", e))?;
            if entries.next().is_none() || target.join(marker).exists() {
                Ok(())
            } else {
                Err(FsError::Refused {
                    path: target.to_path_buf(),
                    problem: format!(
                        "is a non-empty directory that is not a previous output (no {marker}); give a new or empty directory"
                    ),
                })
            }
        }
    }
}

/// Removes `.NAME.frameid-tmp-*` and `.NAME.frameid-old-*` siblings left
/// by interrupted runs.
fn remove_stale(parent: &Path, name: &str) {
    let Ok(entries) = std::fs::read_dir(parent) else {
        return;
    };
    for entry in entries.flatten() {
        let file = entry.file_name().to_string_lossy().into_owned();
        let stale = [TMP_TAG, OLD_TAG]
            .iter()
            .any(|tag| file.starts_with(&format!(".{name}{tag}")));
        if stale {
            let _ = std::fs::remove_dir_all(entry.path());
        }
    }
}

#[cfg(unix)]
fn umask() -> u32 {
    // The umask can only be read by setting it; set it back at once. Only
    // the permission bits of new directories depend on it.
    unsafe extern "C" {
        fn umask(mask: u32) -> u32;
    }
    // SAFETY: umask(2) has no preconditions and cannot fail.
    unsafe {
        let old = umask(0o022);
        umask(old);
        old
    }
}

static PENDING: std::sync::Mutex<Vec<PathBuf>> = std::sync::Mutex::new(Vec::new());
static INTERRUPTED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

fn register(path: &Path) {
    if let Ok(mut p) = PENDING.lock() {
        p.push(path.to_path_buf());
    }
}

fn unregister(path: &Path) {
    if let Ok(mut p) = PENDING.lock() {
        p.retain(|x| x != path);
    }
}

/// Removes every temporary directory still being built; for a handler of
/// SIGINT/SIGTERM, which then exits. Returns what it removed.
pub fn on_interrupt_remove() -> Vec<PathBuf> {
    INTERRUPTED.store(true, std::sync::atomic::Ordering::SeqCst);
    let pending = match PENDING.lock() {
        Ok(mut p) => std::mem::take(&mut *p),
        Err(_) => Vec::new(),
    };
    for p in &pending {
        let _ = std::fs::remove_dir_all(p);
    }
    pending
}

/// Whether [`on_interrupt_remove`] ran.
pub fn interrupted() -> bool {
    INTERRUPTED.load(std::sync::atomic::Ordering::SeqCst)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn files_follow_symlinks_and_refuse_non_regular_targets() {
        let dir = tempfile::tempdir().unwrap();
        let real = dir.path().join("real.html");
        std::fs::write(&real, b"old").unwrap();
        let link = dir.path().join("link.html");
        std::os::unix::fs::symlink("real.html", &link).unwrap();
        write_file(&link, b"new").unwrap();
        assert!(
            std::fs::symlink_metadata(&link)
                .unwrap()
                .file_type()
                .is_symlink()
        );
        assert_eq!(std::fs::read(&real).unwrap(), b"new");
        let e = write_file(dir.path(), b"x").unwrap_err();
        assert!(e.to_string().contains("is a directory"), "{e}");
        let e = write_file(Path::new("/dev/null"), b"x").unwrap_err();
        assert!(e.to_string().contains("not a regular file"), "{e}");
        // No temporary file left.
        let names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names.len(), 2, "{names:?}");
    }

    #[test]
    fn files_get_the_umask_permissions() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("f.json");
        write_file(&p, b"{}").unwrap();
        let mode = std::fs::metadata(&p).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, 0o666 & !umask());
    }

    #[test]
    fn directories_appear_whole_and_replace_only_outputs() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("sweep");
        let out = OutputDir::create(&target, "sweep.json").unwrap();
        write_file(&out.path().join("sweep.json"), b"1").unwrap();
        assert!(!target.exists(), "nothing in place before commit");
        out.commit().unwrap();
        assert_eq!(std::fs::read(target.join("sweep.json")).unwrap(), b"1");
        // A rerun replaces it whole.
        let out = OutputDir::create(&target, "sweep.json").unwrap();
        write_file(&out.path().join("sweep.json"), b"2").unwrap();
        out.commit().unwrap();
        assert_eq!(std::fs::read(target.join("sweep.json")).unwrap(), b"2");
        // Dropped without commit: nothing changes, nothing is left.
        let out = OutputDir::create(&target, "sweep.json").unwrap();
        write_file(&out.path().join("sweep.json"), b"3").unwrap();
        drop(out);
        assert_eq!(std::fs::read(target.join("sweep.json")).unwrap(), b"2");
        // A stale temporary sibling of a crashed run is cleaned.
        std::fs::create_dir(dir.path().join(".sweep.frameid-tmp-crashed")).unwrap();
        OutputDir::create(&target, "sweep.json")
            .unwrap()
            .commit()
            .unwrap();
        let names: Vec<String> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        assert_eq!(names, ["sweep"]);
        // A user's directory is not replaced.
        let mine = dir.path().join("mine");
        std::fs::create_dir(&mine).unwrap();
        std::fs::write(mine.join("notes.txt"), b"keep").unwrap();
        let e = OutputDir::create(&mine, "sweep.json").unwrap_err();
        assert!(e.to_string().contains("not a previous output"), "{e}");
    }
}
