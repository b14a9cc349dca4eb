//! Collating the pairs of several FRF files into one FRF matrix.

use std::path::{Path, PathBuf};

use ident::linalg::C64;
use ident::{CollocatedPair, Frf, FrfQuantity};
use nalgebra::DMatrix;

use super::{FrfFile, FrfPoint, grid_mismatch};
use crate::error::RecordError;

/// How to collate FRF files ([`assemble`]).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct AssembleOptions {
    /// Convert every pair to this quantity: line `k` is multiplied by
    /// `(i 2 pi f_k)^(target - own)` (derivative orders 0 receptance, 1
    /// mobility, 2 accelerance); dividing makes a 0 Hz line 0, as
    /// [`Frf::to_quantity`] does. `None`: every pair must already have the
    /// same quantity, and mixed quantities are refused.
    pub quantity: Option<FrfQuantity>,
    /// Collocated pairs as `(response name, reference name)`, overriding
    /// the detection from nodes and directions. Empty: detected.
    pub collocated: Vec<(String, String)>,
}

/// FRF files collated into one matrix.
#[derive(Debug, Clone, PartialEq)]
pub struct FrfSet {
    /// The FRFs: `frf.values[k][(i, j)]` is response `i` over reference
    /// `j`; `outputs` and `references` are the points' names. Coherence is
    /// present only if every pair has one; averages if a pair states them
    /// (all that do agree).
    pub frf: Frf,
    /// The response point of each output row (order of first appearance,
    /// file by file).
    pub responses: Vec<FrfPoint>,
    /// The reference point of each input column (order of first
    /// appearance).
    pub references: Vec<FrfPoint>,
    /// The collocated (driving-point) pairs: response node and direction
    /// equal to the reference's (both known), or as given in
    /// [`AssembleOptions::collocated`]. Possibly empty; ordered by
    /// reference.
    pub collocated: Vec<CollocatedPair>,
    /// Time constant (s) of the exponential window the FRFs were estimated
    /// with, when every pair states the same one (see
    /// [`FrfPair::exponential_tau_s`](super::FrfPair::exponential_tau_s)).
    pub exponential_tau_s: Option<f64>,
}

/// Why FRF files do not make one FRF matrix. Pairs are described as
/// `file (dataset 3)` or `file (columns 2-3)`.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum FrfSetProblem {
    /// No file, or files without FRFs.
    #[error("no FRF to assemble")]
    Empty,
    /// Two files on different frequency grids (beyond
    /// [`FREQUENCY_REL_TOL`](super::FREQUENCY_REL_TOL)).
    #[error("{} and {} have different frequency grids: {what}", first.display(), other.display())]
    Grid {
        /// The first file, the reference.
        first: PathBuf,
        /// The file that differs.
        other: PathBuf,
        /// How (line counts, or the first line that differs with both
        /// frequencies).
        what: String,
    },
    /// Pairs of different quantities and no target quantity given.
    #[error(
        "{first} is {first_quantity} but {other} is {other_quantity}; give AssembleOptions::quantity to convert them to one"
    )]
    MixedQuantity {
        /// The first pair.
        first: String,
        /// Its quantity.
        first_quantity: FrfQuantity,
        /// The pair that differs.
        other: String,
        /// Its quantity.
        other_quantity: FrfQuantity,
    },
    /// Pairs estimated with different exponential windows (or one with
    /// and one without).
    #[error(
        "{first} was estimated with {first_tau} but {other} with {other_tau}: FRFs of different exponential windows have different damping and cannot be identified together"
    )]
    ExponentialWindow {
        /// The first pair.
        first: String,
        /// Its window, as text.
        first_tau: String,
        /// The pair that differs.
        other: String,
        /// Its window.
        other_tau: String,
    },
    /// Pairs estimated with different numbers of averages.
    #[error("{first} has {first_averages} averages but {other} has {other_averages}")]
    Averages {
        /// The first pair stating averages.
        first: String,
        /// Its averages.
        first_averages: usize,
        /// The pair that differs.
        other: String,
        /// Its averages.
        other_averages: usize,
    },
    /// The same response and reference twice.
    #[error("response {response} over reference {reference} is given twice: {first} and {second}")]
    DuplicatePair {
        /// The response point.
        response: String,
        /// The reference point.
        reference: String,
        /// Where first.
        first: String,
        /// Where again.
        second: String,
    },
    /// A response/reference combination that no file has.
    #[error(
        "no FRF of response {response} over reference {reference} in {}; every response needs an FRF over every reference",
        files.iter().map(|f| f.display().to_string()).collect::<Vec<_>>().join(", ")
    )]
    MissingPair {
        /// The response point.
        response: String,
        /// The reference point.
        reference: String,
        /// The files searched.
        files: Vec<PathBuf>,
    },
    /// Two different points with one name (the FRF's outputs and references
    /// are named).
    #[error("two different {role} points are named '{name}': {first} and {second}")]
    SameName {
        /// `response` or `reference`.
        role: &'static str,
        /// The name.
        name: String,
        /// The first point (with node and direction).
        first: String,
        /// The other point.
        second: String,
    },
    /// A collocated pair given in the options that names no response or
    /// reference.
    #[error("collocated pair {response}/{reference}: no {missing} of that name; {available}")]
    CollocatedNotFound {
        /// The response name given.
        response: String,
        /// The reference name given.
        reference: String,
        /// `response` or `reference`.
        missing: &'static str,
        /// The names there are.
        available: String,
    },
    /// The assembled FRF fails its own checks (a value out of range).
    #[error("{0}")]
    Invalid(String),
}

