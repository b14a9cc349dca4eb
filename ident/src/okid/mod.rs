//! Observer/Kalman filter identification (OKID) over several records jointly.
//!
//! # Model
//!
//! With `v[k] = [u[k]; y[k]]`, the observer (ARX) model with `q` input leads is
//!
//! ```text
//! y[n] = sum_{j=1..q} a_{-j} u[n+j] + a_0 u[n] + sum_{i=1..p} ( a_i u[n-i] + b_i y[n-i] )
//! ```
//!
//! written in the zero-initial-condition form: samples before the start of a record are
//! zero, so every sample `n` of every record gives an equation (a hammer record is mostly
//! free decay after a pulse a few samples in; dropping the first `p` equations would lose the
//! pulse). An equation that needs an input sample after the end of a record (only with leads)
//! is not formed. All records are stacked into one least-squares problem.
//!
//! Records that do not start at rest (a shaker already running, ambient vibration, a
//! record cut out of a longer one) break that form: their first equations read zeros where
//! the unknown past had motion. With [`InitialState::Unknown`] the first `p_max` equations
//! of every record (`p_max` the largest observer order tried) are not formed; their samples
//! still serve as regressors of the later equations. For a deadbeat observer of order `p`
//! the ARX model holds exactly from sample `p` on whatever the initial state (its effect is
//! `C (A + G C)^n x_0 = 0` for `n >= p`), and for the least-squares observer it has decayed
//! with the observer's poles, so nothing but `p_max` equations per record is lost.
//!
//! The noncausal leads model band-limited records: the exact discrete relation for an
//! anti-aliased and sampled signal pair is `y[n] = sum_k g[k] u[n-k]` with
//! `g[k] = dt h_bl(k dt)`, the band-limited impulse response, which has small terms at
//! negative `k` and whose `k = 0` term is not `D`. For held (zero-order-hold) records the
//! discrete model is exact and causal, and `q = 0`.
//!
//! # Solution
//!
//! Each channel is scaled by its RMS over all records (so `rcond` does not depend on units).
//! The tall regression matrix, with the regressors ordered by lag and the targets appended,
//! is reduced by Householder QR record by record (never normal equations). One triangular
//! factor then gives the residual of every nested observer order `p`, which the automatic
//! order uses (BIC). The chosen order is solved by an SVD of its triangular block with the
//! singular values below `rcond * s_max` discarded. If the autoregressive part (companion
//! matrix of the `b_i`) has a spectral radius of 1 or more, `rcond` is raised tenfold and the
//! problem re-solved, at most `max_rcond_raises` times.
//!
//! # Markov parameters
//!
//! The input-output Markov parameters follow from
//! `g[k] = a_k + sum_{i=1..p} b_i g[k-i]` for `k >= -q`, with `g[k] = 0` before `-q`
//! (this includes the `b_k g[0] = b_k D` terms). `Y_0 = g[0] = D` and `Y_k = g[k]`. The
//! observer-gain Markov parameters `C A^(k-1) G` (for the observer
//! `x[k+1] = (A + G C) x[k] + (B + G D) u[k] - G y[k]`, so `b_i = -C (A + G C)^(i-1) G`) follow
//! from `h_k = -b_k + sum_{i=1..k-1} b_i h_{k-i}`; they are meaningful for `q = 0`.

use crate::linalg::{self, LinalgError};
use crate::record::{self, DataError, Record};
use nalgebra::{DMatrix, QR, SymmetricEigen};
use serde::{Deserialize, Serialize};

mod moments;
pub(crate) use moments::Moments;
use moments::nested_rss;

#[cfg(test)]
mod tests;

/// The normal equations are solved only if the smallest eigenvalue of the regressors'
/// scaled Gram matrix is at least this fraction of the largest (condition number of the
/// regression at most 1e5): the normal equations then lose at most 1e-6 of relative
/// accuracy, far below the scatter that makes such data well conditioned (measurement
/// noise). Noise-free data, whose redundant directions sit at round-off, go through QR.
const NORMAL_CONDITION_LIMIT: f64 = 1e-10;

/// A Cholesky pivot of the scaled Gram matrix below this fraction of its column's sum of
/// squares (a column within 1e-5 radians of the span of the previous ones) sends the fit to
/// the QR route.
const PIVOT_LIMIT: f64 = 1e-10;

/// A relative residual below this sends the fit to the QR route: the residual sum of
/// squares from the normal equations carries an error of round-off times the squared
/// condition number (at most 1e-6 of the outputs' sum of squares), so nearly exact fits
/// (noise-free data) are solved from the data.
const NORMAL_RESIDUAL_LIMIT: f64 = 1e-4;

