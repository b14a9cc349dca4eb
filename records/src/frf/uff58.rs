//! UFF dataset 58 function types 4 (FRF) and 6 (coherence): reader and
//! writer. The record layout is read by the shared dataset-58 reader of
//! `crate::uff`; this module interprets it (see the module docs of
//! `crate::frf` for the rules).

use std::path::Path;

use ident::FrfQuantity;
use ident::linalg::C64;

use super::{ContentKind, FrfFile, FrfFormat, FrfPair, FrfPoint, default_name, grid_mismatch};
use crate::error::{Location, Problem, RecordError};
use crate::numfmt;
use crate::record::SampleLines;
use crate::uff::{self, Ctx, Cursor, E13_REL, Expect, RawDataset58, TAG, meaningful};
use crate::units;

/// The unit system of a dataset 164: SI per file unit is `1 / factor`.
#[derive(Debug, Clone, Copy)]
struct Units164 {
    length: f64,
    force: f64,
}

/// One dataset 58 interpreted.
struct Read58 {
    index: usize,
    rec6_line: usize,
    rec7_line: usize,
    binary: bool,
    coherence: bool,
    response: FrfPoint,
    reference: FrfPoint,
    response_entity: Option<String>,
    reference_entity: Option<String>,
    frequency_hz: Vec<f64>,
    values: Vec<C64>,
    real: Vec<f64>,
    quantity: FrfQuantity,
    averages: Option<usize>,
    exponential_tau_s: Option<f64>,
}

/// The kind of a UFF file: the function type of its first dataset 58.
pub(crate) fn content_kind(body: &[u8]) -> ContentKind {
    let mut lines = body
        .split(|&b| b == b'\n')
        .map(|l| l.strip_suffix(b"\r").unwrap_or(l));
    while let Some(l) = lines.next() {
        if !uff::is_delimiter(l) {
            continue;
        }
        let Some(header) = lines.next() else { break };
        let h = header.trim_ascii();
        let digits = h.iter().take_while(|b| b.is_ascii_digit()).count();
        if &h[..digits] != b"58" {
            // Skip to the closing delimiter of this (ASCII) dataset.
            if !lines.by_ref().any(uff::is_delimiter) {
                break;
            }
            continue;
        }
        // Records 1-5, then record 6.
        let Some(rec6) = lines.nth(5) else { break };
        let t = String::from_utf8_lossy(rec6);
        let func_type = t
            .split_ascii_whitespace()
            .next()
            .and_then(|tok| tok.parse::<i64>().ok());
        return if matches!(func_type, Some(4 | 6)) {
            ContentKind::Frf
        } else {
            ContentKind::TimeRecord
        };
    }
    ContentKind::TimeRecord
}

fn read164(ctx: &Ctx, cur: &mut Cursor, header_line: usize) -> Result<Units164, RecordError> {
    let mut records = Vec::new();
    loop {
        match cur.next_line() {
            Some((_, l)) if uff::is_delimiter(l) => break,
            Some(l) => records.push(l),
            None => {
                return Err(ctx.truncated(header_line, "before the closing '-1' of dataset 164"));
            }
        }
    }
    let Some(&(line, rec2)) = records.get(1) else {
        return Err(ctx.err(
            ctx.at_line(header_line),
            Problem::UffTruncated {
                missing: "dataset 164 closes before record 2 (unit factors)".into(),
            },
        ));
    };
    let t = String::from_utf8_lossy(rec2);
    let tokens: Vec<&str> = t.split_ascii_whitespace().collect();
    let mut factors = [0.0; 2];
    for (k, name) in ["length", "force"].iter().enumerate() {
        let field = format!("dataset 164 record 2 field {} ({name} factor)", k + 1);
        let tok = tokens.get(k).copied().unwrap_or("");
        factors[k] = numfmt::parse_fortran(tok)
            .ok()
            .filter(|v| *v > 0.0)
            .ok_or_else(|| ctx.bad_field(line, &field, tok.as_bytes(), "a positive number"))?;
    }
    Ok(Units164 {
        length: factors[0],
        force: factors[1],
    })
}

