//! Universal File Format, dataset 58 (function at nodal DOF), ASCII and
//! binary (58b), restricted to real time responses.
//!
//! Layout of one dataset (after the delimiter line `    -1` and the
//! dataset number line `    58`, or `    58b` plus binary header fields):
//!
//! | record | content | format |
//! |---|---|---|
//! | 1–5 | ID lines (1: function description, 3: date) | 80A1 |
//! | 6 | function type, ids, response/reference entity, node, direction | 2(I5,I10),2(1X,10A1,I10,I4) |
//! | 7 | ordinate data type, number of values, spacing, abscissa min, increment, z | 3I10,3E13.5 |
//! | 8–11 | abscissa, ordinate, denominator, z axis: data type, unit exponents, label, unit label | I10,3I5,2(1X,20A1) |
//! | 12 | values: real single 6E13.5, real double 4E20.12; uneven: (x,y) pairs | |
//!
//! then the closing `    -1`. In 58b, record 12 is raw binary, its size
//! given in the dataset number line, `    58b` followed by
//! (I6,I6,I12,I12,I6,I6,I12,I12): byte ordering (1 little, 2 big endian),
//! floating point format (2 IEEE 754), number of ASCII lines (11), number
//! of bytes, four unused zeros; the closing `    -1` follows the bytes
//! directly.
//!
//! The reader accepts fixed columns as the format prescribes and also the
//! blank-separated variants many programs write: a header record is first
//! split at blanks, and parsed by columns if that does not give the
//! expected fields; a data line is split at blanks, and by columns of the
//! prescribed widths if a piece is not a number (fields that fill their
//! whole width touch each other).

use std::borrow::Cow;
use std::path::Path;

use crate::error::{Location, Problem, RecordError};
use crate::numfmt::{self, NumError};
use crate::record::{Channel, Format, ReadOptions, RecordFile, SampleLines};
use crate::spec::direction_label;
use crate::timeaxis::{self, PrintModel};

/// Relative precision of an E13.5 number (6 significant digits): two
/// readings of the same quantity printed this way agree to 5e-6.
pub(crate) const E13_REL: f64 = 1e-5;

/// Tag frameid writes into ID line 5 to carry the exact sampling interval
/// and start time that record 7 (E13.5) can only hold to 6 digits.
pub(crate) const TAG: &str = "frameid";

/// A position in a UFF file being read.
pub(crate) struct Cursor<'a> {
    data: &'a [u8],
    pos: usize,
    /// Number of the next line to be returned.
    pub line: usize,
}

impl<'a> Cursor<'a> {
    pub fn next_line(&mut self) -> Option<(usize, &'a [u8])> {
        if self.pos >= self.data.len() {
            return None;
        }
        let rest = &self.data[self.pos..];
        let (content, advance) = match rest.iter().position(|&b| b == b'\n') {
            Some(i) => (&rest[..i], i + 1),
            None => (rest, rest.len()),
        };
        self.pos += advance;
        let n = self.line;
        self.line += 1;
        Some((n, content.strip_suffix(b"\r").unwrap_or(content)))
    }

    fn take(&mut self, n: usize) -> Option<&'a [u8]> {
        let end = self.pos.checked_add(n)?;
        let bytes = self.data.get(self.pos..end)?;
        self.pos = end;
        self.line += bytes.iter().filter(|&&b| b == b'\n').count();
        Some(bytes)
    }

    /// Whether a delimiter line `-1` starts `offset` bytes ahead (after
    /// an optional line break).
    fn delimiter_at(&self, offset: usize) -> bool {
        let Some(rest) = self
            .pos
            .checked_add(offset)
            .and_then(|p| self.data.get(p..))
        else {
            return false;
        };
        let rest = rest.strip_prefix(b"\r").unwrap_or(rest);
        let rest = rest.strip_prefix(b"\n").unwrap_or(rest);
        let line = rest.split(|&b| b == b'\n').next().unwrap_or(rest);
        is_delimiter(line)
    }

    fn remaining(&self) -> usize {
        self.data.len().saturating_sub(self.pos)
    }

    /// Next line that is not blank.
    fn next_nonblank(&mut self) -> Option<(usize, &'a [u8])> {
        loop {
            let (n, l) = self.next_line()?;
            if !l.iter().all(|b| b.is_ascii_whitespace()) {
                return Some((n, l));
            }
        }
    }
}

/// The next non-blank line must be the closing `-1` of a dataset; `end`
/// and `missing` describe a file that ends before it.
fn expect_delimiter(
    cur: &mut Cursor<'_>,
    ctx: &Ctx<'_>,
    end: usize,
    missing: impl Into<String>,
) -> Result<(), RecordError> {
    match cur.next_nonblank() {
        Some((_, l)) if is_delimiter(l) => Ok(()),
        Some((n, l)) => Err(ctx.err(
            ctx.at_line(n),
            Problem::UffExpectedDelimiter { found: excerpt(l) },
        )),
        None => Err(ctx.truncated(end, missing)),
    }
}

pub(crate) fn is_delimiter(line: &[u8]) -> bool {
    line.trim_ascii() == b"-1"
}

fn text(bytes: &[u8]) -> Cow<'_, str> {
    String::from_utf8_lossy(bytes)
}

/// A free-text field (ID line, label): control characters, such as the
/// NUL padding some writers use, count as blanks; the result is trimmed.
pub(crate) fn free_text(bytes: &[u8]) -> String {
    text(bytes)
        .chars()
        .map(|c| if c.is_control() { ' ' } else { c })
        .collect::<String>()
        .trim()
        .to_string()
}

/// Byte columns `[from, to)` of a line (short lines give what is there).
fn columns(line: &[u8], from: usize, to: usize) -> &[u8] {
    let to = to.min(line.len());
    if from >= to { &[] } else { &line[from..to] }
}

/// Shortened text of a line for messages.
pub(crate) fn excerpt(line: &[u8]) -> String {
    let t = text(line.trim_ascii());
    if t.chars().count() > 40 {
        format!("{}...", t.chars().take(40).collect::<String>())
    } else {
        t.into_owned()
    }
}

