//! Campaign consistency: every hit judged against the other hits.
//!
//! The [`quality`](crate::quality) checks look at one hit at a time. A rig
//! also produces faults that only show against the rest of the campaign: a
//! dead or unplugged accelerometer in one hit, a column copied from another
//! channel, the same file given twice, one wild sample, a channel whose
//! level or spectrum has nothing to do with the other hits. Used silently,
//! any of these skews M, K and R while everything looks fine (one dead
//! channel in one hit of six moved M22 by 41 %). The rule is: **a hit that
//! is inconsistent with the others is never used silently**. The caller
//! (`study::analysis`) drops a flagged hit with a warning by default and
//! refuses the campaign under `--strict`.
//!
//! | kind | what is compared | flagged when (default) |
//! |---|---|---|
//! | non-finite | every sample | NaN or infinite |
//! | dead channel | a channel with itself | every sample equal (unless dead in every hit) |
//! | spike | an output's largest sample with the rest of it | 100x the largest sample more than 3 samples away, not at the hit |
//! | copied channel | two channels of one hit | equal up to a factor (1 - corr^2 <= 1e-8) in fewer than half the hits |
//! | duplicate | two hits, channel by channel | difference energy <= 1e-8 of the signal's |
//! | level | RMS of a channel (outputs: over the hit's force RMS) with the campaign's median | outside 1/10..10x (20 dB) |
//! | spectrum | share of a channel's energy per octave band with the campaign's median share | a band holding >= 5 % differs by 10x |
//! | offset | a channel's mean over its RMS with the campaign's median | over 10x the median and over 0.1 |
//! | residual | each hit's outputs with the joint model of the kept hits (in `study`) | over 10x the median and over 0.1 % of the prediction's energy |
//! | transfer | each hit's gain to each output against the model of the other hits (in `study`) | over 2 % and over 10 robust deviations from the median gain |
//! | spike (glitch) | each output sample with the model of the hits that agree best (in `study`) | over 20 robust deviations of the misfit and 3x the median such departure |
//! | breaks the identification | the joint identification with and without the hit (in `study`) | fails with it, succeeds without it |
//!
//! The comparisons across hits need at least [`ConsistencySettings::min_hits`]
//! hits (with two, the odd one out cannot be told apart); with fewer the
//! result carries a note saying so. Every flag names the record, the channel
//! and, for single samples, the line of the file ([`Locate`]).
//!
//! Thresholds are deliberately coarse: they separate rig faults (orders of
//! magnitude, or an exact copy) from the hit-to-hit spread of honest data
//! (a factor of 2 to 3 in hammer force, a few dB in spectrum). Subtler
//! faults are what the joint-model residual is for.

use std::fmt;

use ident::Campaign;
use rayon::prelude::*;
use rustfft::FftPlanner;
use rustfft::num_complex::Complex;
use serde::Serialize;

use crate::numfmt::sig;
use crate::record::RecordFile;

/// Thresholds of the consistency checks, each with the reason for its size.
#[derive(Debug, Clone, PartialEq)]
pub struct ConsistencySettings {
    /// Fewest hits for the comparisons across hits: with two, a
    /// disagreement does not say which hit is wrong.
    pub min_hits: usize,
    /// Level ratio to the campaign's median beyond which a channel is
    /// flagged: 10 (20 dB). Honest hammer hits vary by a factor 2 to 3 in
    /// force, and the outputs are compared per newton of force, so a factor
    /// of 10 is a fault (dead sensor, wrong range, wrong unit), not spread.
    pub level_factor: f64,
    /// A sample this many times larger than every sample of the channel
    /// more than [`SPIKE_GUARD`] samples away is a spike: 100. An honest
    /// free decay changes by a few percent per sample, and the acceleration
    /// jump at the hit itself (which is exempt) is at most `1/(omega dt)`
    /// times the ringing.
    pub spike_factor: f64,
    /// Two channels of a hit whose waveforms agree up to a factor with
    /// `1 - corr^2` at or below this are copies: 1e-8 (an 80 dB match).
    /// Two real sensors differ at least by their noise, rarely below 60 dB.
    pub copy_tolerance: f64,
    /// Two hits whose every channel differs by at most this share of its
    /// energy are the same data: 1e-8. Re-exported files with 6 significant
    /// digits differ by about 1e-12; two real hits by their noise (1e-4 or
    /// more at 40 dB SNR).
    pub duplicate_tolerance: f64,
    /// Octave bands of the spectrum comparison, down from the Nyquist
    /// frequency (the lowest band reaches 0 Hz): 8, so a 500 Hz record's
    /// lowest band ends near 2 Hz, below any building mode of interest.
    pub spectrum_bands: usize,
    /// Share of a channel's energy a band must hold (in the hit or in the
    /// median) to be compared: 5 %. Bands with less are noise-dominated
    /// and their shares scatter by more than the factor below.
    pub spectrum_min_share: f64,
    /// Ratio of a band's share to the campaign's median share beyond which
    /// the spectrum is flagged: 10 (the same 20 dB as the level).
    pub spectrum_factor: f64,
    /// A hit's output residual against the joint model is flagged when it
    /// exceeds this many times the campaign's median residual: 10. Honest
    /// hits share the noise and the model error, so their residual shares
    /// scatter by far less (chi-square with thousands of degrees of freedom,
    /// times the hit-to-hit force spread squared).
    pub residual_factor: f64,
    /// ... and exceeds this share of the predicted response energy: 1e-3 (a
    /// 3 % RMS misfit). Below it a hit agrees with the model better than any
    /// calibration of a real rig, whatever the median.
    pub residual_floor: f64,
    /// A hit's transfer gain to an output (the least-squares factor between
    /// the output and the model of the other hits' prediction) is flagged
    /// when it differs from the median gain over the hits by more than this
    /// share: 0.02 ...
    pub transfer_floor: f64,
    /// ... and by more than this many robust standard deviations of the
    /// gains (1.4826 x their median absolute deviation): 10. Honest hits of
    /// one set-up share their transfer to well within a percent at 1 %
    /// noise, but the gains of ten hits scatter with heavy tails (weaker hits
    /// are noisier, and ten gains make a rough MAD): clean simulated
    /// campaigns of the bundled scenarios at 5-20 % noise reach 8.6 robust
    /// deviations (105 campaigns, seeds 1-5), so 5 would flag honest hits.
    /// A gain error in one hit of n moves M and K by about the error over n.
    pub transfer_sigmas: f64,
    /// A single output sample departing from the model of the hits that
    /// agree best (in `study`) by more than this many robust deviations of
    /// the hit's misfit (1.4826 x its median absolute deviation) is a
    /// glitch: 20 ...
    pub glitch_sigmas: f64,
    /// ... and by more than this many times the median over the hits of
    /// the same largest departure: 3. Honest misfits are noise plus a
    /// model error concentrated near the hit, which every hit shares.
    pub glitch_factor: f64,
    /// ... and by more than this fraction of the channel's peak in that
    /// hit: 0.02. Without noise (simulated campaigns at noise 0) the misfit
    /// is the model's own error, concentrated at the pulse (measured up to
    /// 0.0068 of the peak on paper case 1, seeds 1-6, where it reached
    /// 13,000 robust deviations of an almost zero misfit); a glitch that
    /// matters to M and K is far larger (the smallest one found to move K
    /// by a standard error was a tenth of the peak).
    pub glitch_floor: f64,
    /// A channel's mean over its RMS about the mean is flagged when it
    /// exceeds this many times the campaign's median of the same ratio:
    /// 10 (as the level).
    pub offset_factor: f64,
    /// ... and exceeds this value: 0.1. A hammer record's acceleration
    /// integrates to the velocity change over the record, near zero, and
    /// its force mean over RMS is about the square root of the pulse's share
    /// of the record (0.04 for 3 of 2048 samples), so honest records stay
    /// well below.
    pub offset_floor: f64,
}

