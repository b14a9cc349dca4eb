//! Identification of mass, stiffness and damping matrices of shear-frame models from
//! impact-hammer records.
//!
//! The chain follows Guida, Nilvetti and Pappalardo (COMPDYN 2011):
//! [OKID](okid) (observer/Kalman filter identification) gives the Markov parameters of the
//! tested structure from input/output records, [ERA/DC](era) turns them into a discrete state
//! space realization, [`modal`] extracts poles, mode shapes and accuracy indicators,
//! [`rayleigh`] fits proportional damping and [`mkr`] builds the second-order model
//! (M, K and damping). [`pipeline::Identifier`] runs the whole chain. [`refine`] then
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
pub mod era;
pub mod frf;
pub mod jackknife;
pub mod linalg;
pub mod mkr;
pub mod modal;
pub mod okid;
pub mod pipeline;
pub mod rayleigh;
pub mod record;
pub mod refine;
pub mod statespace;

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

#[cfg(test)]
mod testutil;

/// Runs `op` on a thread of rayon's global pool (at once if this is one). A refinement runs
/// a few dozen short parallel passes; started from outside the pool, each would hand its
/// work to the pool and put the caller to sleep until it is done (two context switches per
/// pass), while from a pool thread the caller takes part in the pass. Another pool thread
/// is kept awake for the call ([`KeepAwake`]). The arithmetic is the same on any thread.
pub(crate) fn on_pool<R: Send>(op: impl FnOnce() -> R + Send) -> R {
    if rayon::current_thread_index().is_some() {
        return op();
    }
    rayon::scope(|_| {
        let _awake = KeepAwake::start();
        op()
    })
}

/// Whether an [`on_pool`] call has a pool thread kept awake for it: one at a time, so that
/// two helpers can never wait on each other.
static KEPT_AWAKE: AtomicBool = AtomicBool::new(false);

/// Longest time a helper of [`KeepAwake`] stays, whatever happens to its call.
const KEEP_AWAKE_MAX: Duration = Duration::from_secs(2);

/// Keeps a second pool thread awake while an [`on_pool`] call runs. An idle rayon thread
/// sleeps after about 32 rounds of `sched_yield` (tens of microseconds), and waking it took
/// about 0.2 ms on the 2-vCPU machine of the benchmarks: between the refinement's serial
/// steps and its passes (about 30 per refinement) the second thread joined each pass late
/// (pass 1 of the likelihood ran 1.26 times faster on two threads than on one, the
/// Jacobian pass 1.79 times). The helper is a job that runs the pool's pending work
/// (`rayon::yield_now`) and spins in between, until the call ends (the guard's drop, also
/// on unwinding) or [`KEEP_AWAKE_MAX`] has passed; on the call's own thread it returns at
/// once. Refinement bench, two threads: 8.8 ms without, 7.85 ms with.
struct KeepAwake {
    done: Option<Arc<AtomicBool>>,
}

impl KeepAwake {
    fn start() -> Self {
        if rayon::current_num_threads() < 2 || KEPT_AWAKE.swap(true, Ordering::AcqRel) {
            return Self { done: None };
        }
        let owner = rayon::current_thread_index();
        let done = Arc::new(AtomicBool::new(false));
        let flag = Arc::clone(&done);
        rayon::spawn(move || {
            if rayon::current_thread_index() == owner {
                return;
            }
            let start = Instant::now();
            while !flag.load(Ordering::Acquire) && start.elapsed() < KEEP_AWAKE_MAX {
                if rayon::yield_now() != Some(rayon::Yield::Executed) {
                    std::hint::spin_loop();
                }
            }
        });
        Self { done: Some(done) }
    }
}

impl Drop for KeepAwake {
    fn drop(&mut self) {
        if let Some(done) = &self.done {
            done.store(true, Ordering::Release);
            KEPT_AWAKE.store(false, Ordering::Release);
        }
    }
}
pub use campaign::Campaign;
pub use era::{Correlation, Era, EraError, EraParams, ModelOrder};
pub use frf::{Frf, FrfError, FrfQuantity};
pub use jackknife::{
    Jackknife, UncertaintyError, hit_groups, jackknife, jackknife_in_groups, leave_one_out,
};
pub use mkr::{CollocatedPair, Mkr, MkrError, MkrParams, PolarityPolicy};
pub use modal::{Indicators, Intersample, ModalModel, ModalParams, Mode, StructuralRule};
pub use okid::{InitialState, ObserverOrder, Okid, OkidError, OkidParams};

pub use pipeline::{
    Error, Identification, Identifier, MAX_MODE_SUBSETS, ModeSelection, SelectionRule,
    ValidIdentifier, Warning, shear_frame_defect,
};
pub use rayleigh::{Rayleigh, RayleighError};
pub use record::{Channel, DataError, Record};
pub use refine::{
    Dashpot, ModalEstimate, Node, NoiseLevels, NoiseModel, Parametrization, RefineError,
    Refinement, Refiner, SecondOrder, StopReason, Uncertainty,
};
pub use statespace::StateSpace;

#[cfg(test)]
mod on_pool_tests {
    use super::*;
    use rayon::prelude::*;
    use std::panic::{AssertUnwindSafe, catch_unwind};

    /// Calls from several threads outside the pool at once, each with parallel work inside,
    /// all finish with the serial loop's sum (at most one has a helper, and no helper waits
    /// on another).
    #[test]
    fn concurrent_calls_from_outside_the_pool_finish() {
        let want: u64 = (0..20_000u64).map(|i| i * i % 7).sum();
        std::thread::scope(|s| {
            for _ in 0..4 {
                s.spawn(|| {
                    for _ in 0..50 {
                        let got = on_pool(|| {
                            (0..20_000u64)
                                .into_par_iter()
                                .map(|i| i * i % 7)
                                .sum::<u64>()
                        });
                        assert_eq!(got, want);
                    }
                });
            }
        });
    }

    /// A call that panics releases its helper: the guard's drop runs on unwinding. Other
    /// tests may hold the one helper at the time, so the call is retried until one gets it.
    #[test]
    fn a_panicking_call_releases_its_helper() {
        let mut released = 0;
        for _ in 0..1000 {
            let mut seen = None;
            let outcome = catch_unwind(AssertUnwindSafe(|| {
                rayon::scope(|_| {
                    let awake = KeepAwake::start();
                    seen = awake.done.clone();
                    panic!("the call fails");
                })
            }));
            assert!(outcome.is_err(), "the panic reaches the caller");
            if let Some(done) = seen {
                assert!(done.load(Ordering::Acquire), "the helper was told to stop");
                released += 1;
                break;
            }
        }
        assert_eq!(released, 1, "no call got the helper in 1000 tries");
    }
}
