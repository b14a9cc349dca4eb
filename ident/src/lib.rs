//! Identification of mass, stiffness and damping matrices of shear-frame models from
//! impact-hammer records.
//!
//! The chain follows Guida, Nilvetti and Pappalardo (COMPDYN 2011):
//! [OKID](okid) (observer/Kalman filter identification) gives the Markov parameters of the
//! tested structure from input/output records, [ERA/DC](era) turns them into a discrete state
//! space realization, [`modal`] extracts poles, mode shapes and accuracy indicators,
//! [`rayleigh`] fits proportional damping and [`mkr`] builds the second-order model
//! (M, K and damping). [`pipeline::Identifier`] runs the whole chain;
//! [`Identifier::prepare`] validates a campaign's records and accumulates their OKID
//! moments once for the joint identification, subsets of the hits and the [jackknife](mod@jackknife)
//! error bars ([`jackknife_prepared`]). [`refine`] then
//! refines M, K and damping by maximum likelihood on all hits at once (any symmetric
//! damping, with standard errors) and gives the Cramér–Rao bound of a campaign.
//! [`frf::FrfIdentifier`] reaches the same M, K and damping from measured FRFs instead
//! (pLSCF stabilization diagram, LSFD residues, then MKR and Rayleigh), and
//! [`frf::refine`] refines them by maximum likelihood on the FRFs themselves (weights from
//! the coherence and the number of averages, standard errors).
//!
//! # Conventions
//!
//! * Discrete state space: `x[k+1] = A x[k] + B u[k]`, `y[k] = C x[k] + D u[k]`, sample
//!   interval `dt_s` in seconds. Markov parameters: `Y_0 = D`, `Y_k = C A^(k-1) B`.
//! * `C` is always the output matrix. The damping matrix is always called `damping`
//!   (`damping_mkr`, `damping_rayleigh`), never `C`.
//! * Units are part of names: `dt_s`, `frequency_hz`. Continuous poles are in rad/s.
//! * A [`Record`] holds `inputs` (r x N, newtons) and `outputs` (m x N, absolute
//!   accelerations in m/s^2) as `nalgebra::DMatrix<f64>`, one column per sample. Several
//!   records (hits) of possibly different lengths are identified jointly; they share `dt_s`.
//!   Output `i` is degree of freedom `i` (an accelerometer at every floor).
//! * Modes are reported in ascending frequency, one entry per complex-conjugate pair (the
//!   member with `Im(lambda) > 0`). Real eigenvalues of the realization are listed apart.
//! * Reported mode shapes are the complex output shapes `C psi`, scaled so that their
//!   largest-magnitude component is `1 + 0i`. Inside MKR the eigenvectors are scaled as in
//!   the paper's eq. 28 (`Psi^T Vc Psi = I`), which makes `Psi = [W; W Lambda_c]`.
//! * The intersample behaviour of the records is a choice ([`modal::Intersample`]):
//!   `Zoh` for inputs held over each sample (the paper's assumption, exact for simulations
//!   and DAC-driven shakers) and `Bandlimited` for analyzer records (anti-alias low-pass then
//!   sampling). It fixes how discrete modal inputs are converted to continuous time and the
//!   OKID/ERA defaults (see [`pipeline::Identifier`]).
//!
//! # Style
//!
//! Every algorithm has parameters with a `check()` that validates them once and returns a
//! typed error, a `fit` that consumes data and returns a result struct with public fields.
//! Stop reasons and warnings are data ([`pipeline::Warning`]), never panics. Bad data give
//! typed errors with diagnostic fields; matrices of inconsistent shapes passed by code are
//! programming errors and trip assertions.
//!
//! # Example
//!
//! ```
//! use ident::{Identifier, Intersample};
//! use nalgebra::DMatrix;
//!
//! // The realization printed in the paper (case 1, eq. 31-34), dt = 1/64 s.
//! let a = DMatrix::from_row_slice(4, 4, &[
//!     0.6220, -0.7789, -0.0003, -0.0021,
//!     0.7839, 0.6191, 0.0031, -0.0012,
//!     -0.0036, 0.0061, 0.9623, 0.2616,
//!     0.0041, 0.0044, -0.2676, 0.9634,
//! ]);
//! let b = DMatrix::from_column_slice(4, 1, &[0.0541, -0.0268, 0.0412, 0.0363]);
//! let c = DMatrix::from_row_slice(2, 4, &[
//!     -37.8710, -5.0124, -5.8513, 1.8479,
//!     26.5700, 3.2700, -7.2966, 2.2001,
//! ]);
//! let d = DMatrix::from_column_slice(2, 1, &[3.6387, 0.0739]);
//! let result = Identifier::default()
//!     .intersample(Intersample::Zoh)
//!     .from_realization(1.0 / 64.0, a, b, c, d)
//!     .unwrap();
//! assert!((result.frequencies_hz[0] - 2.7314).abs() < 1e-3);
//! assert!((result.mass[(0, 0)] - 0.2913).abs() < 1e-3);
//! ```

#![deny(missing_docs)]

pub mod campaign;
pub mod cpu;
pub mod era;
pub mod frf;
pub mod jackknife;
pub mod linalg;
pub mod mkr;
pub mod modal;
pub mod okid;
pub mod parallel;
pub mod pipeline;
pub mod rayleigh;
pub mod record;
pub mod refine;
pub mod statespace;

#[cfg(test)]
mod testutil;

pub use campaign::Campaign;
pub use era::{Correlation, Era, EraError, EraParams, ModelOrder};
pub use frf::{Frf, FrfError, FrfQuantity};
pub use jackknife::{
    Jackknife, UncertaintyError, hit_groups, jackknife, jackknife_in_groups, jackknife_prepared,
    leave_one_out,
};
pub use mkr::{CollocatedPair, Mkr, MkrError, MkrParams, PolarityPolicy};
pub use modal::{Indicators, Intersample, ModalModel, ModalParams, Mode, StructuralRule};
pub use okid::{InitialState, ObserverOrder, Okid, OkidError, OkidParams};

pub use pipeline::{
    Error, Identification, Identifier, MAX_MODE_SUBSETS, ModeSelection, PreparedRecords,
    SelectionRule, ValidIdentifier, Warning, shear_frame_defect,
};
pub use rayleigh::{Rayleigh, RayleighError};
pub use record::{Channel, DataError, Record};
pub use refine::{
    Dashpot, ModalEstimate, Node, NoiseLevels, NoiseModel, Parametrization, RefineError,
    Refinement, Refiner, SecondOrder, StopReason, Uncertainty,
};
pub use statespace::StateSpace;
