//! FRFs as delimited text: the header convention and the headerless
//! Python-complex notation of the module docs of `crate::frf`.

use std::path::Path;

use ident::FrfQuantity;
use ident::linalg::C64;

use super::{FrfFile, FrfFormat, FrfPair, FrfPoint, FrfReadOptions};
use crate::csv::{cell_value, detect_delimiter, header_names, row_cells, split_line, split_unit};
use crate::error::{Location, Problem, RecordError};
use crate::numfmt::{self, NumError};
use crate::spec::{direction_label, parse_direction};
use crate::units;

const FREQUENCY_NAMES: [&str; 6] = ["frequency_hz", "frequency", "freq", "f", "freq_hz", "f_hz"];

fn parse_error(path: &Path, at: Location, problem: Problem) -> RecordError {
    RecordError::Parse {
        path: path.to_path_buf(),
        at: Box::new(at),
        problem,
    }
}

/// A complex number as Python prints it: `1.5+0j`, `-2e-3-4.5j`, `(1+2j)`,
/// `3j`, `0.25`. NaN and infinities are refused.
pub(crate) fn parse_complex(text: &str) -> Result<C64, Problem> {
    let t = text.trim();
    let t = t
        .strip_prefix('(')
        .and_then(|s| s.strip_suffix(')'))
        .unwrap_or(t)
        .trim();
    let bad = |reason| Problem::NotComplex {
        text: excerpt(text),
        reason,
    };
    let part = |s: &str| -> Result<f64, Problem> {
        match numfmt::parse_decimal(s) {
            Ok(v) => Ok(v),
            Err(NumError::NonFinite) => Err(Problem::NonFinite {
                text: excerpt(text),
            }),
            Err(NumError::Empty) => Err(bad("a part is empty")),
            Err(NumError::NotANumber) => Err(bad("expected re+imj as Python prints it")),
        }
    };
    let Some(body) = t.strip_suffix(['j', 'J']) else {
        return Ok(C64::new(part(t)?, 0.0));
    };
    // The imaginary part starts at the last sign that is not the first
    // character and does not follow an exponent letter.
    let split = body
        .char_indices()
        .filter(|&(i, c)| (c == '+' || c == '-') && i > 0 && !body[..i].ends_with(['e', 'E']))
        .map(|(i, _)| i)
        .next_back();
    let (re, im) = match split {
        Some(i) => (part(&body[..i])?, &body[i..]),
        None => (0.0, body),
    };
    let im = match im {
        "" | "+" => 1.0,
        "-" => -1.0,
        s => part(s)?,
    };
    Ok(C64::new(re, im))
}

fn excerpt(s: &str) -> String {
    let s = s.trim();
    if s.chars().count() > 40 {
        format!("{}...", s.chars().take(40).collect::<String>())
    } else {
        s.to_string()
    }
}

/// Whether a first line starts an FRF file: a row of complex numbers, or a
/// header with a frequency first column or a `re H(` column.
pub(crate) fn looks_like_frf(line: &str) -> bool {
    if headerless_row(line) {
        return true;
    }
    let delim = detect_delimiter(line);
    let Ok(cells) = split_line(line, delim) else {
        return false;
    };
    let first_is_frequency = cells.first().is_some_and(|c| frequency_scale(c).is_some());
    first_is_frequency || cells.iter().any(|c| parse_column(c).is_some())
}

/// A row of Python complex numbers (`j` in the row, every cell a number).
fn headerless_row(line: &str) -> bool {
    if !line.contains(['j', 'J']) {
        return false;
    }
    let delim = complex_delimiter(line);
    line.split(delim).all(|c| parse_complex(c).is_ok())
}

fn complex_delimiter(line: &str) -> char {
    if line.contains(';') {
        ';'
    } else if line.contains('\t') {
        '\t'
    } else {
        ','
    }
}

/// Hertz per unit of a frequency column header, if it is one.
fn frequency_scale(header: &str) -> Option<Result<f64, String>> {
    let (bare, unit) = split_unit(header);
    let name = bare.to_ascii_lowercase();
    if !FREQUENCY_NAMES.contains(&name.as_str()) {
        return None;
    }
    Some(match unit {
        None => Ok(1.0),
        Some(u) => units::hertz_per(&u).ok_or(u),
    })
}

