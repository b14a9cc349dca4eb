//! Identified modes as UFF dataset 55 (data at nodes), complex modes
//! (analysis type 3, complex eigenvalue first order): one dataset per mode.
//!
//! | record | content | written |
//! |---|---|---|
//! | 1-4 | ID lines | description, `NONE` |
//! | 5 | ID line | `frameid mode=r f_hz=… zeta=…` (exact values) |
//! | 6 | model, analysis type, data characteristic, specific data type, data type, values per node (6I10) | 1, 3, 2 (3-DOF translation), 8 (displacement), 5 (complex), 3 |
//! | 7 | 2, 6, load case, mode number (4I10) | |
//! | 8 | eigenvalue, modal A, modal B, real and imaginary parts (6E13.5) | `lambda = -zeta w + i w sqrt(1 - zeta^2)`, `w = 2 pi f`; `A`; `B = -lambda A` |
//! | 9, 10 | node (I10); X, Y, Z components, real and imaginary parts (6E13.5) | per node |
//!
//! A point's direction puts its component into X (±1), Y (±2) or Z (±3); a
//! negative direction negates it.

use std::path::Path;

use ident::linalg::C64;

use super::{FrfPoint, default_name};
use crate::error::{Location, Problem, RecordError};
use crate::numfmt::{self, NumError};
use crate::uff::{self, TAG};
use crate::write::write_atomically;

/// One identified mode, for [`write_uff55`].
#[derive(Debug, Clone, PartialEq)]
pub struct ExportMode {
    /// Undamped natural frequency `w / (2 pi)`, Hz (finite, positive).
    pub frequency_hz: f64,
    /// Viscous damping ratio, in `[0, 1)`.
    pub damping_ratio: f64,
    /// Complex mode shape, one component per point of
    /// [`ModeShapeExport::points`] (any scaling; written as given).
    pub shape: Vec<C64>,
    /// Modal A of the first-order formulation (`A_r = psi_r^T [damping M;
    /// M 0] psi_r`; [`ExportMode::modal_a_from_mass`] gives it for a real
    /// mode of known modal mass). `None` writes 0 (unknown).
    pub modal_a: Option<C64>,
}

impl ExportMode {
    /// The pole `lambda = -zeta w + i w sqrt(1 - zeta^2)`, rad/s.
    pub fn eigenvalue(&self) -> C64 {
        let w = 2.0 * std::f64::consts::PI * self.frequency_hz;
        let z = self.damping_ratio;
        C64::new(-z * w, w * (1.0 - z * z).sqrt())
    }

    /// Modal A of a real (proportionally damped) mode of modal mass
    /// `modal_mass_kg = phi^T M phi` for the shape as written: `2 i w_d m`,
    /// `w_d = w sqrt(1 - zeta^2)`.
    pub fn modal_a_from_mass(frequency_hz: f64, damping_ratio: f64, modal_mass_kg: f64) -> C64 {
        let wd = 2.0
            * std::f64::consts::PI
            * frequency_hz
            * (1.0 - damping_ratio * damping_ratio).sqrt();
        C64::new(0.0, 2.0 * wd * modal_mass_kg)
    }
}

/// Identified modes at response points, for UFF dataset 55.
#[derive(Debug, Clone, PartialEq)]
pub struct ModeShapeExport {
    /// The response points; each needs a node and a translational
    /// direction (±1..3), and no two may share both.
    pub points: Vec<FrfPoint>,
    /// The modes (ascending frequency by convention; written in this
    /// order, numbered from 1).
    pub modes: Vec<ExportMode>,
}

fn e13(out: &mut String, x: f64) {
    numfmt::push_fortran_e(out, x, 13, 5);
}