fn describe(path: &Path, source: &str) -> String {
    if source.is_empty() {
        path.display().to_string()
    } else {
        format!("{} ({source})", path.display())
    }
}

fn err(problem: FrfSetProblem) -> RecordError {
    RecordError::FrfSet {
        problem: Box::new(problem),
    }
}

/// Index of `p` among `points` (same place), added if new; refuses a new
/// point whose name an existing one has.
fn index_of(
    points: &mut Vec<FrfPoint>,
    p: &FrfPoint,
    role: &'static str,
) -> Result<usize, RecordError> {
    if let Some(i) = points.iter().position(|q| q.same_point(p)) {
        return Ok(i);
    }
    if let Some(q) = points.iter().find(|q| q.name == p.name) {
        return Err(err(FrfSetProblem::SameName {
            role,
            name: p.name.clone(),
            first: q.to_string(),
            second: p.to_string(),
        }));
    }
    points.push(p.clone());
    Ok(points.len() - 1)
}

/// Collates the pairs of `files` into one FRF matrix: outputs are the
/// distinct response points, references the distinct reference points
/// (identified by node and direction when both are known, else by name;
/// see [`FrfPoint::same_point`]). Refuses, naming the files and pairs:
/// different frequency grids, mixed quantities (unless
/// [`AssembleOptions::quantity`] converts them), different averages, a
/// pair given twice, a response/reference combination missing, two points
/// with one name. The grid is the first file's.
pub fn assemble(files: &[FrfFile], opts: &AssembleOptions) -> Result<FrfSet, RecordError> {
    let Some(first_file) = files.iter().find(|f| !f.pairs.is_empty()) else {
        return Err(err(FrfSetProblem::Empty));
    };
    let grid = &first_file.frequency_hz;
    for f in files {
        if let Some((k, a, b)) = grid_mismatch(&f.frequency_hz, grid) {
            let what = match (a, b) {
                (Some(a), Some(b)) => {
                    format!("line {} is {a} Hz in one, {b} Hz in the other", k + 1)
                }
                _ => format!("{} lines against {}", f.frequency_hz.len(), grid.len()),
            };
            return Err(err(FrfSetProblem::Grid {
                first: first_file.path.clone(),
                other: f.path.clone(),
                what,
            }));
        }
    }
    let all = || {
        files
            .iter()
            .flat_map(|f| f.pairs.iter().map(move |p| (f.path.as_path(), p)))
    };
    let (first_path, first_pair) = all().next().expect("a file with pairs");
    let target = opts.quantity.unwrap_or(first_pair.quantity);
    let mut averages: Option<(usize, String)> = None;
    let mut responses: Vec<FrfPoint> = Vec::new();
    let mut references: Vec<FrfPoint> = Vec::new();
    let mut slots: Vec<(usize, usize, &Path, &super::FrfPair)> = Vec::new();
    for (path, pair) in all() {
        if opts.quantity.is_none() && pair.quantity != target {
            return Err(err(FrfSetProblem::MixedQuantity {
                first: describe(first_path, &first_pair.source),
                first_quantity: target,
                other: describe(path, &pair.source),
                other_quantity: pair.quantity,
            }));
        }
        if let Some(a) = pair.averages {
            match &averages {
                None => averages = Some((a, describe(path, &pair.source))),
                Some((b, first)) if *b != a => {
                    return Err(err(FrfSetProblem::Averages {
                        first: first.clone(),
                        first_averages: *b,
                        other: describe(path, &pair.source),
                        other_averages: a,
                    }));
                }
                Some(_) => {}
            }
        }
        if pair.exponential_tau_s != first_pair.exponential_tau_s {
            let text = |t: Option<f64>| {
                t.map_or("no exponential window".to_string(), |t| {
                    format!("an exponential window of tau = {t} s")
                })
            };
            return Err(err(FrfSetProblem::ExponentialWindow {
                first: describe(first_path, &first_pair.source),
                first_tau: text(first_pair.exponential_tau_s),
                other: describe(path, &pair.source),
                other_tau: text(pair.exponential_tau_s),
            }));
        }
        let i = index_of(&mut responses, &pair.response, "response")?;
        let j = index_of(&mut references, &pair.reference, "reference")?;
        if let Some((_, _, p0, q0)) = slots.iter().find(|s| s.0 == i && s.1 == j) {
            return Err(err(FrfSetProblem::DuplicatePair {
                response: pair.response.to_string(),
                reference: pair.reference.to_string(),
                first: describe(p0, &q0.source),
                second: describe(path, &pair.source),
            }));
        }
        slots.push((i, j, path, pair));
    }
    let (m, r) = (responses.len(), references.len());
    for j in 0..r {
        for i in 0..m {
            if !slots.iter().any(|s| s.0 == i && s.1 == j) {
                return Err(err(FrfSetProblem::MissingPair {
                    response: responses[i].to_string(),
                    reference: references[j].to_string(),
                    files: files.iter().map(|f| f.path.clone()).collect(),
                }));
            }
        }
    }
    let nf = grid.len();
    let mut values = vec![DMatrix::<C64>::zeros(m, r); nf];
    let with_coherence = slots.iter().all(|s| s.3.coherence.is_some());
    let mut coherence = with_coherence.then(|| vec![DMatrix::<f64>::zeros(m, r); nf]);
    for &(i, j, _, pair) in &slots {
        let power = target.derivative_order() - pair.quantity.derivative_order();
        for (k, &f) in grid.iter().enumerate() {
            let factor = if power == 0 {
                C64::new(1.0, 0.0)
            } else if power < 0 && f == 0.0 {
                C64::new(0.0, 0.0)
            } else {
                C64::new(0.0, 2.0 * std::f64::consts::PI * f).powi(power)
            };
            values[k][(i, j)] = pair.values[k] * factor;
            if let (Some(c), Some(g)) = (coherence.as_mut(), pair.coherence.as_ref()) {
                c[k][(i, j)] = g[k];
            }
        }
    }
    let frf = Frf {
        frequency_hz: grid.clone(),
        values,
        quantity: target,
        coherence,
        averages: averages.map(|(a, _)| a),
        outputs: responses.iter().map(|p| p.name.clone()).collect(),
        references: references.iter().map(|p| p.name.clone()).collect(),
    };
    frf.validate()
        .map_err(|e| err(FrfSetProblem::Invalid(e.to_string())))?;
    let collocated = if opts.collocated.is_empty() {
        let mut found = Vec::new();
        for (j, s) in references.iter().enumerate() {
            for (i, p) in responses.iter().enumerate() {
                if p.node_dir().is_some() && p.node_dir() == s.node_dir() {
                    found.push(CollocatedPair {
                        output: i,
                        input: j,
                    });
                }
            }
        }
        found
    } else {
        let names = |v: &[FrfPoint]| {
            v.iter()
                .map(|p| p.name.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        };
        opts.collocated
            .iter()
            .map(|(resp, reference)| {
                let i = responses.iter().position(|p| &p.name == resp);
                let j = references.iter().position(|p| &p.name == reference);
                match (i, j) {
                    (Some(output), Some(input)) => Ok(CollocatedPair { output, input }),
                    (None, _) => Err(err(FrfSetProblem::CollocatedNotFound {
                        response: resp.clone(),
                        reference: reference.clone(),
                        missing: "response",
                        available: format!("responses: {}", names(&responses)),
                    })),
                    (_, None) => Err(err(FrfSetProblem::CollocatedNotFound {
                        response: resp.clone(),
                        reference: reference.clone(),
                        missing: "reference",
                        available: format!("references: {}", names(&references)),
                    })),
                }
            })
            .collect::<Result<Vec<_>, _>>()?
    };
    Ok(FrfSet {
        frf,
        responses,
        references,
        collocated,
        exponential_tau_s: first_pair.exponential_tau_s,
    })
}