/// Parsing context of one dataset, for locating errors.
pub(crate) struct Ctx<'p> {
    pub path: &'p Path,
    pub dataset: usize,
}

impl Ctx<'_> {
    pub fn at(&self, line: usize, field: impl Into<String>) -> Location {
        Location {
            dataset: Some(self.dataset),
            line: Some(line),
            column: None,
            field: Some(field.into()),
        }
    }

    pub fn at_line(&self, line: usize) -> Location {
        Location {
            dataset: Some(self.dataset),
            line: Some(line),
            ..Location::default()
        }
    }

    pub fn err(&self, at: Location, problem: Problem) -> RecordError {
        RecordError::Parse {
            path: self.path.to_path_buf(),
            at: Box::new(at),
            problem,
        }
    }

    pub fn bad_field(&self, line: usize, field: &str, text: &[u8], reason: &str) -> RecordError {
        self.err(
            self.at(line, field),
            Problem::UffBadField {
                text: excerpt(text),
                reason: reason.to_string(),
            },
        )
    }

    pub fn truncated(&self, line: usize, missing: impl Into<String>) -> RecordError {
        self.err(
            self.at_line(line),
            Problem::UffTruncated {
                missing: format!("the file ends {}", missing.into()),
            },
        )
    }
}

/// Dataset number line: number, binary flag, the rest of the line.
fn dataset_header(line: &[u8]) -> Option<(u32, bool, &[u8])> {
    let l = line.trim_ascii_start();
    let digits = l.iter().take_while(|b| b.is_ascii_digit()).count();
    let number: u32 = std::str::from_utf8(&l[..digits]).ok()?.parse().ok()?;
    let rest = &l[digits..];
    match rest.first() {
        Some(b'b' | b'B') => Some((number, true, &rest[1..])),
        None => Some((number, false, rest)),
        Some(b) if b.is_ascii_whitespace() => Some((number, false, rest)),
        Some(_) => None,
    }
}

#[derive(Debug, Clone, Copy)]
pub(crate) struct BinaryHeader {
    byte_order: i64,
    fp_format: i64,
    ascii_lines: i64,
    bytes: u64,
}

fn binary_header(ctx: &Ctx, line_no: usize, rest: &[u8]) -> Result<BinaryHeader, RecordError> {
    let t = text(rest);
    let tokens: Vec<&str> = t.split_ascii_whitespace().collect();
    let names = [
        "byte ordering",
        "floating point format",
        "number of ASCII lines",
        "number of bytes",
    ];
    let mut v = [0i64; 4];
    for (i, name) in names.iter().enumerate() {
        let field = format!("binary header field {} ({name})", i + 3);
        let tok = tokens.get(i).ok_or_else(|| {
            ctx.bad_field(
                line_no,
                &field,
                rest,
                "missing (a 58b header line has 8 numbers after '58b')",
            )
        })?;
        v[i] = tok
            .parse()
            .map_err(|_| ctx.bad_field(line_no, &field, tok.as_bytes(), "not an integer"))?;
    }
    let bytes = u64::try_from(v[3]).map_err(|_| {
        ctx.bad_field(
            line_no,
            "binary header field 6 (number of bytes)",
            tokens[3].as_bytes(),
            "negative",
        )
    })?;
    Ok(BinaryHeader {
        byte_order: v[0],
        fp_format: v[1],
        ascii_lines: v[2],
        bytes,
    })
}

/// Which function types a reader accepts, checked as soon as record 6 and
/// record 7 are read (before the data).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Expect {
    /// Time responses (function type 1), real ordinates.
    TimeRecord,
    /// FRFs (function type 4) and coherences (6), real or complex ordinates.
    Frf,
}

/// Record 6: the DOF identification.
pub(crate) struct Rec6 {
    pub func_type: i64,
    pub response_entity: String,
    pub response_node: i64,
    pub response_direction: i64,
    pub reference_entity: String,
    pub reference_node: i64,
    pub reference_direction: i64,
}

const REC6_FIELDS: [(&str, usize, usize); 10] = [
    ("function type", 0, 5),
    ("function identification number", 5, 15),
    ("version number", 15, 20),
    ("load case", 20, 30),
    ("response entity name", 31, 41),
    ("response node", 41, 51),
    ("response direction", 51, 55),
    ("reference entity name", 56, 66),
    ("reference node", 66, 76),
    ("reference direction", 76, 80),
];

fn parse_int_field(bytes: &[u8]) -> Result<i64, ()> {
    let t = bytes.trim_ascii();
    if t.is_empty() {
        // Fortran reads a blank integer field as zero.
        return Ok(0);
    }
    std::str::from_utf8(t)
        .map_err(|_| ())?
        .parse()
        .map_err(|_| ())
}

fn record6(ctx: &Ctx, line_no: usize, line: &[u8], expect: Expect) -> Result<Rec6, RecordError> {
    const INTS: [usize; 8] = [0, 1, 2, 3, 5, 6, 8, 9];
    // Blank-separated: ten tokens (entity names without blanks).
    let t = text(line);
    let tokens: Vec<&str> = t.split_ascii_whitespace().collect();
    if tokens.len() == 10 {
        let ints: Option<Vec<i64>> = INTS.iter().map(|&i| tokens[i].parse().ok()).collect();
        if let Some(v) = ints {
            // v holds the fields listed in INTS: v[4] is field 6 (node).
            let r6 = Rec6 {
                func_type: v[0],
                response_entity: tokens[4].to_string(),
                response_node: v[4],
                response_direction: v[5],
                reference_entity: tokens[7].to_string(),
                reference_node: v[6],
                reference_direction: v[7],
            };
            return check_rec6(ctx, line_no, r6, [tokens[6], tokens[9]], expect);
        }
    }
    // Fixed columns.
    let mut v = [0i64; 10];
    for &i in &INTS {
        let (name, from, to) = REC6_FIELDS[i];
        let field = columns(line, from, to);
        v[i] = parse_int_field(field).map_err(|_| {
            ctx.bad_field(
                line_no,
                &format!(
                    "record 6 field {} ({name}, columns {}-{})",
                    i + 1,
                    from + 1,
                    to
                ),
                field,
                "not an integer",
            )
        })?;
    }
    let r6 = Rec6 {
        func_type: v[0],
        response_entity: free_text(columns(line, 31, 41)),
        response_node: v[5],
        response_direction: v[6],
        reference_entity: free_text(columns(line, 56, 66)),
        reference_node: v[8],
        reference_direction: v[9],
    };
    let dirs = [text(columns(line, 51, 55)), text(columns(line, 76, 80))];
    check_rec6(ctx, line_no, r6, [&dirs[0], &dirs[1]], expect)
}

