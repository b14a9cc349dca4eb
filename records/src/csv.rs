//! Delimited text records: a header row of channel names, one row per
//! sample, optionally a leading time column.

use std::path::Path;

use crate::error::{Location, Problem, RecordError};
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

/// Scale to seconds if `bare`/`unit` name a time column; `Err` carries an
/// unsupported unit.
pub(crate) fn time_column_scale(bare: &str, unit: Option<&str>) -> Option<Result<f64, String>> {
    let name = bare.to_ascii_lowercase();
    let implied = match name.as_str() {
        "time" | "t" | "zeit" => None,
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

/// Parses a CSV record held in memory; `path` is used in messages only.
pub fn parse_csv(bytes: &[u8], path: &Path, opts: &ReadOptions) -> Result<RecordFile, RecordError> {
    opts.validate()?;
    let err = |at: Location, problem: Problem| parse_error(path, at, problem);
    if bytes.starts_with(b"\xFF\xFE") || bytes.starts_with(b"\xFE\xFF") {
        return Err(err(Location::default(), Problem::Utf16));
    }
    let body = bytes.strip_prefix(BOM).unwrap_or(bytes);
    if body.iter().take(8192).any(|&b| b == 0) {
        return Err(err(Location::default(), Problem::NotText));
    }

    let mut lines = body
        .split(|&b| b == b'\n')
        .map(|l| l.strip_suffix(b"\r").unwrap_or(l))
        .enumerate()
        .map(|(i, l)| (i + 1, l));

    // Header: the first non-blank line.
    let (header_line, header_bytes) = loop {
        match lines.next() {
            None => return Err(err(Location::default(), Problem::EmptyFile)),
            Some((n, l)) if !is_blank(l) => break (n, l),
            Some(_) => {}
        }
    };
    let header_text = String::from_utf8_lossy(header_bytes);
    let delim = detect_delimiter(&header_text);
    let mut names: Vec<String> = split_line(&header_text, delim)
        .map_err(|col| {
            err(
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
    // Spreadsheets often end every line with a delimiter: an empty last
    // header cell is then dropped, and so is an empty last cell of a row.
    let trailing_delimiter = names.len() > 1 && names.last().is_some_and(|n| n.is_empty());
    if trailing_delimiter {
        names.pop();
    }
    let ncols = names.len();

    // Columns: names, units, time column.
    let mut time_scale = None;
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
    let first_channel_col = usize::from(time_scale.is_some());

    // Data rows.
    let decimal_comma = delim != ',';
    // Every data row is a line: reserving that many values up front keeps long records
    // from growing (and copying) every column by doubling, which at 10^6 rows held up to
    // twice the columns' memory at once.
    let rows_bound = body.iter().filter(|&&b| b == b'\n').count() + 1;
    let mut time: Vec<f64> = Vec::with_capacity(if time_scale.is_some() { rows_bound } else { 0 });
    for c in &mut channels {
        c.values.reserve_exact(rows_bound);
    }
    let mut time_model = PrintModel::printed();
    let mut first_data_line = None;
    let mut pending_blank: Option<usize> = None;
    for (n, raw) in lines {
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
        let cells = row_cells(&text, delim, n, ncols, trailing_delimiter, &err)?;
        for (col, cell) in cells.iter().enumerate() {
            let (value, s) = cell_value(
                cell,
                decimal_comma,
                || Location::cell(n, col + 1, &names[col]),
                &err,
            )?;
            if col < first_channel_col {
                time_model.observe(numfmt::printed_precision(&s));
                time.push(value);
            } else {
                channels[col - first_channel_col].values.push(value);
            }
        }
    }
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

/// Renders a validated record as CSV text: `time,<channels...>`.
pub(crate) fn render_csv(rec: &RecordFile) -> String {
    let n = rec.len();
    let mut out = String::with_capacity((rec.channels.len() + 1) * n * 12 + 64);
    out.push_str("time");
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

    #[test]
    fn quoted_cells() {
        let c = split_line(r#" "a, b" ,"say ""hi""",c"#, ',').ok().unwrap();
        assert_eq!(c, vec!["a, b", r#"say "hi""#, "c"]);
        assert_eq!(split_line(r#"a,"b"#, ',').err(), Some(2));
    }
}
