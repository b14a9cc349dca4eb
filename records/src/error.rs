//! Error type of the record layer.
//!
//! Every refusal names the file, and for content problems the place in it
//! (UFF dataset, line, column or record field) and what is wrong, so that a
//! user can open the file in an editor and see the problem.

use std::fmt;
use std::path::{Path, PathBuf};

/// What the record layer could not do, and why.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RecordError {
    /// The operating system refused a file operation. The message is
    /// self-contained (the I/O error is not chained as a source, so error
    /// chains do not print it twice).
    #[error("{}: cannot {op}: {error}", path.display())]
    Io {
        path: PathBuf,
        op: IoOp,
        error: std::io::Error,
    },

    /// An output file could not be written (the message names it).
    #[error(transparent)]
    Output(#[from] fsio::FsError),

    /// The file is larger than a record file can be.
    #[error("{}: {bytes} bytes, more than the {limit} bytes a record file may have", path.display())]
    TooLarge {
        /// The file.
        path: PathBuf,
        /// Its size.
        bytes: u64,
        /// The limit ([`crate::MAX_FILE_BYTES`]).
        limit: u64,
    },

    /// The file content is not a usable record.
    #[error("{}: {at}{problem}", path.display())]
    Parse {
        path: PathBuf,
        at: Box<Location>,
        problem: Problem,
    },

    /// No channel of the record matches the requested one.
    #[error(
        "{}: no channel matches '{spec}'; available channels: {}",
        path.display(),
        available.join(", ")
    )]
    ChannelNotFound {
        path: PathBuf,
        spec: String,
        available: Vec<String>,
    },

    /// Several channels match the requested one.
    #[error(
        "{}: '{spec}' matches more than one channel: {}; use a more specific selector (e.g. '#N')",
        path.display(),
        matches.join(", ")
    )]
    AmbiguousChannel {
        path: PathBuf,
        spec: String,
        matches: Vec<String>,
    },

    /// A channel selector string could not be understood.
    #[error("invalid channel selector '{spec}': {reason}")]
    InvalidSpec { spec: String, reason: String },

    /// The read options are unusable (e.g. a negative sampling rate).
    #[error("invalid read options: {reason}")]
    InvalidOptions { reason: String },

    /// A record handed to a writer cannot be written faithfully.
    #[error("{}: refusing to write: {reason}", path.display())]
    InvalidRecord { path: PathBuf, reason: String },

    /// Two records of a campaign are not compatible.
    #[error("{}", campaign_message(reference, other, mismatch))]
    Campaign {
        reference: PathBuf,
        other: PathBuf,
        mismatch: CampaignMismatch,
    },

    /// A campaign needs at least one record.
    #[error("a campaign needs at least one record file")]
    EmptyCampaign,

    /// A realization file is not usable.
    #[error("{}: {problem}", path.display())]
    Realization {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        problem: String,
    },

    /// Every channel of the record is an input: nothing to identify.
    #[error("{}: no output channels besides the input", path.display())]
    NoOutputs {
        /// The record whose channels were selected.
        path: PathBuf,
    },

    /// A channel was selected both as an input and as an output.
    #[error("{}: channel '{channel}' is selected both as input and as output", path.display())]
    OutputIsInput {
        /// The record whose channels were selected.
        path: PathBuf,
        /// The channel's name.
        channel: String,
    },
}

/// Which file operation failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum IoOp {
    Read,
    CreateTemp,
    Write,
    Replace,
}

impl fmt::Display for IoOp {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            IoOp::Read => "read the file",
            IoOp::CreateTemp => "create a temporary file next to it",
            IoOp::Write => "write the temporary file",
            IoOp::Replace => "move the temporary file into place",
        })
    }
}

/// Where in a file a problem was found. All parts are optional; lines and
/// columns are 1-based, datasets are counted from 1 in file order.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Location {
    /// UFF dataset (1-based position in the file).
    pub dataset: Option<usize>,
    /// Line as an editor counts it (binary payloads included).
    pub line: Option<usize>,
    /// CSV column (1-based, the time column included).
    pub column: Option<usize>,
    /// Column name, UFF record/field, or sample position.
    pub field: Option<String>,
}

impl Location {
    pub fn line(line: usize) -> Self {
        Location {
            line: Some(line),
            ..Location::default()
        }
    }

    pub fn cell(line: usize, column: usize, name: &str) -> Self {
        Location {
            line: Some(line),
            column: Some(column),
            field: Some(name.to_string()),
            ..Location::default()
        }
    }

    pub fn is_empty(&self) -> bool {
        self.dataset.is_none()
            && self.line.is_none()
            && self.column.is_none()
            && self.field.is_none()
    }
}

/// Renders as "dataset 2, line 14, record 7 field 2 (number of values): "
/// or "line 5, column 3 (acc2): "; empty when nothing is known.
impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.is_empty() {
            return Ok(());
        }
        let mut parts = Vec::new();
        if let Some(d) = self.dataset {
            parts.push(format!("dataset {d}"));
        }
        if let Some(l) = self.line {
            parts.push(format!("line {l}"));
        }
        match (self.column, &self.field) {
            (Some(c), Some(name)) => parts.push(format!("column {c} ({name})")),
            (Some(c), None) => parts.push(format!("column {c}")),
            (None, Some(name)) => parts.push(name.clone()),
            (None, None) => {}
        }
        write!(f, "{}: ", parts.join(", "))
    }
}