/// A data column of the header convention.
#[derive(Debug, Clone, PartialEq)]
enum Column {
    Re(FrfPoint, FrfPoint, Option<String>),
    Im(FrfPoint, FrfPoint, Option<String>),
    Coh(FrfPoint, FrfPoint),
}

/// `name` or `name@node:direction`.
fn parse_point(text: &str) -> Option<FrfPoint> {
    let t = text.trim();
    if t.is_empty() || t.contains(['/', '(', ')', '[', ']']) {
        return None;
    }
    match t.split_once('@') {
        None => Some(FrfPoint::named(t)),
        Some((name, at)) => {
            let (node, dir) = at.split_once(':')?;
            let name = name.trim();
            if name.is_empty() {
                return None;
            }
            Some(FrfPoint::named_at(
                name,
                node.trim().parse().ok()?,
                parse_direction(dir)?,
            ))
        }
    }
}

fn point_text(p: &FrfPoint) -> String {
    match p.node_dir() {
        Some((n, d)) => format!("{}@{n}:{}", p.name, direction_label(d)),
        None => p.name.clone(),
    }
}

/// `response/reference` inside `H(...)` or `coh(...)`.
fn parse_pair(inner: &str) -> Option<(FrfPoint, FrfPoint)> {
    let (r, s) = inner.split_once('/')?;
    Some((parse_point(r)?, parse_point(s)?))
}

/// Splits a trailing `[unit]` (only brackets: the parentheses of `H(...)`
/// are not a unit).
fn split_bracket_unit(header: &str) -> (String, Option<String>) {
    let h = header.trim();
    if let Some(inner) = h.strip_suffix(']')
        && let Some(pos) = inner.rfind('[')
    {
        let unit = inner[pos + 1..].trim();
        if !unit.is_empty() {
            return (inner[..pos].trim().to_string(), Some(unit.to_string()));
        }
    }
    (h.to_string(), None)
}

fn parse_column(header: &str) -> Option<Column> {
    let (bare, unit) = split_bracket_unit(header);
    let lower = bare.to_ascii_lowercase();
    for prefix in ["coh(", "coh h("] {
        if lower.starts_with(prefix) && bare.ends_with(')') {
            let inner = &bare[prefix.len()..bare.len() - 1];
            let (r, s) = parse_pair(inner)?;
            return unit.is_none().then_some(Column::Coh(r, s));
        }
    }
    let (part, rest) = bare.split_once(char::is_whitespace)?;
    let rest = rest.trim_start();
    let inner = rest
        .strip_prefix("H(")
        .or_else(|| rest.strip_prefix("h("))?
        .strip_suffix(')')?;
    let (r, s) = parse_pair(inner)?;
    match part.to_ascii_lowercase().as_str() {
        "re" => Some(Column::Re(r, s, unit)),
        "im" => Some(Column::Im(r, s, unit)),
        _ => None,
    }
}

fn same_pair(a: (&FrfPoint, &FrfPoint), b: (&FrfPoint, &FrfPoint)) -> bool {
    a.0.same_point(b.0) && a.1.same_point(b.1)
}

struct Lines<'a> {
    lines: Vec<(usize, &'a [u8])>,
}

fn split_lines(body: &[u8]) -> Lines<'_> {
    Lines {
        lines: body
            .split(|&b| b == b'\n')
            .map(|l| l.strip_suffix(b"\r").unwrap_or(l))
            .enumerate()
            .map(|(i, l)| (i + 1, l))
            .collect(),
    }
}

fn is_blank(l: &[u8]) -> bool {
    l.iter().all(|b| b.is_ascii_whitespace())
}

/// The data rows after `from` (an index into `lines`): trailing blank lines
/// are allowed, a blank line between rows is refused.
fn data_rows<'a>(
    path: &Path,
    lines: &'a Lines<'a>,
    from: usize,
) -> Result<Vec<(usize, &'a [u8])>, RecordError> {
    let mut rows = Vec::new();
    let mut pending_blank = None;
    for &(n, l) in &lines.lines[from..] {
        if is_blank(l) {
            pending_blank.get_or_insert(n);
            continue;
        }
        if let Some(b) = pending_blank {
            return Err(parse_error(path, Location::line(b), Problem::BlankLine));
        }
        rows.push((n, l));
    }
    Ok(rows)
}

