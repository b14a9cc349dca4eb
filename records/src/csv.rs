//! Delimited text records: a header row of channel names, one row per
//! sample, optionally a leading time column.

use std::io::{BufRead, Read};
use std::path::Path;

use crate::error::{IoOp, Location, Problem, RecordError};
use crate::numfmt::{self, NumError};
use crate::record::{Channel, Format, ReadOptions, RecordFile, SampleLines};
use crate::timeaxis::{self, AxisError, PrintModel};

const BOM: &[u8] = b"\xEF\xBB\xBF";

fn parse_error(path: &Path, at: Location, problem: Problem) -> RecordError {
    RecordError::Parse {
        path: path.to_path_buf(),
        at: Box::new(at),
        problem,
    }
}

/// Splits a header cell such as `force [N]` or `acc1 (m/s^2)` into the bare
/// name and the unit. Only a trailing bracket or parenthesis group is a
/// unit: `force_N` and `acc_1` are names.
pub(crate) fn split_unit(header: &str) -> (String, Option<String>) {
    let h = header.trim();
    for (open, close) in [('[', ']'), ('(', ')')] {
        let Some(inner) = h.strip_suffix(close) else {
            continue;
        };
        let Some(pos) = inner.rfind(open) else {
            continue;
        };
        let bare = inner[..pos].trim();
        let unit = inner[pos + open.len_utf8()..].trim();
        if !bare.is_empty() && !unit.is_empty() {
            return (bare.to_string(), Some(unit.to_string()));
        }
    }
    (h.to_string(), None)
}

/// Names of a time column that state no unit (taken as seconds, unless the
/// interval is implausible: [`timeaxis::UNDECLARED_UNIT_MAX_DT_S`]).
const UNITLESS_TIME_NAMES: [&str; 3] = ["time", "t", "zeit"];

/// Scale to seconds if `bare`/`unit` name a time column; `Err` carries an
/// unsupported unit.
pub(crate) fn time_column_scale(bare: &str, unit: Option<&str>) -> Option<Result<f64, String>> {
    let name = bare.to_ascii_lowercase();
    let implied = match name.as_str() {
        n if UNITLESS_TIME_NAMES.contains(&n) => None,
        "time_s" | "t_s" | "time_sec" => Some(1.0),
        "time_ms" | "t_ms" => Some(1e-3),
        _ => return None,
    };
    Some(match (implied, unit) {
        (Some(s), None) => Ok(s),
        (None, None) => Ok(1.0),
        (_, Some(u)) => {
            let Some(scale) = crate::units::seconds_per(u) else {
                return Some(Err(u.to_string()));
            };
            match implied {
                Some(s) if s != scale => Err(u.to_string()),
                _ => Ok(scale),
            }
        }
    })
}

/// Whether a time column's header (`bare`, `unit`) states its unit: a unit
/// in brackets or a name such as `time_ms`; `time` alone does not.
fn time_unit_declared(bare: &str, unit: Option<&str>) -> bool {
    unit.is_some() || !UNITLESS_TIME_NAMES.contains(&bare.to_ascii_lowercase().as_str())
}

pub(crate) type Cells<'a> = Vec<std::borrow::Cow<'a, str>>;

/// The cells of data row `n` (1-based line): split at `delim` (quotes
/// honoured), a trailing empty cell dropped when every row ends with the
/// delimiter, refused unless `ncols` wide.
pub(crate) fn row_cells<'a>(
    text: &'a str,
    delim: char,
    n: usize,
    ncols: usize,
    trailing_delimiter: bool,
    err: &dyn Fn(Location, Problem) -> RecordError,
) -> Result<Cells<'a>, RecordError> {
    let mut cells = split_line(text, delim).map_err(|col| {
        err(
            Location {
                line: Some(n),
                column: Some(col),
                ..Location::default()
            },
            Problem::UnterminatedQuote,
        )
    })?;
    if trailing_delimiter && cells.len() == ncols + 1 && cells[ncols].is_empty() {
        cells.pop();
    }
    if cells.len() != ncols {
        return Err(err(
            Location::line(n),
            Problem::RaggedRow {
                expected: ncols,
                found: cells.len(),
            },
        ));
    }
    Ok(cells)
}

/// The number in `cell` (at `at`), a decimal comma read as a point when
/// `decimal_comma` and the cell has no point and one comma; with the text
/// as read (for its printed precision).
pub(crate) fn cell_value<'a>(
    cell: &'a str,
    decimal_comma: bool,
    at: impl FnOnce() -> Location,
    err: &dyn Fn(Location, Problem) -> RecordError,
) -> Result<(f64, std::borrow::Cow<'a, str>), RecordError> {
    let s: std::borrow::Cow<'a, str> =
        if decimal_comma && !cell.contains('.') && cell.matches(',').count() == 1 {
            cell.replace(',', ".").into()
        } else {
            cell.into()
        };
    match numfmt::parse_decimal(&s) {
        Ok(v) => Ok((v, s)),
        Err(e) => {
            let text = cell.to_string();
            Err(err(
                at(),
                match e {
                    NumError::Empty => Problem::EmptyCell,
                    NumError::NotANumber => Problem::NonNumeric { text },
                    NumError::NonFinite => Problem::NonFinite { text },
                },
            ))
        }
    }
}