fn check_rec6(
    ctx: &Ctx,
    line_no: usize,
    r6: Rec6,
    dir_texts: [&str; 2],
    expect: Expect,
) -> Result<Rec6, RecordError> {
    let accepted = match expect {
        Expect::TimeRecord => r6.func_type == 1,
        Expect::Frf => r6.func_type == 4 || r6.func_type == 6,
    };
    if !accepted {
        let func_type = r6.func_type;
        return Err(ctx.err(
            ctx.at(line_no, "record 6 field 1 (function type)"),
            match expect {
                Expect::TimeRecord => Problem::UffUnsupportedFunction { func_type },
                Expect::Frf => Problem::UffNotFrf { func_type },
            },
        ));
    }
    if !(-6..=6).contains(&r6.response_direction) {
        return Err(ctx.bad_field(
            line_no,
            "record 6 field 7 (response direction)",
            dir_texts[0].as_bytes(),
            "a direction is -6..6",
        ));
    }
    // The reference of a time response is not used; an FRF's is its input.
    if expect == Expect::Frf && !(-6..=6).contains(&r6.reference_direction) {
        return Err(ctx.bad_field(
            line_no,
            "record 6 field 10 (reference direction)",
            dir_texts[1].as_bytes(),
            "a direction is -6..6",
        ));
    }
    Ok(r6)
}

/// Record 7.
pub(crate) struct Rec7 {
    pub ord_type: i64,
    pub count: u64,
    pub even: bool,
    pub x_min: f64,
    pub dx: f64,
}

fn record7(
    ctx: &Ctx,
    line_no: usize,
    line: &[u8],
    expect: Expect,
    func_type: i64,
) -> Result<Rec7, RecordError> {
    const NAMES: [&str; 5] = [
        "ordinate data type",
        "number of values",
        "abscissa spacing",
        "abscissa minimum",
        "abscissa increment",
    ];
    const COLS: [(usize, usize); 5] = [(0, 10), (10, 20), (20, 30), (30, 43), (43, 56)];
    let t = text(line);
    let tokens: Vec<&str> = t.split_ascii_whitespace().collect();
    let blank_split = (5..=6).contains(&tokens.len())
        && tokens[..3].iter().all(|s| s.parse::<i64>().is_ok())
        && tokens[3..5]
            .iter()
            .all(|s| numfmt::parse_fortran(s).is_ok());
    let field = |i: usize| -> (String, Vec<u8>) {
        let name = if blank_split {
            format!("record 7 field {} ({})", i + 1, NAMES[i])
        } else {
            format!(
                "record 7 field {} ({}, columns {}-{})",
                i + 1,
                NAMES[i],
                COLS[i].0 + 1,
                COLS[i].1
            )
        };
        let raw = if blank_split {
            tokens[i].as_bytes().to_vec()
        } else {
            columns(line, COLS[i].0, COLS[i].1).to_vec()
        };
        (name, raw)
    };
    let mut ints = [0i64; 3];
    for (i, slot) in ints.iter_mut().enumerate() {
        let (name, raw) = field(i);
        *slot = parse_int_field(&raw)
            .map_err(|_| ctx.bad_field(line_no, &name, &raw, "not an integer"))?;
    }
    let mut reals = [0f64; 2];
    for (k, slot) in reals.iter_mut().enumerate() {
        let (name, raw) = field(3 + k);
        let t = text(raw.trim_ascii()).into_owned();
        *slot = if t.is_empty() {
            0.0
        } else {
            numfmt::parse_fortran(&t).map_err(|e| {
                ctx.bad_field(
                    line_no,
                    &name,
                    &raw,
                    match e {
                        NumError::NonFinite => "NaN or infinite",
                        _ => "not a number",
                    },
                )
            })?
        };
    }
    let [ord_type, count, spacing] = ints;
    let at = || ctx.at(line_no, "record 7 field 1 (ordinate data type)");
    match expect {
        Expect::TimeRecord if ord_type != 2 && ord_type != 4 => {
            return Err(ctx.err(at(), Problem::UffUnsupportedOrdinate { ord_type }));
        }
        Expect::Frf => {
            let fits = if func_type == 4 {
                ord_type == 5 || ord_type == 6
            } else {
                ord_type == 2 || ord_type == 4
            };
            if !fits {
                return Err(ctx.err(
                    at(),
                    Problem::UffFrfOrdinate {
                        ord_type,
                        func_type,
                    },
                ));
            }
        }
        Expect::TimeRecord => {}
    }
    let count = match u64::try_from(count) {
        Ok(c) if c > 0 => c,
        _ => {
            let (name, raw) = field(1);
            return Err(ctx.bad_field(
                line_no,
                &name,
                &raw,
                "the number of values must be positive",
            ));
        }
    };
    let even = match spacing {
        1 => true,
        0 => false,
        _ => {
            let (name, raw) = field(2);
            return Err(ctx.bad_field(line_no, &name, &raw, "spacing is 0 (uneven) or 1 (even)"));
        }
    };
    let [x_min, dx] = reals;
    if even && (dx <= 0.0 || dx.is_nan()) {
        let (name, raw) = field(4);
        return Err(ctx.bad_field(
            line_no,
            &name,
            &raw,
            "the increment of an evenly spaced abscissa must be positive",
        ));
    }
    Ok(Rec7 {
        ord_type,
        count,
        even,
        x_min,
        dx,
    })
}

