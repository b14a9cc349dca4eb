//! FRF files: measured frequency response functions as analyzers export
//! them, read into [`FrfFile`]s, collated across files into one
//! [`ident::Frf`] ([`assemble`]), and written back; identified modes
//! written as UFF dataset 55 ([`write_uff55`]).
//!
//! # What an FRF file is
//!
//! An [`FrfFile`] holds [`FrfPair`]s on one frequency grid: the FRF of one
//! response point over one reference (force) point, in SI units
//! ((m, m/s or m/s^2) per N, by [`FrfQuantity`]), with its coherence if the
//! file has one. Whether bytes hold FRFs or time records is decided from
//! the content ([`content_kind`]), never from the file name.
//!
//! # Universal File Format dataset 58, function type 4
//!
//! One dataset per response/reference pair (record 6: response node and
//! direction, reference node and direction), ASCII or binary (58b), complex
//! single or double ordinates (record 7 field 1: 5 or 6), even or uneven
//! abscissa. Coherences are datasets of function type 6 (real ordinates)
//! and belong to the FRF of the same pair in the same file. Other datasets
//! (151 header, 164 units, ...) are skipped, except that a dataset 164
//! before an FRF gives the unit system of FRFs without unit labels.
//!
//! - Abscissa (record 8): a frequency, specific data type 18 (or 0/1
//!   unknown/general), unit label `Hz`, `kHz` or none (Hz); anything else
//!   (time, rpm, order) is refused.
//! - Quantity: record 9 field 1 (ordinate numerator specific data type: 8
//!   displacement, 11 velocity, 12 acceleration) and record 10 field 1
//!   (denominator: 13 excitation force, 9 reaction force, or 0/1). Unit
//!   labels take precedence, as the format says (record 9 field 6: a
//!   response unit of [`units::MOTION_UNITS`](crate::units::MOTION_UNITS),
//!   or a whole FRF unit such as `g/N`; record 10 field 6: a force unit),
//!   and decide the quantity when the data type is 0 or 1; a label that
//!   contradicts the data type is refused. Without labels the values are
//!   in the unit system of a preceding dataset 164 (divided by its length
//!   factor, multiplied by its force factor), else SI. Unit exponents
//!   (records 9 and 10 fields 2-4) must be those of a translation over a
//!   force (length 0 or 1, force 0 and temperature 0 in record 9; length
//!   0, force 0 or 1, temperature 0 in record 10) or are refused.
//!   Rotational directions (4..6) are refused.
//! - Points: node 0 with direction 0 is a point without node
//!   ([`FrfPoint::node`] `None`). A point's name is its record 6 entity
//!   name when that is not `NONE` and names one node/direction only in the
//!   file, else `node:direction` (`3:+X`).
//! - frameid's writer puts `frameid f0_hz=… df_hz=… averages=…` into ID
//!   line 5 (record 7 holds the grid with 6 digits); the reader uses the
//!   exact values when they agree with record 7.
//!
//! # CSV: header convention
//!
//! ```text
//! frequency_hz,re H(acc2@2:+X/force@2:+X) [(m/s^2)/N],im H(acc2@2:+X/force@2:+X) [(m/s^2)/N],coh(acc2@2:+X/force@2:+X)
//! 0.5,1.25e-3,-3.5e-4,0.998
//! ```
//!
//! - Column 1: the frequency, named `frequency_hz`, `frequency`, `freq` or
//!   `f`, with an optional unit `[Hz]` or `[kHz]` (Hz if none).
//! - Then, in any order, for every pair: `re H(response/reference) [unit]`
//!   and `im H(response/reference) [unit]` (real and imaginary parts, the
//!   same unit: an FRF unit of [`units::frf_unit`](crate::units::frf_unit)
//!   such as `(m/s^2)/N`, `g/N`, `mm/N`), and optionally
//!   `coh(response/reference)` (the coherence, in [0, 1]).
//! - A point is `name` or `name@node:direction` (`acc2@2:+X`, direction as
//!   [`parse_direction`](crate::parse_direction) reads it); names hold no
//!   `/ @ ( ) [ ]` and no delimiter.
//! - Without a unit, [`FrfReadOptions::quantity`] (values in SI) or
//!   [`FrfReadOptions::unit`] must say what the values are.
//! - Delimiters, quoting and decimal commas as in record CSV files.
//!
//! # CSV: headerless complex notation
//!
//! `freq; H1; H2; ...` with Python's complex numbers
//! (`0.03125+0j;-0.0285-0.0434j;...`): the frequency's imaginary part must
//! be 0. Such a file states neither the points nor the quantity:
//! [`FrfReadOptions::quantity`] or [`FrfReadOptions::unit`],
//! [`FrfReadOptions::reference`] and [`FrfReadOptions::responses`] (one
//! per FRF column) are required, and their absence is an error naming the
//! option.
//!
//! # Conventions
//!
//! Frequencies in hertz, strictly ascending, non-negative. Values in SI,
//! time convention `e^{+i w t}` as in [`ident::frf`]. UFF directions
//! `1..6 = +X, +Y, +Z, +RX, +RY, +RZ`, negative for minus, 0 scalar.
//! Datasets and CSV columns in messages are 1-based.

