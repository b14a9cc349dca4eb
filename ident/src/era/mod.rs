//! Eigensystem realization algorithm (ERA) and ERA with data correlations (ERA/DC).
//!
//! The block Hankel matrix of the Markov parameters, started at an offset `k0`, is
//!
//! ```text
//! H(k) = [ Y_{k0+1+k}        Y_{k0+2+k}  ...  Y_{k0+beta+k}
//!          ...
//!          Y_{k0+alpha+k}    ...              Y_{k0+alpha+beta-1+k} ]      (alpha m x beta r)
//! ```
//!
//! Plain ERA factors `H(0) = U S V^T`. ERA/DC (Juang, Cooper and Wright 1988) factors the
//! block Hankel matrix of the correlations `R(k) = H(k) H(0)^T`,
//!
//! ```text
//! Hc(k) = [ R(k)        R(k+1)  ...  R(k+zeta)
//!           ...
//!           R(k+xi)     ...          R(k+xi+zeta) ]                         ((xi+1) alpha m square-ish)
//! ```
//!
//! which averages the data over the `beta` columns and shrinks the problem. With the order-n
//! truncation `U_n S_n V_n^T`, `A = S_n^(-1/2) U_n^T Hc(1) V_n S_n^(-1/2)`, the observability
//! matrix `O = U_n S_n^(1/2)` (first `alpha m` rows), `C` its first `m` rows, and the
//! controllability matrix at the offset `A^k0 [B, AB, ...] = O^+ H(0)`; then
//! `B = A^(-k0)` times its first block column, and `D = Y_0`.
//!
//! Starting at an offset skips the first Markov parameters, which for band-limited records
//! carry the analyzer filter's transient and are not those of a finite-order system.
//!
//! # Default Hankel size
//!
//! With `n_ref = max(order or maximum order, 10)`: `alpha = ceil(max(4 n_ref, 40) / m)` block
//! rows (at least 40 and four times the order in rows), `beta = ceil(3 alpha m / r)` block
//! columns (three times as many columns as rows, so ERA/DC averages over many lags), and, if
//! the data do not support that many Markov parameters (the longest record), `beta` shrinks to
//! fit, down to `n_ref / r + 1`.

use crate::linalg::{self, LinalgError, ThinSvd};
use crate::statespace::StateSpace;
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

#[cfg(test)]
mod tests;

/// Which matrix is factored.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Correlation {
    /// Plain ERA: factor `H(0)`.
    None,
    /// ERA/DC: factor the block Hankel matrix of `R(k) = H(k) H(0)^T` with `xi + 1` block
    /// rows and `zeta + 1` block columns.
    Dc {
        /// Block rows of the correlation Hankel matrix minus one (`xi = 0`: one block row).
        xi: usize,
        /// Block columns of the correlation Hankel matrix minus one.
        zeta: usize,
    },
}

/// Model order (state dimension) of the realization.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum ModelOrder {
    /// Use this order.
    Fixed(usize),
    /// Largest gap `ln s_n - ln s_(n+1)` of the Hankel singular values of `H(0)` over the
    /// even orders `n = 2, 4, ..., max`.
    Auto {
        /// Largest order considered (states, at least 2).
        max: usize,
    },
}

impl ModelOrder {
    /// The fixed order or the maximum order.
    pub fn max_order(&self) -> usize {
        match *self {
            ModelOrder::Fixed(n) => n,
            ModelOrder::Auto { max } => max,
        }
    }
}

/// ERA parameters.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct EraParams {
    /// Block rows `alpha` of the Hankel matrix (`None`: default from the data, see module docs).
    pub block_rows: Option<usize>,
    /// Block columns `beta` of the Hankel matrix (`None`: default from the data).
    pub block_cols: Option<usize>,
    /// ERA or ERA/DC.
    pub correlation: Correlation,
    /// Markov offset `k0`: the Hankel matrix starts at `Y_{k0+1}`.
    pub offset: usize,
    /// Model order.
    pub order: ModelOrder,
}

