//! The whole chain: records -> OKID -> ERA/DC -> modes -> MKR and Rayleigh damping.
//!
//! ```no_run
//! use ident::{Identifier, Intersample, Record};
//! # fn records() -> Vec<Record> { unimplemented!() }
//! let result = Identifier::default()
//!     .intersample(Intersample::Bandlimited)
//!     .collocated(0, 0)
//!     .identify(&records(), 1.0 / 64.0)?;
//! println!("M = {}", result.mass);
//! for w in &result.warnings {
//!     println!("warning: {w}");
//! }
//! # Ok::<(), ident::Error>(())
//! ```
//!
//! # Defaults
//!
//! | setting | `Zoh` | `Bandlimited` |
//! |---|---|---|
//! | OKID leads `q` | 0 | 8 |
//! | OKID `rcond` | 1e-8 | 1e-4 |
//! | ERA Markov offset `k0` | 0 | 10 |
//!
//! Both: observer order automatic up to 20 (BIC), ERA/DC with `xi = zeta = 2`, Hankel size
//! from the data ([`crate::era`]), model order automatic up to 20 and at most `p_max m` (the
//! observer's state count; largest singular-value gap, moved to the next candidates if it
//! shows fewer structural modes than DOFs),
//! collocated pair output 0 / input 0, polarity flipped with a warning.
//! `Bandlimited` is the default intersample assumption because analyzer records are
//! band-limited; use `Zoh` for held inputs (simulations that hold the force per sample,
//! DAC-driven shakers) and for the paper's published realizations.
//!
//! Band-limited records need a pre-trigger: the filtered force and response start before
//! the hit, and what precedes the record is taken as zero. Keep the hit at least `2 q`
//! (16) samples into every record; [`Warning::ShortPretrigger`] flags records that do not.

use crate::era::{Correlation, EraError, EraParams, HankelShape, ModelOrder};
use crate::linalg::{self, C64};
use crate::mkr::{CollocatedPair, MkrError, MkrParams, PolarityPolicy};
use crate::modal::{Intersample, ModalError, ModalModel, ModalParams, Mode, StructuralRule};
use crate::okid::{InitialState, Moments, ObserverOrder, OkidError, OkidParams};
use crate::rayleigh::{Rayleigh, RayleighError};
use crate::record::{self, DataError, Record};
use crate::statespace::StateSpace;
use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

mod stabilization;
pub use stabilization::{Stability, StabilizationCriteria, StabilizationPoint};

use std::fmt;

/// Consistency `||W W^T|| / ||W Lc W^T||` above which a warning is issued.
pub const CONSISTENCY_WARNING: f64 = 0.1;

/// Share of the driving point's `(M^-1)[k,k] = sum_j 2 Re(W[k,j]^2 lambda_j)` (in
/// `|W[k,j]^2 lambda_j|`, as [`crate::mkr::POLARITY_VOTE_SHARE`]) below which a mode is
/// reported as weakly driven ([`Warning::WeakDrivingPoint`]): the hit is near a node of that
/// mode, whose mass normalization, and with it M and K, then rests on a small, noisy residue.
/// Measured on a two-storey frame (masses 0.3 kg, stiffness 600/400 N/m with coupling -k12,
/// Rayleigh damping of paper case 1, hit at floor 1, 10 hits, 1 % noise, seed 1): the weakly
/// driven mode's share 0.13 % (k12 = 7), 0.56 % (15), 2.1 % (30) and 15 % (100) gave M off by
/// 2.4 %, 0.87 %, 0.41 % and 0.050 %, and the jackknife standard error of M22 was 22 %, 2.3 %,
/// 0.36 % and 0.12 % of it: below 1 % the error is over ten times that of a well-driven frame.
/// The bundled scenarios' smallest share is 6.8 % (the three-storey frame's first mode).
pub const WEAK_DRIVING_POINT_SHARE: f64 = 0.01;

/// [`Warning::WeakDrivingPoint`] for every mode of `modes` (those MKR used, `mkr` their fit)
/// whose share of the driving point ([`crate::mkr::Mkr::driving_point_shares`]) is below
/// [`WEAK_DRIVING_POINT_SHARE`].
pub(crate) fn weak_driving_point(mkr: &crate::mkr::Mkr, modes: &[Mode]) -> Vec<Warning> {
    mkr.driving_point_shares
        .iter()
        .zip(modes)
        .enumerate()
        .filter(|(_, (share, _))| **share < WEAK_DRIVING_POINT_SHARE)
        .map(|(j, (&share, md))| Warning::WeakDrivingPoint {
            mode: j,
            frequency_hz: md.frequency_hz,
            share,
        })
        .collect()
}

/// Which structural modes form the n-DOF model (n = outputs) when the
/// realization holds more structural modes than that: real structures have
/// torsional, out-of-plane and local modes in the band that a shear model
/// lacks. The structural modes left out are reported as out-of-model modes
/// ([`Identification::out_of_model_modes`]); none is ever refused for being
/// there.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(rename_all = "kebab-case", tag = "kind")]
pub enum ModeSelection {
    /// The n structural modes whose MKR model is closest to a shear frame:
    /// M and K positive definite, adjacent floors coupled by springs
    /// (negative `K[i, i+1]`), and the smallest
    /// [`shear_frame_defect`] (M's off-diagonal part over its diagonal plus
    /// the row sums of K above the first floor over K: both 0 for a shear
    /// frame with lumped masses). Second-order consistency cannot choose:
    /// any n lightly damped modes with real shapes make a consistent n-DOF
    /// second-order model, a torsional mode included; what they do not make
    /// is a shear frame. With more than [`MAX_MODE_SUBSETS`] subsets, or no
    /// admissible one, the most consistent and significant modes (largest
    /// `cmi * msv_relative`) are kept.
    #[default]
    Auto,
    /// The structural modes between `low_hz` and `high_hz` (inclusive);
    /// more than n inside are chosen as by [`ModeSelection::Auto`].
    Band {
        /// Lower edge, Hz.
        low_hz: f64,
        /// Upper edge, Hz.
        high_hz: f64,
    },
    /// The structural mode nearest to each of these frequencies (one per
    /// output, Hz).
    Near {
        /// Approximate natural frequencies, Hz.
        frequencies_hz: Vec<f64>,
    },
}

/// Largest number of n-mode subsets [`ModeSelection::Auto`] compares (each
/// costs one MKR fit of n modes, microseconds for a few DOFs).
pub const MAX_MODE_SUBSETS: usize = 1000;

/// How the modes used by MKR were chosen.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SelectionRule {
    /// As many structural modes as outputs: all of them.
    AllStructural,
    /// The subset whose M and K are closest to a shear frame's.
    ShearFrame,
    /// The most consistent and significant modes (`cmi * msv_relative`).
    Significance,
    /// The user's band (with one of the rules above inside it if needed).
    Band,
    /// The modes nearest the user's frequencies.
    Near,
}

