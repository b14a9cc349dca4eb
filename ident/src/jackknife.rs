//! Uncertainty across hits: the delete-one jackknife over the hits of a
//! campaign.
//!
//! The main result identifies all hits jointly. To put error bars on it,
//! the campaign is identified again `n` times, each time without one hit,
//! and the spread of those leave-one-out results gives the jackknife
//! standard error of the joint estimate,
//! `std = sqrt((n - 1) / n * sum_i (theta_i - mean)^2)`,
//! for every frequency, damping ratio, Rayleigh coefficient and entry of
//! M, K and both damping matrices.
//!
//! Why the jackknife and not per-hit identification or a bootstrap:
//! - it estimates the standard error of the quantity reported, the joint
//!   estimate, directly. Per-hit results estimate the spread of
//!   single-hit identifications, which must then be divided by `sqrt(n)`
//!   on the assumption that the joint estimate behaves like their mean; a
//!   single hit is also the weakest data set the identifier ever sees (a
//!   mode barely excited in one hit, or noisy hits, break it first),
//!   while every jackknife resample keeps `n - 1` hits and behaves like
//!   the main fit. Measured on the paper's case 1 with 1 % noise and 10
//!   hits, both estimate the spread of jointly identified campaigns
//!   equally well, and single hits identify with the defaults;
//! - it needs `n` fits, no random numbers and no seed (it is
//!   deterministic by construction), where a bootstrap needs a hundred
//!   or more to settle its own noise;
//! - its known weakness, non-smooth statistics, does not apply to M, K
//!   and the modal parameters, smooth functions of the records once the
//!   model order is fixed.
//!
//! The resamples reuse the joint fit's model order and OKID observer order,
//! so the error bars are those of the parameters at the model structure
//! that the main result uses (and the resamples cost about 30 % less). The
//! resamples run in parallel with rayon; each is independent and the sums
//! are taken in hit order afterwards, so the result does not depend on the
//! number of threads. With fewer than [`MIN_HITS`] hits there is no
//! uncertainty (a standard deviation from two values says nothing).
//!
//! Above [`MAX_GROUPS`] hits the resamples leave out groups instead of
//! single hits (the delete-a-group jackknife): the hits are split into
//! [`MAX_GROUPS`] contiguous groups of near-equal size ([`hit_groups`]) and
//! each resample is identified without one group. The error bars then cost
//! [`MAX_GROUPS`] identifications whatever the number of hits, where the
//! delete-one jackknife's cost grows with the hits (and its work per hit as
//! well: quadratically in all). For groups of unequal size the variance is
//! the delete-m_j jackknife's (Busing, Meijer and van der Leeden, 1999,
//! *Statistics and Computing* 9, 3-8), built on pseudo-values
//! `h_j theta - (h_j - 1) theta_(-j)` with `h_j = n / m_j`; for groups of
//! equal size it is the textbook `(G - 1) / G sum (theta_(-j) - mean)^2`
//! (and for single hits the delete-one formula above, computed as before).
//! Groups are contiguous in the campaign's order, so a slow change over the
//! campaign (temperature, a loosening fixture) shows as spread between groups
//! rather than being averaged inside each. Measured on the paper's case 1 (1 %
//! noise, 20 campaigns of 40 hits each, `study/tests/jackknife.rs`), the
//! grouped error bars match the spread of the joint estimates as well as the
//! delete-one jackknife's do.
//!
//! Limits: the jackknife captures the hit-to-hit (noise) scatter, not
//! biases shared by all hits (an intersample assumption that does not
//! match the records, a wrong collocated pair, calibration errors).

use crate::campaign::Campaign;
use crate::pipeline::{Error, Identification, Identifier, Prepared, PreparedRecords};
use crate::record::Record;
use nalgebra::DMatrix;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::borrow::Cow;
use std::ops::Range;

/// Fewest hits for an uncertainty estimate.
pub const MIN_HITS: usize = 3;

