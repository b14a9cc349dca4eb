//! Mass, stiffness and damping from FRFs: pLSCF poles ([`super::lscf`]),
//! LSFD residues ([`super::lsfd`]), then MKR and Rayleigh as on the
//! time-domain route.
//!
//! ```no_run
//! use ident::frf::{Frf, FrfIdentifier};
//! # fn frf() -> Frf { unimplemented!() }
//! let result = FrfIdentifier::default().band_hz(0.5, 25.0).identify(&frf())?;
//! println!("M = {}", result.mass);
//! for &j in &result.out_of_model {
//!     let md = &result.modes[j];
//!     println!("out-of-model mode {:.3} Hz, damping {:.4}", md.frequency_hz, md.damping_ratio);
//! }
//! # Ok::<(), ident::frf::FrfIdentError>(())
//! ```
//!
//! # Steps
//!
//! 1. pLSCF at every order `1..=max` on the band gives the stabilization
//!    diagram ([`Lscf`]); the order is fixed or chosen by
//!    [`Lscf::auto_order`].
//! 2. The poles of that order that are stable (frequency, damping and
//!    participation vector) and physical (damping ratio in
//!    `(0, max_damping_ratio]`, frequency in the band) are the modes.
//! 3. LSFD fits their residues with lower and upper residual terms on the
//!    same band and refines the poles ([`Lsfd`]).
//! 4. Each mode becomes a [`Mode`] as on the time-domain route: `shape` is the
//!    dominant left singular vector of its residue matrix (the mode shape of
//!    `psi l^T`), `residue` is the rank-one part of its *accelerance* residue
//!    `lambda^2 R_j` (for one reference, the residue itself), `eigenvalue` is
//!    `exp(lambda dt)` in the pLSCF's z-domain, `structural` is true. With an
//!    exponential window on the records (`exponential_tau_s`), `lambda` is
//!    the measured pole moved back by `+1 / tau` first.
//!    Indicators: no EMAC, MPC of the shape, `cmi = mpc`, and `msv` is the
//!    peak of the mode's term in the measured FRF, `||A_j||_F / |Re lambda_j|`
//!    (`msv_relative` over the largest).
//! 5. A mode whose refined pole left the band or the damping range, or else
//!    whose `msv_relative` is below `min_contribution` (default 1 %: a peak
//!    40 dB below the largest), is set aside as a [`RejectedMode`] and LSFD
//!    is run again without it, from the pLSCF poles of the others: noise
//!    poles that happen to be stable over a few orders carry little of the
//!    FRF and drift away when refined.
//! 6. As many modes as outputs are chosen for MKR ([`ModeSelection`]); the
//!    others are reported as out-of-model modes with a
//!    [`Warning::ExtraStructuralModes`].
//! 7. MKR ([`crate::mkr`]) and the Rayleigh fit, with the same warnings as
//!    the time route (polarity, `||W W^T||` consistency, negative Rayleigh
//!    coefficients).
//!
//! Steps 1 to 5 are [`FrfIdentifier::modal`], all of them
//! [`FrfIdentifier::identify`].
//!
//! # From residues to MKR
//!
//! With the eq. 28 scaling, the receptance of the `n`-DOF model with forces
//! at the reference DOFs is `H(s) = sum_j R_j / (s - lambda_j) + conj`,
//! `R_j = W_j W_j^T B2` over the `n` modes, and the accelerance is
//!
//! ```text
//! s^2 H(s) = sum_j lambda_j^2 R_j / (s - lambda_j) + conj + sum_all (s + lambda_j) R_j
//!          = sum_j lambda_j^2 R_j / (s - lambda_j) + conj + M^-1 B2
//! ```
//!
//! because `sum_all W_j W_j^T = 0` and `sum_all lambda_j W_j W_j^T = M^-1`.
//! So the accelerance residue `lambda_j^2 R_j` is exactly the state-space
//! residue `C psi_j b_j^T` MKR takes (`W[k,j]^2 = residue[k,l] / lambda_j^2`
//! for the collocated pair), and the accelerance's high-frequency constant is
//! the feedthrough `D = M^-1 B2`. MKR's driving-point check uses the fitted
//! constant term for accelerance data (an estimate independent of the
//! residues) and `D = 2 Re sum_j lambda_j R_j` (the modal value) for
//! receptance and mobility data.
//!
//! # Conventions
//!
//! As in [`crate::frf`]: `H(w)` for `s = i w`, time convention
//! `x(t) = Re(X e^{i w t})`; poles in rad/s, frequencies in Hz.