impl Default for EraParams {
    fn default() -> Self {
        Self {
            block_rows: None,
            block_cols: None,
            correlation: Correlation::Dc { xi: 2, zeta: 2 },
            offset: 0,
            order: ModelOrder::Auto { max: 20 },
        }
    }
}

/// Resolved Hankel dimensions.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct HankelShape {
    /// Block rows `alpha`.
    pub block_rows: usize,
    /// Block columns `beta`.
    pub block_cols: usize,
    /// ERA/DC correlation block rows minus one (0 for plain ERA).
    pub xi: usize,
    /// ERA/DC correlation block columns minus one (0 for plain ERA).
    pub zeta: usize,
    /// Markov offset `k0`.
    pub offset: usize,
    /// Whether the correlation (ERA/DC) form is used.
    pub correlated: bool,
}

impl HankelShape {
    /// Number of Markov parameters `Y_0 ..` the realization uses.
    pub fn markov_needed(&self) -> usize {
        self.offset + self.block_rows + self.block_cols + self.xi + self.zeta + 1
    }

    /// Number of Markov terms spanned by `H(0)` (used by the modal singular value).
    pub fn span(&self) -> usize {
        self.block_rows + self.block_cols - 1
    }
}

/// Ways ERA can fail.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum EraError {
    /// Parameters out of range.
    #[error("invalid ERA parameters: {reason}")]
    InvalidParams {
        /// Which parameter is out of range and what it must be.
        reason: String,
    },
    /// Not enough Markov parameters (or data) for the Hankel matrices.
    #[error("ERA needs {required} Markov parameters, {available} are available")]
    TooFewMarkov {
        /// Markov parameters given (`Y_0 ..`, i.e. the samples of the longest record).
        available: usize,
        /// Markov parameters the Hankel matrices need ([`HankelShape::markov_needed`]).
        required: usize,
    },
    /// The requested order exceeds what the Hankel matrix can reveal.
    #[error("order {order} exceeds the largest order {max} the Hankel matrix supports")]
    OrderTooLarge {
        /// The requested model order (states).
        order: usize,
        /// The largest order the factored matrix supports (its smaller dimension).
        max: usize,
    },
    /// The Hankel matrix has fewer nonzero singular values than the order.
    #[error("Hankel matrix has rank {rank}, below the order {order}")]
    RankDeficient {
        /// The requested model order (states).
        order: usize,
        /// Singular values above the numerical rank threshold (or columns kept by the
        /// truncated least squares that recovers the controllability matrix in ERA/DC).
        rank: usize,
    },
    /// `A` is singular, so `B` cannot be recovered at a nonzero Markov offset.
    #[error("the identified A is singular; B cannot be recovered at Markov offset {offset}")]
    SingularStateMatrix {
        /// The Markov offset `k0`: `B` is `A^-k0` times the first block column.
        offset: usize,
    },
    /// A decomposition failed.
    #[error(transparent)]
    Linalg(#[from] LinalgError),
}

impl EraParams {
    /// Sets the model order.
    pub fn order(mut self, order: ModelOrder) -> Self {
        self.order = order;
        self
    }

    /// Sets the Markov offset.
    pub fn offset(mut self, offset: usize) -> Self {
        self.offset = offset;
        self
    }

    /// Sets ERA or ERA/DC.
    pub fn correlation(mut self, correlation: Correlation) -> Self {
        self.correlation = correlation;
        self
    }

    /// Sets the Hankel block rows and columns.
    pub fn blocks(mut self, block_rows: usize, block_cols: usize) -> Self {
        self.block_rows = Some(block_rows);
        self.block_cols = Some(block_cols);
        self
    }

    /// Validates the parameters.
    pub fn check(&self) -> Result<(), EraError> {
        let bad = |reason: String| Err(EraError::InvalidParams { reason });
        match self.order {
            ModelOrder::Fixed(0) => return bad("model order must be at least 1".into()),
            ModelOrder::Auto { max } if max < 2 => {
                return bad("maximum model order must be at least 2".into());
            }
            _ => {}
        }
        if self.block_rows == Some(0) || self.block_cols == Some(0) {
            return bad("Hankel block rows and columns must be at least 1".into());
        }
        Ok(())
    }