/// A resample whose modes differ from the joint fit's by more than this
/// (relative frequency) picked other modes (a noise mode passed as
/// structural, typically at an over-specified order) and is left out:
/// hit-to-hit noise moves the frequencies by parts per 10^5 to 10^4, a
/// different mode by far more than 2 %.
pub const MODE_MATCH_TOLERANCE: f64 = 0.02;

/// Most resamples of the error bars: campaigns of more hits are split into this many
/// groups ([`hit_groups`]). A standard error from `G` resamples is itself uncertain by about
/// `1 / sqrt(2 (G - 1))`: 16 % at 20 (24 % at 10, the paper's campaigns), small beside the
/// factor-of-1.5 agreement the calibration tests ask for, while the error bars' cost stops
/// growing with the hits.
pub const MAX_GROUPS: usize = 20;

/// The left-out groups of a jackknife over `hits` hits with at most `max_groups` groups:
/// one hit each up to `max_groups` hits, else `max_groups` contiguous ranges whose sizes
/// differ by at most one (`k * hits / max_groups` rounded down are the starts).
pub fn hit_groups(hits: usize, max_groups: usize) -> Vec<Range<usize>> {
    let groups = hits.min(max_groups.max(1));
    (0..groups)
        .map(|k| k * hits / groups..(k + 1) * hits / groups)
        .collect()
}

/// Mean and standard deviation of one quantity.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Spread {
    /// Mean of the leave-one-out values.
    pub mean: f64,
    /// Jackknife standard error.
    pub std: f64,
}

/// Mean and standard deviation of a list of quantities (modes).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct VectorSpread {
    /// Means, one per mode.
    pub mean: Vec<f64>,
    /// Standard errors, one per mode.
    pub std: Vec<f64>,
}

/// Mean and standard deviation of every entry of a matrix (rows).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MatrixSpread {
    /// Means, as rows.
    pub mean: Vec<Vec<f64>>,
    /// Standard errors, as rows.
    pub std: Vec<Vec<f64>>,
}

/// A resample that could not be identified.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FailedResample {
    /// The hit left out (its label: the file), or the group of hits left out (`"FIRST to
    /// LAST (K hits)"`).
    pub left_out: String,
    /// Why it failed.
    pub error: String,
}

/// Error bars of an identification. `mean` is the mean of the
/// leave-one-out results, `std` the jackknife standard error of the joint
/// result (not the spread of single hits).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Jackknife {
    /// `"jackknife"` (delete-one, over hits) or `"grouped jackknife"` (delete-a-group, more
    /// hits than [`MAX_GROUPS`]).
    pub method: String,
    /// Hits in the joint identification.
    pub hits: usize,
    /// Groups of hits, one left out per resample (the hits, up to [`MAX_GROUPS`]).
    pub groups: usize,
    /// Resamples identified (each without one group).
    pub resamples: usize,
    /// Resamples that failed; they are left out of the statistics.
    pub failed: Vec<FailedResample>,
    /// Model order every resample used (the joint fit's).
    pub model_order: usize,
    /// OKID observer order every resample used (the joint fit's).
    pub observer_order: Option<usize>,
    /// Natural frequencies of the modes used, Hz.
    pub frequencies_hz: VectorSpread,
    /// Damping ratios of the modes used.
    pub damping_ratios: VectorSpread,
    /// Rayleigh alpha, 1/s.
    pub rayleigh_alpha: Spread,
    /// Rayleigh beta, s.
    pub rayleigh_beta: Spread,
    /// Mass matrix, kg.
    pub mass: MatrixSpread,
    /// Stiffness matrix, N/m.
    pub stiffness: MatrixSpread,
    /// MKR damping matrix, N s/m.
    pub damping_mkr: MatrixSpread,
    /// Rayleigh damping matrix, N s/m.
    pub damping_rayleigh: MatrixSpread,
}