/// The bytes of `modes` as UFF dataset 55 (one complex-mode dataset per
/// mode); refuses (naming the point or mode) points without node or
/// translational direction, two points at one node and direction, shapes of
/// the wrong length, frequencies that are not positive, damping ratios
/// outside `[0, 1)` and values that are not finite.
pub fn encode_uff55(modes: &ModeShapeExport) -> Result<Vec<u8>, String> {
    // Nodes in order of first appearance; per point its node slot and
    // component (0..3) and sign.
    let mut nodes: Vec<i64> = Vec::new();
    let mut slots = Vec::with_capacity(modes.points.len());
    for (i, p) in modes.points.iter().enumerate() {
        let (Some(node), Some(dir)) = (p.node, p.direction) else {
            return Err(format!(
                "point #{} ({p}) has no node and direction; UFF 55 stores values at nodes",
                i + 1
            ));
        };
        if !(1..=3).contains(&dir.abs()) {
            return Err(format!(
                "point #{} ({p}) direction {dir} is not a translation (±1..3)",
                i + 1
            ));
        }
        if !(-999_999_999..=9_999_999_999).contains(&node) {
            return Err(format!(
                "point #{} node {node} does not fit in 10 columns",
                i + 1
            ));
        }
        let slot = match nodes.iter().position(|&n| n == node) {
            Some(s) => s,
            None => {
                nodes.push(node);
                nodes.len() - 1
            }
        };
        let comp = (dir.unsigned_abs() - 1) as usize;
        if let Some(j) = slots.iter().position(|&(s, c, _)| s == slot && c == comp) {
            return Err(format!(
                "points #{} and #{} are both at node {node} direction {}",
                j + 1,
                i + 1,
                ["X", "Y", "Z"][comp]
            ));
        }
        slots.push((slot, comp, f64::from(dir.signum())));
    }
    let mut out = String::new();
    for (r, mode) in modes.modes.iter().enumerate() {
        let what = format!("mode {}", r + 1);
        if !(mode.frequency_hz.is_finite() && mode.frequency_hz > 0.0) {
            return Err(format!(
                "{what}: frequency {} Hz is not positive",
                mode.frequency_hz
            ));
        }
        if !(0.0..1.0).contains(&mode.damping_ratio) {
            return Err(format!(
                "{what}: damping ratio {} is outside [0, 1)",
                mode.damping_ratio
            ));
        }
        if mode.shape.len() != modes.points.len() {
            return Err(format!(
                "{what}: {} shape components for {} points",
                mode.shape.len(),
                modes.points.len()
            ));
        }
        let a = mode.modal_a.unwrap_or_default();
        if mode
            .shape
            .iter()
            .chain([&a])
            .any(|z| !(z.re.is_finite() && z.im.is_finite()))
        {
            return Err(format!(
                "{what}: a shape component or modal A is not finite"
            ));
        }
        let lambda = mode.eigenvalue();
        let b = -lambda * a;
        let mut values = vec![[C64::default(); 3]; nodes.len()];
        for (&(slot, comp, sign), z) in slots.iter().zip(&mode.shape) {
            values[slot][comp] = z * sign;
        }
        let line = |out: &mut String, s: &str| {
            out.push_str(&format!("{s:<80}").replace('\n', " "));
            out.push('\n');
        };
        out.push_str("    -1\n    55\n");
        line(&mut out, "frameid mode shapes");
        line(&mut out, "NONE");
        line(&mut out, "NONE");
        line(&mut out, "NONE");
        line(
            &mut out,
            &format!(
                "{TAG} mode={} f_hz={} zeta={}",
                r + 1,
                numfmt::shortest(mode.frequency_hz),
                numfmt::shortest(mode.damping_ratio)
            ),
        );
        out.push_str(&format!(
            "{:>10}{:>10}{:>10}{:>10}{:>10}{:>10}\n",
            1, 3, 2, 8, 5, 3
        ));
        out.push_str(&format!("{:>10}{:>10}{:>10}{:>10}\n", 2, 6, 1, r + 1));
        for x in [lambda.re, lambda.im, a.re, a.im, b.re, b.im] {
            e13(&mut out, x);
        }
        out.push('\n');
        for (node, v) in nodes.iter().zip(&values) {
            out.push_str(&format!("{node:>10}\n"));
            for z in v {
                e13(&mut out, z.re);
                e13(&mut out, z.im);
            }
            out.push('\n');
        }
        out.push_str("    -1\n");
    }
    Ok(out.into_bytes())
}