impl SelectionRule {
    /// Short description, as in messages.
    pub fn describe(self) -> &'static str {
        match self {
            SelectionRule::AllStructural => "every structural mode",
            SelectionRule::ShearFrame => {
                "the subset whose M and K are closest to a shear frame (diagonal M, each floor above the first held by its storey springs)"
            }
            SelectionRule::Significance => "the most consistent and significant modes (CMI x MSV)",
            SelectionRule::Band => "the structural modes inside the band given",
            SelectionRule::Near => "the structural modes nearest the frequencies given",
        }
    }
}

/// Identification parameters. `Identifier::default()` plus setters covers common use; the
/// fields are public for configuration files. `None` means "default for the intersample
/// assumption" (see the module docs).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Identifier {
    /// Intersample assumption of the records.
    pub intersample: Intersample,
    /// OKID observer order.
    pub observer_order: ObserverOrder,
    /// OKID input leads.
    pub leads: Option<usize>,
    /// OKID relative truncation.
    pub rcond: Option<f64>,
    /// How many times OKID may raise `rcond` tenfold to stabilize the observer.
    pub max_rcond_raises: usize,
    /// ERA Markov offset `k0`.
    pub markov_offset: Option<usize>,
    /// ERA Hankel block rows.
    pub block_rows: Option<usize>,
    /// ERA Hankel block columns.
    pub block_cols: Option<usize>,
    /// ERA or ERA/DC.
    pub correlation: Correlation,
    /// Model order of the realization.
    pub order: ModelOrder,
    /// Collocated force/accelerometer pair.
    pub collocated: CollocatedPair,
    /// What to do with an inverted polarity.
    pub polarity: PolarityPolicy,
    /// Structural-mode rule.
    pub rule: StructuralRule,
    /// Number of degrees of freedom, if known (must equal the number of outputs).
    pub dofs: Option<usize>,
    /// Which structural modes form the model when there are more than
    /// outputs.
    #[serde(default)]
    pub modes: ModeSelection,
    /// The state at the start of every record (OKID, see [`InitialState`]).
    #[serde(default)]
    pub initial_state: InitialState,
}

impl Default for Identifier {
    fn default() -> Self {
        Self {
            intersample: Intersample::Bandlimited,
            observer_order: ObserverOrder::Auto { max: 20 },
            leads: None,
            rcond: None,
            max_rcond_raises: 4,
            markov_offset: None,
            block_rows: None,
            block_cols: None,
            correlation: Correlation::Dc { xi: 2, zeta: 2 },
            order: ModelOrder::Auto { max: 20 },
            collocated: CollocatedPair::default(),
            polarity: PolarityPolicy::default(),
            rule: StructuralRule::default(),
            dofs: None,
            modes: ModeSelection::Auto,
            initial_state: InitialState::AtRest,
        }
    }
}

impl Identifier {
    /// Sets the intersample assumption.
    pub fn intersample(mut self, intersample: Intersample) -> Self {
        self.intersample = intersample;
        self
    }

    /// Sets the OKID observer order.
    pub fn observer_order(mut self, order: ObserverOrder) -> Self {
        self.observer_order = order;
        self
    }

    /// Sets what OKID assumes about the state at the start of every record.
    pub fn initial_state(mut self, initial_state: InitialState) -> Self {
        self.initial_state = initial_state;
        self
    }

    /// Sets the OKID input leads.
    pub fn leads(mut self, leads: usize) -> Self {
        self.leads = Some(leads);
        self
    }

    /// Sets the OKID relative truncation.
    pub fn rcond(mut self, rcond: f64) -> Self {
        self.rcond = Some(rcond);
        self
    }

    /// Sets how many times OKID may raise `rcond`.
    pub fn max_rcond_raises(mut self, raises: usize) -> Self {
        self.max_rcond_raises = raises;
        self
    }

    /// Sets the ERA Markov offset.
    pub fn markov_offset(mut self, offset: usize) -> Self {
        self.markov_offset = Some(offset);
        self
    }

    /// Sets the ERA Hankel block rows and columns.
    pub fn blocks(mut self, block_rows: usize, block_cols: usize) -> Self {
        self.block_rows = Some(block_rows);
        self.block_cols = Some(block_cols);
        self
    }

    /// Sets ERA or ERA/DC.
    pub fn correlation(mut self, correlation: Correlation) -> Self {
        self.correlation = correlation;
        self
    }

    /// Sets the model order.
    pub fn order(mut self, order: ModelOrder) -> Self {
        self.order = order;
        self
    }

    /// Sets the collocated pair (output index, input index).
    pub fn collocated(mut self, output: usize, input: usize) -> Self {
        self.collocated = CollocatedPair { output, input };
        self
    }

    /// Sets the polarity policy.
    pub fn polarity(mut self, policy: PolarityPolicy) -> Self {
        self.polarity = policy;
        self
    }

    /// Sets the structural-mode rule.
    pub fn rule(mut self, rule: StructuralRule) -> Self {
        self.rule = rule;
        self
    }

    /// Sets the number of degrees of freedom.
    pub fn dofs(mut self, dofs: usize) -> Self {
        self.dofs = Some(dofs);
        self
    }

    /// Sets how the modes of the model are chosen among more structural
    /// modes than outputs.
    pub fn mode_selection(mut self, modes: ModeSelection) -> Self {
        self.modes = modes;
        self
    }

    /// Validates the parameters and resolves the defaults.
    pub fn check(&self) -> Result<ValidIdentifier, Error> {
        let base = match self.intersample {
            Intersample::Zoh => OkidParams::zoh(),
            Intersample::Bandlimited => OkidParams::bandlimited(),
        };
        let okid = OkidParams {
            order: self.observer_order,
            leads: self.leads.unwrap_or(base.leads),
            rcond: self.rcond.unwrap_or(base.rcond),
            max_rcond_raises: self.max_rcond_raises,
            markov_count: base.markov_count,
            initial_state: self.initial_state,
        };
        okid.check().map_err(Error::from_okid)?;
        let default_offset = match self.intersample {
            Intersample::Zoh => 0,
            Intersample::Bandlimited => 10,
        };
        let era = EraParams {
            block_rows: self.block_rows,
            block_cols: self.block_cols,
            correlation: self.correlation,
            offset: self.markov_offset.unwrap_or(default_offset),
            order: self.order,
        };
        era.check()?;
        let modal = ModalParams {
            intersample: self.intersample,
            rule: self.rule,
        };
        modal.check()?;
        if self.dofs == Some(0) {
            return Err(Error::InvalidParams {
                reason: "the number of degrees of freedom must be at least 1".into(),
            });
        }
        match &self.modes {
            ModeSelection::Auto => {}
            ModeSelection::Band { low_hz, high_hz } => {
                if !(low_hz.is_finite()
                    && high_hz.is_finite()
                    && 0.0 <= *low_hz
                    && low_hz < high_hz)
                {
                    return Err(Error::InvalidParams {
                        reason: format!(
                            "mode band {low_hz}-{high_hz} Hz: needs 0 <= low < high, both finite"
                        ),
                    });
                }
            }
            ModeSelection::Near { frequencies_hz } => {
                if frequencies_hz.is_empty()
                    || frequencies_hz.iter().any(|f| !(f.is_finite() && *f > 0.0))
                {
                    return Err(Error::InvalidParams {
                        reason: format!(
                            "mode frequencies {frequencies_hz:?} Hz: need one or more positive finite values"
                        ),
                    });
                }
            }
        }
        Ok(ValidIdentifier {
            okid,
            era,
            modal,
            mkr: MkrParams {
                collocated: self.collocated,
                polarity: self.polarity,
            },
            dofs: self.dofs,
            modes: self.modes.clone(),
        })
    }