/// Samples either side of a spike candidate excluded from the comparison:
/// the analyzer's anti-aliasing filter spreads a true sample over about
/// three samples either side.
pub const SPIKE_GUARD: usize = 3;

impl Default for ConsistencySettings {
    fn default() -> Self {
        ConsistencySettings {
            min_hits: 3,
            level_factor: 10.0,
            spike_factor: 100.0,
            copy_tolerance: 1e-8,
            duplicate_tolerance: 1e-8,
            spectrum_bands: 8,
            spectrum_min_share: 0.05,
            spectrum_factor: 10.0,
            residual_factor: 10.0,
            residual_floor: 1e-3,
            offset_factor: 10.0,
            offset_floor: 0.1,
            transfer_floor: 0.02,
            glitch_sigmas: 20.0,
            glitch_factor: 3.0,
            glitch_floor: 0.02,
            transfer_sigmas: 10.0,
        }
    }
}

impl ConsistencySettings {
    /// Checks the thresholds (a message naming the field otherwise).
    pub fn check(&self) -> Result<(), String> {
        let above_one = [
            ("level_factor", self.level_factor),
            ("spike_factor", self.spike_factor),
            ("spectrum_factor", self.spectrum_factor),
            ("residual_factor", self.residual_factor),
            ("offset_factor", self.offset_factor),
            ("transfer_sigmas", self.transfer_sigmas),
            ("glitch_sigmas", self.glitch_sigmas),
            ("glitch_factor", self.glitch_factor),
        ];
        for (name, v) in above_one {
            if !(v.is_finite() && v > 1.0) {
                return Err(format!(
                    "consistency.{name}: must be a number above 1, got {v}"
                ));
            }
        }
        let fractions = [
            ("copy_tolerance", self.copy_tolerance),
            ("duplicate_tolerance", self.duplicate_tolerance),
            ("spectrum_min_share", self.spectrum_min_share),
            ("residual_floor", self.residual_floor),
            ("offset_floor", self.offset_floor),
            ("transfer_floor", self.transfer_floor),
            ("glitch_floor", self.glitch_floor),
        ];
        for (name, v) in fractions {
            if !(v.is_finite() && (0.0..1.0).contains(&v)) {
                return Err(format!("consistency.{name}: must be in [0, 1), got {v}"));
            }
        }
        if self.min_hits < 3 {
            return Err(format!(
                "consistency.min_hits: must be at least 3 (with two hits the odd one out cannot be told), got {}",
                self.min_hits
            ));
        }
        if !(1..=30).contains(&self.spectrum_bands) {
            return Err(format!(
                "consistency.spectrum_bands: must be 1 to 30 octaves, got {}",
                self.spectrum_bands
            ));
        }
        Ok(())
    }
}

/// What is inconsistent.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "kebab-case")]
#[non_exhaustive]
pub enum Inconsistency {
    /// A NaN or infinite sample.
    NonFinite,
    /// A channel constant over the whole record.
    DeadChannel,
    /// One sample far above the rest of its channel.
    Spike,
    /// A channel equal (up to a factor) to another channel of the hit.
    CopiedChannel,
    /// The hit repeats another hit's data.
    Duplicate,
    /// A channel's level is far from the other hits'.
    Level,
    /// A channel's spectrum is far from the other hits'.
    Spectrum,
    /// A channel's mean is far from zero, unlike the other hits' (a DC
    /// offset or a drift).
    Offset,
    /// A hit's outputs do not follow the model the other hits agree on.
    Residual,
    /// A hit's transfer gain from the input to an output (against the model
    /// of the other hits) differs from the other hits'.
    Transfer,
    /// The joint identification fails with the hit and succeeds without
    /// it.
    BreaksIdentification,
}

impl Inconsistency {
    /// Short name, as in messages.
    pub fn label(self) -> &'static str {
        match self {
            Inconsistency::NonFinite => "non-finite sample",
            Inconsistency::DeadChannel => "dead channel",
            Inconsistency::Spike => "spike",
            Inconsistency::CopiedChannel => "copied channel",
            Inconsistency::Duplicate => "duplicate record",
            Inconsistency::Level => "level",
            Inconsistency::Spectrum => "spectrum",
            Inconsistency::Offset => "offset",
            Inconsistency::Residual => "residual",
            Inconsistency::Transfer => "transfer",
            Inconsistency::BreaksIdentification => "breaks the identification",
        }
    }
}

