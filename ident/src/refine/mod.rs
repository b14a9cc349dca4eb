//! Maximum-likelihood refinement of M, K and damping from all hits at once, and the
//! Cramér–Rao bound of the same likelihood.
//!
//! MKR (see [`crate::mkr`]) gives good M and K but a damping matrix far less accurate than
//! the data allow, and Rayleigh damping cannot represent non-proportional damping.
//! [`Refiner::refine`] starts from an initial M, K and damping (for example MKR's M and K
//! with Rayleigh damping) and minimizes the output error of every hit over physical
//! parameters ([`Parametrization`]); [`Refiner::cramer_rao`] gives the best accuracy any
//! unbiased estimator can reach on a campaign, with the same likelihood.
//!
//! # Model
//!
//! Forces at the DOFs of `B2` (unit columns, [`Refiner::input_dofs`]), accelerations at every
//! DOF: `H(s) = s^2 (M s^2 + R s + K)^-1 B2`; state space `A = [[0, I], [-M^-1 K, -M^-1 R]]`,
//! `C = [-M^-1 K, -M^-1 R]`, `D = M^-1 B2`, `A_d = expm(A dt)`. Per hit `h` and DFT bin `k`
//! (`z_k = exp(j w_k dt)`):
//!
//! ```text
//! Y_h(k) = G(theta, k) U_h(k) + C (I - A_d / z_k)^-1 xi_h + noise
//! ```
//!
//! with `xi_h` (2n real numbers) a free transient per hit. It is exact, not an
//! approximation of leakage: it is the difference between the record's DFT and the circular
//! convolution the DFT sees.
//!
//! * [`Intersample::Zoh`] (held inputs): `G = C (z I - A_d)^-1 B_d + D`, all bins
//!   `0..=N/2`; exact for any held record (`xi_h = x_0 - x_N`).
//! * [`Intersample::Bandlimited`] (analyzer records, the same anti-alias filter on every
//!   channel): `G = H(j w_k)`, the continuous FRF, on the bins up to
//!   [`Refiner::band_edge`] times Nyquist. For band-limited signals `y = g_bl * u` with
//!   `g_bl` the sampled band-limited impulse response, whose DTFT is `H(j w)` in band. The
//!   windowed minus circular convolution is, for the modal (exponential) part of `g_bl`,
//!   exactly `C (I - A_d / z_k)^-1 xi_h`; only the short non-causal band-limiting part of
//!   `g_bl` leaks beyond it, negligible with the hit well inside the record (measured:
//!   noise-free band-limited records give M, K and damping to about 1e-9).
//!
//! # Likelihood
//!
//! Gaussian white noise of standard deviation `sigma_y,i` on output `i` and `sigma_u,l` on
//! force `l` (the force channel is noisy too). With the true force eliminated
//! (errors-in-variables), the residual `e = Y - G U - T xi` of bin `k` has covariance
//! `N (Sy + G Su G^H)`; the cost is `sum_h sum_k w_k e^H (Sy + G Su G^H)^-1 e / N` (`w_k = 1`
//! for the real DC and Nyquist bins, 2 for the others): twice the negative log-likelihood
//! maximized over the unknown true force, up to a constant. For one output this is Pintelon and Schoukens' `|e|^2 / (sigma_y^2 +
//! |G|^2 sigma_u^2)`; the full matrix keeps the correlation the common force noise puts
//! between outputs. The weight depends on the parameters; it is whitened by its Cholesky
//! factor and differentiated exactly (Cholesky derivative), so the Gauss-Newton steps
//! minimize the stated cost and the stop tests refer to it.
//!
//! The transients are eliminated by variable projection: for given parameters each
//! `xi_h` is the linear least-squares solution, and the Gauss-Newton matrix is the Schur
//! complement with the transients eliminated (Kaufman). That keeps the iteration in the
//! `p` physical parameters instead of `p + 2 n hits`, makes the gradient exact, and the
//! matrix is, at the estimate, the Fisher information with the nuisance parameters
//! eliminated — the same matrix the bound uses.
//!
//! Noise levels are given ([`NoiseModel::Known`]) or estimated from the residuals
//! ([`NoiseModel::Estimate`]): `E |e_ik|^2 / N = sigma_y,i^2 + sum_l |G_il|^2 sigma_u,l^2`
//! fitted by maximum likelihood for the exponentially distributed `|e|^2`, alternated with
//! the refinement until the levels change by less than [`NOISE_CHANGE_TOLERANCE`]. The
//! levels are per channel, shared by all hits (a sensor noise floor).
//!
//! # Derivatives
//!
//! All exact: `dH = -s^2 Q^-1 dQ Q^-1 B2` (`Q = M s^2 + R s + K`); `dA_d`, `dB_d` are
//! Frechet derivatives of the exponential (block-triangular exponential); the transient's
//! derivative follows from `d(z I - A_d)^-1 = (z I - A_d)^-1 dA_d (z I - A_d)^-1`.
//!
//! # Optimizer
//!
//! Levenberg–Marquardt with Moré's scaling; steps that make M or K indefinite are rejected like
//! steps that increase the cost. The stop reason is data ([`StopReason`]). A run usually ends
//! at a point reached by a step that, by its quadratic model (whose predicted decrease the
//! actual one matches within the same tolerance), leaves less than a tolerance of the decrease
//! a full Gauss-Newton step would bring; that point is evaluated only for what follows (the
//! residuals for the noise fit, or the expected Fisher information at the estimate), not for
//! another step (`LOOSE_DECREASE`, [`STATISTICAL_TOLERANCE`]).
//!
//! The first run weighs the bins by the residuals of the initial guess (mostly model error,
//! largest near the resonances, so the resonances are down-weighted): a relative-error fit
//! whose cost is much smoother than an absolute fit of sharp peaks at slightly wrong
//! frequencies (on every other bin, `FIRST_RUN_BIN_STRIDE`). From M and K entries 2 % off
//! (first frequency up to 7 % off) and damping x3, all 300 trials of the efficiency test (1 %
//! noise) converged, and the 20 also refined
//! from MKR's start reached the same optimum. Then the noise levels (estimated or given)
//! take over, with tight tolerances in the last run. A model with an overdamped mode has
//! fewer oscillatory modes than DOFs: a refinement that ends so from a poor start has
//! found a local minimum.
//!
//! ```no_run
//! use ident::refine::{Refiner, SecondOrder};
//! use ident::{Identifier, Intersample, Record};
//! # fn records() -> Vec<Record> { unimplemented!() }
//! let records = records();
//! let dt_s = 1.0 / 64.0;
//! let first = Identifier::default().identify(&records, dt_s)?;
//! let initial = SecondOrder::new(first.mass, first.stiffness, first.damping_rayleigh);
//! let refined = Refiner::default()
//!     .intersample(Intersample::Bandlimited)
//!     .refine(&records, dt_s, &initial)?;
//! println!("damping = {} +- {}", refined.damping, refined.uncertainty.damping_std);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