/// Records 8-11: data characteristics of an axis. Integer fields that do
/// not parse are `None` (the time reader does not use them; the FRF reader
/// refuses them where it needs them).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct AxisRecord {
    /// Field 1: specific data type (8 displacement, 11 velocity, 12
    /// acceleration, 13 excitation force, 17 time, 18 frequency, ...).
    pub spec_type: Option<i64>,
    /// Fields 2-4: length, force and temperature unit exponents.
    pub exponents: [Option<i64>; 3],
    /// Field 5: axis label (blank if absent).
    pub label: String,
    /// Field 6: axis units label (blank if absent).
    pub unit: String,
    /// The record's text, for messages.
    pub raw: String,
}

fn axis_record(line: &[u8]) -> AxisRecord {
    let fixed = line.len() >= 48 && parse_int_field(columns(line, 0, 10)).is_ok();
    let raw = free_text(line);
    if fixed {
        let int = |from, to| parse_int_field(columns(line, from, to)).ok();
        AxisRecord {
            spec_type: int(0, 10),
            exponents: [int(10, 15), int(15, 20), int(20, 25)],
            label: free_text(columns(line, 26, 46)),
            unit: free_text(columns(line, 47, 67)),
            raw,
        }
    } else {
        let tokens: Vec<&str> = raw.split_ascii_whitespace().collect();
        let int = |i: usize| tokens.get(i).and_then(|t| t.parse::<i64>().ok());
        AxisRecord {
            spec_type: int(0),
            exponents: [int(1), int(2), int(3)],
            label: tokens.get(4).copied().unwrap_or("").to_string(),
            unit: tokens.get(5).copied().unwrap_or("").to_string(),
            raw: raw.clone(),
        }
    }
}

pub(crate) fn meaningful(s: &str) -> Option<&str> {
    let s = s.trim();
    if s.is_empty() || s.eq_ignore_ascii_case("NONE") {
        None
    } else {
        Some(s)
    }
}

/// Seconds per abscissa unit, from the record 8 unit label.
fn abscissa_scale(label: &str) -> Option<f64> {
    match meaningful(label).map(|l| l.to_ascii_lowercase()) {
        None => Some(1.0),
        Some(l) => crate::units::seconds_per(&l),
    }
}

/// The exact interval and start frameid wrote into ID line 5, if present.
fn read_tag(id5: &str) -> Option<(f64, f64)> {
    let rest = id5.trim().strip_prefix(TAG)?;
    let mut dt = None;
    let mut start = None;
    for tok in rest.split_ascii_whitespace() {
        if let Some(v) = tok.strip_prefix("dt_s=") {
            dt = v.parse::<f64>().ok();
        } else if let Some(v) = tok.strip_prefix("start_s=") {
            start = v.parse::<f64>().ok();
        }
    }
    match (dt, start) {
        (Some(d), Some(s)) if d > 0.0 && d.is_finite() && s.is_finite() => Some((d, s)),
        _ => None,
    }
}

/// One dataset 58 read from the file.
struct Dataset {
    index: usize,
    rec7_line: usize,
    /// Line of record 8 (abscissa data characteristics) and whether its
    /// units label states a unit (not blank, not `NONE`).
    rec8: (usize, bool),
    binary: bool,
    start: f64,
    dt: f64,
    channel: Channel,
}

/// One dataset 58 as stored: its header records and the numbers of record 12
/// (ASCII or binary), not yet interpreted.
pub(crate) struct RawDataset58 {
    /// 1-based position of the dataset in the file.
    pub index: usize,
    /// Lines of records 1-11.
    pub record_lines: [usize; 11],
    /// Whether record 12 is binary (58b).
    pub binary: bool,
    /// ID lines 1-5 (free text, trimmed).
    pub id: [String; 5],
    pub r6: Rec6,
    pub r7: Rec7,
    /// Records 8 (abscissa), 9 (ordinate numerator), 10 (ordinate
    /// denominator), 11 (z axis).
    pub axes: [AxisRecord; 4],
    /// Record 12 in file order: per point the abscissa (uneven spacing
    /// only), then the ordinate (real, or real and imaginary parts).
    pub values: Vec<f64>,
    /// How precisely the abscissa values were printed (uneven ASCII).
    pub x_model: PrintModel,
    /// First line of record 12.
    pub data_line: usize,
    /// `(first value index, line)` of every ASCII data line.
    pub line_starts: Vec<(usize, usize)>,
}

impl RawDataset58 {
    /// Numbers stored per point: abscissa (uneven) plus 1 (real) or 2
    /// (complex) ordinate values.
    pub fn per_point(&self) -> usize {
        per_point(&self.r7)
    }
}

fn per_point(r7: &Rec7) -> usize {
    let ordinate = if r7.ord_type == 5 || r7.ord_type == 6 {
        2
    } else {
        1
    };
    ordinate + usize::from(!r7.even)
}

/// Widths of the fixed fields of a data line, cycled.
fn data_widths(ord_type: i64, even: bool) -> &'static [usize] {
    match (ord_type, even) {
        (4 | 6, true) => &[20],
        (4, false) => &[13, 20],
        (6, false) => &[13, 20, 20],
        _ => &[13],
    }
}

/// Splits a data line into number texts: at blanks, or by fixed columns if a
/// blank-separated piece is not a number.
pub(crate) fn data_tokens<'l>(line: &'l str, widths: &[usize]) -> Vec<&'l str> {
    let blank: Vec<&str> = line.split_ascii_whitespace().collect();
    if blank
        .iter()
        .all(|t| !matches!(numfmt::parse_fortran(t), Err(NumError::NotANumber)))
    {
        return blank;
    }
    if !line.is_ascii() {
        return blank;
    }
    let mut out = Vec::new();
    let mut pos = 0;
    for &w in widths.iter().cycle() {
        if pos >= line.len() {
            break;
        }
        let end = (pos + w).min(line.len());
        let piece = line[pos..end].trim();
        if !piece.is_empty() {
            out.push(piece);
        }
        pos = end;
    }
    out
}

