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
        /// The file.
        path: PathBuf,
        /// What was attempted.
        op: IoOp,
        /// The operating system's error.
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
        /// The file.
        path: PathBuf,
        /// Where in the file (boxed to keep the error small); possibly empty.
        at: Box<Location>,
        /// What is wrong there.
        problem: Problem,
    },

    /// No channel of the record matches the requested one.
    #[error(
        "{}: no channel matches '{spec}'; available channels: {}",
        path.display(),
        available.join(", ")
    )]
    ChannelNotFound {
        /// The record file searched.
        path: PathBuf,
        /// The selector as the user wrote it ([`ChannelSpec`](crate::ChannelSpec) text form).
        spec: String,
        /// Every channel of the file, as labels `#k name [unit] (node n dir)`
        /// (1-based `k`), to choose from.
        available: Vec<String>,
    },

    /// Several channels match the requested one.
    #[error(
        "{}: '{spec}' matches more than one channel: {}; use a more specific selector (e.g. '#N')",
        path.display(),
        matches.join(", ")
    )]
    AmbiguousChannel {
        /// The record file searched.
        path: PathBuf,
        /// The selector as the user wrote it.
        spec: String,
        /// The channels it matches, labelled as in `ChannelNotFound`.
        matches: Vec<String>,
    },

    /// A channel selector string could not be understood.
    #[error("invalid channel selector '{spec}': {reason}")]
    InvalidSpec {
        /// The selector text as given.
        spec: String,
        /// What is wrong with it and what was expected.
        reason: String,
    },

    /// The read options are unusable (e.g. a negative sampling rate).
    #[error("invalid read options: {reason}")]
    InvalidOptions {
        /// Which option is unusable and why.
        reason: String,
    },

    /// A record handed to a writer cannot be written faithfully.
    #[error("{}: refusing to write: {reason}", path.display())]
    InvalidRecord {
        /// The target file (when writing) or the record's own path (when encoding).
        path: PathBuf,
        /// What would not read back unchanged (e.g. a name the format cannot hold).
        reason: String,
    },

    /// Two records of a campaign are not compatible.
    #[error("{}", campaign_message(reference, other, mismatch))]
    Campaign {
        /// The campaign's first record, which the others must match.
        reference: PathBuf,
        /// The record that differs.
        other: PathBuf,
        /// How it differs.
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

    /// FRF files that do not make one FRF matrix (see
    /// [`assemble`](crate::frf::assemble)).
    #[error("cannot assemble the FRFs: {problem}")]
    FrfSet {
        /// What is wrong (boxed to keep the error small).
        problem: Box<crate::frf::FrfSetProblem>,
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

    /// A selected channel declares a unit that is not a force (inputs) or
    /// an acceleration (outputs): its values cannot be brought to N or m/s^2.
    #[error(
        "{}: channel {channel} is in '{unit}', {problem}; {} must be {}",
        path.display(),
        if *input { "inputs" } else { "outputs" },
        if *input {
            "forces (N, kN, lbf or kgf; converted to N)"
        } else {
            "accelerations (m/s^2, mm/s^2, cm/s^2, g, in/s^2 or ft/s^2; converted to m/s^2)"
        }
    )]
    ChannelUnit {
        /// The record whose channels were selected.
        path: PathBuf,
        /// The channel, labelled `#k name [unit]`.
        channel: String,
        /// The unit as the file declares it.
        unit: String,
        /// Whether the channel was selected as an input.
        input: bool,
        /// What the unit is instead (`a displacement unit`, `not a force unit`).
        problem: String,
    },
}

