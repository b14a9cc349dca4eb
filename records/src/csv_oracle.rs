//! The in-memory CSV reader as it was before the streaming one (whole file
//! split into lines, one `Vec` of cells per row), kept as the oracle the
//! streaming reader is compared with.

use std::path::Path;

use super::*;

/// The former `parse_csv` (its row loop: whole file split into lines, one `Vec` of
/// cells per row), around the header and sampling code it shares with the streaming
/// reader ([`parse_header`], [`finish`]).
pub(super) fn parse_csv_oracle(
    bytes: &[u8],
    path: &Path,
    opts: &ReadOptions,
) -> Result<RecordFile, RecordError> {
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
