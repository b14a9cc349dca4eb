//! The JSON documents of `frameid identify --json` (schema in the README):
//! the typed outcome of an identification, built from the library results
//! ([`Analysis`], [`FrfAnalysis`]). The binary renders them as JSON (serde)
//! or as readable tables; nothing here formats text for the terminal.
//!
//! Conventions: matrices are arrays of rows; mode shapes are `[re, im]`
//! per output, normalized so that the largest component is `[1, 0]`;
//! frequencies in Hz, damping ratios as fractions of critical.

use ident::refine::Refinement;
use ident::{Identification, Jackknife};
use nalgebra::DMatrix;
use records::consistency::ConsistencyFlag;
use records::numfmt::sig;
use records::quality::HitQuality;
use serde::Serialize;

use crate::analysis::Analysis;
use crate::frf_analysis::FrfAnalysis;

/// A matrix as an array of rows.
pub fn rows(m: &DMatrix<f64>) -> Vec<Vec<f64>> {
    (0..m.nrows())
        .map(|i| m.row(i).iter().copied().collect())
        .collect()
}

/// The maximum-likelihood refinement in the JSON output.
#[derive(Debug, Clone, Serialize)]
pub struct RefinedReport {
    /// Mass matrix M, kg.
    pub mass: Vec<Vec<f64>>,
    /// Standard errors of M, kg.
    pub mass_std: Vec<Vec<f64>>,
    /// Stiffness matrix K, N/m.
    pub stiffness: Vec<Vec<f64>>,
    /// Standard errors of K, N/m.
    pub stiffness_std: Vec<Vec<f64>>,
    /// Damping matrix, N s/m.
    pub damping: Vec<Vec<f64>>,
    /// Standard errors of the damping matrix, N s/m.
    pub damping_std: Vec<Vec<f64>>,
    /// The modes, in order of frequency.
    pub modes: Vec<RefinedMode>,
    /// Estimated noise standard deviations: per output, per input.
    pub noise_outputs: Vec<f64>,
    /// Per input channel (0 for a noise-free force).
    pub noise_inputs: Vec<f64>,
    /// Levenberg-Marquardt iterations taken.
    pub iterations: usize,
    /// Why the optimizer stopped (`Gradient`, `Step`, `Cost`, `MaxIterations`, `NoProgress`).
    pub stop: String,
    /// Whether the stop reason is a convergence test.
    pub converged: bool,
    /// Cost at the start (twice the negative log-likelihood up to a constant).
    pub initial_cost: f64,
    /// Cost at the end.
    pub cost: f64,
    /// Where the variances of the FRF values came from (FRF route only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub noise_model: Option<String>,
}

/// A mode of the refined model with standard errors (delta method).
#[derive(Debug, Clone, Serialize)]
pub struct RefinedMode {
    /// Natural frequency, Hz.
    pub frequency_hz: f64,
    /// Its standard error, Hz.
    pub frequency_std_hz: f64,
    /// Damping ratio, fraction of critical.
    pub damping_ratio: f64,
    /// Its standard error.
    pub damping_ratio_std: f64,
    /// Output shape as `[re, im]` per output, largest component `[1, 0]`.
    pub mode_shape: Vec<[f64; 2]>,
}

impl RefinedReport {
    /// The refinement of records (time route).
    pub fn new(r: &Refinement) -> Self {
        let mut report = Self::matrices(&r.mass, &r.stiffness, &r.damping, &r.uncertainty);
        report.noise_outputs = r.noise.outputs.clone();
        report.noise_inputs = r.noise.inputs.clone();
        report.iterations = r.iterations;
        report.stop = format!("{:?}", r.stop);
        report.converged = r.stop.converged();
        report.initial_cost = r.initial_cost;
        report.cost = r.cost;
        report
    }

    /// The refinement of FRFs.
    pub fn from_frf(r: &ident::frf::refine::FrfRefinement) -> Self {
        let mut report = Self::matrices(&r.mass, &r.stiffness, &r.damping, &r.uncertainty);
        report.iterations = r.iterations;
        report.stop = format!("{:?}", r.stop);
        report.converged = r.stop.converged();
        report.initial_cost = r.initial_cost;
        report.cost = r.cost;
        report.noise_model = Some(format!("{:?}", r.noise.source));
        report
    }