impl fmt::Display for Inconsistency {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.label())
    }
}

/// One inconsistent hit (or channel of a hit).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ConsistencyFlag {
    /// 0-based position of the record in the campaign.
    pub record: usize,
    /// The record's label (its file).
    pub file: String,
    /// The channel concerned, if one is.
    pub channel: Option<String>,
    /// What is wrong.
    pub kind: Inconsistency,
    /// The finding with its numbers and threshold (without file and
    /// channel).
    pub message: String,
}

impl fmt::Display for ConsistencyFlag {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: ", self.file)?;
        if let Some(c) = &self.channel {
            write!(f, "channel {c}: ")?;
        }
        write!(f, "{}: {}", self.kind, self.message)
    }
}

/// The outcome of [`check_consistency`].
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct Consistency {
    /// Inconsistent hits, in record order (a hit may have several flags).
    pub flags: Vec<ConsistencyFlag>,
    /// Findings about the whole campaign that flag no hit (for example a
    /// channel pair equal in every hit, or too few hits to compare).
    pub notes: Vec<String>,
}

impl Consistency {
    /// The flagged records, ascending, each once.
    pub fn flagged_records(&self) -> Vec<usize> {
        let mut r: Vec<usize> = self.flags.iter().map(|f| f.record).collect();
        r.sort_unstable();
        r.dedup();
        r
    }
}

/// Names the place of a sample in its file, for messages (shared by the threads of an
/// analysis).
pub trait Locate: Sync {
    /// Where sample `sample` (0-based) of channel `channel` of record
    /// `record` is, e.g. `line 512` or `sample #513`.
    fn sample(&self, record: usize, channel: &str, sample: usize) -> String;
}

/// Records without files: samples are named by position (1-based).
#[derive(Debug, Clone, Copy, Default)]
pub struct ByPosition;

impl Locate for ByPosition {
    fn sample(&self, _record: usize, _channel: &str, sample: usize) -> String {
        format!("sample #{}", sample + 1)
    }
}

/// Records read from files: samples are named by line where the format has
/// lines, else by position and time.
#[derive(Debug, Clone, Copy)]
pub struct ByLine<'a>(pub &'a [RecordFile]);

impl Locate for ByLine<'_> {
    fn sample(&self, record: usize, channel: &str, sample: usize) -> String {
        let Some(file) = self.0.get(record) else {
            return ByPosition.sample(record, channel, sample);
        };
        let line = file
            .channels
            .iter()
            .find(|c| c.name == channel)
            .and_then(|c| c.lines.as_ref())
            .and_then(|l| l.line_of(sample));
        match line {
            Some(l) => format!("line {l}"),
            None => format!(
                "sample #{} (t = {} s)",
                sample + 1,
                sig(file.time_s(sample), 6)
            ),
        }
    }
}

/// One channel of one hit, as the checks see it.
struct Signal<'a> {
    name: &'a str,
    input: bool,
    values: Vec<f64>,
}

fn signals(c: &Campaign, k: usize) -> Vec<Signal<'_>> {
    let rec = &c.records[k];
    let mut out = Vec::with_capacity(c.inputs.len() + c.outputs.len());
    for (i, name) in c.inputs.iter().enumerate() {
        out.push(Signal {
            name,
            input: true,
            values: rec.inputs.row(i).iter().copied().collect(),
        });
    }
    for (i, name) in c.outputs.iter().enumerate() {
        out.push(Signal {
            name,
            input: false,
            values: rec.outputs.row(i).iter().copied().collect(),
        });
    }
    out
}