/// How the observer order `p` is chosen.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum ObserverOrder {
    /// Use this order.
    Fixed(usize),
    /// Minimize the Bayesian information criterion over `p = 1..=max`. The residual sum of
    /// squares is floored at `(1e-12)^2 ||Y||^2` (scaled data), so noise-free data stop at
    /// the first order that fits them exactly.
    Auto {
        /// Largest observer order `p` tried (past samples per regressor, at least 1).
        max: usize,
    },
}

/// What OKID assumes about the state at the start of every record.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum InitialState {
    /// At rest before the first sample: every sample gives an equation, with zeros before
    /// the record (hammer records with a pre-trigger, or starting at the hit).
    #[default]
    AtRest,
    /// Unknown (the structure may already move): the first `p_max` equations of every
    /// record are not formed (see the module docs).
    Unknown,
}

/// OKID parameters.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct OkidParams {
    /// Observer order.
    pub order: ObserverOrder,
    /// Number of noncausal input leads `q`.
    pub leads: usize,
    /// Relative singular value truncation of the least-squares solve.
    pub rcond: f64,
    /// How many times `rcond` may be raised tenfold to stabilize the observer.
    pub max_rcond_raises: usize,
    /// Number of system Markov parameters to return (`Y_0 .. Y_{markov_count-1}`).
    pub markov_count: usize,
    /// The state at the start of every record.
    #[serde(default)]
    pub initial_state: InitialState,
}

/// Floor of the relative residual norm used by the automatic order.
pub const BIC_RELATIVE_FLOOR: f64 = 1e-12;

impl Default for OkidParams {
    fn default() -> Self {
        Self::zoh()
    }
}

impl OkidParams {
    /// Defaults for held (zero-order-hold) records: no leads, `rcond = 1e-8` (exact
    /// discrete data give a regression whose redundant directions sit at round-off level),
    /// automatic order up to 20.
    pub fn zoh() -> Self {
        Self {
            order: ObserverOrder::Auto { max: 20 },
            leads: 0,
            rcond: 1e-8,
            max_rcond_raises: 4,
            markov_count: 400,
            initial_state: InitialState::AtRest,
        }
    }

    /// Defaults for band-limited (analyzer) records: 8 leads, `rcond = 1e-4` (below the
    /// -80..-100 dB stop band of analyzer anti-alias filters: noise-free band-limited data
    /// leave the band above the filter edge unexcited), automatic order up to 20.
    pub fn bandlimited() -> Self {
        Self {
            leads: 8,
            rcond: 1e-4,
            ..Self::zoh()
        }
    }

    /// Sets the observer order.
    pub fn order(mut self, order: ObserverOrder) -> Self {
        self.order = order;
        self
    }

    /// Sets the number of input leads.
    pub fn leads(mut self, leads: usize) -> Self {
        self.leads = leads;
        self
    }

    /// Sets the relative truncation of the least-squares solve.
    pub fn rcond(mut self, rcond: f64) -> Self {
        self.rcond = rcond;
        self
    }

    /// Sets what is assumed about the state at the start of every record.
    pub fn initial_state(mut self, initial_state: InitialState) -> Self {
        self.initial_state = initial_state;
        self
    }

    /// Equations not formed at the start of every record: the largest observer order for
    /// [`InitialState::Unknown`], none at rest.
    pub fn skipped_equations(&self) -> usize {
        match self.initial_state {
            InitialState::AtRest => 0,
            InitialState::Unknown => self.max_order(),
        }
    }

    /// Sets the number of Markov parameters returned.
    pub fn markov_count(mut self, count: usize) -> Self {
        self.markov_count = count;
        self
    }

    /// Largest observer order that may be used.
    pub fn max_order(&self) -> usize {
        match self.order {
            ObserverOrder::Fixed(p) => p,
            ObserverOrder::Auto { max } => max,
        }
    }

    /// Validates the parameters.
    pub fn check(&self) -> Result<(), OkidError> {
        let bad = |reason: String| Err(OkidError::InvalidParams { reason });
        match self.order {
            ObserverOrder::Fixed(0) => return bad("observer order must be at least 1".into()),
            ObserverOrder::Auto { max: 0 } => {
                return bad("maximum observer order must be at least 1".into());
            }
            _ => {}
        }
        if !(self.rcond.is_finite() && self.rcond > 0.0 && self.rcond < 1.0) {
            return bad(format!("rcond = {} must be in (0, 1)", self.rcond));
        }
        if self.markov_count < 2 {
            return bad(format!(
                "markov_count = {} must be at least 2",
                self.markov_count
            ));
        }
        Ok(())
    }

    /// Identifies the observer and system Markov parameters from `records`.
    pub fn fit(&self, records: &[Record]) -> Result<Okid, OkidError> {
        self.check()?;
        let shape = record::validate(records)?;
        let refs: Vec<&Record> = records.iter().collect();
        let layout = self.layout(shape.inputs, shape.outputs);
        self.check_lengths(&refs)?;
        let moments = Moments::of_records(&refs, &layout);
        self.fit_moments(&moments, &refs)
    }

