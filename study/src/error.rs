//! The error type of the harness.

use std::path::PathBuf;

use crate::scenario::ScenarioError;

/// What the harness could not do, and why. Every variant names the file,
/// line or field concerned.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum StudyError {
    /// A scenario file (or a built-in scenario) is unusable.
    #[error(transparent)]
    Scenario(#[from] ScenarioError),

    /// A record file could not be written or read.
    #[error(transparent)]
    Record(#[from] records::RecordError),

    /// An output file or directory could not be written (the message names
    /// it).
    #[error(transparent)]
    Output(#[from] fsio::FsError),

    /// The operating system refused a file operation. The message is
    /// self-contained (the I/O error is kept as a field, not chained, so
    /// that error chains do not print it twice).
    #[error("{}: cannot {op}: {error}", path.display())]
    Io {
        /// The file or directory.
        path: PathBuf,
        /// What was attempted (`read`, `create directory`, ...).
        op: &'static str,
        /// The operating system's error.
        error: std::io::Error,
    },

    /// A file written by frameid (a sweep's `summary.json`, `sweep.json`,
    /// `trials.csv`, `representative.json`) does not have the expected
    /// content.
    #[error("{}: {}{problem}", path.display(), line.map(|l| format!("line {l}: ")).unwrap_or_default())]
    BadFile {
        /// The file.
        path: PathBuf,
        /// The 1-based line, if known.
        line: Option<usize>,
        /// What is wrong.
        problem: String,
    },

    /// A plan setting (trials, noise levels, seed, shard, threads) is out of
    /// range. `setting` is the name under which the caller set it.
    #[error("{setting}: {problem}")]
    InvalidSetting {
        /// The setting, as the caller named it (a flag or a field).
        setting: String,
        /// What is wrong.
        problem: String,
    },

    /// Sweep directories cannot be merged.
    #[error("{problem}")]
    Merge {
        /// What does not fit.
        problem: String,
    },

    /// The simulator refused the scenario (for an axis value of a sweep).
    #[error("{context}: {error}")]
    Simulation {
        /// Which scenario or axis value.
        context: String,
        /// The simulator's error.
        error: sim::SimError,
    },

    /// The worker threads could not be started.
    #[error("cannot start the worker threads: {0}")]
    Threads(#[from] rayon::ThreadPoolBuildError),
}

impl StudyError {
    /// An I/O error on `path`.
    pub fn io(path: impl Into<PathBuf>, op: &'static str, error: std::io::Error) -> Self {
        StudyError::Io {
            path: path.into(),
            op,
            error,
        }
    }

    /// A content problem in a file frameid wrote.
    pub fn bad_file(
        path: impl Into<PathBuf>,
        line: Option<usize>,
        problem: impl Into<String>,
    ) -> Self {
        StudyError::BadFile {
            path: path.into(),
            line,
            problem: problem.into(),
        }
    }
}
