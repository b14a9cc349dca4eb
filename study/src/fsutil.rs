//! Writing the harness's JSON files atomically.

use std::path::Path;

use crate::error::StudyError;

/// Serializes `value` as pretty JSON (with a final newline) and writes it
/// atomically (see [`records::write_atomically`]).
pub fn write_json<T: serde::Serialize>(path: &Path, value: &T) -> Result<(), StudyError> {
    let mut text = serde_json::to_string_pretty(value)
        .map_err(|e| StudyError::bad_file(path, None, format!("cannot serialize to JSON: {e}")))?;
    text.push('\n');
    records::write_atomically(path, text.as_bytes())?;
    Ok(())
}

/// Reads and parses a JSON file; `what` says what it should be (in messages).
pub fn read_json<T: serde::de::DeserializeOwned>(path: &Path, what: &str) -> Result<T, StudyError> {
    let text = std::fs::read_to_string(path).map_err(|e| StudyError::io(path, "read", e))?;
    serde_json::from_str(&text)
        .map_err(|e| StudyError::bad_file(path, Some(e.line()), format!("not {what}: {e}")))
}