/// Parses an FRF CSV file (with header, or headerless complex).
pub(crate) fn parse(
    bytes: &[u8],
    path: &Path,
    opts: &FrfReadOptions,
) -> Result<FrfFile, RecordError> {
    let err = |at: Location, problem: Problem| parse_error(path, at, problem);
    if bytes.starts_with(b"\xFF\xFE") || bytes.starts_with(b"\xFE\xFF") {
        return Err(err(Location::default(), Problem::Utf16));
    }
    let body = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    if body.iter().take(8192).any(|&b| b == 0) {
        return Err(err(Location::default(), Problem::NotText));
    }
    let lines = split_lines(body);
    let Some(first) = lines.lines.iter().position(|(_, l)| !is_blank(l)) else {
        return Err(err(Location::default(), Problem::EmptyFile));
    };
    let first_text = String::from_utf8_lossy(lines.lines[first].1);
    if headerless_row(&first_text) {
        parse_headerless(path, &lines, first, opts)
    } else {
        parse_headed(path, &lines, first, opts)
    }
}

fn parse_headerless(
    path: &Path,
    lines: &Lines<'_>,
    first: usize,
    opts: &FrfReadOptions,
) -> Result<FrfFile, RecordError> {
    let err = |at: Location, problem: Problem| parse_error(path, at, problem);
    let first_line = lines.lines[first].0;
    let missing = |option, what| {
        err(
            Location::line(first_line),
            Problem::FrfMissingOption { option, what },
        )
    };
    let (quantity, scale) = opts.unitless()?.ok_or_else(|| {
        missing(
            "quantity",
            "the quantity (receptance, mobility, accelerance) or unit of its values",
        )
    })?;
    let reference = opts
        .reference
        .clone()
        .ok_or_else(|| missing("reference", "the reference (force) point"))?;
    let responses = opts
        .responses
        .clone()
        .ok_or_else(|| missing("responses", "the response points of its columns"))?;
    let delim = complex_delimiter(&String::from_utf8_lossy(lines.lines[first].1));
    let rows = data_rows(path, lines, first)?;
    let ncols = responses.len() + 1;
    let mut frequency_hz = Vec::with_capacity(rows.len());
    let mut values: Vec<Vec<C64>> = vec![Vec::with_capacity(rows.len()); responses.len()];
    for &(n, raw) in &rows {
        let text = String::from_utf8_lossy(raw);
        let mut cells: Vec<&str> = text.split(delim).collect();
        if cells.len() == ncols + 1 && cells[ncols].trim().is_empty() {
            cells.pop();
        }
        if cells.len() != ncols {
            if n == first_line {
                return Err(RecordError::InvalidOptions {
                    reason: format!(
                        "{}: line {n} has {} FRF columns but {} responses were given",
                        path.display(),
                        cells.len().saturating_sub(1),
                        responses.len()
                    ),
                });
            }
            return Err(err(
                Location::line(n),
                Problem::RaggedRow {
                    expected: ncols,
                    found: cells.len(),
                },
            ));
        }
        for (col, cell) in cells.iter().enumerate() {
            let name = if col == 0 {
                "frequency".to_string()
            } else {
                format!("H{col}")
            };
            let at = || Location::cell(n, col + 1, &name);
            let z = parse_complex(cell).map_err(|p| err(at(), p))?;
            if col == 0 {
                if z.im != 0.0 {
                    return Err(err(
                        at(),
                        Problem::NotComplex {
                            text: excerpt(cell),
                            reason: "a frequency has imaginary part 0",
                        },
                    ));
                }
                frequency_hz.push(z.re);
            } else {
                values[col - 1].push(z * scale);
            }
        }
    }
    super::check_grid(path, &frequency_hz, |k| {
        Location::cell(rows[k].0, 1, "frequency")
    })?;
    for (i, r) in responses.iter().enumerate() {
        if let Some(j) = responses[..i].iter().position(|o| o.same_point(r)) {
            return Err(RecordError::InvalidOptions {
                reason: format!(
                    "responses #{} and #{} ({r}) are the same point",
                    j + 1,
                    i + 1
                ),
            });
        }
    }
    let pairs = responses
        .into_iter()
        .zip(values)
        .enumerate()
        .map(|(i, (response, values))| FrfPair {
            response,
            reference: reference.clone(),
            quantity,
            values,
            coherence: None,
            averages: None,
            source: format!("column {}", i + 2),
            exponential_tau_s: None,
        })
        .collect();
    Ok(FrfFile {
        path: path.to_path_buf(),
        format: FrfFormat::CsvComplex,
        frequency_hz,
        pairs,
    })
}