    /// Matrices and modes with their standard errors; the rest empty.
    fn matrices(
        mass: &DMatrix<f64>,
        stiffness: &DMatrix<f64>,
        damping: &DMatrix<f64>,
        u: &ident::refine::Uncertainty,
    ) -> Self {
        RefinedReport {
            mass: rows(mass),
            mass_std: rows(&u.mass_std),
            stiffness: rows(stiffness),
            stiffness_std: rows(&u.stiffness_std),
            damping: rows(damping),
            damping_std: rows(&u.damping_std),
            modes: u
                .modes
                .iter()
                .map(|m| RefinedMode {
                    frequency_hz: m.frequency_hz,
                    frequency_std_hz: m.frequency_std_hz,
                    damping_ratio: m.damping_ratio,
                    damping_ratio_std: m.damping_ratio_std,
                    mode_shape: m.shape.iter().map(|z| [z.re, z.im]).collect(),
                })
                .collect(),
            noise_outputs: Vec::new(),
            noise_inputs: Vec::new(),
            iterations: 0,
            stop: String::new(),
            converged: false,
            initial_cost: f64::NAN,
            cost: f64::NAN,
            noise_model: None,
        }
    }
}

/// Where the identification came from.
#[derive(Debug, Clone, Serialize)]
pub struct Source {
    /// The files read, in the order given.
    pub files: Vec<String>,
    /// Whether a state-space realization was given instead of records.
    pub realization: bool,
    /// Sample interval after any decimation, s.
    pub dt_s: f64,
    /// Records (hits or runs) identified.
    pub hits: usize,
    /// Samples of the longest record.
    pub samples: usize,
    /// Input channel names.
    pub inputs: Vec<String>,
    /// Output channel names, in DOF order.
    pub outputs: Vec<String>,
    /// The collocated output and input.
    pub collocated: Collocated,
}

/// Zero-based indices of the collocated pair among outputs and inputs.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Collocated {
    /// Index among the outputs.
    pub output: usize,
    /// Index among the inputs.
    pub input: usize,
}

/// One identified mode in the JSON output.
#[derive(Debug, Clone, Serialize)]
pub struct ModeReport {
    /// Natural frequency, Hz.
    pub frequency_hz: f64,
    /// Damping ratio, fraction of critical.
    pub damping_ratio: f64,
    /// Output shape `C psi` as `[re, im]` per output, largest component `[1, 0]`.
    pub mode_shape: Vec<[f64; 2]>,
    /// Output EMAC x input EMAC (null for a given realization).
    pub emac: Option<f64>,
    /// EMAC of the output (temporal consistency of the observability).
    pub emac_output: Option<f64>,
    /// EMAC of the input (of the controllability).
    pub emac_input: Option<f64>,
    /// Modal phase collinearity.
    pub mpc: f64,
    /// Modal singular value.
    pub msv: f64,
    /// Consistent-mode indicator.
    pub cmi: f64,
    /// Passed the structural-mode tests.
    pub structural: bool,
    /// Used by MKR and the Rayleigh fit.
    pub used: bool,
}

impl ModeReport {
    /// The document of mode `m`; `used` if MKR and the Rayleigh fit use it.
    /// The EMACs are null where the route has none (FRFs, a realization).
    pub fn new(m: &ident::Mode, used: bool) -> Self {
        let i = &m.indicators;
        ModeReport {
            frequency_hz: m.frequency_hz,
            damping_ratio: m.damping_ratio,
            mode_shape: m.shape.iter().map(|z| [z.re, z.im]).collect(),
            emac: i.emac_output.zip(i.emac_input).map(|(o, i)| o * i),
            emac_output: i.emac_output,
            emac_input: i.emac_input,
            mpc: i.mpc,
            msv: i.msv,
            cmi: i.cmi,
            structural: m.structural,
            used,
        }
    }
}

/// Rayleigh coefficients.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct RayleighReport {
    /// Mass-proportional coefficient, 1/s.
    pub alpha: f64,
    /// Stiffness-proportional coefficient, s.
    pub beta: f64,
}

