//! State-space realization files: a discrete realization as JSON, for
//! identifying modal parameters and M, K, R from a published realization
//! (the paper's eq. 31-34) instead of records.
//!
//! The file is an object with `dt` (or `dt_s`, the sample interval in
//! seconds) and `A`, `B`, `C`, `D` as arrays of rows.

use std::path::Path;

use nalgebra::DMatrix;

use crate::error::RecordError;

/// Default names of a realization's outputs and inputs (`y1`.., `u1`..).
pub type ChannelNames = (Vec<String>, Vec<String>);

fn bad(path: &Path, problem: impl Into<String>) -> RecordError {
    RecordError::Realization {
        path: path.to_path_buf(),
        problem: problem.into(),
    }
}

/// Reads a realization file. Returns the realization and default channel
/// names (outputs, inputs).
pub fn read_realization(path: &Path) -> Result<(ident::StateSpace, ChannelNames), RecordError> {
    let bytes = crate::format::read_bytes(path)?;
    let text = String::from_utf8(bytes).map_err(|_| bad(path, "not UTF-8 text"))?;
    let value: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| bad(path, format!("not valid JSON: {e}")))?;
    let obj = value
        .as_object()
        .ok_or_else(|| bad(path, "expected a JSON object with dt, A, B, C, D"))?;
    let field = |name: &str| -> Result<&serde_json::Value, RecordError> {
        obj.get(name)
            .ok_or_else(|| bad(path, format!("missing field `{name}`")))
    };
    let dt = match (obj.get("dt"), obj.get("dt_s")) {
        (Some(v), _) | (None, Some(v)) => v.as_f64(),
        (None, None) => {
            return Err(bad(path, "missing field `dt` (sample interval in seconds)"));
        }
    }
    .filter(|d| d.is_finite() && *d > 0.0)
    .ok_or_else(|| bad(path, "`dt` must be a positive number of seconds"))?;
    let a = json_matrix(path, "A", field("A")?)?;
    let n = a.nrows();
    if a.ncols() != n || n == 0 {
        return Err(bad(
            path,
            format!(
                "`A` must be square and non-empty, got {}x{}",
                a.nrows(),
                a.ncols()
            ),
        ));
    }
    let b = json_matrix(path, "B", field("B")?)?;
    let c = json_matrix(path, "C", field("C")?)?;
    let d = json_matrix(path, "D", field("D")?)?;
    if b.nrows() != n {
        return Err(bad(
            path,
            format!("`B` must have {n} rows (A is {n}x{n}), got {}", b.nrows()),
        ));
    }
    if c.ncols() != n {
        return Err(bad(
            path,
            format!(
                "`C` must have {n} columns (A is {n}x{n}), got {}",
                c.ncols()
            ),
        ));
    }
    if d.nrows() != c.nrows() || d.ncols() != b.ncols() {
        return Err(bad(
            path,
            format!(
                "`D` must be {}x{} (outputs of C x inputs of B), got {}x{}",
                c.nrows(),
                b.ncols(),
                d.nrows(),
                d.ncols()
            ),
        ));
    }
    let outputs = (0..c.nrows()).map(|i| format!("y{}", i + 1)).collect();
    let inputs = (0..b.ncols()).map(|i| format!("u{}", i + 1)).collect();
    Ok((ident::StateSpace::new(a, b, c, d, dt), (outputs, inputs)))
}

fn json_matrix(
    path: &Path,
    name: &str,
    v: &serde_json::Value,
) -> Result<DMatrix<f64>, RecordError> {
    let rows = v
        .as_array()
        .ok_or_else(|| bad(path, format!("`{name}` must be an array of rows")))?;
    let mut data: Vec<Vec<f64>> = Vec::with_capacity(rows.len());
    for (i, row) in rows.iter().enumerate() {
        let row = row
            .as_array()
            .ok_or_else(|| bad(path, format!("`{name}[{i}]` must be an array of numbers")))?;
        let vals: Vec<f64> = row
            .iter()
            .enumerate()
            .map(|(j, x)| {
                x.as_f64()
                    .filter(|v| v.is_finite())
                    .ok_or_else(|| bad(path, format!("`{name}[{i}][{j}]` is not a finite number")))
            })
            .collect::<Result<_, _>>()?;
        if let Some(first) = data.first()
            && first.len() != vals.len()
        {
            return Err(bad(
                path,
                format!(
                    "`{name}[{i}]` has {} entries, row 0 has {}",
                    vals.len(),
                    first.len()
                ),
            ));
        }
        data.push(vals);
    }
    let ncols = data.first().map_or(0, Vec::len);
    Ok(DMatrix::from_fn(data.len(), ncols, |i, j| data[i][j]))
}