/// `frameid key=value` tokens of an ID line.
fn tag_value(id: &str, key: &str) -> Option<f64> {
    let rest = id.trim().strip_prefix(TAG)?;
    rest.split_ascii_whitespace()
        .find_map(|tok| tok.strip_prefix(key)?.strip_prefix('='))
        .and_then(|v| v.parse::<f64>().ok())
        .filter(|v| v.is_finite())
}

fn quantity_of_type(t: i64) -> Option<FrfQuantity> {
    match t {
        8 => Some(FrfQuantity::Receptance),
        11 => Some(FrfQuantity::Mobility),
        12 => Some(FrfQuantity::Accelerance),
        _ => None,
    }
}

/// The quantity and the factor to SI of an FRF dataset (records 9, 10).
fn quantity_and_scale(
    ctx: &Ctx,
    raw: &RawDataset58,
    units164: Option<Units164>,
) -> Result<(FrfQuantity, f64), RecordError> {
    let [_, num, den, _] = &raw.axes;
    let (num_line, den_line) = (raw.record_lines[8], raw.record_lines[9]);
    let unit_err = |line: usize, field: &str, reason: String| {
        ctx.err(ctx.at(line, field), Problem::FrfUnit { reason })
    };
    let from_type = match num.spec_type {
        Some(0 | 1) => None,
        Some(t) if quantity_of_type(t).is_some() => quantity_of_type(t),
        other => {
            return Err(unit_err(
                num_line,
                "record 9 field 1 (ordinate numerator specific data type)",
                format!(
                    "data type {} is not displacement (8), velocity (11), acceleration (12) or unknown (0, 1)",
                    other.map_or_else(|| format!("'{}'", num.raw), |t| t.to_string())
                ),
            ));
        }
    };
    match den.spec_type {
        Some(0 | 1 | 9 | 13) => {}
        other => {
            return Err(unit_err(
                den_line,
                "record 10 field 1 (ordinate denominator specific data type)",
                format!(
                    "data type {} is not a force (13 excitation, 9 reaction) or unknown (0, 1)",
                    other.map_or_else(|| format!("'{}'", den.raw), |t| t.to_string())
                ),
            ));
        }
    }
    // Exponents of a translation over a force.
    let checks = [
        (num, num_line, 9, [&[0i64, 1][..], &[0], &[0]]),
        (den, den_line, 10, [&[0][..], &[0, 1], &[0]]),
    ];
    for (axis, line, record, allowed) in checks {
        for (k, name) in ["length", "force", "temperature"].iter().enumerate() {
            if !axis.exponents[k].is_some_and(|e| allowed[k].contains(&e)) {
                return Err(unit_err(
                    line,
                    &format!("record {record} field {} ({name} units exponent)", k + 2),
                    format!(
                        "exponent {} is not that of {} (allowed: {:?})",
                        axis.exponents[k].map_or("unreadable".into(), |e| e.to_string()),
                        if record == 9 {
                            "a translation"
                        } else {
                            "a force"
                        },
                        allowed[k]
                    ),
                ));
            }
        }
    }
    let default_len = units164.map_or(1.0, |u| 1.0 / u.length);
    let default_force = units164.map_or(1.0, |u| 1.0 / u.force);
    let force_scale = |label: Option<&str>| -> Result<f64, RecordError> {
        match label {
            None => Ok(default_force),
            Some(d) => units::newtons_per(d).ok_or_else(|| {
                unit_err(
                    den_line,
                    "record 10 field 6 (ordinate denominator units label)",
                    format!("'{d}' is not a force unit (N, kN, lbf, kgf)"),
                )
            }),
        }
    };
    let num_label = meaningful(&num.unit);
    let den_label = meaningful(&den.unit);
    let (label_quantity, scale) = match num_label {
        Some(n) => {
            if let (Some((q, s)), None) = (units::frf_unit(n), den_label) {
                (Some(q), s)
            } else {
                let (q, s) = units::motion_unit(n).ok_or_else(|| {
                    unit_err(
                        num_line,
                        "record 9 field 6 (ordinate units label)",
                        format!(
                            "'{n}' is not a response unit (m, mm, m/s, mm/s, in/s, m/s^2, g, ...) nor an FRF unit ({})",
                            units::frf_units_hint()
                        ),
                    )
                })?;
                (Some(q), s / force_scale(den_label)?)
            }
        }
        None => (None, default_len / force_scale(den_label)?),
    };
    let quantity = match (from_type, label_quantity) {
        (Some(a), Some(b)) if a != b => {
            return Err(unit_err(
                num_line,
                "record 9 fields 1 and 6 (data type and units label)",
                format!(
                    "data type {} says {a} but the unit label '{}' says {b}",
                    num.spec_type.unwrap_or(0),
                    num_label.unwrap_or_default()
                ),
            ));
        }
        (Some(a), _) | (None, Some(a)) => a,
        (None, None) => {
            return Err(unit_err(
                num_line,
                "record 9 fields 1 and 6 (data type and units label)",
                format!(
                    "data type {} (unknown or general) and no unit label: displacement, velocity or acceleration cannot be decided",
                    num.spec_type.unwrap_or(0)
                ),
            ));
        }
    };
    Ok((quantity, scale))
}

