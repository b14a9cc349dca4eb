//! Physical parametrizations of M, K and damping: every parameter scales one fixed symmetric
//! basis matrix of one of the three matrices, so the matrices are linear in the parameters.

use super::RefineError;
use crate::linalg;
use crate::mkr::MatrixKind;
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};
use std::fmt;

/// End point of a spring or dashpot: the ground or a degree of freedom (0-based, output `i`
/// is DOF `i`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Node {
    /// The fixed base.
    Ground,
    /// Degree of freedom (floor) `i`, 0-based.
    Dof(usize),
}

impl fmt::Display for Node {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Node::Ground => f.write_str("ground"),
            Node::Dof(i) => write!(f, "{i}"),
        }
    }
}

/// A dashpot between two nodes, in addition to the storey dashpots of
/// [`Parametrization::ShearFrame`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Dashpot {
    /// One end.
    pub a: Node,
    /// The other end.
    pub b: Node,
}

impl Dashpot {
    /// A dashpot between `a` and `b`.
    pub fn between(a: Node, b: Node) -> Self {
        Self { a, b }
    }
}

/// Which physical parameters are estimated.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum Parametrization {
    /// Symmetric M, K and damping: the `n (n + 1) / 2` upper-triangle entries of each
    /// (3 n (n + 1) / 2 parameters). Parameters are the entries themselves.
    #[default]
    Full,
    /// Shear frame: one mass per floor (diagonal M), one stiffness and one dashpot per
    /// storey (storey `i` joins DOF `i - 1`, or the ground for `i = 0`, to DOF `i`), plus
    /// the extra `dashpots`. Mass-proportional (Rayleigh) damping needs ground dashpots at
    /// DOFs `1..n` (DOF 0's ground dashpot is storey 0's).
    ShearFrame {
        /// Extra dashpots between node pairs.
        dashpots: Vec<Dashpot>,
    },
}

/// One physical parameter: `matrix += value * basis`.
#[derive(Debug, Clone, PartialEq)]
pub struct Parameter {
    /// The matrix it enters.
    pub matrix: MatrixKind,
    /// Short name: `M[0,1]` (Full), `m0`, `k1`, `c1`, `c(ground-2)` (ShearFrame).
    pub label: String,
    /// Symmetric n x n basis matrix.
    pub basis: DMatrix<f64>,
}

/// `d d^T` for the element joining `a` and `b`.
fn element(n: usize, a: Node, b: Node) -> DMatrix<f64> {
    let mut d = DVector::<f64>::zeros(n);
    if let Node::Dof(i) = a {
        d[i] += 1.0;
    }
    if let Node::Dof(j) = b {
        d[j] -= 1.0;
    }
    &d * d.transpose()
}

fn storey_nodes(i: usize) -> (Node, Node) {
    let below = if i == 0 {
        Node::Ground
    } else {
        Node::Dof(i - 1)
    };
    (below, Node::Dof(i))
}

impl Parametrization {
    /// Shear frame with storey dashpots only.
    pub fn shear_frame() -> Self {
        Parametrization::ShearFrame {
            dashpots: Vec::new(),
        }
    }