struct PairColumns {
    response: FrfPoint,
    reference: FrfPoint,
    re: Option<(usize, Option<String>)>,
    im: Option<(usize, Option<String>)>,
    coh: Option<usize>,
}

fn parse_headed(
    path: &Path,
    lines: &Lines<'_>,
    first: usize,
    opts: &FrfReadOptions,
) -> Result<FrfFile, RecordError> {
    let err = |at: Location, problem: Problem| parse_error(path, at, problem);
    let (header_line, header_bytes) = lines.lines[first];
    let header_text = String::from_utf8_lossy(header_bytes);
    let (delim, names, trailing_delimiter) = header_names(&header_text, header_line, path)?;
    let ncols = names.len();
    let header_err = |col: usize, reason: String| {
        err(
            Location::cell(header_line, col + 1, &names[col]),
            Problem::FrfCsvHeader { reason },
        )
    };
    let f_scale = match frequency_scale(&names[0]) {
        Some(Ok(s)) => s,
        Some(Err(u)) => {
            return Err(header_err(
                0,
                format!("frequency unit '{u}' is not supported (use Hz or kHz)"),
            ));
        }
        None => {
            return Err(header_err(
                0,
                "the first column of an FRF file is the frequency (frequency_hz, or frequency [Hz])"
                    .into(),
            ));
        }
    };
    let mut pairs: Vec<PairColumns> = Vec::new();
    for col in 1..ncols {
        let Some(column) = parse_column(&names[col]) else {
            return Err(header_err(
                col,
                "not an FRF column: expected 're H(response/reference) [unit]', 'im H(response/reference) [unit]' or 'coh(response/reference)', a point being name or name@node:direction".into(),
            ));
        };
        let (r, s) = match &column {
            Column::Re(r, s, _) | Column::Im(r, s, _) | Column::Coh(r, s) => (r, s),
        };
        let k = match pairs
            .iter()
            .position(|p| same_pair((&p.response, &p.reference), (r, s)))
        {
            Some(k) => k,
            None => {
                pairs.push(PairColumns {
                    response: r.clone(),
                    reference: s.clone(),
                    re: None,
                    im: None,
                    coh: None,
                });
                pairs.len() - 1
            }
        };
        let p = &mut pairs[k];
        let taken = match column {
            Column::Re(_, _, u) => p.re.replace((col, u)).map(|(c, _)| c),
            Column::Im(_, _, u) => p.im.replace((col, u)).map(|(c, _)| c),
            Column::Coh(..) => p.coh.replace(col),
        };
        if let Some(c) = taken {
            return Err(header_err(
                col,
                format!("the same column as column {} ({})", c + 1, names[c]),
            ));
        }
    }
    if pairs.is_empty() {
        return Err(err(Location::line(header_line), Problem::NoChannels));
    }
    // Units and quantities per pair.
    let unitless = opts.unitless()?;
    let mut layout = Vec::with_capacity(pairs.len());
    for p in &pairs {
        let (Some((re, re_unit)), Some((im, im_unit))) = (&p.re, &p.im) else {
            let (have, lack) = if p.re.is_some() {
                ("re", "im")
            } else {
                ("im", "re")
            };
            let col =
                p.re.as_ref()
                    .or(p.im.as_ref())
                    .map_or(p.coh.unwrap_or(1), |c| c.0);
            return Err(header_err(
                col,
                format!(
                    "the pair {}/{} has a '{have}' column but no '{lack} H(...)' column",
                    p.response.name, p.reference.name
                ),
            ));
        };
        if re_unit != im_unit {
            return Err(header_err(
                *im,
                format!(
                    "unit {:?} differs from the unit {:?} of its real part (column {})",
                    im_unit,
                    re_unit,
                    re + 1
                ),
            ));
        }
        let (quantity, scale) = match re_unit {
            Some(u) => {
                let (q, s) = units::frf_unit(u).ok_or_else(|| {
                    header_err(
                        *re,
                        format!(
                            "FRF unit '{u}' is not known; use {}",
                            units::frf_units_hint()
                        ),
                    )
                })?;
                if let Some((oq, _)) = unitless
                    && oq != q
                    && opts.unit.is_none()
                {
                    return Err(header_err(
                        *re,
                        format!("unit '{u}' is {q}, but the read options say {oq}"),
                    ));
                }
                (q, s)
            }
            None => unitless.ok_or_else(|| {
                err(
                    Location::cell(header_line, re + 1, &names[*re]),
                    Problem::FrfMissingOption {
                        option: "quantity",
                        what: "the unit of this column ('[(m/s^2)/N]' after the name)",
                    },
                )
            })?,
        };
        layout.push((*re, *im, p.coh, quantity, scale));
    }
    // Data.
    let rows = data_rows(path, lines, first + 1)?;
    if rows.is_empty() {
        return Err(err(Location::line(header_line), Problem::HeaderOnly));
    }
    let decimal_comma = delim != ',';
    let mut columns: Vec<Vec<f64>> = vec![Vec::with_capacity(rows.len()); ncols];
    for &(n, raw) in &rows {
        let text = String::from_utf8_lossy(raw);
        let cells = row_cells(&text, delim, n, ncols, trailing_delimiter, &err)?;
        for (col, cell) in cells.iter().enumerate() {
            let (v, _) = cell_value(
                cell,
                decimal_comma,
                || Location::cell(n, col + 1, &names[col]),
                &err,
            )?;
            columns[col].push(v);
        }
    }
    let frequency_hz: Vec<f64> = columns[0].iter().map(|f| f * f_scale).collect();
    super::check_grid(path, &frequency_hz, |k| {
        Location::cell(rows[k].0, 1, &names[0])
    })?;
    let mut out = Vec::with_capacity(pairs.len());
    for (p, (re, im, coh, quantity, scale)) in pairs.into_iter().zip(layout) {
        let values = columns[re]
            .iter()
            .zip(&columns[im])
            .map(|(&a, &b)| C64::new(a * scale, b * scale))
            .collect();
        let coherence = match coh {
            None => None,
            Some(c) => {
                if let Some(k) = columns[c].iter().position(|g| !(0.0..=1.0).contains(g)) {
                    return Err(err(
                        Location::cell(rows[k].0, c + 1, &names[c]),
                        Problem::FrfBadCoherence {
                            value: columns[c][k],
                        },
                    ));
                }
                Some(columns[c].clone())
            }
        };
        out.push(FrfPair {
            response: p.response,
            reference: p.reference,
            quantity,
            values,
            coherence,
            averages: None,
            source: format!("columns {}-{}", re + 1, im + 1),
            exponential_tau_s: None,
        });
    }
    Ok(FrfFile {
        path: path.to_path_buf(),
        format: FrfFormat::Csv,
        frequency_hz,
        pairs: out,
    })
}