    /// The regression layout at the largest order for `r` inputs and `m` outputs.
    pub(crate) fn layout(&self, r: usize, m: usize) -> Layout {
        Layout {
            r,
            m,
            q: self.leads,
            p: self.max_order(),
            skip: self.skipped_equations(),
        }
    }

    /// Whether moments accumulated for `lay` serve these parameters: the same leads and
    /// skipped equations, and at least the largest order (with the same equations, the
    /// Gram matrix at a lower order is a corner of that at a higher one).
    pub(crate) fn fits_layout(&self, lay: &Layout) -> bool {
        lay.q == self.leads && lay.p >= self.max_order() && lay.skip == self.skipped_equations()
    }

    /// Every record must be long enough for the largest order and the leads.
    pub(crate) fn check_lengths(&self, records: &[&Record]) -> Result<(), OkidError> {
        let required = self.max_order() + self.leads + 1 + self.skipped_equations();
        for (index, rec) in records.iter().enumerate() {
            if rec.len() < required {
                return Err(DataError::TooShort {
                    record: index,
                    samples: rec.len(),
                    required,
                    reason: match self.initial_state {
                        InitialState::AtRest => "observer order plus leads plus one",
                        InitialState::Unknown => {
                            "twice the observer order plus leads plus one (unknown initial state)"
                        }
                    },
                }
                .into());
            }
        }
        Ok(())
    }

    /// Fits from the accumulated lagged products `moments` of `records` (validated, long
    /// enough; `moments` built with the same leads and an order at least
    /// [`OkidParams::max_order`]). The normal equations are solved when they are accurate
    /// (see the module docs); otherwise the records are reduced by QR.
    pub(crate) fn fit_moments(
        &self,
        moments: &Moments,
        records: &[&Record],
    ) -> Result<Okid, OkidError> {
        self.check()?;
        let lay = moments.layout;
        assert!(
            self.fits_layout(&lay),
            "OKID moments built for another layout"
        );
        let layout = Layout {
            p: self.max_order(),
            ..lay
        };
        let ncols = layout.columns(layout.p);
        if moments.equations < ncols {
            return Err(OkidError::Underdetermined {
                equations: moments.equations,
                unknowns: ncols,
            });
        }
        match self.fit_normal(moments, &layout)? {
            Some(okid) => Ok(okid),
            None => self.fit_qr(records, &layout, moments.equations),
        }
    }

    /// The normal-equation route; `None` when it would not be accurate.
    fn fit_normal(&self, moments: &Moments, layout: &Layout) -> Result<Option<Okid>, OkidError> {
        let m = layout.m;
        let scales = moments.scales();
        let ncols = layout.columns(layout.p);
        let gram = moments.scaled_gram(layout, &scales);
        if let Some((row, col)) = linalg::first_non_finite(&gram) {
            return Err(LinalgError::NonFinite {
                what: "OKID correlation matrix",
                row,
                col,
            }
            .into());
        }
        let y_ss: f64 = (0..m).map(|i| gram[(ncols + i, ncols + i)]).sum();
        let (p, bic) = match self.order {
            ObserverOrder::Fixed(p) => (p, Vec::new()),
            ObserverOrder::Auto { max } => {
                let Some(rss) = nested_rss(&gram, layout) else {
                    return Ok(None);
                };
                self.bic(&|p| rss[p - 1], layout, moments.equations, y_ss, max)
            }
        };
        let c = layout.columns(p);
        let gxx = gram.view((0, 0), (c, c)).into_owned();
        let gxy = gram.view((0, ncols), (c, m)).into_owned();
        let layout_p = Layout { p, ..*layout };
        // A solution `theta` at `rcond` (rank `rank`, after `raises`): the fit when its
        // observer is stable (`None` when the fit is too close for the normal equations
        // to be trusted), or the spectral radius when it is not.
        let attempt = |theta: &DMatrix<f64>,
                       rcond: f64,
                       raises: &[RcondRaise],
                       rank: usize|
         -> Result<Result<Option<Okid>, f64>, OkidError> {
            let coeffs = layout_p.coefficients(theta, &scales);
            let radius = linalg::spectral_radius(&companion_for_radius(&coeffs.b, m))?;
            if !(radius < 1.0 && radius.is_finite()) {
                return Ok(Err(radius));
            }
            let fit_ss = y_ss - 2.0 * theta.dot(&gxy) + theta.dot(&(&gxx * theta));
            let relative_residual = (fit_ss.max(0.0) / y_ss).sqrt();
            if relative_residual < NORMAL_RESIDUAL_LIMIT {
                return Ok(Ok(None));
            }
            Ok(Ok(Some(self.finish(
                coeffs,
                FitInfo {
                    p,
                    rcond,
                    raises: raises.to_vec(),
                    rank,
                    unknowns: c,
                    equations: moments.equations,
                    spectral_radius: radius,
                    bic: bic.clone(),
                    relative_residual,
                },
            ))))
        };
        // Well-conditioned normal equations (the usual case with noisy records): every
        // eigenvalue is provably above the truncation floor, so the truncated solution
        // below is the plain one, by Cholesky. An unstable observer goes on to the eigen
        // route, which raises rcond.
        if let Some(theta) = well_conditioned_solve(&gxx, &gxy, self.rcond * self.rcond)
            && let Ok(fit) = attempt(&theta, self.rcond, &[], c)?
        {
            return Ok(fit);
        }
        let eig = SymmetricEigen::new(gxx.clone());
        let lambda_max = eig.eigenvalues.max();
        let lambda_min = eig.eigenvalues.min();
        if !(lambda_max > 0.0 && lambda_min >= NORMAL_CONDITION_LIMIT * lambda_max) {
            return Ok(None);
        }
        let vty = eig.eigenvectors.transpose() * &gxy;
        let mut rcond = self.rcond;
        let mut raises = Vec::new();
        loop {
            let floor = rcond * rcond * lambda_max;
            let mut scaled = vty.clone();
            let mut rank = 0;
            for (i, &l) in eig.eigenvalues.iter().enumerate() {
                if l > floor {
                    scaled.row_mut(i).scale_mut(1.0 / l);
                    rank += 1;
                } else {
                    scaled.row_mut(i).fill(0.0);
                }
            }
            let theta = &eig.eigenvectors * scaled;
            let radius = match attempt(&theta, rcond, &raises, rank)? {
                Ok(fit) => return Ok(fit),
                Err(radius) => radius,
            };
            if raises.len() >= self.max_rcond_raises || rcond * 10.0 >= 1.0 {
                return Err(OkidError::UnstableObserver {
                    spectral_radius: radius,
                    rcond,
                    observer_order: p,
                });
            }
            raises.push(RcondRaise {
                from: rcond,
                to: rcond * 10.0,
                spectral_radius: radius,
            });
            rcond *= 10.0;
        }
    }