use super::lscf::{Lscf, LscfParams};
use super::lsfd::{Lsfd, LsfdParams, ResidualTerms, rank_one};
use super::{Frf, FrfError, FrfQuantity};
use crate::linalg::{self, C64, LinalgError};
use crate::mkr::{CollocatedPair, MkrError, MkrParams, PolarityPolicy};
use crate::modal::{Indicators, Mode, mpc};
use crate::pipeline::{CONSISTENCY_WARNING, StabilizationCriteria, Warning};
use crate::rayleigh::{Rayleigh, RayleighError};
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};
use std::ops::Range;

/// How the frequency lines are weighted in pLSCF and LSFD.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum Weighting {
    /// Every line and output with weight 1 (least squares on the FRF values
    /// themselves: right for noise of equal level on every line).
    #[default]
    Uniform,
    /// Inverse standard deviation of an H1 estimate from the coherence:
    /// `w = 1 / sigma`, `sigma^2` the mean over the references of
    /// `(1 - gamma^2) |H|^2 / gamma^2` (proportional to the variance of an H1
    /// estimate, Bendat and Piersol), one weight per output and line;
    /// `1 - gamma^2` is floored at `1e-6`, a zero coherence gives weight 0.
    /// Needs [`Frf::coherence`].
    Coherence,
}

/// Model order of pLSCF.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum FrfOrder {
    /// Use this order `p` (the diagram is still computed up to it; stability
    /// needs `p >= 2`).
    Fixed(usize),
    /// Diagram up to `max`, order by [`Lscf::auto_order`].
    Auto {
        /// Largest order of the diagram.
        max: usize,
    },
}

/// Which identified modes MKR uses (as many as outputs).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum ModeSelection {
    /// The modes with the largest peak contribution to the FRFs (`msv`).
    Largest,
    /// The mode nearest to each frequency, each within `tolerance` (relative).
    Nearest {
        /// Target frequencies, Hz (one per output).
        frequency_hz: Vec<f64>,
        /// Largest relative distance `|f / target - 1|`.
        tolerance: f64,
    },
    /// Every mode inside the band (Hz); there must be one per output.
    Band(f64, f64),
}

/// Parameters of the FRF route. `FrfIdentifier::default()` plus setters covers
/// common use.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FrfIdentifier {
    /// Band (Hz) for pLSCF and LSFD; `None` for all lines.
    pub band_hz: Option<(f64, f64)>,
    /// pLSCF model order.
    pub order: FrfOrder,
    /// Line weighting.
    pub weighting: Weighting,
    /// Stabilization tolerances.
    pub criteria: StabilizationCriteria,
    /// Largest damping ratio of a physical mode.
    pub max_damping_ratio: f64,
    /// LSFD residual terms.
    pub residuals: ResidualTerms,
    /// Largest number of iterations refining the poles in LSFD (0 keeps the
    /// pLSCF poles).
    pub pole_iterations: usize,
    /// Smallest peak contribution of a mode relative to the largest
    /// (`msv_relative`) for it to stay in the modal model.
    pub min_contribution: f64,
    /// Time constant (s) of an exponential window `exp(-t / tau)` applied to
    /// the records behind the FRFs (as in
    /// [`super::estimate::AppliedWindows::exponential_tau_s`]), if any. The
    /// window turns `H(s)` into `H(s + 1 / tau)`: every pole moves by
    /// `-1 / tau` and the residues of the measured quantity stay. The
    /// [`Mode`]s (and so MKR and Rayleigh) get the poles moved back by
    /// `+1 / tau`; the diagram, the LSFD fit, the rejection of step 5 and
    /// `msv` describe the measured (windowed) FRFs.
    pub exponential_tau_s: Option<f64>,
    /// Modes for MKR.
    pub selection: ModeSelection,
    /// Collocated pair (output, reference).
    pub collocated: CollocatedPair,
    /// What to do with an inverted polarity.
    pub polarity: PolarityPolicy,
}

impl Default for FrfIdentifier {
    fn default() -> Self {
        Self {
            band_hz: None,
            order: FrfOrder::Auto { max: 32 },
            weighting: Weighting::Uniform,
            criteria: StabilizationCriteria::default(),
            max_damping_ratio: 0.2,
            residuals: ResidualTerms::default(),
            pole_iterations: 50,
            min_contribution: 0.01,
            exponential_tau_s: None,
            selection: ModeSelection::Largest,
            collocated: CollocatedPair::default(),
            polarity: PolarityPolicy::default(),
        }
    }
}

