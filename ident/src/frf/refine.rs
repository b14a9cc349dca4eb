//! Maximum-likelihood refinement of M, K and damping on the measured FRFs themselves, with
//! standard errors: the FRF counterpart of [`crate::refine`] (same parametrization, model
//! derivatives, Levenberg–Marquardt and uncertainty propagation).
//!
//! ```no_run
//! use ident::frf::refine::{FrfRefiner, FrfStart};
//! use ident::frf::{Frf, FrfIdentifier};
//! use ident::refine::Parametrization;
//! use ident::CollocatedPair;
//! # fn frf() -> Frf { unimplemented!() }
//! let frf = frf();
//! let collocated = CollocatedPair::default();
//! let id = FrfIdentifier::default().collocated(collocated.output, collocated.input).identify(&frf)?;
//! let start = FrfStart::from_identification(&id, collocated)?;
//! let refined = FrfRefiner::default()
//!     .parametrization(Parametrization::shear_frame())
//!     .refine(&frf, &start)?;
//! println!("damping = {} +- {}", refined.damping, refined.uncertainty.damping_std);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! # Model
//!
//! Forces at the DOFs `reference_dofs` (`B2` of unit columns), responses at every DOF
//! (output `i` is DOF `i`), FRFs of derivative order `d` ([`FrfQuantity::derivative_order`]):
//!
//! ```text
//! H(w) = s^d (K + s^2 M + s damping)^-1 B2 + sum_t E_t (i w)^(n_t),   s = i w + 1/tau
//! ```
//!
//! (`1/tau = 0` without an exponential window; with one, the model is the windowed FRF, as
//! in [`super::identify`]). `M`, `K` and `damping` are linear in the physical parameters
//! ([`Parametrization`]), so `dH = -s^d f_p Q^-1 E_p Q^-1 B2` exactly, with `f_p = s^2`, `1`
//! or `s` for a mass, stiffness or damping parameter of basis `E_p`.
//!
//! # Modes outside the model
//!
//! Both of LSFD's devices are used, each for what it can represent:
//!
//! * *Out-of-band* modes: the real residual matrices `E_t` (outputs x references) of the
//!   lower (`n_t = d - 2`) and upper (`n_t = d`) residual terms ([`ResidualTerms`], default
//!   upper only: a frame fixed to the ground has no mode below its first, higher modes of a
//!   real structure act as a flexibility). They are extra linear parameters eliminated by
//!   variable projection per output and reference (Golub and Pereyra; Kaufman's Jacobian
//!   and Schur complement, as [`crate::refine`] does with its transients): for given
//!   physical parameters they are the weighted least-squares solution, the Gauss-Newton
//!   matrix is the information about the physical parameters with them eliminated, and the
//!   standard errors account for them. They are reported in
//!   [`FrfRefinement::residual_terms`]. Unlike LSFD the accelerance has no free constant:
//!   its high-frequency value `M^-1 B2` is part of the second-order model.
//! * *In-band* modes left out of the `n`-DOF model (the out-of-model modes of an
//!   [`FrfIdentification`]) cannot be represented by smooth residual terms. Their LSFD
//!   partial fractions `A_j / (i w - lambda_j) + conj` are subtracted from the data
//!   ([`FrfStart::subtracted_modes`], filled by [`FrfStart::from_identification`]). Their
//!   estimation error is then neglected (it is small when LSFD fits them on many lines).
//!
//! Lines at 0 Hz are never used: an accelerance or mobility is 0 there and an analyzer's
//! DC line carries no information about the modes.
//!
//! # Noise model
//!
//! Each FRF value has circular complex Gaussian error of variance `V = E |Ĥ - H|^2` (half in
//! the real part, half in the imaginary part), independent between lines, outputs and
//! references. The cost is `sum 2 |e|^2 / V` over the values used (`e` the residual):
//! twice the negative log-likelihood up to a constant, each of its real terms of unit
//! variance at the truth, as in [`crate::refine`].
//!
//! **From the coherence and the number of averages** ([`FrfNoise::Coherence`]). An H1
//! estimate from `n_d` averages (hits or Welch segments) with noise `N` on the response,
//! `Y_i = H X_i + N_i`, is `Ĥ = sum_i Y_i X_i^* / sum_i |X_i|^2 = H + sum_i N_i X_i^* /
//! sum_i |X_i|^2`. For independent circular noise spectra of variance `G_nn`, given the
//! forces, its error is circular with `E |Ĥ - H|^2 = G_nn / (n_d Ĝ_xx)`, `Ĝ_xx = sum_i
//! |X_i|^2 / n_d`. The ordinary coherence `γ² = |Ĝ_xy|^2 / (Ĝ_xx Ĝ_yy)` gives `|Ĥ|^2 = γ²
//! Ĝ_yy / Ĝ_xx`, and `(1 - γ²) Ĝ_yy = sum_i |Y_i - Ĥ X_i|^2 / n_d` is the residual spectrum
//! of that regression, of expectation `(n_d - 1) G_nn / n_d` (one complex degree of freedom
//! spent on `Ĥ`). Hence the unbiased estimate
//!
//! ```text
//! V = (1 - γ²) |Ĥ|^2 / ((n_d - 1) γ²)          (n_d >= 2)
//! ```
//!
//! Bendat and Piersol (*Random Data*, 4th ed., Wiley 2010, ch. 9, random errors of
//! frequency response estimates) give the same to first order in `1 / n_d`: a normalized
//! random error `sqrt(1 - γ²) / (|γ| sqrt(2 n_d))` of `|Ĥ|` and the same standard deviation
//! (rad) of its phase, i.e. `V = (1 - γ²) |H|^2 / (n_d γ²)` split equally between the
//! magnitude (real) and phase (imaginary) directions; the `n_d - 1` is the exact residual
//! degrees of freedom (Pintelon and Schoukens, *System Identification*, 2nd ed., 2012,
//! ch. 2, sample variance of the FRF). Because `V` is the residual spectrum over `Ĝ_xx`,
//! it is statistically independent of `Ĥ` for Gaussian noise (the residual of a linear
//! least-squares fit is independent of its estimate), so weighting with the measured `Ĥ`
//! does not bias the fit. It assumes noise on the responses only (force noise biases H1
//! instead) and one reference per test or uncorrelated references (so that the ordinary
//! coherence is the relevant one).
//!
//! **The variance is itself estimated.** Given the forces, `(1 - γ²) Ĝ_yy n_d / G_nn` is
//! chi-square with `2 nu` degrees of freedom over 2, `nu = n_d - 1`: `V = V_true u` with
//! `u ~ chi2(2 nu) / (2 nu)` independent of `Ĥ`. Weighting with such variances keeps the
//! estimate unbiased, but over many lines (first order, the usual sandwich with
//! independent `u` per value) the cost's expectation is `E[1/u] = nu / (nu - 1)` times
//! `observations - unknowns`, its variance `4 E[1/u^2] - 2 E[1/u]^2` times that (each
//! complex value's term is `chi2(2) / u`; the variance is 2 for exact variances), and the
//! estimate's covariance is `E[1/u^2] / E[1/u] = nu / (nu - 2)` times the inverse of the
//! weighted Gauss-Newton matrix, `E[1/u^2] = nu^2 / ((nu - 1) (nu - 2))`. The standard
//! errors are scaled by `sqrt(nu / (nu - 2))` accordingly ([`FrfRefinement::uncertainty`]);
//! with 2 or 3 averages that factor and the cost's variance are infinite (with 2 its
//! expectation too): a [`FrfRefineWarning::FewAverages`] is raised instead (standard
//! errors unscaled, too small) and the cost is not tested. The efficiency lost to the
//! noisy weights is `(nu - 1) / (nu - 2)` in variance (14 % with 10 averages). With
//! [`FrfNoise::CoherenceScaled`] the number of averages is unknown: the estimated scale
//! absorbs `E[1/u]`, but the standard errors stay too small by that last factor in
//! variance.
//!
//! Floors: `1 - γ²` is floored at [`FrfRefiner::coherence_floor`] (default `1e-6`, as
//! [`super::Weighting::Coherence`]: a value is never trusted beyond a signal-to-noise
//! power ratio of `1e6` per average, however close to 1 the coherence is; coherence 1,
//! e.g. of noise-free data, gives a finite, relative-error weight), and every variance is
//! at least `(1e-10 rms |Ĥ|)^2` of its output and reference over the band (the round-off
//! resolution of [`crate::refine`]), so that a value measured as exactly 0 does not get an
//! infinite weight. A coherence of 0 (no information) excludes the value (zero weight; not
//! counted as an observation).
//!
//! **Estimated** ([`FrfNoise::PerOutput`], [`FrfNoise::PerPair`], and
//! [`FrfNoise::CoherenceScaled`] for coherence without averages): `V = sigma_g^2 v` with a
//! known shape `v` (1, or `(1 - γ²) |Ĥ|^2 / γ²`) and one unknown variance per group
//! (output, output/reference pair, or one for all). Maximizing the likelihood over
//! `sigma_g^2` for given parameters gives `sigma_g^2 = sum_g |e|^2 / v / N_g` (`N_g` complex
//! values in the group) and the concentrated cost `sum_g N_g log(sum_g |e|^2 / v)`; its
//! minimum is the fixed point of the alternation used here (weighted refinement, variances
//! from its residuals), as [`crate::refine::NoiseModel::Estimate`] does, until the variances
//! change by less than [`crate::refine::NOISE_CHANGE_TOLERANCE`]. The variances are
//! corrected for the degrees of freedom used (`observations / (observations - unknowns)`),
//! and the standard errors are computed with them: `(J^T W J)^-1`, the usual `s^2 (J^T
//! J)^-1` of nonlinear least squares for one group.
//!
//! # Optimizer and start
//!
//! Levenberg–Marquardt of [`crate::refine`] on the physical parameters. As there, the
//! first run weighs the values by the residuals of the start (mostly model error): variance
//! `a + b |Ĥ|^2` per output and reference, `a` the median of `|e|^2` over the band and `b`
//! the median of `|e|^2 / |Ĥ|^2`, a relative-error fit near the resonances whose cost is
//! far smoother than an absolute fit of sharp peaks at slightly wrong frequencies. The
//! noise model then takes over, with tight tolerances in the last run. The start is
//! usually MKR's M and K with the Rayleigh damping ([`FrfStart::from_identification`]).