    /// BIC of every order `1..=max` from the nested residual sums of squares; returns the
    /// best order and the criteria.
    fn bic(
        &self,
        rss: &dyn Fn(usize) -> f64,
        layout: &Layout,
        equations: usize,
        y_ss: f64,
        max: usize,
    ) -> (usize, Vec<f64>) {
        let m = layout.m;
        let n_obs = (equations * m) as f64;
        let floor = BIC_RELATIVE_FLOOR * BIC_RELATIVE_FLOOR * y_ss;
        let bic: Vec<f64> = (1..=max)
            .map(|p| {
                let rss = rss(p).max(floor).max(f64::MIN_POSITIVE);
                let params = (m * layout.columns(p)) as f64;
                n_obs * (rss / n_obs).ln() + params * n_obs.ln()
            })
            .collect();
        let best = bic
            .iter()
            .enumerate()
            .min_by(|a, b| a.1.total_cmp(b.1))
            .map(|(i, _)| i + 1)
            .unwrap_or(1);
        (best, bic)
    }

    /// The QR route: the stacked regression reduced record by record.
    fn fit_qr(
        &self,
        records: &[&Record],
        layout: &Layout,
        equations: usize,
    ) -> Result<Okid, OkidError> {
        let m = layout.m;
        let ncols = layout.columns(layout.p);
        let scales = Scales::new(records, layout.r, m);
        let rfac = triangular_factor(records, layout, &scales)?;

        // Residual sum of squares of every nested order from the one factor.
        let y_block = rfac.columns(ncols, m);
        let row_ss: Vec<f64> = (0..rfac.nrows())
            .map(|i| y_block.row(i).norm_squared())
            .collect();
        let y_ss: f64 = row_ss.iter().sum();
        let rss = |p: usize| -> f64 { row_ss.iter().skip(layout.columns(p)).sum() };

        let (p, bic) = match self.order {
            ObserverOrder::Fixed(p) => (p, Vec::new()),
            ObserverOrder::Auto { max } => self.bic(&rss, layout, equations, y_ss, max),
        };

        let c = layout.columns(p);
        let r11 = rfac.view((0, 0), (c, c)).into_owned();
        let rhs = rfac.view((0, ncols), (c, m)).into_owned();
        let svd = linalg::thin_svd(&r11)?;
        let layout = Layout { p, ..*layout };

        let mut rcond = self.rcond;
        let mut raises = Vec::new();
        loop {
            let (theta, rank) = linalg::lstsq_truncated(&svd, &rhs, rcond);
            let coeffs = layout.coefficients(&theta, &scales);
            let radius = linalg::spectral_radius(&companion_for_radius(&coeffs.b, m))?;
            if radius < 1.0 && radius.is_finite() {
                let fit_ss = (&rhs - &r11 * &theta).norm_squared() + rss(p);
                return Ok(self.finish(
                    coeffs,
                    FitInfo {
                        p,
                        rcond,
                        raises,
                        rank,
                        unknowns: c,
                        equations,
                        spectral_radius: radius,
                        bic,
                        relative_residual: (fit_ss / y_ss).sqrt(),
                    },
                ));
            }
            if raises.len() >= self.max_rcond_raises || rcond * 10.0 >= 1.0 {
                return Err(OkidError::UnstableObserver {
                    spectral_radius: radius,
                    rcond,
                    observer_order: p,
                });
            }
            raises.push(RcondRaise {
                from: rcond,
                to: rcond * 10.0,
                spectral_radius: radius,
            });
            rcond *= 10.0;
        }
    }