    /// Resolves the Hankel dimensions for `m` outputs, `r` inputs and `available` Markov
    /// parameters (for records: the length of the longest record).
    pub fn shape(&self, m: usize, r: usize, available: usize) -> Result<HankelShape, EraError> {
        self.check()?;
        assert!(m > 0 && r > 0, "EraParams::shape: m and r must be positive");
        let n_ref = self.order.max_order().max(10);
        let (xi, zeta, correlated) = match self.correlation {
            Correlation::None => (0, 0, false),
            Correlation::Dc { xi, zeta } => (xi, zeta, true),
        };
        let alpha = self
            .block_rows
            .unwrap_or_else(|| (4 * n_ref).max(40).div_ceil(m));
        let fixed = self.offset + alpha + xi + zeta + 1;
        let beta = match self.block_cols {
            Some(beta) => beta,
            None => {
                let wanted = (3 * alpha * m).div_ceil(r);
                let fits = available.saturating_sub(fixed);
                let least = n_ref / r + 1;
                wanted.min(fits).max(least)
            }
        };
        let shape = HankelShape {
            block_rows: alpha,
            block_cols: beta,
            xi,
            zeta,
            offset: self.offset,
            correlated,
        };
        if shape.markov_needed() > available {
            return Err(EraError::TooFewMarkov {
                available,
                required: shape.markov_needed(),
            });
        }
        Ok(shape)
    }

    /// Factors the Hankel matrices of `markov` (`Y_0 = D, Y_1, ...`), without choosing the
    /// order yet.
    pub fn decompose(&self, markov: &[DMatrix<f64>], dt_s: f64) -> Result<Decomposition, EraError> {
        self.decompose_vectors(markov, dt_s, None, None)
    }

    /// [`EraParams::decompose`] for realizations of order `order` only: the factored matrix's
    /// singular vectors only to `order` when [`linalg::leading_svd`] converges (all of them
    /// otherwise). Its singular values: ERA's (`H(0)`, the Hankel singular values) all;
    /// ERA/DC's correlation Hankel matrix's the first `order + 8` when
    /// [`linalg::leading_svd_certified`] certifies the leading ones (the `H(0)` values
    /// behind the gaps are all computed either way). The realization of that
    /// order agrees with [`EraParams::decompose`]'s to the vectors' accuracy (in the tests
    /// poles within 2e-12, Markov parameters within 1.1e-14 relative); realizations of higher
    /// orders may then be refused ([`EraError::OrderTooLarge`]). For resamples at a known
    /// order (the jackknife).
    pub fn decompose_to_order(
        &self,
        markov: &[DMatrix<f64>],
        dt_s: f64,
        order: usize,
    ) -> Result<Decomposition, EraError> {
        self.decompose_vectors(markov, dt_s, Some(order), None)
    }

    /// [`EraParams::decompose_to_order`] for the Markov parameters of an OKID observer of
    /// `states` states (observer order times outputs): their correlation Hankel matrix
    /// generically has rank `states`, so when `H(0)` has a lower rank the compression to
    /// `H(0)`'s row space (see `compressed_svd_of`) cannot succeed and is not tried. (The
    /// three-storey campaigns' jackknife resamples: `H(0)` of rank 42, 60 states; the
    /// attempt cost about a quarter of their ERA.) When `H(0)` has fewer rows or columns
    /// than `states`, its right singular vectors are not computed either, only its values
    /// (`linalg::right_singular_values`, equal to [`EraParams::decompose_to_order`]'s to
    /// round-off: they only bound the orders realized).
    pub(crate) fn decompose_observer_to_order(
        &self,
        markov: &[DMatrix<f64>],
        dt_s: f64,
        order: usize,
        states: usize,
    ) -> Result<Decomposition, EraError> {
        self.decompose_vectors(markov, dt_s, Some(order), Some(states))
    }