use super::identify::FrfIdentification;
use super::lsfd::ResidualTerms;
use super::{Frf, FrfError, FrfQuantity};
use crate::linalg::{self, C64};
use crate::mkr::{CollocatedPair, MatrixKind};
use crate::modal::Intersample;
use crate::refine::likelihood::{NOISE_RESOLUTION, eliminate_nuisance, spd_inverse};
use crate::refine::model::Model;
use crate::refine::{
    LOOSE_TOLERANCE, NOISE_CHANGE_TOLERANCE, Parameter, Parametrization, RefineError, SecondOrder,
    StopReason, Uncertainty, dense, lm, param, uncertainty,
};
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// Default floor of `1 - γ²` (see the module docs).
pub const COHERENCE_FLOOR: f64 = 1e-6;

/// Smallest dominance (`|B2[dof, l]| / ||B2[:, l]||` of the estimated input matrix) of a
/// reference DOF derived by [`FrfStart::from_identification`] before a warning: an exact
/// model gives 1, a reference between two floors about 0.7.
pub const REFERENCE_DOMINANCE_WARNING: f64 = 0.8;

/// Where the variance of each FRF value comes from (see the module docs).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub enum FrfNoise {
    /// [`FrfNoise::Coherence`] when the FRFs carry coherence and at least 2 averages,
    /// [`FrfNoise::CoherenceScaled`] with coherence alone, else [`FrfNoise::PerOutput`].
    #[default]
    Auto,
    /// `(1 - γ²) |Ĥ|^2 / ((n_d - 1) γ²)` from [`Frf::coherence`] and [`Frf::averages`]
    /// (`n_d >= 2`); nothing is estimated.
    Coherence,
    /// Shape `(1 - γ²) |Ĥ|^2 / γ²` from the coherence, one scale for all values estimated
    /// (the number of averages unknown or not trusted).
    CoherenceScaled,
    /// One variance per output, the same on every line and reference, estimated.
    PerOutput,
    /// One variance per output and reference, estimated.
    PerPair,
    /// Given variances `E |Ĥ - H|^2` (quantity's unit squared), one `outputs x
    /// references` matrix per line of the FRF set (all lines, not only the band); positive,
    /// `+inf` excludes a value.
    Known(Vec<DMatrix<f64>>),
}

/// The noise model actually used.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum NoiseSource {
    /// Coherence and this number of averages.
    Coherence {
        /// `n_d`.
        averages: usize,
    },
    /// Coherence shape, one estimated scale.
    CoherenceScaled,
    /// One estimated variance per output.
    PerOutput,
    /// One estimated variance per output and reference.
    PerPair,
    /// Given variances.
    Known,
}

impl NoiseSource {
    fn estimated(self) -> bool {
        matches!(
            self,
            NoiseSource::CoherenceScaled | NoiseSource::PerOutput | NoiseSource::PerPair
        )
    }
}

/// Noise model of a refinement and what it found.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FrfNoiseReport {
    /// The model used.
    pub source: NoiseSource,
    /// Per output and reference (outputs x references), the factor `sigma_g^2` of the
    /// variance: the variance itself for [`NoiseSource::PerOutput`] and
    /// [`NoiseSource::PerPair`] (quantity's unit squared), the factor of `(1 - γ²) |Ĥ|^2 /
    /// γ²` for the coherence models (`1 / (n_d - 1)` when given), 1 for given variances.
    pub scale: DMatrix<f64>,
    /// Values whose `1 - γ²` was raised to the floor.
    pub coherence_floored: usize,
    /// Values excluded (coherence 0 or infinite given variance).
    pub excluded: usize,
}

/// Refinement parameters. `FrfRefiner::default()` plus setters covers common use.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FrfRefiner {
    /// Physical parameters estimated.
    pub parametrization: Parametrization,
    /// Band (Hz) of the lines used; `None` for the start's band ([`FrfStart::band_hz`]),
    /// or every line if that is `None` too.
    pub band_hz: Option<(f64, f64)>,
    /// Residual terms for the modes outside the band.
    pub residuals: ResidualTerms,
    /// Noise model.
    pub noise: FrfNoise,
    /// Floor of `1 - γ²`, in `(0, 1)`.
    pub coherence_floor: f64,
    /// Levenberg–Marquardt step limit per run.
    pub max_iterations: usize,
    /// Gradient (cosine) tolerance.
    pub gradient_tolerance: f64,
    /// Relative step tolerance.
    pub step_tolerance: f64,
    /// Relative cost-reduction tolerance.
    pub cost_tolerance: f64,
    /// Largest number of noise estimations (estimated noise only, at least 1).
    pub max_noise_updates: usize,
}

impl Default for FrfRefiner {
    fn default() -> Self {
        Self {
            parametrization: Parametrization::Full,
            band_hz: None,
            residuals: ResidualTerms {
                lower: false,
                upper: true,
            },
            noise: FrfNoise::Auto,
            coherence_floor: COHERENCE_FLOOR,
            max_iterations: 100,
            gradient_tolerance: 1e-10,
            step_tolerance: 1e-10,
            cost_tolerance: 1e-12,
            max_noise_updates: 4,
        }
    }
}

/// A partial fraction subtracted from the data before the refinement.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SubtractedMode {
    /// Pole (rad/s, `Im > 0`) as it appears in the FRFs (with an exponential window, the
    /// windowed pole).
    pub pole: C64,
    /// Residue `A` in the FRFs' quantity (outputs x references): the term is `A / (i w -
    /// pole) + conj(A) / (i w - conj(pole))`.
    pub residue: DMatrix<C64>,
}