    fn finish(&self, coeffs: Coefficients, info: FitInfo) -> Okid {
        let (lead_markov, markov) =
            system_markov(&coeffs.a, &coeffs.b, self.leads, self.markov_count);
        let observer_gain_markov = observer_gain_markov(&coeffs.b, self.markov_count - 1);
        Okid {
            observer_order: info.p,
            leads: self.leads,
            rcond: info.rcond,
            rcond_raises: info.raises,
            rank: info.rank,
            unknowns: info.unknowns,
            equations: info.equations,
            spectral_radius: info.spectral_radius,
            bic: info.bic,
            relative_residual: info.relative_residual,
            input_coefficients: coeffs.a,
            output_coefficients: coeffs.b,
            lead_markov,
            markov,
            observer_gain_markov,
        }
    }
}

/// `gxx^-1 gxy` by Cholesky if `gxx` is provably conditioned well enough that the
/// truncated eigen-solution with relative floor `floor` (eigenvalues at most
/// `floor * lambda_max` dropped) and [`NORMAL_CONDITION_LIMIT`] keep everything; `None`
/// otherwise (then the caller decides by the eigenvalues themselves). The proof uses
/// bounds, not estimates: `lambda_max <= min(||G||_F, ||G||_inf)` and
/// `lambda_min >= 1 / ||G^-1||_F >= 1 / ||L^-1||_F^2` (`G = L L^T`), loose by at most the
/// dimension each, so a Gram matrix within that factor of the limits takes the eigen route.
fn well_conditioned_solve(
    gxx: &DMatrix<f64>,
    gxy: &DMatrix<f64>,
    floor: f64,
) -> Option<DMatrix<f64>> {
    let n = gxx.nrows();
    let chol = nalgebra::Cholesky::new(gxx.clone())?;
    let lambda_max_bound = gxx.norm().min(
        (0..n)
            .map(|i| gxx.row(i).iter().map(|x| x.abs()).sum::<f64>())
            .fold(0.0, f64::max),
    );
    // ||L^-1||_F^2 column by column: column j of L^-1 is zero above row j, so its
    // forward substitution starts there (a sixth of n^3 instead of a half).
    // Column `i` of `L` below the diagonal is contiguous (column-major): the update runs
    // over slices (the same operations in the same order as indexing entry by entry).
    let l = chol.l_dirty().as_slice();
    let mut l_inv_ss = 0.0;
    let mut x = vec![0.0; n];
    for j in 0..n {
        x[j..].fill(0.0);
        x[j] = 1.0;
        for i in j..n {
            let coeff = x[i] / l[i + i * n];
            x[i] = coeff;
            for (xk, &lk) in x[i + 1..].iter_mut().zip(&l[i * n + i + 1..(i + 1) * n]) {
                *xk -= coeff * lk;
            }
        }
        for v in &x[j..] {
            l_inv_ss += v * v;
        }
    }
    if !l_inv_ss.is_finite() {
        return None;
    }
    let lambda_min_bound = 1.0 / l_inv_ss;
    let limit = floor.max(NORMAL_CONDITION_LIMIT);
    if !(lambda_min_bound.is_finite() && lambda_min_bound > limit * lambda_max_bound) {
        return None;
    }
    Some(chol.solve(gxy))
}