fn point(node: i64, direction: i64) -> FrfPoint {
    if node == 0 && direction == 0 {
        FrfPoint::named(default_name(0, 0))
    } else {
        FrfPoint::at(node, direction as i32)
    }
}

fn interpret(
    ctx: &Ctx,
    raw: RawDataset58,
    units164: Option<Units164>,
) -> Result<Read58, RecordError> {
    let lines = raw.record_lines;
    let coherence = raw.r6.func_type == 6;
    for (dir, field) in [
        (
            raw.r6.response_direction,
            "record 6 field 7 (response direction)",
        ),
        (
            raw.r6.reference_direction,
            "record 6 field 10 (reference direction)",
        ),
    ] {
        if dir.abs() >= 4 {
            return Err(ctx.bad_field(
                lines[5],
                field,
                dir.to_string().as_bytes(),
                "a rotation (4..6); FRFs of translations over forces only are read",
            ));
        }
    }
    // Abscissa: a frequency.
    let ax = &raw.axes[0];
    let hz = match meaningful(&ax.unit) {
        Some(u) => units::hertz_per(u),
        None => Some(1.0),
    };
    let hz = match (ax.spec_type, hz) {
        (Some(0 | 1 | 18), Some(h)) => h,
        _ => {
            return Err(ctx.err(
                ctx.at(
                    lines[7],
                    "record 8 fields 1 and 6 (abscissa data type and units label)",
                ),
                Problem::FrfAbscissa {
                    found: format!(
                        "specific data type {} with units label '{}'",
                        ax.spec_type
                            .map_or_else(|| "unreadable".to_string(), |t| t.to_string()),
                        ax.unit
                    ),
                },
            ));
        }
    };
    let (quantity, scale) = if coherence {
        (FrfQuantity::Accelerance, 1.0)
    } else {
        quantity_and_scale(ctx, &raw, units164)?
    };
    let per = raw.per_point();
    let n = raw.values.len() / per;
    let offset = usize::from(!raw.r7.even);
    let frequency_hz: Vec<f64> = if raw.r7.even {
        let (mut f0, mut df) = (raw.r7.x_min * hz, raw.r7.dx * hz);
        if let (Some(t0), Some(tdf)) = (
            tag_value(&raw.id[4], "f0_hz"),
            tag_value(&raw.id[4], "df_hz"),
        ) && (tdf - df).abs() <= E13_REL * df
            && (t0 - f0).abs() <= E13_REL * f0.abs().max(df)
        {
            (f0, df) = (t0, tdf);
        }
        (0..n).map(|k| f0 + k as f64 * df).collect()
    } else {
        raw.values.iter().step_by(per).map(|x| x * hz).collect()
    };
    let sample_lines = (!raw.line_starts.is_empty()).then(|| SampleLines::Values {
        starts: raw.line_starts.clone(),
        stride: per,
        offset,
    });
    let line_of = |k: usize| {
        sample_lines
            .as_ref()
            .and_then(|s| s.line_of(k))
            .unwrap_or(raw.data_line)
    };
    super::check_grid(ctx.path, &frequency_hz, |k| {
        ctx.at(
            line_of(k),
            if raw.r7.even {
                format!("frequency line {} (from record 7)", k + 1)
            } else {
                format!("abscissa value {} of the data", k + 1)
            },
        )
    })?;
    let (mut values, mut real) = (Vec::new(), Vec::new());
    if coherence {
        real.reserve(n);
        for k in 0..n {
            let g = raw.values[k * per + offset];
            // An analyzer's coherence of exactly 1 can come out one
            // single-precision step above it (1 + 1.2e-7); allow 1e-6.
            if !(0.0..=1.0 + 1e-6).contains(&g) {
                return Err(ctx.err(
                    ctx.at(line_of(k), format!("coherence value {} of the data", k + 1)),
                    Problem::FrfBadCoherence { value: g },
                ));
            }
            real.push(g.min(1.0));
        }
    } else {
        values.reserve(n);
        for k in 0..n {
            let i = k * per + offset;
            values.push(C64::new(raw.values[i] * scale, raw.values[i + 1] * scale));
        }
    }
    let averages = raw.id[3..]
        .iter()
        .find_map(|id| tag_value(id, "averages"))
        .filter(|a| *a >= 1.0 && a.fract() == 0.0)
        .map(|a| a as usize);
    let exponential_tau_s = raw.id[3..]
        .iter()
        .find_map(|id| tag_value(id, "tau_s"))
        .filter(|t| *t > 0.0);
    let r6 = &raw.r6;
    Ok(Read58 {
        index: raw.index,
        rec6_line: lines[5],
        rec7_line: lines[6],
        binary: raw.binary,
        coherence,
        response: point(r6.response_node, r6.response_direction),
        reference: point(r6.reference_node, r6.reference_direction),
        response_entity: meaningful(&r6.response_entity).map(str::to_string),
        reference_entity: meaningful(&r6.reference_entity).map(str::to_string),
        frequency_hz,
        values,
        real,
        quantity,
        averages,
        exponential_tau_s,
    })
}