/// Why there is no uncertainty estimate.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum UncertaintyError {
    /// Fewer than [`MIN_HITS`] records.
    #[error("uncertainty needs at least {MIN_HITS} hits, the campaign has {hits}")]
    TooFewHits {
        /// Records in the campaign.
        hits: usize,
    },
    /// Fewer than [`MIN_HITS`] resamples could be identified.
    #[error(
        "uncertainty: only {succeeded} of {groups} leave-out identifications succeeded, at least {MIN_HITS} are needed"
    )]
    TooFewResamples {
        /// Resamples identified.
        succeeded: usize,
        /// Resamples tried (groups of hits; the hits, up to [`MAX_GROUPS`]).
        groups: usize,
    },
}

/// Jackknife over the hits: identifies the campaign again without each hit (or, above
/// [`MAX_GROUPS`] hits, without each group of [`hit_groups`]), with `identifier` at the
/// orders of `joint` (the identification of all records with the same identifier). Failed
/// resamples are named by the campaign's labels.
pub fn jackknife(
    identifier: &Identifier,
    campaign: &Campaign,
    joint: &Identification,
) -> Result<Jackknife, UncertaintyError> {
    jackknife_in_groups(identifier, campaign, joint, MAX_GROUPS)
}

/// [`jackknife`] with at most `max_groups` resamples (`max_groups >= hits`: the delete-one
/// jackknife whatever the hits). Panics if `max_groups < MIN_HITS`.
pub fn jackknife_in_groups(
    identifier: &Identifier,
    campaign: &Campaign,
    joint: &Identification,
    max_groups: usize,
) -> Result<Jackknife, UncertaintyError> {
    grouped(identifier, campaign, joint, max_groups, None)
}

/// [`jackknife`] of the records `prepared` (those of `campaign`, in its order) with the
/// identifier that prepared them: the resamples' moments are those already accumulated
/// when the fixed observer order allows (at rest always: every sample from the leads on
/// forms an equation whatever the order, so the normal equations at a lower order are a
/// corner of those at the largest), so that the records are not read again. The same
/// result as [`jackknife`]: bit for bit when `joint` has the largest observer order
/// allowed, and within the round-off of the correlations' FFT (whose length follows the
/// order) below it. Panics if `prepared` holds other records than `campaign`.
pub fn jackknife_prepared(
    prepared: &PreparedRecords,
    campaign: &Campaign,
    joint: &Identification,
) -> Result<Jackknife, UncertaintyError> {
    assert!(
        std::ptr::eq(prepared.records(), campaign.records.as_slice())
            && prepared.dt_s() == campaign.dt_s,
        "jackknife_prepared: the records prepared are not the campaign's"
    );
    grouped(
        &prepared.identifier,
        campaign,
        joint,
        MAX_GROUPS,
        Some(&prepared.prepared),
    )
}

fn grouped(
    identifier: &Identifier,
    campaign: &Campaign,
    joint: &Identification,
    max_groups: usize,
    shared: Option<&Prepared>,
) -> Result<Jackknife, UncertaintyError> {
    assert!(
        max_groups >= MIN_HITS,
        "jackknife: at least {MIN_HITS} groups, asked for {max_groups}"
    );
    let n = campaign.records.len();
    if n < MIN_HITS {
        return Err(UncertaintyError::TooFewHits { hits: n });
    }
    let groups = hit_groups(n, max_groups);
    let results = leave_groups_out(identifier, campaign, Some(joint), &groups, shared);
    jackknife_from(campaign, joint, &groups, results)
}

/// The `n` leave-one-out identifications of a campaign (result `i` without
/// record `i`), in parallel and independent of the thread count. With
/// `joint` (the identification of all records with the same identifier)
/// they use its model and observer orders, as the jackknife does; without,
/// each chooses its own.
///
/// The records are validated and their OKID lagged products accumulated
/// once, and every resample subtracts one record's share; if the records
/// cannot be prepared as a whole, each subset is identified from scratch
/// (and fails or not on its own).
pub fn leave_one_out(
    identifier: &Identifier,
    campaign: &Campaign,
    joint: Option<&Identification>,
) -> Vec<Result<Identification, Error>> {
    let n = campaign.records.len();
    leave_groups_out(identifier, campaign, joint, &hit_groups(n, n), None)
}