    fn decompose_vectors(
        &self,
        markov: &[DMatrix<f64>],
        dt_s: f64,
        vectors: Option<usize>,
        states: Option<usize>,
    ) -> Result<Decomposition, EraError> {
        // The SVD of a factored matrix: thin, or with only the leading vectors asked for.
        // The correlation Hankel matrix's values past the order are not used (its
        // `Decomposition` keeps those of `H(0)` for the gaps), so there the leading
        // triplets come certified without the values-only SVD.
        let factor_with = |mat: &DMatrix<f64>, all_values: bool| -> Result<ThinSvd, EraError> {
            let full = mat.nrows().min(mat.ncols());
            if let Some(k) = vectors.filter(|&k| k <= full) {
                let lead = if all_values {
                    linalg::leading_svd(mat, k)?
                } else {
                    linalg::leading_svd_certified(mat, k)?
                };
                if let Some(svd) = lead {
                    return Ok(svd);
                }
            }
            Ok(linalg::thin_svd(mat)?)
        };
        let factor = |mat: &DMatrix<f64>| factor_with(mat, false);
        let y0 = markov.first().ok_or(EraError::TooFewMarkov {
            available: 0,
            required: 1,
        })?;
        let (m, r) = y0.shape();
        let shape = self.shape(m, r, markov.len())?;
        let hankel = |k: usize| -> DMatrix<f64> {
            let (alpha, beta) = (shape.block_rows, shape.block_cols);
            let rows = alpha * m;
            let mut h = DMatrix::zeros(rows, beta * r);
            let data = h.as_mut_slice();
            if r == 1 && markov.iter().all(|y| y.shape() == (m, 1)) {
                // One input: every column is `alpha` consecutive Markov parameters.
                let first = shape.offset + 1 + k;
                let flat: Vec<f64> = markov[first..first + alpha + beta - 1]
                    .iter()
                    .flat_map(|y| y.iter().copied())
                    .collect();
                for (j, col) in data.chunks_exact_mut(rows).enumerate() {
                    col.copy_from_slice(&flat[j * m..j * m + rows]);
                }
                return h;
            }
            for j in 0..beta {
                for i in 0..alpha {
                    let y = &markov[shape.offset + 1 + k + i + j];
                    assert_eq!(y.shape(), (m, r), "Markov parameters must all be m x r");
                    let y = y.as_slice();
                    for l in 0..r {
                        let start = (j * r + l) * rows + i * m;
                        data[start..start + m].copy_from_slice(&y[l * m..(l + 1) * m]);
                    }
                }
            }
            h
        };
        let h0 = hankel(0);
        let (hankel_singular_values, factored_svd, shifted) = if shape.correlated {
            let (xi, zeta) = (shape.xi, shape.zeta);
            let corr = correlations(markov, &shape);
            let block = |k: usize| -> DMatrix<f64> {
                let s = corr[0].nrows();
                let rows = (xi + 1) * s;
                // Column by column, without zeroing first.
                let mut data = Vec::with_capacity(rows * (zeta + 1) * s);
                for j in 0..=zeta {
                    for col in 0..s {
                        for i in 0..=xi {
                            data.extend_from_slice(
                                &corr[k + i + j].as_slice()[col * s..(col + 1) * s],
                            );
                        }
                    }
                }
                DMatrix::from_vec(rows, (zeta + 1) * s, data)
            };
            let big0 = block(0);
            if states.is_some_and(|n| h0.nrows().min(h0.ncols()) < n) {
                // `H(0)` is too small to have the observer's rank: no compression to try
                // (`compressed_svd_of` would refuse it), so its right vectors are not needed.
                (
                    linalg::right_singular_values(&h0)?,
                    factor(&big0)?,
                    block(1),
                )
            } else {
                let h0_svd = linalg::right_svd(&h0)?;
                let stacked_v = |v: &DMatrix<f64>| -> DMatrix<f64> {
                    let rows = h0.nrows();
                    let mut out = DMatrix::zeros((xi + 1) * rows, v.ncols());
                    for i in 0..=xi {
                        let mut view = out.view_mut((i * rows, 0), (rows, v.ncols()));
                        if i == 0 {
                            view.gemm(1.0, &h0, v, 0.0);
                        } else {
                            view.gemm(1.0, &hankel(i), v, 0.0);
                        }
                    }
                    out
                };
                let factored = match compressed_svd_of(stacked_v, &h0_svd, &big0, &factor, states)?
                {
                    Some(svd) => svd,
                    None => factor(&big0)?,
                };
                (h0_svd.s, factored, block(1))
            }
        } else {
            let svd = factor_with(&h0, true)?;
            (svd.s.clone(), svd, hankel(1))
        };
        Ok(Decomposition {
            shape,
            dt_s,
            outputs: m,
            inputs: r,
            d: y0.clone(),
            h0,
            hankel_singular_values,
            factored: factored_svd,
            shifted,
        })
    }