/// Parses a UFF file of FRFs held in memory.
pub(crate) fn parse(bytes: &[u8], path: &Path) -> Result<FrfFile, RecordError> {
    let mut units164: Option<Units164> = None;
    let mut sets: Vec<Read58> = Vec::new();
    let (count, others) = uff::scan_datasets(bytes, path, |ctx, cur, number, hn, bin| {
        match (number, bin) {
            (58, _) => {
                let raw = uff::read_raw58(ctx, cur, hn, bin, Expect::Frf)?;
                sets.push(interpret(ctx, raw, units164)?);
                Ok(true)
            }
            (164, None) => {
                units164 = Some(read164(ctx, cur, hn)?);
                Ok(true)
            }
            _ => Ok(false),
        }
    })?;
    let parse_err = |at: Location, problem| RecordError::Parse {
        path: path.to_path_buf(),
        at: Box::new(at),
        problem,
    };
    if sets.is_empty() {
        return Err(parse_err(
            Location::default(),
            if count == 0 {
                Problem::EmptyFile
            } else {
                Problem::UffNoDataset58 { found: others }
            },
        ));
    }
    name_points(&mut sets);
    let Some(first) = sets.iter().position(|s| !s.coherence) else {
        let s = &sets[0];
        return Err(parse_err(
            dataset_at(s.index, s.rec6_line, "record 6 field 1 (function type)"),
            Problem::FrfOrphanCoherence {
                response: s.response.name.clone(),
                reference: s.reference.name.clone(),
            },
        ));
    };
    let grid = sets[first].frequency_hz.clone();
    let grid_index = sets[first].index;
    let mut pairs: Vec<FrfPair> = Vec::new();
    let mut pair_index: Vec<usize> = Vec::new();
    for s in &sets {
        if let Some((k, here, there)) = grid_mismatch(&s.frequency_hz, &grid) {
            let (what, value, first_value) = match (here, there) {
                (Some(h), Some(t)) => (
                    format!("frequency line {}", k + 1),
                    format!("{h} Hz"),
                    format!("{t} Hz"),
                ),
                _ => (
                    "the number of frequency lines".into(),
                    s.frequency_hz.len().to_string(),
                    grid.len().to_string(),
                ),
            };
            return Err(parse_err(
                dataset_at(s.index, s.rec7_line, "record 7"),
                Problem::FrfGridMismatch {
                    what,
                    value,
                    first: grid_index,
                    first_value,
                },
            ));
        }
        if s.coherence {
            continue;
        }
        if let Some(p) = pairs.iter().position(|p| {
            p.response.same_point(&s.response) && p.reference.same_point(&s.reference)
        }) {
            return Err(parse_err(
                dataset_at(s.index, s.rec6_line, "record 6"),
                Problem::FrfDuplicatePair {
                    what: "FRF",
                    response: s.response.to_string(),
                    reference: s.reference.to_string(),
                    first: pair_index[p],
                },
            ));
        }
        pairs.push(FrfPair {
            response: s.response.clone(),
            reference: s.reference.clone(),
            quantity: s.quantity,
            values: s.values.clone(),
            coherence: None,
            averages: s.averages,
            source: format!("dataset {}", s.index),
            exponential_tau_s: s.exponential_tau_s,
        });
        pair_index.push(s.index);
    }
    let mut coherence_index: Vec<Option<usize>> = vec![None; pairs.len()];
    for s in sets.iter().filter(|s| s.coherence) {
        let Some(p) = pairs.iter().position(|p| {
            p.response.same_point(&s.response) && p.reference.same_point(&s.reference)
        }) else {
            return Err(parse_err(
                dataset_at(s.index, s.rec6_line, "record 6"),
                Problem::FrfOrphanCoherence {
                    response: s.response.to_string(),
                    reference: s.reference.to_string(),
                },
            ));
        };
        if let Some(first) = coherence_index[p] {
            return Err(parse_err(
                dataset_at(s.index, s.rec6_line, "record 6"),
                Problem::FrfDuplicatePair {
                    what: "coherence",
                    response: s.response.to_string(),
                    reference: s.reference.to_string(),
                    first,
                },
            ));
        }
        coherence_index[p] = Some(s.index);
        pairs[p].coherence = Some(s.real.clone());
    }
    Ok(FrfFile {
        path: path.to_path_buf(),
        format: if sets[first].binary {
            FrfFormat::Uff58Binary
        } else {
            FrfFormat::Uff58Ascii
        },
        frequency_hz: grid,
        pairs,
    })
}