/// Reads one dataset 58 whose dataset number line (`header_line`) has just
/// been read: records 1-11, checked against `expect`, and record 12 as
/// numbers, up to and including the closing `-1`.
pub(crate) fn read_raw58(
    ctx: &Ctx,
    cur: &mut Cursor,
    header_line: usize,
    binary: Option<BinaryHeader>,
    expect: Expect,
) -> Result<RawDataset58, RecordError> {
    if let Some(b) = &binary
        && b.ascii_lines != 11
    {
        return Err(ctx.bad_field(
            header_line,
            "binary header field 5 (number of ASCII lines)",
            b.ascii_lines.to_string().as_bytes(),
            "dataset 58 has 11 ASCII header records",
        ));
    }
    let mut rec: Vec<(usize, &[u8])> = Vec::with_capacity(11);
    for k in 1..=11 {
        match cur.next_line() {
            Some((n, l)) if is_delimiter(l) => {
                return Err(ctx.err(
                    ctx.at_line(n),
                    Problem::UffTruncated {
                        missing: format!("its closing '-1' comes before record {k} of 11"),
                    },
                ));
            }
            Some(l) => rec.push(l),
            None => {
                return Err(ctx.truncated(
                    cur.line.saturating_sub(1).max(header_line),
                    format!("in the header, before record {k} of 11"),
                ));
            }
        }
    }
    let r6 = record6(ctx, rec[5].0, rec[5].1, expect)?;
    let (rec7_line, rec7_bytes) = rec[6];
    let r7 = record7(ctx, rec7_line, rec7_bytes, expect, r6.func_type)?;

    let per_sample = per_point(&r7) as u64;
    let n_values = r7.count.checked_mul(per_sample);
    let mut values: Vec<f64>;
    let mut x_model = PrintModel::exact();
    let data_line = cur.line;
    // (first value index, line) of every ASCII data line, for messages.
    let mut line_starts: Vec<(usize, usize)> = Vec::new();
    match &binary {
        Some(b) => {
            if b.fp_format != 2 {
                return Err(ctx.err(
                    ctx.at(header_line, "binary header field 4 (floating point format)"),
                    Problem::UffUnsupportedBinary {
                        what: format!(
                            "floating point format {} ({}); only 2 (IEEE 754) is supported",
                            b.fp_format,
                            match b.fp_format {
                                1 => "DEC VMS",
                                3 => "IBM 5/370",
                                _ => "unknown",
                            }
                        ),
                    },
                ));
            }
            let little = match b.byte_order {
                1 => true,
                2 => false,
                o => {
                    return Err(ctx.err(
                        ctx.at(header_line, "binary header field 3 (byte ordering)"),
                        Problem::UffUnsupportedBinary {
                            what: format!(
                                "byte ordering {o}; only 1 (little endian) and 2 (big endian) exist"
                            ),
                        },
                    ));
                }
            };
            let width: u64 = if r7.ord_type == 2 || r7.ord_type == 5 {
                4
            } else {
                8
            };
            let expected = n_values.and_then(|n| n.checked_mul(width));
            // pyuff (2.x) declares count*8 bytes whatever it writes: for
            // uneven or complex data it writes 2 or 3 numbers per point
            // (abscissa, real, imaginary). Accept exactly that case, and
            // only if the closing delimiter is where the full data ends:
            // then the file cannot be read any other way.
            let pyuff_quirk = per_sample > 1
                && expected == b.bytes.checked_mul(per_sample)
                && expected
                    .and_then(|e| usize::try_from(e).ok())
                    .is_some_and(|e| cur.delimiter_at(e));
            if expected != Some(b.bytes) && !pyuff_quirk {
                return Err(ctx.err(
                    ctx.at(header_line, "binary header field 6 (number of bytes)"),
                    Problem::UffByteCountMismatch {
                        declared: b.bytes,
                        expected: expected.unwrap_or(u64::MAX),
                        values: n_values.unwrap_or(u64::MAX),
                        bytes_per_value: width,
                    },
                ));
            }
            let available = cur.remaining();
            let payload = usize::try_from(if pyuff_quirk {
                b.bytes * per_sample
            } else {
                b.bytes
            })
            .ok()
            .and_then(|n| cur.take(n))
            .ok_or_else(|| {
                ctx.truncated(
                    data_line,
                    format!(
                        "inside the binary data: {} bytes declared, {available} present",
                        b.bytes
                    ),
                )
            })?;
            values = Vec::with_capacity(payload.len() / width as usize);
            for (k, chunk) in payload.chunks_exact(width as usize).enumerate() {
                let v = if width == 4 {
                    let a = [chunk[0], chunk[1], chunk[2], chunk[3]];
                    f64::from(if little {
                        f32::from_le_bytes(a)
                    } else {
                        f32::from_be_bytes(a)
                    })
                } else {
                    let mut a = [0u8; 8];
                    a.copy_from_slice(chunk);
                    if little {
                        f64::from_le_bytes(a)
                    } else {
                        f64::from_be_bytes(a)
                    }
                };
                if !v.is_finite() {
                    return Err(ctx.err(
                        ctx.at(
                            data_line,
                            format!(
                                "binary value {} (byte {} of the data)",
                                k + 1,
                                k * width as usize + 1
                            ),
                        ),
                        Problem::NonFinite {
                            text: v.to_string(),
                        },
                    ));
                }
                values.push(v);
            }
            let end = cur.line.saturating_sub(1);
            expect_delimiter(
                cur,
                ctx,
                end,
                "after the binary data, before the closing '-1'",
            )?;
        }
        None => {
            let widths = data_widths(r7.ord_type, r7.even);
            let cap = n_values.unwrap_or(0).min(cur.remaining() as u64 / 2) as usize;
            values = Vec::with_capacity(cap);
            if !r7.even {
                x_model = PrintModel::printed();
            }
            let close_line = loop {
                let Some((n, l)) = cur.next_line() else {
                    return Err(ctx.truncated(
                        cur.line.saturating_sub(1),
                        format!(
                            "inside the data ({} of {} values read) before the closing '-1'",
                            values.len(),
                            n_values.unwrap_or(u64::MAX)
                        ),
                    ));
                };
                if is_delimiter(l) {
                    break n;
                }
                let t = text(l);
                line_starts.push((values.len(), n));
                for (k, tok) in data_tokens(&t, widths).into_iter().enumerate() {
                    let v = numfmt::parse_fortran(tok).map_err(|e| {
                        let at = ctx.at(n, format!("value {} on the line", k + 1));
                        let text = tok.to_string();
                        ctx.err(
                            at,
                            match e {
                                NumError::NonFinite => Problem::NonFinite { text },
                                _ => Problem::NonNumeric { text },
                            },
                        )
                    })?;
                    if !r7.even && values.len().is_multiple_of(per_sample as usize) {
                        x_model.observe(numfmt::printed_precision(tok));
                    }
                    values.push(v);
                }
            };
            if Some(values.len() as u64) != n_values {
                return Err(ctx.err(
                    ctx.at_line(close_line),
                    Problem::UffCountMismatch {
                        declared: n_values.unwrap_or(u64::MAX),
                        found: values.len() as u64,
                        record7_line: rec7_line,
                    },
                ));
            }
        }
    }

    let record_lines: [usize; 11] = std::array::from_fn(|k| rec[k].0);
    Ok(RawDataset58 {
        index: ctx.dataset,
        record_lines,
        binary: binary.is_some(),
        id: std::array::from_fn(|k| free_text(rec[k].1)),
        axes: std::array::from_fn(|k| axis_record(rec[7 + k].1)),
        r6,
        r7,
        values,
        x_model,
        data_line,
        line_starts,
    })
}