/// System Markov parameters from observer coefficients: `g[k] = a_k + sum_i b_i g[k-i]`
/// for `k = -leads ..`, `g` zero before `-leads`.
///
/// `input_coefficients[k + leads]` is `a_k` (`k = -leads ..= p`), `output_coefficients[i - 1]`
/// is `b_i`. Returns the noncausal terms `g[-1] .. g[-leads]` and `Y_0 = g[0] .. Y_{count-1}`.
pub fn system_markov(
    input_coefficients: &[DMatrix<f64>],
    output_coefficients: &[DMatrix<f64>],
    leads: usize,
    count: usize,
) -> (Vec<DMatrix<f64>>, Vec<DMatrix<f64>>) {
    let (m, r) = input_coefficients
        .first()
        .expect("system_markov: no input coefficients")
        .shape();
    let total = leads + count;
    let (mr, mm) = (m * r, m * m);
    // g[idx] (m x r, column-major) at flat[idx * mr ..], idx = k + leads.
    let mut flat = vec![0.0; total * mr];
    for idx in 0..total {
        let (done, rest) = flat.split_at_mut(idx * mr);
        let acc = &mut rest[..mr];
        if let Some(a) = input_coefficients.get(idx) {
            acc.copy_from_slice(a.as_slice());
        }
        for (i, b) in output_coefficients.iter().enumerate() {
            let lag = i + 1;
            if idx < lag {
                break;
            }
            let (b, g) = (b.as_slice(), &done[(idx - lag) * mr..(idx - lag + 1) * mr]);
            debug_assert_eq!(b.len(), mm);
            mul_add(acc, b, g, m, r);
        }
    }
    let at = |idx: usize| DMatrix::from_column_slice(m, r, &flat[idx * mr..(idx + 1) * mr]);
    let lead_markov = (1..=leads).map(|j| at(leads - j)).collect();
    let markov = (leads..total).map(at).collect();
    (lead_markov, markov)
}

/// `acc += b g` for `b` m x m and `g`, `acc` m x cols (column-major slices). Two to four
/// outputs (the common frames) take constant sizes, so that the loops unroll: the same
/// operations in the same order.
fn mul_add(acc: &mut [f64], b: &[f64], g: &[f64], m: usize, cols: usize) {
    match m {
        2 => mul_add_sizes(acc, b, g, 2, cols),
        3 => mul_add_sizes(acc, b, g, 3, cols),
        4 => mul_add_sizes(acc, b, g, 4, cols),
        _ => mul_add_sizes(acc, b, g, m, cols),
    }
}

/// [`mul_add`] itself, inlined into each of its calls so that a constant `m` unrolls it.
#[inline(always)]
fn mul_add_sizes(acc: &mut [f64], b: &[f64], g: &[f64], m: usize, cols: usize) {
    let (b, g, acc) = (&b[..m * m], &g[..m * cols], &mut acc[..m * cols]);
    for c in 0..cols {
        for o in 0..m {
            let mut sum = 0.0;
            for l in 0..m {
                sum += b[o + m * l] * g[l + m * c];
            }
            acc[o + m * c] += sum;
        }
    }
}

/// Observer-gain Markov parameters `h_k = C A^(k-1) G`, `k = 1 ..= count`, from the output
/// coefficients `b_i = -C (A + G C)^(i-1) G`: `h_k = -b_k + sum_{i=1..k-1} b_i h_{k-i}`.
pub fn observer_gain_markov(
    output_coefficients: &[DMatrix<f64>],
    count: usize,
) -> Vec<DMatrix<f64>> {
    let Some(m) = output_coefficients.first().map(|b| b.nrows()) else {
        return Vec::new();
    };
    let mm = m * m;
    // h_k (m x m, column-major) at flat[(k - 1) * mm ..].
    let mut flat = vec![0.0; count * mm];
    for k in 1..=count {
        let (done, rest) = flat.split_at_mut((k - 1) * mm);
        let acc = &mut rest[..mm];
        if let Some(b) = output_coefficients.get(k - 1) {
            for (a, x) in acc.iter_mut().zip(b.as_slice()) {
                *a = -x;
            }
        }
        for i in 1..k.min(output_coefficients.len() + 1) {
            let b = output_coefficients[i - 1].as_slice();
            let h = &done[(k - i - 1) * mm..(k - i) * mm];
            mul_add(acc, b, h, m, m);
        }
    }
    (0..count)
        .map(|k| DMatrix::from_column_slice(m, m, &flat[k * mm..(k + 1) * mm]))
        .collect()
}

struct FitInfo {
    p: usize,
    rcond: f64,
    raises: Vec<RcondRaise>,
    rank: usize,
    unknowns: usize,
    equations: usize,
    spectral_radius: f64,
    bic: Vec<f64>,
    relative_residual: f64,
}

/// One tenfold increase of `rcond` made to stabilize the observer.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RcondRaise {
    /// Truncation before the raise.
    pub from: f64,
    /// Truncation after the raise.
    pub to: f64,
    /// Spectral radius of the observer's autoregressive part that caused it.
    pub spectral_radius: f64,
}

