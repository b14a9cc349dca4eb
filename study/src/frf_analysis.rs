//! Identification from measured FRFs (`frameid identify` given FRF files):
//! the checks of the FRFs, the FRF route of [`ident::frf`] (pLSCF, LSFD,
//! MKR and Rayleigh), and what the report shows of it.
//!
//! # Checks of the data
//!
//! FRF files carry no hits to compare, so the checks are of the FRFs
//! themselves; each result is in [`FrfChecks`], and what is suspicious
//! becomes a warning (`--strict` refuses):
//!
//! - **Coherence.** Per pair, the median ordinary coherence over the band.
//!   Below [`COHERENCE_MEDIAN_MIN`] the estimate is dominated by noise,
//!   leakage or unmeasured inputs over much of the band.
//! - **Reciprocity.** With several references whose points are also
//!   response points, `H_ab = H_ba` for a linear, reciprocal structure. The
//!   relative difference over the band is reported per pair of references;
//!   above [`RECIPROCITY_MAX`] it is a warning (a mislabelled channel, a
//!   calibration error, a non-reciprocal set-up).

use ident::frf::refine::{FrfRefineError, FrfRefineWarning, FrfRefinement, FrfRefiner, FrfStart};
use ident::frf::{Frf, FrfIdentError, FrfIdentification, FrfIdentifier};
use records::numfmt::sig;
use serde::Serialize;

use crate::scenario::ParametrizationSetting;

/// Smallest median coherence of a pair over the band without a warning.
/// A clean hammer test averages 0.95-1 between anti-resonances; 0.8 is
/// well below that and still far above what noise alone gives.
pub const COHERENCE_MEDIAN_MIN: f64 = 0.8;

/// Largest relative reciprocity difference `||H_ab - H_ba|| / ||(H_ab +
/// H_ba) / 2||` over the band without a warning. Measured lab FRFs reach a
/// few percent (sensor calibrations of about 1 % each, small
/// non-linearities); 15 % is beyond what those explain.
pub const RECIPROCITY_MAX: f64 = 0.15;

/// Median coherence of one pair over the band.
#[derive(Debug, Clone, Serialize)]
pub struct CoherenceCheck {
    /// The response.
    pub output: String,
    /// The reference.
    pub reference: String,
    /// Median ordinary coherence over the band's lines.
    pub median: f64,
    /// Fraction of the band's lines whose coherence is below 0.5.
    pub below_half: f64,
}

/// Reciprocity between two references that are also response points.
#[derive(Debug, Clone, Serialize)]
pub struct ReciprocityCheck {
    /// First reference and the output at its point.
    pub a: String,
    /// Second reference and the output at its point.
    pub b: String,
    /// `||H_ab - H_ba|| / ||(H_ab + H_ba) / 2||` over the band.
    pub relative_difference: f64,
}

/// The checks of the FRFs (see the module docs).
#[derive(Debug, Clone, Default, Serialize)]
pub struct FrfChecks {
    /// Per pair, when the FRFs carry coherence.
    pub coherence: Vec<CoherenceCheck>,
    /// Per pair of references with collocated responses.
    pub reciprocity: Vec<ReciprocityCheck>,
}

impl FrfChecks {
    /// The findings that deserve a warning.
    pub fn warnings(&self) -> Vec<String> {
        let mut out = Vec::new();
        for c in &self.coherence {
            if c.median < COHERENCE_MEDIAN_MIN {
                out.push(format!(
                    "coherence of {} / {}: median {} over the band ({} % of the lines below 0.5); the FRF is dominated by noise, leakage or unmeasured inputs there",
                    c.output,
                    c.reference,
                    sig(c.median, 3),
                    sig(100.0 * c.below_half, 2)
                ));
            }
        }
        for r in &self.reciprocity {
            if r.relative_difference > RECIPROCITY_MAX {
                out.push(format!(
                    "reciprocity: {} and {} differ by {} % over the band (more than {} %): a mislabelled or miscalibrated channel, or a set-up that is not reciprocal",
                    r.a,
                    r.b,
                    sig(100.0 * r.relative_difference, 3),
                    sig(100.0 * RECIPROCITY_MAX, 2)
                ));
            }
        }
        out
    }
}

/// Lines of `frf` inside `band_hz` (all for `None`).
fn lines_in(frf: &Frf, band_hz: Option<(f64, f64)>) -> Vec<usize> {
    (0..frf.frequency_hz.len())
        .filter(|&k| {
            let f = frf.frequency_hz[k];
            band_hz.is_none_or(|(lo, hi)| f >= lo && f <= hi)
        })
        .collect()
}