    /// Realization of the chosen order (see [`ModelOrder`]).
    pub fn fit(&self, markov: &[DMatrix<f64>], dt_s: f64) -> Result<Era, EraError> {
        let dec = self.decompose(markov, dt_s)?;
        let n = match self.order {
            ModelOrder::Fixed(n) => n,
            ModelOrder::Auto { max } => {
                dec.orders_by_gap(max)
                    .first()
                    .copied()
                    .ok_or(EraError::OrderTooLarge {
                        order: 2,
                        max: dec.max_order(),
                    })?
            }
        };
        dec.realize(n)
    }
}

/// The correlations `R(k) = H(k) H(0)^T`, `k = 0 ..= xi + zeta + 1`, from sums of
/// products of Markov parameters: block `(i, l)` of `R(k)` is
/// `S(c + k + i, c + l)` with `c = k0 + 1` and `S(a, b) = sum_{j < beta} Y_{a+j} Y_{b+j}^T`,
/// and `S(a + 1, b + 1) = S(a, b) + Y_{a+beta} Y_{b+beta}^T - Y_a Y_b^T`, so each diagonal
/// `a - b` costs one sum of `beta` products and two products per further block (instead of
/// a product of `alpha m x beta r` matrices per `k`). The first sum of each diagonal is
/// formed by [`linalg::dot`] of the Markov parameters' entry series (its four partial
/// sums: round-off of the same order as the running sum's).
fn correlations(markov: &[DMatrix<f64>], shape: &HankelShape) -> Vec<DMatrix<f64>> {
    let (m, r) = markov[0].shape();
    let (alpha, beta) = (shape.block_rows, shape.block_cols);
    let shifts = shape.xi + shape.zeta + 1;
    let c = shape.offset + 1;
    let size = alpha * m;
    let mut corr = vec![DMatrix::zeros(size, size); shifts + 1];
    // The Markov parameters used, contiguous (m x r each, column-major).
    let rows_a = alpha + shifts;
    let used = rows_a + beta - 1;
    let mr = m * r;
    let mut flat = Vec::with_capacity(used * mr);
    for y in &markov[c..c + used] {
        assert_eq!(y.shape(), (m, r), "Markov parameters must all be m x r");
        flat.extend_from_slice(y.as_slice());
    }
    let y = |k: usize| &flat[k * mr..(k + 1) * mr];
    // The same, one series per entry `o + m l` of the Markov parameters (`used` each).
    let mut series = vec![0.0; mr * used];
    for (k, yk) in flat.chunks_exact(mr).enumerate() {
        for (s, &v) in yk.iter().enumerate() {
            series[s * used + k] = v;
        }
    }
    // acc += sign Y_a Y_b^T (m x m, column-major).
    let outer = |ya: &[f64], yb: &[f64], acc: &mut [f64], sign: f64| {
        for o2 in 0..m {
            for o1 in 0..m {
                let mut sum = 0.0;
                for l in 0..r {
                    sum += ya[o1 + m * l] * yb[o2 + m * l];
                }
                acc[o1 + m * o2] += sign * sum;
            }
        }
    };
    let mut acc = vec![0.0; m * m];
    // a - b = d for a = c + k + i (k + i in 0 ..= alpha - 1 + shifts) and b = c + l.
    for d in -(alpha as isize - 1)..rows_a as isize {
        // First pair on the diagonal.
        let (mut ia, mut ib) = if d >= 0 {
            (d as usize, 0)
        } else {
            (0, (-d) as usize)
        };
        // The first sum over the `beta` products, entry by entry as dot products of
        // the channel series.
        for o2 in 0..m {
            for o1 in 0..m {
                let mut sum = 0.0;
                for l in 0..r {
                    let (s1, s2) = (o1 + m * l, o2 + m * l);
                    sum += linalg::dot(
                        &series[s1 * used + ia..][..beta],
                        &series[s2 * used + ib..][..beta],
                    );
                }
                acc[o1 + m * o2] = sum;
            }
        }
        loop {
            // S(c + ia, c + ib) goes to every R(k) block (i, l) with k + i = ia, l = ib.
            for k in 0..=shifts.min(ia) {
                let i = ia - k;
                if i < alpha {
                    let data = corr[k].as_mut_slice();
                    for o2 in 0..m {
                        let start = (ib * m + o2) * size + i * m;
                        data[start..start + m].copy_from_slice(&acc[o2 * m..(o2 + 1) * m]);
                    }
                }
            }
            if ia + 1 >= rows_a || ib + 1 >= alpha {
                break;
            }
            outer(y(ia + beta), y(ib + beta), &mut acc, 1.0);
            outer(y(ia), y(ib), &mut acc, -1.0);
            ia += 1;
            ib += 1;
        }
    }
    corr
}