/// Result of OKID.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Okid {
    /// Observer order `p` used.
    pub observer_order: usize,
    /// Number of input leads `q` used.
    pub leads: usize,
    /// Relative truncation finally used.
    pub rcond: f64,
    /// Raises of `rcond` made to stabilize the observer (empty if none).
    pub rcond_raises: Vec<RcondRaise>,
    /// Number of singular values kept in the least-squares solve.
    pub rank: usize,
    /// Number of regressors (unknowns per output).
    pub unknowns: usize,
    /// Number of equations (samples) in the stacked regression.
    pub equations: usize,
    /// Spectral radius of the observer's autoregressive part (< 1).
    pub spectral_radius: f64,
    /// BIC of each observer order `1..=max` for [`ObserverOrder::Auto`] (index `p - 1`).
    pub bic: Vec<f64>,
    /// Residual norm relative to the output norm (scaled channels).
    pub relative_residual: f64,
    /// Input coefficients `a_k`, `k = -q ..= p`, stored at index `k + q` (m x r each).
    pub input_coefficients: Vec<DMatrix<f64>>,
    /// Output coefficients `b_i`, `i = 1 ..= p`, stored at index `i - 1` (m x m each).
    pub output_coefficients: Vec<DMatrix<f64>>,
    /// Noncausal Markov parameters `g[-j]`, `j = 1 ..= q`, stored at index `j - 1`.
    pub lead_markov: Vec<DMatrix<f64>>,
    /// System Markov parameters `Y_0 = D, Y_1, ...` (m x r each).
    pub markov: Vec<DMatrix<f64>>,
    /// Observer-gain Markov parameters `C A^(k-1) G`, `k = 1, 2, ...`, at index `k - 1`
    /// (m x m each).
    pub observer_gain_markov: Vec<DMatrix<f64>>,
}

/// Ways OKID can fail.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum OkidError {
    /// Parameters out of range.
    #[error("invalid OKID parameters: {reason}")]
    InvalidParams {
        /// Which parameter is out of range and what it must be.
        reason: String,
    },
    /// The records are unusable.
    #[error(transparent)]
    Data(#[from] DataError),
    /// Fewer equations than unknowns.
    #[error("OKID regression has {equations} equations for {unknowns} unknowns")]
    Underdetermined {
        /// Equations of the stacked regression: one per usable sample of every record
        /// (each with one target per output).
        equations: usize,
        /// Coefficients per output at the largest observer order `p` tried:
        /// `(q + 1) r + p (r + m)`.
        unknowns: usize,
    },
    /// The observer stayed unstable after raising `rcond` as far as allowed.
    #[error(
        "OKID observer of order {observer_order} is unstable (spectral radius {spectral_radius:.6}) even with rcond = {rcond:e}"
    )]
    UnstableObserver {
        /// Spectral radius of the observer's autoregressive companion matrix at the last
        /// attempt (1 or more: unstable).
        spectral_radius: f64,
        /// The relative singular-value cutoff of the last attempt.
        rcond: f64,
        /// Observer order `p` of the fit.
        observer_order: usize,
    },
    /// A decomposition failed.
    #[error(transparent)]
    Linalg(#[from] LinalgError),
}

/// Column layout of the regression: leads `u[n+q] .. u[n+1]`, then `u[n]`, then
/// `[u[n-i]; y[n-i]]` for `i = 1..=p`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Layout {
    r: usize,
    m: usize,
    q: usize,
    p: usize,
    /// Equations not formed at the start of every record (unknown initial state).
    skip: usize,
}

impl Layout {
    /// Number of regressors for observer order `p`.
    fn columns(&self, p: usize) -> usize {
        (self.q + 1) * self.r + p * (self.r + self.m)
    }

    /// Splits the solution (regressors x m, scaled units) into coefficient matrices in
    /// physical units.
    fn coefficients(&self, theta: &DMatrix<f64>, s: &Scales) -> Coefficients {
        let (r, m, q) = (self.r, self.m, self.q);
        let input_block = |row0: usize| -> DMatrix<f64> {
            DMatrix::from_fn(m, r, |o, ch| theta[(row0 + ch, o)] * s.y[o] / s.u[ch])
        };
        let mut a = Vec::with_capacity(q + 1 + self.p);
        // Leads: column block t holds u[n + q - t], i.e. k = -(q - t).
        for j in (1..=q).rev() {
            // a_{-j} multiplies u[n + j], held in column block t = q - j.
            a.push(input_block((q - j) * r));
        }
        a.push(input_block(q * r));
        let mut b = Vec::with_capacity(self.p);
        for i in 1..=self.p {
            let base = (q + 1) * r + (i - 1) * (r + m);
            a.push(input_block(base));
            b.push(DMatrix::from_fn(m, m, |o, o2| {
                theta[(base + r + o2, o)] * s.y[o] / s.y[o2]
            }));
        }
        Coefficients { a, b }
    }
}

/// Observer coefficients in physical units.
struct Coefficients {
    /// a_k at index k + q, k = -q ..= p.
    a: Vec<DMatrix<f64>>,
    /// b_i at index i - 1.
    b: Vec<DMatrix<f64>>,
}

/// RMS of each channel over all records (1 for a channel that is zero everywhere).
struct Scales {
    u: Vec<f64>,
    y: Vec<f64>,
}