/// Where a refinement starts and what it assumes about the test.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FrfStart {
    /// Initial M, K and damping (projected on the parametrization).
    pub initial: SecondOrder,
    /// DOF (0-based floor) each reference force acts on, one per reference.
    pub reference_dofs: Vec<usize>,
    /// Band (Hz) to use unless [`FrfRefiner::band_hz`] is set; `None` for every line.
    pub band_hz: Option<(f64, f64)>,
    /// Whether the FRFs are negated first (inverted polarity found by MKR).
    pub negate: bool,
    /// `1 / tau` (1/s) of an exponential window on the records, 0 without.
    pub decay_per_s: f64,
    /// In-band modes outside the model, subtracted from the (negated, if so) data.
    pub subtracted_modes: Vec<SubtractedMode>,
    /// Warnings about the start, passed on to the result.
    pub warnings: Vec<FrfRefineWarning>,
}

impl FrfStart {
    /// Starts from `initial` with forces at `reference_dofs`; nothing subtracted, no
    /// window, every line (unless the refiner has a band).
    pub fn new(initial: SecondOrder, reference_dofs: Vec<usize>) -> Self {
        Self {
            initial,
            reference_dofs,
            band_hz: None,
            negate: false,
            decay_per_s: 0.0,
            subtracted_modes: Vec::new(),
            warnings: Vec::new(),
        }
    }

    /// The start from an FRF identification made with the collocated pair `collocated`,
    /// as the time route starts from [`SecondOrder::from_identification`]: MKR's M and K
    /// with the Rayleigh damping, LSFD's band, MKR's polarity, the exponential window and
    /// the out-of-model modes (subtracted). The collocated reference acts on the
    /// collocated output's DOF; every other reference on the DOF where the estimated
    /// input matrix `B2 = M D` is largest, `D = M^-1 B2` being the accelerance's fitted
    /// constant (accelerance data) or `2 Re sum_j lambda_j R_j` over the MKR modes (as
    /// MKR's driving-point check uses), with a [`FrfRefineWarning::ReferenceDof`] below
    /// [`REFERENCE_DOMINANCE_WARNING`].
    pub fn from_identification(
        id: &FrfIdentification,
        collocated: CollocatedPair,
    ) -> Result<Self, FrfRefineError> {
        let n = id.mass.nrows();
        let r = id.lsfd.residues.first().map_or(0, |a| a.ncols());
        if collocated.output >= n || collocated.input >= r {
            return Err(FrfRefineError::Shape {
                reason: format!(
                    "collocated pair (output {}, reference {}) is out of range for {n} outputs and {r} references",
                    collocated.output, collocated.input
                ),
            });
        }
        let d = match (id.quantity, id.lsfd.residual(0)) {
            (FrfQuantity::Accelerance, Some(direct)) => direct.clone(),
            _ => {
                let mut d = DMatrix::<f64>::zeros(n, r);
                for &j in &id.mkr_modes {
                    let md = &id.modes[j];
                    d += md.residue.map(|x| 2.0 * (x / md.pole).re);
                }
                d
            }
        };
        let b2 = &id.mass * d;
        let mut reference_dofs = Vec::with_capacity(r);
        let mut warnings = Vec::new();
        for l in 0..r {
            let column = b2.column(l);
            let (best, _) = column.iter().enumerate().fold((0, -1.0), |a, (i, v)| {
                if v.abs() > a.1 { (i, v.abs()) } else { a }
            });
            let dof = if l == collocated.input {
                collocated.output
            } else {
                best
            };
            let norm = column.norm();
            let dominance = if norm > 0.0 {
                column[dof].abs() / norm
            } else {
                0.0
            };
            if dominance < REFERENCE_DOMINANCE_WARNING {
                warnings.push(FrfRefineWarning::ReferenceDof {
                    reference: l,
                    dof,
                    dominance,
                });
            }
            reference_dofs.push(dof);
        }
        Ok(Self {
            initial: SecondOrder::new(
                id.mass.clone(),
                id.stiffness.clone(),
                id.damping_rayleigh.clone(),
            ),
            reference_dofs,
            band_hz: Some(id.lsfd.band_hz),
            negate: id.polarity_flipped,
            decay_per_s: id.exponential_tau_s.map_or(0.0, |tau| 1.0 / tau),
            subtracted_modes: id
                .out_of_model
                .iter()
                .map(|&j| SubtractedMode {
                    pole: id.lsfd.poles[j],
                    residue: id.lsfd.residues[j].clone(),
                })
                .collect(),
            warnings,
        })
    }
}

/// Something the caller should know about a refinement (the result is still returned).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub enum FrfRefineWarning {
    /// The optimizer stopped without converging.
    NotConverged {
        /// Why it stopped.
        stop: StopReason,
    },
    /// With given noise (coherence and at least 4 averages, or known variances), the final
    /// cost is far above its expectation (more than 5 of its standard deviations, `sqrt(2
    /// (observations - unknowns))` for known variances, `sqrt((observations - unknowns) (4
    /// E[1/u^2] - 2 E[1/u]^2))` for variances from the coherence, see the module docs): the
    /// model misses something (a mode, a residual term, nonlinearity) or the variances are
    /// too small; the standard errors are then too small too. Not tested with 2 or 3
    /// averages, where the cost's variance is infinite.
    CostAboveExpectation {
        /// Final cost.
        cost: f64,
        /// `observations - unknowns`, times `nu / (nu - 1)` for variances from the
        /// coherence (see the module docs).
        expected: f64,
    },
    /// Variances from the coherence of fewer than 4 averages: so noisy that the
    /// covariance of the estimate is not finite to first order; the standard errors are
    /// not scaled (and too small).
    FewAverages {
        /// `n_d`.
        averages: usize,
    },
    /// A reference DOF derived from the identification is not clear-cut.
    ReferenceDof {
        /// Reference (0-based column of the FRFs).
        reference: usize,
        /// DOF chosen (0-based floor).
        dof: usize,
        /// `|B2[dof, l]| / ||B2[:, l]||` of the estimated input matrix (1 when exact).
        dominance: f64,
    },
    /// A refined mode has a negative damping ratio: a pole in the right half-plane, an
    /// unstable model, which no passive structure is. Usually a lightly damped mode whose
    /// damping the data do not determine to its sign (the damping ratio within a few
    /// standard errors of 0); the model is then no use for simulation. One per such mode.
    NegativeDamping {
        /// Mode (0-based, ascending frequency, as in [`Uncertainty::modes`]).
        mode: usize,
        /// Its damping ratio (negative).
        damping_ratio: f64,
        /// Its standard error.
        damping_ratio_std: f64,
    },
    /// The refined model has fewer oscillatory modes than DOFs (an overdamped pair of
    /// real poles): from a poor start, a local minimum.
    OverdampedModes {
        /// Oscillatory modes found.
        oscillatory: usize,
        /// DOFs.
        dofs: usize,
    },
    /// The alternation of noise fit and refinement stopped at
    /// [`FrfRefiner::max_noise_updates`] while the estimated levels still moved: the weights,
    /// and so the estimate and its standard errors, are not those of its fixed point. Not
    /// raised when the final residuals are below `1e-8` of the data (noise-free FRFs: any
    /// weights give the same exact fit, and the "levels" shrink with the residuals from one
    /// update to the next).
    NoiseNotSettled {
        /// Re-estimations done.
        updates: usize,
        /// Largest relative change of a level at the last one (`None` after a single
        /// re-estimation, which has no earlier estimate to compare with).
        change: Option<f64>,
    },
}