    /// Identifies M, K and damping from records sampled every `dt_s` seconds.
    pub fn identify(&self, records: &[Record], dt_s: f64) -> Result<Identification, Error> {
        self.check()?.identify(records, dt_s)
    }

    /// Validates `records` (sampled every `dt_s` seconds) once and accumulates their OKID
    /// moments, record by record: the joint identification and those of subsets
    /// ([`PreparedRecords::identify_subset`], the jackknife's resamples:
    /// [`crate::jackknife::jackknife_prepared`]) then share that work. Fails where
    /// [`Identifier::identify`] fails on the records' data or lengths (the error may be
    /// another of its errors).
    pub fn prepare<'a>(
        &self,
        records: &'a [Record],
        dt_s: f64,
    ) -> Result<PreparedRecords<'a>, Error> {
        let valid = self.check()?;
        let prepared = crate::parallel::on_pool(|| valid.prepare(records, dt_s))?;
        Ok(PreparedRecords {
            identifier: self.clone(),
            valid,
            prepared,
        })
    }

    /// This identifier with the model order and observer order of `joint` fixed (as the
    /// jackknife's resamples use them).
    pub(crate) fn at_orders_of(&self, joint: &Identification) -> Identifier {
        let mut id = self.clone().order(ModelOrder::Fixed(joint.model_order));
        if let Some(p) = joint.observer.map(|o| o.order) {
            id = id.observer_order(ObserverOrder::Fixed(p));
        }
        id
    }

    /// Skips OKID and ERA: modal parameters, MKR and Rayleigh damping of a given discrete
    /// realization. Panics if the matrix shapes are inconsistent.
    pub fn from_realization(
        &self,
        dt_s: f64,
        a: DMatrix<f64>,
        b: DMatrix<f64>,
        c: DMatrix<f64>,
        d: DMatrix<f64>,
    ) -> Result<Identification, Error> {
        self.check()?
            .from_state_space(&StateSpace::new(a, b, c, d, dt_s))
    }

    /// As [`Identifier::from_realization`], from a [`StateSpace`].
    pub fn from_state_space(&self, realization: &StateSpace) -> Result<Identification, Error> {
        self.check()?.from_state_space(realization)
    }
}

/// Checked parameters with the defaults resolved, ready to run.
#[derive(Debug, Clone, PartialEq)]
pub struct ValidIdentifier {
    /// OKID parameters (the Markov count is set from the Hankel size at run time).
    pub okid: OkidParams,
    /// ERA parameters.
    pub era: EraParams,
    /// Modal parameters.
    pub modal: ModalParams,
    /// MKR parameters.
    pub mkr: MkrParams,
    /// Expected number of DOFs.
    pub dofs: Option<usize>,
    /// Mode selection among more structural modes than outputs.
    pub modes: ModeSelection,
}

impl ValidIdentifier {
    /// The modes for MKR (indices into `modal.modes`, ascending) and how
    /// they were chosen (see [`ModeSelection`]).
    fn select_modes(
        &self,
        modal: &ModalModel,
        d: &DMatrix<f64>,
        m: usize,
    ) -> Result<(Vec<usize>, SelectionRule), Error> {
        let structural = modal.structural();
        let list = |idx: &[usize]| -> String {
            idx.iter()
                .map(|&j| format!("{:.4}", modal.modes[j].frequency_hz))
                .collect::<Vec<_>>()
                .join(", ")
        };
        match &self.modes {
            ModeSelection::Auto => Ok(self.most_second_order(modal, &structural, d, m)),
            ModeSelection::Band { low_hz, high_hz } => {
                let inside: Vec<usize> = structural
                    .iter()
                    .copied()
                    .filter(|&j| (*low_hz..=*high_hz).contains(&modal.modes[j].frequency_hz))
                    .collect();
                if inside.len() < m {
                    return Err(Error::ModeSelection {
                        reason: format!(
                            "the band {low_hz}-{high_hz} Hz holds {} structural mode(s) ({} Hz) but the model of {m} outputs needs {m}; the structural modes are at {} Hz",
                            inside.len(),
                            list(&inside),
                            list(&structural)
                        ),
                    });
                }
                let (sel, _) = self.most_second_order(modal, &inside, d, m);
                Ok((sel, SelectionRule::Band))
            }
            ModeSelection::Near { frequencies_hz } => {
                if frequencies_hz.len() != m {
                    return Err(Error::ModeSelection {
                        reason: format!(
                            "{} mode frequencies given ({:?} Hz) but the model of {m} outputs needs {m}",
                            frequencies_hz.len(),
                            frequencies_hz
                        ),
                    });
                }
                if structural.len() < m {
                    return Err(Error::ModeSelection {
                        reason: format!(
                            "only {} structural mode(s) identified ({} Hz), {m} asked for",
                            structural.len(),
                            list(&structural)
                        ),
                    });
                }
                // Closest pairs first (relative distance), each mode and
                // each frequency used once.
                let mut pairs: Vec<(f64, usize, usize)> = Vec::new();
                for (t, f) in frequencies_hz.iter().enumerate() {
                    for &j in &structural {
                        pairs.push(((modal.modes[j].frequency_hz / f - 1.0).abs(), t, j));
                    }
                }
                pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
                let (mut used_t, mut chosen) = (Vec::new(), Vec::new());
                for (_, t, j) in pairs {
                    if !used_t.contains(&t) && !chosen.contains(&j) {
                        used_t.push(t);
                        chosen.push(j);
                    }
                }
                chosen.sort_unstable();
                Ok((chosen, SelectionRule::Near))
            }
        }
    }

    /// `m` of the `candidates` (structural modes): all of them if there are
    /// `m` or fewer, else the subset whose MKR model is closest to a shear
    /// frame, else (more than [`MAX_MODE_SUBSETS`] subsets, or no subset
    /// fits) the most consistent and significant ones.
    fn most_second_order(
        &self,
        modal: &ModalModel,
        candidates: &[usize],
        d: &DMatrix<f64>,
        m: usize,
    ) -> (Vec<usize>, SelectionRule) {
        if candidates.len() <= m {
            return (candidates.to_vec(), SelectionRule::AllStructural);
        }
        let by_significance = || {
            let score =
                |j: usize| modal.modes[j].indicators.cmi * modal.modes[j].indicators.msv_relative;
            let mut idx = candidates.to_vec();
            idx.sort_by(|&a, &b| score(b).total_cmp(&score(a)));
            idx.truncate(m);
            idx.sort_unstable();
            (idx, SelectionRule::Significance)
        };
        if binomial(candidates.len(), m) > MAX_MODE_SUBSETS {
            return by_significance();
        }
        let mut best: Option<(f64, Vec<usize>)> = None;
        let mut subset: Vec<usize> = (0..m).collect();
        loop {
            let chosen: Vec<Mode> = subset
                .iter()
                .map(|&i| modal.modes[candidates[i]].clone())
                .collect();
            if let Ok(fit) = self.mkr.fit(&chosen, d)
                && let Some(defect) = shear_frame_defect(&fit.mass, &fit.stiffness)
                && best.as_ref().is_none_or(|(c, _)| defect < *c)
            {
                best = Some((defect, subset.iter().map(|&i| candidates[i]).collect()));
            }
            if !next_subset(&mut subset, candidates.len()) {
                break;
            }
        }
        match best {
            Some((_, idx)) => (idx, SelectionRule::ShearFrame),
            None => by_significance(),
        }
    }