/// Splits a line at `delim`, honouring double quotes ("" inside quotes is a
/// quote). Cells are trimmed. Returns the 1-based column of an unclosed
/// quote as error.
pub(crate) fn split_line(line: &str, delim: char) -> Result<Cells<'_>, usize> {
    if !line.contains('"') {
        return Ok(line.split(delim).map(|c| c.trim().into()).collect());
    }
    let mut cells = Vec::new();
    let mut cur = String::new();
    let mut chars = line.chars().peekable();
    let mut in_quotes = false;
    let mut quote_col = 0;
    let mut col = 1;
    while let Some(c) = chars.next() {
        if in_quotes {
            if c == '"' {
                if chars.peek() == Some(&'"') {
                    chars.next();
                    cur.push('"');
                } else {
                    in_quotes = false;
                }
            } else {
                cur.push(c);
            }
        } else if c == delim {
            cells.push(std::mem::take(&mut cur).trim().to_string().into());
            col += 1;
        } else if c == '"' && cur.trim().is_empty() {
            cur.clear();
            in_quotes = true;
            quote_col = col;
        } else {
            cur.push(c);
        }
    }
    if in_quotes {
        return Err(quote_col);
    }
    cells.push(cur.trim().to_string().into());
    Ok(cells)
}

/// Picks the delimiter from the header line: the most frequent of tab,
/// semicolon and comma outside quotes (ties in that order); comma for a
/// single column.
pub(crate) fn detect_delimiter(header: &str) -> char {
    let (mut tabs, mut semis, mut commas) = (0usize, 0usize, 0usize);
    let mut in_quotes = false;
    for c in header.chars() {
        match c {
            '"' => in_quotes = !in_quotes,
            '\t' if !in_quotes => tabs += 1,
            ';' if !in_quotes => semis += 1,
            ',' if !in_quotes => commas += 1,
            _ => {}
        }
    }
    if tabs > 0 && tabs >= semis && tabs >= commas {
        '\t'
    } else if semis > 0 && semis >= commas {
        ';'
    } else {
        ','
    }
}

fn is_blank(line: &[u8]) -> bool {
    line.iter().all(|b| b.is_ascii_whitespace())
}

/// Bytes at the start of the input examined before its lines: a byte-order
/// mark and the first 8192 bytes after it (a NUL there is binary content).
const HEAD_BYTES: u64 = 8192 + BOM.len() as u64;

/// Parses a CSV record held in memory; `path` is used in messages only.
/// The same reader as [`parse_csv_from`], with every column reserved to
/// the file's line count up front.
pub fn parse_csv(bytes: &[u8], path: &Path, opts: &ReadOptions) -> Result<RecordFile, RecordError> {
    // Every data row is a line: reserving that many values up front keeps
    // long records from growing every column by doubling.
    let rows_bound = bytes.iter().filter(|&&b| b == b'\n').count() + 1;
    parse_lines(bytes, path, opts, rows_bound)
}

/// Reads a CSV record from `input` line by line (one line buffer, reused;
/// the values go straight into their columns), with the same checks,
/// messages and values as [`parse_csv`] on the whole content: the file is
/// never held in memory. `path` is used in messages only; an error while
/// reading is [`RecordError::Io`].
pub fn parse_csv_from<R: BufRead>(
    input: R,
    path: &Path,
    opts: &ReadOptions,
) -> Result<RecordFile, RecordError> {
    parse_lines(input, path, opts, 0)
}

/// Lines of the input, numbered from 1, without the `\n` and one `\r`
/// before it: the lines of splitting the content at every `\n` (but for
/// the empty line after a final `\n`, which is blank and so changes
/// nothing).
struct Lines<R> {
    input: R,
    buf: Vec<u8>,
    number: usize,
}

impl<R: BufRead> Lines<R> {
    fn next(&mut self) -> std::io::Result<Option<(usize, &[u8])>> {
        self.buf.clear();
        if self.input.read_until(b'\n', &mut self.buf)? == 0 {
            return Ok(None);
        }
        self.number += 1;
        let line = self.buf.strip_suffix(b"\n").unwrap_or(&self.buf);
        Ok(Some((
            self.number,
            line.strip_suffix(b"\r").unwrap_or(line),
        )))
    }
}

/// Byte ranges of the cells of a line without quotes, split at `delim`
/// (an ASCII byte, so never part of a multi-byte character), into `out`
/// (cleared first); untrimmed. Eight bytes at a time: the delimiters of a
/// word are the zero bytes of `word ^ [delim; 8]`, found exactly (no carry
/// between bytes) as the high bits of `!(((x & 0x7f..) + 0x7f..) | x | 0x7f..)`.
fn cell_ranges(text: &str, delim: u8, out: &mut Vec<(usize, usize)>) {
    const LOW7: u64 = 0x7f7f_7f7f_7f7f_7f7f;
    out.clear();
    let bytes = text.as_bytes();
    let pattern = u64::from_le_bytes([delim; 8]);
    let mut start = 0;
    let mut chunks = bytes.chunks_exact(8);
    let mut base = 0;
    for chunk in &mut chunks {
        let word = u64::from_le_bytes(chunk.try_into().expect("chunks of 8 bytes")) ^ pattern;
        let mut found = !(((word & LOW7) + LOW7) | word | LOW7);
        while found != 0 {
            let at = base + (found.trailing_zeros() / 8) as usize;
            out.push((start, at));
            start = at + 1;
            found &= found - 1;
        }
        base += 8;
    }
    for (i, &b) in chunks.remainder().iter().enumerate() {
        if b == delim {
            out.push((start, base + i));
            start = base + i + 1;
        }
    }
    out.push((start, bytes.len()));
}