// `pub(crate)`: the FRF refinement (`crate::frf::refine`) reuses the parametrization, the
// model, the optimizer and the uncertainty propagation.
pub(crate) mod dense;
mod eigenbasis;
pub(crate) mod likelihood;
pub(crate) mod lm;
pub(crate) mod model;
pub(crate) mod param;
mod spectra;
pub(crate) mod uncertainty;

#[cfg(test)]
mod tests;

pub use param::{Dashpot, Node, Parameter, Parametrization};
pub use uncertainty::IDENTIFIABILITY_THRESHOLD;

use crate::linalg::{self, C64};
use crate::mkr::MatrixKind;
use crate::modal::Intersample;
use crate::record::{self, DataError, Record};
use likelihood::{Noise, Want};
use model::{Model, ModelError};
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};
use spectra::Spectra;
use std::fmt;
use std::ptr;
use std::sync::Mutex;

/// Mass, stiffness and damping matrices of a second-order model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SecondOrder {
    /// Mass matrix (kg).
    pub mass: DMatrix<f64>,
    /// Stiffness matrix (N/m).
    pub stiffness: DMatrix<f64>,
    /// Damping matrix (N s/m).
    pub damping: DMatrix<f64>,
}

impl SecondOrder {
    /// The refinement's usual starting point: the M and K identified by MKR
    /// with the Rayleigh damping `alpha M + beta K`. MKR's own damping matrix
    /// is far off at any noise level (it is hypersensitive to the complex
    /// mode shapes when damping is light, see the paper's eq. 46 against
    /// eq. 47), the Rayleigh one is a smooth function of the identified
    /// frequencies and damping ratios.
    pub fn from_identification(id: &crate::pipeline::Identification) -> Self {
        Self::new(
            id.mass.clone(),
            id.stiffness.clone(),
            id.damping_rayleigh.clone(),
        )
    }

    /// Bundles the three matrices. Panics if they are not square of one size.
    pub fn new(mass: DMatrix<f64>, stiffness: DMatrix<f64>, damping: DMatrix<f64>) -> Self {
        let out = Self {
            mass,
            stiffness,
            damping,
        };
        out.assert_shapes();
        out
    }

    /// Number of degrees of freedom.
    pub fn dofs(&self) -> usize {
        self.mass.nrows()
    }

    fn assert_shapes(&self) {
        let n = self.mass.nrows();
        for (what, m) in [
            ("mass", &self.mass),
            ("stiffness", &self.stiffness),
            ("damping", &self.damping),
        ] {
            assert_eq!(m.shape(), (n, n), "SecondOrder: {what} must be {n} x {n}");
        }
    }
}

/// Noise standard deviations per channel (time domain, per sample).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NoiseLevels {
    /// Per output channel (m/s^2).
    pub outputs: Vec<f64>,
    /// Per input channel (N); 0 for a noise-free force.
    pub inputs: Vec<f64>,
}

/// Where the noise levels come from.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub enum NoiseModel {
    /// Output and force noise estimated from the residuals.
    #[default]
    Estimate,
    /// Output noise estimated, the force taken as noise-free (output error).
    EstimateOutputsOnly,
    /// Given levels.
    Known(NoiseLevels),
}

/// Why the optimizer stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum StopReason {
    /// Converged: the largest cosine between the residual and a Jacobian column,
    /// `max_i |J_i^T r| / (|J_i| |r|)`, is below the gradient tolerance.
    Gradient,
    /// Converged: the scaled step is below the step tolerance relative to the scaled
    /// parameters.
    Step,
    /// Converged: the relative cost decrease of the last step and its prediction, or the
    /// decrease a full Gauss-Newton step would bring, are below the cost tolerance (or that
    /// decrease is below [`STATISTICAL_TOLERANCE`]).
    Cost,
    /// The iteration limit was reached.
    MaxIterations,
    /// No admissible step reduces the cost, even with very large damping.
    NoProgress,
}

impl StopReason {
    /// Whether the reason is a convergence test.
    pub fn converged(&self) -> bool {
        matches!(
            self,
            StopReason::Gradient | StopReason::Step | StopReason::Cost
        )
    }
}

impl fmt::Display for StopReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            StopReason::Gradient => "converged (gradient)",
            StopReason::Step => "converged (step)",
            StopReason::Cost => "converged (cost)",
            StopReason::MaxIterations => "iteration limit reached",
            StopReason::NoProgress => "no progress",
        })
    }
}

/// Refinement parameters. `Refiner::default()` plus setters covers common use.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Refiner {
    /// Physical parameters estimated.
    pub parametrization: Parametrization,
    /// How the records were acquired (fixes the model, see the module docs).
    pub intersample: Intersample,
    /// Highest bin used for band-limited records, as a fraction of Nyquist (0, 1].
    pub band_edge: f64,
    /// DOF of each input (force) channel, `B2 = [e_dof...]`.
    pub input_dofs: Vec<usize>,
    /// Noise levels: given or estimated.
    pub noise: NoiseModel,
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

impl Default for Refiner {
    fn default() -> Self {
        Self {
            parametrization: Parametrization::Full,
            intersample: Intersample::Bandlimited,
            band_edge: 0.75,
            input_dofs: vec![0],
            noise: NoiseModel::Estimate,
            max_iterations: 100,
            gradient_tolerance: 1e-10,
            step_tolerance: 1e-10,
            cost_tolerance: 1e-12,
            max_noise_updates: 4,
        }
    }
}

/// Relative change of the noise levels below which the alternation of noise fit and
/// refinement stops (the refinement then runs once more with the new levels). The
/// alternation contracts fast (measured changes about 1, 0.05, 5e-4 on 1 % noise
/// analyzer campaigns), so the levels used are then within about 0.1 % of its fixed point
/// (the parameters within 2.6e-3 of their standard deviations of those after four updates,
/// the most [`Refiner::max_noise_updates`] allows by default). Not so on held (zero-order-hold)
/// paper-case-1 campaigns: the changes were 10, 0.76, 0.010 and then 3.0e-3 (a slow
/// contraction), and a fourth update moved the parameters by 0.40 of their standard
/// deviations (measured on two campaigns).
pub const NOISE_CHANGE_TOLERANCE: f64 = 0.1;