/// Checks every hit of `c` against the others (see the module docs).
/// `locate` names the lines of single samples.
///
/// Panics if `settings` fail [`ConsistencySettings::check`] (validate them
/// once, where they are read).
pub fn check_consistency(
    c: &Campaign,
    locate: &dyn Locate,
    settings: &ConsistencySettings,
) -> Consistency {
    settings
        .check()
        .expect("consistency settings are checked where they are read");
    let hits = c.records.len();
    let data: Vec<Vec<Signal<'_>>> = (0..hits).map(|k| signals(c, k)).collect();
    let channels = c.inputs.len() + c.outputs.len();
    let mut out = Consistency::default();
    let flag = |out: &mut Consistency, k: usize, ch: Option<&str>, kind, message: String| {
        out.flags.push(ConsistencyFlag {
            record: k,
            file: c.labels[k].clone(),
            channel: ch.map(str::to_string),
            kind,
            message,
        });
    };

    // Non-finite samples: nothing else can be computed on such a channel.
    let mut broken = vec![vec![false; channels]; hits];
    for k in 0..hits {
        for (j, s) in data[k].iter().enumerate() {
            if let Some(i) = s.values.iter().position(|v| !v.is_finite()) {
                broken[k][j] = true;
                flag(
                    &mut out,
                    k,
                    Some(s.name),
                    Inconsistency::NonFinite,
                    format!("{} holds {}", locate.sample(k, s.name, i), s.values[i]),
                );
            }
        }
    }

    // Dead channels, unless dead in every hit (then the channel, not a hit,
    // is the problem, and the identifier refuses it by name).
    let dead: Vec<Vec<bool>> = data
        .iter()
        .map(|sig| {
            sig.iter()
                .map(|s| s.values.windows(2).all(|w| w[0] == w[1]))
                .collect()
        })
        .collect();
    for j in 0..channels {
        let dead_hits = (0..hits).filter(|&k| dead[k][j]).count();
        if dead_hits == hits {
            out.notes.push(format!(
                "channel {} is constant in every hit",
                data[0][j].name
            ));
            continue;
        }
        for k in (0..hits).filter(|&k| dead[k][j] && !broken[k][j]) {
            let s = &data[k][j];
            flag(
                &mut out,
                k,
                Some(s.name),
                Inconsistency::DeadChannel,
                format!(
                    "constant at {} over all {} samples while it varies in {} other hit(s) (a dead, unplugged or unpowered sensor?)",
                    sig(s.values.first().copied().unwrap_or(0.0), 4),
                    s.values.len(),
                    hits - dead_hits
                ),
            );
        }
    }
    let usable = |k: usize, j: usize| !broken[k][j] && !dead[k][j];

    // Spikes in outputs (inputs: see the level check, which tells a spike
    // from a hit by comparing with the other hits).
    // The search per hit in parallel (each hit's numbers are its own), the flags in order.
    let spikes: Vec<Vec<Option<Spike>>> = (0..hits)
        .into_par_iter()
        .map(|k| {
            data[k]
                .iter()
                .enumerate()
                .map(|(j, s)| {
                    (!s.input && usable(k, j))
                        .then(|| spike(&s.values, settings.spike_factor))
                        .flatten()
                })
                .collect()
        })
        .collect();
    let mut spiked = vec![vec![false; channels]; hits];
    for k in 0..hits {
        let hit_at: Vec<usize> = data[k]
            .iter()
            .enumerate()
            .filter(|(j, s)| s.input && usable(k, *j))
            .map(|(_, s)| argmax_abs(&s.values, mean(&s.values)).0)
            .collect();
        for (j, s) in data[k].iter().enumerate() {
            if let Some(sp) = &spikes[k][j]
                && !hit_at.iter().any(|&h| h.abs_diff(sp.sample) <= SPIKE_GUARD)
            {
                spiked[k][j] = true;
                flag(
                    &mut out,
                    k,
                    Some(s.name),
                    Inconsistency::Spike,
                    sp.describe(&locate.sample(k, s.name, sp.sample)),
                );
            }
        }
    }

    // Copied channels: a pair equal up to a factor in a minority of hits.
    for a in 0..channels {
        for b in a + 1..channels {
            let equal: Vec<Option<f64>> = (0..hits)
                .map(|k| {
                    if !(usable(k, a) && usable(k, b)) {
                        return None;
                    }
                    let (x, y) = (&data[k][a].values, &data[k][b].values);
                    let (sxy, sxx, syy) = dots(x, y);
                    let miss = 1.0 - sxy * sxy / (sxx * syy);
                    (miss <= settings.copy_tolerance).then_some(sxy / sxx)
                })
                .collect();
            let count = equal.iter().filter(|e| e.is_some()).count();
            let (na, nb) = (data[0][a].name, data[0][b].name);
            if count == 0 {
                continue;
            }
            if 2 * count > hits {
                out.notes.push(format!(
                    "channels {na} and {nb} are equal up to a factor in {count} of {hits} hits (two sensors on one rigid point, or one signal recorded twice?)"
                ));
                continue;
            }
            for (k, e) in equal.iter().enumerate() {
                if let Some(factor) = e {
                    flag(
                        &mut out,
                        k,
                        Some(nb),
                        Inconsistency::CopiedChannel,
                        format!(
                            "equals {na} times {} sample for sample, in this hit only ({} of {hits} hits): a copied column or a wiring fault",
                            sig(*factor, 4),
                            count
                        ),
                    );
                }
            }
        }
    }

    // Duplicate records, whatever their names. Each channel's fingerprint
    // is computed once (the pairs are quadratic in the hits).
    let prints: Vec<Vec<Fingerprint>> = data
        .iter()
        .map(|sig| sig.iter().map(|s| Fingerprint::of(&s.values)).collect())
        .collect();
    let mut duplicate_of = vec![None; hits];
    for l in 1..hits {
        for k in 0..l {
            if duplicate_of[k].is_some() || data[k][0].values.len() != data[l][0].values.len() {
                continue;
            }
            if !prints[k]
                .iter()
                .zip(&prints[l])
                .all(|(a, b)| a.may_match(b, settings.duplicate_tolerance))
            {
                continue;
            }
            if let Some(share) = same_data(&data[k], &data[l], settings.duplicate_tolerance) {
                duplicate_of[l] = Some(k);
                let how = if share == 0.0 {
                    "identical samples".to_string()
                } else {
                    format!("differs by {} of the signal energy", sig(share, 2))
                };
                flag(
                    &mut out,
                    l,
                    None,
                    Inconsistency::Duplicate,
                    format!(
                        "the same data as {} ({how}); a record given twice adds no information and makes error bars too small",
                        c.labels[k]
                    ),
                );
                break;
            }
        }
    }

    if hits < settings.min_hits {
        if hits > 1 {
            out.notes.push(format!(
                "{hits} hits: level, spectrum and residual comparisons across hits need at least {}",
                settings.min_hits
            ));
        }
        sort_flags(&mut out);
        return out;
    }
    // Hits left out of the medians: duplicates count once.
    let distinct: Vec<usize> = (0..hits).filter(|&k| duplicate_of[k].is_none()).collect();

    // Levels: inputs on their own, outputs per unit of the hit's first
    // input (hammer strength varies from hit to hit; the transfer does not).
    let levels: Vec<Vec<f64>> = data
        .iter()
        .map(|sig| sig.iter().map(|s| rms_about_mean(&s.values)).collect())
        .collect();
    let n_in = c.inputs.len();
    let mut level_flagged = vec![false; hits];
    for j in 0..channels {
        let input = j < n_in;
        let value = |k: usize| -> Option<f64> {
            if !usable(k, j) || spiked[k][j] {
                return None;
            }
            if input || n_in == 0 {
                return Some(levels[k][j]);
            }
            // The first input normalizes; unusable if it is itself odd.
            (usable(k, 0) && !level_flagged[k] && levels[k][0] > 0.0)
                .then(|| levels[k][j] / levels[k][0])
        };
        let values: Vec<Option<f64>> = (0..hits).map(value).collect();
        let pool: Vec<f64> = distinct.iter().filter_map(|&k| values[k]).collect();
        if pool.len() < settings.min_hits {
            continue;
        }
        let med = median(&pool);
        if med <= 0.0 {
            continue;
        }
        // Records of different lengths: a level of its own (not per unit of
        // force) is an RMS, which is the right measure for a stationary
        // (shaker) signal but falls as 1/sqrt(N) for a transient of fixed
        // energy (a hammer pulse, a free decay) in a longer record. Such a
        // level is flagged only when its root energy is off the median too:
        // like is compared with like whatever the excitation. Outputs per
        // unit of force are ratios of two levels of one record, where the
        // length cancels. With equal lengths both measures agree.
        let own_level = input || n_in == 0;
        let root_energy = |k: usize| values[k].map(|v| v * (data[k][j].values.len() as f64).sqrt());
        let energy_med = if own_level {
            median(
                &distinct
                    .iter()
                    .filter_map(|&k| root_energy(k))
                    .collect::<Vec<_>>(),
            )
        } else {
            0.0
        };
        let within =
            |ratio: f64| ratio <= settings.level_factor && ratio >= 1.0 / settings.level_factor;
        for k in 0..hits {
            let Some(v) = values[k] else { continue };
            let ratio = v / med;
            if within(ratio) {
                continue;
            }
            if own_level
                && energy_med > 0.0
                && root_energy(k).is_some_and(|e| within(e / energy_med))
            {
                continue;
            }
            let s = &data[k][j];
            if input {
                level_flagged[k] = true;
            }
            let what = if input || n_in == 0 {
                "RMS level".to_string()
            } else {
                format!("RMS level per unit of {}", c.inputs[0])
            };
            let db = 20.0 * ratio.log10();
            let mut message = format!(
                "{what} {} dB {} the median of the {} hits (limit {} dB)",
                sig(db.abs(), 3),
                if db > 0.0 { "above" } else { "below" },
                pool.len(),
                sig(20.0 * settings.level_factor.log10(), 3),
            );
            let mut kind = Inconsistency::Level;
            if ratio > 1.0 {
                // Is it one sample? Then say where.
                let base = median(&s.values);
                let (p, peak) = argmax_abs(&s.values, base);
                let rest = max_abs_outside(&s.values, base, p, SPIKE_GUARD);
                if peak > settings.spike_factor * rest {
                    kind = Inconsistency::Spike;
                    message = format!(
                        "{} holds {}, {}x the largest other sample of the channel; {message}",
                        locate.sample(k, s.name, p),
                        sig(s.values[p], 4),
                        sig(peak / rest.max(f64::MIN_POSITIVE), 3),
                    );
                }
            } else {
                message.push_str(" (a dead, disconnected or mis-ranged sensor?)");
            }
            flag(&mut out, k, Some(s.name), kind, message);
        }
    }

    // Offsets: mean over RMS about the mean, against the campaign.
    for j in 0..channels {
        let ratio: Vec<Option<f64>> = (0..hits)
            .map(|k| {
                let x = &data[k][j].values;
                (usable(k, j) && !spiked[k][j] && levels[k][j] > 0.0)
                    .then(|| mean(x).abs() / levels[k][j])
            })
            .collect();
        let pool: Vec<f64> = distinct.iter().filter_map(|&k| ratio[k]).collect();
        if pool.len() < settings.min_hits {
            continue;
        }
        let med = median(&pool);
        for k in 0..hits {
            let Some(r) = ratio[k] else { continue };
            if r > settings.offset_floor && r > settings.offset_factor * med {
                let s = &data[k][j];
                flag(
                    &mut out,
                    k,
                    Some(s.name),
                    Inconsistency::Offset,
                    format!(
                        "mean {} is {} times the channel's RMS about it, against a median {} over the {} hits (limits {} and {}x): a DC offset or drift the other hits do not have",
                        sig(mean(&s.values), 4),
                        sig(r, 3),
                        sig(med, 3),
                        pool.len(),
                        sig(settings.offset_floor, 3),
                        sig(settings.offset_factor, 3)
                    ),
                );
            }
        }
    }

    // Spectra: share of each channel's energy per octave band.
    let bands = settings.spectrum_bands;
    // Hits in parallel, each with its own numbers (a planner per job: the same transforms).
    let shares: Vec<Vec<Option<Vec<f64>>>> = (0..hits)
        .into_par_iter()
        .map_init(FftPlanner::<f64>::new, |planner, k| {
            (0..channels)
                .map(|j| {
                    (usable(k, j) && !spiked[k][j])
                        .then(|| band_shares(&data[k][j].values, bands, planner))
                        .flatten()
                })
                .collect()
        })
        .collect();
    let already = |out: &Consistency, k: usize| out.flags.iter().any(|f| f.record == k);
    for j in 0..channels {
        let pool: Vec<&Vec<f64>> = distinct
            .iter()
            .filter_map(|&k| shares[k][j].as_ref())
            .collect();
        if pool.len() < settings.min_hits {
            continue;
        }
        let med: Vec<f64> = (0..=bands)
            .map(|b| median(&pool.iter().map(|p| p[b]).collect::<Vec<_>>()))
            .collect();
        for k in 0..hits {
            if already(&out, k) {
                continue;
            }
            let Some(p) = &shares[k][j] else { continue };
            let worst = (0..=bands)
                .filter(|&b| p[b].max(med[b]) >= settings.spectrum_min_share)
                .map(|b| (b, (p[b].max(1e-300) / med[b].max(1e-300)).ln().abs()))
                .max_by(|a, b| a.1.total_cmp(&b.1));
            if let Some((b, lr)) = worst
                && lr > settings.spectrum_factor.ln()
            {
                let nyquist = 0.5 / c.dt_s;
                let hi = nyquist / 2f64.powi((bands - b) as i32);
                let lo = if b == 0 { 0.0 } else { hi / 2.0 };
                flag(
                    &mut out,
                    k,
                    Some(data[k][j].name),
                    Inconsistency::Spectrum,
                    format!(
                        "{}-{} Hz holds {} % of the channel's energy against a median {} % over the hits (limit a factor {})",
                        sig(lo, 3),
                        sig(hi, 3),
                        sig(100.0 * p[b], 3),
                        sig(100.0 * med[b], 3),
                        sig(settings.spectrum_factor, 3)
                    ),
                );
            }
        }
    }
    sort_flags(&mut out);
    out
}