    fn check_dofs(&self, outputs: usize) -> Result<(), Error> {
        match self.dofs {
            Some(dofs) if dofs > outputs => Err(Error::OutputsFewerThanDofs { outputs, dofs }),
            Some(dofs) if dofs < outputs => Err(Error::InvalidParams {
                reason: format!(
                    "{outputs} outputs for {dofs} degrees of freedom: MKR needs one accelerometer per DOF"
                ),
            }),
            _ => Ok(()),
        }
    }

    /// OKID and the ERA decomposition of the Markov parameters: everything
    /// before a model order is chosen.
    fn decompose(&self, records: &[Record], dt_s: f64) -> Result<Decomposed, Error> {
        record::validate_dt(dt_s)?;
        let shape = record::validate(records)?;
        let refs: Vec<&Record> = records.iter().collect();
        let peaks: Vec<usize> = if self.okid.leads > 0 {
            records.iter().map(peak_sample).collect()
        } else {
            Vec::new()
        };
        self.decompose_with(&refs, &peaks, shape, dt_s, None, false)
    }

    /// [`ValidIdentifier::decompose`] of validated records with their input peaks (empty
    /// without leads) and, if already accumulated, their OKID moments. A `subset` (the
    /// jackknife's resamples, a campaign's core) at a fixed model order is realized to that
    /// order only.
    fn decompose_with(
        &self,
        records: &[&Record],
        peaks: &[usize],
        shape: record::RecordShape,
        dt_s: f64,
        moments: Option<&Moments>,
        subset: bool,
    ) -> Result<Decomposed, Error> {
        let (m, r) = (shape.outputs, shape.inputs);
        self.check_dofs(m)?;
        self.mkr.check(m, r)?;
        // The Markov parameters come from an observer with at most p m states, so no
        // realization of higher order is identifiable.
        let state_limit = self.okid.max_order() * m;
        let era_base = match self.era.order {
            ModelOrder::Fixed(n) if n > state_limit => {
                return Err(Error::Era(EraError::OrderTooLarge {
                    order: n,
                    max: state_limit,
                }));
            }
            ModelOrder::Auto { max } => EraParams {
                order: ModelOrder::Auto {
                    max: max.min(state_limit).max(2),
                },
                ..self.era
            },
            ModelOrder::Fixed(_) => self.era,
        };
        let hankel = era_base.shape(m, r, shape.longest).map_err(|e| match e {
            EraError::TooFewMarkov { required, .. } => Error::Data(DataError::TooShort {
                record: shape.longest_record,
                samples: shape.longest,
                required,
                reason: "Markov parameters for the Hankel matrices",
            }),
            other => Error::Era(other),
        })?;
        let params = self.okid.markov_count(hankel.markov_needed());
        let okid = match moments {
            Some(moments) => params.fit_moments(moments, records),
            None => params.check_lengths(records).and_then(|()| {
                let moments = Moments::of_records(records, &params.layout(r, m));
                params.fit_moments(&moments, records)
            }),
        }
        .map_err(Error::from_okid)?;
        let mut warnings = short_pretriggers(peaks, okid.leads);
        warnings.extend(okid.rcond_raises.iter().map(|raise| Warning::RcondRaised {
            from: raise.from,
            to: raise.to,
            spectral_radius: raise.spectral_radius,
        }));
        let era_params = EraParams {
            block_rows: Some(hankel.block_rows),
            block_cols: Some(hankel.block_cols),
            ..era_base
        };
        // Subsets at a fixed order realize that order only: the factored matrix's
        // singular vectors beyond it are not needed.
        let dec = match (subset, era_params.order) {
            (true, ModelOrder::Fixed(n)) => era_params.decompose_observer_to_order(
                &okid.markov,
                dt_s,
                n,
                okid.observer_order * m,
            )?,
            _ => era_params.decompose(&okid.markov, dt_s)?,
        };
        Ok(Decomposed {
            outputs: m,
            state_limit,
            okid,
            era_params,
            dec,
            warnings,
        })
    }