/// A dataset 58 read as a time response (function type 1, real ordinates).
fn read_dataset58(
    ctx: &Ctx,
    cur: &mut Cursor,
    header_line: usize,
    binary: Option<BinaryHeader>,
) -> Result<Dataset, RecordError> {
    let raw = read_raw58(ctx, cur, header_line, binary, Expect::TimeRecord)?;
    let RawDataset58 {
        record_lines,
        binary,
        id,
        r6,
        r7,
        axes,
        values,
        x_model,
        data_line,
        line_starts,
        ..
    } = raw;
    let rec7_line = record_lines[6];
    let x_units = &axes[0].unit;
    let scale = abscissa_scale(x_units).ok_or_else(|| {
        ctx.bad_field(
            record_lines[7],
            "record 8 field 6 (abscissa units label)",
            x_units.as_bytes(),
            "not a time unit (s, ms, us or NONE)",
        )
    })?;
    let unit = match (meaningful(&axes[1].unit), meaningful(&axes[2].unit)) {
        (Some(n), Some(d)) if d != "1" => Some(format!("{n}/{d}")),
        (Some(n), _) => Some(n.to_string()),
        (None, Some(d)) if d != "1" => Some(format!("1/{d}")),
        (None, _) => None,
    };
    let [id1, _, _, _, id5] = &id;

    // Abscissa.
    let (start, dt, ys) = if r7.even {
        let (mut start, mut dt) = (r7.x_min * scale, r7.dx * scale);
        if let Some((tag_dt, tag_start)) = read_tag(id5) {
            // Use the exact values only if they agree with record 7 to its
            // printed precision (a program that edited record 7 and kept
            // the ID lines must not be overridden).
            if (tag_dt - dt).abs() <= E13_REL * dt
                && (tag_start - start).abs() <= E13_REL * start.abs().max(dt)
            {
                (start, dt) = (tag_start, tag_dt);
            }
        }
        (start, dt, values)
    } else {
        let xs: Vec<f64> = values.iter().step_by(2).map(|x| x * scale).collect();
        let ys: Vec<f64> = values.iter().skip(1).step_by(2).copied().collect();
        if xs.len() < 2 {
            return Err(ctx.err(ctx.at_line(rec7_line), Problem::SingleSample));
        }
        let dt = timeaxis::check_uniform(&xs, &x_model, scale).map_err(|e| {
            super::csv::axis_error(ctx.path, e, |i| {
                ctx.at(data_line, format!("abscissa value {} of the data", i + 1))
            })
        })?;
        (xs[0], dt, ys)
    };

    let direction = r6.response_direction as i32;
    let name = match meaningful(id1) {
        Some(id) => id.to_string(),
        None => format!("{}:{}", r6.response_node, direction_label(direction)),
    };
    Ok(Dataset {
        index: ctx.dataset,
        rec7_line,
        rec8: (record_lines[7], meaningful(x_units).is_some()),
        binary,
        start,
        dt,
        channel: Channel {
            name,
            unit,
            node: Some(r6.response_node),
            direction: Some(direction),
            id_line: meaningful(id1).map(str::to_string),
            values: ys,
            lines: (!line_starts.is_empty()).then_some(SampleLines::Values {
                starts: line_starts,
                stride: if r7.even { 1 } else { 2 },
                offset: if r7.even { 0 } else { 1 },
            }),
        },
    })
}