/// Largest relative residual (Frobenius) of the correlation Hankel matrix outside the
/// space spanned by its columns for which [`compressed_svd`] is used: the Markov
/// parameters of a finite-order system (those of an OKID observer) leave round-off there
/// (1e-15); anything else takes the full SVD.
const COMPRESSION_TOLERANCE: f64 = 1e-12;

/// SVD of the correlation Hankel matrix `big0` in the space that contains its columns.
///
/// For Markov parameters of a system of order `N` (`N` = numerical rank of `H(0)`, at most
/// `alpha m`), `H(k) = O A^k G` and `big0 = [H(i + j) H(0)^T]` has rank `N`. Its columns lie
/// in the span of `[H(0); ...; H(xi)] V_N` (`V_N` the leading right singular vectors of
/// `H(0)`; unlike the first block column of `big0`, whose weak directions are squared, this
/// keeps every direction of `O` at the scale of the Hankel singular values). With an
/// orthonormal basis `Q_L` (`N` columns) of that span, `big0 = Q_L T` with the short
/// `T = Q_L^T big0` (`N` rows), and the SVD `T = U S V^T` gives that of `big0`,
/// `(Q_L U) S V^T` (singular values past `N` are zero). `None` if the residual outside that
/// span exceeds [`COMPRESSION_TOLERANCE`] (then the caller factors `big0` itself), or
/// without trying when `H(0)`'s rank is below the `states` of the system behind the Markov
/// parameters (given: an OKID observer's).
fn compressed_svd_of(
    stacked_v: impl Fn(&DMatrix<f64>) -> DMatrix<f64>,
    h0_svd: &linalg::RightSvd,
    big0: &DMatrix<f64>,
    factor: &dyn Fn(&DMatrix<f64>) -> Result<ThinSvd, EraError>,
    states: Option<usize>,
) -> Result<Option<ThinSvd>, EraError> {
    let (rows, cols) = h0_svd.shape();
    let tol = f64::EPSILON * rows.max(cols) as f64;
    let rank = h0_svd.rank(tol);
    if states.is_some_and(|n| rank < n) {
        return Ok(None);
    }
    compress(stacked_v, rank, &|k| h0_svd.v_columns(k), big0, factor)
}

/// [`compressed_svd_of`] from a full thin SVD of `H(0)` (the correlations `corr` and the
/// block columns `zeta` of `big0` are no longer needed: the row space comes from `T`).
#[cfg(test)]
fn compressed_svd(
    _corr: &[DMatrix<f64>],
    stacked_v: impl Fn(&DMatrix<f64>) -> DMatrix<f64>,
    h0_svd: &ThinSvd,
    _zeta: usize,
    big0: &DMatrix<f64>,
) -> Result<Option<ThinSvd>, EraError> {
    let tol = f64::EPSILON * h0_svd.u.nrows().max(h0_svd.v.nrows()) as f64;
    let rank = h0_svd.rank(tol);
    compress(
        stacked_v,
        rank,
        &|k| h0_svd.v.columns(0, k).into_owned(),
        big0,
        &|t| Ok(linalg::thin_svd(t)?),
    )
}