fn sort_flags(out: &mut Consistency) {
    out.flags.sort_by_key(|f| f.record);
}

fn mean(x: &[f64]) -> f64 {
    if x.is_empty() {
        0.0
    } else {
        x.iter().sum::<f64>() / x.len() as f64
    }
}

fn rms_about_mean(x: &[f64]) -> f64 {
    if x.is_empty() {
        return 0.0;
    }
    let m = mean(x);
    (x.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / x.len() as f64).sqrt()
}

/// Median (the mean of the middle two for even length; 0 for an empty
/// slice).
pub fn median(x: &[f64]) -> f64 {
    let n = x.len();
    if n == 0 {
        return 0.0;
    }
    let mut v = x.to_vec();
    let (_, &mut hi, _) = v.select_nth_unstable_by(n / 2, f64::total_cmp);
    if n % 2 == 1 {
        hi
    } else {
        // The largest of the lower half.
        let lo = v[..n / 2].iter().copied().fold(f64::NEG_INFINITY, f64::max);
        0.5 * (lo + hi)
    }
}

/// Index and size of the largest deviation from `base`.
fn argmax_abs(x: &[f64], base: f64) -> (usize, f64) {
    x.iter()
        .enumerate()
        .map(|(i, v)| (i, (v - base).abs()))
        .fold((0, 0.0), |a, b| if b.1 > a.1 { b } else { a })
}