/// The identifications of a campaign without each of `groups` (non-empty ranges of
/// records), as [`leave_one_out`] does for single records, from the moments `shared` of
/// its records when given and usable at the resamples' orders.
fn leave_groups_out(
    identifier: &Identifier,
    campaign: &Campaign,
    joint: Option<&Identification>,
    groups: &[Range<usize>],
    shared: Option<&Prepared>,
) -> Vec<Result<Identification, Error>> {
    let (records, dt_s) = (&campaign.records, campaign.dt_s);
    let id = match joint {
        Some(joint) => identifier.at_orders_of(joint),
        None => identifier.clone(),
    };
    let prepared = id.check().and_then(|valid| {
        let prepared = match shared.filter(|s| valid.fits_from(s)) {
            Some(s) => Cow::Borrowed(s),
            None => Cow::Owned(valid.prepare(records, dt_s)?),
        };
        Ok((valid, prepared))
    });
    match &prepared {
        Ok((valid, prepared)) => groups
            .par_iter()
            .map(|left_out| valid.identify_without(prepared, left_out.clone()))
            .collect(),
        Err(_) => groups
            .par_iter()
            .map(|left_out| {
                let subset: Vec<Record> = records
                    .iter()
                    .enumerate()
                    .filter(|(k, _)| !left_out.contains(k))
                    .map(|(_, r)| r.clone())
                    .collect();
                id.identify(&subset, dt_s)
            })
            .collect(),
    }
}

/// The jackknife of `joint` from the identifications of `campaign` without each of
/// `groups` (at `joint`'s orders), in the groups' order.
fn jackknife_from(
    campaign: &Campaign,
    joint: &Identification,
    groups: &[Range<usize>],
    results: Vec<Result<Identification, Error>>,
) -> Result<Jackknife, UncertaintyError> {
    let n = campaign.records.len();
    assert_eq!(results.len(), groups.len(), "one result per group");
    if n < MIN_HITS {
        return Err(UncertaintyError::TooFewHits { hits: n });
    }
    let observer_order = joint.observer.map(|o| o.order);
    // Identified resamples with the size of the group each left out.
    let mut ok: Vec<(Identification, usize)> = Vec::with_capacity(groups.len());
    let mut failed = Vec::new();
    let dofs = joint.frequencies_hz.len();
    for (group, r) in groups.iter().zip(results) {
        let label = if group.len() == 1 {
            campaign.label(group.start)
        } else {
            format!(
                "{} to {} ({} hits)",
                campaign.label(group.start),
                campaign.label(group.end - 1),
                group.len()
            )
        };
        match r {
            Ok(r) if r.frequencies_hz.len() != dofs || r.mass.nrows() != dofs => {
                failed.push(FailedResample {
                    left_out: label,
                    error: format!(
                        "{} modes identified, the joint fit has {dofs}",
                        r.frequencies_hz.len()
                    ),
                })
            }
            Ok(r)
                if r.frequencies_hz
                    .iter()
                    .zip(&joint.frequencies_hz)
                    .any(|(f, fj)| (f / fj - 1.0).abs() > MODE_MATCH_TOLERANCE) =>
            {
                failed.push(FailedResample {
                    left_out: label,
                    error: format!(
                        "other modes identified ({:.4?} Hz, the joint fit has {:.4?} Hz)",
                        r.frequencies_hz, joint.frequencies_hz
                    ),
                })
            }
            Ok(r) => ok.push((r, group.len())),
            Err(e) => failed.push(FailedResample {
                left_out: label,
                error: e.to_string(),
            }),
        }
    }
    if ok.len() < MIN_HITS {
        return Err(UncertaintyError::TooFewResamples {
            succeeded: ok.len(),
            groups: groups.len(),
        });
    }
    let sizes: Vec<usize> = ok.iter().map(|(_, m)| *m).collect();
    let spread = |get: &dyn Fn(&Identification) -> f64| -> Spread {
        let values: Vec<f64> = ok.iter().map(|(r, _)| get(r)).collect();
        grouped_spread(&values, &sizes, get(joint))
    };
    let vector = |get: &dyn Fn(&Identification) -> &[f64]| -> VectorSpread {
        let stats: Vec<Spread> = (0..dofs).map(|j| spread(&|r| get(r)[j])).collect();
        VectorSpread {
            mean: stats.iter().map(|s| s.mean).collect(),
            std: stats.iter().map(|s| s.std).collect(),
        }
    };
    let matrix = |get: &dyn Fn(&Identification) -> &DMatrix<f64>| -> MatrixSpread {
        let stats: Vec<Vec<Spread>> = (0..dofs)
            .map(|i| (0..dofs).map(|j| spread(&|r| get(r)[(i, j)])).collect())
            .collect();
        MatrixSpread {
            mean: stats
                .iter()
                .map(|row| row.iter().map(|s| s.mean).collect())
                .collect(),
            std: stats
                .iter()
                .map(|row| row.iter().map(|s| s.std).collect())
                .collect(),
        }
    };
    let delete_one = groups.iter().all(|g| g.len() == 1);
    Ok(Jackknife {
        method: if delete_one {
            "jackknife"
        } else {
            "grouped jackknife"
        }
        .into(),
        hits: n,
        groups: groups.len(),
        resamples: ok.len(),
        failed,
        model_order: joint.model_order,
        observer_order,
        frequencies_hz: vector(&|r| &r.frequencies_hz),
        damping_ratios: vector(&|r| &r.damping_ratios),
        rayleigh_alpha: spread(&|r| r.rayleigh.alpha),
        rayleigh_beta: spread(&|r| r.rayleigh.beta),
        mass: matrix(&|r| &r.mass),
        stiffness: matrix(&|r| &r.stiffness),
        damping_mkr: matrix(&|r| &r.damping_mkr),
        damping_rayleigh: matrix(&|r| &r.damping_rayleigh),
    })
}