/// The JSON document of `frameid identify --json` (schema in the README).
#[derive(Debug, Clone, Serialize)]
pub struct IdentifyReport {
    /// The version of frameid that wrote the document.
    pub frameid_version: String,
    /// Where the data came from.
    pub source: Source,
    /// Intersample assumption (`zoh`, `foh`, `bandlimited`).
    pub intersample: String,
    /// State-space model order.
    pub model_order: usize,
    /// The OKID observer solved (null for a realization).
    pub observer: Option<ident::pipeline::ObserverSummary>,
    /// Singular values of the Hankel matrix, largest first.
    pub hankel_singular_values: Vec<f64>,
    /// The modes, in order of frequency.
    pub modes: Vec<ModeReport>,
    /// Rayleigh coefficients of the fit.
    pub rayleigh: RayleighReport,
    /// Mass matrix M, kg.
    pub mass: Vec<Vec<f64>>,
    /// Stiffness matrix K, N/m.
    pub stiffness: Vec<Vec<f64>>,
    /// Damping matrix from MKR, N s/m.
    pub damping_mkr: Vec<Vec<f64>>,
    /// Rayleigh damping alpha M + beta K, N s/m.
    pub damping_rayleigh: Vec<Vec<f64>>,
    /// Second-order consistency ||W W^T|| / ||W L W^T|| (0 for an exact second-order system).
    pub consistency: f64,
    /// Whether the input polarity was inverted and flipped.
    pub polarity_flipped: bool,
    /// Everything the reader must know about the result.
    pub warnings: Vec<String>,
    /// Quality checks of every hit given (empty for a realization).
    pub hit_quality: Vec<HitQuality>,
    /// Hits inconsistent with the others (dead, copied or spiked channels,
    /// duplicates, level, spectrum or residual against the joint model);
    /// `record` is the 0-based position in the files given.
    pub inconsistent_hits: Vec<ConsistencyFlag>,
    /// Findings of the consistency checks that flag no hit.
    pub consistency_notes: Vec<String>,
    /// Files of the hits left out: inconsistent ones, and with
    /// `--drop-bad-hits` those failing a quality check.
    pub dropped_hits: Vec<String>,
    /// How the modes of the model were chosen (`all-structural`,
    /// `second-order`, `significance`, `band`, `near`).
    pub mode_selection: ident::SelectionRule,
    /// Structural modes the model does not use (torsional, out-of-plane or
    /// local modes), as in `modes`.
    pub out_of_model_modes: Vec<ModeReport>,
    /// Positions (0-based) of the dropped hits, for the hit table (files may
    /// repeat).
    #[serde(skip)]
    pub dropped_positions: Vec<usize>,
    /// Error bars over the hits (null for a realization, with
    /// `--no-uncertainty`, or with fewer than 3 hits).
    pub uncertainty: Option<Jackknife>,
    /// Why there are no error bars, if there are none for records.
    pub uncertainty_skipped: Option<String>,
    /// Indices into `modes` of the modes used, in the order of the
    /// uncertainty's per-mode lists.
    #[serde(skip)]
    pub mkr_modes: Vec<usize>,
    /// The maximum-likelihood refinement (with `--refine`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub refined: Option<RefinedReport>,
    /// M without the known sensor masses (with `--sensor-mass`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub without_sensors: Option<WithoutSensors>,
    /// The decimation before identification (absent when the records were
    /// identified at their own rate by `--decimate auto` or `off`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub decimation: Option<crate::decimate::Decimation>,
    /// The initial state assumed and why (absent when nothing was judged:
    /// hammer records under `--initial-state auto`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub initial_state: Option<crate::analysis::InitialStateReport>,
    /// Shortest record identified, samples (the source's `samples` is the
    /// longest).
    #[serde(skip)]
    pub shortest: usize,
}

impl IdentifyReport {
    /// The document of an identification, without the checks of records
    /// (a realization given, or before [`IdentifyReport::from_analysis`] fills them).
    pub fn new(r: &Identification, source: Source) -> Self {
        let modes = r
            .modes
            .iter()
            .enumerate()
            .map(|(i, m)| ModeReport::new(m, r.mkr_modes.contains(&i)))
            .collect::<Vec<ModeReport>>();
        let out_of_model_modes = modes
            .iter()
            .filter(|m| m.structural && !m.used)
            .cloned()
            .collect();
        IdentifyReport {
            frameid_version: env!("CARGO_PKG_VERSION").into(),
            source,
            intersample: r.intersample.to_string(),
            model_order: r.model_order,
            observer: r.observer,
            hankel_singular_values: r.hankel_singular_values.iter().copied().collect(),
            modes,
            rayleigh: RayleighReport {
                alpha: r.rayleigh.alpha,
                beta: r.rayleigh.beta,
            },
            mass: rows(&r.mass),
            stiffness: rows(&r.stiffness),
            damping_mkr: rows(&r.damping_mkr),
            damping_rayleigh: rows(&r.damping_rayleigh),
            consistency: r.consistency,
            polarity_flipped: r.polarity_flipped,
            warnings: r.warnings.iter().map(ToString::to_string).collect(),
            hit_quality: Vec::new(),
            inconsistent_hits: Vec::new(),
            consistency_notes: Vec::new(),
            dropped_hits: Vec::new(),
            dropped_positions: Vec::new(),
            mode_selection: r.mode_selection,
            out_of_model_modes,
            uncertainty: None,
            uncertainty_skipped: None,
            mkr_modes: r.mkr_modes.clone(),
            refined: None,
            without_sensors: None,
            decimation: None,
            initial_state: None,
            shortest: 0,
        }
    }