/// Result of a refinement on FRFs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FrfRefinement {
    /// Refined mass matrix (kg).
    pub mass: DMatrix<f64>,
    /// Refined stiffness matrix (N/m).
    pub stiffness: DMatrix<f64>,
    /// Refined damping matrix (N s/m).
    pub damping: DMatrix<f64>,
    /// Refined parameters (see `uncertainty.labels`).
    pub parameters: DVector<f64>,
    /// Standard errors from the Gauss-Newton (Fisher) matrix at the estimate, residual
    /// terms eliminated, and the refined modal parameters with theirs. With variances
    /// from the coherence and `n_d >= 4` averages, `fisher` is the weighted Gauss-Newton
    /// matrix divided by `nu / (nu - 2)`, `nu = n_d - 1` (see the module docs).
    pub uncertainty: Uncertainty,
    /// Noise model and variances used by the final cost.
    pub noise: FrfNoiseReport,
    /// DOF of each reference force.
    pub reference_dofs: Vec<usize>,
    /// Powers of `i w` of the residual terms, ascending.
    pub residual_powers: Vec<i32>,
    /// Real coefficient matrix (outputs x references) of each residual power.
    pub residual_terms: Vec<DMatrix<f64>>,
    /// First and last line used, Hz.
    pub band_hz: (f64, f64),
    /// Lines used.
    pub lines: usize,
    /// Final cost `sum 2 |e|^2 / V` (about `observations - unknowns` when model and
    /// variances are right).
    pub cost: f64,
    /// Cost of the start with the final variances.
    pub initial_cost: f64,
    /// Real observations (real and imaginary parts of every value used).
    pub observations: usize,
    /// Unknowns: physical parameters plus residual coefficients.
    pub unknowns: usize,
    /// Levenberg–Marquardt steps tried, over all runs.
    pub iterations: usize,
    /// Noise re-estimations done.
    pub noise_updates: usize,
    /// Why the last run stopped.
    pub stop: StopReason,
    /// Warnings, in the order they arose (the start's first).
    pub warnings: Vec<FrfRefineWarning>,
}

/// Ways a refinement on FRFs can fail.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum FrfRefineError {
    /// A refinement parameter is out of range.
    #[error("invalid FRF refinement parameter {field}: {reason}")]
    InvalidParams {
        /// The parameter.
        field: &'static str,
        /// What is wrong.
        reason: String,
    },
    /// The FRF set is unusable.
    #[error(transparent)]
    Frf(#[from] FrfError),
    /// The FRFs, the start and the reference DOFs do not fit together.
    #[error("FRF refinement: {reason}")]
    Shape {
        /// What disagrees.
        reason: String,
    },
    /// The band has too few values for the unknowns.
    #[error(
        "{lines} lines in the band {band_hz:?} Hz give {observations} real observations for {unknowns} unknowns"
    )]
    TooFewLines {
        /// Lines in the band (0 Hz excluded).
        lines: usize,
        /// Real observations they give.
        observations: usize,
        /// Physical parameters plus residual coefficients.
        unknowns: usize,
        /// The band.
        band_hz: (f64, f64),
    },
    /// The FRF of a response/reference pair is exactly 0 on every line of the band (a
    /// disconnected or unconnected channel): no model with positive definite M and K has
    /// such a response.
    #[error(
        "the FRF of output {output} to reference {reference} (0-based) is exactly 0 on every line of the band {band_hz:?} Hz"
    )]
    ZeroFrf {
        /// Output (0-based row of the FRFs).
        output: usize,
        /// Reference (0-based column of the FRFs).
        reference: usize,
        /// The band.
        band_hz: (f64, f64),
    },
    /// The noise model needs what the FRFs do not carry.
    #[error("noise model {model}: {reason}")]
    Noise {
        /// The model requested.
        model: &'static str,
        /// What is missing or wrong.
        reason: String,
    },
    /// The start has no finite FRF at a line (an undamped pole on the line).
    #[error("the start model has no finite FRF at {frequency_hz} Hz")]
    SingularModel {
        /// The line.
        frequency_hz: f64,
    },
    /// Parametrization, start matrices or Fisher information (as on the time route).
    #[error(transparent)]
    Refine(#[from] RefineError),
}

/// One line of the band.
struct Line {
    /// Index in the FRF set.
    index: usize,
    frequency_hz: f64,
    /// `i w + 1 / tau`.
    s: C64,
    /// `s^d`.
    sd: C64,
    /// `(i w)^(n_t)` per residual power.
    regressors: Vec<C64>,
}

/// Residual RMS of an output and reference, relative to the RMS of its data, at or below
/// which a fit is exact: the residuals measure no noise. At the end of
/// `noise_free_frfs_give_the_frame_from_a_perturbed_start`'s refinements (noise-free FRFs)
/// the estimates are within 5e-11 of the truth; any measured FRF is far noisier (a 24-bit
/// converter's quantization step is 6e-8 of its range).
const EXACT_FIT: f64 = 1e-8;

/// Whether some output and reference's residuals (per line, as kept by an evaluation) are
/// above [`EXACT_FIT`] of its data: the residuals then measure noise.
fn above_exact_fit(problem: &Problem, residuals: &[DMatrix<C64>]) -> bool {
    let lines = residuals.len().max(1) as f64;
    (0..problem.r).any(|l| {
        (0..problem.n).any(|i| {
            let power = residuals.iter().map(|e| e[(i, l)].norm_sqr()).sum::<f64>() / lines;
            power.sqrt() > EXACT_FIT * problem.rms[(i, l)]
        })
    })
}

/// Everything fixed for one refinement.
struct Problem {
    params: Vec<Parameter>,
    bases: Vec<DMatrix<C64>>,
    n: usize,
    r: usize,
    dofs: Vec<usize>,
    lines: Vec<Line>,
    /// Data per line (n x r), negated and with the subtracted modes removed.
    data: Vec<DMatrix<C64>>,
    powers: Vec<i32>,
    /// RMS of `|data|` per output and reference over the band.
    rms: DMatrix<f64>,
}

/// One evaluation of the projected cost.
struct Evaluation {
    cost: f64,
    fisher: Option<DMatrix<f64>>,
    gradient: Option<DVector<f64>>,
    /// Residual coefficients per pair `i + l n`.
    xi: Vec<DVector<f64>>,
    /// Unweighted residuals per line (n x r), residual terms removed, if kept.
    residuals: Option<Vec<DMatrix<C64>>>,
}

impl Problem {
    fn pairs(&self) -> usize {
        self.n * self.r
    }

    /// Frequency of the first line where the model at `theta` has no finite FRF (the
    /// first line if none: the failure was elsewhere).
    fn first_singular_line(&self, theta: &DVector<f64>) -> f64 {
        let n = self.n;
        let (mass, stiffness, damping) = param::matrices(&self.params, theta, n);
        let zero = C64::new(0.0, 0.0);
        let mut q = vec![zero; n * n];
        let mut qi = vec![zero; n * n];
        for line in &self.lines {
            let s = line.s;
            for j in 0..n {
                for i in 0..n {
                    q[i + j * n] = stiffness[(i, j)] + s * s * mass[(i, j)] + s * damping[(i, j)];
                }
            }
            if !dense::invert(&mut q, n, &mut qi)
                || qi.iter().any(|v| !(v.re.is_finite() && v.im.is_finite()))
            {
                return line.frequency_hz;
            }
        }
        self.lines[0].frequency_hz
    }