/// Mean of the leave-group-out `values` (group `j` of `sizes[j]` records left out) and the
/// jackknife standard error of the joint value `joint`. Groups of one size: the textbook
/// formula ([`jackknife_spread`]); of unequal sizes: the delete-m_j jackknife (module docs),
/// over the records of the groups given (`n = sum sizes`).
pub fn grouped_spread(values: &[f64], sizes: &[usize], joint: f64) -> Spread {
    assert_eq!(values.len(), sizes.len(), "one size per value");
    if sizes.windows(2).all(|w| w[0] == w[1]) {
        return jackknife_spread(values.iter().copied());
    }
    let g = values.len() as f64;
    let n = sizes.iter().sum::<usize>() as f64;
    let mean = values.iter().sum::<f64>() / g;
    // theta_J = G theta - sum (1 - m_j / n) theta_(-j)
    let corrected = g * joint
        - values
            .iter()
            .zip(sizes)
            .map(|(v, &m)| (1.0 - m as f64 / n) * v)
            .sum::<f64>();
    let var = values
        .iter()
        .zip(sizes)
        .map(|(v, &m)| {
            let h = n / m as f64;
            let pseudo = h * joint - (h - 1.0) * v;
            (pseudo - corrected).powi(2) / (h - 1.0)
        })
        .sum::<f64>()
        / g;
    Spread {
        mean,
        std: var.sqrt(),
    }
}