fn dataset_at(dataset: usize, line: usize, field: &str) -> Location {
    Location {
        dataset: Some(dataset),
        line: Some(line),
        column: None,
        field: Some(field.to_string()),
    }
}

/// Names every point by its entity name when that names one place in the
/// file, else `node:direction` (already set).
fn name_points(sets: &mut [Read58]) {
    use std::collections::HashMap;
    type Place = (Option<i64>, Option<i32>);
    let mut places: HashMap<String, Vec<Place>> = HashMap::new();
    for s in sets.iter() {
        for (entity, p) in [
            (&s.response_entity, &s.response),
            (&s.reference_entity, &s.reference),
        ] {
            if let Some(e) = entity {
                let v = places.entry(e.clone()).or_default();
                let place = (p.node, p.direction);
                if !v.contains(&place) {
                    v.push(place);
                }
            }
        }
    }
    for s in sets.iter_mut() {
        for (entity, p) in [
            (&s.response_entity, &mut s.response),
            (&s.reference_entity, &mut s.reference),
        ] {
            if let Some(e) = entity
                && places.get(e).is_some_and(|v| v.len() == 1)
            {
                p.name = e.clone();
            }
        }
    }
}

// ----- writer -----

fn push_line(out: &mut Vec<u8>, s: &str) {
    out.extend_from_slice(s.as_bytes());
    out.push(b'\n');
}