// ----- writers -----

fn csv_point_problem(p: &FrfPoint, role: &str) -> Option<String> {
    let bad = p.name.is_empty()
        || p.name.trim() != p.name
        || p.name.chars().any(|c| {
            c.is_control() || matches!(c, '/' | '@' | '(' | ')' | '[' | ']' | ',' | ';' | '"')
        });
    if bad {
        return Some(format!(
            "{role} point name '{}' cannot be written in a CSV FRF header (no / @ ( ) [ ] , ; \" or control characters, no surrounding blanks, not empty)",
            p.name
        ));
    }
    let back = parse_point(&point_text(p));
    (back.as_ref() != Some(p)).then(|| {
        format!(
            "{role} point '{}' would not read back unchanged from '{}'",
            p.name,
            point_text(p)
        )
    })
}

/// Renders the header convention: `frequency_hz`, then per pair `re`,
/// `im` and (if present) `coh` columns; shortest round-trip numbers.
pub(crate) fn render(file: &FrfFile) -> Result<Vec<u8>, String> {
    let mut out = String::from("frequency_hz");
    for pair in &file.pairs {
        for (p, role) in [(&pair.response, "response"), (&pair.reference, "reference")] {
            if let Some(reason) = csv_point_problem(p, role) {
                return Err(reason);
            }
        }
        let h = format!(
            "{}/{}",
            point_text(&pair.response),
            point_text(&pair.reference)
        );
        let unit = pair.quantity.unit();
        out.push_str(&format!(",re H({h}) [{unit}],im H({h}) [{unit}]"));
        if pair.coherence.is_some() {
            out.push_str(&format!(",coh({h})"));
        }
    }
    out.push('\n');
    for (k, &f) in file.frequency_hz.iter().enumerate() {
        out.push_str(&numfmt::shortest(f));
        for pair in &file.pairs {
            let z = pair.values[k];
            out.push(',');
            out.push_str(&numfmt::shortest(z.re));
            out.push(',');
            out.push_str(&numfmt::shortest(z.im));
            if let Some(c) = &pair.coherence {
                out.push(',');
                out.push_str(&numfmt::shortest(c[k]));
            }
        }
        out.push('\n');
    }
    Ok(out.into_bytes())
}