/// Mean of leave-one-out values and the jackknife standard error
/// `sqrt((n - 1) / n * sum (x_i - mean)^2)`.
pub fn jackknife_spread(values: impl Iterator<Item = f64>) -> Spread {
    let v: Vec<f64> = values.collect();
    let n = v.len() as f64;
    if v.is_empty() {
        return Spread {
            mean: f64::NAN,
            std: f64::NAN,
        };
    }
    let mean = v.iter().sum::<f64>() / n;
    let ss: f64 = v.iter().map(|x| (x - mean) * (x - mean)).sum();
    Spread {
        mean,
        std: ((n - 1.0) / n * ss).sqrt(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn groups_cover_the_hits_in_order_with_sizes_within_one() {
        assert_eq!(
            hit_groups(10, MAX_GROUPS),
            (0..10).map(|k| k..k + 1).collect::<Vec<_>>()
        );
        for hits in [21, 40, 50, 53, 200] {
            let g = hit_groups(hits, MAX_GROUPS);
            assert_eq!(g.len(), MAX_GROUPS);
            assert_eq!((g[0].start, g[MAX_GROUPS - 1].end), (0, hits));
            assert!(g.windows(2).all(|w| w[0].end == w[1].start));
            let (lo, hi) = (hits / MAX_GROUPS, hits.div_ceil(MAX_GROUPS));
            assert!(
                g.iter().all(|r| (lo..=hi).contains(&r.len())),
                "{hits}: {g:?}"
            );
        }
    }

    /// Leave-group-out means of `x` for `groups`, and the sizes.
    fn group_means(x: &[f64], groups: &[Range<usize>]) -> (Vec<f64>, Vec<usize>) {
        let total: f64 = x.iter().sum();
        groups
            .iter()
            .map(|g| {
                let out: f64 = x[g.clone()].iter().sum();
                ((total - out) / (x.len() - g.len()) as f64, g.len())
            })
            .unzip()
    }

    #[test]
    fn grouped_jackknife_of_the_mean_has_its_closed_form() {
        // For the sample mean the pseudo-value of group j is the group's own
        // mean ybar_j, so the delete-m_j variance is
        // (1/G) sum m_j (ybar_j - xbar)^2 / (n - m_j), computed here directly.
        // Equal groups: (G - 1)/G sum (theta_(-j) - mean)^2. Both to 1e-12
        // relative (sums of 50 terms of order 1 in a different order).
        let x: Vec<f64> = (0..50)
            .map(|i| ((i * i) as f64 * 0.37).sin() + 0.1 * i as f64)
            .collect();
        let n = x.len() as f64;
        let xbar = x.iter().sum::<f64>() / n;
        let groups = hit_groups(x.len(), 20);
        let (values, sizes) = group_means(&x, &groups);
        assert!(sizes.contains(&2) && sizes.contains(&3));
        let s = grouped_spread(&values, &sizes, xbar);
        let expected: f64 = groups
            .iter()
            .map(|g| {
                let m = g.len() as f64;
                let ybar = x[g.clone()].iter().sum::<f64>() / m;
                m * (ybar - xbar).powi(2) / (n - m)
            })
            .sum::<f64>()
            / groups.len() as f64;
        assert!(
            (s.std.powi(2) / expected - 1.0).abs() < 1e-12,
            "{} {expected}",
            s.std.powi(2)
        );
        let equal = hit_groups(x.len(), 10);
        let (values, sizes) = group_means(&x, &equal);
        let s = grouped_spread(&values, &sizes, xbar);
        let g = values.len() as f64;
        let mean = values.iter().sum::<f64>() / g;
        let textbook = (g - 1.0) / g * values.iter().map(|v| (v - mean).powi(2)).sum::<f64>();
        assert!((s.std.powi(2) / textbook - 1.0).abs() < 1e-12);
        assert!((s.mean - mean).abs() < 1e-12);
    }

    #[test]
    fn jackknife_of_the_mean_is_the_standard_error() {
        // For the sample mean, the jackknife standard error equals
        // s / sqrt(n) exactly.
        let x = [1.0, 4.0, 2.0, 8.0, 5.0];
        let n = x.len() as f64;
        let loo = (0..x.len()).map(|i| {
            x.iter()
                .enumerate()
                .filter(|&(k, _)| k != i)
                .map(|(_, v)| v)
                .sum::<f64>()
                / (n - 1.0)
        });
        let s = jackknife_spread(loo);
        let mean = x.iter().sum::<f64>() / n;
        let sd = (x.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / (n - 1.0)).sqrt();
        assert!((s.mean - mean).abs() < 1e-12);
        assert!((s.std - sd / n.sqrt()).abs() < 1e-12, "{} {}", s.std, sd);
    }
}