    /// The document of an analysis of records.
    pub fn from_analysis(a: &Analysis) -> Self {
        let c = &a.campaign;
        let id = &a.identification;
        let source = Source {
            files: c.labels.clone(),
            realization: false,
            dt_s: c.dt_s,
            hits: c.len(),
            samples: c.longest(),
            inputs: c.inputs.clone(),
            outputs: c.outputs.clone(),
            collocated: Collocated {
                output: a.collocated.output,
                input: a.collocated.input,
            },
        };
        let mut report = IdentifyReport::new(id, source);
        report.warnings = a.warnings.clone();
        report.hit_quality = a.hit_quality.clone();
        report.inconsistent_hits = a.consistency.flags.clone();
        report.consistency_notes = a.consistency.notes.clone();
        report.dropped_hits = a
            .dropped
            .iter()
            .map(|&i| a.hit_quality[i].file.clone())
            .collect();
        report.dropped_positions = a.dropped.clone();
        report.uncertainty = a.uncertainty.clone();
        report.uncertainty_skipped = a.uncertainty_skipped.clone();
        report.refined = a.refinement.as_ref().map(RefinedReport::new);
        report.decimation = (a.decimation.factor > 1 || a.decimation.chosen == "given")
            .then(|| a.decimation.clone());
        report.initial_state = a.initial_state.clone();
        report.shortest = c.records.iter().map(|r| r.len()).min().unwrap_or(0);
        report
    }
}

/// A measurement point of an FRF file.
#[derive(Debug, Clone, Serialize)]
pub struct PointReport {
    /// Channel or point name.
    pub name: String,
    /// Node number (UFF), if known.
    pub node: Option<i64>,
    /// Direction code (UFF: 1..3 = +X..+Z, negative for minus), if known.
    pub direction: Option<i32>,
}

/// Where FRFs came from.
#[derive(Debug, Clone, Serialize)]
pub struct FrfSource {
    /// The files read, in the order given.
    pub files: Vec<String>,
    /// `receptance`, `mobility` or `accelerance` (values in SI).
    pub quantity: String,
    /// Spectral lines used.
    pub lines: usize,
    /// First and last line, Hz.
    pub band_hz: [f64; 2],
    /// Averages behind each FRF, if stated.
    pub averages: Option<usize>,
    /// Whether the files carry coherence.
    pub coherence: bool,
    /// Responses, in output (DOF) order.
    pub outputs: Vec<PointReport>,
    /// References (inputs).
    pub references: Vec<PointReport>,
    /// The collocated output and input.
    pub collocated: Collocated,
}

/// A pLSCF pole left out of the modal model.
#[derive(Debug, Clone, Serialize)]
pub struct RejectedReport {
    /// Natural frequency, Hz.
    pub frequency_hz: f64,
    /// Damping ratio, fraction of critical.
    pub damping_ratio: f64,
    /// Why it was left out.
    pub reason: String,
}

/// The JSON document of `frameid identify --json` given FRFs.
#[derive(Debug, Clone, Serialize)]
pub struct FrfIdentifyReport {
    /// The version of frameid that wrote the document.
    pub frameid_version: String,
    /// Always `frf`.
    pub route: String,
    /// Where the data came from.
    pub source: FrfSource,
    /// pLSCF order.
    pub model_order: usize,
    /// The modes, in order of frequency.
    pub modes: Vec<ModeReport>,
    /// Structural modes the model does not use.
    pub out_of_model_modes: Vec<ModeReport>,
    /// pLSCF poles left out of the modal model.
    pub rejected_modes: Vec<RejectedReport>,
    /// Natural frequencies of the modes used, Hz.
    pub frequencies_hz: Vec<f64>,
    /// Damping ratios of the modes used.
    pub damping_ratios: Vec<f64>,
    /// Rayleigh coefficients of the fit.
    pub rayleigh: RayleighReport,
    /// Mass matrix M, kg.
    pub mass: Vec<Vec<f64>>,
    /// Stiffness matrix K, N/m.
    pub stiffness: Vec<Vec<f64>>,
    /// Damping matrix from MKR, N s/m.
    pub damping_mkr: Vec<Vec<f64>>,
    /// Rayleigh damping alpha M + beta K, N s/m.
    pub damping_rayleigh: Vec<Vec<f64>>,
    /// Second-order consistency ||W W^T|| / ||W L W^T|| (0 for an exact second-order system).
    pub consistency: f64,
    /// Whether the input polarity was inverted and flipped.
    pub polarity_flipped: bool,
    /// Time constant of an exponential window taken out of the modes, s.
    pub exponential_tau_s: Option<f64>,
    /// Coherence per pair and reciprocity between references.
    pub checks: crate::frf_analysis::FrfChecks,
    /// Error bars (parametric bootstrap; null with `--no-uncertainty`).
    pub uncertainty: Option<crate::frf_analysis::FrfSpread>,
    /// Why there are no error bars, if asked for and there are none.
    pub uncertainty_skipped: Option<String>,
    /// The maximum-likelihood refinement (with `--refine`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub refined: Option<RefinedReport>,
    /// M without the known sensor masses (with `--sensor-mass`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub without_sensors: Option<WithoutSensors>,
    /// Everything the reader must know about the result.
    pub warnings: Vec<String>,
}