/// Node, direction and entity name of a point as written; refuses a point
/// that would not read back as itself.
fn written_point(p: &FrfPoint, role: &str) -> Result<(i64, i32, String), String> {
    let fits_entity = |s: &str| {
        !s.is_empty()
            && s.len() <= 10
            && s.bytes().all(|b| b.is_ascii_graphic())
            && !s.eq_ignore_ascii_case("NONE")
    };
    let entity_err = || {
        format!(
            "{role} point name '{}' does not fit a UFF entity name (1 to 10 printable ASCII characters without blanks, not NONE){}",
            p.name,
            if p.node.is_some() {
                "; name it node:direction or shorter"
            } else {
                ""
            }
        )
    };
    match (p.node, p.direction) {
        (None, None) => {
            if !fits_entity(&p.name) {
                return Err(entity_err());
            }
            Ok((0, 0, p.name.clone()))
        }
        (Some(node), Some(dir)) => {
            if node == 0 && dir == 0 {
                return Err(format!(
                    "{role} point '{}' at node 0 direction 0 would read back as a point without node",
                    p.name
                ));
            }
            if !(-999_999_999..=9_999_999_999).contains(&node) {
                return Err(format!(
                    "{role} point '{}' node {node} does not fit in 10 columns",
                    p.name
                ));
            }
            if !(-3..=3).contains(&dir) {
                return Err(format!(
                    "{role} point '{}' direction {dir} is not a translation (-3..3)",
                    p.name
                ));
            }
            if p.name == default_name(node, dir) {
                Ok((node, dir, "NONE".into()))
            } else if fits_entity(&p.name) {
                Ok((node, dir, p.name.clone()))
            } else {
                Err(entity_err())
            }
        }
        _ => Err(format!(
            "{role} point '{}' has a node or a direction but not both",
            p.name
        )),
    }
}

/// Relative departure from `f0 + k df` below which an ASCII file writes a
/// grid as evenly spaced: grids computed as `k fs / n` and as `k (fs / n)`
/// differ by a few units in the last place (1e-16 relative); written
/// unevenly, the abscissa would keep only the 6 digits of E13.5.
const NEARLY_EVEN_REL: f64 = 1e-12;

/// `(f0, df)` if `f[k] == f0 + k df` bit for bit (as the reader computes
/// it), or, when `nearly` is set, within [`NEARLY_EVEN_REL`]; else `None`.
fn even_grid(f: &[f64], nearly: bool) -> Option<(f64, f64)> {
    let f0 = f[0];
    let n = f.len();
    if n == 1 {
        return Some((f0, 1.0));
    }
    let df = f[1] - f0;
    if f.iter().enumerate().all(|(k, &x)| x == f0 + k as f64 * df) {
        return Some((f0, df));
    }
    let df = (f[n - 1] - f0) / (n - 1) as f64;
    (nearly
        && f.iter()
            .enumerate()
            .all(|(k, &x)| (x - (f0 + k as f64 * df)).abs() <= NEARLY_EVEN_REL * x.abs().max(df)))
    .then_some((f0, df))
}

fn e13(x: f64) -> String {
    let mut s = String::new();
    numfmt::push_fortran_e(&mut s, x, 13, 5);
    s
}