/// Largest deviation from `base` more than `guard` samples from `at`.
fn max_abs_outside(x: &[f64], base: f64, at: usize, guard: usize) -> f64 {
    x.iter()
        .enumerate()
        .filter(|(i, _)| i.abs_diff(at) > guard)
        .map(|(_, v)| (v - base).abs())
        .fold(0.0, f64::max)
}

struct Spike {
    sample: usize,
    value: f64,
    ratio: f64,
    rest: f64,
}

impl Spike {
    fn describe(&self, place: &str) -> String {
        format!(
            "{place} holds {}, {}x the largest sample more than {SPIKE_GUARD} samples away ({}): a single wild sample (transmission error, sensor glitch)",
            sig(self.value, 4),
            sig(self.ratio, 3),
            sig(self.rest, 3)
        )
    }
}

/// A sample `factor` times larger than the rest of the channel.
fn spike(x: &[f64], factor: f64) -> Option<Spike> {
    if x.len() <= 2 * SPIKE_GUARD + 1 {
        return None;
    }
    let base = median(x);
    let (p, peak) = argmax_abs(x, base);
    let rest = max_abs_outside(x, base, p, SPIKE_GUARD);
    (peak > factor * rest && peak > 0.0).then(|| Spike {
        sample: p,
        value: x[p],
        ratio: if rest > 0.0 {
            peak / rest
        } else {
            f64::INFINITY
        },
        rest,
    })
}

/// `(x.y, x.x, y.y)`.
fn dots(x: &[f64], y: &[f64]) -> (f64, f64, f64) {
    x.iter().zip(y).fold((0.0, 0.0, 0.0), |(a, b, c), (u, v)| {
        (a + u * v, b + u * u, c + v * v)
    })
}

/// What two channels must share to be the same data: the place of the
/// largest sample and, nearly, the energy.
struct Fingerprint {
    /// Index of the largest absolute sample.
    peak: usize,
    /// `sqrt(sum x^2)`.
    norm: f64,
}

impl Fingerprint {
    fn of(x: &[f64]) -> Self {
        Self {
            peak: argmax_abs(x, 0.0).0,
            norm: x.iter().map(|v| v * v).sum::<f64>().sqrt(),
        }
    }

    /// False when `self` (channel `x`) and `other` (`y`) cannot differ by at
    /// most `tol` of the energy of `x`: `|x - y|^2 <= tol |x|^2` needs the
    /// same largest sample and `||x| - |y|| <= |x - y| <= sqrt(tol) |x|`.
    /// The norm test keeps a margin of 1 % plus 1e-9 of the larger norm,
    /// far above the rounding of two sums of squares (about 1e-13 relative
    /// for records of 10^6 samples), so a pair [`same_data`] would accept is
    /// never skipped. Non-finite norms never skip (`same_data` decides).
    fn may_match(&self, other: &Fingerprint, tol: f64) -> bool {
        if self.peak != other.peak {
            return false;
        }
        let gap = (self.norm - other.norm).abs();
        let bound = 1.01 * tol.sqrt() * self.norm + 1e-9 * self.norm.max(other.norm);
        // A NaN on either side compares as "may match".
        gap.partial_cmp(&bound) != Some(std::cmp::Ordering::Greater)
    }
}

/// Largest share of difference energy over the channels if every channel
/// of `a` and `b` differs by at most `tol` of its energy (callers test the
/// channels' [`Fingerprint`]s first).
fn same_data(a: &[Signal<'_>], b: &[Signal<'_>], tol: f64) -> Option<f64> {
    let mut worst: f64 = 0.0;
    for (x, y) in a.iter().zip(b) {
        let (mut d, mut e) = (0.0, 0.0);
        for (u, v) in x.values.iter().zip(&y.values) {
            d += (u - v) * (u - v);
            e += u * u;
        }
        let share = if e > 0.0 {
            d / e
        } else if d == 0.0 {
            0.0
        } else {
            return None;
        };
        if share > tol {
            return None;
        }
        worst = worst.max(share);
    }
    Some(worst)
}