impl FrfIdentifyReport {
    /// The document of an identification from FRFs.
    pub fn new(a: &FrfAnalysis, source: FrfSource) -> Self {
        let id = &a.identification;
        let mode = |j: usize| ModeReport::new(&id.modes[j], id.mkr_modes.contains(&j));
        FrfIdentifyReport {
            frameid_version: env!("CARGO_PKG_VERSION").into(),
            route: "frf".into(),
            source,
            model_order: id.order,
            modes: (0..id.modes.len()).map(mode).collect(),
            out_of_model_modes: id.out_of_model.iter().map(|&j| mode(j)).collect(),
            rejected_modes: id
                .rejected
                .iter()
                .map(|r| RejectedReport {
                    frequency_hz: r.frequency_hz,
                    damping_ratio: r.damping_ratio,
                    reason: match r.reason {
                        ident::frf::RejectReason::LeftPhysicalRange { .. } => {
                            "left the band or damping range when refined".into()
                        }
                        ident::frf::RejectReason::Insignificant { contribution } => {
                            format!("peak contribution {} of the largest", sig(contribution, 2))
                        }
                    },
                })
                .collect(),
            frequencies_hz: id.frequencies_hz.clone(),
            damping_ratios: id.damping_ratios.clone(),
            rayleigh: RayleighReport {
                alpha: id.rayleigh.alpha,
                beta: id.rayleigh.beta,
            },
            mass: rows(&id.mass),
            stiffness: rows(&id.stiffness),
            damping_mkr: rows(&id.damping_mkr),
            damping_rayleigh: rows(&id.damping_rayleigh),
            consistency: id.consistency,
            polarity_flipped: id.polarity_flipped,
            exponential_tau_s: id.exponential_tau_s,
            checks: a.checks.clone(),
            uncertainty: a.uncertainty.clone(),
            uncertainty_skipped: a.uncertainty_skipped.clone(),
            refined: a.refinement.as_ref().map(RefinedReport::from_frf),
            without_sensors: None,
            warnings: a.warnings.clone(),
        }
    }
}

/// The identified mass matrices with known sensor masses taken off
/// (`--sensor-mass`).
#[derive(Debug, Clone, Serialize)]
pub struct WithoutSensors {
    /// The sensor masses, one per DOF, kg.
    pub sensor_mass_kg: Vec<f64>,
    /// `M - diag(sensor masses)`.
    pub mass: Vec<Vec<f64>>,
    /// The refined M without them, with `--refine`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub refined_mass: Option<Vec<Vec<f64>>>,
}

impl WithoutSensors {
    /// Takes `sensor_mass_kg` off `mass` (and `refined`).
    pub fn new(
        sensor_mass_kg: &[f64],
        mass: &DMatrix<f64>,
        refined: Option<&DMatrix<f64>>,
    ) -> Result<Self, String> {
        let take = |m: &DMatrix<f64>| crate::analysis::subtract_sensor_masses(m, sensor_mass_kg);
        let bare = take(mass)?;
        let n = mass.nrows();
        Ok(WithoutSensors {
            sensor_mass_kg: if sensor_mass_kg.len() == 1 {
                vec![sensor_mass_kg[0]; n]
            } else {
                sensor_mass_kg.to_vec()
            },
            mass: rows(&bare),
            refined_mass: refined.map(take).transpose()?.map(|m| rows(&m)),
        })
    }
}