/// Gradient and step tolerances of the FRF refinement's runs before its last noise update
/// (cost tolerance: its square; see `crate::frf::refine`). Those runs only need residuals
/// close enough to the final ones for the noise fit: a gradient cosine of 1e-4 leaves the
/// cost within about 1e-7 of its minimum. (The refinement from records stops its runs
/// before the last noise update with [`LOOSE_DECREASE`] instead: on its likelihood this
/// cosine test was measured to stop them with a decrease of up to 1.85 still to gain,
/// 6e-5 of the cost.)
pub(crate) const LOOSE_TOLERANCE: f64 = 1e-4;

/// Decrease of the cost (twice the negative log-likelihood) a full Gauss-Newton step would
/// still bring, relative to the cost, below which a run before the last noise update ends (its
/// `cost_tolerance`). Such a run only gives the residuals of the noise fit and the start of the
/// next run, so it ends at a point reached by a step whose quadratic model leaves at most this
/// much (its predicted decrease matching the actual one that closely), and that point is
/// evaluated for its residuals only, without the Jacobian (a quarter of the work; see
/// `lm::minimize_to_tail`). On 10-hit paper-case-1 campaigns (cost near 30000, 41000 held) that
/// is a decrease of 0.5 (0.65) left, a residual power 1.6e-5 above the run's minimum: far below
/// the noise levels' own statistical error (0.6 % from 7690 bins a channel). It is relative, as
/// the noise fit's sensitivity is, so that it means the same on costs far from the number of
/// observations (nearly noise-free records, whose noise levels are model error). It is tighter
/// than the gradient-cosine test ([`LOOSE_TOLERANCE`]) those runs used before, which left
/// decreases up to 1.85 (6e-5 of the cost), so that the last run starts closer and usually
/// needs one step fewer. On twenty analyzer and five held 10-hit paper-case-1 campaigns (1 %
/// noise), with the last run's final point as in [`STATISTICAL_TOLERANCE`], a refinement made 6
/// evaluations with the Jacobian, one without the weights' derivative and 4 of the cost only,
/// instead of 9 with the Jacobian and 2 of the cost (every campaign; 21 % fewer instructions on
/// the first); the estimated noise levels moved by at most 9.4e-5 (outputs) and 1.4e-3 (force)
/// relative, less than the alternation's own distance to its fixed point (for the force 2.3e-3
/// after, 3.3e-3 before, against a fully converged alternation), and the parameters by at most
/// 1.45e-3 of their standard deviations (3.8e-6 relative).
pub(crate) const LOOSE_DECREASE: f64 = 1.6e-5;

/// Decrease of the cost (twice the negative log-likelihood) a full Gauss-Newton step would
/// still bring, below which a run stops whatever the relative tolerances ([`StopReason::Cost`]).
/// That decrease is `d^T F d` for the remaining step `d` with `F` the Gauss-Newton matrix,
/// which is the Fisher information of the parameters: below 1e-5 the estimate is within
/// `sqrt(1e-5)`, 0.3 % of a standard deviation (Mahalanobis), of the converged one, far below
/// its statistical error. On twenty analyzer and five held 10-hit paper-case-1 campaigns
/// (1 % noise) it saved one likelihood evaluation of thirteen in every refinement and moved
/// every parameter by at most 2.6e-3 of its standard deviation (1.5e-6 relative), the
/// standard deviations by at most 1.4e-6 and the modal parameters by 5e-7 relative.
///
/// The last run usually ends before that test can be made at a point: a step whose quadratic
/// model leaves at most this decrease, and whose actual decrease matches the predicted one
/// within this much too, ends it, and the point it reaches is evaluated without the weights'
/// derivative (see `lm::minimize_to_tail`). That pass gives the expected Fisher information for
/// the standard errors directly and costs a third less than the exact Jacobian with that matrix
/// beside it. Checked on the 25 campaigns above (the point evaluated with the Jacobian): the
/// decrease left there was 0.991 to 1.041 times the model's.
pub const STATISTICAL_TOLERANCE: f64 = 1e-5;

/// Predicted cost decrease of a step of the last run below which the point it reaches is
/// evaluated with the expected Fisher information as well, in the same pass: that point is
/// probably the final one, whose Fisher matrix gives the standard errors (otherwise one more
/// evaluation at the end computes it). Measured on paper case 1: the steps before the last
/// point predicted 1.5e-3 to 3.1e-3, the steps before them 0.1 to 0.3, and on 25 campaigns
/// (20 analyzer, 5 held) the last point always had the matrix. Since the last run ends
/// with a step evaluated for that matrix only ([`STATISTICAL_TOLERANCE`]), the hint serves
/// only steps that do not qualify for it (2 of those 25 campaigns, not at the last point).
const FISHER_HINT_DECREASE: f64 = 1e-2;

/// The first run (robust weights, see `likelihood::initial_noise`) fits every this-many-th bin of
/// each group only, from the first (unless that leaves too few observations); the point it ends
/// at is then evaluated on every bin (cost only) for the noise fit, whose residuals are all of
/// them. That run only brings the parameters from the start near the optimum; the following
/// ones, on all bins, go the rest of the way. On 32 paper-case-1 sweep trials (1 % noise) its
/// two evaluations with the Jacobian and its tail cost half as much; with the extra evaluation a
/// refinement took 11.7 % fewer instructions, a sweep trial 9.0 % (callgrind, 16 trials, one
/// thread: 352 M to 320 M a trial). On twenty analyzer and five held 10-hit paper-case-1
/// campaigns (1 % noise) the refined parameters moved by at most 7.3e-4 of their standard
/// deviations (the standard deviations by 1.7e-4 relative), the noise levels by 3.7e-5 (outputs)
/// and 5.8e-4 (force) relative; the sequence of evaluations was otherwise the same but for one
/// analyzer campaign (and 7 of 32 sweep trials, against 2 before) whose last run took one more evaluation with the
/// Jacobian. A fit of the noise levels on the subset's residuals instead (no extra evaluation)
/// needed a fourth run in 12 of the 32 trials.
const FIRST_RUN_BIN_STRIDE: usize = 2;

/// Records of more samples than this in all (a 10-hit campaign of 2048 samples has 20,480)
/// are refined on the caller's thread rather than hopping to a pool thread: see
/// [`Refiner::refine`].
const POOL_HOP_MAX_SAMPLES: usize = 1 << 18;