mod assemble;
mod csv;
mod uff55;
mod uff58;

pub use assemble::{AssembleOptions, FrfSet, FrfSetProblem, assemble};
pub use uff55::{ExportMode, ModeShapeExport, encode_uff55, parse_uff55, read_uff55, write_uff55};

use std::fmt;
use std::path::{Path, PathBuf};

use ident::linalg::C64;
use ident::{Frf, FrfQuantity};

use crate::error::RecordError;
use crate::format::read_bytes;
use crate::spec::direction_label;
use crate::write::write_atomically;

/// Relative tolerance on frequencies that must be the same line (across
/// the datasets of a file and across files): UFF record 7 stores the first
/// line and the spacing with 6 significant digits (E13.5), so line `k` of
/// the same grid written by two programs can differ by `5e-6 f_k`.
pub const FREQUENCY_REL_TOL: f64 = 1e-5;

/// A measurement point: a response transducer or a force.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct FrfPoint {
    /// The name shown in messages and used as the output/reference name of
    /// the assembled [`Frf`] (UFF: entity name or `node:direction`; CSV:
    /// the name in the header; headerless CSV: from the read options).
    pub name: String,
    /// UFF node number, if known.
    pub node: Option<i64>,
    /// UFF direction `1..6 = +X, +Y, +Z, +RX, +RY, +RZ`, negative for
    /// minus, 0 scalar; `None` if unknown.
    pub direction: Option<i32>,
}

impl FrfPoint {
    /// A point known by name only.
    pub fn named(name: impl Into<String>) -> Self {
        FrfPoint {
            name: name.into(),
            node: None,
            direction: None,
        }
    }

    /// A point at a node and direction, named `node:direction` (`3:+X`).
    pub fn at(node: i64, direction: i32) -> Self {
        FrfPoint {
            name: default_name(node, direction),
            node: Some(node),
            direction: Some(direction),
        }
    }

    /// A named point at a node and direction.
    pub fn named_at(name: impl Into<String>, node: i64, direction: i32) -> Self {
        FrfPoint {
            name: name.into(),
            node: Some(node),
            direction: Some(direction),
        }
    }

    /// Whether two points are the same place: same node and direction when
    /// both know them, else the same name.
    pub fn same_point(&self, other: &FrfPoint) -> bool {
        match (self.node_dir(), other.node_dir()) {
            (Some(a), Some(b)) => a == b,
            _ => self.name == other.name,
        }
    }

    /// Node and direction when both are known.
    pub fn node_dir(&self) -> Option<(i64, i32)> {
        self.node.zip(self.direction)
    }
}

/// `name`, followed by ` (node 3 +X)` when the node is known and the name
/// does not already say it.
impl fmt::Display for FrfPoint {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.name)?;
        if let Some((n, d)) = self.node_dir()
            && self.name != default_name(n, d)
        {
            write!(f, " (node {n} {})", direction_label(d))?;
        }
        Ok(())
    }
}

/// Reads `NAME` or `NAME@NODE:DIR` (`force@2:+X`; the direction as
/// [`parse_direction`](crate::parse_direction) reads it), as command lines
/// and scripts name points.
impl std::str::FromStr for FrfPoint {
    type Err = String;