/// `cell.trim()`, without its character scan when both ends are visible
/// ASCII (then there is nothing to trim).
fn trim_cell(cell: &str) -> &str {
    match (cell.as_bytes().first(), cell.as_bytes().last()) {
        (Some(a), Some(b)) if a.is_ascii_graphic() && b.is_ascii_graphic() => cell,
        _ => cell.trim(),
    }
}

/// The text of `cell` as a number: with `decimal_comma`, a cell with no
/// point and one comma is read with the comma as the point (the converted
/// text is written into `scratch`).
fn number_text<'a>(cell: &'a str, decimal_comma: bool, scratch: &'a mut String) -> &'a str {
    if decimal_comma && !cell.contains('.') && cell.matches(',').count() == 1 {
        scratch.clear();
        scratch.extend(cell.chars().map(|c| if c == ',' { '.' } else { c }));
        scratch
    } else {
        cell
    }
}

/// The problem of a cell that is not a usable number.
fn number_problem(e: NumError, cell: &str) -> Problem {
    let text = cell.to_string();
    match e {
        NumError::Empty => Problem::EmptyCell,
        NumError::NotANumber => Problem::NonNumeric { text },
        NumError::NonFinite => Problem::NonFinite { text },
    }
}

/// The reader behind [`parse_csv`] and [`parse_csv_from`]; every column is
/// reserved to `rows_hint` values.
fn parse_lines<R: BufRead>(
    mut input: R,
    path: &Path,
    opts: &ReadOptions,
    rows_hint: usize,
) -> Result<RecordFile, RecordError> {
    opts.validate()?;
    let err = |at: Location, problem: Problem| parse_error(path, at, problem);
    let io = |error| RecordError::Io {
        path: path.to_path_buf(),
        op: IoOp::Read,
        error,
    };
    let mut head = Vec::with_capacity(HEAD_BYTES as usize);
    (&mut input)
        .take(HEAD_BYTES)
        .read_to_end(&mut head)
        .map_err(io)?;
    if head.starts_with(b"\xFF\xFE") || head.starts_with(b"\xFE\xFF") {
        return Err(err(Location::default(), Problem::Utf16));
    }
    let bom = if head.starts_with(BOM) { BOM.len() } else { 0 };
    if head[bom..].iter().take(8192).any(|&b| b == 0) {
        return Err(err(Location::default(), Problem::NotText));
    }
    let mut head = std::io::Cursor::new(head);
    head.set_position(bom as u64);
    let mut lines = Lines {
        input: head.chain(input),
        buf: Vec::new(),
        number: 0,
    };

    // Header: the first non-blank line.
    let (header_line, header_text) = loop {
        match lines.next().map_err(io)? {
            None => return Err(err(Location::default(), Problem::EmptyFile)),
            Some((n, l)) if !is_blank(l) => break (n, String::from_utf8_lossy(l).into_owned()),
            Some(_) => {}
        }
    };
    let Header {
        delim,
        names,
        trailing_delimiter,
        time_scale,
        time_unit_declared,
        mut channels,
    } = parse_header(&header_text, header_line, path)?;
    let ncols = names.len();
    let first_channel_col = usize::from(time_scale.is_some());

    // Data rows.
    let decimal_comma = delim != ',';
    let mut time: Vec<f64> = Vec::with_capacity(if time_scale.is_some() { rows_hint } else { 0 });
    for c in &mut channels {
        c.values.reserve_exact(rows_hint);
    }
    let mut time_model = PrintModel::printed();
    let mut first_data_line = None;
    let mut pending_blank: Option<usize> = None;
    // Reused by every row: cell ranges, and the text of a decimal-comma cell.
    let mut ranges: Vec<(usize, usize)> = Vec::with_capacity(ncols + 1);
    let mut scratch = String::new();
    while let Some((n, raw)) = lines.next().map_err(io)? {
        if is_blank(raw) {
            pending_blank.get_or_insert(n);
            continue;
        }
        if let Some(blank) = pending_blank {
            return Err(err(Location::line(blank), Problem::BlankLine));
        }
        first_data_line.get_or_insert(n);
        // The same text as `from_utf8_lossy`, without its per-character scan of valid
        // lines.
        let text = match std::str::from_utf8(raw) {
            Ok(valid) => std::borrow::Cow::Borrowed(valid),
            Err(_) => String::from_utf8_lossy(raw),
        };
        let mut push = |col: usize, cell: &str| -> Result<(), RecordError> {
            let s = number_text(cell, decimal_comma, &mut scratch);
            let value = numfmt::parse_decimal(s).map_err(|e| {
                err(
                    Location::cell(n, col + 1, &names[col]),
                    number_problem(e, cell),
                )
            })?;
            if col < first_channel_col {
                time_model.observe(numfmt::printed_precision(s));
                time.push(value);
            } else {
                channels[col - first_channel_col].values.push(value);
            }
            Ok(())
        };
        if text.contains('"') {
            // Quoted cells (rare in data rows): the general splitter.
            let cells = row_cells(&text, delim, n, ncols, trailing_delimiter, &err)?;
            for (col, cell) in cells.iter().enumerate() {
                push(col, cell)?;
            }
        } else {
            // The cells of `text.split(delim)`, trimmed, as `row_cells` takes them.
            cell_ranges(&text, delim as u8, &mut ranges);
            let cell = |&(a, b): &(usize, usize)| trim_cell(&text[a..b]);
            if trailing_delimiter && ranges.len() == ncols + 1 && cell(&ranges[ncols]).is_empty() {
                ranges.pop();
            }
            if ranges.len() != ncols {
                return Err(err(
                    Location::line(n),
                    Problem::RaggedRow {
                        expected: ncols,
                        found: ranges.len(),
                    },
                ));
            }
            for (col, range) in ranges.iter().enumerate() {
                push(col, cell(range))?;
            }
        }
    }
    finish(
        path,
        opts,
        header_line,
        &names,
        delim,
        (time_scale, time_unit_declared),
        Columns {
            time,
            time_model,
            channels,
            first_data_line,
        },
    )
}