/// Walks the datasets of a UFF file: for each, after its delimiter and
/// dataset number line, calls `visit(ctx, cursor, number, number line,
/// binary header)`, which either reads the dataset through its closing
/// `-1` and returns `true`, or returns `false` without reading, and the
/// dataset is skipped. Returns the number of datasets and the numbers of
/// the skipped ones, in file order.
pub(crate) fn scan_datasets<'a>(
    bytes: &'a [u8],
    path: &Path,
    mut visit: impl FnMut(
        &Ctx<'_>,
        &mut Cursor<'a>,
        u32,
        usize,
        Option<BinaryHeader>,
    ) -> Result<bool, RecordError>,
) -> Result<(usize, Vec<u32>), RecordError> {
    let body = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    let mut cur = Cursor {
        data: body,
        pos: 0,
        line: 1,
    };
    let mut other_types: Vec<u32> = Vec::new();
    let mut index = 0;
    while let Some((n, l)) = cur.next_nonblank() {
        index += 1;
        let ctx = Ctx {
            path,
            dataset: index,
        };
        if !is_delimiter(l) {
            return Err(ctx.err(
                Location::line(n),
                Problem::UffExpectedDelimiter { found: excerpt(l) },
            ));
        }
        let Some((hn, hl)) = cur.next_line() else {
            return Err(ctx.truncated(n, "after the opening '-1', before the dataset number"));
        };
        let Some((number, is_binary, rest)) = dataset_header(hl) else {
            return Err(ctx.bad_field(
                hn,
                "dataset number",
                hl,
                "not a dataset number (I6, optionally followed by 'b')",
            ));
        };
        let bin = if is_binary {
            Some(binary_header(&ctx, hn, rest)?)
        } else {
            None
        };
        if visit(&ctx, &mut cur, number, hn, bin)? {
            continue;
        }
        // Any other dataset is skipped.
        other_types.push(number);
        match bin {
            Some(b) => {
                for _ in 0..b.ascii_lines.max(0) {
                    if cur.next_line().is_none() {
                        return Err(ctx.truncated(
                            hn,
                            format!("inside the ASCII header of dataset type {number}"),
                        ));
                    }
                }
                if usize::try_from(b.bytes)
                    .ok()
                    .and_then(|k| cur.take(k))
                    .is_none()
                {
                    return Err(ctx.truncated(
                        hn,
                        format!("inside the binary data of dataset type {number}"),
                    ));
                }
                expect_delimiter(
                    &mut cur,
                    &ctx,
                    hn,
                    format!("before the closing '-1' of dataset type {number}"),
                )?;
            }
            None => loop {
                match cur.next_line() {
                    Some((_, l)) if is_delimiter(l) => break,
                    Some(_) => {}
                    None => {
                        return Err(ctx.truncated(
                            hn,
                            format!("before the closing '-1' of dataset type {number}"),
                        ));
                    }
                }
            },
        }
    }
    Ok((index, other_types))
}

/// Parses a UFF file held in memory; `path` is used in messages only.
pub fn parse_uff58(
    bytes: &[u8],
    path: &Path,
    opts: &ReadOptions,
) -> Result<RecordFile, RecordError> {
    opts.validate()?;
    let mut datasets: Vec<Dataset> = Vec::new();
    let (index, other_types) = scan_datasets(bytes, path, |ctx, cur, number, hn, bin| {
        if number != 58 {
            return Ok(false);
        }
        datasets.push(read_dataset58(ctx, cur, hn, bin)?);
        Ok(true)
    })?;
    if datasets.is_empty() {
        let at = Location::default();
        let problem = if index == 0 {
            Problem::EmptyFile
        } else {
            Problem::UffNoDataset58 { found: other_types }
        };
        return Err(RecordError::Parse {
            path: path.to_path_buf(),
            at: Box::new(at),
            problem,
        });
    }

    // All channels of a record share length, start and interval.
    let first = &datasets[0];
    let same = |a: f64, b: f64, scale: f64| (a - b).abs() <= 1e-9 * scale;
    for d in &datasets[1..] {
        let ctx = Ctx {
            path,
            dataset: d.index,
        };
        let mismatch = if d.channel.values.len() != first.channel.values.len() {
            Some((
                "the number of samples",
                d.channel.values.len().to_string(),
                first.channel.values.len().to_string(),
            ))
        } else if !same(d.dt, first.dt, first.dt) {
            Some((
                "the sampling interval",
                format!("{} s", d.dt),
                format!("{} s", first.dt),
            ))
        } else if !same(d.start, first.start, first.dt) {
            Some((
                "the start time",
                format!("{} s", d.start),
                format!("{} s", first.start),
            ))
        } else {
            None
        };
        if let Some((what, value, first_value)) = mismatch {
            return Err(ctx.err(
                ctx.at(d.rec7_line, "record 7"),
                Problem::UffDatasetMismatch {
                    what,
                    value,
                    first_dataset: first.index,
                    first_value,
                },
            ));
        }
    }
    if let Some(fs) = opts.fs_hz
        && (1.0 / fs - first.dt).abs() > E13_REL * first.dt
    {
        let ctx = Ctx {
            path,
            dataset: first.index,
        };
        return Err(ctx.err(
            ctx.at(first.rec7_line, "record 7 field 5 (abscissa increment)"),
            Problem::FsMismatch {
                fs_hz: fs,
                file_dt_s: first.dt,
            },
        ));
    }
    // An abscissa without a unit is taken in seconds, unless that makes the
    // sampling implausibly slow (milliseconds read as seconds).
    if opts.fs_hz.is_none()
        && let Some(d) = datasets
            .iter()
            .find(|d| !d.rec8.1 && d.dt >= timeaxis::UNDECLARED_UNIT_MAX_DT_S)
    {
        let ctx = Ctx {
            path,
            dataset: d.index,
        };
        return Err(ctx.err(
            ctx.at(d.rec8.0, "record 8 field 6 (abscissa units label)"),
            Problem::UndeclaredTimeUnit {
                dt_s: d.dt,
                declare: "set the abscissa units label to ms (or s if they are seconds)".into(),
            },
        ));
    }
    let format = if first.binary {
        Format::Uff58Binary
    } else {
        Format::Uff58Ascii
    };
    // -0.0 becomes +0.0, as in the CSV reader.
    let (dt_s, start_s) = (first.dt, first.start + 0.0);
    Ok(RecordFile {
        path: path.to_path_buf(),
        format,
        dt_s,
        start_s,
        channels: datasets.into_iter().map(|d| d.channel).collect(),
    })
}