    fn from_str(text: &str) -> Result<Self, String> {
        let text = text.trim();
        match text.split_once('@') {
            None if !text.is_empty() => Ok(FrfPoint::named(text)),
            None => Err("empty point name".into()),
            Some((name, at)) => {
                let (node, dir) = at.split_once(':').ok_or_else(|| {
                    format!("expected NAME@NODE:DIR (e.g. force@2:+X), got '{text}'")
                })?;
                let node: i64 = node
                    .trim()
                    .parse()
                    .map_err(|_| format!("node '{node}' of '{text}' is not an integer"))?;
                let dir = crate::parse_direction(dir.trim()).ok_or_else(|| {
                    format!("direction '{dir}' of '{text}' is not one of +X, -X, +Y, ..., +RZ (or 1..6, -1..-6)")
                })?;
                if name.trim().is_empty() {
                    return Err(format!("'{text}' has no name before '@'"));
                }
                Ok(FrfPoint::named_at(name.trim(), node, dir))
            }
        }
    }
}

pub(crate) fn default_name(node: i64, direction: i32) -> String {
    format!("{node}:{}", direction_label(direction))
}

/// One measured FRF: a response over a reference on the file's grid.
#[derive(Debug, Clone, PartialEq)]
pub struct FrfPair {
    /// The response point (output).
    pub response: FrfPoint,
    /// The reference point (input force).
    pub reference: FrfPoint,
    /// What the response is (displacement, velocity, acceleration).
    pub quantity: FrfQuantity,
    /// `values[k]` at `frequency_hz[k]` of the file, in the SI unit of
    /// `quantity` ([`FrfQuantity::unit`]).
    pub values: Vec<C64>,
    /// Ordinary coherence per line, in [0, 1]; `None` if the file has none.
    pub coherence: Option<Vec<f64>>,
    /// Number of averages behind the estimate, if the file states it.
    pub averages: Option<usize>,
    /// Time constant (s) of the exponential window `exp(-t / tau)` the
    /// estimate was made with, if any: it adds `1 / tau` to every pole's
    /// decay rate, which identification removes. UFF58: `tau_s=` in ID
    /// line 4 (frameid's tag); CSV files do not carry it.
    pub exponential_tau_s: Option<f64>,
    /// Where in the file it was read, for messages (`dataset 3`,
    /// `columns 2-3`); empty for pairs built in memory.
    pub source: String,
}

/// The layout of an FRF file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FrfFormat {
    /// UFF dataset 58 function type 4, ASCII: complex double, 4E20.12 (13
    /// significant digits); the uneven abscissa E13.5 (6 digits).
    Uff58Ascii,
    /// UFF dataset 58b function type 4, little-endian IEEE doubles (exact).
    Uff58Binary,
    /// CSV with the header convention of the module docs; every number in
    /// the shortest form that reads back bit for bit.
    Csv,
    /// Headerless `freq; H1; H2; ...` with Python complex numbers
    /// (`;`-separated, shortest round-trip digits). It holds one reference
    /// and no points, quantity or coherence: reading it back needs
    /// [`FrfReadOptions`].
    CsvComplex,
}

impl FrfFormat {
    /// Short name, as in messages.
    pub fn name(self) -> &'static str {
        match self {
            FrfFormat::Uff58Ascii => "uff58 (ascii)",
            FrfFormat::Uff58Binary => "uff58 (binary)",
            FrfFormat::Csv => "csv",
            FrfFormat::CsvComplex => "csv (headerless complex)",
        }
    }
}

/// The FRFs of one file.
#[derive(Debug, Clone, PartialEq)]
pub struct FrfFile {
    /// The file read (or to be written).
    pub path: PathBuf,
    /// The layout it was read from.
    pub format: FrfFormat,
    /// Frequency lines in Hz: strictly ascending, non-negative, shared by
    /// every pair.
    pub frequency_hz: Vec<f64>,
    /// The FRFs, in file order (UFF: dataset order; CSV: order of the `re`
    /// columns).
    pub pairs: Vec<FrfPair>,
}