/// The header row of a CSV record, read.
struct Header {
    delim: char,
    /// Column names as written (an empty last one of a trailing delimiter dropped).
    names: Vec<String>,
    /// Every line ends with a delimiter (its empty last cell is dropped).
    trailing_delimiter: bool,
    /// Seconds per unit of the time column (column 1), if there is one.
    time_scale: Option<f64>,
    /// The time column's header states its unit (`time [s]`, `time_ms`;
    /// not `time`). False without a time column.
    time_unit_declared: bool,
    /// The channels, without values.
    channels: Vec<Channel>,
}

/// Delimiter and column names of the header row `header_text` (line `header_line` of
/// `path`), and whether every line ends with a delimiter: spreadsheets often do, and an
/// empty last header cell is then dropped (as is the empty last cell of each row).
pub(crate) fn header_names(
    header_text: &str,
    header_line: usize,
    path: &Path,
) -> Result<(char, Vec<String>, bool), RecordError> {
    let delim = detect_delimiter(header_text);
    let mut names: Vec<String> = split_line(header_text, delim)
        .map_err(|col| {
            parse_error(
                path,
                Location {
                    line: Some(header_line),
                    column: Some(col),
                    ..Location::default()
                },
                Problem::UnterminatedQuote,
            )
        })?
        .into_iter()
        .map(|c| c.into_owned())
        .collect();
    let trailing_delimiter = names.len() > 1 && names.last().is_some_and(|n| n.is_empty());
    if trailing_delimiter {
        names.pop();
    }
    Ok((delim, names, trailing_delimiter))
}

/// Reads the header row `header_text` (line `header_line` of `path`): delimiter, names,
/// units and the time column.
fn parse_header(header_text: &str, header_line: usize, path: &Path) -> Result<Header, RecordError> {
    let err = |at: Location, problem: Problem| parse_error(path, at, problem);
    let (delim, names, trailing_delimiter) = header_names(header_text, header_line, path)?;
    let ncols = names.len();

    // Columns: names, units, time column.
    let mut time_scale = None;
    let mut declared = false;
    let mut channels = Vec::with_capacity(ncols);
    for (i, header) in names.iter().enumerate() {
        let at = || Location::cell(header_line, i + 1, header);
        let (bare, unit) = split_unit(header);
        if bare.is_empty() {
            return Err(err(at(), Problem::EmptyColumnName));
        }
        if let Some(scale) = time_column_scale(&bare, unit.as_deref()) {
            if i != 0 {
                return Err(err(at(), Problem::MisplacedTimeColumn));
            }
            time_scale =
                Some(scale.map_err(|unit| err(at(), Problem::UnsupportedTimeUnit { unit }))?);
            declared = time_unit_declared(&bare, unit.as_deref());
            continue;
        }
        channels.push(Channel {
            name: bare,
            unit,
            node: None,
            direction: None,
            id_line: None,
            values: Vec::new(),
            lines: None,
        });
    }
    if channels.is_empty() {
        return Err(err(Location::line(header_line), Problem::NoChannels));
    }
    Ok(Header {
        delim,
        names,
        trailing_delimiter,
        time_scale,
        time_unit_declared: declared,
        channels,
    })
}

/// The data rows of a CSV record, read.
struct Columns {
    /// Time column values (empty without one), in its unit.
    time: Vec<f64>,
    /// How the time column was printed.
    time_model: PrintModel,
    /// The channels with their values.
    channels: Vec<Channel>,
    /// Line of the first data row.
    first_data_line: Option<usize>,
}