/// The work of [`compressed_svd_of`] given the rank of `H(0)` and its leading right
/// singular vectors.
fn compress(
    stacked_v: impl Fn(&DMatrix<f64>) -> DMatrix<f64>,
    rank: usize,
    v_columns: &dyn Fn(usize) -> DMatrix<f64>,
    big0: &DMatrix<f64>,
    factor: &dyn Fn(&DMatrix<f64>) -> Result<ThinSvd, EraError>,
) -> Result<Option<ThinSvd>, EraError> {
    if rank == 0 {
        return Ok(None);
    }
    let basis_cols = stacked_v(&v_columns(rank));
    if linalg::first_non_finite(&basis_cols).is_some() {
        return Ok(None);
    }
    let (ql, _) = linalg::thin_qr(&basis_cols);
    // An explicit transpose: the product then goes through the blocked matrix
    // multiplication (`tr_mul` forms one dot product per entry, several times slower).
    let t = ql.transpose() * big0;
    let norm = big0.norm();
    let mut residual = big0.clone();
    residual.gemm(-1.0, &ql, &t, 1.0);
    let residual_norm = residual.norm();
    if residual_norm.is_nan() || residual_norm > COMPRESSION_TOLERANCE * norm {
        return Ok(None);
    }
    let small = factor(&t)?;
    let full = big0.nrows().min(big0.ncols());
    let mut values = DVector::zeros(full);
    values.rows_mut(0, small.s.len()).copy_from(&small.s);
    Ok(Some(ThinSvd {
        u: ql * small.u,
        s: values,
        v: small.v,
    }))
}

/// Factored Hankel matrices, from which realizations of any order can be cut.
#[derive(Debug, Clone)]
pub struct Decomposition {
    /// Hankel dimensions used.
    pub shape: HankelShape,
    dt_s: f64,
    outputs: usize,
    inputs: usize,
    d: DMatrix<f64>,
    h0: DMatrix<f64>,
    /// Singular values of `H(0)`, descending.
    pub hankel_singular_values: DVector<f64>,
    factored: ThinSvd,
    shifted: DMatrix<f64>,
}

impl Decomposition {
    /// Largest order the factored matrix supports.
    pub fn max_order(&self) -> usize {
        self.factored.s.len().min(self.hankel_singular_values.len()) - 1
    }

    /// Numerical rank: the number of singular values above `eps * max(rows, cols) * s_1`,
    /// the smaller of the counts for `H(0)` and for the factored matrix.
    pub fn rank(&self) -> usize {
        let tol = f64::EPSILON * self.factored.u.nrows().max(self.factored.v.nrows()) as f64;
        let h_tol = f64::EPSILON * self.h0.nrows().max(self.h0.ncols()) as f64;
        let s = &self.hankel_singular_values;
        let h_rank = match s.get(0) {
            Some(&s0) if s0 > 0.0 => s.iter().filter(|&&x| x > h_tol * s0).count(),
            _ => 0,
        };
        h_rank.min(self.factored.rank(tol))
    }

    /// `ln s_n - ln s_(n+1)` of the Hankel singular values for `n = 2, 4, ...` up to the
    /// smallest of `max`, [`Decomposition::max_order`] and [`Decomposition::rank`] (index
    /// `n/2 - 1`). The gap between the last significant singular value and round-off counts.
    pub fn gaps(&self, max: usize) -> Vec<f64> {
        let s = &self.hankel_singular_values;
        let floor = s.get(0).copied().unwrap_or(0.0) * 1e-300;
        let ln = |i: usize| s[i].max(floor).max(f64::MIN_POSITIVE).ln();
        let limit = max.min(self.max_order()).min(self.rank());
        (1..)
            .map(|h| 2 * h)
            .take_while(|&n| n <= limit)
            .map(|n| ln(n - 1) - ln(n))
            .collect()
    }