impl FrfFile {
    /// The pairs of an FRF matrix: `frf.values[k][(i, j)]` becomes pair
    /// `(responses[i], references[j])`, ordered by reference, then
    /// response; the coherence and averages are carried over.
    ///
    /// # Panics
    /// If the point counts differ from the FRF's outputs and references (a
    /// shape contract between code).
    pub fn from_frf(
        path: impl Into<PathBuf>,
        frf: &Frf,
        responses: &[FrfPoint],
        references: &[FrfPoint],
    ) -> FrfFile {
        assert_eq!(responses.len(), frf.outputs.len(), "one point per output");
        assert_eq!(
            references.len(),
            frf.references.len(),
            "one point per reference"
        );
        let mut pairs = Vec::with_capacity(responses.len() * references.len());
        for (j, reference) in references.iter().enumerate() {
            for (i, response) in responses.iter().enumerate() {
                pairs.push(FrfPair {
                    response: response.clone(),
                    reference: reference.clone(),
                    quantity: frf.quantity,
                    values: frf.values.iter().map(|h| h[(i, j)]).collect(),
                    coherence: frf
                        .coherence
                        .as_ref()
                        .map(|c| c.iter().map(|g| g[(i, j)]).collect()),
                    averages: frf.averages,
                    source: String::new(),
                    exponential_tau_s: None,
                });
            }
        }
        FrfFile {
            path: path.into(),
            format: FrfFormat::Uff58Binary,
            frequency_hz: frf.frequency_hz.clone(),
            pairs,
        }
    }

    /// Why the file cannot be written as it is (the grid is not strictly
    /// ascending and non-negative, a pair has the wrong length, a value is
    /// not finite, a coherence is outside [0, 1]); `None` if it can.
    pub fn consistency_problem(&self) -> Option<String> {
        let n = self.frequency_hz.len();
        if n == 0 {
            return Some("no frequency line".into());
        }
        if self.pairs.is_empty() {
            return Some("no FRF".into());
        }
        for (k, &f) in self.frequency_hz.iter().enumerate() {
            if !f.is_finite() || f < 0.0 {
                return Some(format!("frequency line {} is {f} Hz", k + 1));
            }
            if k > 0 && f <= self.frequency_hz[k - 1] {
                return Some(format!(
                    "frequency line {} ({f} Hz) is not above the previous one",
                    k + 1
                ));
            }
        }
        for (p, pair) in self.pairs.iter().enumerate() {
            let what = format!(
                "FRF #{} ({} / {})",
                p + 1,
                pair.response.name,
                pair.reference.name
            );
            if pair.values.len() != n {
                return Some(format!(
                    "{what} has {} values for {n} frequency lines",
                    pair.values.len()
                ));
            }
            if let Some(k) = pair
                .values
                .iter()
                .position(|z| !(z.re.is_finite() && z.im.is_finite()))
            {
                return Some(format!(
                    "{what} value at line {} is {} (not finite)",
                    k + 1,
                    pair.values[k]
                ));
            }
            if let Some(c) = &pair.coherence {
                if c.len() != n {
                    return Some(format!(
                        "{what} has {} coherence values for {n} frequency lines",
                        c.len()
                    ));
                }
                if let Some(k) = c.iter().position(|g| !(0.0..=1.0).contains(g)) {
                    return Some(format!(
                        "{what} coherence at line {} is {}, outside [0, 1]",
                        k + 1,
                        c[k]
                    ));
                }
            }
            for (q, other) in self.pairs[..p].iter().enumerate() {
                if other.response.same_point(&pair.response)
                    && other.reference.same_point(&pair.reference)
                {
                    return Some(format!("{what} is the same pair as FRF #{}", q + 1));
                }
            }
        }
        None
    }
}

/// How to read FRF files: what the file may not state itself.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FrfReadOptions {
    /// The quantity of values without a unit (values in its SI unit): CSV
    /// columns without `[unit]`, headerless files. If the file states a
    /// unit, the two must agree.
    pub quantity: Option<FrfQuantity>,
    /// The unit of values without a unit in the file (`g/N`, `(m/s^2)/N`;
    /// see [`units::frf_unit`](crate::units::frf_unit)): values are
    /// converted to SI. It implies the quantity; if `quantity` is also
    /// given, they must agree.
    pub unit: Option<String>,
    /// The reference (force) point of a headerless file.
    pub reference: Option<FrfPoint>,
    /// The response points of a headerless file, one per FRF column.
    pub responses: Option<Vec<FrfPoint>>,
}