/// Share of the energy of `x` (mean removed) in `bands` octaves down from
/// the Nyquist frequency plus one band from 0 Hz up to the lowest octave
/// (index 0). `None` for a channel without energy.
fn band_shares(x: &[f64], bands: usize, planner: &mut FftPlanner<f64>) -> Option<Vec<f64>> {
    let n = x.len();
    if n < 4 {
        return None;
    }
    let m = mean(x);
    let mut buf: Vec<Complex<f64>> = x.iter().map(|v| Complex::new(v - m, 0.0)).collect();
    planner.plan_fft_forward(n).process(&mut buf);
    let half = n / 2;
    let mut e = vec![0.0; bands + 1];
    for (i, z) in buf.iter().enumerate().take(half + 1).skip(1) {
        // Fraction of the Nyquist frequency; octave b (1..=bands) covers
        // (2^-(bands-b+1), 2^-(bands-b)].
        let f = i as f64 / half as f64;
        let octave = (-f.log2()).floor().max(0.0) as usize;
        let b = bands.saturating_sub(octave);
        e[b] += z.norm_sqr();
    }
    let total: f64 = e.iter().sum();
    (total > 0.0).then(|| e.iter().map(|v| v / total).collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use ident::Record;
    use nalgebra::DMatrix;

    /// A damped oscillator's acceleration response to a short pulse at
    /// sample 20, and a second output at another floor, with deterministic
    /// pseudo-noise of relative size `noise` (different per hit `k`).
    fn hit(k: usize, n: usize, noise: f64) -> Record {
        let dt = 0.002;
        let (w1, w2, z) = (
            2.0 * std::f64::consts::PI * 5.0,
            2.0 * std::f64::consts::PI * 13.0,
            0.02,
        );
        let amp = 1.0 + 0.3 * ((k as f64) * 1.7).sin();
        let mut u = vec![0.0; n];
        for i in 20..24 {
            u[i] = amp * 100.0 * ((i - 19) as f64 * std::f64::consts::PI / 5.0).sin();
        }
        let mut y1 = vec![0.0; n];
        let mut y2 = vec![0.0; n];
        let mut seed = 12345u64 + 977 * k as u64;
        let mut rnd = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((seed >> 11) as f64 / (1u64 << 53) as f64) - 0.5
        };
        for i in 20..n {
            let t = (i - 20) as f64 * dt;
            let r1 = (-z * w1 * t).exp() * (w1 * t).cos();
            let r2 = (-z * w2 * t).exp() * (w2 * t).cos();
            y1[i] = amp * (r1 + 0.5 * r2);
            y2[i] = amp * (1.6 * r1 - 0.3 * r2);
        }
        for v in y1.iter_mut().chain(y2.iter_mut()) {
            *v += noise * rnd();
        }
        for v in u.iter_mut() {
            *v += 100.0 * noise * rnd();
        }
        Record::new(
            DMatrix::from_row_slice(1, n, &u),
            DMatrix::from_fn(2, n, |r, i| if r == 0 { y1[i] } else { y2[i] }),
        )
    }

    fn campaign(hits: usize) -> Campaign {
        let records = (0..hits).map(|k| hit(k, 1024, 1e-3)).collect();
        Campaign::named(
            records,
            0.002,
            vec!["force".into()],
            vec!["acc1".into(), "acc2".into()],
            (1..=hits).map(|k| format!("hit{k:02}.csv")).collect(),
        )
    }

    fn check(c: &Campaign) -> Consistency {
        check_consistency(c, &ByPosition, &ConsistencySettings::default())
    }

    #[test]
    fn clean_campaign_has_no_flags() {
        let r = check(&campaign(6));
        assert!(r.flags.is_empty(), "{:#?}", r.flags);
        assert!(r.notes.is_empty(), "{:?}", r.notes);
    }

    #[test]
    fn dead_channel_in_one_hit() {
        let mut c = campaign(6);
        c.records[2].outputs.row_mut(1).fill(0.0);
        let r = check(&c);
        assert_eq!(r.flagged_records(), [2]);
        assert_eq!(r.flags[0].kind, Inconsistency::DeadChannel);
        assert_eq!(r.flags[0].channel.as_deref(), Some("acc2"));
        assert!(
            r.flags[0]
                .to_string()
                .starts_with("hit03.csv: channel acc2: dead channel")
        );
    }

    #[test]
    fn quiet_channel_is_a_level_flag() {
        // An unplugged sensor reads noise, not zeros: caught by its level.
        let mut c = campaign(6);
        let n = c.records[4].len();
        for i in 0..n {
            c.records[4].outputs[(0, i)] *= 1e-3;
        }
        let r = check(&c);
        assert_eq!(r.flagged_records(), [4]);
        assert_eq!(r.flags[0].kind, Inconsistency::Level);
        assert!(
            r.flags[0].message.contains("60.0 dB below"),
            "{}",
            r.flags[0]
        );
    }

    /// Hits of very different lengths: a transient's RMS falls with the
    /// record's length (1024 against 204800 samples: 23 dB), its energy
    /// does not; no level flag. A quiet force in a hit of the usual length
    /// is still one.
    #[test]
    fn hits_of_different_lengths_are_compared_by_energy_too() {
        let mut c = campaign(6);
        c.records[2] = hit(2, 200 * 1024, 1e-6);
        let r = check(&c);
        assert!(
            !r.flags.iter().any(|f| f.kind == Inconsistency::Level),
            "{:#?}",
            r.flags
        );
        c.records[4].inputs.scale_mut(1e-2);
        let r = check(&c);
        assert_eq!(r.flagged_records(), [4], "{:#?}", r.flags);
        assert_eq!(r.flags[0].kind, Inconsistency::Level);
    }

    #[test]
    fn copied_force_column() {
        let mut c = campaign(6);
        let f = c.records[1].inputs.row(0).clone_owned();
        c.records[1].outputs.row_mut(0).copy_from(&f);
        let r = check(&c);
        assert_eq!(r.flagged_records(), [1]);
        assert!(
            r.flags
                .iter()
                .any(|f| f.kind == Inconsistency::CopiedChannel
                    && f.channel.as_deref() == Some("acc1")
                    && f.message.contains("equals force"))
        );
    }

    #[test]
    fn duplicate_records_whatever_the_names() {
        let mut c = campaign(5);
        c.records[3] = c.records[0].clone();
        c.records[4] = c.records[0].clone();
        let r = check(&c);
        assert_eq!(r.flagged_records(), [3, 4]);
        assert!(r.flags.iter().all(|f| f.kind == Inconsistency::Duplicate
            && f.message.contains("hit01.csv")
            && f.message.contains("identical samples")));
    }

    #[test]
    fn near_duplicates_pass_the_fingerprint_and_rescaled_copies_do_not() {
        // A copy scaled by 1 + 5e-5 differs by 2.5e-9 of the energy, under
        // the default tolerance 1e-8: still the same data. Scaled by
        // 1 + 2e-4 it differs by 4e-8: not a duplicate (and its norm alone
        // tells, the fingerprint skips the sample comparison).
        let mut c = campaign(5);
        c.records[3] = c.records[0].clone();
        c.records[3].outputs *= 1.0 + 5e-5;
        c.records[3].inputs *= 1.0 + 5e-5;
        c.records[4] = c.records[0].clone();
        c.records[4].outputs *= 1.0 + 2e-4;
        c.records[4].inputs *= 1.0 + 2e-4;
        let r = check(&c);
        let dups: Vec<usize> = r
            .flags
            .iter()
            .filter(|f| f.kind == Inconsistency::Duplicate)
            .map(|f| f.record)
            .collect();
        assert_eq!(dups, [3], "{:#?}", r.flags);
        let x: Vec<f64> = (0..100).map(|i| (i as f64 * 0.37).sin()).collect();
        let tol: f64 = 1e-8;
        let a = Fingerprint::of(&x);
        let y: Vec<f64> = x.iter().map(|v| v * (1.0 + 0.99 * tol.sqrt())).collect();
        assert!(a.may_match(&Fingerprint::of(&y), tol));
        let z: Vec<f64> = x.iter().map(|v| v * (1.0 + 1.1 * tol.sqrt())).collect();
        assert!(!a.may_match(&Fingerprint::of(&z), tol));
    }

    #[test]
    fn spike_in_an_output_is_named_by_line() {
        let mut c = campaign(6);
        c.records[5].outputs[(0, 700)] = 1e30;
        let r = check(&c);
        assert_eq!(r.flagged_records(), [5]);
        assert_eq!(r.flags[0].kind, Inconsistency::Spike);
        assert!(
            r.flags[0].message.contains("sample #701 holds 1e+30")
                || r.flags[0].message.contains("sample #701 holds 1.000e30"),
            "{}",
            r.flags[0]
        );
    }

    #[test]
    fn flags_are_the_same_for_any_thread_count() {
        // Spikes, a quiet channel and a hum in different hits: the per-hit searches run in
        // parallel, the flags are written in hit order, the same on 1 and 3 threads.
        let mut c = campaign(8);
        c.records[5].outputs[(0, 700)] = 1e30;
        c.records[3].inputs[(0, 500)] = 1e12;
        for i in 0..c.records[1].len() {
            c.records[1].outputs[(0, i)] *= 1e-3;
            c.records[6].outputs[(1, i)] += 0.3 * (i as f64 * 0.61).sin();
        }
        let on = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| format!("{:?}", check(&c)))
        };
        let one = on(1);
        assert!(one.contains("Spike") && one.contains("Level"), "{one}");
        assert_eq!(one, on(3));
    }

    #[test]
    fn force_spike_is_told_from_the_hit_by_the_other_hits() {
        let mut c = campaign(6);
        c.records[3].inputs[(0, 500)] = 1e12;
        let r = check(&c);
        assert_eq!(r.flagged_records(), [3], "{:#?}", r.flags);
        assert_eq!(r.flags[0].kind, Inconsistency::Spike);
        assert_eq!(r.flags[0].channel.as_deref(), Some("force"));
        assert!(r.flags[0].message.contains("sample #501"), "{}", r.flags[0]);
    }

    #[test]
    fn a_hum_in_one_hit_is_a_spectrum_flag() {
        let mut c = campaign(6);
        let n = c.records[2].len();
        for i in 0..n {
            // 200 Hz hum at a third of the response's peak: a quarter of
            // the channel's energy in an octave that holds almost none.
            c.records[2].outputs[(1, i)] +=
                0.5 * (2.0 * std::f64::consts::PI * 200.0 * i as f64 * 0.002).sin();
        }
        let r = check(&c);
        assert_eq!(r.flagged_records(), [2], "{:#?}", r.flags);
        assert_eq!(r.flags[0].kind, Inconsistency::Spectrum);
    }

    #[test]
    fn two_hits_cannot_be_compared_and_say_so() {
        let mut c = campaign(2);
        for i in 0..c.records[1].len() {
            c.records[1].outputs[(0, i)] *= 1e-3;
        }
        let r = check(&c);
        assert!(r.flags.is_empty());
        assert!(r.notes[0].contains("need at least 3"), "{:?}", r.notes);
    }

    #[test]
    fn nan_is_flagged() {
        let mut c = campaign(3);
        c.records[0].outputs[(1, 9)] = f64::NAN;
        let r = check(&c);
        assert_eq!(r.flagged_records(), [0]);
        assert_eq!(r.flags[0].kind, Inconsistency::NonFinite);
        assert!(r.flags[0].message.contains("sample #10 holds NaN"));
    }

    #[test]
    fn sample_lines_map_values_to_lines() {
        use crate::record::SampleLines;
        let rows = SampleLines::Rows { first_line: 3 };
        assert_eq!(rows.line_of(0), Some(3));
        assert_eq!(rows.line_of(10), Some(13));
        // Four values per line from line 20; uneven pairs (x, y).
        let starts: Vec<(usize, usize)> = (0..5).map(|l| (4 * l, 20 + l)).collect();
        let even = SampleLines::Values {
            starts: starts.clone(),
            stride: 1,
            offset: 0,
        };
        assert_eq!(even.line_of(0), Some(20));
        assert_eq!(even.line_of(7), Some(21));
        let pairs = SampleLines::Values {
            starts,
            stride: 2,
            offset: 1,
        };
        // Sample 2 is value 5: second line.
        assert_eq!(pairs.line_of(2), Some(21));
    }
}