    /// The projected cost at `theta` with weights `weights[k][(i, l)] = sqrt(2 / V)` (0
    /// excludes a value); `None` if M or K is not positive definite or the FRF is not
    /// finite.
    fn evaluate(
        &self,
        theta: &DVector<f64>,
        weights: &[DMatrix<f64>],
        jacobian: bool,
        keep_residuals: bool,
    ) -> Option<Evaluation> {
        let (n, r) = (self.n, self.r);
        let np = self.params.len();
        let nt = self.powers.len();
        let rows = 2 * self.lines.len();
        let (mass, stiffness, damping) = param::matrices(&self.params, theta, n);
        if linalg::first_non_finite(&mass).is_some()
            || linalg::first_non_finite(&stiffness).is_some()
            || linalg::first_non_finite(&damping).is_some()
            || linalg::cholesky(&mass).is_err()
            || linalg::cholesky(&stiffness).is_err()
        {
            return None;
        }
        let pairs = self.pairs();
        let mut rt = vec![DVector::<f64>::zeros(rows); pairs];
        let mut xt = vec![DMatrix::<f64>::zeros(nt, rows); pairs];
        let mut jt = if jacobian {
            vec![DMatrix::<f64>::zeros(np, rows); pairs]
        } else {
            Vec::new()
        };
        let mut model_values = keep_residuals.then(|| Vec::with_capacity(self.lines.len()));
        let zero = C64::new(0.0, 0.0);
        let mut q = vec![zero; n * n];
        let mut qi = vec![zero; n * n];
        let mut g = vec![zero; n * r];
        let mut eg = vec![zero; n * r];
        let mut z = vec![zero; n * r];
        for (k, line) in self.lines.iter().enumerate() {
            let s = line.s;
            let s2 = s * s;
            for j in 0..n {
                for i in 0..n {
                    q[i + j * n] = stiffness[(i, j)] + s2 * mass[(i, j)] + s * damping[(i, j)];
                }
            }
            if !dense::invert(&mut q, n, &mut qi) {
                return None;
            }
            for l in 0..r {
                for i in 0..n {
                    g[i + l * n] = qi[i + self.dofs[l] * n];
                }
            }
            let w = &weights[k];
            let data = &self.data[k];
            for l in 0..r {
                for i in 0..n {
                    let c = w[(i, l)];
                    let h = line.sd * g[i + l * n];
                    if !(h.re.is_finite() && h.im.is_finite()) {
                        return None;
                    }
                    if c == 0.0 {
                        continue;
                    }
                    let e = data[(i, l)] - h;
                    let pair = i + l * n;
                    rt[pair][2 * k] = c * e.re;
                    rt[pair][2 * k + 1] = c * e.im;
                    for (t, reg) in line.regressors.iter().enumerate() {
                        xt[pair][(t, 2 * k)] = c * reg.re;
                        xt[pair][(t, 2 * k + 1)] = c * reg.im;
                    }
                }
            }
            if let Some(values) = model_values.as_mut() {
                values.push(DMatrix::from_fn(n, r, |i, l| line.sd * g[i + l * n]));
            }
            if jacobian {
                for p in 0..np {
                    // dr = -c dH = c s^d f_p Q^-1 E_p Q^-1 B2.
                    let f = match self.params[p].matrix {
                        MatrixKind::Mass => s2,
                        MatrixKind::Stiffness => C64::new(1.0, 0.0),
                        MatrixKind::Damping => s,
                    };
                    dense::mul(self.bases[p].as_slice(), n, n, &g, r, &mut eg);
                    dense::mul(&qi, n, n, &eg, r, &mut z);
                    let factor = line.sd * f;
                    for l in 0..r {
                        for i in 0..n {
                            let c = w[(i, l)];
                            if c == 0.0 {
                                continue;
                            }
                            let v = factor * z[i + l * n] * c;
                            let jp = &mut jt[i + l * n];
                            jp[(p, 2 * k)] = v.re;
                            jp[(p, 2 * k + 1)] = v.im;
                        }
                    }
                }
            }
        }
        let mut cost = 0.0;
        let mut xi = Vec::with_capacity(pairs);
        let mut fisher = DMatrix::zeros(np, np);
        let mut gradient = DVector::zeros(np);
        for pair in 0..pairs {
            let res = &mut rt[pair];
            let xtx_inv = if nt > 0 {
                let x = &xt[pair];
                let xtx_inv = spd_inverse(&(x * x.transpose()));
                let mut sol = &xtx_inv * (x * &*res);
                *res -= x.tr_mul(&sol);
                // One step of iterative refinement, as in `crate::refine`: the gradient
                // J^T r is exact only for r orthogonal to X.
                let correction = &xtx_inv * (x * &*res);
                *res -= x.tr_mul(&correction);
                sol += correction;
                xi.push(sol);
                Some(xtx_inv)
            } else {
                xi.push(DVector::zeros(0));
                None
            };
            cost += res.norm_squared();
            if jacobian {
                let j = &jt[pair];
                let (f, g) = match &xtx_inv {
                    Some(inv) => eliminate_nuisance(j, &xt[pair], inv, res),
                    None => (j * j.transpose(), j * &*res),
                };
                fisher += f;
                gradient += g;
            }
        }
        if !cost.is_finite() {
            return None;
        }
        let residuals = model_values.map(|values| {
            self.lines
                .iter()
                .enumerate()
                .map(|(k, line)| {
                    DMatrix::from_fn(n, r, |i, l| {
                        let mut e = self.data[k][(i, l)] - values[k][(i, l)];
                        for (t, reg) in line.regressors.iter().enumerate() {
                            e -= reg * xi[i + l * n][t];
                        }
                        e
                    })
                })
                .collect()
        });
        Some(Evaluation {
            cost,
            fisher: jacobian.then_some(fisher),
            gradient: jacobian.then_some(gradient),
            xi,
            residuals,
        })
    }
}

/// Noise model resolved against the data: a variance shape per value and how its scale
/// is obtained.
struct Noise {
    source: NoiseSource,
    /// Per band line, `v` (n x r); `+inf` excludes the value.
    shape: Vec<DMatrix<f64>>,
    /// Group of each output and reference (n x r).
    group: DMatrix<usize>,
    groups: usize,
    /// Scale of each group: given, or a starting value to be estimated.
    scale: Vec<f64>,
    floored: usize,
    excluded: usize,
}

impl Noise {
    /// Weights `sqrt(2 / V)` per line for the current scales, variances floored at the
    /// round-off resolution.
    fn weights(&self, problem: &Problem) -> Vec<DMatrix<f64>> {
        self.shape
            .iter()
            .map(|v| {
                DMatrix::from_fn(problem.n, problem.r, |i, l| {
                    let shape = v[(i, l)];
                    if shape.is_infinite() {
                        return 0.0;
                    }
                    let floor = (NOISE_RESOLUTION * problem.rms[(i, l)]).powi(2);
                    let var = (shape * self.scale[self.group[(i, l)]]).max(floor);
                    if var > 0.0 { (2.0 / var).sqrt() } else { 0.0 }
                })
            })
            .collect()
    }

    /// Maximum-likelihood scales from unweighted residuals, corrected by `dof_factor`.
    fn estimate(&self, problem: &Problem, residuals: &[DMatrix<C64>], dof_factor: f64) -> Vec<f64> {
        let mut sum = vec![0.0; self.groups];
        let mut count = vec![0usize; self.groups];
        for (k, e) in residuals.iter().enumerate() {
            for l in 0..problem.r {
                for i in 0..problem.n {
                    let v = self.shape[k][(i, l)];
                    if v.is_finite() && v > 0.0 {
                        let g = self.group[(i, l)];
                        sum[g] += e[(i, l)].norm_sqr() / v;
                        count[g] += 1;
                    }
                }
            }
        }
        (0..self.groups)
            .map(|g| dof_factor * sum[g] / count[g].max(1) as f64)
            .collect()
    }

    fn report(&self, problem: &Problem) -> FrfNoiseReport {
        FrfNoiseReport {
            source: self.source,
            scale: DMatrix::from_fn(problem.n, problem.r, |i, l| self.scale[self.group[(i, l)]]),
            coherence_floored: self.floored,
            excluded: self.excluded,
        }
    }
}

/// Median of `v` (0 if empty).
fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    let mid = v.len() / 2;
    *v.select_nth_unstable_by(mid, f64::total_cmp).1
}

impl FrfRefiner {
    /// Sets the parametrization.
    pub fn parametrization(mut self, parametrization: Parametrization) -> Self {
        self.parametrization = parametrization;
        self
    }

    /// Sets the band (Hz).
    pub fn band_hz(mut self, lo: f64, hi: f64) -> Self {
        self.band_hz = Some((lo, hi));
        self
    }