    /// Validates `records` once and accumulates their OKID moments, for identifications of
    /// subsets (the jackknife).
    pub(crate) fn prepare<'a>(
        &self,
        records: &'a [Record],
        dt_s: f64,
    ) -> Result<Prepared<'a>, Error> {
        record::validate_dt(dt_s)?;
        let shape = record::validate(records)?;
        let refs: Vec<&Record> = records.iter().collect();
        self.okid.check_lengths(&refs).map_err(Error::from_okid)?;
        let layout = self.okid.layout(shape.inputs, shape.outputs);
        let per_record: Vec<Moments> = records
            .par_iter()
            .map(|rec| Moments::of_record(rec, &layout))
            .collect();
        let mut total = Moments::zeros(&layout);
        for mom in &per_record {
            total.add(mom);
        }
        let peaks = records.iter().map(peak_sample).collect();
        Ok(Prepared {
            records,
            dt_s,
            shape,
            per_record,
            total,
            peaks,
        })
    }

    /// Whether this identifier can fit from the moments of `prepared` (accumulated by an
    /// identifier with the same leads and initial state and at least this observer order;
    /// with an unknown initial state the equations skipped follow the order, so only the
    /// same order serves).
    pub(crate) fn fits_from(&self, prepared: &Prepared) -> bool {
        self.okid.fits_layout(&prepared.total.layout)
    }

    /// Runs the whole chain on all the prepared records: the same as
    /// [`ValidIdentifier::identify`] of them, bit for bit (the same moments summed in the
    /// same order).
    pub(crate) fn identify_prepared(&self, prepared: &Prepared) -> Result<Identification, Error> {
        assert!(
            self.fits_from(prepared),
            "moments prepared for another layout"
        );
        let refs: Vec<&Record> = prepared.records.iter().collect();
        let peaks: &[usize] = if self.okid.leads > 0 {
            &prepared.peaks
        } else {
            &[]
        };
        let decomposed = self.decompose_with(
            &refs,
            peaks,
            prepared.shape,
            prepared.dt_s,
            Some(&prepared.total),
            false,
        )?;
        self.identify_decomposed(decomposed)
    }

    /// Runs the whole chain on the prepared records without the records `left_out` (a
    /// non-empty range).
    pub(crate) fn identify_without(
        &self,
        prepared: &Prepared,
        left_out: std::ops::Range<usize>,
    ) -> Result<Identification, Error> {
        assert!(
            !left_out.is_empty() && left_out.end <= prepared.records.len(),
            "identify_without: left-out range {left_out:?} of {} records",
            prepared.records.len()
        );
        let keep: Vec<usize> = (0..prepared.records.len())
            .filter(|k| !left_out.contains(k))
            .collect();
        // One record: its moments are subtracted as they are (the delete-one jackknife's
        // results do not depend on how groups are summed); several: their sum.
        let moments = if left_out.len() == 1 {
            prepared.total.without(&prepared.per_record[left_out.start])
        } else {
            let mut group = prepared.per_record[left_out.start].clone();
            for mom in &prepared.per_record[left_out.start + 1..left_out.end] {
                group.add(mom);
            }
            prepared.total.without(&group)
        };
        self.identify_subset_with(prepared, &keep, &moments)
    }

    /// Runs the whole chain on the prepared records `keep` (increasing indices, at least
    /// one), their moments summed in order: the same as [`ValidIdentifier::identify`] of
    /// those records bit for bit, but for the realization to a fixed model order only.
    pub(crate) fn identify_kept(
        &self,
        prepared: &Prepared,
        keep: &[usize],
    ) -> Result<Identification, Error> {
        assert!(
            !keep.is_empty()
                && keep.windows(2).all(|w| w[0] < w[1])
                && keep.iter().all(|&k| k < prepared.records.len()),
            "identify_kept: records {keep:?} of {}",
            prepared.records.len()
        );
        let mut moments = Moments::zeros(&prepared.total.layout);
        for &k in keep {
            moments.add(&prepared.per_record[k]);
        }
        self.identify_subset_with(prepared, keep, &moments)
    }

    /// The chain on the prepared records `keep` with their `moments`.
    fn identify_subset_with(
        &self,
        prepared: &Prepared,
        keep: &[usize],
        moments: &Moments,
    ) -> Result<Identification, Error> {
        assert!(
            self.fits_from(prepared),
            "moments prepared for another layout"
        );
        let refs: Vec<&Record> = keep.iter().map(|&k| &prepared.records[k]).collect();
        let first = refs.first().ok_or(Error::Data(DataError::NoRecords))?;
        let m = first.outputs.nrows();
        let mut shape = record::RecordShape {
            inputs: first.inputs.nrows(),
            outputs: m,
            longest: 0,
            longest_record: 0,
            total_samples: 0,
        };
        for (index, rec) in refs.iter().enumerate() {
            if rec.len() > shape.longest {
                shape.longest = rec.len();
                shape.longest_record = index;
            }
            shape.total_samples += rec.len();
        }
        if let Some(ch) = (0..m).find(|&ch| {
            refs.iter()
                .all(|rec| rec.outputs.row(ch).iter().all(|&x| x == 0.0))
        }) {
            return Err(Error::Data(DataError::DeadChannel {
                channel: record::Channel::Output(ch),
            }));
        }
        let peaks: Vec<usize> = keep.iter().map(|&k| prepared.peaks[k]).collect();
        let decomposed =
            self.decompose_with(&refs, &peaks, shape, prepared.dt_s, Some(moments), true)?;
        self.identify_decomposed(decomposed)
    }

    /// Runs the whole chain on `records` (on a thread of rayon's pool: see
    /// `ident::parallel::on_pool`).
    pub fn identify(&self, records: &[Record], dt_s: f64) -> Result<Identification, Error> {
        crate::parallel::on_pool(|| {
            let decomposed = self.decompose(records, dt_s)?;
            self.identify_decomposed(decomposed)
        })
    }

    /// Order choice, modal analysis, MKR and Rayleigh after OKID and ERA.
    fn identify_decomposed(&self, decomposed: Decomposed) -> Result<Identification, Error> {
        let Decomposed {
            outputs: m,
            okid,
            era_params,
            dec,
            mut warnings,
            ..
        } = decomposed;
        let candidates = match era_params.order {
            ModelOrder::Fixed(n) => vec![n],
            ModelOrder::Auto { max } => dec.orders_by_gap(max),
        };
        let first = *candidates.first().ok_or(Error::OrderNotIdentifiable {
            structural: 0,
            required: m,
            order: 0,
        })?;
        // Largest-gap order first; if it shows too few structural modes, the next
        // candidates by gap that are larger than it.
        let mut best: Option<(usize, usize)> = None;
        let mut chosen = None;
        for &n in candidates.iter().filter(|&&n| n >= first) {
            let era = dec.realize(n)?;
            let modal = self.modal.fit(&era.realization, Some(&era))?;
            let count = modal.structural().len();
            if count >= m {
                chosen = Some((era, modal));
                break;
            }
            if best.is_none_or(|(c, _)| count > c) {
                best = Some((count, n));
            }
        }
        let Some((era, modal)) = chosen else {
            let (structural, order) = best.unwrap_or((0, first));
            return Err(Error::OrderNotIdentifiable {
                structural,
                required: m,
                order,
            });
        };
        if era.order != first {
            warnings.push(Warning::OrderIncreased {
                from: first,
                to: era.order,
            });
        }
        let observer = ObserverSummary {
            order: okid.observer_order,
            leads: okid.leads,
            rcond: okid.rcond,
            rcond_raises: okid.rcond_raises.len(),
            rank: okid.rank,
            unknowns: okid.unknowns,
            spectral_radius: okid.spectral_radius,
            relative_residual: okid.relative_residual,
        };
        self.finish(
            era.realization.clone(),
            modal,
            Some(observer),
            Some(era.shape),
            era.hankel_singular_values.clone(),
            warnings,
        )
    }

    /// Modal parameters, MKR and Rayleigh damping of a given realization.
    pub fn from_state_space(&self, realization: &StateSpace) -> Result<Identification, Error> {
        realization.assert_shapes();
        record::validate_dt(realization.dt_s)?;
        for (what, mat) in [
            ("A", &realization.a),
            ("B", &realization.b),
            ("C", &realization.c),
            ("D", &realization.d),
        ] {
            if linalg::first_non_finite(mat).is_some() {
                return Err(Error::InvalidParams {
                    reason: format!("the realization's {what} has non-finite entries"),
                });
            }
        }
        let (m, r) = (realization.outputs(), realization.inputs());
        self.check_dofs(m)?;
        self.mkr.check(m, r)?;
        let modal = self.modal.fit(realization, None)?;
        let structural = modal.structural().len();
        if structural < m {
            return Err(Error::OrderNotIdentifiable {
                structural,
                required: m,
                order: realization.order(),
            });
        }
        self.finish(
            realization.clone(),
            modal,
            None,
            None,
            DVector::zeros(0),
            Vec::new(),
        )
    }

    fn finish(
        &self,
        mut realization: StateSpace,
        mut modal: ModalModel,
        observer: Option<ObserverSummary>,
        hankel: Option<HankelShape>,
        hankel_singular_values: DVector<f64>,
        mut warnings: Vec<Warning>,
    ) -> Result<Identification, Error> {
        let m = realization.outputs();
        let (selected, mode_selection) = self.select_modes(&modal, &realization.d, m)?;
        let structural = modal.structural();
        if structural.len() > m {
            warnings.push(Warning::ExtraStructuralModes {
                kept_hz: selected
                    .iter()
                    .map(|&j| modal.modes[j].frequency_hz)
                    .collect(),
                dropped_hz: structural
                    .iter()
                    .filter(|j| !selected.contains(j))
                    .map(|&j| modal.modes[j].frequency_hz)
                    .collect(),
            });
        }
        let chosen: Vec<Mode> = selected.iter().map(|&j| modal.modes[j].clone()).collect();
        let mkr = self.mkr.fit(&chosen, &realization.d)?;
        if mkr.polarity_flipped {
            warnings.push(Warning::PolarityFlipped {
                driving_point: -mkr.driving_point,
            });
            realization.b.neg_mut();
            realization.d.neg_mut();
            modal.negate_inputs();
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
        warnings.extend(weak_driving_point(&mkr, &chosen));
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
        let mode_shapes =
            DMatrix::from_fn(m, selected.len(), |i, j| modal.modes[selected[j]].shape[i]);
        let result = Identification {
            modes: modal.modes,
            real_eigenvalues: modal.real_eigenvalues,
            mkr_modes: selected,
            mode_selection,
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
            hankel_singular_values,
            model_order: realization.order(),
            realization,
            observer,
            hankel,
            intersample: self.modal.intersample,
            polarity_flipped: mkr.polarity_flipped,
            warnings,
        };
        result.ensure_finite()?;
        Ok(result)
    }
}