/// Estimated value and standard deviation of one mode's parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModalEstimate {
    /// Natural frequency `|lambda| / (2 pi)` (Hz).
    pub frequency_hz: f64,
    /// Its standard deviation (Hz).
    pub frequency_std_hz: f64,
    /// Damping ratio `-Re(lambda) / |lambda|`.
    pub damping_ratio: f64,
    /// Its standard deviation.
    pub damping_ratio_std: f64,
    /// Continuous pole (rad/s), `Im > 0`.
    pub pole: C64,
    /// Complex output shape `C psi`, largest component `1 + 0i`.
    pub shape: DVector<C64>,
    /// Standard deviation of the real parts of the shape (0 at the normalizing component).
    pub shape_std_re: DVector<f64>,
    /// Standard deviation of the imaginary parts of the shape.
    pub shape_std_im: DVector<f64>,
}

/// Fisher information (transients eliminated), covariance and standard deviations.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Uncertainty {
    /// Parameter labels ([`Parameter::label`]).
    pub labels: Vec<String>,
    /// Fisher information of the parameters, transients eliminated.
    pub fisher: DMatrix<f64>,
    /// Its inverse: covariance of the parameters.
    pub covariance: DMatrix<f64>,
    /// Standard deviations of the parameters.
    pub parameter_std: DVector<f64>,
    /// Standard deviation of each mass entry (0 for entries the parametrization fixes).
    pub mass_std: DMatrix<f64>,
    /// Standard deviation of each stiffness entry.
    pub stiffness_std: DMatrix<f64>,
    /// Standard deviation of each damping entry.
    pub damping_std: DMatrix<f64>,
    /// Oscillatory modes (complex poles) in ascending frequency with standard deviations
    /// (delta method); an overdamped mode (two real poles) is not listed.
    pub modes: Vec<ModalEstimate>,
}

/// Result of a refinement.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Refinement {
    /// Refined mass matrix (kg).
    pub mass: DMatrix<f64>,
    /// Refined stiffness matrix (N/m).
    pub stiffness: DMatrix<f64>,
    /// Refined damping matrix (N s/m).
    pub damping: DMatrix<f64>,
    /// Refined parameters (see `uncertainty.labels`).
    pub parameters: DVector<f64>,
    /// Standard errors from the Fisher information at the estimate, and the refined modal
    /// parameters with theirs.
    pub uncertainty: Uncertainty,
    /// Noise levels used by the final cost (estimated or given).
    pub noise: NoiseLevels,
    /// Final cost `sum |whitened residual|^2` (about `observations - unknowns` when the
    /// model and noise levels are right).
    pub cost: f64,
    /// Cost of the initial guess with the final noise levels.
    pub initial_cost: f64,
    /// Real observations used (real and imaginary parts of every bin and output).
    pub observations: usize,
    /// Unknowns: parameters plus `2 n` transient values per hit.
    pub unknowns: usize,
    /// Levenberg–Marquardt steps tried, over all runs.
    pub iterations: usize,
    /// Noise re-estimations done.
    pub noise_updates: usize,
    /// Relative change of the noise levels at the last re-estimation (the largest over the
    /// channels; 0 with given levels). At or above [`NOISE_CHANGE_TOLERANCE`] the alternation
    /// of noise fit and refinement stopped at [`Refiner::max_noise_updates`] before it settled
    /// ([`Refinement::noise_settled`]).
    pub noise_change: f64,
    /// Why the last run stopped.
    pub stop: StopReason,
    /// Transient vector `xi_h` of every hit.
    pub transients: Vec<DVector<f64>>,
}

impl Refinement {
    /// Whether the alternation of noise fit and refinement settled: the last re-estimation
    /// changed the levels by less than [`NOISE_CHANGE_TOLERANCE`] (always with given levels).
    pub fn noise_settled(&self) -> bool {
        self.noise_change < NOISE_CHANGE_TOLERANCE
    }
}

/// Ways a refinement or a bound can fail.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum RefineError {
    /// Parameters out of range.
    #[error("invalid refinement parameters: {reason}")]
    InvalidParams {
        /// Which parameter is out of range and what it must be.
        reason: String,
    },
    /// The records are unusable.
    #[error(transparent)]
    Data(#[from] DataError),
    /// The initial (or true) M or K is not positive definite.
    #[error("the {matrix} matrix is not positive definite (Cholesky pivot {pivot} = {value:e})")]
    NotPositiveDefinite {
        /// The mass or the stiffness matrix.
        matrix: MatrixKind,
        /// The first non-positive Cholesky pivot (0-based DOF).
        pivot: usize,
        /// Its value (the Schur-complement diagonal entry, in kg or N/m).
        value: f64,
    },
    /// The model has non-finite entries.
    #[error("the model has non-finite entries")]
    NonFiniteModel,
    /// The model has no finite response at some bin (a pole on the unit circle).
    #[error("the model has no finite frequency response at some bin")]
    SingularModel,
    /// The given model is not representable by the parametrization.
    #[error(
        "the {matrix} matrix is not representable by the parametrization (relative residual {residual:e})"
    )]
    NotRepresentable {
        /// The matrix that does not fit the parametrization.
        matrix: MatrixKind,
        /// Relative Frobenius residual of its least-squares projection on the
        /// parametrization (above `1e-9`).
        residual: f64,
    },
    /// Fewer observations than unknowns.
    #[error(
        "{observations} real observations for {unknowns} unknowns{}: too few bins (longer records or a higher band edge)",
        hit.map(|h| format!(" in record {h}")).unwrap_or_default()
    )]
    TooFewBins {
        /// The record with too few bins for its transient, or `None` for the total.
        hit: Option<usize>,
        /// Real observations (real and imaginary parts of every bin and channel) of that
        /// record, or of all records.
        observations: usize,
        /// Unknowns they must determine: the record's transient vector (`2 n`), or all
        /// parameters plus every record's transient.
        unknowns: usize,
    },
    /// The Fisher information is singular: the data do not determine every parameter.
    #[error(
        "the parameters are not identifiable: Fisher information of rank {rank} for {parameters} parameters (weakest: parameter {weakest})"
    )]
    NotIdentifiable {
        /// Numerical rank of the Jacobi-scaled Fisher information.
        rank: usize,
        /// Parameters of the parametrization (the Fisher matrix's size).
        parameters: usize,
        /// The parameter (0-based, in the parametrization's order) the data determine
        /// least: the first with no information at all, else the largest component of the
        /// eigenvector of the smallest eigenvalue.
        weakest: usize,
    },
    /// The eigendecomposition of the refined model failed.
    #[error("modal analysis of the refined model failed")]
    ModalAnalysis,
}