    /// Sets the residual terms.
    pub fn residuals(mut self, residuals: ResidualTerms) -> Self {
        self.residuals = residuals;
        self
    }

    /// Sets the noise model.
    pub fn noise(mut self, noise: FrfNoise) -> Self {
        self.noise = noise;
        self
    }

    /// Sets the step limit per run.
    pub fn max_iterations(mut self, max_iterations: usize) -> Self {
        self.max_iterations = max_iterations;
        self
    }

    /// Validates the parameters that do not depend on the data.
    pub fn check(&self) -> Result<(), FrfRefineError> {
        let bad = |field: &'static str, reason: String| {
            Err(FrfRefineError::InvalidParams { field, reason })
        };
        if let Some((lo, hi)) = self.band_hz
            && !(lo.is_finite() && hi.is_finite() && lo >= 0.0 && hi > lo)
        {
            return bad(
                "band_hz",
                format!("({lo}, {hi}) Hz is not a band: need 0 <= f_min < f_max"),
            );
        }
        if !(self.coherence_floor > 0.0 && self.coherence_floor < 1.0) {
            return bad(
                "coherence_floor",
                format!("{} must be in (0, 1)", self.coherence_floor),
            );
        }
        for (field, v) in [
            ("gradient_tolerance", self.gradient_tolerance),
            ("step_tolerance", self.step_tolerance),
            ("cost_tolerance", self.cost_tolerance),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return bad(field, format!("{v} must be finite and non-negative"));
            }
        }
        if self.max_noise_updates == 0 {
            return bad("max_noise_updates", "must be at least 1".into());
        }
        Ok(())
    }

    /// Refines `start` on `frf` (every output a DOF, one reference DOF per reference).
    pub fn refine(&self, frf: &Frf, start: &FrfStart) -> Result<FrfRefinement, FrfRefineError> {
        self.check()?;
        frf.validate()?;
        let problem = self.problem(frf, start)?;
        let noise = self.resolve_noise(frf, &problem)?;
        let n = problem.n;
        let np = problem.params.len();
        let nt = problem.powers.len();
        let used: usize = noise
            .shape
            .iter()
            .map(|v| v.iter().filter(|x| x.is_finite()).count())
            .sum();
        let observations = 2 * used;
        let unknowns = np + nt * problem.pairs();
        let band_hz = (
            problem.lines[0].frequency_hz,
            problem.lines[problem.lines.len() - 1].frequency_hz,
        );
        if observations <= unknowns {
            return Err(FrfRefineError::TooFewLines {
                lines: problem.lines.len(),
                observations,
                unknowns,
                band_hz,
            });
        }
        let dof_factor = observations as f64 / (observations - unknowns) as f64;

        let initial = &start.initial;
        for (matrix, value) in [
            (MatrixKind::Mass, &initial.mass),
            (MatrixKind::Stiffness, &initial.stiffness),
            (MatrixKind::Damping, &initial.damping),
        ] {
            if linalg::first_non_finite(value).is_some() {
                return Err(RefineError::NonFiniteModel.into());
            }
            if matrix != MatrixKind::Damping
                && let Err((pivot, v)) = linalg::cholesky(value)
            {
                return Err(RefineError::NotPositiveDefinite {
                    matrix,
                    pivot,
                    value: v,
                }
                .into());
            }
        }
        let (theta0, _) = param::project(
            &problem.params,
            &initial.mass,
            &initial.stiffness,
            &initial.damping,
        );
        // The projection of positive definite matrices on a parametrization may not be.
        {
            let (mass, stiffness, _) = param::matrices(&problem.params, &theta0, n);
            for (matrix, value) in [(MatrixKind::Mass, mass), (MatrixKind::Stiffness, stiffness)] {
                if let Err((pivot, v)) = linalg::cholesky(&value) {
                    return Err(RefineError::NotPositiveDefinite {
                        matrix,
                        pivot,
                        value: v,
                    }
                    .into());
                }
            }
        }
        let singular = || FrfRefineError::SingularModel {
            frequency_hz: problem.first_singular_line(&theta0),
        };

        let strict = lm::Settings {
            max_iterations: self.max_iterations,
            gradient_tolerance: self.gradient_tolerance,
            step_tolerance: self.step_tolerance,
            cost_tolerance: self.cost_tolerance,
            decrease_tolerance: 0.0,
            damping_floor: lm::NIELSEN_FLOOR,
        };
        let loose = lm::Settings {
            gradient_tolerance: self.gradient_tolerance.max(LOOSE_TOLERANCE),
            step_tolerance: self.step_tolerance.max(LOOSE_TOLERANCE),
            cost_tolerance: self.cost_tolerance.max(LOOSE_TOLERANCE * LOOSE_TOLERANCE),
            ..strict
        };
        let run = |theta: DVector<f64>,
                   weights: &[DMatrix<f64>],
                   settings: lm::Settings,
                   mu: f64|
         -> Option<lm::Outcome<Evaluation>> {
            let eval = |t: &DVector<f64>| -> Option<lm::Point<Evaluation>> {
                let mut ev = problem.evaluate(t, weights, true, false)?;
                Some(lm::Point {
                    cost: ev.cost,
                    fisher: ev.fisher.take()?,
                    gradient: ev.gradient.take()?,
                    extra: ev,
                })
            };
            let start = eval(&theta)?;
            Some(lm::minimize(theta, start, settings, mu, |t, _| eval(t)))
        };

        // First run: weights from the start's residuals (see the module docs).
        let unit: Vec<DMatrix<f64>> = noise
            .shape
            .iter()
            .map(|v| v.map(|x| if x.is_finite() { 1.0 } else { 0.0 }))
            .collect();
        let ev0 = problem
            .evaluate(&theta0, &unit, false, true)
            .ok_or_else(singular)?;
        let robust = robust_weights(&problem, &noise, ev0.residuals.as_ref().expect("kept"));
        let mut outcome =
            run(theta0.clone(), &robust, loose, lm::INITIAL_DAMPING).ok_or_else(singular)?;
        let mut iterations = outcome.iterations;
        let mut noise = noise;
        let mut noise_updates = 0;
        // The last re-estimation's change (infinite for the first, which has nothing to
        // compare with).
        let mut noise_change = 0.0;
        let estimated = noise.source.estimated();
        // Residuals for the noise fit: with the weights of the run that produced them, so
        // that the residual terms are those of that run.
        let mut weights = robust;
        loop {
            let last = if estimated {
                let ev = problem
                    .evaluate(&outcome.theta, &weights, false, true)
                    .expect("the optimizer only accepts admissible points");
                let new =
                    noise.estimate(&problem, ev.residuals.as_ref().expect("kept"), dof_factor);
                let change = if noise_updates == 0 {
                    f64::INFINITY
                } else {
                    noise
                        .scale
                        .iter()
                        .zip(&new)
                        .map(|(&a, &b)| if a > 0.0 { ((b - a) / a).abs() } else { 1.0 })
                        .fold(0.0, f64::max)
                };
                noise_updates += 1;
                noise.scale = new;
                noise_change = change;
                change < NOISE_CHANGE_TOLERANCE || noise_updates >= self.max_noise_updates
            } else {
                true
            };
            weights = noise.weights(&problem);
            outcome = run(
                outcome.theta.clone(),
                &weights,
                if last { strict } else { loose },
                outcome.damping,
            )
            .expect("the optimizer only accepts admissible points");
            iterations += outcome.iterations;
            if last {
                break;
            }
        }

        let theta = outcome.theta;
        let (mass, stiffness, damping) = param::matrices(&problem.params, &theta, n);
        let mut b2 = DMatrix::zeros(n, problem.r);
        for (l, &dof) in problem.dofs.iter().enumerate() {
            b2[(dof, l)] = 1.0;
        }
        // The modal part of the uncertainty reads only the continuous matrices of the
        // model; the sample interval (needed by its constructor) is immaterial.
        let dt_s = 0.25 / band_hz.1.max(1e-3);
        let model = Model::new(
            &mass,
            &stiffness,
            &damping,
            &b2,
            dt_s,
            Intersample::Bandlimited,
            Some(&problem.params),
        )
        .map_err(|_| RefineError::NonFiniteModel)?;
        let mut warnings = start.warnings.clone();
        // Noisy weights (variances from the coherence): covariance nu / (nu - 2) times; per
        // real observation the cost has mean E[1/u] = nu / (nu - 1) and variance 4 E[1/u^2] -
        // 2 E[1/u]^2, E[1/u^2] = nu^2 / ((nu - 1) (nu - 2)) (see the module docs). With fewer
        // than 4 averages that variance is infinite: no cost test.
        let (inflation, cost_moments) = match noise.source {
            NoiseSource::Coherence { averages } => {
                let nu = (averages - 1) as f64;
                if averages >= 4 {
                    let m1 = nu / (nu - 1.0);
                    let m2 = nu * nu / ((nu - 1.0) * (nu - 2.0));
                    (nu / (nu - 2.0), Some((m1, 4.0 * m2 - 2.0 * m1 * m1)))
                } else {
                    warnings.push(FrfRefineWarning::FewAverages { averages });
                    (1.0, None)
                }
            }
            _ if estimated => (1.0, None),
            _ => (1.0, Some((1.0, 2.0))),
        };
        let uncertainty =
            uncertainty::uncertainty(&problem.params, &model, &outcome.point.fisher / inflation)?;
        let initial_cost = problem
            .evaluate(&theta0, &weights, false, false)
            .map_or(f64::INFINITY, |ev| ev.cost);
        if !outcome.stop.converged() {
            warnings.push(FrfRefineWarning::NotConverged { stop: outcome.stop });
        }
        // An unsettled alternation matters unless the final fit is exact (noise-free FRFs:
        // any weights give the same estimate, and the "levels" shrink with the residuals from
        // one update to the next); the final residuals say which (one more evaluation, only
        // here).
        if noise_change >= NOISE_CHANGE_TOLERANCE
            && problem
                .evaluate(&theta, &weights, false, true)
                .and_then(|ev| ev.residuals)
                .is_none_or(|residuals| above_exact_fit(&problem, &residuals))
        {
            warnings.push(FrfRefineWarning::NoiseNotSettled {
                updates: noise_updates,
                change: f64::is_finite(noise_change).then_some(noise_change),
            });
        }
        let cost = outcome.point.cost;
        if let Some((mean, variance)) = cost_moments {
            let dof = (observations - unknowns) as f64;
            let expected = dof * mean;
            if cost > expected + 5.0 * (dof * variance).sqrt() {
                warnings.push(FrfRefineWarning::CostAboveExpectation { cost, expected });
            }
        }
        if uncertainty.modes.len() < n {
            warnings.push(FrfRefineWarning::OverdampedModes {
                oscillatory: uncertainty.modes.len(),
                dofs: n,
            });
        }
        for (mode, md) in uncertainty.modes.iter().enumerate() {
            if md.damping_ratio < 0.0 {
                warnings.push(FrfRefineWarning::NegativeDamping {
                    mode,
                    damping_ratio: md.damping_ratio,
                    damping_ratio_std: md.damping_ratio_std,
                });
            }
        }
        let xi = &outcome.point.extra.xi;
        let residual_terms = (0..nt)
            .map(|t| DMatrix::from_fn(n, problem.r, |i, l| xi[i + l * n][t]))
            .collect();
        Ok(FrfRefinement {
            mass,
            stiffness,
            damping,
            parameters: theta,
            uncertainty,
            noise: noise.report(&problem),
            reference_dofs: problem.dofs.clone(),
            residual_powers: problem.powers.clone(),
            residual_terms,
            band_hz,
            lines: problem.lines.len(),
            cost,
            initial_cost,
            observations,
            unknowns,
            iterations,
            noise_updates,
            stop: outcome.stop,
            warnings,
        })
    }

    /// Lines, data and parameters of one refinement.
    fn problem(&self, frf: &Frf, start: &FrfStart) -> Result<Problem, FrfRefineError> {
        let n = start.initial.mass.nrows();
        for (what, m) in [
            ("mass", &start.initial.mass),
            ("stiffness", &start.initial.stiffness),
            ("damping", &start.initial.damping),
        ] {
            if m.shape() != (n, n) {
                return Err(FrfRefineError::Shape {
                    reason: format!(
                        "the start's {what} matrix is {}x{}, the mass matrix {n}x{n}",
                        m.nrows(),
                        m.ncols()
                    ),
                });
            }
        }
        let (m, r) = (frf.outputs_count(), frf.references_count());
        if m != n {
            return Err(FrfRefineError::Shape {
                reason: format!(
                    "the FRFs have {m} outputs, the model {n} DOFs (one response per DOF)"
                ),
            });
        }
        if start.reference_dofs.len() != r {
            return Err(FrfRefineError::Shape {
                reason: format!(
                    "{} reference DOFs for {r} references",
                    start.reference_dofs.len()
                ),
            });
        }
        if let Some((l, &dof)) = start
            .reference_dofs
            .iter()
            .enumerate()
            .find(|(_, d)| **d >= n)
        {
            return Err(FrfRefineError::Shape {
                reason: format!("reference {l} acts on DOF {dof}, the model has {n} DOFs"),
            });
        }
        if !(start.decay_per_s.is_finite() && start.decay_per_s >= 0.0) {
            return Err(FrfRefineError::InvalidParams {
                field: "decay_per_s",
                reason: format!("{} 1/s must be finite and non-negative", start.decay_per_s),
            });
        }
        for (j, md) in start.subtracted_modes.iter().enumerate() {
            if md.residue.shape() != (m, r) {
                return Err(FrfRefineError::Shape {
                    reason: format!(
                        "subtracted mode {j} has a {}x{} residue, the FRFs are {m}x{r}",
                        md.residue.nrows(),
                        md.residue.ncols()
                    ),
                });
            }
            let finite = |z: &C64| z.re.is_finite() && z.im.is_finite();
            if !(finite(&md.pole) && md.residue.iter().all(finite)) {
                return Err(FrfRefineError::InvalidParams {
                    field: "FrfStart::subtracted_modes",
                    reason: format!(
                        "subtracted mode {j} (pole {} rad/s) has a non-finite pole or residue",
                        md.pole
                    ),
                });
            }
        }
        let params = self.parametrization.parameters(n)?;
        if self.band_hz.is_none()
            && let Some((lo, hi)) = start.band_hz
            && !(lo.is_finite() && hi.is_finite() && lo >= 0.0 && hi > lo)
        {
            return Err(FrfRefineError::InvalidParams {
                field: "FrfStart::band_hz",
                reason: format!("({lo}, {hi}) Hz is not a band: need 0 <= f_min < f_max"),
            });
        }
        let f = &frf.frequency_hz;
        let (lo, hi) = self
            .band_hz
            .or(start.band_hz)
            .unwrap_or((f[0], f[f.len() - 1]));
        let q = frf.quantity.derivative_order();
        let mut powers = Vec::new();
        if self.residuals.lower {
            powers.push(q - 2);
        }
        if self.residuals.upper {
            powers.push(q);
        }
        powers.sort_unstable();
        powers.dedup();
        let mut lines = Vec::new();
        let mut data = Vec::new();
        for (k, &fk) in f.iter().enumerate() {
            if fk < lo || fk > hi || fk <= 0.0 {
                continue;
            }
            let w = 2.0 * PI * fk;
            let iw = C64::new(0.0, w);
            let s = C64::new(start.decay_per_s, w);
            let mut h = if start.negate {
                -frf.values[k].clone()
            } else {
                frf.values[k].clone()
            };
            for (j, md) in start.subtracted_modes.iter().enumerate() {
                let (a, b) = (1.0 / (iw - md.pole), 1.0 / (iw - md.pole.conj()));
                let term = md.residue.map(|x| x * a + x.conj() * b);
                if term.iter().any(|z| !(z.re.is_finite() && z.im.is_finite())) {
                    return Err(FrfRefineError::InvalidParams {
                        field: "FrfStart::subtracted_modes",
                        reason: format!(
                            "subtracted mode {j} (pole {} rad/s) is not finite at {fk} Hz",
                            md.pole
                        ),
                    });
                }
                h -= term;
            }
            lines.push(Line {
                index: k,
                frequency_hz: fk,
                s,
                sd: s.powi(q),
                regressors: powers.iter().map(|&p| iw.powi(p)).collect(),
            });
            data.push(h);
        }
        if lines.is_empty() {
            return Err(FrfRefineError::TooFewLines {
                lines: 0,
                observations: 0,
                unknowns: params.len() + powers.len() * m * r,
                band_hz: (lo, hi),
            });
        }
        for l in 0..r {
            for i in 0..m {
                if lines
                    .iter()
                    .all(|line| frf.values[line.index][(i, l)] == C64::new(0.0, 0.0))
                {
                    return Err(FrfRefineError::ZeroFrf {
                        output: i,
                        reference: l,
                        band_hz: (lines[0].frequency_hz, lines[lines.len() - 1].frequency_hz),
                    });
                }
            }
        }
        let rms = DMatrix::from_fn(n, r, |i, l| {
            (data.iter().map(|h| h[(i, l)].norm_sqr()).sum::<f64>() / data.len() as f64).sqrt()
        });
        Ok(Problem {
            bases: params
                .iter()
                .map(|p| p.basis.map(|x| C64::new(x, 0.0)))
                .collect(),
            params,
            n,
            r,
            dofs: start.reference_dofs.clone(),
            lines,
            data,
            powers,
            rms,
        })
    }

    /// The noise model for `frf` on the lines of `problem`.
    fn resolve_noise(&self, frf: &Frf, problem: &Problem) -> Result<Noise, FrfRefineError> {
        let (n, r) = (problem.n, problem.r);
        let has_coherence = frf.coherence.is_some();
        let averages = frf.averages.filter(|&a| a >= 2);
        let model = match &self.noise {
            FrfNoise::Auto => match (has_coherence, averages) {
                (true, Some(a)) => NoiseSource::Coherence { averages: a },
                (true, None) => NoiseSource::CoherenceScaled,
                _ => NoiseSource::PerOutput,
            },
            FrfNoise::Coherence => {
                if !has_coherence {
                    return Err(FrfRefineError::Noise {
                        model: "coherence",
                        reason: "the FRF set has no coherence".into(),
                    });
                }
                match averages {
                    Some(a) => NoiseSource::Coherence { averages: a },
                    None => {
                        return Err(FrfRefineError::Noise {
                            model: "coherence",
                            reason: format!(
                                "the variance needs at least 2 averages, the FRF set has {}",
                                frf.averages
                                    .map_or("no count".to_string(), |a| a.to_string())
                            ),
                        });
                    }
                }
            }
            FrfNoise::CoherenceScaled => {
                if !has_coherence {
                    return Err(FrfRefineError::Noise {
                        model: "coherence-scaled",
                        reason: "the FRF set has no coherence".into(),
                    });
                }
                NoiseSource::CoherenceScaled
            }
            FrfNoise::PerOutput => NoiseSource::PerOutput,
            FrfNoise::PerPair => NoiseSource::PerPair,
            FrfNoise::Known(v) => {
                if v.len() != frf.lines() {
                    return Err(FrfRefineError::Noise {
                        model: "known",
                        reason: format!("{} variance matrices for {} lines", v.len(), frf.lines()),
                    });
                }
                for (k, m) in v.iter().enumerate() {
                    if m.shape() != (n, r) {
                        return Err(FrfRefineError::Noise {
                            model: "known",
                            reason: format!(
                                "variances at line {k} are {}x{}, expected {n}x{r}",
                                m.nrows(),
                                m.ncols()
                            ),
                        });
                    }
                    if let Some(x) = m.iter().find(|x| x.is_nan() || **x <= 0.0) {
                        return Err(FrfRefineError::Noise {
                            model: "known",
                            reason: format!("variance {x} at line {k} must be positive"),
                        });
                    }
                }
                NoiseSource::Known
            }
        };
        let index: Vec<usize> = problem.lines.iter().map(|line| line.index).collect();
        let mut floored = 0;
        let mut excluded = 0;
        let shape: Vec<DMatrix<f64>> = match model {
            NoiseSource::Coherence { .. } | NoiseSource::CoherenceScaled => {
                let coh = frf.coherence.as_ref().expect("checked above");
                index
                    .iter()
                    .map(|&k| {
                        DMatrix::from_fn(n, r, |i, l| {
                            let g2 = coh[k][(i, l)];
                            if g2 <= 0.0 {
                                excluded += 1;
                                return f64::INFINITY;
                            }
                            let mut one_minus = 1.0 - g2;
                            if one_minus < self.coherence_floor {
                                one_minus = self.coherence_floor;
                                floored += 1;
                            }
                            one_minus * frf.values[k][(i, l)].norm_sqr() / g2
                        })
                    })
                    .collect()
            }
            NoiseSource::Known => {
                let FrfNoise::Known(v) = &self.noise else {
                    unreachable!("resolved from FrfNoise::Known")
                };
                index
                    .iter()
                    .map(|&k| {
                        v[k].map(|x| {
                            if x.is_infinite() {
                                excluded += 1;
                            }
                            x
                        })
                    })
                    .collect()
            }
            NoiseSource::PerOutput | NoiseSource::PerPair => {
                vec![DMatrix::from_element(n, r, 1.0); index.len()]
            }
        };
        let (group, groups) = match model {
            NoiseSource::PerOutput => (DMatrix::from_fn(n, r, |i, _| i), n),
            NoiseSource::PerPair => (DMatrix::from_fn(n, r, |i, l| i + l * n), n * r),
            _ => (DMatrix::zeros(n, r), 1),
        };
        let scale = match model {
            NoiseSource::Coherence { averages } => vec![1.0 / (averages - 1) as f64],
            _ => vec![1.0; groups],
        };
        Ok(Noise {
            source: model,
            shape,
            group,
            groups,
            scale,
            floored,
            excluded,
        })
    }
}