impl FrfReadOptions {
    /// The quantity and SI factor of values the file gives without unit;
    /// `None` if the options say nothing about it.
    pub(crate) fn unitless(&self) -> Result<Option<(FrfQuantity, f64)>, RecordError> {
        let from_unit = match &self.unit {
            None => None,
            Some(u) => {
                Some(
                    crate::units::frf_unit(u).ok_or_else(|| RecordError::InvalidOptions {
                        reason: format!(
                            "FRF unit '{u}' is not known; use {}",
                            crate::units::frf_units_hint()
                        ),
                    })?,
                )
            }
        };
        match (self.quantity, from_unit) {
            (Some(q), Some((uq, _))) if q != uq => Err(RecordError::InvalidOptions {
                reason: format!(
                    "quantity {q} and unit '{}' ({uq}) disagree",
                    self.unit.as_deref().unwrap_or_default()
                ),
            }),
            (_, Some(qs)) => Ok(Some(qs)),
            (Some(q), None) => Ok(Some((q, 1.0))),
            (None, None) => Ok(None),
        }
    }
}

/// What a file holds, judged from its content.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ContentKind {
    /// Time records (read with [`read_record`](crate::read_record)). Also
    /// what is neither (a UFF file of spectra, unreadable text): the record
    /// reader then says what is wrong.
    TimeRecord,
    /// FRFs (read with [`read_frf`]).
    Frf,
}

/// Whether `bytes` hold time records or FRFs, from the content only:
///
/// - UFF (first non-blank line `-1`): the function type (record 6 field 1)
///   of the first dataset 58: 4 (FRF) or 6 (coherence) is [`ContentKind::Frf`].
/// - Text: FRF if the first non-blank line is a row of Python complex
///   numbers (`0.5+0j;...`), or a header whose first column is a frequency
///   (`frequency_hz`, `freq [Hz]`, ...) or that has a `re H(...)` column.
/// - Anything else: [`ContentKind::TimeRecord`].
///
/// It reads lines up to the first dataset 58 (UFF) or the first line (text).
pub fn content_kind(bytes: &[u8]) -> ContentKind {
    let body = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    let mut lines = body
        .split(|&b| b == b'\n')
        .map(|l| l.strip_suffix(b"\r").unwrap_or(l));
    let Some(first) = lines.find(|l| !l.trim_ascii().is_empty()) else {
        return ContentKind::TimeRecord;
    };
    if crate::uff::is_delimiter(first) {
        return uff58::content_kind(body);
    }
    if csv::looks_like_frf(&String::from_utf8_lossy(first)) {
        ContentKind::Frf
    } else {
        ContentKind::TimeRecord
    }
}

/// [`content_kind`] of the file at `path`. A text file is judged from its
/// first lines without reading the rest; a UFF file (which is judged from
/// its first dataset 58) is read whole.
pub fn read_content_kind(path: &Path) -> Result<ContentKind, RecordError> {
    use crate::format::FileFormat as _;
    let head = crate::format::Head::read(path)?;
    if head.first_line_whole()
        && !crate::format::Uff58(crate::uff::Uff58Encoding::Ascii).detect(&head.bytes)
    {
        return Ok(content_kind(&head.bytes));
    }
    Ok(content_kind(&head.into_bytes(path)?))
}

/// Parses FRF content held in memory, recognising the format from the
/// content (UFF if the first non-blank line is `-1`, else CSV, headerless
/// if the first line is a row of complex numbers). `path` is used in
/// messages and stored.
pub fn parse_frf(bytes: &[u8], path: &Path, opts: &FrfReadOptions) -> Result<FrfFile, RecordError> {
    opts.unitless()?;
    let body = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    let first = body
        .split(|&b| b == b'\n')
        .find(|l| !l.trim_ascii().is_empty());
    let file = match first {
        Some(l) if crate::uff::is_delimiter(l.strip_suffix(b"\r").unwrap_or(l)) => {
            uff58::parse(bytes, path)?
        }
        _ => csv::parse(bytes, path, opts)?,
    };
    debug_assert!(file.consistency_problem().is_none(), "{file:?}");
    Ok(file)
}