/// Writes `modes` as UFF dataset 55 to `path`, atomically (see
/// [`encode_uff55`] for what is refused; the error names `path`). Values
/// are E13.5 (6 significant digits) as the format prescribes; the exact
/// frequency and damping ratio are added to ID line 5.
pub fn write_uff55(path: &Path, modes: &ModeShapeExport) -> Result<(), RecordError> {
    let bytes = encode_uff55(modes).map_err(|reason| RecordError::InvalidRecord {
        path: path.to_path_buf(),
        reason,
    })?;
    write_atomically(path, &bytes)
}

/// Reads the complex modes (analysis type 3) of a UFF file (see
/// [`parse_uff55`]).
pub fn read_uff55(path: &Path) -> Result<ModeShapeExport, RecordError> {
    let bytes = crate::format::read_bytes(path)?;
    parse_uff55(&bytes, path)
}

/// Parses the datasets 55 of complex modes (analysis type 3, 3 complex
/// values per node) held in memory; other datasets are skipped. The points
/// are the node/direction components (X, Y, Z = +1, +2, +3) that are
/// non-zero in some mode, named `node:direction`, in node order of the
/// file; frequency and damping ratio come from the eigenvalue
/// (`f = |lambda| / 2 pi`, `zeta = -Re lambda / |lambda|`), or from
/// frameid's exact values in ID line 5 when they agree with it.
pub fn parse_uff55(bytes: &[u8], path: &Path) -> Result<ModeShapeExport, RecordError> {
    struct Raw {
        frequency_hz: f64,
        damping_ratio: f64,
        modal_a: C64,
        nodes: Vec<(i64, [C64; 3])>,
    }
    let mut raws: Vec<Raw> = Vec::new();
    let (count, others) = uff::scan_datasets(bytes, path, |ctx, cur, number, hn, bin| {
        if number != 55 || bin.is_some() {
            return Ok(false);
        }
        let mut lines = Vec::new();
        loop {
            match cur.next_line() {
                Some((_, l)) if uff::is_delimiter(l) => break,
                Some(l) => lines.push(l),
                None => {
                    return Err(ctx.truncated(hn, "before the closing '-1' of dataset 55"));
                }
            }
        }
        if lines.len() < 8 {
            return Err(ctx.err(
                ctx.at_line(hn),
                Problem::UffTruncated {
                    missing: format!("dataset 55 has {} of its 8 header records", lines.len()),
                },
            ));
        }
        let numbers = |k: usize, what: &str| -> Result<Vec<f64>, RecordError> {
            let (n, l) = lines[k];
            let t = String::from_utf8_lossy(l);
            uff::data_tokens(&t, &[13])
                .into_iter()
                .enumerate()
                .map(|(i, tok)| {
                    numfmt::parse_fortran(tok).map_err(|e| {
                        let text = tok.to_string();
                        ctx.err(
                            ctx.at(n, format!("{what} value {}", i + 1)),
                            match e {
                                NumError::NonFinite => Problem::NonFinite { text },
                                _ => Problem::NonNumeric { text },
                            },
                        )
                    })
                })
                .collect()
        };
        let rec6 = numbers(5, "record 6")?;
        let (n6, l6) = lines[5];
        if rec6.len() < 6 || rec6[1] != 3.0 || rec6[4] != 5.0 || rec6[5] != 3.0 {
            return Err(ctx.bad_field(
                n6,
                "record 6 (analysis type, data type, values per node)",
                l6,
                "only complex modes are read: analysis type 3, data type 5, 3 values per node",
            ));
        }
        let r8 = numbers(7, "record 8")?;
        if r8.len() < 6 {
            return Err(ctx.bad_field(lines[7].0, "record 8", lines[7].1, "six numbers"));
        }
        let lambda = C64::new(r8[0], r8[1]);
        let w = lambda.norm();
        if w <= 0.0 {
            return Err(ctx.bad_field(
                lines[7].0,
                "record 8 fields 1-2 (eigenvalue)",
                lines[7].1,
                "a non-zero eigenvalue",
            ));
        }
        let (mut f, mut z) = (w / (2.0 * std::f64::consts::PI), -lambda.re / w);
        let id5 = uff::free_text(lines[4].1);
        let tag = |key: &str| {
            id5.strip_prefix(TAG).and_then(|rest| {
                rest.split_ascii_whitespace()
                    .find_map(|t| t.strip_prefix(key)?.strip_prefix('=')?.parse::<f64>().ok())
            })
        };
        if let (Some(tf), Some(tz)) = (tag("f_hz"), tag("zeta"))
            && (tf - f).abs() <= uff::E13_REL * f
            && (tz - z).abs() <= uff::E13_REL
        {
            (f, z) = (tf, tz);
        }
        let mut nodes = Vec::new();
        let mut k = 8;
        while k < lines.len() {
            let (n, l) = lines[k];
            let t = String::from_utf8_lossy(l);
            let node: i64 = t
                .trim()
                .parse()
                .map_err(|_| ctx.bad_field(n, "record 9 (node number)", l, "an integer"))?;
            if k + 1 >= lines.len() {
                return Err(ctx.err(
                    ctx.at_line(n),
                    Problem::UffTruncated {
                        missing: format!("node {node} has no record 10"),
                    },
                ));
            }
            let v = numbers(k + 1, "record 10")?;
            if v.len() != 6 {
                return Err(ctx.bad_field(
                    lines[k + 1].0,
                    "record 10",
                    lines[k + 1].1,
                    "six numbers (X, Y, Z, real and imaginary parts)",
                ));
            }
            nodes.push((
                node,
                [
                    C64::new(v[0], v[1]),
                    C64::new(v[2], v[3]),
                    C64::new(v[4], v[5]),
                ],
            ));
            k += 2;
        }
        raws.push(Raw {
            frequency_hz: f,
            damping_ratio: z,
            modal_a: C64::new(r8[2], r8[3]),
            nodes,
        });
        Ok(true)
    })?;
    if raws.is_empty() {
        return Err(RecordError::Parse {
            path: path.to_path_buf(),
            at: Box::new(Location::default()),
            problem: if count == 0 {
                Problem::EmptyFile
            } else {
                Problem::UffBadField {
                    text: others
                        .iter()
                        .map(u32::to_string)
                        .collect::<Vec<_>>()
                        .join(", "),
                    reason: "no dataset 55 of complex modes among these datasets".into(),
                }
            },
        });
    }
    let mut points: Vec<(i64, usize)> = Vec::new();
    for raw in &raws {
        for (node, v) in &raw.nodes {
            for (c, z) in v.iter().enumerate() {
                if *z != C64::default() && !points.contains(&(*node, c)) {
                    points.push((*node, c));
                }
            }
        }
    }
    let modes = raws
        .iter()
        .map(|raw| ExportMode {
            frequency_hz: raw.frequency_hz,
            damping_ratio: raw.damping_ratio,
            shape: points
                .iter()
                .map(|&(node, c)| {
                    raw.nodes
                        .iter()
                        .find(|(n, _)| *n == node)
                        .map_or(C64::default(), |(_, v)| v[c])
                })
                .collect(),
            modal_a: (raw.modal_a != C64::default()).then_some(raw.modal_a),
        })
        .collect();
    Ok(ModeShapeExport {
        points: points
            .iter()
            .map(|&(node, c)| FrfPoint {
                name: default_name(node, c as i32 + 1),
                node: Some(node),
                direction: Some(c as i32 + 1),
            })
            .collect(),
        modes,
    })
}
