//! Writing output files atomically.

use std::io::Write as _;
use std::path::Path;

use crate::error::{IoOp, RecordError};

/// Writes `bytes` to a temporary file in the target's directory, flushes it
/// to disk and renames it over `path`. On any failure the temporary file is
/// removed and `path` is untouched. The file gets the permissions of a file
/// created the ordinary way (0666 minus the umask).
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<(), RecordError> {
    let io_err = |op, error| RecordError::Io {
        path: path.to_path_buf(),
        op,
        error,
    };
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let Some(name) = path.file_name() else {
        return Err(io_err(
            IoOp::CreateTemp,
            std::io::Error::new(std::io::ErrorKind::InvalidInput, "the path names no file"),
        ));
    };
    let mut builder = tempfile::Builder::new();
    let prefix = format!(".{}.", name.to_string_lossy());
    builder.prefix(&prefix).suffix(".tmp");
    #[cfg(unix)]
    {
        // Same permissions as a file created the ordinary way (0666 minus
        // the umask) instead of the private 0600 of temporary files.
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(0o666));
    }
    let mut tmp = builder
        .tempfile_in(dir)
        .map_err(|e| io_err(IoOp::CreateTemp, e))?;
    tmp.write_all(bytes)
        .and_then(|()| tmp.flush())
        .and_then(|()| tmp.as_file().sync_all())
        .map_err(|e| io_err(IoOp::Write, e))?;
    tmp.persist(path)
        .map_err(|e| io_err(IoOp::Replace, e.error))?;
    Ok(())
}