impl From<ModelError> for RefineError {
    fn from(e: ModelError) -> Self {
        match e {
            ModelError::NotPositiveDefinite {
                matrix,
                pivot,
                value,
            } => RefineError::NotPositiveDefinite {
                matrix,
                pivot,
                value,
            },
            ModelError::NonFinite => RefineError::NonFiniteModel,
        }
    }
}

/// Everything fixed for one problem.
struct Problem {
    params: Vec<Parameter>,
    b2: DMatrix<f64>,
    spectra: Spectra,
    dt: f64,
    intersample: Intersample,
    n: usize,
    r: usize,
    observations: usize,
    unknowns: usize,
    /// Per-bin models of earlier evaluations, by their parameters (see [`Memo`]).
    memo: Mutex<Memo>,
}

/// The per-bin models of the first point evaluated and of the latest other one, which the
/// refinement evaluates again: the start at unit noise and at the last weights (the initial
/// cost), and every run's end again after a noise update (the first run's as evaluated on all
/// bins for the noise fit, see [`FIRST_RUN_BIN_STRIDE`]; the first run's own problem keeps its
/// own). Before that run was on a subset, 4 of 9 evaluations took a kept model on analyzer
/// seeds 1 and 2 and held seed 101 of paper case 1, 10 hits; now usually 3 of the 7 on all
/// bins. Kept while they
/// take at most [`MEMO_BYTES`] together (so never for a long record).
#[derive(Default)]
struct Memo {
    entries: Vec<(DVector<f64>, likelihood::BinModels)>,
}

/// Largest memory the per-bin models of [`Memo`] take together (a 10-hit paper-case-1
/// campaign's take 0.42 MB a point, 0.56 MB held; measured on the seeds above). Half the
/// per-bin cache's budget: since the eigenbasis form needs no resolvent, the first run of a
/// 10^6-sample record (on every other bin) keeps its per-bin models whole, and kept in the memo
/// as well (for no reuse: that run's points are not evaluated again) they raised the peak
/// resident set of `identify --refine` from 287 to 348 MB (`/usr/bin/time`, same output
/// bytes).
const MEMO_BYTES: usize = 32 << 20;

impl Memo {
    /// The models kept for `theta` (the same bits).
    fn get(&self, theta: &DVector<f64>) -> Option<likelihood::BinModels> {
        self.entries
            .iter()
            .find(|(t, _)| {
                t.len() == theta.len()
                    && t.iter()
                        .zip(theta.iter())
                        .all(|(a, b)| a.to_bits() == b.to_bits())
            })
            .map(|(_, models)| models.clone())
    }

    /// Keeps `models` of `theta`: the first point's for good, then the latest other one's.
    fn keep(&mut self, theta: &DVector<f64>, models: likelihood::BinModels) {
        let entry = (theta.clone(), models);
        if self.entries.len() == 2 {
            self.entries[1] = entry;
        } else {
            self.entries.push(entry);
        }
        let bytes = |e: &(DVector<f64>, likelihood::BinModels)| likelihood::model_bytes(&e.1);
        while self.entries.iter().map(bytes).sum::<usize>() > MEMO_BYTES {
            self.entries.pop();
        }
    }
}

impl Problem {
    fn model(&self, theta: &DVector<f64>, derivatives: bool) -> Result<Model, ModelError> {
        let (mass, stiffness, damping) = param::matrices(&self.params, theta, self.n);
        Model::new(
            &mass,
            &stiffness,
            &damping,
            &self.b2,
            self.dt,
            self.intersample,
            derivatives.then_some(self.params.as_slice()),
        )
    }

    fn evaluate(
        &self,
        theta: &DVector<f64>,
        noise: &Noise,
        want: Want,
        keep_residuals: bool,
    ) -> Result<likelihood::Evaluation, RefineError> {
        let model = self.model(theta, want != Want::Cost)?;
        let kept = self.memo.lock().expect("memo lock").get(theta);
        let mut ev = likelihood::evaluate(
            &model,
            &self.params,
            &self.spectra,
            noise,
            want,
            keep_residuals,
            kept.as_ref(),
        )
        .map_err(|_| RefineError::SingularModel)?;
        // Not kept with the evaluation (the minimizer holds points).
        if let Some(models) = ev.models.take()
            && kept.is_none()
        {
            self.memo.lock().expect("memo lock").keep(theta, models);
        }
        Ok(ev)
    }

    /// The problem on every `stride`-th bin of each group (see [`Spectra::every`]; the same
    /// parameters and transients), or `None` if that leaves a hit's transient or the
    /// parameters with too few observations.
    fn subset(&self, stride: usize) -> Option<Problem> {
        let spectra = self.spectra.every(stride);
        let n = self.n;
        let observations = enough_bins(&spectra, n, self.unknowns).ok()?;
        Some(Problem {
            params: self.params.clone(),
            b2: self.b2.clone(),
            spectra,
            dt: self.dt,
            intersample: self.intersample,
            n,
            r: self.r,
            observations,
            unknowns: self.unknowns,
            memo: Mutex::default(),
        })
    }

    /// The expected Fisher information of `model` (built with derivatives) under `noise`:
    /// the Gauss-Newton matrix without the weights' derivative.
    fn expected_fisher(&self, model: &Model, noise: &Noise) -> Result<DMatrix<f64>, RefineError> {
        let ev = likelihood::evaluate(
            model,
            &self.params,
            &self.spectra,
            noise,
            Want::Jacobian {
                weight_derivative: false,
            },
            false,
            None,
        )
        .map_err(|_| RefineError::SingularModel)?;
        Ok(ev.fisher.expect("Jacobian requested"))
    }
}

impl Refiner {
    /// Sets the parametrization.
    pub fn parametrization(mut self, parametrization: Parametrization) -> Self {
        self.parametrization = parametrization;
        self
    }

    /// Sets the intersample assumption.
    pub fn intersample(mut self, intersample: Intersample) -> Self {
        self.intersample = intersample;
        self
    }

    /// Sets the band edge (fraction of Nyquist) for band-limited records.
    pub fn band_edge(mut self, band_edge: f64) -> Self {
        self.band_edge = band_edge;
        self
    }

    /// Sets the DOF of each input channel.
    pub fn input_dofs(mut self, dofs: Vec<usize>) -> Self {
        self.input_dofs = dofs;
        self
    }

    /// Sets the noise model.
    pub fn noise(mut self, noise: NoiseModel) -> Self {
        self.noise = noise;
        self
    }

    /// Sets the step limit per run.
    pub fn max_iterations(mut self, max_iterations: usize) -> Self {
        self.max_iterations = max_iterations;
        self
    }