/// Renders a validated FRF file as dataset 58 (function types 4 and 6).
pub(crate) fn render(file: &FrfFile, binary: bool) -> Result<Vec<u8>, String> {
    let f = &file.frequency_hz;
    let n = f.len();
    let even = even_grid(f, !binary);
    if even.is_none() && !binary {
        // The uneven abscissa is E13.5: it must stay strictly ascending.
        let printed: Vec<f64> = f
            .iter()
            .map(|&x| e13(x).trim().parse::<f64>().unwrap_or(f64::NAN))
            .collect();
        if let Some(k) = (1..n).find(|&k| printed[k].is_nan() || printed[k] <= printed[k - 1]) {
            return Err(format!(
                "frequency lines {} and {} ({} and {} Hz) are not uniformly spaced and print alike with the 6 digits of an ASCII UFF abscissa; write binary UFF",
                k,
                k + 1,
                f[k - 1],
                f[k]
            ));
        }
    }
    let mut names: Vec<(String, (i64, i32))> = Vec::new();
    let mut points = Vec::with_capacity(file.pairs.len());
    for pair in &file.pairs {
        let r = written_point(&pair.response, "response")?;
        let s = written_point(&pair.reference, "reference")?;
        for (node, dir, entity) in [&r, &s] {
            if entity != "NONE" {
                match names.iter().find(|(e, _)| e == entity) {
                    Some((_, place)) if *place != (*node, *dir) => {
                        return Err(format!(
                            "point name '{entity}' is used for two places ({}:{} and {node}:{dir}); UFF readers would not tell them apart",
                            place.0, place.1
                        ));
                    }
                    Some(_) => {}
                    None => names.push((entity.clone(), (*node, *dir))),
                }
            }
        }
        points.push((r, s));
    }
    let mut out = Vec::with_capacity(file.pairs.len() * (n * 45 + 1200));
    let mut id = 0;
    for (pair, (r, s)) in file.pairs.iter().zip(&points) {
        let desc = format!("{}/{}", pair.response.name, pair.reference.name);
        id += 1;
        dataset(
            &mut out,
            &Dataset {
                func_type: 4,
                func_id: id,
                id1: &format!("H {desc}"),
                averages: pair.averages,
                exponential_tau_s: pair.exponential_tau_s,
                response: r,
                reference: s,
                quantity: Some(pair.quantity),
                complex: &pair.values,
                real: &[],
            },
            f,
            even,
            binary,
        );
        if let Some(c) = &pair.coherence {
            id += 1;
            dataset(
                &mut out,
                &Dataset {
                    func_type: 6,
                    func_id: id,
                    id1: &format!("coherence {desc}"),
                    averages: pair.averages,
                    exponential_tau_s: pair.exponential_tau_s,
                    response: r,
                    reference: s,
                    quantity: None,
                    complex: &[],
                    real: c,
                },
                f,
                even,
                binary,
            );
        }
    }
    Ok(out)
}

struct Dataset<'a> {
    func_type: i64,
    func_id: usize,
    id1: &'a str,
    averages: Option<usize>,
    exponential_tau_s: Option<f64>,
    response: &'a (i64, i32, String),
    reference: &'a (i64, i32, String),
    /// `Some` for an FRF (complex), `None` for a coherence (real).
    quantity: Option<FrfQuantity>,
    complex: &'a [C64],
    real: &'a [f64],
}