/// How [`write_uff58`](crate::write_uff58) and the [`Uff58`](crate::Uff58)
/// format encode the values.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Uff58Encoding {
    /// ASCII as the format prescribes: real double, 4E20.12 per line.
    /// Every reader understands it; values keep 13 significant digits
    /// (relative error at most 5e-13), not all 17 of a double.
    Ascii,
    /// ASCII with 17 significant digits, 3E25.16 per line (75 columns):
    /// reads back bit for bit in frameid and in readers that split at
    /// blanks, but NOT in fixed-column readers such as pyuff, which cut
    /// 20-character fields and would misread it. For frameid's own use.
    AsciiFullPrecision,
    /// 58b, little-endian IEEE doubles: exact and widely readable.
    Binary,
}

fn ascii_field(what: &str, s: &str, max: usize) -> Result<(), String> {
    if !s.is_ascii() || s.chars().any(|c| c.is_ascii_control()) {
        return Err(format!(
            "{what} '{s}' is not printable ASCII, which UFF requires"
        ));
    }
    if s.len() > max {
        return Err(format!(
            "{what} '{s}' is longer than the {max} characters UFF allows"
        ));
    }
    if s.trim() != s {
        return Err(format!(
            "{what} '{s}' has leading or trailing blanks, which readers drop"
        ));
    }
    Ok(())
}

/// Checks that every channel can be written as UFF and read back unchanged.
pub(crate) fn check_writable(rec: &RecordFile) -> Result<(), String> {
    for (i, ch) in rec.channels.iter().enumerate() {
        let what = format!("channel #{} name", i + 1);
        ascii_field(&what, &ch.name, 80)?;
        if ch.name.is_empty() || ch.name.eq_ignore_ascii_case("NONE") || ch.name == "-1" {
            return Err(format!("{what} '{}' cannot be an ID line", ch.name));
        }
        if let Some(u) = &ch.unit {
            ascii_field(&format!("channel #{} unit", i + 1), u, 20)?;
            if u.is_empty() || u.eq_ignore_ascii_case("NONE") {
                return Err(format!("channel #{} unit '{u}' would not read back", i + 1));
            }
        }
        if let Some(node) = ch.node
            && !(-999_999_999..=9_999_999_999).contains(&node)
        {
            return Err(format!(
                "channel #{} node {node} does not fit in 10 columns",
                i + 1
            ));
        }
        if let Some(d) = ch.direction
            && !(-6..=6).contains(&d)
        {
            return Err(format!("channel #{} direction {d} is not -6..6", i + 1));
        }
    }
    Ok(())
}

fn push_line(out: &mut Vec<u8>, s: &str) {
    out.extend_from_slice(s.as_bytes());
    out.push(b'\n');
}

/// Renders a validated record as dataset-58 file content.
pub(crate) fn render_uff58(rec: &RecordFile, enc: Uff58Encoding) -> Vec<u8> {
    let n = rec.len();
    let mut out = Vec::with_capacity(rec.channels.len() * (n * 26 + 1200));
    for (i, ch) in rec.channels.iter().enumerate() {
        push_line(&mut out, "    -1");
        match enc {
            Uff58Encoding::Binary => push_line(
                &mut out,
                &format!(
                    "{:>6}b{:>6}{:>6}{:>12}{:>12}{:>6}{:>6}{:>12}{:>12}",
                    58,
                    1,
                    2,
                    11,
                    n * 8,
                    0,
                    0,
                    0,
                    0
                ),
            ),
            _ => push_line(&mut out, "    58"),
        }
        // Records 1-5.
        push_line(&mut out, &format!("{:<80}", ch.name));
        push_line(&mut out, &format!("{:<80}", "NONE"));
        push_line(&mut out, &format!("{:<80}", "NONE"));
        push_line(&mut out, &format!("{:<80}", "NONE"));
        let tag = format!(
            "{TAG} dt_s={} start_s={}",
            numfmt::shortest(rec.dt_s),
            numfmt::shortest(rec.start_s)
        );
        push_line(&mut out, &format!("{tag:<80}"));
        // Record 6: time response at the channel's node and direction.
        push_line(
            &mut out,
            &format!(
                "{:>5}{:>10}{:>5}{:>10} {:<10}{:>10}{:>4} {:<10}{:>10}{:>4}",
                1,
                i + 1,
                0,
                0,
                "NONE",
                ch.node.unwrap_or(0),
                ch.direction.unwrap_or(0),
                "NONE",
                0,
                0
            ),
        );
        // Record 7: real double, even spacing.
        let mut r7 = format!("{:>10}{:>10}{:>10}", 4, n, 1);
        numfmt::push_fortran_e(&mut r7, rec.start_s, 13, 5);
        numfmt::push_fortran_e(&mut r7, rec.dt_s, 13, 5);
        numfmt::push_fortran_e(&mut r7, 0.0, 13, 5);
        push_line(&mut out, &r7);
        // Records 8-11.
        let axis = |t: i32, label: &str, unit: &str| {
            format!(
                "{:>10}{:>5}{:>5}{:>5} {:<20} {:<20}",
                t, 0, 0, 0, label, unit
            )
        };
        push_line(&mut out, &axis(17, "Time", "s"));
        let label = if ch.name.len() <= 20 {
            ch.name.as_str()
        } else {
            "NONE"
        };
        push_line(
            &mut out,
            &axis(0, label, ch.unit.as_deref().unwrap_or("NONE")),
        );
        push_line(&mut out, &axis(0, "NONE", "NONE"));
        push_line(&mut out, &axis(0, "NONE", "NONE"));
        // Record 12.
        match enc {
            Uff58Encoding::Binary => {
                for v in &ch.values {
                    out.extend_from_slice(&v.to_le_bytes());
                }
            }
            Uff58Encoding::Ascii | Uff58Encoding::AsciiFullPrecision => {
                let (per_line, width, decimals) = if enc == Uff58Encoding::Ascii {
                    (4, 20, 12)
                } else {
                    (3, 25, 16)
                };
                let mut line = String::with_capacity(per_line * width + 1);
                for chunk in ch.values.chunks(per_line) {
                    line.clear();
                    for &v in chunk {
                        numfmt::push_fortran_e(&mut line, v, width, decimals);
                    }
                    push_line(&mut out, &line);
                }
            }
        }
        push_line(&mut out, "    -1");
    }
    out
}