/// What is wrong with a file's content.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Problem {
    // ----- any format -----
    #[error("the file is empty")]
    EmptyFile,
    #[error("the file is UTF-16 encoded; save it as UTF-8 (or ASCII) text")]
    Utf16,
    #[error("binary content that is not a UFF file (found a NUL byte)")]
    NotText,
    #[error("'{text}' is not a number")]
    NonNumeric { text: String },
    #[error("value '{text}' is NaN or infinite")]
    NonFinite { text: String },

    // ----- CSV -----
    #[error("header row but no data rows")]
    HeaderOnly,
    #[error("empty cell")]
    EmptyCell,
    #[error("row has {found} cells but the header has {expected} columns")]
    RaggedRow { expected: usize, found: usize },
    #[error("quoted field is not closed on this line")]
    UnterminatedQuote,
    #[error("column has an empty name")]
    EmptyColumnName,
    #[error("blank line inside the data (only trailing blank lines are allowed)")]
    BlankLine,
    #[error("a time column must be the first column")]
    MisplacedTimeColumn,
    #[error("time unit '{unit}' is not supported (use s, ms or us)")]
    UnsupportedTimeUnit { unit: String },
    #[error("the file has no channels besides the time column")]
    NoChannels,
    #[error(
        "no time column (first column named time, t, time_s, 'time [s]' ...) and no sampling rate given; pass fs_hz"
    )]
    NoTimeColumnNoFs,
    #[error("a single sample does not define a sampling interval; pass fs_hz")]
    SingleSample,

    // ----- time axis (CSV time column, uneven UFF abscissa) -----
    #[error("time {value} is not after the previous time {previous} ({})", if value == previous { "repeated" } else { "decreasing" })]
    TimeNotIncreasing { previous: f64, value: f64 },
    #[error(
        "time step {step} differs from the mean interval {dt} by more than the tolerance {tolerance}: time is not uniformly sampled (missing or repeated sample?)"
    )]
    NonUniformStep { step: f64, dt: f64, tolerance: f64 },
    #[error(
        "time {value} is off the uniform grid (expected {expected}, dt {dt}, tolerance {tolerance}): time is not uniformly sampled"
    )]
    NonUniformTime {
        value: f64,
        expected: f64,
        dt: f64,
        tolerance: f64,
    },
    #[error("time span overflows a double")]
    TimeOverflow,
    #[error("fs_hz = {fs_hz} was given, but the file's sampling interval is {file_dt_s} s ({} Hz)", 1.0 / file_dt_s)]
    FsMismatch { fs_hz: f64, file_dt_s: f64 },

    // ----- UFF -----
    #[error("expected a dataset delimiter line '    -1', found '{found}'")]
    UffExpectedDelimiter { found: String },
    #[error("dataset is truncated: {missing}")]
    UffTruncated { missing: String },
    #[error("bad value '{text}': {reason}")]
    UffBadField { text: String, reason: String },
    #[error(
        "function type {func_type} ({}) is not supported; only 1 (time response) is",
        func_type_name(*func_type)
    )]
    UffUnsupportedFunction { func_type: i64 },
    #[error(
        "ordinate data type {ord_type} ({}) is not supported; only 2 (real single) and 4 (real double) are",
        ord_type_name(*ord_type)
    )]
    UffUnsupportedOrdinate { ord_type: i64 },
    #[error(
        "record 7 (line {record7_line}) declares {declared} values, but the data section holds {found}"
    )]
    UffCountMismatch {
        declared: u64,
        found: u64,
        record7_line: usize,
    },
    #[error(
        "binary header declares {declared} data bytes, but record 7 implies {expected} ({values} values of {bytes_per_value} bytes)"
    )]
    UffByteCountMismatch {
        declared: u64,
        expected: u64,
        values: u64,
        bytes_per_value: u64,
    },
    #[error("binary layout not supported: {what}")]
    UffUnsupportedBinary { what: String },
    #[error("no dataset 58 (function at nodal DOF) in the file{}", if found.is_empty() { String::new() } else { format!("; datasets found: {}", found.iter().map(|d| d.to_string()).collect::<Vec<_>>().join(", ")) })]
    UffNoDataset58 { found: Vec<u32> },
    #[error(
        "{what} is {value}, but dataset {first_dataset} has {first_value}; all channels of a file must share length, start and sampling interval"
    )]
    UffDatasetMismatch {
        what: &'static str,
        value: String,
        first_dataset: usize,
        first_value: String,
    },
}

fn func_type_name(t: i64) -> &'static str {
    match t {
        0 => "general or unknown",
        1 => "time response",
        2 => "auto spectrum",
        3 => "cross spectrum",
        4 => "frequency response function",
        5 => "transmissibility",
        6 => "coherence",
        7 => "auto correlation",
        8 => "cross correlation",
        9 => "power spectral density",
        10 => "energy spectral density",
        11 => "probability density function",
        12 => "spectrum",
        _ => "other",
    }
}

fn ord_type_name(t: i64) -> &'static str {
    match t {
        2 => "real single",
        4 => "real double",
        5 => "complex single",
        6 => "complex double",
        _ => "unknown",
    }
}

/// How two records of a campaign differ.
#[derive(Debug, Clone, PartialEq)]
pub enum CampaignMismatch {
    Length { reference: usize, other: usize },
    SamplingInterval { reference_s: f64, other_s: f64 },
}

fn campaign_message(reference: &Path, other: &Path, mismatch: &CampaignMismatch) -> String {
    let (r, o) = (reference.display(), other.display());
    match mismatch {
        CampaignMismatch::Length {
            reference: nr,
            other: no,
        } => format!("campaign records differ in length: {o} has {no} samples but {r} has {nr}"),
        CampaignMismatch::SamplingInterval {
            reference_s,
            other_s,
        } => format!(
            "campaign records differ in sampling: {o} has dt = {other_s} s ({} Hz) but {r} has dt = {reference_s} s ({} Hz)",
            1.0 / other_s,
            1.0 / reference_s
        ),
    }
}