/// Which file operation failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum IoOp {
    /// Reading a record file (or its metadata).
    Read,
    /// Creating the temporary file next to a target. (Writes now go through
    /// [`fsio`] and fail with [`RecordError::Output`]; kept for callers that
    /// match on it.)
    CreateTemp,
    /// Writing and flushing the temporary file.
    Write,
    /// Renaming the temporary file over the target.
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
    /// A whole line (1-based, as an editor counts it).
    pub fn line(line: usize) -> Self {
        Location {
            line: Some(line),
            ..Location::default()
        }
    }

    /// A CSV cell: 1-based line and column, with the column's name as field.
    pub fn cell(line: usize, column: usize, name: &str) -> Self {
        Location {
            line: Some(line),
            column: Some(column),
            field: Some(name.to_string()),
            ..Location::default()
        }
    }

    /// True when nothing is known about the place (it then renders as "").
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
    /// Nothing to read: no non-blank line (CSV) or no dataset (UFF).
    #[error("the file is empty")]
    EmptyFile,
    /// The file starts with a UTF-16 byte-order mark.
    #[error("the file is UTF-16 encoded; save it as UTF-8 (or ASCII) text")]
    Utf16,
    /// A NUL byte in the first 8 KiB of a file read as text.
    #[error("binary content that is not a UFF file (found a NUL byte)")]
    NotText,
    /// A value that does not parse as a number.
    #[error("'{text}' is not a number")]
    NonNumeric {
        /// The text found (an excerpt if long).
        text: String,
    },
    /// A value that parses as NaN or an infinity: records hold finite samples.
    #[error("value '{text}' is NaN or infinite")]
    NonFinite {
        /// The text found.
        text: String,
    },

    // ----- CSV -----
    /// A header row and nothing after it.
    #[error("header row but no data rows")]
    HeaderOnly,
    /// A data cell with nothing in it (a missing sample).
    #[error("empty cell")]
    EmptyCell,
    /// A data row whose cell count differs from the header's.
    #[error("row has {found} cells but the header has {expected} columns")]
    RaggedRow {
        /// Columns of the header.
        expected: usize,
        /// Cells of this row.
        found: usize,
    },
    /// A `"` opens a field that the line does not close.
    #[error("quoted field is not closed on this line")]
    UnterminatedQuote,
    /// A header cell that is empty (after trimming and removing a `[unit]`).
    #[error("column has an empty name")]
    EmptyColumnName,
    /// An empty line between data rows (it would shift every later sample).
    #[error("blank line inside the data (only trailing blank lines are allowed)")]
    BlankLine,
    /// A column named like a time axis that is not the first one.
    #[error("a time column must be the first column")]
    MisplacedTimeColumn,
    /// The time column's unit is neither seconds nor a known fraction of them.
    #[error("time unit '{unit}' is not supported (use s, ms or us)")]
    UnsupportedTimeUnit {
        /// The unit as written in the header.
        unit: String,
    },
    /// Only a time column.
    #[error("the file has no channels besides the time column")]
    NoChannels,
    /// Neither a time column nor a sampling rate in the read options.
    #[error(
        "no time column (first column named time, t, time_s, 'time [s]' ...) and no sampling rate given; pass fs_hz"
    )]
    NoTimeColumnNoFs,
    /// One data row and no sampling rate in the read options.
    #[error("a single sample does not define a sampling interval; pass fs_hz")]
    SingleSample,

    // ----- time axis (CSV time column, uneven UFF abscissa) -----
    /// A time value that is not after the previous one (all times in seconds).
    #[error("time {value} is not after the previous time {previous} ({})", if value == previous { "repeated" } else { "decreasing" })]
    TimeNotIncreasing {
        /// The previous time (s).
        previous: f64,
        /// This time (s), equal to or before `previous`.
        value: f64,
    },
    /// A step between successive times that is not the median step (a
    /// missing or repeated sample). See the printing tolerance in the crate's
    /// time-axis check.
    #[error(
        "time step {step} differs from the median step {dt} by more than the tolerance {tolerance}: time is not uniformly sampled (missing or repeated sample?)"
    )]
    NonUniformStep {
        /// This step `t[i] - t[i-1]` (s).
        step: f64,
        /// The median step of the column (s).
        dt: f64,
        /// The largest deviation allowed for this step (s, at most `0.45 dt`).
        tolerance: f64,
    },
    /// A time off the grid `t0 + i dt` fitted to the end points (a slow drift
    /// that no single step shows).
    #[error(
        "time {value} is off the uniform grid (expected {expected}, dt {dt}, tolerance {tolerance}): time is not uniformly sampled"
    )]
    NonUniformTime {
        /// The time found (s).
        value: f64,
        /// Its place on the grid (s).
        expected: f64,
        /// The mean interval (s).
        dt: f64,
        /// The largest deviation allowed for this value (s, at most `0.45 dt`).
        tolerance: f64,
    },
    /// The times are finite but their differences are not.
    #[error("time span overflows a double")]
    TimeOverflow,
    /// A sampling rate was given in the read options and the file's own time
    /// axis disagrees with it beyond its printing precision.
    #[error("fs_hz = {fs_hz} was given, but the file's sampling interval is {file_dt_s} s ({} Hz)", 1.0 / file_dt_s)]
    FsMismatch {
        /// The sampling rate given (Hz).
        fs_hz: f64,
        /// The sampling interval of the file (s).
        file_dt_s: f64,
    },

    /// A time axis whose unit the file does not state (a CSV column headed
    /// `time` or `t`, a UFF abscissa labelled `NONE` or blank) and whose
    /// interval, taken in seconds, is 1 s or more: too slow for any
    /// structural test, and what times in milliseconds read as seconds
    /// look like. Declaring the unit or passing `fs_hz` lifts the refusal.
    #[error(
        "the time axis states no unit and, read as seconds, its interval is {dt_s} s ({} Hz sampling), too slow for a structural test: are the times in milliseconds? {declare}, or pass fs_hz",
        1.0 / dt_s
    )]
    UndeclaredTimeUnit {
        /// The interval read with the axis taken in seconds (s).
        dt_s: f64,
        /// How to state the unit in this format, e.g. "write the header
        /// `'time [ms]'` (or `'time [s]'` if they are seconds)".
        declare: String,
    },

    // ----- UFF -----
    /// A line where a dataset must open or close (`    -1`) holds something else.
    #[error("expected a dataset delimiter line '    -1', found '{found}'")]
    UffExpectedDelimiter {
        /// The line found (an excerpt if long).
        found: String,
    },
    /// The file or the dataset ends before all its records.
    #[error("dataset is truncated: {missing}")]
    UffTruncated {
        /// Where it ends, e.g. "its closing '-1' comes before record 7 of 11".
        missing: String,
    },
    /// A header field that does not parse or is out of range (the location
    /// names the record and field).
    #[error("bad value '{text}': {reason}")]
    UffBadField {
        /// The field's text (an excerpt if long).
        text: String,
        /// What was expected.
        reason: String,
    },
    /// A dataset 58 that is not a time response (an FRF, a spectrum, ...).
    #[error(
        "function type {func_type} ({}) is not supported; only 1 (time response) is{}",
        func_type_name(*func_type),
        if *func_type == 4 || *func_type == 6 { " (this is an FRF file: read it as FRFs)" } else { "" }
    )]
    UffUnsupportedFunction {
        /// Record 6 field 1: the UFF function type (1 = time response).
        func_type: i64,
    },
    /// Ordinate values that are not real (complex or of an unknown type).
    #[error(
        "ordinate data type {ord_type} ({}) is not supported; only 2 (real single) and 4 (real double) are",
        ord_type_name(*ord_type)
    )]
    UffUnsupportedOrdinate {
        /// Record 7 field 1: the ordinate data type (2 real single, 4 real double).
        ord_type: i64,
    },
    /// The ASCII data section holds a different number of values than record 7
    /// declares.
    #[error(
        "record 7 (line {record7_line}) declares {declared} values, but the data section holds {found}"
    )]
    UffCountMismatch {
        /// Values declared in record 7 (`u64::MAX` if it could not be read).
        declared: u64,
        /// Values in the data section.
        found: u64,
        /// Line of record 7 (1-based).
        record7_line: usize,
    },
    /// The binary dataset header's byte count disagrees with record 7.
    #[error(
        "binary header declares {declared} data bytes, but record 7 implies {expected} ({values} values of {bytes_per_value} bytes)"
    )]
    UffByteCountMismatch {
        /// Data bytes declared in the binary header.
        declared: u64,
        /// Bytes implied by record 7: `values x bytes_per_value` (`u64::MAX` if
        /// it cannot be computed).
        expected: u64,
        /// Values declared in record 7 (`u64::MAX` if it could not be read).
        values: u64,
        /// 4 (real single) or 8 (real double).
        bytes_per_value: u64,
    },
    /// A binary dataset in a floating-point format or byte order this reader
    /// does not decode.
    #[error("binary layout not supported: {what}")]
    UffUnsupportedBinary {
        /// The header field and its value, with what is supported.
        what: String,
    },
    /// A dataset 58 in an FRF file that is neither an FRF nor a coherence.
    #[error(
        "function type {func_type} ({}) is not an FRF; an FRF file holds function types 4 (frequency response function) and 6 (coherence){}",
        func_type_name(*func_type),
        if *func_type == 1 { " (this is a time record: read it as a record)" } else { "" }
    )]
    UffNotFrf {
        /// Record 6 field 1: the UFF function type found.
        func_type: i64,
    },
    /// An ordinate data type that does not fit the function type: FRFs are
    /// complex, coherences real.
    #[error(
        "ordinate data type {ord_type} ({}) does not fit function type {func_type} ({}): {}",
        ord_type_name(*ord_type),
        func_type_name(*func_type),
        if *func_type == 4 { "an FRF is complex (5 complex single or 6 complex double)" } else { "a coherence is real (2 real single or 4 real double)" }
    )]
    UffFrfOrdinate {
        /// Record 7 field 1: the ordinate data type (2, 4 real; 5, 6 complex).
        ord_type: i64,
        /// Record 6 field 1: the function type (4 FRF, 6 coherence).
        func_type: i64,
    },
    /// An FRF whose abscissa is not a frequency in hertz.
    #[error(
        "the abscissa is {found}, not a frequency in Hz (record 8: specific data type 18 or 0, unit Hz or kHz)"
    )]
    FrfAbscissa {
        /// What record 8 states (specific data type and unit label).
        found: String,
    },
    /// An FRF whose quantity (receptance, mobility, accelerance) or unit
    /// cannot be decided from the file, or is contradictory.
    #[error("cannot decide the FRF's quantity or unit: {reason}")]
    FrfUnit {
        /// What the file states and why it does not decide (names the unit
        /// label or data type found).
        reason: String,
    },
    /// A coherence (function type 6) with no FRF of the same response and
    /// reference in the file.
    #[error(
        "coherence of response {response} and reference {reference} has no FRF of the same pair in the file"
    )]
    FrfOrphanCoherence {
        /// The response point (`node:direction` or name).
        response: String,
        /// The reference point.
        reference: String,
    },
    /// A coherence value outside [0, 1].
    #[error("coherence {value} is outside [0, 1]")]
    FrfBadCoherence {
        /// The value found.
        value: f64,
    },
    /// Two FRFs (or two coherences) of the same response and reference in one file.
    #[error(
        "a second {what} of response {response} and reference {reference}; the first is {first}"
    )]
    FrfDuplicatePair {
        /// `FRF` or `coherence`.
        what: &'static str,
        /// The response point.
        response: String,
        /// The reference point.
        reference: String,
        /// The dataset (1-based) of the first one.
        first: usize,
    },
    /// The FRFs of one file are on different frequency grids.
    #[error(
        "{what} is {value}, but dataset {first} has {first_value}; all FRFs of a file share one frequency grid"
    )]
    FrfGridMismatch {
        /// Which property differs (number of lines, a frequency).
        what: String,
        /// Its value here.
        value: String,
        /// The dataset (1-based) compared with: the file's first FRF.
        first: usize,
        /// Its value there.
        first_value: String,
    },
    /// A frequency that is negative or not above the previous one.
    #[error("frequency {value} Hz {reason}")]
    FrfBadFrequency {
        /// The frequency (Hz).
        value: f64,
        /// What is wrong (`is negative`, `is not above the previous line (x Hz)`).
        reason: String,
    },
    /// A CSV FRF header that does not follow the convention (see `records::frf`).
    #[error("{reason}")]
    FrfCsvHeader {
        /// What is wrong with the header cell and what was expected.
        reason: String,
    },
    /// An FRF file that does not state something the reader needs (the
    /// quantity of a CSV column without unit; the points and quantity of a
    /// headerless file), and the read option that would supply it is absent.
    #[error("the file does not state {what}; give FrfReadOptions::{option}")]
    FrfMissingOption {
        /// The option's field name in `FrfReadOptions`.
        option: &'static str,
        /// What the file does not state.
        what: &'static str,
    },
    /// A complex number that is not in the form its notation requires.
    #[error("'{text}' is not a complex number ({reason})")]
    NotComplex {
        /// The text found (an excerpt if long).
        text: String,
        /// What was expected.
        reason: &'static str,
    },
    /// The file holds UFF datasets, none of them a dataset 58.
    #[error("no dataset 58 (function at nodal DOF) in the file{}", if found.is_empty() { String::new() } else { format!("; datasets found: {}", found.iter().map(|d| d.to_string()).collect::<Vec<_>>().join(", ")) })]
    UffNoDataset58 {
        /// The dataset numbers found, in file order (empty for none).
        found: Vec<u32>,
    },
    /// The channels (datasets) of one file do not share length, start time
    /// and sampling interval.
    #[error(
        "{what} is {value}, but dataset {first_dataset} has {first_value}; all channels of a file must share length, start and sampling interval"
    )]
    UffDatasetMismatch {
        /// Which property differs: the number of samples, the sampling interval
        /// or the start time.
        what: &'static str,
        /// Its value in this dataset (with its unit).
        value: String,
        /// The first dataset 58 of the file (1-based position), the reference.
        first_dataset: usize,
        /// Its value there.
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

/// How two records of a campaign differ (records of different lengths are
/// one campaign: only the sampling must agree).
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum CampaignMismatch {
    /// Sampling intervals that differ by more than
    /// [`CAMPAIGN_DT_REL_TOL`](crate::CAMPAIGN_DT_REL_TOL) relative.
    SamplingInterval {
        /// Interval of the reference (first) record (s).
        reference_s: f64,
        /// Interval of the other record (s).
        other_s: f64,
    },
}

fn campaign_message(reference: &Path, other: &Path, mismatch: &CampaignMismatch) -> String {
    let (r, o) = (reference.display(), other.display());
    match mismatch {
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
