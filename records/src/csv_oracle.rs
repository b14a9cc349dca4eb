//! The in-memory CSV reader as it was before the streaming one (whole file
//! split into lines, one `Vec` of cells per row), kept as the oracle the
//! streaming reader is compared with.

use std::path::Path;

use super::*;

/// The former `parse_csv`, unchanged but for its name.
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