/// With input leads (band-limited records) the force and the response start before the
/// hit: the anti-alias filter's precursor. The zero-initial-condition form neglects what
/// precedes the record, which is accurate only if the hit (the largest input sample) comes
/// at least `2 q` samples after the record start (measured on a 2-DOF frame with `q = 8`:
/// 16 samples give 1e-5 errors on M and K, 8 samples 2e-3, 4 samples fail).
fn short_pretriggers(peaks: &[usize], leads: usize) -> Vec<Warning> {
    if leads == 0 {
        return Vec::new();
    }
    let recommended = 2 * leads;
    peaks
        .iter()
        .enumerate()
        .filter_map(|(record, &peak_sample)| {
            (peak_sample < recommended).then_some(Warning::ShortPretrigger {
                record,
                peak_sample,
                recommended,
            })
        })
        .collect()
}

/// First sample of a record's largest input magnitude.
fn peak_sample(rec: &Record) -> usize {
    (0..rec.len())
        .fold((0, -1.0), |best, k| {
            let v = rec.inputs.column(k).amax();
            if v > best.1 { (k, v) } else { best }
        })
        .0
}

/// Records validated once with their OKID moments, for the identification of all of them
/// and of subsets ([`Identifier::prepare`]).
pub struct PreparedRecords<'a> {
    pub(crate) identifier: Identifier,
    pub(crate) valid: ValidIdentifier,
    pub(crate) prepared: Prepared<'a>,
}

impl PreparedRecords<'_> {
    /// The records prepared.
    pub fn records(&self) -> &[Record] {
        self.prepared.records
    }

    /// Their sampling interval in seconds.
    pub fn dt_s(&self) -> f64 {
        self.prepared.dt_s
    }

    /// The identification of all the records: [`Identifier::identify`] of them, bit for
    /// bit.
    pub fn identify(&self) -> Result<Identification, Error> {
        crate::parallel::on_pool(|| self.valid.identify_prepared(&self.prepared))
    }

    /// The records `keep` (increasing indices into [`PreparedRecords::records`], at least
    /// one) identified on their own: [`Identifier::identify`] of those records, bit for bit
    /// (their moments summed in the same order) when the model order is automatic; at a
    /// fixed model order the realization is computed to that order only (as for the
    /// jackknife's resamples), which moves the results by round-off (M 5.9e-15 and K
    /// 1.1e-14 relative on five hits of paper case 1, measured).
    pub fn identify_subset(&self, keep: &[usize]) -> Result<Identification, Error> {
        crate::parallel::on_pool(|| self.valid.identify_kept(&self.prepared, keep))
    }
}

/// Records validated once, with their OKID moments and input peaks, from which subsets are
/// identified without repeating the work ([`ValidIdentifier::prepare`]).
#[derive(Clone)]
pub(crate) struct Prepared<'a> {
    records: &'a [Record],
    dt_s: f64,
    shape: record::RecordShape,
    per_record: Vec<Moments>,
    total: Moments,
    peaks: Vec<usize>,
}

/// OKID's result and the ERA decomposition, before the order is chosen.
struct Decomposed {
    outputs: usize,
    state_limit: usize,
    okid: crate::okid::Okid,
    era_params: EraParams,
    dec: crate::era::Decomposition,
    warnings: Vec<Warning>,
}

/// What OKID did.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ObserverSummary {
    /// Observer order `p`.
    pub order: usize,
    /// Input leads `q`.
    pub leads: usize,
    /// Relative truncation finally used.
    pub rcond: f64,
    /// Number of tenfold `rcond` raises.
    pub rcond_raises: usize,
    /// Singular values kept in the least-squares solve.
    pub rank: usize,
    /// Regressors per output.
    pub unknowns: usize,
    /// Spectral radius of the observer's autoregressive part.
    pub spectral_radius: f64,
    /// Relative residual of the observer fit.
    pub relative_residual: f64,
}

/// Result of an identification.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Identification {
    /// All oscillatory modes of the realization, ascending frequency, with indicators and
    /// the structural flag.
    pub modes: Vec<Mode>,
    /// Real eigenvalues of the realization (discrete).
    pub real_eigenvalues: Vec<f64>,
    /// Indices into `modes` of the modes used by MKR and the Rayleigh fit.
    pub mkr_modes: Vec<usize>,
    /// How those modes were chosen.
    #[serde(default = "default_rule")]
    pub mode_selection: SelectionRule,
    /// Natural frequencies (Hz) of the MKR modes.
    pub frequencies_hz: Vec<f64>,
    /// Damping ratios of the MKR modes.
    pub damping_ratios: Vec<f64>,
    /// Normalized complex output shapes of the MKR modes (m x n_dof, by columns).
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
    /// Singular values of the Hankel matrix `H(0)` (empty for a given realization).
    pub hankel_singular_values: DVector<f64>,
    /// State dimension of the realization.
    pub model_order: usize,
    /// Discrete realization (with the polarity corrected if it was flipped).
    pub realization: StateSpace,
    /// What OKID did (absent for a given realization).
    pub observer: Option<ObserverSummary>,
    /// Hankel dimensions used by ERA (absent for a given realization).
    pub hankel: Option<HankelShape>,
    /// Intersample assumption used.
    pub intersample: Intersample,
    /// Whether the input polarity was flipped.
    pub polarity_flipped: bool,
    /// Warnings, in the order they arose.
    pub warnings: Vec<Warning>,
}