/// Runs the checks on the lines of `band_hz`; `reference_outputs[l]` is
/// the output at reference `l`'s point, if any.
pub fn check_frfs(
    frf: &Frf,
    band_hz: Option<(f64, f64)>,
    reference_outputs: &[Option<usize>],
) -> FrfChecks {
    let lines = lines_in(frf, band_hz);
    let mut checks = FrfChecks::default();
    if lines.is_empty() {
        return checks;
    }
    if let Some(coherence) = &frf.coherence {
        for l in 0..frf.references.len() {
            for i in 0..frf.outputs.len() {
                let mut g: Vec<f64> = lines.iter().map(|&k| coherence[k][(i, l)]).collect();
                g.sort_by(f64::total_cmp);
                let below = g.iter().filter(|&&x| x < 0.5).count();
                checks.coherence.push(CoherenceCheck {
                    output: frf.outputs[i].clone(),
                    reference: frf.references[l].clone(),
                    median: g[g.len() / 2],
                    below_half: below as f64 / g.len() as f64,
                });
            }
        }
    }
    for a in 0..frf.references.len() {
        for b in a + 1..frf.references.len() {
            let (Some(ia), Some(ib)) = (
                reference_outputs.get(a).copied().flatten(),
                reference_outputs.get(b).copied().flatten(),
            ) else {
                continue;
            };
            // H(response at b, force at a) against H(response at a, force at b).
            let (mut diff, mut mean) = (0.0, 0.0);
            for &k in &lines {
                let hab = frf.values[k][(ib, a)];
                let hba = frf.values[k][(ia, b)];
                diff += (hab - hba).norm_sqr();
                mean += ((hab + hba) * 0.5).norm_sqr();
            }
            checks.reciprocity.push(ReciprocityCheck {
                a: format!("{} / {}", frf.outputs[ib], frf.references[a]),
                b: format!("{} / {}", frf.outputs[ia], frf.references[b]),
                relative_difference: if mean > 0.0 {
                    (diff / mean).sqrt()
                } else {
                    f64::NAN
                },
            });
        }
    }
    checks
}

/// What the FRF route runs.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct FrfAnalysisSettings {
    /// The FRF identifier (band, order, weighting, selection, collocated
    /// pair, exponential window).
    pub identifier: FrfIdentifier,
    /// Refuse the FRFs when a check warns.
    pub strict: bool,
    /// Error bars by the parametric bootstrap ([`bootstrap`]).
    pub uncertainty: bool,
    /// Maximum-likelihood refinement on the FRFs with this parametrization
    /// (variances from the coherence and averages when the FRFs carry
    /// them, else estimated per output).
    pub refine: Option<ParametrizationSetting>,
}

/// The outcome of [`analyze_frfs`].
#[derive(Debug, Clone)]
pub struct FrfAnalysis {
    /// The identification.
    pub identification: FrfIdentification,
    /// Error bars of the identification (parametric bootstrap), if asked
    /// for and possible.
    pub uncertainty: Option<FrfSpread>,
    /// Why there are no error bars, when asked for.
    pub uncertainty_skipped: Option<String>,
    /// The refinement, if asked for.
    pub refinement: Option<FrfRefinement>,
    /// The checks of the FRFs.
    pub checks: FrfChecks,
    /// Every warning: the checks', then the identification's.
    pub warnings: Vec<String>,
}