    /// Validates the parameters that do not depend on the data.
    pub fn check(&self) -> Result<(), RefineError> {
        let bad = |reason: String| Err(RefineError::InvalidParams { reason });
        if !(self.band_edge > 0.0 && self.band_edge <= 1.0) {
            return bad(format!("band_edge = {} must be in (0, 1]", self.band_edge));
        }
        if self.input_dofs.is_empty() {
            return bad("at least one input DOF is needed".into());
        }
        for (i, a) in self.input_dofs.iter().enumerate() {
            if self.input_dofs[..i].contains(a) {
                return bad(format!("input DOF {a} is listed twice"));
            }
        }
        for (name, v) in [
            ("gradient_tolerance", self.gradient_tolerance),
            ("step_tolerance", self.step_tolerance),
            ("cost_tolerance", self.cost_tolerance),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return bad(format!("{name} = {v} must be finite and non-negative"));
            }
        }
        match &self.noise {
            NoiseModel::Known(levels) => check_levels(levels)?,
            _ if self.max_noise_updates == 0 => {
                return bad("estimated noise needs max_noise_updates >= 1".into());
            }
            _ => {}
        }
        Ok(())
    }

    fn problem(&self, records: &[Record], dt_s: f64, n: usize) -> Result<Problem, RefineError> {
        self.check()?;
        record::validate_dt(dt_s)?;
        let shape = record::validate(records)?;
        assert_eq!(
            shape.outputs, n,
            "refine: the records have {} outputs, the model {n} DOFs (one accelerometer per DOF)",
            shape.outputs
        );
        assert_eq!(
            shape.inputs,
            self.input_dofs.len(),
            "refine: the records have {} inputs, input_dofs lists {}",
            shape.inputs,
            self.input_dofs.len()
        );
        for &dof in &self.input_dofs {
            assert!(dof < n, "refine: input DOF {dof} out of range for {n} DOFs");
        }
        let params = self.parametrization.parameters(n)?;
        let mut b2 = DMatrix::zeros(n, self.input_dofs.len());
        for (l, &dof) in self.input_dofs.iter().enumerate() {
            b2[(dof, l)] = 1.0;
        }
        let spectra = Spectra::new(records, dt_s, self.intersample, self.band_edge);
        let unknowns = params.len() + 2 * n * records.len();
        let observations = enough_bins(&spectra, n, unknowns)?;
        Ok(Problem {
            params,
            b2,
            spectra,
            dt: dt_s,
            intersample: self.intersample,
            n,
            r: self.input_dofs.len(),
            observations,
            unknowns,
            memo: Mutex::default(),
        })
    }

    /// Refines `initial` (projected on the parametrization) on `records` sampled every
    /// `dt_s` seconds. Panics if the records' channel counts do not match the model (one
    /// output per DOF, one input per entry of `input_dofs`).
    pub fn refine(
        &self,
        records: &[Record],
        dt_s: f64,
        initial: &SecondOrder,
    ) -> Result<Refinement, RefineError> {
        // Short records: on a pool thread (see `ident::parallel::on_pool`). Long ones stay
        // on the caller's thread: their passes take milliseconds, so the hand-overs do not
        // count, and their large buffers then stay in the caller's allocation arena (on a
        // pool thread a 10^6-sample record's peak resident set rose from 274 to 282-292
        // MiB, in the same time).
        let samples: usize = records.iter().map(Record::len).sum();
        if samples > POOL_HOP_MAX_SAMPLES {
            self.refine_here(records, dt_s, initial)
        } else {
            crate::parallel::on_pool(|| self.refine_here(records, dt_s, initial))
        }
    }

    /// [`Refiner::refine`] on the current thread.
    fn refine_here(
        &self,
        records: &[Record],
        dt_s: f64,
        initial: &SecondOrder,
    ) -> Result<Refinement, RefineError> {
        initial.assert_shapes();
        let n = initial.dofs();
        for (matrix, value) in [
            (MatrixKind::Mass, &initial.mass),
            (MatrixKind::Stiffness, &initial.stiffness),
            (MatrixKind::Damping, &initial.damping),
        ] {
            if linalg::first_non_finite(value).is_some() {
                return Err(RefineError::NonFiniteModel);
            }
            if matrix != MatrixKind::Damping
                && let Err((pivot, v)) = linalg::cholesky(value)
            {
                return Err(RefineError::NotPositiveDefinite {
                    matrix,
                    pivot,
                    value: v,
                });
            }
        }
        let problem = self.problem(records, dt_s, n)?;
        let (theta0, _) = param::project(
            &problem.params,
            &initial.mass,
            &initial.stiffness,
            &initial.damping,
        );
        problem.model(&theta0, false)?;
        let full = &problem;
        let (m, r) = (n, problem.r);

        let rms = |rows: &dyn Fn(&Record) -> f64| {
            let count: usize = records.iter().map(|rec| rec.len()).sum();
            (records.iter().map(rows).sum::<f64>() / count as f64).sqrt()
        };
        let mut fit = likelihood::NoiseFit {
            m,
            r,
            estimate_inputs: false,
            dof_factor: problem.observations as f64
                / (problem.observations - problem.unknowns) as f64,
            output_rms: (0..m)
                .map(|i| rms(&|rec: &Record| rec.outputs.row(i).norm_squared()))
                .collect(),
            input_rms: (0..r)
                .map(|l| rms(&|rec: &Record| rec.inputs.row(l).norm_squared()))
                .collect(),
        };
        if let NoiseModel::Known(levels) = &self.noise {
            assert_eq!(
                levels.outputs.len(),
                m,
                "refine: one output noise level per output"
            );
            assert_eq!(
                levels.inputs.len(),
                r,
                "refine: one input noise level per input"
            );
        }
        let settings = lm::Settings {
            max_iterations: self.max_iterations,
            gradient_tolerance: self.gradient_tolerance,
            step_tolerance: self.step_tolerance,
            cost_tolerance: self.cost_tolerance,
            decrease_tolerance: STATISTICAL_TOLERANCE,
            damping_floor: lm::DAMPING_DECREASE_FLOOR,
        };
        // Before the last noise update a run only gives the residuals of the noise fit.
        let loose = lm::Settings {
            cost_tolerance: self.cost_tolerance.max(LOOSE_DECREASE),
            ..settings
        };
        // The noise fit uses the unwhitened residuals of a run's last point only: they are kept
        // by a run's tail evaluation before the last noise update, and a run that ends at a
        // point with the Jacobian is evaluated there once more for them (where the noise is
        // estimated, below). Unwhitening every point's residuals took 3.3 % of a sweep trial's
        // instructions.
        let jacobian = Want::Jacobian {
            weight_derivative: true,
        };
        // Tests compare with the residuals kept at every point (the earlier way).
        #[cfg(test)]
        let every_residual = EVERY_RESIDUAL.with(|c| c.get());
        #[cfg(not(test))]
        let every_residual = false;
        let eval = |problem: &Problem,
                    t: &DVector<f64>,
                    noise: &Noise,
                    want: Want|
         -> Result<lm::Point<likelihood::Evaluation>, RefineError> {
            let mut ev = problem.evaluate(t, noise, want, every_residual)?;
            Ok(lm::Point {
                cost: ev.cost,
                fisher: ev.fisher.take().expect("Jacobian requested"),
                gradient: ev.gradient.take().expect("Jacobian requested"),
                extra: ev,
            })
        };
        // A run ends at a point reached by a step that leaves at most its stop threshold of
        // the decrease (see `lm::minimize_to_tail`), evaluated for what follows only: the
        // residuals for the noise fit before the last run ([`LOOSE_DECREASE`]), the expected
        // Fisher information for the standard errors in the last one
        // ([`STATISTICAL_TOLERANCE`]). In the last run, points reached by other steps
        // predicting a decrease below `FISHER_HINT_DECREASE` also get the expected Fisher
        // information. The first run may be on a subset of the bins (`problem`), whose tail
        // residuals nothing uses.
        let run = |problem: &Problem,
                   theta: DVector<f64>,
                   noise: &Noise,
                   mu: f64,
                   last: bool|
         -> Result<lm::TailOutcome<likelihood::Evaluation>, RefineError> {
            let start = eval(problem, &theta, noise, jacobian)?;
            let (settings, tail_want) = if last {
                (
                    settings,
                    Want::Jacobian {
                        weight_derivative: false,
                    },
                )
            } else {
                (loose, Want::Cost)
            };
            Ok(lm::minimize_to_tail(
                theta,
                start,
                settings,
                mu,
                |t, predicted| {
                    let want = if last && predicted <= FISHER_HINT_DECREASE {
                        Want::JacobianAndFisher
                    } else {
                        jacobian
                    };
                    eval(problem, t, noise, want).ok()
                },
                |t| {
                    let keep = (!last && ptr::eq(problem, full)) || every_residual;
                    let ev = problem.evaluate(t, noise, tail_want, keep).ok()?;
                    Some((ev.cost, ev))
                },
            ))
        };

        // First run: weights from the initial residuals (see `likelihood::initial_noise`),
        // a robust start whatever the noise model, on every other bin
        // ([`FIRST_RUN_BIN_STRIDE`]) if they are enough; its end is evaluated on all of them
        // for the noise fit.
        let unit = Noise {
            outputs: vec![1.0; m],
            inputs: vec![0.0; r],
        };
        let ev = problem.evaluate(&theta0, &unit, Want::Cost, true)?;
        let mut noise = likelihood::initial_noise(&problem.spectra, &ev, &fit);
        #[cfg(test)]
        let stride = FIRST_RUN_STRIDE.with(|c| c.get());
        #[cfg(not(test))]
        let stride = FIRST_RUN_BIN_STRIDE;
        let coarse = (stride > 1).then(|| problem.subset(stride)).flatten();
        let first = coarse.as_ref().unwrap_or(&problem);
        let mut outcome = run(first, theta0.clone(), &noise, lm::INITIAL_DAMPING, false)?;
        if coarse.is_some() && !matches!(self.noise, NoiseModel::Known(_)) {
            let ev = problem.evaluate(&outcome.theta, &noise, Want::Cost, true)?;
            outcome.end = lm::End::Tail(lm::TailPoint {
                cost: ev.cost,
                extra: ev,
            });
        }
        let mut iterations = outcome.iterations;
        let mut noise_updates = 0;
        let mut noise_change = 0.0;
        fit.estimate_inputs = matches!(self.noise, NoiseModel::Estimate);
        loop {
            let (new, last) = match &self.noise {
                NoiseModel::Known(levels) => (
                    Noise {
                        outputs: levels.outputs.clone(),
                        inputs: levels.inputs.clone(),
                    },
                    true,
                ),
                _ => {
                    let again;
                    let end = match &outcome.end {
                        lm::End::Tail(tail) => &tail.extra,
                        lm::End::Point(point) if every_residual => &point.extra,
                        // The same pass as the point's own (the residuals do not depend on
                        // what else is computed): the same numbers.
                        lm::End::Point(_) => {
                            #[cfg(test)]
                            REEVALUATED_ENDS.with(|c| c.set(c.get() + 1));
                            again = problem.evaluate(&outcome.theta, &noise, Want::Cost, true)?;
                            &again
                        }
                    };
                    let new = likelihood::estimate_noise(&problem.spectra, end, &fit);
                    noise_updates += 1;
                    let change = relative_change(&noise, &new);
                    noise_change = change;
                    (
                        new,
                        change < NOISE_CHANGE_TOLERANCE || noise_updates >= self.max_noise_updates,
                    )
                }
            };
            noise = new;
            outcome = run(full, outcome.theta.clone(), &noise, outcome.damping, last)?;
            iterations += outcome.iterations;
            if last {
                break;
            }
        }
        let theta = outcome.theta;
        let model = problem.model(&theta, true)?;
        let (cost, mut last, gauss_newton) = match outcome.end {
            lm::End::Point(point) => (point.cost, point.extra, Some(point.fisher)),
            lm::End::Tail(tail) => (tail.cost, tail.extra, None),
        };
        // The expected Fisher information at the estimate: from the last point's own pass
        // (a final step's evaluation without the weights' derivative, or one that asked for
        // it beside them: bit for bit the same matrix), or without errors in variables the
        // last point's Gauss-Newton matrix (the same matrix again).
        let fisher = match (
            last.expected_fisher.take(),
            last.fisher.take(),
            gauss_newton,
        ) {
            (Some(fisher), _, _) | (None, Some(fisher), _) => fisher,
            (None, None, Some(fisher)) if !noise.errors_in_variables() => fisher,
            _ => problem.expected_fisher(&model, &noise)?,
        };
        let uncertainty = uncertainty::uncertainty(&problem.params, &model, fisher)?;
        let initial_cost = problem.evaluate(&theta0, &noise, Want::Cost, false)?.cost;
        Ok(Refinement {
            mass: model.mass.clone(),
            stiffness: model.stiffness.clone(),
            damping: model.damping.clone(),
            parameters: theta,
            uncertainty,
            noise: NoiseLevels {
                outputs: noise.outputs,
                inputs: noise.inputs,
            },
            cost,
            initial_cost,
            observations: problem.observations,
            unknowns: problem.unknowns,
            iterations,
            noise_updates,
            noise_change,
            stop: outcome.stop,
            transients: last.xi,
        })
    }

    /// Cramér–Rao bound of the refinement's likelihood for a campaign: the true model
    /// `truth` (representable by the parametrization), the noise-free force records
    /// `inputs` (r x N each, the structure at rest before each) and the noise levels
    /// (include the force noise if the records have it: the errors-in-variables bound is
    /// then the reachable one). The transients are nuisance parameters, eliminated. The
    /// noise-free responses are computed from `truth` as the records would be acquired
    /// (exact held simulation, or band-limited convolution). Panics on inconsistent shapes.
    pub fn cramer_rao(
        &self,
        truth: &SecondOrder,
        dt_s: f64,
        inputs: &[DMatrix<f64>],
        noise: &NoiseLevels,
    ) -> Result<Uncertainty, RefineError> {
        crate::parallel::on_pool(|| self.cramer_rao_here(truth, dt_s, inputs, noise))
    }

    /// [`Refiner::cramer_rao`] on the current thread.
    fn cramer_rao_here(
        &self,
        truth: &SecondOrder,
        dt_s: f64,
        inputs: &[DMatrix<f64>],
        noise: &NoiseLevels,
    ) -> Result<Uncertainty, RefineError> {
        truth.assert_shapes();
        self.check()?;
        check_levels(noise)?;
        record::validate_dt(dt_s)?;
        let n = truth.dofs();
        assert_eq!(
            noise.outputs.len(),
            n,
            "cramer_rao: one output noise level per DOF"
        );
        assert_eq!(
            noise.inputs.len(),
            self.input_dofs.len(),
            "cramer_rao: one input noise level per input"
        );
        let params = self.parametrization.parameters(n)?;
        let (theta, residuals) =
            param::project(&params, &truth.mass, &truth.stiffness, &truth.damping);
        for (matrix, residual) in [MatrixKind::Mass, MatrixKind::Stiffness, MatrixKind::Damping]
            .into_iter()
            .zip(residuals)
        {
            if residual > 1e-9 {
                return Err(RefineError::NotRepresentable { matrix, residual });
            }
        }
        for &dof in &self.input_dofs {
            assert!(
                dof < n,
                "cramer_rao: input DOF {dof} out of range for {n} DOFs"
            );
        }
        let mut b2 = DMatrix::zeros(n, self.input_dofs.len());
        for (l, &dof) in self.input_dofs.iter().enumerate() {
            b2[(dof, l)] = 1.0;
        }
        let plain = Model::new(
            &truth.mass,
            &truth.stiffness,
            &truth.damping,
            &b2,
            dt_s,
            self.intersample,
            None,
        )?;
        for (h, u) in inputs.iter().enumerate() {
            assert_eq!(
                u.nrows(),
                self.input_dofs.len(),
                "cramer_rao: input record {h} must have one row per input"
            );
            if let Some((row, sample)) = linalg::first_non_finite(u) {
                return Err(RefineError::Data(DataError::NonFinite {
                    record: h,
                    channel: crate::record::Channel::Input(row),
                    sample,
                    value: u[(row, sample)],
                }));
            }
        }
        let records: Vec<Record> = inputs
            .iter()
            .zip(spectra::noise_free_outputs(&plain, inputs))
            .map(|(u, y)| Record::new(u.clone(), y))
            .collect();
        let problem = self.problem(&records, dt_s, n)?;
        let noise = Noise {
            outputs: noise.outputs.clone(),
            inputs: noise.inputs.clone(),
        };
        let model = problem.model(&theta, true)?;
        let fisher = problem.expected_fisher(&model, &noise)?;
        uncertainty::uncertainty(&problem.params, &model, fisher)
    }
}