/// Modes identified from FRFs (steps 1 to 5 of the module docs).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FrfModal {
    /// The stabilization diagram.
    pub diagram: Lscf,
    /// The pLSCF order used.
    pub order: usize,
    /// Stable physical modes at that order, ascending frequency (see the
    /// module docs for what the fields hold on this route).
    pub modes: Vec<Mode>,
    /// LSFD fit; its poles and residues are in the order of `modes`.
    pub lsfd: Lsfd,
    /// Stable physical pLSCF poles left out of the modal model (step 5).
    pub rejected: Vec<RejectedMode>,
    /// Time constant of the exponential window taken out of `modes`, s.
    pub exponential_tau_s: Option<f64>,
}

/// A stable physical pLSCF pole left out of the modal model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RejectedMode {
    /// Natural frequency of the pLSCF pole, Hz.
    pub frequency_hz: f64,
    /// Damping ratio of the pLSCF pole.
    pub damping_ratio: f64,
    /// Why it was left out.
    pub reason: RejectReason,
}

/// Why a stable physical pLSCF pole was left out of the modal model.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum RejectReason {
    /// The pole refinement moved it out of the band or of the damping range.
    LeftPhysicalRange {
        /// The refined pole, rad/s.
        refined: C64,
    },
    /// Its peak contribution is below `min_contribution` of the largest.
    Insignificant {
        /// Its `msv_relative`.
        contribution: f64,
    },
}

/// Result of the FRF route; the fields it shares with
/// [`crate::pipeline::Identification`] have the same names and meanings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FrfIdentification {
    /// Every identified mode (stable, physical, in the band), ascending frequency.
    pub modes: Vec<Mode>,
    /// Indices into `modes` of the modes used by MKR and the Rayleigh fit.
    pub mkr_modes: Vec<usize>,
    /// Indices into `modes` of the other modes (out of the `n`-DOF model).
    pub out_of_model: Vec<usize>,
    /// Natural frequencies (Hz) of the MKR modes.
    pub frequencies_hz: Vec<f64>,
    /// Damping ratios of the MKR modes.
    pub damping_ratios: Vec<f64>,
    /// Normalized complex shapes of the MKR modes (outputs x n_dof, by columns).
    pub mode_shapes: DMatrix<C64>,
    /// Rayleigh coefficients fitted to the MKR modes.
    pub rayleigh: Rayleigh,
    /// Mass matrix (kg).
    pub mass: DMatrix<f64>,
    /// Stiffness matrix (N/m).
    pub stiffness: DMatrix<f64>,
    /// Damping matrix from MKR (eq. 30), N s/m.
    pub damping_mkr: DMatrix<f64>,
    /// Rayleigh damping `alpha M + beta K`, N s/m.
    pub damping_rayleigh: DMatrix<f64>,
    /// `||W W^T|| / ||W Lc W^T||` (0 for an exact second-order system).
    pub consistency: f64,
    /// MKR's `W` (eq. 28 scaling), modes each followed by its conjugate.
    pub w: DMatrix<C64>,
    /// Whether the input polarity was flipped (residues and residual terms
    /// below are then negated).
    pub polarity_flipped: bool,
    /// Warnings, in the order they arose.
    pub warnings: Vec<Warning>,
    /// Quantity of the FRFs identified.
    pub quantity: FrfQuantity,
    /// The pLSCF order used.
    pub order: usize,
    /// The stabilization diagram.
    pub diagram: Lscf,
    /// LSFD fit of all `modes` (same order).
    pub lsfd: Lsfd,
    /// Stable physical pLSCF poles left out of the modal model.
    pub rejected: Vec<RejectedMode>,
    /// Time constant of the exponential window taken out of `modes`, s.
    pub exponential_tau_s: Option<f64>,
}