/// A complex number as Python's `repr` would print it (without the
/// parentheses), with the shortest round-trip digits.
fn complex_text(z: C64) -> String {
    let im = numfmt::shortest(z.im);
    let sign = if im.starts_with('-') { "" } else { "+" };
    format!("{}{sign}{im}j", numfmt::shortest(z.re))
}

/// Renders the headerless notation `freq;H1;H2;...` (one reference).
pub(crate) fn render_complex(file: &FrfFile) -> Result<Vec<u8>, String> {
    let reference = &file.pairs[0].reference;
    if let Some(p) = file
        .pairs
        .iter()
        .find(|p| !p.reference.same_point(reference))
    {
        return Err(format!(
            "the headerless notation holds one reference, but the file has {} and {}",
            reference, p.reference
        ));
    }
    let quantity: FrfQuantity = file.pairs[0].quantity;
    if let Some(p) = file.pairs.iter().find(|p| p.quantity != quantity) {
        return Err(format!(
            "the headerless notation holds one quantity, but the file has {quantity} and {} ({})",
            p.quantity, p.response
        ));
    }
    let mut out = String::new();
    for (k, &f) in file.frequency_hz.iter().enumerate() {
        out.push_str(&complex_text(C64::new(f, 0.0)));
        for pair in &file.pairs {
            out.push(';');
            out.push_str(&complex_text(pair.values[k]));
        }
        out.push('\n');
    }
    Ok(out.into_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn python_complex_numbers() {
        let c = |s: &str| parse_complex(s).unwrap();
        assert_eq!(c("0.03125+0j"), C64::new(0.03125, 0.0));
        assert_eq!(
            c("-0.0285156946629286-0.0434577353298664j"),
            C64::new(-0.0285156946629286, -0.0434577353298664)
        );
        assert_eq!(c("(1e-05+2.5E+03j)"), C64::new(1e-5, 2500.0));
        assert_eq!(c("-3j"), C64::new(0.0, -3.0));
        assert_eq!(c("1-j"), C64::new(1.0, -1.0));
        assert_eq!(c(" 7 "), C64::new(7.0, 0.0));
        assert!(matches!(
            parse_complex("nan+0j"),
            Err(Problem::NonFinite { .. })
        ));
        assert!(matches!(
            parse_complex("1+2i"),
            Err(Problem::NotComplex { .. })
        ));
        for z in [
            C64::new(0.1, -0.2),
            C64::new(-1e-300, 5e-324),
            C64::new(0.0, -0.0),
        ] {
            let back = c(&complex_text(z));
            assert_eq!(back.re.to_bits(), z.re.to_bits());
            assert_eq!(back.im.to_bits(), z.im.to_bits());
        }
    }

    #[test]
    fn header_columns() {
        assert_eq!(
            parse_column("re H(acc2@2:+X/force@2:x) [(m/s^2)/N]"),
            Some(Column::Re(
                FrfPoint::named_at("acc2", 2, 1),
                FrfPoint::named_at("force", 2, 1),
                Some("(m/s^2)/N".into())
            ))
        );
        assert_eq!(
            parse_column("im H(a/b)"),
            Some(Column::Im(FrfPoint::named("a"), FrfPoint::named("b"), None))
        );
        assert_eq!(
            parse_column("coh(a/b)"),
            Some(Column::Coh(FrfPoint::named("a"), FrfPoint::named("b")))
        );
        assert_eq!(parse_column("acc1 [m/s^2]"), None);
        assert_eq!(parse_column("re H(a)"), None);
        assert!(looks_like_frf("frequency_hz,re H(a/b),im H(a/b)"));
        assert!(looks_like_frf("0.03125+0j;-0.02-0.04j"));
        assert!(!looks_like_frf("time [s],force [N],acc1 [m/s^2]"));
        assert!(!looks_like_frf("0.0,1.0,2.0"));
    }
}