impl Identification {
    /// Indices into `modes` of the structural modes the model does not use
    /// (torsional, out-of-plane or local modes a shear model lacks, or the
    /// mode of a floor without an accelerometer), ascending.
    pub fn out_of_model_modes(&self) -> Vec<usize> {
        (0..self.modes.len())
            .filter(|j| self.modes[*j].structural && !self.mkr_modes.contains(j))
            .collect()
    }

    fn ensure_finite(&self) -> Result<(), Error> {
        let matrices = [
            ("mass", &self.mass),
            ("stiffness", &self.stiffness),
            ("damping_mkr", &self.damping_mkr),
            ("damping_rayleigh", &self.damping_rayleigh),
        ];
        for (quantity, m) in matrices {
            if linalg::first_non_finite(m).is_some() {
                return Err(Error::NonFiniteResult { quantity });
            }
        }
        let scalars = self
            .frequencies_hz
            .iter()
            .chain(&self.damping_ratios)
            .chain([&self.rayleigh.alpha, &self.rayleigh.beta, &self.consistency]);
        for x in scalars {
            if !x.is_finite() {
                return Err(Error::NonFiniteResult {
                    quantity: "modal parameters",
                });
            }
        }
        if self
            .mode_shapes
            .iter()
            .any(|z| !(z.re.is_finite() && z.im.is_finite()))
        {
            return Err(Error::NonFiniteResult {
                quantity: "mode shapes",
            });
        }
        Ok(())
    }
}

/// Something worth knowing about a successful identification.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Warning {
    /// A record's hit (largest input sample) comes fewer than `recommended` samples after
    /// its start: with band-limited records the neglected filter precursor biases the result.
    ShortPretrigger {
        /// The record (hit), 0-based in the order given.
        record: usize,
        /// Sample of the largest input magnitude (0-based from the record start).
        peak_sample: usize,
        /// Samples wanted before the hit: twice the OKID input leads `q`.
        recommended: usize,
    },
    /// OKID raised `rcond` to stabilize the observer.
    RcondRaised {
        /// The relative singular-value cutoff that gave an unstable observer.
        from: f64,
        /// The cutoff tried next (ten times `from`).
        to: f64,
        /// Spectral radius of the observer's companion matrix at `from` (1 or more).
        spectral_radius: f64,
    },
    /// The largest singular-value gap gave too few structural modes; a larger order was used.
    OrderIncreased {
        /// The model order of the largest singular-value gap (states).
        from: usize,
        /// The model order used (states).
        to: usize,
    },
    /// More structural modes than DOFs; the most consistent were kept.
    ExtraStructuralModes {
        /// Natural frequencies of the modes used by MKR (Hz, one per DOF).
        kept_hz: Vec<f64>,
        /// Natural frequencies of the structural modes left out (Hz).
        dropped_hz: Vec<f64>,
    },
    /// The input polarity was inverted and has been flipped.
    PolarityFlipped {
        /// Driving-point feedthrough before the flip.
        driving_point: f64,
    },
    /// The driving-point feedthrough `D[k,l]` is not positive (after any flip), contrary to
    /// `D = M^-1 B2`.
    DrivingPointNotPositive {
        /// `D[k,l]` of the collocated pair (m/s^2 per N).
        value: f64,
    },
    /// The realization is far from a second-order system (`||W W^T|| / ||W Lc W^T||`).
    SecondOrderInconsistent {
        /// `||W W^T||_F / ||W Lc W^T||_F`, above [`CONSISTENCY_WARNING`] (0 for an exact
        /// second-order system).
        consistency: f64,
    },
    /// A Rayleigh coefficient is negative.
    NegativeRayleigh {
        /// Mass-proportional coefficient `alpha` (1/s).
        alpha: f64,
        /// Stiffness-proportional coefficient `beta` (s).
        beta: f64,
    },
    /// A mode MKR used carries less than [`WEAK_DRIVING_POINT_SHARE`] of the driving
    /// point's response: the hit is near a node of that mode.
    WeakDrivingPoint {
        /// The mode, 0-based among those MKR used (ascending frequency).
        mode: usize,
        /// Its natural frequency (Hz).
        frequency_hz: f64,
        /// Its share of the driving point, `|W[k,j]^2 lambda_j| / sum`.
        share: f64,
    },
}

impl fmt::Display for Warning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Warning::ShortPretrigger {
                record,
                peak_sample,
                recommended,
            } => write!(
                f,
                "record {record}: the hit is at sample {peak_sample}, less than {recommended} samples after the record start; the band-limited precursor before the record is neglected"
            ),
            Warning::RcondRaised {
                from,
                to,
                spectral_radius,
            } => write!(
                f,
                "OKID observer was unstable (spectral radius {spectral_radius:.4}); rcond raised from {from:.1e} to {to:.1e}"
            ),
            Warning::OrderIncreased { from, to } => write!(
                f,
                "model order {from} (largest singular-value gap) showed too few structural modes; used order {to}"
            ),
            Warning::ExtraStructuralModes {
                kept_hz,
                dropped_hz,
            } => write!(
                f,
                "more structural modes than degrees of freedom: kept {kept_hz:.4?} Hz, dropped {dropped_hz:.4?} Hz"
            ),
            Warning::PolarityFlipped { driving_point } => write!(
                f,
                "input polarity was inverted (driving-point residues, D[k,l] = {driving_point:.4}); the input sign was flipped"
            ),
            Warning::DrivingPointNotPositive { value } => write!(
                f,
                "driving-point feedthrough D[k,l] = {value:.4} is not positive although D = M^-1 B2"
            ),
            Warning::SecondOrderInconsistent { consistency } => write!(
                f,
                "realization is far from a second-order system: ||W W^T|| / ||W L W^T|| = {consistency:.3}"
            ),
            Warning::NegativeRayleigh { alpha, beta } => write!(
                f,
                "negative Rayleigh coefficient: alpha = {alpha:.4e}, beta = {beta:.4e}"
            ),
            Warning::WeakDrivingPoint {
                mode,
                frequency_hz,
                share,
            } => write!(
                f,
                "mode {} ({frequency_hz:.3} Hz) carries only {:.2} % of the driving point's response: the hit is near a node of that mode, whose mass normalization, and with it M and K, rests on a weak, noisy residue (expect errors ten times and more those of a well-placed hit; see the error bars); hit where that mode moves",
                mode + 1,
                100.0 * share
            ),
        }
    }
}