/// Ways the FRF route can fail.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum FrfIdentError {
    /// A parameter is out of range.
    #[error("invalid parameter {field}: {reason}")]
    InvalidParams {
        /// The parameter.
        field: &'static str,
        /// What is wrong.
        reason: String,
    },
    /// The FRF set is unusable.
    #[error(transparent)]
    Frf(#[from] FrfError),
    /// The band holds too few lines.
    #[error("{lines} frequency lines in the band {band_hz:?} Hz, {required} needed for {what}")]
    TooFewLines {
        /// Lines available.
        lines: usize,
        /// Lines needed.
        required: usize,
        /// The band (requested, or first and last line).
        band_hz: (f64, f64),
        /// What needs them.
        what: &'static str,
    },
    /// Coherence weighting without coherence, or with a coherence of 0 everywhere.
    #[error("coherence weighting: {reason}")]
    Weighting {
        /// What is wrong.
        reason: String,
    },
    /// A matrix of the pLSCF solution is singular.
    #[error("{stage} (model order {order})")]
    Numerical {
        /// Where.
        stage: &'static str,
        /// pLSCF order.
        order: usize,
    },
    /// A decomposition failed.
    #[error("{stage}: {source}")]
    Linalg {
        /// Where.
        stage: &'static str,
        /// The failure.
        #[source]
        source: LinalgError,
    },
    /// LSFD cannot separate the poles (or a pole from a residual term) on the band.
    #[error(
        "LSFD regressor for output {output} has rank {rank} < {unknowns}: poles {poles:?} rad/s are not separable on the band"
    )]
    LsfdRankDeficient {
        /// Output.
        output: usize,
        /// Numerical rank.
        rank: usize,
        /// Unknowns.
        unknowns: usize,
        /// The poles fitted.
        poles: Vec<C64>,
    },
    /// The diagram has no order with a stable physical pole.
    #[error(
        "no stable physical pole in the band {band_hz:?} Hz at any pLSCF order up to {max_order}"
    )]
    NoStableModes {
        /// Band fitted.
        band_hz: (f64, f64),
        /// Largest order.
        max_order: usize,
    },
    /// MKR needs one mode per output and the selection does not give it.
    #[error(
        "MKR needs {required} modes (one per output); {found} available ({what}) at pLSCF order {order}, frequencies {frequencies_hz:?} Hz"
    )]
    ModeCount {
        /// Modes available to the selection.
        found: usize,
        /// Modes needed (outputs).
        required: usize,
        /// Which selection.
        what: &'static str,
        /// pLSCF order.
        order: usize,
        /// Frequencies of the modes available.
        frequencies_hz: Vec<f64>,
    },
    /// A target frequency of [`ModeSelection::Nearest`] has no mode near it,
    /// or shares its nearest mode with another target.
    #[error(
        "no distinct identified mode within {tolerance} of {target_hz} Hz (nearest {nearest_hz:?} Hz)"
    )]
    ModeNotFound {
        /// Target frequency.
        target_hz: f64,
        /// Nearest identified mode, if any.
        nearest_hz: Option<f64>,
        /// Relative tolerance.
        tolerance: f64,
    },
    /// MKR failed.
    #[error(transparent)]
    Mkr(#[from] MkrError),
    /// The Rayleigh fit failed.
    #[error(transparent)]
    Rayleigh(#[from] RayleighError),
    /// A result is not finite.
    #[error("identified {quantity} is not finite")]
    NonFiniteResult {
        /// Which.
        quantity: &'static str,
    },
}

/// Lines of `frf` inside `band` (all lines for `None`).
pub(crate) fn band_lines(
    frf: &Frf,
    band: Option<(f64, f64)>,
) -> Result<Range<usize>, FrfIdentError> {
    let f = &frf.frequency_hz;
    let (lo, hi) = band.unwrap_or((f[0], f[f.len() - 1]));
    let start = f.partition_point(|&x| x < lo);
    let end = f.partition_point(|&x| x <= hi);
    if end <= start + 1 {
        return Err(FrfIdentError::TooFewLines {
            lines: end.saturating_sub(start),
            required: 2,
            band_hz: (lo, hi),
            what: "a band",
        });
    }
    Ok(start..end)
}

/// Weight of every output at every line of `band` (index `line - band.start`).
pub(crate) fn line_weights(
    frf: &Frf,
    band: Range<usize>,
    weighting: Weighting,
) -> Result<Vec<DVector<f64>>, FrfIdentError> {
    let l = frf.outputs_count();
    match weighting {
        Weighting::Uniform => Ok(vec![DVector::from_element(l, 1.0); band.len()]),
        Weighting::Coherence => {
            let coh = frf.coherence.as_ref().ok_or(FrfIdentError::Weighting {
                reason: "the FRF set has no coherence".into(),
            })?;
            let n_ref = frf.references_count();
            let mut out = Vec::with_capacity(band.len());
            let mut any = false;
            for k in band {
                let w = DVector::from_fn(l, |o, _| {
                    // sigma_o^2 ~ mean_i (1 - g^2) |H|^2 / g^2
                    let var: f64 = (0..n_ref)
                        .map(|i| {
                            let g2 = coh[k][(o, i)];
                            let h2 = frf.values[k][(o, i)].norm_sqr();
                            if g2 > 0.0 {
                                (1.0 - g2).max(1e-6) * h2 / g2
                            } else {
                                f64::INFINITY
                            }
                        })
                        .sum::<f64>()
                        / n_ref as f64;
                    if var.is_finite() && var > 0.0 {
                        1.0 / var.sqrt()
                    } else {
                        0.0
                    }
                });
                any |= w.iter().any(|&x| x > 0.0);
                out.push(w);
            }
            if !any {
                return Err(FrfIdentError::Weighting {
                    reason: "every line of the band has zero coherence or a zero FRF".into(),
                });
            }
            Ok(out)
        }
    }
}

impl FrfIdentifier {
    /// Sets the band (Hz).
    pub fn band_hz(mut self, f_min_hz: f64, f_max_hz: f64) -> Self {
        self.band_hz = Some((f_min_hz, f_max_hz));
        self
    }

    /// Sets the pLSCF order.
    pub fn order(mut self, order: FrfOrder) -> Self {
        self.order = order;
        self
    }

    /// Sets the line weighting.
    pub fn weighting(mut self, weighting: Weighting) -> Self {
        self.weighting = weighting;
        self
    }

    /// Sets the residual terms.
    pub fn residuals(mut self, residuals: ResidualTerms) -> Self {
        self.residuals = residuals;
        self
    }

    /// Sets the largest number of pole-refinement iterations (0: none).
    pub fn pole_iterations(mut self, iterations: usize) -> Self {
        self.pole_iterations = iterations;
        self
    }

    /// Sets the smallest relative peak contribution of a mode.
    pub fn min_contribution(mut self, ratio: f64) -> Self {
        self.min_contribution = ratio;
        self
    }

    /// Sets the time constant (s) of the exponential window on the records.
    pub fn exponential_window(mut self, tau_s: f64) -> Self {
        self.exponential_tau_s = Some(tau_s);
        self
    }

    /// Sets the MKR mode selection.
    pub fn selection(mut self, selection: ModeSelection) -> Self {
        self.selection = selection;
        self
    }

    /// Sets the collocated pair (output index, reference index).
    pub fn collocated(mut self, output: usize, reference: usize) -> Self {
        self.collocated = CollocatedPair {
            output,
            input: reference,
        };
        self
    }

    /// Sets the polarity policy.
    pub fn polarity(mut self, policy: PolarityPolicy) -> Self {
        self.polarity = policy;
        self
    }

    fn lscf_params(&self) -> LscfParams {
        LscfParams {
            band_hz: self.band_hz,
            max_order: match self.order {
                FrfOrder::Fixed(p) => p,
                FrfOrder::Auto { max } => max,
            },
            weighting: self.weighting,
            criteria: self.criteria,
            max_damping_ratio: self.max_damping_ratio,
        }
    }

    fn lsfd_params(&self) -> LsfdParams {
        LsfdParams {
            band_hz: self.band_hz,
            residuals: self.residuals,
            weighting: self.weighting,
            max_iterations: self.pole_iterations,
        }
    }

    /// Validates the parameters (not the data).
    pub fn check(&self) -> Result<(), FrfIdentError> {
        self.lscf_params().check()?;
        self.lsfd_params().check()?;
        if let Some(tau) = self.exponential_tau_s
            && !(tau.is_finite() && tau > 0.0)
        {
            return Err(FrfIdentError::InvalidParams {
                field: "exponential_tau_s",
                reason: format!("{tau} s must be positive and finite"),
            });
        }
        if !(0.0..1.0).contains(&self.min_contribution) {
            return Err(FrfIdentError::InvalidParams {
                field: "min_contribution",
                reason: format!("{} must be in [0, 1)", self.min_contribution),
            });
        }
        match &self.selection {
            ModeSelection::Largest => {}
            ModeSelection::Nearest {
                frequency_hz,
                tolerance,
            } => {
                if !(tolerance.is_finite() && *tolerance > 0.0) {
                    return Err(FrfIdentError::InvalidParams {
                        field: "selection",
                        reason: format!("tolerance {tolerance} must be positive"),
                    });
                }
                if let Some(f) = frequency_hz.iter().find(|f| !(f.is_finite() && **f > 0.0)) {
                    return Err(FrfIdentError::InvalidParams {
                        field: "selection",
                        reason: format!("target frequency {f} Hz must be positive"),
                    });
                }
            }
            &ModeSelection::Band(lo, hi) => {
                if !(lo.is_finite() && hi.is_finite() && lo >= 0.0 && hi > lo) {
                    return Err(FrfIdentError::InvalidParams {
                        field: "selection",
                        reason: format!("({lo}, {hi}) Hz is not a band"),
                    });
                }
            }
        }
        Ok(())
    }

    /// Steps 1 to 4: the stabilization diagram, the modes at the chosen order
    /// and their LSFD residues.
    pub fn modal(&self, frf: &Frf) -> Result<FrfModal, FrfIdentError> {
        self.check()?;
        let diagram = self.lscf_params().fit(frf)?;
        let order = match self.order {
            FrfOrder::Fixed(p) => p,
            FrfOrder::Auto { .. } => diagram.auto_order().ok_or(FrfIdentError::NoStableModes {
                band_hz: diagram.band_hz,
                max_order: diagram.max_order,
            })?,
        };
        let mut poles: Vec<C64> = diagram
            .stable_physical_at(order)
            .iter()
            .map(|p| p.pole)
            .collect();
        let lsfd_params = self.lsfd_params();
        let shift = self.exponential_tau_s.map_or(0.0, |tau| 1.0 / tau);
        let mut rejected = Vec::new();
        loop {
            if poles.is_empty() {
                return Err(FrfIdentError::NoStableModes {
                    band_hz: diagram.band_hz,
                    max_order: order,
                });
            }
            let lsfd = lsfd_params.fit(frf, &poles)?;
            let modes = modes_from_lsfd(&lsfd, diagram.dt_s, shift)?;
            // Poles that left the physical range first (a runaway pole can
            // have a huge contribution and dwarf the others), then the
            // insignificant ones, each followed by a new fit.
            let (lo, hi) = diagram.band_hz;
            // (On the measured poles: with an exponential window they are
            // what the FRFs show.)
            let left: Vec<Option<RejectReason>> = lsfd
                .poles
                .iter()
                .map(|&p| {
                    let (f, z) = (p.norm() / (2.0 * std::f64::consts::PI), -p.re / p.norm());
                    let physical = z > 0.0 && z <= self.max_damping_ratio && f >= lo && f <= hi;
                    (!physical).then_some(RejectReason::LeftPhysicalRange { refined: p })
                })
                .collect();
            let reasons = if left.iter().any(Option::is_some) {
                left
            } else {
                modes
                    .iter()
                    .map(|md| {
                        (md.indicators.msv_relative < self.min_contribution).then_some(
                            RejectReason::Insignificant {
                                contribution: md.indicators.msv_relative,
                            },
                        )
                    })
                    .collect()
            };
            if reasons.iter().all(Option::is_none) {
                // Ascending frequency (refinement may swap close modes).
                let mut order_idx: Vec<usize> = (0..modes.len()).collect();
                order_idx.sort_by(|&a, &b| modes[a].frequency_hz.total_cmp(&modes[b].frequency_hz));
                let modes = order_idx.iter().map(|&j| modes[j].clone()).collect();
                let mut lsfd = lsfd;
                lsfd.permute(&order_idx);
                return Ok(FrfModal {
                    diagram,
                    order,
                    modes,
                    lsfd,
                    rejected,
                    exponential_tau_s: self.exponential_tau_s,
                });
            }
            // Refit without them, from the pLSCF poles of the others.
            let mut kept = Vec::new();
            for (pole, reason) in poles.iter().zip(reasons) {
                match reason {
                    Some(reason) => rejected.push(RejectedMode {
                        frequency_hz: pole.norm() / (2.0 * std::f64::consts::PI),
                        damping_ratio: -pole.re / pole.norm(),
                        reason,
                    }),
                    None => kept.push(*pole),
                }
            }
            poles = kept;
        }
    }

    /// The whole route: modes, MKR and Rayleigh damping.
    pub fn identify(&self, frf: &Frf) -> Result<FrfIdentification, FrfIdentError> {
        self.check()?;
        frf.validate()?;
        let (m, r) = (frf.outputs_count(), frf.references_count());
        let mkr_params = MkrParams {
            collocated: self.collocated,
            polarity: self.polarity,
        };
        mkr_params.check(m, r)?;
        let FrfModal {
            diagram,
            order,
            mut modes,
            mut lsfd,
            rejected,
            exponential_tau_s,
        } = self.modal(frf)?;
        let selected = self.select(&modes, m, order)?;
        let mut warnings = Vec::new();
        let out_of_model: Vec<usize> = (0..modes.len()).filter(|j| !selected.contains(j)).collect();
        if !out_of_model.is_empty() {
            warnings.push(Warning::ExtraStructuralModes {
                kept_hz: selected.iter().map(|&j| modes[j].frequency_hz).collect(),
                dropped_hz: out_of_model
                    .iter()
                    .map(|&j| modes[j].frequency_hz)
                    .collect(),
            });
        }
        let chosen: Vec<Mode> = selected.iter().map(|&j| modes[j].clone()).collect();
        let d = match (frf.quantity, lsfd.residual(0)) {
            (FrfQuantity::Accelerance, Some(direct)) => direct.clone(),
            _ => {
                // 2 Re sum_j lambda_j R_j = 2 Re sum_j (lambda_j^2 R_j) / lambda_j
                let mut d = DMatrix::<f64>::zeros(m, r);
                for md in &chosen {
                    d += md.residue.map(|x| 2.0 * (x / md.pole).re);
                }
                d
            }
        };
        let mkr = mkr_params.fit(&chosen, &d)?;
        if mkr.polarity_flipped {
            warnings.push(Warning::PolarityFlipped {
                driving_point: -mkr.driving_point,
            });
            lsfd.negate();
            for md in &mut modes {
                md.residue.neg_mut();
            }
        }
        if mkr.driving_point <= 0.0 {
            warnings.push(Warning::DrivingPointNotPositive {
                value: mkr.driving_point,
            });
        }
        if mkr.consistency > CONSISTENCY_WARNING {
            warnings.push(Warning::SecondOrderInconsistent {
                consistency: mkr.consistency,
            });
        }
        warnings.extend(crate::pipeline::weak_driving_point(&mkr, &chosen));
        let frequencies_hz: Vec<f64> = chosen.iter().map(|md| md.frequency_hz).collect();
        let damping_ratios: Vec<f64> = chosen.iter().map(|md| md.damping_ratio).collect();
        let rayleigh = Rayleigh::fit(&frequencies_hz, &damping_ratios)?;
        if rayleigh.alpha < 0.0 || rayleigh.beta < 0.0 {
            warnings.push(Warning::NegativeRayleigh {
                alpha: rayleigh.alpha,
                beta: rayleigh.beta,
            });
        }
        let damping_rayleigh = rayleigh.damping(&mkr.mass, &mkr.stiffness);
        let mode_shapes = DMatrix::from_fn(m, selected.len(), |i, j| modes[selected[j]].shape[i]);
        let result = FrfIdentification {
            modes,
            mkr_modes: selected,
            out_of_model,
            frequencies_hz,
            damping_ratios,
            mode_shapes,
            rayleigh,
            mass: mkr.mass,
            stiffness: mkr.stiffness,
            damping_mkr: mkr.damping,
            damping_rayleigh,
            consistency: mkr.consistency,
            w: mkr.w,
            polarity_flipped: mkr.polarity_flipped,
            warnings,
            quantity: frf.quantity,
            order,
            diagram,
            lsfd,
            rejected,
            exponential_tau_s,
        };
        result.ensure_finite()?;
        Ok(result)
    }

    /// Indices (ascending) of the `count` modes MKR uses.
    fn select(
        &self,
        modes: &[Mode],
        count: usize,
        order: usize,
    ) -> Result<Vec<usize>, FrfIdentError> {
        let frequencies_hz: Vec<f64> = modes.iter().map(|md| md.frequency_hz).collect();
        let mut idx: Vec<usize> = match &self.selection {
            ModeSelection::Largest => {
                if modes.len() < count {
                    return Err(FrfIdentError::ModeCount {
                        found: modes.len(),
                        required: count,
                        what: "identified modes",
                        order,
                        frequencies_hz,
                    });
                }
                let mut idx: Vec<usize> = (0..modes.len()).collect();
                idx.sort_by(|&a, &b| modes[b].indicators.msv.total_cmp(&modes[a].indicators.msv));
                idx.truncate(count);
                idx
            }
            ModeSelection::Nearest {
                frequency_hz: targets,
                tolerance,
            } => {
                if targets.len() != count {
                    return Err(FrfIdentError::InvalidParams {
                        field: "selection",
                        reason: format!(
                            "{} target frequencies for {count} outputs (MKR needs one mode per output)",
                            targets.len()
                        ),
                    });
                }
                let mut idx = Vec::with_capacity(count);
                for &target in targets {
                    let nearest = (0..modes.len()).min_by(|&a, &b| {
                        (frequencies_hz[a] - target)
                            .abs()
                            .total_cmp(&(frequencies_hz[b] - target).abs())
                    });
                    match nearest {
                        Some(j)
                            if (frequencies_hz[j] / target - 1.0).abs() <= *tolerance
                                && !idx.contains(&j) =>
                        {
                            idx.push(j)
                        }
                        _ => {
                            return Err(FrfIdentError::ModeNotFound {
                                target_hz: target,
                                nearest_hz: nearest.map(|j| frequencies_hz[j]),
                                tolerance: *tolerance,
                            });
                        }
                    }
                }
                idx
            }
            &ModeSelection::Band(lo, hi) => {
                let idx: Vec<usize> = (0..modes.len())
                    .filter(|&j| frequencies_hz[j] >= lo && frequencies_hz[j] <= hi)
                    .collect();
                if idx.len() != count {
                    return Err(FrfIdentError::ModeCount {
                        found: idx.len(),
                        required: count,
                        what: "modes in the selection band",
                        order,
                        frequencies_hz: idx.iter().map(|&j| frequencies_hz[j]).collect(),
                    });
                }
                idx
            }
        };
        idx.sort_unstable();
        Ok(idx)
    }
}

/// [`Mode`]s from an LSFD fit (see step 4 of the module docs), each pole
/// moved by `+shift` (rad/s; the exponential window's `1 / tau`).
fn modes_from_lsfd(lsfd: &Lsfd, dt_s: f64, shift: f64) -> Result<Vec<Mode>, FrfIdentError> {
    let q = lsfd.quantity.derivative_order();
    let mut modes = Vec::with_capacity(lsfd.poles.len());
    for (j, &measured) in lsfd.poles.iter().enumerate() {
        let pole = measured + shift;
        let accelerance = lsfd.residues[j].map(|a| a * pole.powi(2 - q));
        let (shape, acc) = rank_one(&accelerance).map_err(|source| FrfIdentError::Linalg {
            stage: "rank-one part of a residue",
            source,
        })?;
        let mpc = mpc(shape.as_slice());
        // Peak of the mode's term in the measured FRF.
        let msv = lsfd.residues[j].norm() / measured.re.abs().max(f64::MIN_POSITIVE);
        modes.push(Mode {
            frequency_hz: pole.norm() / (2.0 * std::f64::consts::PI),
            damping_ratio: -pole.re / pole.norm(),
            eigenvalue: (pole * dt_s).exp(),
            pole,
            shape,
            residue: acc,
            indicators: Indicators {
                emac_output: None,
                emac_input: None,
                mpc,
                msv,
                msv_relative: 0.0,
                cmi: mpc,
            },
            structural: true,
        });
    }
    let max = modes.iter().map(|md| md.indicators.msv).fold(0.0, f64::max);
    for md in &mut modes {
        md.indicators.msv_relative = if max > 0.0 {
            md.indicators.msv / max
        } else {
            0.0
        };
    }
    Ok(modes)
}

impl FrfIdentification {
    fn ensure_finite(&self) -> Result<(), FrfIdentError> {
        for (quantity, m) in [
            ("mass", &self.mass),
            ("stiffness", &self.stiffness),
            ("damping_mkr", &self.damping_mkr),
            ("damping_rayleigh", &self.damping_rayleigh),
        ] {
            if linalg::first_non_finite(m).is_some() {
                return Err(FrfIdentError::NonFiniteResult { quantity });
            }
        }
        let scalars = self
            .frequencies_hz
            .iter()
            .chain(&self.damping_ratios)
            .chain([&self.rayleigh.alpha, &self.rayleigh.beta, &self.consistency]);
        if scalars.into_iter().any(|x| !x.is_finite()) {
            return Err(FrfIdentError::NonFiniteResult {
                quantity: "modal parameters",
            });
        }
        if self
            .mode_shapes
            .iter()
            .any(|z| !(z.re.is_finite() && z.im.is_finite()))
        {
            return Err(FrfIdentError::NonFiniteResult {
                quantity: "mode shapes",
            });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests;