#[cfg(test)]
thread_local! {
    /// Keep the residuals of every evaluation, as the refinement did before it kept only
    /// those the noise fit uses (tests compare the two).
    pub(crate) static EVERY_RESIDUAL: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
    /// Runs that ended at a point with the Jacobian and were evaluated again for the noise
    /// fit's residuals, on this thread.
    pub(crate) static REEVALUATED_ENDS: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
    /// [`FIRST_RUN_BIN_STRIDE`] in tests (1: the first run on every bin, as before it was not).
    pub(crate) static FIRST_RUN_STRIDE: std::cell::Cell<usize> = const { std::cell::Cell::new(FIRST_RUN_BIN_STRIDE) };
}

/// The observations of `spectra` (`n` outputs), if every hit has more than its `2 n`
/// transient components and all of them more than `unknowns` (parameters and transients);
/// else which is short.
fn enough_bins(spectra: &Spectra, n: usize, unknowns: usize) -> Result<usize, RefineError> {
    let s = 2 * n;
    for group in &spectra.groups {
        let per_hit: usize = group
            .bins
            .iter()
            .map(|b| if b.weight > 1.5 { 2 * n } else { n })
            .sum();
        if per_hit <= s {
            return Err(RefineError::TooFewBins {
                hit: Some(group.hits[0]),
                observations: per_hit,
                unknowns: s,
            });
        }
    }
    let observations = likelihood::observations(spectra, n);
    if observations <= unknowns {
        return Err(RefineError::TooFewBins {
            hit: None,
            observations,
            unknowns,
        });
    }
    Ok(observations)
}

fn check_levels(levels: &NoiseLevels) -> Result<(), RefineError> {
    for (i, &s) in levels.outputs.iter().enumerate() {
        if !(s.is_finite() && s > 0.0) {
            return Err(RefineError::InvalidParams {
                reason: format!("output noise level {i} = {s} must be positive and finite"),
            });
        }
    }
    for (l, &s) in levels.inputs.iter().enumerate() {
        if !(s.is_finite() && s >= 0.0) {
            return Err(RefineError::InvalidParams {
                reason: format!("input noise level {l} = {s} must be non-negative and finite"),
            });
        }
    }
    Ok(())
}

fn relative_change(old: &Noise, new: &Noise) -> f64 {
    old.outputs
        .iter()
        .chain(&old.inputs)
        .zip(new.outputs.iter().chain(&new.inputs))
        .map(|(&a, &b)| {
            if a > 0.0 {
                ((b - a) / a).abs()
            } else if b > 0.0 {
                1.0
            } else {
                0.0
            }
        })
        .fold(0.0, f64::max)
}