/// Why FRFs were not identified.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum FrfAnalysisError {
    /// `--strict` and a check warns.
    #[error("--strict: the FRFs fail {} check(s):\n{}", lines.len(), lines.join("\n"))]
    Strict {
        /// The warnings.
        lines: Vec<String>,
    },
    /// The identification failed.
    #[error("FRF identification: {0}")]
    Identification(#[from] FrfIdentError),
    /// The refinement failed.
    #[error("--refine: {0}")]
    Refinement(#[from] FrfRefineError),
}

/// A refinement warning in the user's terms.
fn refine_warning(w: &FrfRefineWarning) -> String {
    match w {
        FrfRefineWarning::NotConverged { stop } => {
            format!("the optimizer stopped without converging ({stop:?})")
        }
        FrfRefineWarning::CostAboveExpectation { cost, expected } => format!(
            "the final cost {} is far above its expectation {}: the model misses something (a mode, nonlinearity) or the coherence understates the noise; the standard errors are too small",
            sig(*cost, 4),
            sig(*expected, 4)
        ),
        FrfRefineWarning::FewAverages { averages } => format!(
            "variances from the coherence of only {averages} averages: the standard errors are too small"
        ),
        FrfRefineWarning::ReferenceDof {
            reference,
            dof,
            dominance,
        } => format!(
            "reference {} was placed at floor {} but the identified input matrix is not clear-cut there (dominance {})",
            reference + 1,
            dof + 1,
            sig(*dominance, 3)
        ),
        FrfRefineWarning::NegativeDamping {
            mode,
            damping_ratio,
            damping_ratio_std,
        } => format!(
            "refined mode {} has a negative damping ratio {} (standard error {}): an unstable model, no use for simulation; the data do not determine that mode's damping to its sign",
            mode + 1,
            sig(*damping_ratio, 3),
            sig(*damping_ratio_std, 2)
        ),
        FrfRefineWarning::OverdampedModes { oscillatory, dofs } => format!(
            "the refined model has {oscillatory} oscillatory modes for {dofs} floors (an overdamped pair of poles): a local minimum from a poor start"
        ),
        FrfRefineWarning::NoiseNotSettled { updates, change } => format!(
            "the noise levels had not settled after {updates} re-estimation{} ({}; settled below {}): the weights, and so the refined values and their standard errors, are not yet those of the noise fit's fixed point",
            if *updates == 1 { "" } else { "s" },
            match change {
                Some(c) => format!("the last changed them by {} (relative)", sig(*c, 2)),
                None => "a single one cannot tell".to_string(),
            },
            ident::refine::NOISE_CHANGE_TOLERANCE
        ),
        other => format!("{other:?}"),
    }
}

/// Checks and identifies `frf` (see the module docs).
pub fn analyze_frfs(
    frf: &Frf,
    reference_outputs: &[Option<usize>],
    settings: &FrfAnalysisSettings,
) -> Result<FrfAnalysis, FrfAnalysisError> {
    let checks = check_frfs(frf, settings.identifier.band_hz, reference_outputs);
    let mut warnings = checks.warnings();
    if settings.strict && !warnings.is_empty() {
        return Err(FrfAnalysisError::Strict { lines: warnings });
    }
    let identification = settings.identifier.identify(frf)?;
    warnings.extend(identification.warnings.iter().map(ToString::to_string));
    let refinement = match settings.refine {
        Some(p) => {
            let start =
                FrfStart::from_identification(&identification, settings.identifier.collocated)?;
            let mut refiner =
                FrfRefiner::default().parametrization(p.parametrization(frf.outputs.len()));
            if let Some((lo, hi)) = settings.identifier.band_hz {
                refiner = refiner.band_hz(lo, hi);
            }
            let r = refiner.refine(frf, &start)?;
            warnings.extend(
                r.warnings
                    .iter()
                    .map(|w| format!("--refine: {}", refine_warning(w))),
            );
            Some(r)
        }
        None => None,
    };
    let (uncertainty, uncertainty_skipped) = if settings.uncertainty {
        match bootstrap(frf, &settings.identifier, &identification) {
            Ok(u) => {
                if u.failed > 0 {
                    warnings.push(format!(
                        "uncertainty: {} of {} resamples could not be identified and are left out",
                        u.failed, BOOTSTRAP_RESAMPLES
                    ));
                }
                (Some(u), None)
            }
            Err(why) => (None, Some(why)),
        }
    } else {
        (None, None)
    };
    Ok(FrfAnalysis {
        identification,
        uncertainty,
        uncertainty_skipped,
        refinement,
        checks,
        warnings,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use ident::frf::FrfQuantity;
    use nalgebra::DMatrix;
    use num_complex::Complex64 as C;

    #[test]
    fn refinement_warnings_are_worded_for_the_user() {
        // Each variant the refinement raises has its own wording, not its debug form
        // (`NegativeDamping { mode: ... }` reached the command line before).
        let ws = [
            FrfRefineWarning::NegativeDamping {
                mode: 1,
                damping_ratio: -2e-4,
                damping_ratio_std: 3e-4,
            },
            FrfRefineWarning::OverdampedModes {
                oscillatory: 2,
                dofs: 3,
            },
            FrfRefineWarning::FewAverages { averages: 3 },
            FrfRefineWarning::NoiseNotSettled {
                updates: 4,
                change: Some(0.31),
            },
            FrfRefineWarning::NoiseNotSettled {
                updates: 1,
                change: None,
            },
        ];
        let texts: Vec<String> = ws.iter().map(refine_warning).collect();
        for t in &texts {
            assert!(!t.contains('{') && !t.contains("Damping {"), "{t}");
        }
        assert!(
            texts[0].starts_with("refined mode 2 has a negative damping ratio -2.00e-4"),
            "{}",
            texts[0]
        );
        assert!(
            texts[1].contains("2 oscillatory modes for 3 floors"),
            "{}",
            texts[1]
        );
        assert!(
            texts[3].contains(
                "had not settled after 4 re-estimations (the last changed them by 0.31 (relative); settled below 0.1)"
            ),
            "{}",
            texts[3]
        );
        assert!(
            texts[4].contains("after 1 re-estimation (a single one cannot tell"),
            "{}",
            texts[4]
        );
    }

    /// Two outputs, two references at the outputs' points; `H_10` scaled
    /// by `1 + e` against `H_01`.
    fn frf(e: f64, coherence: f64) -> Frf {
        let frequency_hz: Vec<f64> = (1..=8).map(f64::from).collect();
        let values = frequency_hz
            .iter()
            .map(|&f| {
                let h = C::new(1.0 / f, 0.5);
                DMatrix::from_row_slice(2, 2, &[C::new(2.0, f), h, h * (1.0 + e), C::new(1.0, -f)])
            })
            .collect();
        Frf {
            coherence: Some(vec![DMatrix::from_element(2, 2, coherence); 8]),
            values,
            frequency_hz,
            quantity: FrfQuantity::Accelerance,
            averages: Some(10),
            outputs: vec!["acc1".into(), "acc2".into()],
            references: vec!["f1".into(), "f2".into()],
        }
    }

    #[test]
    fn reciprocity_is_the_relative_difference_of_the_transfer_pair() {
        let c = check_frfs(&frf(0.0, 1.0), None, &[Some(0), Some(1)]);
        assert_eq!(c.reciprocity.len(), 1);
        assert_eq!(c.reciprocity[0].relative_difference, 0.0);
        assert!(c.warnings().is_empty());
        // |h (1 + e) - h| / |h (1 + e / 2)| = e / (1 + e / 2) exactly, for
        // every line: 0.2 / 1.1.
        let c = check_frfs(&frf(0.2, 1.0), None, &[Some(0), Some(1)]);
        let d = c.reciprocity[0].relative_difference;
        assert!((d - 0.2 / 1.1).abs() < 1e-12, "{d}");
        assert!(
            c.warnings()[0].contains("reciprocity"),
            "{:?}",
            c.warnings()
        );
        // Without the references' points, nothing to compare.
        assert!(
            check_frfs(&frf(0.2, 1.0), None, &[None, Some(1)])
                .reciprocity
                .is_empty()
        );
    }

    #[test]
    fn a_low_coherence_is_named_and_strict_refuses() {
        let c = check_frfs(&frf(0.0, 0.4), Some((2.0, 5.0)), &[]);
        assert_eq!(c.coherence.len(), 4);
        assert_eq!(c.coherence[0].median, 0.4);
        assert_eq!(c.coherence[0].below_half, 1.0);
        let w = c.warnings();
        assert_eq!(w.len(), 4);
        assert!(w[0].contains("acc1 / f1"), "{w:?}");
        let settings = FrfAnalysisSettings {
            strict: true,
            ..Default::default()
        };
        let e = analyze_frfs(&frf(0.0, 0.4), &[], &settings).unwrap_err();
        assert!(matches!(e, FrfAnalysisError::Strict { ref lines } if lines.len() == 4));
    }
}

/// Resamples of the parametric bootstrap.
pub const BOOTSTRAP_RESAMPLES: usize = 40;

/// Seed of the bootstrap's noise: fixed, so that error bars repeat.
pub const BOOTSTRAP_SEED: u64 = 0x5eed_f4f0;

/// Standard deviations of an FRF identification over bootstrap resamples.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FrfSpread {
    /// How they were obtained, in words.
    pub method: String,
    /// Resamples identified.
    pub resamples: usize,
    /// Resamples that could not be identified (left out).
    pub failed: usize,
    /// Natural frequencies of the model's modes, Hz.
    pub frequencies_hz_std: Vec<f64>,
    /// Damping ratios of the model's modes.
    pub damping_ratios_std: Vec<f64>,
    /// M, rows.
    pub mass_std: Vec<Vec<f64>>,
    /// K, rows.
    pub stiffness_std: Vec<Vec<f64>>,
    /// MKR damping, rows.
    pub damping_mkr_std: Vec<Vec<f64>>,
    /// Rayleigh damping, rows.
    pub damping_rayleigh_std: Vec<Vec<f64>>,
}

/// Error bars of an FRF identification by the parametric bootstrap: the
/// identified modal model (LSFD's fit, residual terms included) plus
/// circular complex Gaussian noise of each value's variance is identified
/// again [`BOOTSTRAP_RESAMPLES`] times at the same pLSCF order, and the
/// standard deviations of the results are the error bars.
///
/// The variance of a value is `(1 - γ²) |H|^2 / ((n_d - 1) γ²)` when the
/// FRFs carry the coherence and at least 2 averages (the H1 estimate's
/// variance, as the refinement uses: see [`ident::frf::refine`]); otherwise
/// the mean square of LSFD's residual of that output and reference over
/// the band (what the data say the noise is, model errors included, so the
/// bars are then conservative). Resamples are drawn from a fixed seed: the
/// bars repeat. Refused (the reason returned) when the residual is zero or
/// the band is empty.
///
/// The noise is drawn independent from line to line. Windowed records make
/// neighbouring lines' errors correlated (an exponential window of time
/// constant `tau` smooths the noise spectrum over about `1 / (2 pi tau)`
/// Hz), and the bars then come out low. Measured on paper case 1 (24
/// campaigns at 2 % noise, FRFs with `--exponential-window 0.01`, about 5
/// correlated lines): the bars are 0.71-0.95 of the spread over the
/// campaigns for M and K (0.56 for K12) and 0.45-0.56 for the damping
/// ratios; with 24 campaigns that spread is itself known to about 15 %.
/// The refinement's standard errors (`--refine`) use the same independence
/// assumption.
pub fn bootstrap(
    frf: &Frf,
    identifier: &FrfIdentifier,
    id: &FrfIdentification,
) -> Result<FrfSpread, String> {
    use rand::RngExt;
    use rand::SeedableRng;
    use rand::rngs::ChaCha8Rng;
    use rand_distr::StandardNormal;

    let lines = lines_in(frf, identifier.band_hz);
    if lines.is_empty() {
        return Err("no line in the band".into());
    }
    let (m, r) = (frf.outputs.len(), frf.references.len());
    // The model the resamples are drawn around: LSFD's synthesis (in the
    // measured, windowed and polarity-corrected sense of the data).
    let sign = if id.polarity_flipped { -1.0 } else { 1.0 };
    // model[b] at line lines[b]: only the band is resampled.
    let model: Vec<nalgebra::DMatrix<ident::linalg::C64>> = lines
        .iter()
        .map(|&k| id.lsfd.synthesize(frf.frequency_hz[k]) * ident::linalg::C64::new(sign, 0.0))
        .collect();
    let from_coherence = match (&frf.coherence, frf.averages) {
        (Some(g), Some(n)) if n >= 2 => Some((g, n)),
        _ => None,
    };
    let mut variance = vec![nalgebra::DMatrix::<f64>::zeros(m, r); frf.frequency_hz.len()];
    match from_coherence {
        Some((g, n)) => {
            for &k in &lines {
                for i in 0..m {
                    for l in 0..r {
                        let g2 = g[k][(i, l)].clamp(0.0, 1.0);
                        let h2 = frf.values[k][(i, l)].norm_sqr();
                        variance[k][(i, l)] = if g2 > 0.0 {
                            (1.0 - g2).max(1e-6) * h2 / ((n - 1) as f64 * g2)
                        } else {
                            0.0
                        };
                    }
                }
            }
        }
        None => {
            for i in 0..m {
                for l in 0..r {
                    let ms = lines
                        .iter()
                        .zip(&model)
                        .map(|(&k, h)| (frf.values[k][(i, l)] - h[(i, l)]).norm_sqr())
                        .sum::<f64>()
                        / lines.len() as f64;
                    if !(ms.is_finite() && ms > 0.0) {
                        return Err(format!(
                            "the FRF of {} / {} is fitted exactly: no noise to resample",
                            frf.outputs[i], frf.references[l]
                        ));
                    }
                    for &k in &lines {
                        variance[k][(i, l)] = ms;
                    }
                }
            }
        }
    }
    let fixed = identifier
        .clone()
        .order(ident::frf::FrfOrder::Fixed(id.order));
    let mut rng = ChaCha8Rng::seed_from_u64(BOOTSTRAP_SEED);
    let mut results: Vec<FrfIdentification> = Vec::new();
    let mut failed = 0;
    for _ in 0..BOOTSTRAP_RESAMPLES {
        let mut resample = frf.clone();
        for (&k, h) in lines.iter().zip(&model) {
            for i in 0..m {
                for l in 0..r {
                    // Half the variance in each of the real and imaginary parts.
                    let sd = (variance[k][(i, l)] / 2.0).sqrt();
                    let re: f64 = rng.sample(StandardNormal);
                    let im: f64 = rng.sample(StandardNormal);
                    resample.values[k][(i, l)] =
                        h[(i, l)] + ident::linalg::C64::new(sd * re, sd * im);
                }
            }
        }
        match fixed.identify(&resample) {
            Ok(r) if r.mass.nrows() == id.mass.nrows() => results.push(r),
            _ => failed += 1,
        }
    }
    if results.len() < 2 {
        return Err(format!(
            "only {} of {BOOTSTRAP_RESAMPLES} bootstrap resamples could be identified",
            results.len()
        ));
    }
    let std_of = |values: Vec<f64>| -> f64 {
        let n = values.len() as f64;
        let mean = values.iter().sum::<f64>() / n;
        (values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt()
    };
    let dofs = id.mass.nrows();
    let matrix_std = |pick: fn(&FrfIdentification) -> &nalgebra::DMatrix<f64>| {
        (0..dofs)
            .map(|i| {
                (0..dofs)
                    .map(|j| std_of(results.iter().map(|r| pick(r)[(i, j)]).collect()))
                    .collect()
            })
            .collect()
    };
    let modal_std = |pick: fn(&FrfIdentification) -> &Vec<f64>| {
        (0..id.frequencies_hz.len())
            .map(|j| {
                std_of(
                    results
                        .iter()
                        .filter_map(|r| pick(r).get(j).copied())
                        .collect(),
                )
            })
            .collect()
    };
    Ok(FrfSpread {
        method: format!(
            "parametric bootstrap: {} resamples of the identified modal model plus noise of {}",
            BOOTSTRAP_RESAMPLES,
            if from_coherence.is_some() {
                "the H1 variance from the coherence and the averages"
            } else {
                "LSFD's residual variance per output and reference"
            }
        ),
        resamples: results.len(),
        failed,
        frequencies_hz_std: modal_std(|r| &r.frequencies_hz),
        damping_ratios_std: modal_std(|r| &r.damping_ratios),
        mass_std: matrix_std(|r| &r.mass),
        stiffness_std: matrix_std(|r| &r.stiffness),
        damping_mkr_std: matrix_std(|r| &r.damping_mkr),
        damping_rayleigh_std: matrix_std(|r| &r.damping_rayleigh),
    })
}

/// Where each reference force acts: the output at the collocated
/// reference's point is the collocated output; every other reference acts
/// at the output whose point is its own, if any.
pub fn reference_outputs(
    responses: &[records::frf::FrfPoint],
    references: &[records::frf::FrfPoint],
    collocated: (usize, usize),
) -> Vec<Option<usize>> {
    references
        .iter()
        .enumerate()
        .map(|(l, r)| {
            if l == collocated.1 {
                Some(collocated.0)
            } else {
                responses.iter().position(|p| p.same_point(r))
            }
        })
        .collect()
}

/// Reads FRF files and collates them into one set. `references[k]` is the
/// force point of file `k` when the file does not say it (headerless CSV),
/// one for every file or a single one for all.
pub fn read_frfs(
    paths: &[std::path::PathBuf],
    quantity: Option<ident::FrfQuantity>,
    unit: Option<&str>,
    references: &[records::frf::FrfPoint],
    responses: Option<&[records::frf::FrfPoint]>,
) -> Result<records::frf::FrfSet, records::RecordError> {
    use records::frf::{AssembleOptions, FrfReadOptions, assemble, read_frf};
    let files = paths
        .iter()
        .enumerate()
        .map(|(k, path)| {
            let opts = FrfReadOptions {
                quantity,
                unit: unit.map(str::to_string),
                reference: references
                    .get(if references.len() == 1 { 0 } else { k })
                    .cloned(),
                responses: responses.map(<[_]>::to_vec),
            };
            read_frf(path, &opts)
        })
        .collect::<Result<Vec<_>, _>>()?;
    assemble(&files, &AssembleOptions::default())
}