/// Ways an identification can fail.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The modes asked for (a band, or frequencies) cannot be chosen.
    #[error("mode selection: {reason}")]
    ModeSelection {
        /// Why the modes asked for cannot be chosen, with the structural
        /// modes found.
        reason: String,
    },
    /// Parameters out of range.
    #[error("invalid parameters: {reason}")]
    InvalidParams {
        /// Which parameter is out of range and what it must be.
        reason: String,
    },
    /// The records are unusable.
    #[error(transparent)]
    Data(#[from] DataError),
    /// OKID failed.
    #[error(transparent)]
    Okid(OkidError),
    /// ERA failed.
    #[error(transparent)]
    Era(#[from] EraError),
    /// Modal analysis failed.
    #[error(transparent)]
    Modal(#[from] ModalError),
    /// MKR failed (collocated pair out of range, polarity, not positive definite, ...).
    #[error(transparent)]
    Mkr(#[from] MkrError),
    /// Rayleigh fit failed.
    #[error(transparent)]
    Rayleigh(#[from] RayleighError),
    /// Fewer outputs than degrees of freedom.
    #[error(
        "{outputs} outputs for {dofs} degrees of freedom: MKR needs an accelerometer at every DOF"
    )]
    OutputsFewerThanDofs {
        /// Outputs (accelerometer channels) of the records.
        outputs: usize,
        /// Degrees of freedom expected ([`Identifier::dofs`]).
        dofs: usize,
    },
    /// Fewer structural modes than degrees of freedom at every order tried.
    #[error(
        "only {structural} structural modes found (best at model order {order}), {required} are needed"
    )]
    OrderNotIdentifiable {
        /// Structural modes found at the best order (0 when no order could be tried).
        structural: usize,
        /// Structural modes needed: one per DOF (the outputs).
        required: usize,
        /// The model order (states) with the most structural modes (0 when none was tried).
        order: usize,
    },
    /// A result is not finite.
    #[error("identified {quantity} is not finite")]
    NonFiniteResult {
        /// What is not finite (e.g. `"mass"`, `"mode shapes"`).
        quantity: &'static str,
    },
}

impl Error {
    fn from_okid(e: OkidError) -> Self {
        match e {
            OkidError::Data(d) => Error::Data(d),
            OkidError::InvalidParams { reason } => Error::InvalidParams { reason },
            other => Error::Okid(other),
        }
    }
}

/// How far M and K (floors in order, the first on the ground) are from a
/// shear frame with lumped masses: `||offdiag M||_F / ||diag M||_2` plus
/// `||(K 1)[1..]||_2 / ||K||_F` (every floor above the first is held only by
/// the storey springs to its neighbours, so its row of K sums to 0). `None`
/// if M or K is not positive definite or two adjacent floors are coupled by
/// a positive `K[i, i+1]` (no spring does that).
pub fn shear_frame_defect(mass: &DMatrix<f64>, stiffness: &DMatrix<f64>) -> Option<f64> {
    let n = mass.nrows();
    if mass.clone().cholesky().is_none() || stiffness.clone().cholesky().is_none() {
        return None;
    }
    if (0..n.saturating_sub(1)).any(|i| stiffness[(i, i + 1)] > 0.0) {
        return None;
    }
    let diag = (0..n).map(|i| mass[(i, i)].powi(2)).sum::<f64>().sqrt();
    let off = (0..n)
        .flat_map(|i| (0..n).filter(move |&j| j != i).map(move |j| (i, j)))
        .map(|(i, j)| mass[(i, j)].powi(2))
        .sum::<f64>()
        .sqrt();
    let rows = (1..n)
        .map(|i| stiffness.row(i).sum().powi(2))
        .sum::<f64>()
        .sqrt();
    let defect = off / diag + rows / stiffness.norm();
    defect.is_finite().then_some(defect)
}

/// `n choose k`, saturating.
fn binomial(n: usize, k: usize) -> usize {
    let k = k.min(n - k.min(n));
    (0..k).fold(1usize, |acc, i| acc.saturating_mul(n - i) / (i + 1))
}

/// Advances `subset` (ascending indices below `n`) to the next
/// combination in lexicographic order; false after the last.
fn next_subset(subset: &mut [usize], n: usize) -> bool {
    let k = subset.len();
    for i in (0..k).rev() {
        if subset[i] < n - k + i {
            subset[i] += 1;
            for j in i + 1..k {
                subset[j] = subset[j - 1] + 1;
            }
            return true;
        }
    }
    false
}

fn default_rule() -> SelectionRule {
    SelectionRule::AllStructural
}

#[cfg(test)]
mod selection_tests {
    use super::*;

    #[test]
    fn a_shear_frame_has_no_defect_and_couplings_are_measured() {
        // Lumped masses and storey springs k1 = 200, k2 = 430: exactly 0.
        let m = DMatrix::from_row_slice(2, 2, &[0.3, 0.0, 0.0, 0.34]);
        let k = DMatrix::from_row_slice(2, 2, &[630.0, -430.0, -430.0, 430.0]);
        assert_eq!(shear_frame_defect(&m, &k), Some(0.0));
        // An off-diagonal mass of 0.03 and a top row summing to 20: the
        // closed form ||off M|| / ||diag M|| + |row 2 sum| / ||K||_F.
        let m2 = DMatrix::from_row_slice(2, 2, &[0.3, 0.03, 0.03, 0.34]);
        let k2 = DMatrix::from_row_slice(2, 2, &[630.0, -430.0, -430.0, 450.0]);
        let want =
            (2.0f64 * 0.03 * 0.03).sqrt() / (0.3f64 * 0.3 + 0.34 * 0.34).sqrt() + 20.0 / k2.norm();
        // Same arithmetic in another order: a few ulps.
        assert!((shear_frame_defect(&m2, &k2).unwrap() - want).abs() < 1e-14);
        // Not positive definite, or a positive coupling: not a frame.
        let k3 = DMatrix::from_row_slice(2, 2, &[630.0, 430.0, 430.0, 450.0]);
        assert_eq!(shear_frame_defect(&m, &k3), None);
        let m4 = DMatrix::from_row_slice(2, 2, &[0.3, 0.4, 0.4, 0.34]);
        assert_eq!(shear_frame_defect(&m4, &k), None);
    }

    #[test]
    fn subsets_are_enumerated_once_each() {
        // Every 2-subset of 5 in lexicographic order: C(5, 2) = 10.
        let mut s = vec![0, 1];
        let mut seen = vec![s.clone()];
        while next_subset(&mut s, 5) {
            seen.push(s.clone());
        }
        assert_eq!(seen.len(), 10);
        assert_eq!(seen.len(), binomial(5, 2));
        assert_eq!(seen.last().unwrap(), &vec![3, 4]);
        assert_eq!(binomial(6, 3), 20);
        assert_eq!(binomial(3, 3), 1);
        // Large counts saturate (no overflow panic) and exceed the cap.
        assert!(binomial(70, 35) > MAX_MODE_SUBSETS);
    }

    #[test]
    fn selection_settings_are_checked() {
        let bad = Identifier::default().mode_selection(ModeSelection::Band {
            low_hz: 5.0,
            high_hz: 2.0,
        });
        assert!(matches!(bad.check(), Err(Error::InvalidParams { .. })));
        let bad = Identifier::default().mode_selection(ModeSelection::Near {
            frequencies_hz: vec![2.0, f64::NAN],
        });
        assert!(matches!(bad.check(), Err(Error::InvalidParams { .. })));
        let ok = Identifier::default().mode_selection(ModeSelection::Near {
            frequencies_hz: vec![2.0, 9.0],
        });
        assert!(ok.check().is_ok());
    }
}