    /// Even orders up to `max`, by decreasing singular value gap.
    pub fn orders_by_gap(&self, max: usize) -> Vec<usize> {
        let gaps = self.gaps(max);
        let mut orders: Vec<usize> = (1..=gaps.len()).map(|h| 2 * h).collect();
        orders.sort_by(|a, b| gaps[b / 2 - 1].total_cmp(&gaps[a / 2 - 1]));
        orders
    }

    /// Realization of order `n`.
    pub fn realize(&self, n: usize) -> Result<Era, EraError> {
        let max = self.max_order();
        if n == 0 || n > max {
            return Err(EraError::OrderTooLarge { order: n, max });
        }
        let svd = &self.factored;
        let rank = self.rank();
        if rank < n {
            return Err(EraError::RankDeficient { order: n, rank });
        }
        if n > svd.u.ncols() {
            // Decomposed for a lower order only (`EraParams::decompose_to_order`).
            return Err(EraError::OrderTooLarge {
                order: n,
                max: svd.u.ncols(),
            });
        }
        let (m, r) = (self.outputs, self.inputs);
        let shape = self.shape;
        let un = svd.u.columns(0, n);
        let vn = svd.v.columns(0, n);
        let sqrt_s = svd.s.rows(0, n).map(|x| x.sqrt());
        let inv_sqrt = sqrt_s.map(|x| 1.0 / x);
        // `Hc(1) V_n` first (long columns), then its dot products with `U_n`: a product
        // with the short and wide `U_n^T` on the left runs over columns of length `n`.
        let mut a = un.tr_mul(&(&self.shifted * vn));
        for j in 0..n {
            for i in 0..n {
                a[(i, j)] *= inv_sqrt[i] * inv_sqrt[j];
            }
        }
        let p = un * DMatrix::from_diagonal(&sqrt_s);
        let alpha_rows = shape.block_rows * m;
        let observability = p.rows(0, alpha_rows).into_owned();
        let c = p.rows(0, m).into_owned();
        let controllability = if shape.correlated {
            let osvd = linalg::thin_svd(&observability)?;
            let (q, kept) = linalg::lstsq_truncated(&osvd, &self.h0, 1e-13);
            if kept < n {
                return Err(EraError::RankDeficient {
                    order: n,
                    rank: kept,
                });
            }
            q
        } else {
            DMatrix::from_diagonal(&sqrt_s) * svd.v.columns(0, n).transpose()
        };
        let mut b = controllability.columns(0, r).into_owned();
        if shape.offset > 0 {
            let lu = a.clone().lu();
            for _ in 0..shape.offset {
                b = lu.solve(&b).ok_or(EraError::SingularStateMatrix {
                    offset: shape.offset,
                })?;
            }
            if linalg::first_non_finite(&b).is_some() {
                return Err(EraError::SingularStateMatrix {
                    offset: shape.offset,
                });
            }
        }
        Ok(Era {
            realization: StateSpace::new(a, b, c, self.d.clone(), self.dt_s),
            order: n,
            shape,
            hankel_singular_values: self.hankel_singular_values.clone(),
            singular_values: svd.s.clone(),
            observability,
            controllability,
        })
    }
}

/// Result of ERA or ERA/DC.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Era {
    /// Discrete realization `A, B, C, D` (with `D = Y_0`).
    pub realization: StateSpace,
    /// Model order used.
    pub order: usize,
    /// Hankel dimensions used.
    pub shape: HankelShape,
    /// Singular values of `H(0)`, descending (the paper's Fig. 4).
    pub hankel_singular_values: DVector<f64>,
    /// Singular values of the factored matrix (`H(0)` for ERA, the correlation Hankel
    /// matrix for ERA/DC).
    pub singular_values: DVector<f64>,
    /// Identified observability matrix `[C; C A; ...; C A^(alpha-1)]` (alpha m x n).
    pub observability: DMatrix<f64>,
    /// Identified controllability matrix at the offset, `A^k0 [B, A B, ..., A^(beta-1) B]`
    /// (n x beta r).
    pub controllability: DMatrix<f64>,
}