impl Scales {
    fn new(records: &[&Record], r: usize, m: usize) -> Self {
        let total: usize = records.iter().map(|rec| rec.len()).sum();
        let rms = |get: &dyn Fn(&Record) -> &DMatrix<f64>, ch: usize| -> f64 {
            let ss: f64 = records
                .iter()
                .map(|rec| get(rec).row(ch).norm_squared())
                .sum();
            let v = (ss / total as f64).sqrt();
            if v > 0.0 && v.is_finite() { v } else { 1.0 }
        };
        Self {
            u: (0..r).map(|ch| rms(&|rec| &rec.inputs, ch)).collect(),
            y: (0..m).map(|ch| rms(&|rec| &rec.outputs, ch)).collect(),
        }
    }
}

/// Maximum number of regression rows reduced per QR step.
const ROWS_PER_BLOCK: usize = 4096;

/// Triangular factor of the stacked regression `[X | Y]` over all records, accumulated
/// block by block (`R <- qr([R; Z_block]).R`).
fn triangular_factor(
    records: &[&Record],
    layout: &Layout,
    s: &Scales,
) -> Result<DMatrix<f64>, LinalgError> {
    let (r, m, q, p) = (layout.r, layout.m, layout.q, layout.p);
    let ncols = layout.columns(p);
    let width = ncols + m;
    let mut rfac = DMatrix::<f64>::zeros(0, width);
    for rec in records {
        let rows = rec.len() - q;
        let u = |ch: usize, n: usize| rec.inputs[(ch, n)] / s.u[ch];
        let y = |ch: usize, n: usize| rec.outputs[(ch, n)] / s.y[ch];
        let mut start = layout.skip;
        while start < rows {
            let len = (rows - start).min(ROWS_PER_BLOCK);
            let top = rfac.nrows();
            let mut z = DMatrix::<f64>::zeros(top + len, width);
            z.view_mut((0, 0), (top, width)).copy_from(&rfac);
            for row in 0..len {
                let n = start + row;
                let zr = top + row;
                debug_assert!(n < rows);
                for t in 0..q {
                    for ch in 0..r {
                        z[(zr, t * r + ch)] = u(ch, n + q - t);
                    }
                }
                for ch in 0..r {
                    z[(zr, q * r + ch)] = u(ch, n);
                }
                for i in 1..=p.min(n) {
                    let base = (q + 1) * r + (i - 1) * (r + m);
                    for ch in 0..r {
                        z[(zr, base + ch)] = u(ch, n - i);
                    }
                    for ch in 0..m {
                        z[(zr, base + r + ch)] = y(ch, n - i);
                    }
                }
                for ch in 0..m {
                    z[(zr, ncols + ch)] = y(ch, n);
                }
            }
            rfac = QR::new(z).unpack_r();
            start += len;
        }
    }
    if let Some((row, col)) = linalg::first_non_finite(&rfac) {
        return Err(LinalgError::NonFinite {
            what: "OKID triangular factor",
            row,
            col,
        });
    }
    Ok(rfac)
}

/// Companion matrix of the autoregressive part `y[n] = sum_i b_i y[n-i]`: block row 0 is
/// `[b_1 .. b_p]`, identity blocks below the block diagonal (`mp x mp`).
#[cfg(test)]
fn companion(b: &[DMatrix<f64>], m: usize) -> DMatrix<f64> {
    let p = b.len();
    let mut c = DMatrix::zeros(m * p, m * p);
    for (i, bi) in b.iter().enumerate() {
        c.view_mut((0, i * m), (m, m)).copy_from(bi);
    }
    for i in 1..p {
        for j in 0..m {
            c[(i * m + j, (i - 1) * m + j)] = 1.0;
        }
    }
    c
}

/// The companion matrix (`companion` in the tests) transposed and with its indices permuted,
/// a similarity (the same eigenvalues), laid out for the Hessenberg reduction of
/// [`linalg::spectral_radius`]: index `i m + j` (lag block `i`, output `j`) goes to position
/// `j p + p - 1 - i`. The identity blocks then sit on the subdiagonal, one chain of `p`
/// positions per output, and the only entries below it are those of the `m` columns of the
/// coefficients (column `j2` at position `j2 p + p - 1` holds `b_{i+1}[j2, j1]` in the row
/// of index `i m + j1`). The reduction skips every column with nothing below the subdiagonal,
/// so it starts at column `p - 1` and reduces a trailing block of `(m - 1) p + 1` instead of
/// the whole matrix.
fn companion_for_radius(b: &[DMatrix<f64>], m: usize) -> DMatrix<f64> {
    let p = b.len();
    let pos = |i: usize, j: usize| j * p + p - 1 - i;
    let mut c = DMatrix::zeros(m * p, m * p);
    for (i, bi) in b.iter().enumerate() {
        for j2 in 0..m {
            for j1 in 0..m {
                c[(pos(i, j1), pos(0, j2))] = bi[(j2, j1)];
            }
        }
    }
    for i in 1..p {
        for j in 0..m {
            c[(pos(i - 1, j), pos(i, j))] = 1.0;
        }
    }
    c
}