    /// The parameters for `dofs` degrees of freedom, in the order M, K, damping.
    pub fn parameters(&self, dofs: usize) -> Result<Vec<Parameter>, RefineError> {
        let n = dofs;
        if n == 0 {
            return Err(RefineError::InvalidParams {
                reason: "the model needs at least one degree of freedom".into(),
            });
        }
        let mut out = Vec::new();
        match self {
            Parametrization::Full => {
                for (matrix, name) in [
                    (MatrixKind::Mass, "M"),
                    (MatrixKind::Stiffness, "K"),
                    (MatrixKind::Damping, "R"),
                ] {
                    for i in 0..n {
                        for j in i..n {
                            let mut basis = DMatrix::zeros(n, n);
                            basis[(i, j)] = 1.0;
                            basis[(j, i)] = 1.0;
                            out.push(Parameter {
                                matrix,
                                label: format!("{name}[{i},{j}]"),
                                basis,
                            });
                        }
                    }
                }
            }
            Parametrization::ShearFrame { dashpots } => {
                for i in 0..n {
                    let mut basis = DMatrix::zeros(n, n);
                    basis[(i, i)] = 1.0;
                    out.push(Parameter {
                        matrix: MatrixKind::Mass,
                        label: format!("m{i}"),
                        basis,
                    });
                }
                for (matrix, name) in [(MatrixKind::Stiffness, "k"), (MatrixKind::Damping, "c")] {
                    for i in 0..n {
                        let (a, b) = storey_nodes(i);
                        out.push(Parameter {
                            matrix,
                            label: format!("{name}{i}"),
                            basis: element(n, a, b),
                        });
                    }
                }
                for (index, dp) in dashpots.iter().enumerate() {
                    for node in [dp.a, dp.b] {
                        if let Node::Dof(i) = node
                            && i >= n
                        {
                            return Err(RefineError::InvalidParams {
                                reason: format!(
                                    "dashpot {index} ends at DOF {i}, the model has {n} DOFs"
                                ),
                            });
                        }
                    }
                    if dp.a == dp.b {
                        return Err(RefineError::InvalidParams {
                            reason: format!("dashpot {index} joins node {} to itself", dp.a),
                        });
                    }
                    let basis = element(n, dp.a, dp.b);
                    if out
                        .iter()
                        .any(|p| p.matrix == MatrixKind::Damping && p.basis == basis)
                    {
                        return Err(RefineError::InvalidParams {
                            reason: format!(
                                "dashpot {index} ({}-{}) duplicates a storey or another dashpot",
                                dp.a, dp.b
                            ),
                        });
                    }
                    out.push(Parameter {
                        matrix: MatrixKind::Damping,
                        label: format!("c({}-{})", dp.a, dp.b),
                        basis,
                    });
                }
            }
        }
        Ok(out)
    }
}

/// M, K and damping of parameter vector `theta`.
pub(crate) fn matrices(
    params: &[Parameter],
    theta: &DVector<f64>,
    n: usize,
) -> (DMatrix<f64>, DMatrix<f64>, DMatrix<f64>) {
    assert_eq!(params.len(), theta.len(), "one value per parameter");
    let mut mass = DMatrix::zeros(n, n);
    let mut stiffness = DMatrix::zeros(n, n);
    let mut damping = DMatrix::zeros(n, n);
    for (p, &v) in params.iter().zip(theta.iter()) {
        let target = match p.matrix {
            MatrixKind::Mass => &mut mass,
            MatrixKind::Stiffness => &mut stiffness,
            MatrixKind::Damping => &mut damping,
        };
        *target += &p.basis * v;
    }
    (mass, stiffness, damping)
}

/// Least-squares projection of given matrices on the parametrization (exact when they
/// are representable). Returns the parameters and, per matrix kind, the relative Frobenius
/// residual of the projection.
pub(crate) fn project(
    params: &[Parameter],
    mass: &DMatrix<f64>,
    stiffness: &DMatrix<f64>,
    damping: &DMatrix<f64>,
) -> (DVector<f64>, [f64; 3]) {
    let n = mass.nrows();
    let mut theta = DVector::zeros(params.len());
    let mut residuals = [0.0; 3];
    for (slot, (kind, target)) in [
        (MatrixKind::Mass, mass),
        (MatrixKind::Stiffness, stiffness),
        (MatrixKind::Damping, damping),
    ]
    .into_iter()
    .enumerate()
    {
        let idx: Vec<usize> = (0..params.len())
            .filter(|&p| params[p].matrix == kind)
            .collect();
        if idx.is_empty() {
            continue;
        }
        let basis = DMatrix::from_fn(n * n, idx.len(), |row, col| {
            params[idx[col]].basis[(row % n, row / n)]
        });
        let rhs = DMatrix::from_column_slice(n * n, 1, target.as_slice());
        let fitted = match linalg::thin_svd(&basis) {
            Ok(svd) => linalg::lstsq_truncated(&svd, &rhs, 1e-12).0,
            Err(_) => DMatrix::zeros(idx.len(), 1),
        };
        for (col, &p) in idx.iter().enumerate() {
            theta[p] = fitted[(col, 0)];
        }
        let scale = target.norm();
        residuals[slot] = if scale > 0.0 {
            (&basis * &fitted - rhs).norm() / scale
        } else {
            0.0
        };
    }
    (theta, residuals)
}