/// The record from its header and data rows: refuses a header-only file, checks the time
/// axis against `opts` and sets the sampling. `time` is the time column's seconds per unit
/// (`None` without one) and whether its header states the unit.
fn finish(
    path: &Path,
    opts: &ReadOptions,
    header_line: usize,
    names: &[String],
    delim: char,
    (time_scale, time_unit_declared): (Option<f64>, bool),
    columns: Columns,
) -> Result<RecordFile, RecordError> {
    let err = |at: Location, problem: Problem| parse_error(path, at, problem);
    let Columns {
        mut time,
        time_model,
        mut channels,
        first_data_line,
    } = columns;
    let Some(first_data_line) = first_data_line else {
        return Err(err(Location::line(header_line), Problem::HeaderOnly));
    };
    let nrows = channels[0].values.len();
    // Data rows are contiguous (a blank line inside them is refused above).
    for c in &mut channels {
        c.lines = Some(SampleLines::Rows {
            first_line: first_data_line,
        });
    }

    // Sampling.
    let (start_s, dt_s) = match time_scale {
        Some(scale) => {
            if scale != 1.0 {
                time.iter_mut().for_each(|t| *t *= scale);
            }
            let time_name = names[0].as_str();
            let row_at = |i: usize| Location::cell(first_data_line + i, 1, time_name);
            if nrows == 1 {
                match opts.fs_hz {
                    Some(fs) => (time[0], 1.0 / fs),
                    None => return Err(err(row_at(0), Problem::SingleSample)),
                }
            } else {
                let dt = timeaxis::check_uniform(&time, &time_model, scale)
                    .map_err(|e| axis_error(path, e, row_at))?;
                if let Some(fs) = opts.fs_hz {
                    // The interval from the end points is uncertain by the
                    // printing error of both; allow that, at least 1e-6.
                    let q = time_model.half_unit(time[0], scale)
                        + time_model.half_unit(time[nrows - 1], scale);
                    let tol = (q / (nrows - 1) as f64).max(1e-6 * dt);
                    if (1.0 / fs - dt).abs() > tol {
                        return Err(err(
                            Location::cell(first_data_line, 1, time_name),
                            Problem::FsMismatch {
                                fs_hz: fs,
                                file_dt_s: dt,
                            },
                        ));
                    }
                } else if !time_unit_declared && dt >= timeaxis::UNDECLARED_UNIT_MAX_DT_S {
                    return Err(err(
                        Location::cell(header_line, 1, time_name),
                        Problem::UndeclaredTimeUnit {
                            dt_s: dt,
                            declare: format!(
                                "write the header '{time_name} [ms]' (or '{time_name} [s]' if they are seconds)"
                            ),
                        },
                    ));
                }
                (time[0], dt)
            }
        }
        None => match opts.fs_hz {
            Some(fs) => (0.0, 1.0 / fs),
            None => return Err(err(Location::line(header_line), Problem::NoTimeColumnNoFs)),
        },
    };

    Ok(RecordFile {
        path: path.to_path_buf(),
        format: Format::Csv {
            delimiter: delim as u8,
        },
        dt_s,
        // -0.0 (a time column starting at "-0") becomes +0.0: times are
        // computed as start + i*dt, which gives +0.0 at i = 0 anyway.
        start_s: start_s + 0.0,
        channels,
    })
}

/// Turns a time-axis refusal into a located error.
pub(crate) fn axis_error(path: &Path, e: AxisError, at: impl Fn(usize) -> Location) -> RecordError {
    let (index, problem) = match e {
        AxisError::NotIncreasing {
            index,
            previous,
            value,
        } => (index, Problem::TimeNotIncreasing { previous, value }),
        AxisError::Step {
            index,
            step,
            dt,
            tolerance,
        } => (
            index,
            Problem::NonUniformStep {
                step,
                dt,
                tolerance,
            },
        ),
        AxisError::OffGrid {
            index,
            value,
            expected,
            dt,
            tolerance,
        } => (
            index,
            Problem::NonUniformTime {
                value,
                expected,
                dt,
                tolerance,
            },
        ),
        AxisError::Overflow { index } => (index, Problem::TimeOverflow),
    };
    parse_error(path, at(index), problem)
}

/// The text of a header cell for a channel: `name` or `name [unit]`,
/// quoted if needed.
fn header_cell(ch: &Channel) -> String {
    let text = match &ch.unit {
        Some(u) => format!("{} [{}]", ch.name, u),
        None => ch.name.clone(),
    };
    if text.contains([',', '"', ';', '\t']) {
        format!("\"{}\"", text.replace('"', "\"\""))
    } else {
        text
    }
}

/// Checks that a channel's name and unit come back unchanged from
/// [`parse_csv`]; returns the reason if not.
pub(crate) fn header_round_trip_problem(ch: &Channel, index: usize) -> Option<String> {
    let control = |t: &str| t.chars().any(char::is_control);
    if control(&ch.name) || ch.unit.as_deref().is_some_and(control) {
        return Some(format!(
            "channel #{} name or unit contains a control character",
            index + 1
        ));
    }
    let written = match &ch.unit {
        Some(u) => format!("{} [{}]", ch.name, u),
        None => ch.name.clone(),
    };
    let (bare, unit) = split_unit(&written);
    if bare != ch.name || unit != ch.unit {
        return Some(format!(
            "channel #{} ('{}', unit {:?}) would be read back as '{}' with unit {:?}",
            index + 1,
            ch.name,
            ch.unit,
            bare,
            unit
        ));
    }
    if time_column_scale(&bare, unit.as_deref()).is_some() {
        return Some(format!(
            "channel #{} is named '{}', which readers take for the time column",
            index + 1,
            ch.name
        ));
    }
    None
}

