//! Writing output files atomically, through [`fsio`].

use std::path::Path;

use crate::error::RecordError;

/// Writes `bytes` to `path` atomically (see [`fsio::write_file`]): a
/// temporary file next to the target, flushed, then renamed over it; a
/// symbolic link is followed, a target that is not a regular file is
/// refused, permissions follow the umask. On any failure `path` is
/// untouched and no temporary file is left.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<(), RecordError> {
    fsio::write_file(path, bytes).map_err(RecordError::from)
}