fn dataset(out: &mut Vec<u8>, d: &Dataset, f: &[f64], even: Option<(f64, f64)>, binary: bool) {
    let n = f.len();
    let complex = d.quantity.is_some();
    let per = usize::from(complex) + 1 + usize::from(even.is_none());
    push_line(out, "    -1");
    if binary {
        push_line(
            out,
            &format!(
                "{:>6}b{:>6}{:>6}{:>12}{:>12}{:>6}{:>6}{:>12}{:>12}",
                58,
                1,
                2,
                11,
                n * per * 8,
                0,
                0,
                0,
                0
            ),
        );
    } else {
        push_line(out, "    58");
    }
    let id1: String = d.id1.chars().take(80).collect();
    push_line(out, &format!("{id1:<80}"));
    push_line(out, &format!("{:<80}", "NONE"));
    push_line(out, &format!("{:<80}", "NONE"));
    let id4 = match (d.averages, d.exponential_tau_s) {
        (Some(a), Some(t)) => format!("{TAG} averages={a} tau_s={}", numfmt::shortest(t)),
        (Some(a), None) => format!("{TAG} averages={a}"),
        (None, Some(t)) => format!("{TAG} tau_s={}", numfmt::shortest(t)),
        (None, None) => "NONE".into(),
    };
    push_line(out, &format!("{id4:<80}"));
    let id5 = match even {
        Some((f0, df)) => format!(
            "{TAG} f0_hz={} df_hz={}",
            numfmt::shortest(f0),
            numfmt::shortest(df)
        ),
        None => "NONE".into(),
    };
    push_line(out, &format!("{id5:<80}"));
    let (r, s) = (d.response, d.reference);
    push_line(
        out,
        &format!(
            "{:>5}{:>10}{:>5}{:>10} {:<10}{:>10}{:>4} {:<10}{:>10}{:>4}",
            d.func_type, d.func_id, 0, 0, r.2, r.0, r.1, s.2, s.0, s.1
        ),
    );
    let (f0, df) = even.unwrap_or((0.0, 0.0));
    let mut r7 = format!(
        "{:>10}{:>10}{:>10}",
        if complex { 6 } else { 4 },
        n,
        usize::from(even.is_some())
    );
    r7.push_str(&e13(f0));
    r7.push_str(&e13(df));
    r7.push_str(&e13(0.0));
    push_line(out, &r7);
    let axis = |t: i64, e: [i64; 3], label: &str, unit: &str| {
        format!(
            "{:>10}{:>5}{:>5}{:>5} {:<20} {:<20}",
            t, e[0], e[1], e[2], label, unit
        )
    };
    push_line(out, &axis(18, [0, 0, 0], "Frequency", "Hz"));
    match d.quantity {
        Some(q) => {
            let (t, label, unit) = match q {
                FrfQuantity::Receptance => (8, "Displacement", "m"),
                FrfQuantity::Mobility => (11, "Velocity", "m/s"),
                FrfQuantity::Accelerance => (12, "Acceleration", "m/s^2"),
            };
            push_line(out, &axis(t, [1, 0, 0], label, unit));
            push_line(out, &axis(13, [0, 1, 0], "Force", "N"));
        }
        None => {
            push_line(out, &axis(0, [0, 0, 0], "Coherence", "NONE"));
            push_line(out, &axis(0, [0, 0, 0], "NONE", "NONE"));
        }
    }
    push_line(out, &axis(0, [0, 0, 0], "NONE", "NONE"));
    // Record 12: per line [abscissa,] ordinate(s).
    let mut numbers: Vec<f64> = Vec::with_capacity(n * per);
    for k in 0..n {
        if even.is_none() {
            numbers.push(f[k]);
        }
        if complex {
            numbers.push(d.complex[k].re);
            numbers.push(d.complex[k].im);
        } else {
            numbers.push(d.real[k]);
        }
    }
    if binary {
        for v in &numbers {
            out.extend_from_slice(&v.to_le_bytes());
        }
    } else {
        // Even: 4E20.12. Uneven: E13.5 abscissa, then E20.12 ordinates;
        // one point per line (complex) or two (real).
        let mut line = String::with_capacity(81);
        if even.is_some() {
            for chunk in numbers.chunks(4) {
                line.clear();
                for &v in chunk {
                    numfmt::push_fortran_e(&mut line, v, 20, 12);
                }
                push_line(out, &line);
            }
        } else {
            let points_per_line = if complex { 1 } else { 2 };
            for chunk in numbers.chunks(per * points_per_line) {
                line.clear();
                for (i, &v) in chunk.iter().enumerate() {
                    if i % per == 0 {
                        numfmt::push_fortran_e(&mut line, v, 13, 5);
                    } else {
                        numfmt::push_fortran_e(&mut line, v, 20, 12);
                    }
                }
                push_line(out, &line);
            }
        }
    }
    push_line(out, "    -1");
}