/// Weights of the first run: variance `a + b |Ĥ|^2` per output and reference from the
/// residuals `e` of the start (see the module docs), excluded values kept excluded.
fn robust_weights(problem: &Problem, noise: &Noise, e: &[DMatrix<C64>]) -> Vec<DMatrix<f64>> {
    let (n, r) = (problem.n, problem.r);
    let mut a = DMatrix::zeros(n, r);
    let mut b = DMatrix::zeros(n, r);
    for l in 0..r {
        for i in 0..n {
            let mut abs = Vec::with_capacity(e.len());
            let mut rel = Vec::with_capacity(e.len());
            for (k, ek) in e.iter().enumerate() {
                if !noise.shape[k][(i, l)].is_finite() {
                    continue;
                }
                let e2 = ek[(i, l)].norm_sqr();
                abs.push(e2);
                let h2 = problem.data[k][(i, l)].norm_sqr();
                if h2 > 0.0 {
                    rel.push(e2 / h2);
                }
            }
            a[(i, l)] = median(abs);
            b[(i, l)] = median(rel);
        }
    }
    (0..problem.lines.len())
        .map(|k| {
            DMatrix::from_fn(n, r, |i, l| {
                if !noise.shape[k][(i, l)].is_finite() {
                    return 0.0;
                }
                let floor = (NOISE_RESOLUTION * problem.rms[(i, l)]).powi(2);
                let var = (a[(i, l)] + b[(i, l)] * problem.data[k][(i, l)].norm_sqr()).max(floor);
                if var > 0.0 { (2.0 / var).sqrt() } else { 0.0 }
            })
        })
        .collect()
}

#[cfg(test)]
mod tests;