/// Reads an FRF file of any known format (see [`parse_frf`]); the file is
/// read whole, up to [`MAX_FILE_BYTES`](crate::MAX_FILE_BYTES).
pub fn read_frf(path: &Path, opts: &FrfReadOptions) -> Result<FrfFile, RecordError> {
    opts.unitless()?;
    let bytes = read_bytes(path)?;
    parse_frf(&bytes, path, opts)
}

/// The bytes of `file` in `format`; refuses (naming `file.path`) what would
/// not read back (see [`FrfFile::consistency_problem`], and each format's
/// limits: UFF entity names of 10 characters, CSV names without `/ @ ( )
/// [ ]`, one reference for [`FrfFormat::CsvComplex`]).
pub fn encode_frf(file: &FrfFile, format: FrfFormat) -> Result<Vec<u8>, RecordError> {
    let refuse = |reason| RecordError::InvalidRecord {
        path: file.path.clone(),
        reason,
    };
    if let Some(reason) = file.consistency_problem() {
        return Err(refuse(reason));
    }
    match format {
        FrfFormat::Uff58Ascii => uff58::render(file, false),
        FrfFormat::Uff58Binary => uff58::render(file, true),
        FrfFormat::Csv => csv::render(file),
        FrfFormat::CsvComplex => csv::render_complex(file),
    }
    .map_err(refuse)
}

/// Writes `file` to `path` in `format`, atomically (see
/// [`write_atomically`]): UFF58 ASCII or binary (each FRF a dataset of
/// function type 4 with its nodes, directions, SI unit labels and
/// exponents; each coherence a dataset of function type 6), CSV or
/// headerless complex CSV. Errors name `path`.
pub fn write_frf(path: &Path, file: &FrfFile, format: FrfFormat) -> Result<(), RecordError> {
    let bytes = encode_frf(file, format).map_err(|e| match e {
        RecordError::InvalidRecord { reason, .. } => RecordError::InvalidRecord {
            path: path.to_path_buf(),
            reason,
        },
        other => other,
    })?;
    write_atomically(path, &bytes)
}

/// Checks a read grid: strictly ascending, non-negative. `at(k)` locates
/// line `k` (0-based).
pub(crate) fn check_grid(
    path: &Path,
    frequency_hz: &[f64],
    at: impl Fn(usize) -> crate::error::Location,
) -> Result<(), RecordError> {
    for (k, &f) in frequency_hz.iter().enumerate() {
        let reason = if f < 0.0 {
            Some("is negative".to_string())
        } else if k > 0 && f <= frequency_hz[k - 1] {
            Some(format!(
                "is not above the previous line ({} Hz)",
                frequency_hz[k - 1]
            ))
        } else {
            None
        };
        if let Some(reason) = reason {
            return Err(RecordError::Parse {
                path: path.to_path_buf(),
                at: Box::new(at(k)),
                problem: crate::error::Problem::FrfBadFrequency { value: f, reason },
            });
        }
    }
    Ok(())
}

/// Whether two frequencies are the same line within [`FREQUENCY_REL_TOL`]
/// (relative to the larger of them and the grid spacing `df`).
pub(crate) fn same_frequency(a: f64, b: f64, df: f64) -> bool {
    (a - b).abs() <= FREQUENCY_REL_TOL * a.abs().max(b.abs()).max(df)
}

/// The first mismatch between two grids: `(line, a, b)` (0-based line;
/// `None` values for a length mismatch).
pub(crate) fn grid_mismatch(a: &[f64], b: &[f64]) -> Option<(usize, Option<f64>, Option<f64>)> {
    if a.len() != b.len() {
        return Some((a.len().min(b.len()), None, None));
    }
    let df = if a.len() > 1 {
        (a[a.len() - 1] - a[0]) / (a.len() - 1) as f64
    } else {
        0.0
    };
    a.iter()
        .zip(b)
        .position(|(&x, &y)| !same_frequency(x, y, df))
        .map(|k| (k, Some(a[k]), Some(b[k])))
}