/// Renders a validated record as CSV text: `time,<channels...>` (`time [s]`
/// from an interval of [`timeaxis::UNDECLARED_UNIT_MAX_DT_S`] on, which the
/// reader refuses under a bare `time`).
pub(crate) fn render_csv(rec: &RecordFile) -> String {
    let n = rec.len();
    let mut out = String::with_capacity((rec.channels.len() + 1) * n * 12 + 64);
    // `time` alone is read as seconds only below this interval; the unit is
    // written only where needed, so that every other file stays as before.
    out.push_str(if rec.dt_s >= timeaxis::UNDECLARED_UNIT_MAX_DT_S {
        "time [s]"
    } else {
        "time"
    });
    for ch in &rec.channels {
        out.push(',');
        out.push_str(&header_cell(ch));
    }
    out.push('\n');
    for i in 0..n {
        out.push_str(&numfmt::shortest(rec.start_s + i as f64 * rec.dt_s));
        for ch in &rec.channels {
            out.push(',');
            out.push_str(&numfmt::shortest(ch.values[i]));
        }
        out.push('\n');
    }
    out
}

#[cfg(test)]
#[path = "csv_oracle.rs"]
mod oracle;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn units_are_only_bracket_forms() {
        assert_eq!(split_unit("force [N]"), ("force".into(), Some("N".into())));
        assert_eq!(
            split_unit(" acc1 (m/s^2) "),
            ("acc1".into(), Some("m/s^2".into()))
        );
        assert_eq!(split_unit("force_N"), ("force_N".into(), None));
        assert_eq!(split_unit("acc_1"), ("acc_1".into(), None));
        assert_eq!(split_unit("[N]"), ("[N]".into(), None));
        assert_eq!(split_unit("a []"), ("a []".into(), None));
        assert_eq!(split_unit("Time (s)"), ("Time".into(), Some("s".into())));
    }

    #[test]
    fn time_column_names() {
        assert_eq!(time_column_scale("Time", Some("s")), Some(Ok(1.0)));
        assert_eq!(time_column_scale("t", None), Some(Ok(1.0)));
        assert_eq!(time_column_scale("time_s", None), Some(Ok(1.0)));
        assert_eq!(time_column_scale("TIME", Some("ms")), Some(Ok(1e-3)));
        assert_eq!(
            time_column_scale("time_s", Some("ms")),
            Some(Err("ms".into()))
        );
        assert_eq!(time_column_scale("time", Some("h")), Some(Err("h".into())));
        assert_eq!(time_column_scale("times", None), None);
        assert_eq!(time_column_scale("force", None), None);
    }

    #[test]
    fn delimiter_detection() {
        assert_eq!(detect_delimiter("time,force,acc1"), ',');
        assert_eq!(detect_delimiter("time;force;acc1"), ';');
        assert_eq!(detect_delimiter("time\tforce\tacc1"), '\t');
        assert_eq!(detect_delimiter("\"a;b\",c"), ',');
        assert_eq!(detect_delimiter("force"), ',');
    }

    /// Reads `text` with the streaming reader through a buffer of `cap`
    /// bytes (lines then cross the buffer's refills).
    fn stream(text: &[u8], cap: usize) -> Result<RecordFile, RecordError> {
        parse_csv_from(
            std::io::BufReader::with_capacity(cap, text),
            Path::new("hit.csv"),
            &ReadOptions::default(),
        )
    }

    /// The outcome as text: values in their shortest round-trip form (bit
    /// for bit, -0.0 included), errors with problem and location.
    fn outcome(r: &Result<RecordFile, RecordError>) -> String {
        format!("{r:?}")
    }

    /// The streaming reader (whole content, and through small buffers)
    /// against the former in-memory reader.
    fn same_as_oracle(text: &[u8], opts: &ReadOptions) {
        let path = Path::new("hit.csv");
        let want = outcome(&oracle::parse_csv_oracle(text, path, opts));
        assert_eq!(outcome(&parse_csv(text, path, opts)), want, "parse_csv");
        for cap in [1, 7, 64, 8192] {
            let got = parse_csv_from(std::io::BufReader::with_capacity(cap, text), path, opts);
            assert_eq!(outcome(&got), want, "parse_csv_from, buffer {cap}");
        }
    }

    fn problem(r: Result<RecordFile, RecordError>) -> (Problem, Location) {
        match r {
            Err(RecordError::Parse { problem, at, .. }) => (problem, *at),
            other => panic!("expected a parse error, got {other:?}"),
        }
    }

    #[test]
    fn streaming_reads_values_bit_for_bit() {
        let text = "time [s],force [N],acc1\n0,-0.0,1e-3\n0.5,2.5, 7 \n1.0,-1.25E+2,3\n";
        let r = stream(text.as_bytes(), 3).unwrap();
        assert_eq!(r.dt_s, 0.5);
        assert_eq!(r.channels[0].values[0].to_bits(), (-0.0f64).to_bits());
        assert_eq!(r.channels[0].values[2], -125.0);
        assert_eq!(r.channels[1].values, [1e-3, 7.0, 3.0]);
        assert_eq!(
            r.channels[0].lines,
            Some(SampleLines::Rows { first_line: 2 })
        );
        same_as_oracle(text.as_bytes(), &ReadOptions::default());
    }

    #[test]
    fn streaming_error_cases_name_line_and_column() {
        // Ragged row, before any bad number of the same row.
        let (p, at) = problem(stream(b"time,force,acc1\n0,1,2\n0.1,x\n", 5));
        assert_eq!(
            p,
            Problem::RaggedRow {
                expected: 3,
                found: 2
            }
        );
        assert_eq!(at, Location::line(3));
        // Bad number, empty cell, non-finite value.
        let (p, at) = problem(stream(b"time,force,acc1\n0,1,2\n0.1,2,abc\n", 5));
        assert_eq!(p, Problem::NonNumeric { text: "abc".into() });
        assert_eq!(at, Location::cell(3, 3, "acc1"));
        let (p, at) = problem(stream(b"time,force\n0,1\n0.1, \n", 5));
        assert_eq!(p, Problem::EmptyCell);
        assert_eq!(at, Location::cell(3, 2, "force"));
        let (p, _) = problem(stream(b"time,force\n0,1\n0.1,inf\n", 5));
        assert_eq!(p, Problem::NonFinite { text: "inf".into() });
        // Time not increasing, named at its line.
        let (p, at) = problem(stream(b"time,force\n0,1\n0.2,1\n0.1,1\n", 5));
        assert!(matches!(p, Problem::TimeNotIncreasing { .. }), "{p:?}");
        assert_eq!(at, Location::cell(4, 1, "time"));
        // Empty input, blank input, header only.
        assert_eq!(problem(stream(b"", 5)).0, Problem::EmptyFile);
        assert_eq!(problem(stream(b" \r\n\n\t\n", 5)).0, Problem::EmptyFile);
        let (p, at) = problem(stream(b"\n\ntime,force\r\n\r\n", 5));
        assert_eq!(p, Problem::HeaderOnly);
        assert_eq!(at, Location::line(3));
        // A blank line inside the data.
        let (p, at) = problem(stream(b"time,force\n0,1\n\n0.1,1\n", 5));
        assert_eq!(p, Problem::BlankLine);
        assert_eq!(at, Location::line(3));
        // Unterminated quote in a row.
        let (p, at) = problem(stream(b"time,force\n0,\"1\n", 5));
        assert_eq!(p, Problem::UnterminatedQuote);
        assert_eq!(at.line, Some(2));
        // UTF-16 and binary content are judged from the first bytes.
        assert_eq!(problem(stream(b"\xFF\xFEt\0", 2)).0, Problem::Utf16);
        let mut binary = b"time,force\n0,1\n".to_vec();
        binary.push(0);
        assert_eq!(problem(stream(&binary, 2)).0, Problem::NotText);
    }

    #[test]
    fn streaming_header_forms() {
        // BOM, CRLF, decimal commas, a trailing delimiter on every line,
        // quoted header cells, a quoted data cell, milliseconds.
        let text = "\u{feff}\r\n\"t [ms]\";\"acc; 1 [g]\";force;\r\n\
                    0,0;\"1,5\";2;\r\n1,0; -0,5 ;3;\r\n\r\n";
        let r = stream(text.as_bytes(), 4).unwrap();
        assert_eq!(r.format, Format::Csv { delimiter: b';' });
        assert_eq!(r.dt_s, 1e-3);
        assert_eq!(r.channels[0].name, "acc; 1");
        assert_eq!(r.channels[0].values, [1.5, -0.5]);
        assert_eq!(r.channels[1].values, [2.0, 3.0]);
        assert_eq!(
            r.channels[0].lines,
            Some(SampleLines::Rows { first_line: 3 })
        );
        same_as_oracle(text.as_bytes(), &ReadOptions::default());
        // No time column: the rate comes from the options.
        let r = parse_csv_from(
            &b"force\n1\n2\n"[..],
            Path::new("h.csv"),
            &ReadOptions::with_fs_hz(4.0),
        )
        .unwrap();
        assert_eq!((r.dt_s, r.start_s), (0.25, 0.0));
    }

    #[test]
    fn streaming_read_error_names_the_file() {
        /// Gives `ok` bytes of a valid file, then fails.
        struct Failing {
            data: std::io::Cursor<Vec<u8>>,
        }
        impl Read for Failing {
            fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
                match self.data.read(buf)? {
                    0 => Err(std::io::Error::other("device gone")),
                    k => Ok(k),
                }
            }
        }
        let mut text = String::from("time,force\n");
        for i in 0..3000 {
            text.push_str(&format!("{i},1\n"));
        }
        let input = std::io::BufReader::with_capacity(
            16,
            Failing {
                data: std::io::Cursor::new(text.into_bytes()),
            },
        );
        match parse_csv_from(input, Path::new("hit.csv"), &ReadOptions::default()) {
            Err(e @ RecordError::Io { .. }) => {
                assert_eq!(e.to_string(), "hit.csv: cannot read the file: device gone")
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn streaming_long_file_crosses_the_head() {
        // Longer than the bytes examined first: lines cross from the head
        // into the rest of the input.
        let mut text = String::from("time,force,acc1\n");
        for i in 0..3000 {
            text.push_str(&format!(
                "{},{},{}\n",
                i as f64 / 64.0,
                i % 7,
                -(i as f64) * 1e-3
            ));
        }
        assert!(text.len() as u64 > 3 * HEAD_BYTES);
        same_as_oracle(text.as_bytes(), &ReadOptions::default());
        let r = stream(text.as_bytes(), 8192).unwrap();
        assert_eq!(r.len(), 3000);
        assert_eq!(r.dt_s, 1.0 / 64.0);
    }

    use proptest::prelude::*;

    /// One number as writers print it.
    fn number() -> impl Strategy<Value = String> {
        prop_oneof![
            (-1e6f64..1e6).prop_map(|v| format!("{v}")),
            (-1e3f64..1e3, 0usize..9).prop_map(|(v, d)| format!("{v:.d$}")),
            (-1e-3f64..1e-3).prop_map(|v| format!("{v:e}")),
            (-1e9f64..1e9).prop_map(|v| format!("{v:.5E}")),
            (-99i64..99).prop_map(|v| v.to_string()),
        ]
    }

    /// A CSV file: random delimiter, time column (or none), channels,
    /// line ends, blank lines and padding, occasionally damaged.
    fn csv_file() -> impl Strategy<Value = Vec<u8>> {
        (
            (
                0usize..3,
                0usize..4,
                1usize..4,
                any::<bool>(),
                any::<bool>(),
            ),
            (any::<bool>(), any::<bool>(), 0usize..3, any::<bool>()),
            proptest::collection::vec(proptest::collection::vec(number(), 4), 0..40),
            (
                prop_oneof![Just(64u32), Just(100), Just(512), Just(1000), 1u32..2000],
                0usize..4,
                proptest::option::weighted(0.2, (0usize..4000, any::<u8>())),
            ),
        )
            .prop_map(
                |(
                    (d, time, nch, crlf, trailing),
                    (bom, quote_header, blank_before, pad),
                    rows,
                    (rate, digits, damage),
                )| {
                    let delim = [',', ';', '\t'][d];
                    let eol = if crlf { "\r\n" } else { "\n" };
                    let mut out = String::new();
                    if bom {
                        out.push('\u{feff}');
                    }
                    for _ in 0..blank_before {
                        out.push(' ');
                        out.push_str(eol);
                    }
                    let mut header: Vec<String> = Vec::new();
                    let time_name = ["", "time", "t [ms]", "Time (s)"][time];
                    if !time_name.is_empty() {
                        header.push(time_name.to_string());
                    }
                    for c in 0..nch {
                        let name = format!("acc{c} [m/s^2]");
                        header.push(if quote_header {
                            format!("\"{name}\"")
                        } else {
                            name
                        });
                    }
                    out.push_str(&header.join(&delim.to_string()));
                    if trailing {
                        out.push(delim);
                    }
                    out.push_str(eol);
                    for (i, row) in rows.iter().enumerate() {
                        let mut cells: Vec<String> = Vec::new();
                        if !time_name.is_empty() {
                            let t = i as f64 / f64::from(rate);
                            cells.push(format!("{t:.digits$}", digits = 6 + digits));
                        }
                        for v in row.iter().take(nch) {
                            cells.push(if delim != ',' && i % 3 == 0 {
                                v.replacen('.', ",", 1)
                            } else if pad {
                                format!(" {v} ")
                            } else {
                                v.clone()
                            });
                        }
                        if i % 11 == 5 {
                            cells[0] = format!("\"{}\"", cells[0]);
                        }
                        out.push_str(&cells.join(&delim.to_string()));
                        if trailing {
                            out.push(delim);
                        }
                        out.push_str(eol);
                    }
                    let mut bytes = out.into_bytes();
                    if let Some((at, b)) = damage
                        && !bytes.is_empty()
                    {
                        let at = at % bytes.len();
                        bytes[at] = b;
                    }
                    bytes
                },
            )
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(400))]

        #[test]
        fn streaming_reader_agrees_with_the_former_reader(bytes in csv_file()) {
            same_as_oracle(&bytes, &ReadOptions::default());
            same_as_oracle(&bytes, &ReadOptions::with_fs_hz(1000.0));
        }

        #[test]
        fn streaming_reader_agrees_on_any_bytes(
            bytes in proptest::collection::vec(
                prop_oneof![
                    Just(b','), Just(b';'), Just(b'\n'), Just(b'\r'), Just(b'"'), Just(b' '),
                    Just(b'1'), Just(b'.'), Just(b'e'), Just(b't'), any::<u8>()
                ],
                0..300,
            )
        ) {
            same_as_oracle(&bytes, &ReadOptions::default());
        }
    }

    #[test]
    fn cell_ranges_are_those_of_split() {
        let mut ranges = Vec::new();
        let lines = [
            "",
            ",",
            "a",
            "1,2,3",
            ",,,,,,,,,,,,,,,,,",
            "0.015625,9.602407567597727e-6,-0.00034238609177977873,-0.0005255027613384333",
            " \u{a0}x\u{2003} ;é;;\t;1,5;",
            "12345678,",
            ",12345678",
            "1234567,9abcdefg,ijklmnop,",
        ];
        for line in lines {
            for delim in [',', ';', '\t'] {
                cell_ranges(line, delim as u8, &mut ranges);
                let got: Vec<&str> = ranges.iter().map(|&(a, b)| &line[a..b]).collect();
                let want: Vec<&str> = line.split(delim).collect();
                assert_eq!(got, want, "{line:?} split at {delim:?}");
                let trimmed: Vec<&str> = got.iter().map(|c| trim_cell(c)).collect();
                let want: Vec<&str> = want.iter().map(|c| c.trim()).collect();
                assert_eq!(trimmed, want, "{line:?}");
            }
        }
    }

    #[test]
    fn quoted_cells() {
        let c = split_line(r#" "a, b" ,"say ""hi""",c"#, ',').ok().unwrap();
        assert_eq!(c, vec!["a, b", r#"say "hi""#, "c"]);
        assert_eq!(split_line(r#"a,"b"#, ',').err(), Some(2));
    }
}
