//! Hit quality checks, run on the loaded records before identification.
//!
//! A hammer campaign is only as good as its worst hits. Every hit (record)
//! is checked on its own, with thresholds that follow from what a hammer
//! force and a free-decay response look like after a spectrum analyzer:
//!
//! | check | metric | flagged when (default) |
//! |---|---|---|
//! | no hit | force peak over its robust noise level | below 20 dB (fatal: the record cannot be used) |
//! | double hit | second force pulse over the main one, smoothed | ratio >= 0.1 |
//! | clipping | samples equal to a channel's extreme, or at a declared ADC range | 2 samples (in a row or not) |
//! | pulse too long | fall of the force spectrum over the analysis band | more than 12 dB |
//! | response not decayed | RMS of the last 10 % of an output over its peak | above 0.05 (and above the noise) |
//! | pre-trigger too short | noise samples before the hit (after a guard) | fewer than 8 (a note: the hit is not failed) |
//! | low SNR | signal RMS over pre-trigger noise RMS, per channel | below 20 dB |
//!
//! The reasoning behind each threshold is next to its default in
//! [`QualitySettings`]. Everything here is a pure function of the samples:
//! [`assess_hit`] for one record, [`assess_campaign`] for a loaded campaign.
//! The results serialize to JSON (`hit_quality` in `frameid identify --json`)
//! and carry the numbers an HTML report needs.

use rayon::prelude::*;
use std::borrow::Cow;
use std::fmt;

use ident::{Campaign, Record};
use serde::{Deserialize, Serialize};

/// Thresholds of the checks. `QualitySettings::default()` is what
/// `frameid identify` uses.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct QualitySettings {
    /// What excites the records: a hammer, a shaker (continuous: random,
    /// burst random, chirp, swept sine), or `auto` (judged per record from
    /// the force, see [`QualitySettings::min_hammer_crest`]).
    pub excitation: Excitation,
    /// `auto` takes a record for a hammer record when its force peaks at
    /// least this many times its RMS about the median (the crest factor),
    /// and at least [`QualitySettings::min_hit_peak_to_noise`] times its
    /// noise: 8. A hammer pulse of w samples in N has a crest factor near
    /// `sqrt(N / w)` (26 for 3 of 2048 samples, 9 at 20 dB peak-to-noise);
    /// Gaussian random force peaks at 3.5-4.5 RMS over a few thousand
    /// samples, burst random (half the record) near 6, a chirp near 1.5.
    /// Short records with long pulses (a pulse over 1/64 of the record) need
    /// `--excitation hammer`.
    pub min_hammer_crest: f64,
    /// Continuous records: an output whose ordinary coherence with the
    /// force, averaged over the lines the force excites (see
    /// [`mean_coherence`]), is below this fails the record: 0.5, where
    /// noise or an unmeasured input carries as much of the output power as
    /// the force. Not higher: with Welch segments of an eighth of the
    /// record, the leakage of lightly damped modes alone lowers the
    /// averaged coherence of clean simulated shaker records to 0.86-0.93
    /// (paper case 1, 0.25-0.5 % damping, 1 % noise, 1-24 Hz force at
    /// 64 Hz: random, burst random and chirp; 0.81-0.86 when the unexcited
    /// lines were averaged too).
    pub min_coherence: f64,
    /// A hit whose force peak is less than this many robust noise standard
    /// deviations above the record's median is not a hit. Gaussian noise
    /// alone peaks at about 4 sigma in a few thousand samples, so 10 (20 dB)
    /// never mistakes noise for a hit, and a real pulse that weak would
    /// carry less energy than the noise over a few tens of samples.
    pub min_hit_peak_to_noise: f64,
    /// Double hit: a second force pulse whose (smoothed) height is at least
    /// this fraction of the main pulse. The force is smoothed with the
    /// three-tap filter `[1, 2, 1] / 4` first: it keeps the area of a pulse
    /// but has a zero at the Nyquist frequency, and the ringing of an
    /// analyzer's decimation filter (up to 5 % of the peak for several
    /// samples, measured on the simulator's 100 dB Kaiser FIR) sits in the
    /// transition band between fs/2.56 and fs/2, where the smoother's gain
    /// is 0.1 down to 0: after smoothing the ringing stays at about 1 % of
    /// the pulse (1.3 % at most on the bundled scenarios). A second pulse
    /// of 0.1 makes the force spectrum ripple by +-0.8 dB
    /// (20 log10 (1 + r)), where the spectrum visibly departs from a single
    /// pulse's, and is about ten times the residual ringing, so clean
    /// pulses raise no false alarms.
    pub double_hit_ratio: f64,
    /// A second pulse counts only if the smoothed force dips, between it
    /// and the main pulse, to this fraction of the second pulse's height or
    /// lower: two pulses rather than a shoulder on one long pulse (whose
    /// spectrum `max_force_drop_db` checks). At 0.8, two pulses 3.5 samples
    /// apart or more are resolved at the analysis rate.
    pub double_hit_valley: f64,
    /// Clipping: this many samples equal to a channel's extreme value,
    /// in a row (a flat top) or not (several flat-topped peaks). A
    /// band-limited or noisy signal never repeats its extreme exactly: the
    /// top of a 25 Hz sine sampled at 64 Hz changes by tens of percent
    /// between samples, a 2.7 Hz one by 3.5 %, and a decaying response's
    /// next peak is lower by far more than an ADC step. An overloaded ADC
    /// returns its full-scale code for as long as the overload lasts. A
    /// single clipped sample (a one-sample force peak cut short) cannot be
    /// told from a clean one: declare the ranges to catch it. Records
    /// sampled a thousand times faster than their modes and coarsely
    /// quantized may repeat their extreme legitimately: raise this for them.
    pub clip_samples: usize,
    /// Declared input range of the force channel(s), N, if known: a sample
    /// at or beyond it is clipped.
    pub force_range: Option<f64>,
    /// Declared input range of the acceleration channels, m/s^2, if known.
    pub acceleration_range: Option<f64>,
    /// Upper edge of the analysis band, Hz. Default: fs / 2.56, the span of
    /// a spectrum analyzer (the band its anti-alias filter leaves flat).
    pub band_hz: Option<f64>,
    /// Largest allowed fall of the force spectrum over the analysis band,
    /// dB. The rule of thumb in impact testing is that the force spectrum
    /// should not fall by more than 10 to 20 dB over the frequency range of
    /// interest, or the upper modes are barely excited and drown in noise.
    /// 12 dB (a quarter of the low-frequency amplitude) is at the strict end
    /// of that range but clears what a short hit can look like at the
    /// analysis rate: an impulse held over two samples in equal parts
    /// (a contact straddling a sample boundary) falls 9.4 dB at fs/2.56.
    /// A half-sine pulse of duration T falls 12 dB at f T = 1.1.
    pub max_force_drop_db: f64,
    /// Part of each output at the end of the record used for the decay
    /// check (the last 10 %).
    pub tail_fraction: f64,
    /// Largest allowed RMS of an output's tail over its peak. At 0.05
    /// (-26 dB) the response still oscillates with about 7 % of its peak
    /// amplitude when the record ends: an FFT of the record leaks, and the
    /// record holds less of the decay than its length suggests. OKID itself
    /// works in the time domain and tolerates truncation, so this is a
    /// warning about the set-up (record length, exponential window). The
    /// paper's frame (damping 0.25-0.54 %) decays to 0.01 in 32 s.
    pub max_tail_ratio: f64,
    /// The tail counts as undecayed only if its RMS is also this many times
    /// the pre-trigger noise RMS: a tail in the noise has decayed.
    pub tail_noise_factor: f64,
    /// Samples just before the hit (the force peak) left out of the noise
    /// estimate. An analyzer's linear-phase decimation filter starts the
    /// band-limited pulse before the hit: the simulator's 100 dB FIR puts
    /// 1-4 % of the peak into the 12 samples before it and about 0.1 % or
    /// less more than 20 samples before it. A guard of 20 keeps that precursor out of
    /// the noise estimate.
    pub noise_guard_samples: usize,
    /// Fewest noise samples for an estimate: the RMS of n Gaussian samples
    /// has a relative standard deviation of about 1 / sqrt(2 n), 25 %
    /// (2 dB) at 8 samples.
    pub min_noise_samples: usize,
    /// Hammer records: fewest samples between the record's start and the
    /// force peak. An analyzer's anti-alias filter starts the band-limited
    /// pulse before its peak (see [`QualitySettings::noise_guard_samples`]),
    /// and the identification takes the structure at rest, without force,
    /// before the first sample: a record that starts inside the pulse has
    /// lost part of the force that moved the structure. Measured on paper
    /// case 1 (seed 1, 10 analyzer hits, 1 % noise) with every record cut
    /// to start `k` samples before its force peak: M off by 3000x at
    /// `k = 0`, 54 % at 1, 8.4 % at 5, 0.34 % at 8, 0.27 % at 10, 0.24 % at
    /// 12; from 13 on as uncut (0.063 % at 13, 0.072 % at 14, 0.056 % at 15,
    /// 0.055 % at 16, 0.054 % at 20; uncut 0.063 %). 16 leaves three
    /// samples of margin for filters with a longer precursor than the
    /// simulator's; a pre-trigger of 16 samples or more passes. Such a
    /// hit is unusable ([`Check::is_fatal`]): the campaign is refused
    /// unless it is dropped. Held (zero-order-hold) records have no
    /// precursor and may start at the hit (`k = 0` gave M within 1.7e-4 on
    /// the held campaign of seed 101): the analysis sets this to 0 for them
    /// (`--intersample zoh`); 0 disables the check.
    pub min_samples_before_hit: usize,
    /// Smallest acceptable SNR, dB: signal RMS (from the end of the noise
    /// window to the end of the record) over pre-trigger noise RMS, per
    /// channel. Below 20 dB the noise RMS exceeds a tenth of the signal's;
    /// in the simulator's paper case 1, 10 % noise (20 dB) already biases
    /// the identified stiffness by about 1 % over 10 hits.
    pub min_snr_db: f64,
    /// Continuous records: an octave band whose SNR, from the coherence of
    /// an output with the force (`gamma^2 / (1 - gamma^2)`, the power the
    /// force explains over the rest), is below this is marked low in
    /// [`HitQuality::snr_bands`] (a finding, not a failed check), dB: 0, where
    /// noise and unmeasured inputs carry as much of the output as the force
    /// (coherence 0.5, the band-averaged limit of
    /// [`QualitySettings::min_coherence`]). Not a failure: the coherence of
    /// lightly damped modes is lowered by the leakage of Welch segments too
    /// (clean simulated random-shaker records of paper case 1 at 1 % noise,
    /// 32 s: 3-8 dB in the octaves holding the modes at 2.7 and 9.2 Hz,
    /// 25-28 dB at 11-23 Hz, and 0 to -3 dB at 0.7-1.4 Hz, below the
    /// first mode, where the accelerations are weak against the noise).
    pub min_band_snr_db: f64,
    /// Continuous records: outputs whose RMS before the excitation starts
    /// (the pre-trigger, after the guard) exceeds this fraction of their
    /// RMS over the record are not at rest when the record starts: 0.1
    /// (-20 dB, the limit of [`QualitySettings::min_snr_db`]: a structure at
    /// rest shows only noise there, 0.01-0.02 at 1 % noise).
    pub max_initial_motion: f64,
    /// Hammer records: a channel's baseline (its mean) that moves between
    /// the pre-trigger and the record's tail (the last
    /// [`QualitySettings::tail_fraction`]) by more than this many standard
    /// errors of the two means is a drift: 8. The standard errors come from
    /// the scatter in the two windows (white-noise formula); 8 keeps
    /// coloured noise (its correlation raises the true error by a few
    /// times) and the response's remaining oscillation in the tail from
    /// being taken for a drift.
    pub drift_z: f64,
    /// ... and by more than this fraction of the channel's peak: 0.005. A
    /// move below it leaves M, K and the damping within the effect of the
    /// noise; 0.002 m/s^3 over 32 s (3 % of the peak of paper case 1's
    /// second floor) moves the damping by 49 % when left in.
    ///
    /// The same two limits judge the baseline's level: a pre-trigger mean
    /// more than `drift_z` of its standard errors and `drift_min_fraction`
    /// of the peak away from zero is a constant offset, removed like a
    /// drift. A hammer record starts at rest, where force and absolute
    /// acceleration are zero; left in, a force offset of 17 % of the
    /// pulse's peak in every hit of the three-storey frame moved M by
    /// 6-23 % (0.2 N against 0.02 N of noise: no other check sees it, as
    /// every hit has it).
    pub drift_min_fraction: f64,
}

impl Default for QualitySettings {
    fn default() -> Self {
        QualitySettings {
            excitation: Excitation::Auto,
            min_hammer_crest: 8.0,
            min_coherence: 0.5,
            min_hit_peak_to_noise: 10.0,
            double_hit_ratio: 0.1,
            double_hit_valley: 0.8,
            clip_samples: 2,
            force_range: None,
            acceleration_range: None,
            band_hz: None,
            max_force_drop_db: 12.0,
            tail_fraction: 0.1,
            max_tail_ratio: 0.05,
            tail_noise_factor: 2.0,
            noise_guard_samples: 20,
            min_noise_samples: 8,
            min_samples_before_hit: 16,
            min_snr_db: 20.0,
            min_band_snr_db: 0.0,
            max_initial_motion: 0.1,
            drift_z: 8.0,
            drift_min_fraction: 0.005,
        }
    }
}

impl QualitySettings {
    /// Checks the settings; the error names the field.
    pub fn check(&self) -> Result<(), String> {
        let positive = |name: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(format!("{name} must be a positive number, got {v}"))
            }
        };
        positive("min_hit_peak_to_noise", self.min_hit_peak_to_noise)?;
        positive("min_hammer_crest", self.min_hammer_crest)?;
        if !(self.min_coherence > 0.0 && self.min_coherence < 1.0) {
            return Err(format!(
                "min_coherence must be in (0, 1), got {}",
                self.min_coherence
            ));
        }
        positive("double_hit_ratio", self.double_hit_ratio)?;
        positive("double_hit_valley", self.double_hit_valley)?;
        positive("max_force_drop_db", self.max_force_drop_db)?;
        positive("max_tail_ratio", self.max_tail_ratio)?;
        positive("tail_noise_factor", self.tail_noise_factor)?;
        positive("max_initial_motion", self.max_initial_motion)?;
        positive("drift_z", self.drift_z)?;
        positive("drift_min_fraction", self.drift_min_fraction)?;
        if !self.min_band_snr_db.is_finite() {
            return Err(format!(
                "min_band_snr_db must be a finite number, got {}",
                self.min_band_snr_db
            ));
        }
        if !self.min_snr_db.is_finite() {
            return Err(format!(
                "min_snr_db must be a finite number, got {}",
                self.min_snr_db
            ));
        }
        if !(self.tail_fraction > 0.0 && self.tail_fraction <= 0.5) {
            return Err(format!(
                "tail_fraction must be in (0, 0.5], got {}",
                self.tail_fraction
            ));
        }
        for (name, v) in [
            ("force_range", self.force_range),
            ("acceleration_range", self.acceleration_range),
            ("band_hz", self.band_hz),
        ] {
            if let Some(v) = v {
                positive(name, v)?;
            }
        }
        if self.clip_samples < 2 {
            return Err(format!(
                "clip_samples must be at least 2, got {}",
                self.clip_samples
            ));
        }
        if self.min_noise_samples < 2 {
            return Err(format!(
                "min_noise_samples must be at least 2, got {}",
                self.min_noise_samples
            ));
        }
        Ok(())
    }
}

/// Fewest samples for `auto` to take a record for a continuous one: 256,
/// eight Welch segments of 32 samples (16 frequency bins) for the
/// coherence. Shorter records are judged hammer records.
pub const MIN_CONTINUOUS_SAMPLES: usize = 256;

/// What excites the records.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Excitation {
    /// Judged per record from the force's crest factor.
    #[default]
    Auto,
    /// An impact hammer: one pulse per record, free decay after it.
    Hammer,
    /// A shaker: random, burst random, chirp or swept sine.
    Continuous,
}

impl Excitation {
    /// The name as on the command line.
    pub fn label(self) -> &'static str {
        match self {
            Excitation::Auto => "auto",
            Excitation::Hammer => "hammer",
            Excitation::Continuous => "continuous",
        }
    }
}

impl std::str::FromStr for Excitation {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.trim().to_ascii_lowercase().as_str() {
            "auto" => Ok(Excitation::Auto),
            "hammer" => Ok(Excitation::Hammer),
            "continuous" | "shaker" => Ok(Excitation::Continuous),
            other => Err(format!(
                "unknown excitation '{other}': expected auto, hammer or continuous"
            )),
        }
    }
}

/// The checks, in the order they are reported.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Check {
    /// The force holds no hit: zero, or nothing above its noise.
    NoHit,
    /// A second force pulse after (or before) the main one.
    DoubleHit,
    /// A channel is clipped (ADC overload).
    Clipping,
    /// The force pulse is too long for the analysis band.
    LongPulse,
    /// An output has not decayed by the end of the record.
    NotDecayed,
    /// Too few samples before the hit to estimate the noise.
    ShortPretrigger,
    /// Hammer records: the force peaks so soon after the record starts
    /// that part of the band-limited pulse lies before the first sample
    /// ([`QualitySettings::min_samples_before_hit`]).
    LateStart,
    /// A channel's signal-to-noise ratio is low.
    LowSnr,
    /// Continuous excitation: an output's coherence with the force is low.
    LowCoherence,
    /// Continuous excitation: the outputs move before the excitation
    /// starts (the structure is not at rest). A note: the identification
    /// allows for an unknown initial state then.
    NotAtRest,
    /// Hammer records: a channel's baseline drifts linearly over the
    /// record; the line through the pre-trigger and the tail is removed
    /// before identification (see [`remove_drifts`]).
    Drift,
}

impl Check {
    /// A fatal check makes the record unusable: the campaign is refused
    /// unless the hit is dropped.
    pub fn is_fatal(self) -> bool {
        matches!(self, Check::NoHit | Check::LateStart)
    }

    /// Whether the check fails the hit (`--strict` refuses it,
    /// `--drop-bad-hits` drops it). A short pre-trigger only means the
    /// noise could not be measured; it is reported but fails nothing.
    pub fn fails_hit(self) -> bool {
        !matches!(
            self,
            Check::ShortPretrigger | Check::NotAtRest | Check::Drift
        )
    }

    /// Short name, as in messages.
    pub fn label(self) -> &'static str {
        match self {
            Check::NoHit => "no hit",
            Check::DoubleHit => "double hit",
            Check::Clipping => "clipping",
            Check::LongPulse => "force pulse too long",
            Check::NotDecayed => "response not decayed",
            Check::ShortPretrigger => "pre-trigger too short",
            Check::LateStart => "record starts in the hit",
            Check::LowSnr => "low SNR",
            Check::LowCoherence => "low coherence",
            Check::NotAtRest => "not at rest",
            Check::Drift => "drift removed",
        }
    }
}

impl fmt::Display for Check {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.label())
    }
}

/// One failed check of a hit.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Flag {
    /// The check that failed.
    pub check: Check,
    /// The channel concerned, if the check is per channel.
    pub channel: Option<String>,
    /// What was found, with the numbers and the threshold (without the
    /// file name).
    pub message: String,
}

impl fmt::Display for Flag {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.check, self.message)
    }
}

/// Whether a channel is an input (force) or an output (acceleration).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Role {
    /// A force channel.
    Input,
    /// An acceleration channel.
    Output,
}

/// Metrics of one channel of a hit.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ChannelQuality {
    /// The channel's name.
    pub name: String,
    /// Input (force) or output (acceleration).
    pub role: Role,
    /// Largest deviation from the baseline (the pre-trigger mean).
    pub peak: f64,
    /// RMS about the baseline from the end of the noise window to the end
    /// of the record.
    pub rms: f64,
    /// Pre-trigger noise RMS (null if the pre-trigger is too short).
    pub noise_rms: Option<f64>,
    /// `20 log10(rms / noise_rms)` (null without a noise estimate or for
    /// noise-free records).
    pub snr_db: Option<f64>,
    /// Longest run of consecutive samples at the channel's extreme value.
    pub clip_run: usize,
    /// Samples at the channel's extreme value.
    pub clip_samples: usize,
    /// Samples at or beyond the declared ADC range (0 if none declared).
    pub range_samples: usize,
    /// Outputs: RMS of the record's tail over the peak.
    pub tail_ratio: Option<f64>,
    /// Hammer records with a pre-trigger: the baseline line through the
    /// pre-trigger mean and the tail mean (null otherwise). In JSON only
    /// when it is a drift (flagged and removed).
    #[serde(skip_serializing_if = "not_a_drift")]
    pub drift: Option<Drift>,
}

/// A channel's baseline as a line over the record: the mean of the
/// pre-trigger (after the guard) at its centre and the mean of the tail (the
/// last [`QualitySettings::tail_fraction`]) at its centre. A hammer
/// response has decayed in the tail, so the two means differ only by noise
/// unless the baseline moves (a drifting charge amplifier or sensor), and
/// both are zero but for noise unless the channel has an offset. A
/// baseline that does not move but sits off zero is the constant
/// pre-trigger mean (`per_s` 0).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Drift {
    /// The line's value at the record's first sample, channel unit.
    pub start: f64,
    /// Its slope, channel unit per second.
    pub per_s: f64,
    /// The move between the two means over its standard error.
    pub z: f64,
    /// The move over the channel's peak.
    pub fraction_of_peak: f64,
    /// The pre-trigger mean over its standard error: how far the baseline
    /// sits from zero before the hit.
    pub offset_z: f64,
    /// The pre-trigger mean over the channel's peak (absolute value).
    pub offset_fraction_of_peak: f64,
    /// Whether the baseline moves or sits off zero by
    /// [`QualitySettings::drift_z`] and [`QualitySettings::drift_min_fraction`]
    /// (flagged and removed).
    pub significant: bool,
}

/// Metrics of the force pulse (the main input of the hit).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PulseQuality {
    /// Input channel the hit was found on.
    pub channel: String,
    /// Force peak over its robust noise level, dB (null if noise-free).
    pub peak_to_noise_db: Option<f64>,
    /// Height of the largest second pulse over the main one (smoothed
    /// force; 0 if there is none).
    pub double_hit_ratio: f64,
    /// Time from the main pulse to that second pulse, s (negative if it
    /// comes first).
    pub double_hit_delay_s: Option<f64>,
    /// Upper edge of the analysis band, Hz.
    pub band_hz: f64,
    /// Fall of the force amplitude spectrum over [0, band_hz], dB.
    pub spectrum_drop_db: f64,
    /// Duration of the half-sine pulse whose spectrum falls as much at the
    /// same frequency, s (an equivalent contact time).
    pub equivalent_duration_s: f64,
}

/// Quality of one hit.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct HitQuality {
    /// 1-based position in the campaign.
    pub hit: usize,
    /// The excitation the record was judged as (`hammer` or `continuous`).
    pub excitation: Excitation,
    /// Force peak over its RMS about the median (what `auto` decides on).
    pub crest_factor: f64,
    /// Continuous records: per output, the ordinary coherence with the
    /// force averaged over the band (empty for hammer records).
    pub coherence: Vec<f64>,
    /// Continuous records: per output, the SNR in octave bands from the
    /// coherence with the force (absent for hammer records).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub snr_bands: Vec<ChannelBandSnr>,
    /// Continuous records: the motion of the outputs before the excitation
    /// starts (absent for hammer records, whose pre-trigger the SNR check
    /// judges).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub initial_motion: Option<InitialMotion>,
    /// The record's label (its file).
    pub file: String,
    /// Sample of the force peak (0-based) and its time from the record
    /// start (null when there is no hit).
    pub hit_sample: Option<usize>,
    /// Time of the force peak from the record start, s (null when there
    /// is no hit).
    pub hit_time_s: Option<f64>,
    /// Samples used for the noise estimate (before the hit, minus the guard).
    pub noise_samples: usize,
    /// The force pulse (null when there is no hit).
    pub pulse: Option<PulseQuality>,
    /// Inputs, then outputs.
    pub channels: Vec<ChannelQuality>,
    /// Failed checks; empty for a good hit.
    pub flags: Vec<Flag>,
}

impl HitQuality {
    /// No check failed (notes such as a short pre-trigger do not count).
    pub fn passed(&self) -> bool {
        !self.flags.iter().any(|f| f.check.fails_hit())
    }

    /// A fatal check failed (the record cannot be identified).
    pub fn fatal(&self) -> bool {
        self.flags.iter().any(|f| f.check.is_fatal())
    }

    /// The distinct checks that failed the hit, in order.
    pub fn failed_checks(&self) -> Vec<Check> {
        let mut v: Vec<Check> = Vec::new();
        for f in &self.flags {
            if f.check.fails_hit() && !v.contains(&f.check) {
                v.push(f.check);
            }
        }
        v
    }

    /// Lowest SNR over the channels, dB.
    pub fn min_snr_db(&self) -> Option<f64> {
        self.channels
            .iter()
            .filter_map(|c| c.snr_db)
            .min_by(f64::total_cmp)
    }

    /// Largest tail ratio over the outputs.
    pub fn max_tail_ratio(&self) -> Option<f64> {
        self.channels
            .iter()
            .filter_map(|c| c.tail_ratio)
            .max_by(f64::total_cmp)
    }
}

/// Checks every hit of a campaign; `file` of each result is the record's
/// label.
pub fn assess_campaign(c: &Campaign, settings: &QualitySettings) -> Vec<HitQuality> {
    // Hits in parallel, each its own numbers.
    c.records
        .par_iter()
        .zip(&c.labels)
        .enumerate()
        .map(|(i, (rec, label))| {
            let mut q = assess_hit(rec, c.dt_s, &c.inputs, &c.outputs, settings);
            q.hit = i + 1;
            q.file = label.clone();
            q
        })
        .collect()
}

/// Checks one record sampled every `dt_s` seconds; `inputs` and `outputs`
/// name its channels (rows of `record.inputs` and `record.outputs`). The
/// result has `hit` 1 and an empty `file`; [`assess_campaign`] fills them.
///
/// Panics if the name lists do not match the record's channel counts.
pub fn assess_hit(
    record: &Record,
    dt_s: f64,
    inputs: &[String],
    outputs: &[String],
    settings: &QualitySettings,
) -> HitQuality {
    assert_eq!(inputs.len(), record.inputs.nrows(), "one name per input");
    assert_eq!(outputs.len(), record.outputs.nrows(), "one name per output");
    let n = record.len();
    let input_rows: Vec<Vec<f64>> = (0..inputs.len())
        .map(|i| record.inputs.row(i).iter().copied().collect())
        .collect();
    let output_rows: Vec<Vec<f64>> = (0..outputs.len())
        .map(|i| record.outputs.row(i).iter().copied().collect())
        .collect();

    // The hit: the input with the largest peak over its robust noise level.
    let found: Vec<HitPeak> = input_rows.iter().map(|x| find_hit(x)).collect();
    let main = (0..found.len())
        .max_by(|&a, &b| {
            found[a]
                .peak_to_noise()
                .total_cmp(&found[b].peak_to_noise())
        })
        .unwrap_or(0);
    let mut flags = Vec::new();
    let hit = found.get(main).copied().unwrap_or(HitPeak {
        index: 0,
        peak: 0.0,
        sigma: 0.0,
        median: 0.0,
    });
    let crest = {
        let x = input_rows.get(main).map_or(&[][..], |v| &v[..]);
        let rms = rms_about(x, hit.median);
        if rms > 0.0 { hit.peak / rms } else { 0.0 }
    };
    let excitation = match settings.excitation {
        Excitation::Auto => {
            // Records shorter than MIN_CONTINUOUS_SAMPLES are hammer
            // records: a shaker record that short cannot be averaged, and a
            // pulse over a few percent of it has a low crest factor.
            let hammer = hit.peak == 0.0
                || n < MIN_CONTINUOUS_SAMPLES
                || (hit.peak_to_noise() >= settings.min_hit_peak_to_noise
                    && crest >= settings.min_hammer_crest);
            if hammer {
                Excitation::Hammer
            } else {
                Excitation::Continuous
            }
        }
        other => other,
    };
    if excitation == Excitation::Continuous && !input_rows.is_empty() {
        return assess_continuous(
            &input_rows,
            &output_rows,
            inputs,
            outputs,
            main,
            hit,
            crest,
            dt_s,
            settings,
        );
    }
    let is_hit = hit.peak > 0.0 && hit.peak_to_noise() >= settings.min_hit_peak_to_noise;
    if !is_hit {
        let name = inputs.get(main).cloned().unwrap_or_default();
        let message = if hit.peak == 0.0 {
            format!("the force channel '{name}' is constant (no pulse at all)")
        } else {
            format!(
                "the force channel '{name}' peaks at {:.1} times its noise level (robust RMS {}), at least {} is needed for a hammer pulse: only noise",
                hit.peak_to_noise(),
                short(hit.sigma),
                settings.min_hit_peak_to_noise
            )
        };
        flags.push(Flag {
            check: Check::NoHit,
            channel: Some(name),
            message,
        });
    }
    let p = hit.index;
    let noise_end = if is_hit {
        p.saturating_sub(settings.noise_guard_samples)
    } else {
        n
    };
    let noise_ok = noise_end >= settings.min_noise_samples;
    if is_hit && p < settings.min_samples_before_hit {
        flags.push(Flag {
            check: Check::LateStart,
            channel: inputs.get(main).cloned(),
            message: format!(
                "the force peaks at sample {p}, {p} samples after the record starts, fewer than {}: an analyzer's anti-alias filter starts the pulse before its peak, and the force before the first sample is unknown, so M, K and the damping would be wrong (M off by 8 % with the peak at sample 5 of simulated analyzer records, by 54 % at 1); record a longer pre-trigger, or give --intersample zoh if the records are held (zero-order-hold) samples of a structure at rest before them",
                settings.min_samples_before_hit
            ),
        });
    }
    if is_hit && !noise_ok {
        flags.push(Flag {
            check: Check::ShortPretrigger,
            channel: None,
            message: format!(
                "the hit is at sample {p}: {noise_end} samples before it after a guard of {} (the filter precursor), at least {} are needed to estimate the noise; record a longer pre-trigger",
                settings.noise_guard_samples, settings.min_noise_samples
            ),
        });
    }

    let mut channels = Vec::with_capacity(inputs.len() + outputs.len());
    let all = with_roles(&input_rows, inputs, &output_rows, outputs);
    let mut low_snr = Vec::new();
    for (x, name, role) in all {
        let cq = channel_quality(x, name, role, noise_end, noise_ok && is_hit, dt_s, settings);
        if let Some(f) = clipping_flag(&cq, x, settings) {
            flags.push(f);
        }
        if let Some(d) = cq.drift.filter(|d| d.significant) {
            let message = if d.per_s == 0.0 {
                format!(
                    "the baseline of '{}' sits at {} before the hit ({} % of its peak, {:.0} standard errors from zero) and does not move: a constant offset (a hammer record starts at rest, at zero); it is subtracted before identification",
                    cq.name,
                    short(d.start),
                    short(100.0 * d.offset_fraction_of_peak),
                    d.offset_z.min(1e6),
                )
            } else {
                format!(
                    "the baseline of '{}' moves by {} ({} % of its peak, {:.0} standard errors) between the pre-trigger and the last {:.0} % of the record: a linear drift of {} per second; the line through the two is removed before identification",
                    cq.name,
                    short(d.per_s * (n - 1) as f64 * dt_s),
                    short(100.0 * d.fraction_of_peak),
                    d.z.min(1e6),
                    100.0 * settings.tail_fraction,
                    short(d.per_s)
                )
            };
            flags.push(Flag {
                check: Check::Drift,
                channel: Some(cq.name.clone()),
                message,
            });
        }
        if is_hit
            && let Some(snr) = cq.snr_db
            && snr < settings.min_snr_db
        {
            low_snr.push(format!("{} {:.1} dB", cq.name, snr));
        }
        if let Some(r) = cq.tail_ratio
            && r > settings.max_tail_ratio
            && is_hit
        {
            let tail_rms = r * cq.peak;
            let above_noise = cq
                .noise_rms
                .is_none_or(|nr| tail_rms > settings.tail_noise_factor * nr);
            if above_noise {
                flags.push(Flag {
                    check: Check::NotDecayed,
                    channel: Some(cq.name.clone()),
                    message: format!(
                        "the last {:.0} % of '{}' has an RMS of {:.1} % of its peak (at most {:.1} % allowed): the record ends before the response has died away (leakage); record longer",
                        100.0 * settings.tail_fraction,
                        cq.name,
                        100.0 * r,
                        100.0 * settings.max_tail_ratio
                    ),
                });
            }
        }
        channels.push(cq);
    }
    if !low_snr.is_empty() {
        flags.push(Flag {
            check: Check::LowSnr,
            channel: None,
            message: format!(
                "{} (at least {} dB wanted: signal RMS over pre-trigger noise RMS)",
                low_snr.join(", "),
                settings.min_snr_db
            ),
        });
    }

    let pulse = is_hit.then(|| {
        let x = &input_rows[main];
        let pq = pulse_quality(x, &hit, dt_s, &inputs[main], settings);
        if pq.double_hit_ratio >= settings.double_hit_ratio {
            let delay = pq.double_hit_delay_s.unwrap_or(0.0);
            flags.push(Flag {
                check: Check::DoubleHit,
                channel: Some(inputs[main].clone()),
                message: format!(
                    "a second force pulse {:.2} times the first, {:.3} s {} it (the limit is {})",
                    pq.double_hit_ratio,
                    delay.abs(),
                    if delay >= 0.0 { "after" } else { "before" },
                    settings.double_hit_ratio
                ),
            });
        }
        if pq.spectrum_drop_db > settings.max_force_drop_db {
            flags.push(Flag {
                check: Check::LongPulse,
                channel: Some(inputs[main].clone()),
                message: format!(
                    "the force spectrum falls {:.1} dB between 0 and {} Hz (at most {} dB allowed), as a half-sine pulse of {:.1} ms would: the upper modes are barely excited; use a harder hammer tip",
                    pq.spectrum_drop_db,
                    short(pq.band_hz),
                    settings.max_force_drop_db,
                    1e3 * pq.equivalent_duration_s
                ),
            });
        }
        pq
    });
    flags.sort_by_key(|f| order_of(f.check));
    HitQuality {
        hit: 1,
        excitation: Excitation::Hammer,
        crest_factor: crest,
        coherence: Vec::new(),
        snr_bands: Vec::new(),
        initial_motion: None,
        file: String::new(),
        hit_sample: is_hit.then_some(p),
        hit_time_s: is_hit.then_some(p as f64 * dt_s),
        noise_samples: if noise_ok && is_hit { noise_end } else { 0 },
        pulse,
        channels,
        flags,
    }
}

/// The checks of a continuous (shaker) record: clipping, and the coherence
/// of every output with the main force; the hammer checks (pulse, double
/// hit, pre-trigger, decay) do not apply. A record whose outputs are all
/// incoherent with the force (below a third of `min_coherence`) has no
/// usable excitation: fatal, like a hammer record without a hit.
#[allow(clippy::too_many_arguments)]
fn assess_continuous(
    input_rows: &[Vec<f64>],
    output_rows: &[Vec<f64>],
    inputs: &[String],
    outputs: &[String],
    main: usize,
    hit: HitPeak,
    crest: f64,
    dt_s: f64,
    settings: &QualitySettings,
) -> HitQuality {
    let mut flags = Vec::new();
    let mut channels = Vec::with_capacity(inputs.len() + outputs.len());
    let all = with_roles(input_rows, inputs, output_rows, outputs);
    for (x, name, role) in all {
        let mut cq = channel_quality(x, name, role, 0, false, dt_s, settings);
        cq.tail_ratio = None;
        if let Some(f) = clipping_flag(&cq, x, settings) {
            flags.push(f);
        }
        channels.push(cq);
    }
    let coherence: Vec<f64> = output_rows
        .iter()
        .map(|y| mean_coherence(&input_rows[main], y))
        .collect();
    let force = &inputs[main];
    if !coherence.is_empty() && coherence.iter().all(|&c| c < settings.min_coherence / 3.0) {
        flags.push(Flag {
            check: Check::NoHit,
            channel: Some(force.clone()),
            message: format!(
                "the force channel '{force}' peaks at {:.1} times its noise level (robust RMS {}), at least {} is needed for a hammer pulse, and as a continuous excitation its coherence with the outputs is {} (at least {} wanted): only noise",
                hit.peak_to_noise(),
                short(hit.sigma),
                settings.min_hit_peak_to_noise,
                coherence.iter().map(|c| format!("{c:.2}")).collect::<Vec<_>>().join(", "),
                settings.min_coherence
            ),
        });
    } else {
        let low: Vec<String> = outputs
            .iter()
            .zip(&coherence)
            .filter(|(_, c)| **c < settings.min_coherence)
            .map(|(name, c)| format!("{name} {c:.2}"))
            .collect();
        if !low.is_empty() {
            flags.push(Flag {
                check: Check::LowCoherence,
                channel: None,
                message: format!(
                    "coherence with '{force}' averaged over the band: {} (at least {} wanted): noise or an unmeasured input carries much of the response",
                    low.join(", "),
                    settings.min_coherence
                ),
            });
        }
    }
    let snr_bands: Vec<ChannelBandSnr> = output_rows
        .iter()
        .zip(outputs)
        .map(|(y, name)| ChannelBandSnr {
            channel: name.clone(),
            bands: band_snr(&input_rows[main], y, dt_s, settings.min_band_snr_db),
        })
        .collect();
    let motion = initial_motion(
        &input_rows[main],
        output_rows,
        settings.noise_guard_samples,
        settings.min_noise_samples,
    );
    if let Some(ratio) = motion.ratio
        && ratio > settings.max_initial_motion
    {
        let worst = motion.channel.map_or(String::new(), |j| outputs[j].clone());
        flags.push(Flag {
            check: Check::NotAtRest,
            channel: Some(worst.clone()),
            message: format!(
                "'{worst}' moves before the excitation starts: RMS over the first {} samples {} of its RMS over the record (at most {} for a structure at rest); identified with an unknown initial state",
                motion.pre_excitation_samples,
                short(ratio),
                settings.max_initial_motion
            ),
        });
    }
    flags.sort_by_key(|f| order_of(f.check));
    HitQuality {
        hit: 1,
        excitation: Excitation::Continuous,
        crest_factor: crest,
        coherence,
        snr_bands,
        initial_motion: Some(motion),
        file: String::new(),
        hit_sample: None,
        hit_time_s: None,
        noise_samples: 0,
        pulse: None,
        channels,
        flags,
    }
}

/// Ordinary coherence `|Gxy|^2 / (Gxx Gyy)` of `x` and `y` by Welch's
/// method (Hann windows of an eighth of the record, half overlapping, 15
/// segments), averaged over the bins from the first to 0.8 of the Nyquist
/// frequency (the analyzer's usable band, fs/2.56, and a little beyond)
/// where the force `x` is within 20 dB of its largest line
/// ([`EXCITED_LINE`]): a shaker driving 1-24 Hz of a record sampled at
/// 512 Hz leaves nine tenths of the band unexcited, where the coherence
/// says nothing about the record. 0 for records too short to average
/// (under 64 samples) or without power.
pub fn mean_coherence(x: &[f64], y: &[f64]) -> f64 {
    let Some((_, vals)) = coherence_bins(x, y) else {
        return 0.0;
    };
    let top = vals.iter().flatten().map(|v| v.1).fold(0.0, f64::max);
    let vals: Vec<f64> = vals
        .into_iter()
        .flatten()
        .filter(|&(_, gxx)| gxx >= EXCITED_LINE * top)
        .map(|(g, _)| g)
        .collect();
    if vals.is_empty() {
        0.0
    } else {
        vals.iter().sum::<f64>() / vals.len() as f64
    }
}

/// Coherence of one output with the force in one octave band.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BandSnr {
    /// Lower edge of the band, Hz (`2^(k - 1/2)`, or the first line).
    pub low_hz: f64,
    /// Upper edge of the band, Hz (`2^(k + 1/2)`, or 0.8 of the Nyquist
    /// frequency).
    pub high_hz: f64,
    /// Frequency lines (Welch bins) in the band.
    pub lines: usize,
    /// Mean ordinary coherence over those lines.
    pub coherence: f64,
    /// `10 log10(gamma^2 / (1 - gamma^2))` of that mean coherence, dB: the
    /// power the force explains over the rest (noise, other inputs,
    /// leakage). Capped at 60 dB (coherence 1 - 1e-6) and at -60 dB
    /// (coherence 1e-6).
    pub snr_db: f64,
    /// Whether the force excites the band (nearly all its lines within
    /// 20 dB of the force's largest, see [`EXCITED_LINE`] and
    /// [`EXCITED_BAND`]); a band the force leaves out, wholly or in part, is
    /// reported but not judged.
    pub excited: bool,
    /// Excited, and the SNR below
    /// [`QualitySettings::min_band_snr_db`]: a band where the records say
    /// little about the structure.
    pub low: bool,
}

/// The SNR bands of one output.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ChannelBandSnr {
    /// The output's name.
    pub channel: String,
    /// Octave bands, ascending.
    pub bands: Vec<BandSnr>,
}

/// Largest SNR reported, dB (a coherence of 1 - 1e-6); its negative is the
/// smallest (a coherence of 1e-6).
pub const MAX_BAND_SNR_DB: f64 = 60.0;

/// SNR of `y` against the force `x` sampled every `dt_s` seconds, in
/// octave bands of centre frequencies `2^k` Hz (edges `2^(k +- 1/2)`),
/// from the Welch coherence of [`mean_coherence`] (the same segments and
/// lines: from the first line to 0.8 of the Nyquist frequency). A band's
/// SNR is `gamma^2 / (1 - gamma^2)` of the mean coherence of its lines:
/// for an output `y = h * x + n` with noise `n` uncorrelated with the
/// force, `gamma^2 = S / (S + N)`, so this is `S / N`. Bands without a line
/// are left out; empty for records too short (under 64 samples). A band
/// the force excites whose SNR is below `min_snr_db` is marked `low`.
pub fn band_snr(x: &[f64], y: &[f64], dt_s: f64, min_snr_db: f64) -> Vec<BandSnr> {
    let Some((df_hz, vals)) = coherence_bins(x, y) else {
        return Vec::new();
    };
    let df_hz = df_hz / dt_s;
    let top_hz = vals.len() as f64 * df_hz;
    let mut out: Vec<BandSnr> = Vec::new();
    // Lines the force excites, per band.
    let mut force: Vec<usize> = Vec::new();
    let top_force = vals.iter().flatten().map(|v| v.1).fold(0.0, f64::max);
    for (i, v) in vals.iter().enumerate() {
        let Some((g, gxx)) = *v else { continue };
        let excited = usize::from(gxx >= EXCITED_LINE * top_force);
        let f = (i + 1) as f64 * df_hz;
        let k = f.log2().round();
        let (lo, hi) = (2f64.powf(k - 0.5), 2f64.powf(k + 0.5));
        match out.last_mut() {
            Some(b) if b.high_hz == hi.min(top_hz) => {
                b.lines += 1;
                b.coherence += g;
                *force.last_mut().expect("one count per band") += excited;
            }
            _ => {
                out.push(BandSnr {
                    low_hz: lo.max(df_hz),
                    high_hz: hi.min(top_hz),
                    lines: 1,
                    coherence: g,
                    snr_db: 0.0,
                    excited: true,
                    low: false,
                });
                force.push(excited);
            }
        }
    }
    for (b, &excited) in out.iter_mut().zip(&force) {
        b.excited = excited as f64 >= EXCITED_BAND * b.lines as f64;
        b.coherence /= b.lines as f64;
        // Within 1e-6 of 0 and 1: +-60 dB, never infinite.
        let g = b.coherence.clamp(1e-6, 1.0 - 1e-6);
        b.snr_db = (10.0 * (g / (1.0 - g)).log10()).clamp(-MAX_BAND_SNR_DB, MAX_BAND_SNR_DB);
        b.low = b.excited && b.snr_db < min_snr_db;
    }
    out
}

/// A line is excited when the force's auto-spectrum there is at least
/// this fraction of its largest line's: 0.01 (-20 dB). A shaker's random or
/// swept force is flat within a few dB over its band (a Welch estimate of
/// 15 segments scatters by about 25 % per line) and falls by far more
/// outside it (the simulated 1-24 Hz random force: 30 dB and more below
/// 1 Hz).
pub const EXCITED_LINE: f64 = 0.01;

/// A band is judged when at least this fraction of its lines is excited:
/// 0.9. A band the force's edge cuts (a 1-24 Hz force in the octaves
/// 0.71-1.41 Hz and 22.6-25.4 Hz) has a coherence lowered by its unexcited
/// half, which says nothing about the noise.
pub const EXCITED_BAND: f64 = 0.9;

/// The Welch coherence of [`mean_coherence`]: the line spacing in units of
/// the sampling rate and, for lines 1 to 0.8 of the Nyquist frequency, the
/// coherence and the force's auto-spectrum (`None` where a channel has no
/// power; scaled by a power of two when the force's samples are beyond
/// 1e-100..1e100, so only to be compared with its own lines). `None` for records under 64 samples.
#[allow(clippy::type_complexity)]
fn coherence_bins(x: &[f64], y: &[f64]) -> Option<(f64, Vec<Option<(f64, f64)>>)> {
    use rustfft::FftPlanner;
    use rustfft::num_complex::Complex;
    let n = x.len().min(y.len());
    if n < 64 {
        return None;
    }
    // The coherence does not change when `x` or `y` is scaled, but the
    // spectra square sums of up to n samples: samples beyond about 1e150
    // overflowed them (a coherence of inf / inf, NaN, null in the JSON),
    // below about 1e-160 they underflowed. Such a signal is scaled by a
    // power of two (exact) bringing its largest sample near 1; signals
    // within 1e-100..1e100 are taken as they are, as always.
    fn in_range(v: &[f64]) -> Cow<'_, [f64]> {
        let m = v.iter().fold(0.0_f64, |m, a| m.max(a.abs()));
        if m == 0.0 || (1e-100..=1e100).contains(&m) {
            Cow::Borrowed(v)
        } else {
            let factor = 2f64.powi(-(m.log2().floor() as i32).clamp(-1000, 1000));
            Cow::Owned(v.iter().map(|a| a * factor).collect())
        }
    }
    let (x, y) = (in_range(&x[..n]), in_range(&y[..n]));
    let (x, y) = (&x[..], &y[..]);
    let len = n / 8;
    let step = len / 2;
    let window: Vec<f64> = (0..len)
        .map(|i| 0.5 - 0.5 * (2.0 * std::f64::consts::PI * i as f64 / len as f64).cos())
        .collect();
    let fft = FftPlanner::<f64>::new().plan_fft_forward(len);
    let bins = len / 2 + 1;
    let (mut gxx, mut gyy) = (vec![0.0; bins], vec![0.0; bins]);
    let mut gxy = vec![Complex::new(0.0, 0.0); bins];
    let mut start = 0;
    while start + len <= n {
        let seg = |v: &[f64]| -> Vec<Complex<f64>> {
            let m = v[start..start + len].iter().sum::<f64>() / len as f64;
            v[start..start + len]
                .iter()
                .zip(&window)
                .map(|(a, w)| Complex::new((a - m) * w, 0.0))
                .collect()
        };
        let (mut fx, mut fy) = (seg(x), seg(y));
        fft.process(&mut fx);
        fft.process(&mut fy);
        for b in 0..bins {
            gxx[b] += fx[b].norm_sqr();
            gyy[b] += fy[b].norm_sqr();
            gxy[b] += fx[b].conj() * fy[b];
        }
        start += step;
    }
    let top = ((0.8 * (bins - 1) as f64) as usize).max(1);
    let vals: Vec<Option<(f64, f64)>> = (1..=top)
        .map(|b| {
            (gxx[b] > 0.0 && gyy[b] > 0.0).then(|| (gxy[b].norm_sqr() / (gxx[b] * gyy[b]), gxx[b]))
        })
        .collect();
    Some((1.0 / len as f64, vals))
}

/// How much the outputs of a record move before its excitation starts.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct InitialMotion {
    /// Samples before the excitation starts, less the guard (0 when the
    /// force is on from the first sample: the records alone cannot tell
    /// then, the model-based check of the analysis does).
    pub pre_excitation_samples: usize,
    /// Largest over the outputs of the RMS over those samples over the RMS
    /// over the record (null without enough samples).
    pub ratio: Option<f64>,
    /// The output of that largest ratio, 0-based (null without a ratio).
    #[serde(skip)]
    pub channel: Option<usize>,
}

/// The motion of `outputs` before the force `force` starts: the force
/// starts at its first sample above a tenth of its RMS (a shaker's force
/// is many times that within a few samples, a pre-trigger's noise far
/// below it); the `guard` samples before that hold the analyzer filter's
/// precursor and are left out. With fewer than `min_samples` samples
/// left there is no ratio.
pub fn initial_motion(
    force: &[f64],
    outputs: &[Vec<f64>],
    guard: usize,
    min_samples: usize,
) -> InitialMotion {
    let rms = |x: &[f64]| rms_about(x, 0.0);
    let level = 0.1 * rms(force);
    let onset = force
        .iter()
        .position(|v| v.abs() > level)
        .unwrap_or(force.len());
    let pre = onset.saturating_sub(guard);
    if pre < min_samples.max(1) {
        return InitialMotion {
            pre_excitation_samples: pre,
            ratio: None,
            channel: None,
        };
    }
    let mut best: Option<(usize, f64)> = None;
    for (j, y) in outputs.iter().enumerate() {
        let whole = rms(y);
        if whole <= 0.0 || y.len() < pre {
            continue;
        }
        let r = rms(&y[..pre]) / whole;
        if best.is_none_or(|(_, b)| r > b) {
            best = Some((j, r));
        }
    }
    InitialMotion {
        pre_excitation_samples: pre,
        ratio: best.map(|b| b.1),
        channel: best.map(|b| b.0),
    }
}

fn order_of(c: Check) -> usize {
    [
        Check::NoHit,
        Check::LateStart,
        Check::DoubleHit,
        Check::Clipping,
        Check::LongPulse,
        Check::NotDecayed,
        Check::ShortPretrigger,
        Check::LowSnr,
        Check::LowCoherence,
        Check::NotAtRest,
        Check::Drift,
    ]
    .iter()
    .position(|&x| x == c)
    .unwrap_or(usize::MAX)
}

/// A number in a short readable form.
fn short(x: f64) -> String {
    crate::numfmt::sig(x, 3)
}

/// Where a force channel peaks, against its robust noise level.
#[derive(Debug, Clone, Copy)]
struct HitPeak {
    index: usize,
    /// Largest deviation from the median.
    peak: f64,
    /// Robust noise standard deviation: 1.4826 x the median absolute
    /// deviation. The pulse and its ringing cover a few tens of samples of
    /// a record of thousands, so the median sees only noise.
    sigma: f64,
    median: f64,
}

impl HitPeak {
    fn peak_to_noise(&self) -> f64 {
        if self.peak == 0.0 {
            0.0
        } else if self.sigma == 0.0 {
            f64::INFINITY
        } else {
            self.peak / self.sigma
        }
    }
}

fn find_hit(x: &[f64]) -> HitPeak {
    let median = median(x);
    let dev: Vec<f64> = x.iter().map(|v| (v - median).abs()).collect();
    let (index, peak) =
        dev.iter().enumerate().fold(
            (0, 0.0),
            |best, (i, &d)| if d > best.1 { (i, d) } else { best },
        );
    HitPeak {
        index,
        peak,
        sigma: 1.4826 * self::median(&dev),
        median,
    }
}

fn median(x: &[f64]) -> f64 {
    if x.is_empty() {
        return 0.0;
    }
    let mut v = x.to_vec();
    let mid = v.len() / 2;
    let (_, m, _) = v.select_nth_unstable_by(mid, f64::total_cmp);
    *m
}

/// Every channel of a record with its name and role, inputs first.
fn with_roles<'a>(
    input_rows: &'a [Vec<f64>],
    inputs: &'a [String],
    output_rows: &'a [Vec<f64>],
    outputs: &'a [String],
) -> impl Iterator<Item = (&'a Vec<f64>, &'a String, Role)> {
    let ins = input_rows
        .iter()
        .zip(inputs)
        .map(|(x, n)| (x, n, Role::Input));
    let outs = output_rows
        .iter()
        .zip(outputs)
        .map(|(x, n)| (x, n, Role::Output));
    ins.chain(outs)
}

/// `20 log10(a / b)` for positive finite `a` and `b`, dB. The quotient
/// as always, unless it overflows or underflows (a sample near the
/// largest double over ordinary noise made an infinite `snr_db`, null in
/// the JSON); then the difference of the logarithms, which is finite.
fn amplitude_db(a: f64, b: f64) -> f64 {
    let r = a / b;
    if r.is_normal() {
        20.0 * r.log10()
    } else {
        20.0 * (a.log10() - b.log10())
    }
}

/// Root mean square of `x` about `base` (0 for no samples).
///
/// The squares are summed as they are, the value every record got so far
/// bit for bit, unless their sum leaves the range where that is exact to
/// rounding: a sample beyond about 1e154 overflows it to infinity (a wild
/// sample of 1e200 made `rms` infinite, `snr_db` infinite, and both `null`
/// in the JSON of the dropped hit), deviations all below about 1e-100
/// underflow it toward 0. Then every deviation is divided by the largest
/// magnitude of `x` and `base` before squaring (each term at most 4), so
/// the result is finite for any finite samples whose RMS is (up to a
/// quarter of the largest double).
fn rms_about(x: &[f64], base: f64) -> f64 {
    if x.is_empty() {
        return 0.0;
    }
    let n = x.len() as f64;
    let plain = x.iter().map(|v| (v - base) * (v - base)).sum::<f64>();
    // 1e-200: far above the subnormal range (2.2e-308), so every square
    // that matters to the sum was kept; no real record comes near it.
    if plain.is_finite() && plain > 1e-200 {
        return (plain / n).sqrt();
    }
    let scale = x.iter().fold(base.abs(), |m, v| m.max(v.abs()));
    if !(scale > 0.0 && scale.is_finite()) {
        return if scale == 0.0 { 0.0 } else { f64::NAN };
    }
    let b = base / scale;
    let sum = x
        .iter()
        .map(|v| (v / scale - b) * (v / scale - b))
        .sum::<f64>();
    scale * (sum / n).sqrt()
}

fn channel_quality(
    x: &[f64],
    name: &str,
    role: Role,
    noise_end: usize,
    noise_ok: bool,
    dt_s: f64,
    settings: &QualitySettings,
) -> ChannelQuality {
    let n = x.len();
    let noise = &x[..noise_end.min(n)];
    let base = if noise.is_empty() {
        0.0
    } else {
        noise.iter().sum::<f64>() / noise.len() as f64
    };
    let peak = x.iter().fold(0.0_f64, |m, v| m.max((v - base).abs()));
    let rms = rms_about(&x[noise_end.min(n)..], base);
    let noise_rms = noise_ok.then(|| rms_about(noise, base));
    let snr_db = noise_rms
        .filter(|&nr| nr > 0.0 && rms > 0.0)
        .map(|nr| amplitude_db(rms, nr));
    let (clip_run, clip_samples) = extremes(x, base, peak);
    let range = match role {
        Role::Input => settings.force_range,
        Role::Output => settings.acceleration_range,
    };
    let range_samples = range.map_or(0, |r| {
        let at = r * (1.0 - 1e-9);
        x.iter().filter(|v| v.abs() >= at).count()
    });
    let tail_len = ((settings.tail_fraction * n as f64).round() as usize).clamp(1, n);
    let tail_ratio =
        (role == Role::Output && peak > 0.0).then(|| rms_about(&x[n - tail_len..], base) / peak);
    let drift = (noise_ok
        && peak > 0.0
        && noise.len() >= 2
        && tail_len >= 2
        && n - tail_len >= noise.len())
    .then(|| baseline_line(noise, &x[n - tail_len..], n, dt_s, peak, settings));
    ChannelQuality {
        name: name.to_string(),
        role,
        peak,
        rms,
        noise_rms,
        snr_db,
        clip_run,
        clip_samples,
        range_samples,
        tail_ratio,
        drift,
    }
}

fn not_a_drift(d: &Option<Drift>) -> bool {
    !d.is_some_and(|d| d.significant)
}

/// The [`Drift`] line of a channel of `n` samples from its pre-trigger
/// `head` (starting at sample 0) and its `tail` (ending at sample n - 1).
fn baseline_line(
    head: &[f64],
    tail: &[f64],
    n: usize,
    dt_s: f64,
    peak: f64,
    settings: &QualitySettings,
) -> Drift {
    let mean = |x: &[f64]| x.iter().sum::<f64>() / x.len() as f64;
    let (m0, m1) = (mean(head), mean(tail));
    let var =
        |x: &[f64], m: f64| x.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / (x.len() - 1) as f64;
    // A segment without any noise (a constant pre-trigger of a digital or
    // heavily quantized channel) has a standard error of 0, and the move or
    // offset would be infinitely many of them (null in JSON). The smallest
    // meaningful uncertainty is then the samples' round-off, eps times the
    // peak: noisy records keep their bits, noise-free ones get a finite z.
    let floor = f64::EPSILON * peak;
    let se = (var(head, m0) / head.len() as f64 + var(tail, m1) / tail.len() as f64)
        .sqrt()
        .max(floor);
    let t0 = 0.5 * (head.len() - 1) as f64 * dt_s;
    let t1 = 0.5 * ((n - tail.len()) + (n - 1)) as f64 * dt_s;
    let per_s = (m1 - m0) / (t1 - t0);
    let z = if se > 0.0 {
        (m1 - m0).abs() / se
    } else if m1 == m0 {
        0.0
    } else {
        f64::INFINITY
    };
    let fraction_of_peak = (m1 - m0).abs() / peak;
    let se0 = (var(head, m0) / head.len() as f64).sqrt().max(floor);
    let offset_z = if se0 > 0.0 {
        m0.abs() / se0
    } else if m0 == 0.0 {
        0.0
    } else {
        f64::INFINITY
    };
    let offset_fraction_of_peak = m0.abs() / peak;
    let beyond =
        |z: f64, fraction: f64| z > settings.drift_z && fraction > settings.drift_min_fraction;
    let moves = beyond(z, fraction_of_peak);
    let offset = beyond(offset_z, offset_fraction_of_peak);
    // A baseline that does not move is the pre-trigger mean: the slope
    // through the tail would only add the tail's noise to every sample.
    let (start, per_s) = if offset && !moves {
        (m0, 0.0)
    } else {
        (m0 - per_s * t0, per_s)
    };
    Drift {
        start,
        per_s,
        z,
        fraction_of_peak,
        offset_z,
        offset_fraction_of_peak,
        significant: moves || offset,
    }
}

/// `campaign` with the significant drifts of `hits` (its quality, record by
/// record) removed: the baseline line of each such channel subtracted from
/// every sample. Records and channels without one are left bit for bit;
/// without any, `campaign` itself is returned (no copy).
pub fn remove_drifts<'a>(campaign: &'a Campaign, hits: &[HitQuality]) -> Cow<'a, Campaign> {
    let drifting = |q: &HitQuality| {
        q.channels
            .iter()
            .any(|c| c.drift.is_some_and(|d| d.significant))
    };
    if !hits.iter().any(drifting) {
        return Cow::Borrowed(campaign);
    }
    let mut out = campaign.clone();
    for (record, q) in out.records.iter_mut().zip(hits) {
        let inputs = record.inputs.nrows();
        for (c, cq) in q.channels.iter().enumerate() {
            let Some(d) = cq.drift.filter(|d| d.significant) else {
                continue;
            };
            let mut row = if c < inputs {
                record.inputs.row_mut(c)
            } else {
                record.outputs.row_mut(c - inputs)
            };
            for (k, v) in row.iter_mut().enumerate() {
                *v -= d.start + d.per_s * k as f64 * campaign.dt_s;
            }
        }
    }
    Cow::Owned(out)
}

/// Longest run and count of samples equal to the channel's largest and
/// smallest value, over the sides that reach at least half the peak (the
/// other side of a one-signed pulse, or an exactly zero pre-trigger, is
/// not an extreme).
fn extremes(x: &[f64], base: f64, peak: f64) -> (usize, usize) {
    if peak == 0.0 || x.is_empty() {
        return (0, 0);
    }
    let hi = x.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let lo = x.iter().copied().fold(f64::INFINITY, f64::min);
    let mut best = (0, 0);
    for ext in [hi, lo] {
        if (ext - base).abs() < 0.5 * peak {
            continue;
        }
        // Exact repeats (to rounding of the file's number format).
        let tol = 1e-12 * ext.abs();
        let mut run = 0;
        let mut longest = 0;
        let mut count = 0;
        for v in x {
            if (v - ext).abs() <= tol {
                run += 1;
                count += 1;
                longest = longest.max(run);
            } else {
                run = 0;
            }
        }
        best = (best.0.max(longest), best.1.max(count));
    }
    best
}

fn clipping_flag(c: &ChannelQuality, x: &[f64], settings: &QualitySettings) -> Option<Flag> {
    let range = match c.role {
        Role::Input => settings.force_range,
        Role::Output => settings.acceleration_range,
    };
    let mut why = Vec::new();
    if c.clip_samples >= settings.clip_samples {
        let hi = x.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let lo = x.iter().copied().fold(f64::INFINITY, f64::min);
        let ext = if hi.abs() >= lo.abs() { hi } else { lo };
        why.push(format!(
            "{} samples equal to its extreme {} ({} in a row; a clean signal does not repeat its extreme)",
            c.clip_samples,
            short(ext),
            c.clip_run
        ));
    }
    if let Some(r) = range
        && c.range_samples > 0
    {
        why.push(format!(
            "{} samples at or beyond the declared range +-{}",
            c.range_samples,
            short(r)
        ));
    }
    (!why.is_empty()).then(|| Flag {
        check: Check::Clipping,
        channel: Some(c.name.clone()),
        message: format!("'{}' is clipped: {}", c.name, why.join("; ")),
    })
}

/// Half-width, in samples, of the window around the main pulse used for its
/// spectrum: it holds the pulse and the decimation filter's ringing (the
/// simulator's 100 dB Kaiser FIR rings for about 29 analysis samples on
/// each side, at levels that leave the band's spectrum within 0.1 dB).
const PULSE_WINDOW: usize = 32;
/// Frequencies at which the force spectrum is evaluated over the band.
const SPECTRUM_POINTS: usize = 32;

fn pulse_quality(
    x: &[f64],
    hit: &HitPeak,
    dt_s: f64,
    name: &str,
    settings: &QualitySettings,
) -> PulseQuality {
    let n = x.len();
    let sign = if x[hit.index] >= hit.median {
        1.0
    } else {
        -1.0
    };
    let y: Vec<f64> = x.iter().map(|v| sign * (v - hit.median)).collect();
    // [1, 2, 1] / 4: zero gain at fs/2, where the filter ringing lives.
    let g: Vec<f64> = (0..n)
        .map(|k| {
            let left = if k > 0 { y[k - 1] } else { 0.0 };
            let right = if k + 1 < n { y[k + 1] } else { 0.0 };
            0.25 * left + 0.5 * y[k] + 0.25 * right
        })
        .collect();
    let lo = hit.index.saturating_sub(2);
    let hi = (hit.index + 3).min(n);
    let pg = (lo..hi).fold(hit.index, |b, k| if g[k] > g[b] { k } else { b });
    let top = g[pg];
    // Noise on the smoothed force: sqrt(6/16) of the raw noise.
    let floor = 5.0 * 0.61 * hit.sigma;
    let right = second_pulse(&g, pg, top, floor, settings.double_hit_valley, 1);
    let left = second_pulse(&g, pg, top, floor, settings.double_hit_valley, -1);
    let (ratio, delay) = match (right, left) {
        (Some(r), Some(l)) if l.height > r.height => (l.height / top, Some(l.offset)),
        (Some(r), _) => (r.height / top, Some(r.offset)),
        (None, Some(l)) => (l.height / top, Some(l.offset)),
        (None, None) => (0.0, None),
    };
    // The spectrum window: the main pulse and its ringing, but not past the
    // valley before a second pulse.
    let extent = |dir: isize| -> usize {
        let mut k = pg as isize;
        let mut steps = 0;
        while k + dir >= 0 && ((k + dir) as usize) < n && g[(k + dir) as usize] > 0.1 * top {
            k += dir;
            steps += 1;
        }
        steps
    };
    let mut start = pg.saturating_sub(PULSE_WINDOW + extent(-1));
    let mut end = (pg + PULSE_WINDOW + extent(1) + 1).min(n);
    let significant = |s: &SecondPulse| s.height >= settings.double_hit_ratio * top;
    if let Some(l) = left.filter(significant) {
        start = start.max(l.valley + 1);
    }
    if let Some(r) = right.filter(significant) {
        end = end.min(r.valley);
    }
    let fs = 1.0 / dt_s;
    let band_hz = settings.band_hz.unwrap_or(fs / 2.56).min(0.5 * fs);
    let mags: Vec<(f64, f64)> = (0..=SPECTRUM_POINTS)
        .map(|j| {
            let f = band_hz * j as f64 / SPECTRUM_POINTS as f64;
            let w = 2.0 * std::f64::consts::PI * f * dt_s;
            let (mut re, mut im) = (0.0, 0.0);
            for k in start..end {
                let ph = w * (k - start) as f64;
                re += y[k] * ph.cos();
                im -= y[k] * ph.sin();
            }
            (f, re.hypot(im))
        })
        .collect();
    let max = mags.iter().map(|m| m.1).fold(0.0, f64::max);
    let (f_min, min) = mags
        .iter()
        .copied()
        .fold((0.0, f64::INFINITY), |b, m| if m.1 < b.1 { m } else { b });
    let drop_db = if max > 0.0 && min > 0.0 {
        amplitude_db(max, min)
    } else if max > 0.0 {
        f64::INFINITY
    } else {
        0.0
    };
    // The half-sine duration with the same fall at the band edge; if the
    // spectrum dips deeper inside the band (past the first lobe), at the
    // dip instead.
    let (_, edge) = mags[SPECTRUM_POINTS];
    let equivalent_duration_s = if max <= 0.0 {
        0.0
    } else if f_min > 0.0 && min < 0.7 * edge {
        half_sine_fraction_inverse(min / max) / f_min
    } else {
        half_sine_fraction_inverse(edge / max) / band_hz
    };
    PulseQuality {
        channel: name.to_string(),
        peak_to_noise_db: (hit.sigma > 0.0).then(|| amplitude_db(hit.peak, hit.sigma)),
        double_hit_ratio: ratio,
        double_hit_delay_s: delay.map(|d| d as f64 * dt_s),
        band_hz,
        spectrum_drop_db: drop_db.min(999.0),
        equivalent_duration_s,
    }
}

#[derive(Debug, Clone, Copy)]
struct SecondPulse {
    /// Signed offset from the main pulse, samples.
    offset: isize,
    height: f64,
    /// Sample of the lowest smoothed force between the two pulses.
    valley: usize,
}

/// The highest local maximum of the smoothed force `g` on one side
/// (`dir` = 1 after, -1 before) of the main pulse at `pg` that is
/// separated from it by a valley (the force falls to `valley` times the
/// candidate's height in between) and stands above the noise floor.
fn second_pulse(
    g: &[f64],
    pg: usize,
    top: f64,
    floor: f64,
    valley: f64,
    dir: isize,
) -> Option<SecondPulse> {
    let n = g.len() as isize;
    let mut best: Option<SecondPulse> = None;
    let mut lowest = top;
    let mut lowest_at = pg;
    let mut k = pg as isize + dir;
    while k >= 0 && k < n {
        let ku = k as usize;
        let v = g[ku];
        if v < lowest {
            lowest = v;
            lowest_at = ku;
        }
        let prev = g[(k - dir) as usize];
        let next = if k + dir >= 0 && k + dir < n {
            g[(k + dir) as usize]
        } else {
            f64::NEG_INFINITY
        };
        let is_peak = v > 0.0 && v >= prev && v >= next;
        if is_peak && v > floor && lowest <= valley * v && best.is_none_or(|b| v > b.height) {
            best = Some(SecondPulse {
                offset: k - pg as isize,
                height: v,
                valley: lowest_at,
            });
        }
        k += dir;
    }
    best
}

/// Amplitude spectrum of a half-sine pulse of duration T at frequency f,
/// relative to its value at 0, as a function of u = f T:
/// `|cos(pi u) / (1 - 4 u^2)|` (pi/4 at u = 1/2). Decreasing on [0, 1.5).
fn half_sine_fraction(u: f64) -> f64 {
    let d = 1.0 - 4.0 * u * u;
    if d.abs() < 1e-9 {
        std::f64::consts::FRAC_PI_4
    } else {
        ((std::f64::consts::PI * u).cos() / d).abs()
    }
}

/// The u in [0, 1.5] with `half_sine_fraction(u) = ratio` (1.5 if the
/// ratio is below what the main lobe reaches).
fn half_sine_fraction_inverse(ratio: f64) -> f64 {
    if ratio >= 1.0 {
        return 0.0;
    }
    let (mut a, mut b) = (0.0, 1.5);
    for _ in 0..60 {
        let m = 0.5 * (a + b);
        if half_sine_fraction(m) > ratio {
            a = m;
        } else {
            b = m;
        }
    }
    0.5 * (a + b)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DMatrix;

    #[test]
    fn half_sine_spectrum_and_its_inverse() {
        assert!((half_sine_fraction(0.0) - 1.0).abs() < 1e-15);
        assert!((half_sine_fraction(0.5) - std::f64::consts::FRAC_PI_4).abs() < 1e-6);
        // f T = 1: cos(pi) / (1 - 4) = 1/3.
        assert!((half_sine_fraction(1.0) - 1.0 / 3.0).abs() < 1e-12);
        for u in [0.05, 0.3, 0.5, 0.9, 1.2, 1.4] {
            let r = half_sine_fraction(u);
            assert!((half_sine_fraction_inverse(r) - u).abs() < 1e-6, "{u}");
        }
        // 12 dB at f T of about 1.1.
        let u12 = half_sine_fraction_inverse(10f64.powf(-12.0 / 20.0));
        assert!((u12 - 1.1).abs() < 0.03, "{u12}");
    }

    /// Gaussian pseudo-random numbers (xorshift and Box-Muller), seeded.
    fn gaussian(seed: u64, n: usize) -> Vec<f64> {
        let mut state = seed.max(1);
        let mut uniform = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        (0..n)
            .map(|_| {
                let (a, b) = (uniform(), uniform());
                (-2.0 * a.ln()).sqrt() * (2.0 * std::f64::consts::PI * b).cos()
            })
            .collect()
    }

    /// The coherence does not depend on the scale of either signal; with
    /// samples beyond 1e150 the squared spectra overflowed and the mean
    /// coherence was NaN (null in the JSON of a continuous record), below
    /// 1e-160 they underflowed. Scaled signals give the unscaled values.
    #[test]
    fn coherence_of_huge_and_tiny_signals() {
        let n = 16384;
        let x = gaussian(1, n);
        let noise = gaussian(2, n);
        let y: Vec<f64> = x.iter().zip(&noise).map(|(a, e)| 2.0 * a + e).collect();
        let want = mean_coherence(&x, &y);
        let want_bands = band_snr(&x, &y, 1.0 / 64.0, 0.0);
        for (sx, sy) in [(1.0, 1e200), (1e-170, 1.0), (1e300, 1e-300), (1.0, 1e99)] {
            let xs: Vec<f64> = x.iter().map(|v| v * sx).collect();
            let ys: Vec<f64> = y.iter().map(|v| v * sy).collect();
            let got = mean_coherence(&xs, &ys);
            // Scaling by a power of ten rounds each sample once (1.1e-16);
            // the spectra and the mean over ~800 lines carry that to well
            // under 1e-12.
            assert!((got - want).abs() < 1e-12, "{sx:e} {sy:e}: {got} vs {want}");
            let bands = band_snr(&xs, &ys, 1.0 / 64.0, 0.0);
            assert_eq!(bands.len(), want_bands.len());
            for (b, w) in bands.iter().zip(&want_bands) {
                assert!((b.coherence - w.coherence).abs() < 1e-12, "{b:?} {w:?}");
            }
        }
        // A single wild sample: finite, whatever it does to the coherence.
        let mut wild = y.clone();
        wild[n / 2] = 1e200;
        assert!(mean_coherence(&x, &wild).is_finite());
        assert!(
            band_snr(&x, &wild, 1.0 / 64.0, 0.0)
                .iter()
                .all(|b| b.coherence.is_finite() && b.snr_db.is_finite())
        );
    }

    /// A gain plus independent white noise: the coherence is
    /// `S / (S + N)` at every line, so every band's SNR is `S / N`.
    #[test]
    fn band_snr_is_the_signal_to_noise_ratio_of_a_gain_plus_noise() {
        let n = 16384;
        let x = gaussian(1, n);
        let noise = gaussian(2, n);
        for (sigma, want_db) in [(0.5, 6.02), (1.0, 0.0), (0.1, 20.0)] {
            let y: Vec<f64> = x
                .iter()
                .zip(&noise)
                .map(|(a, e)| 2.0 * a + 2.0 * sigma * e)
                .collect();
            let bands = band_snr(&x, &y, 1.0 / 64.0, 0.0);
            // 2048-sample segments at 64 Hz: lines every 1/32 Hz, 819 of
            // them (0.8 of the 1024 up to the Nyquist frequency).
            assert!((bands.last().unwrap().high_hz - 819.0 / 32.0).abs() < 1e-9);
            assert_eq!(bands.iter().map(|b| b.lines).sum::<usize>(), 819);
            for b in bands.iter().filter(|b| b.lines >= 16) {
                // 15 half-overlapping segments scatter the coherence of one
                // line by about 0.07 at 0.8 and bias it up by about
                // (1 - gamma^2)^2 / 15; over 16 lines or more the band's SNR
                // is within 1 dB (measured -0.42 to +0.59 dB, 23 to 362
                // lines).
                assert!((b.snr_db - want_db).abs() < 1.0, "{sigma}: {b:?}");
                assert!(b.excited);
                assert_eq!(b.low, b.snr_db < 0.0);
            }
        }
    }

    /// Outputs moving before a force that starts at sample 300 (after the
    /// 20-sample guard: 280 samples), or quiet there.
    #[test]
    fn initial_motion_before_the_force() {
        let n = 2000;
        let noise = gaussian(3, n);
        let force: Vec<f64> = (0..n)
            .map(|i| if i < 300 { 0.001 * noise[i] } else { noise[i] })
            .collect();
        let sine: Vec<f64> = (0..n).map(|i| (0.3 * i as f64).sin()).collect();
        let quiet: Vec<f64> = (0..n)
            .map(|i| if i < 300 { 0.0 } else { sine[i] })
            .collect();
        let m = initial_motion(&force, &[quiet.clone(), sine.clone()], 20, 8);
        assert_eq!(m.pre_excitation_samples, 280);
        // A steady sine: the same RMS before and over the record, up to the
        // partial period (1 %).
        assert!((m.ratio.unwrap() - 1.0).abs() < 0.01, "{m:?}");
        assert_eq!(m.channel, Some(1));
        let m = initial_motion(&force, &[quiet], 20, 8);
        assert_eq!(m.ratio, Some(0.0));
        // Force on from the first sample: no ratio.
        let m = initial_motion(&noise, &[sine], 20, 8);
        assert_eq!((m.pre_excitation_samples, m.ratio), (0, None));
    }

    /// A hammer hit at sample 200 of 4096 (64 Hz): a half-sine force and a
    /// decaying 5 Hz response, with 1 % white noise, plus an offset of
    /// `offset` and `drift` m/s^3 on the output from the first sample.
    fn drifting_hit(offset: f64, drift_per_s: f64) -> (Record, f64) {
        let (n, dt_s, hit) = (4096, 1.0 / 64.0, 200);
        let noise = gaussian(7, 2 * n);
        let force: Vec<f64> = (0..n)
            .map(|i| {
                let pulse = if (hit..hit + 3).contains(&i) {
                    100.0
                        * (std::f64::consts::PI * (i - hit) as f64 / 3.0)
                            .sin()
                            .max(0.5)
                } else {
                    0.0
                };
                pulse + 0.5 * noise[i]
            })
            .collect();
        let acc: Vec<f64> = (0..n)
            .map(|i| {
                let t = i as f64 * dt_s;
                let resp = if i >= hit {
                    let tau = t - hit as f64 * dt_s;
                    (-0.15 * 2.0 * std::f64::consts::PI * 5.0 * tau).exp()
                        * (2.0 * std::f64::consts::PI * 5.0 * tau).sin()
                } else {
                    0.0
                };
                resp + 0.01 * noise[n + i] + offset + drift_per_s * t
            })
            .collect();
        let record = Record::new(
            DMatrix::from_row_slice(1, n, &force),
            DMatrix::from_row_slice(1, n, &acc),
        );
        (record, dt_s)
    }

    /// The hit of `drifting_hit` with the record cut to start `k` samples
    /// before the force peak: a fatal late start below
    /// `min_samples_before_hit` (16) samples, none from 16 on, and none
    /// when the check is off (held records).
    #[test]
    fn record_starting_in_the_hit_is_fatal() {
        let names = |s: &str| vec![s.to_string()];
        let (whole, dt_s) = drifting_hit(0.0, 0.0);
        let peak = (0..whole.len())
            .max_by(|&a, &b| whole.inputs[(0, a)].total_cmp(&whole.inputs[(0, b)]))
            .unwrap();
        let cut = |k: usize| {
            let start = peak - k;
            let n = whole.len() - start;
            Record::new(
                whole.inputs.columns(start, n).into_owned(),
                whole.outputs.columns(start, n).into_owned(),
            )
        };
        let late = |q: &HitQuality| {
            q.flags
                .iter()
                .find(|f| f.check == Check::LateStart)
                .cloned()
        };
        let settings = QualitySettings::default();
        for k in [0, 1, 5, 15] {
            let q = assess_hit(&cut(k), dt_s, &names("force"), &names("acc"), &settings);
            let flag = late(&q).unwrap_or_else(|| panic!("k = {k}: {q:?}"));
            assert_eq!(flag.channel.as_deref(), Some("force"));
            assert!(
                flag.message.contains(&format!("peaks at sample {k},")),
                "{}",
                flag.message
            );
            assert!(q.fatal() && !q.passed(), "k = {k}");
        }
        for k in [16, 40, 200] {
            let q = assess_hit(&cut(k), dt_s, &names("force"), &names("acc"), &settings);
            assert!(late(&q).is_none() && !q.fatal(), "k = {k}: {q:?}");
        }
        let held = QualitySettings {
            min_samples_before_hit: 0,
            ..QualitySettings::default()
        };
        let q = assess_hit(&cut(0), dt_s, &names("force"), &names("acc"), &held);
        assert!(late(&q).is_none() && !q.fatal(), "{q:?}");
    }

    /// A channel whose pre-trigger and tail are exactly constant (no noise
    /// at all) at different levels: its move and offset are flagged with
    /// finite z values (they were infinite, null in the JSON), over the
    /// samples' round-off.
    #[test]
    fn noise_free_baselines_give_finite_drift_statistics() {
        let names = |s: &str| vec![s.to_string()];
        let settings = QualitySettings::default();
        let (mut hit, dt_s) = drifting_hit(0.0, 0.0);
        let n = hit.len();
        // Before the hit (sample 200) at 1/64, the second half at 3/64 (the response's
        // peak is near 1): the pre-trigger segment and the tail (its last 10 %) are
        // constants whose sums and means are exact, so their variances are exactly 0.
        for k in 0..n {
            if k < 200 {
                hit.outputs[(0, k)] = 1.0 / 64.0;
            } else if k >= n / 2 {
                hit.outputs[(0, k)] = 3.0 / 64.0;
            }
        }
        let q = assess_hit(&hit, dt_s, &names("force"), &names("acc"), &settings);
        let d = q.channels[1].drift.unwrap();
        assert!(d.significant, "{d:?}");
        // A move of 3.9 % and an offset of 2.0 % of the peak (0.8) over eps times
        // the peak: about 1e14.
        assert!(d.z.is_finite() && d.z > 1e13, "{d:?}");
        assert!(d.offset_z.is_finite() && d.offset_z > 1e13, "{d:?}");
        assert!(q.flags.iter().any(|f| f.check == Check::Drift), "{q:?}");
    }

    /// A drift of 0.3 % of the peak per second (18 % of it over the
    /// 64-s record) is flagged and its line removed; none is flagged
    /// without it.
    #[test]
    fn drift_is_flagged_and_removed() {
        let names = |s: &str| vec![s.to_string()];
        let settings = QualitySettings::default();
        let (clean, dt_s) = drifting_hit(0.0, 0.0);
        let q = assess_hit(&clean, dt_s, &names("force"), &names("acc"), &settings);
        assert!(q.flags.iter().all(|f| f.check != Check::Drift), "{q:?}");
        let d = q.channels[1].drift.unwrap();
        assert!(!d.significant && d.z < settings.drift_z, "{d:?}");
        assert!(d.offset_z < settings.drift_z, "{d:?}");

        let (drifting, _) = drifting_hit(0.02, 0.003);
        let q = assess_hit(&drifting, dt_s, &names("force"), &names("acc"), &settings);
        let flag = q.flags.iter().find(|f| f.check == Check::Drift).unwrap();
        assert_eq!(flag.channel.as_deref(), Some("acc"));
        assert!(!Check::Drift.fails_hit());
        let d = q.channels[1].drift.unwrap();
        // The slope from two means of noise 0.01 over 180 and 410 samples,
        // 60 s apart: standard error 9e-6 per s; 1e-4 is 11 of them.
        assert!((d.per_s - 0.003).abs() < 1e-4, "{d:?}");
        assert!(q.channels[0].drift.is_none_or(|d| !d.significant));

        // The offset of 0.02 is the line's start (within the noise of the
        // 180-sample pre-trigger mean: 0.01 / sqrt(180) = 7e-4, 5 sigma).
        assert!((d.start - 0.02).abs() < 3.5e-3, "{d:?}");
        let campaign = Campaign::new(vec![drifting], dt_s);
        let fixed = remove_drifts(&campaign, std::slice::from_ref(&q));
        let again = assess_hit(
            &fixed.records[0],
            dt_s,
            &names("force"),
            &names("acc"),
            &settings,
        );
        let d = again.channels[1].drift.unwrap();
        assert!(
            !d.significant && d.per_s.abs() < 1e-12 && d.start.abs() < 1e-12,
            "{d:?}"
        );
        // The force was left bit for bit.
        assert_eq!(fixed.records[0].inputs, campaign.records[0].inputs);
        // Nothing to remove: the campaign itself, not a copy.
        let clean = Campaign::new(vec![clean], dt_s);
        let q = assess_campaign(&clean, &settings);
        assert!(matches!(remove_drifts(&clean, &q), Cow::Borrowed(_)));
    }

    /// A baseline that sits off zero without moving is a constant offset:
    /// flagged and the pre-trigger mean subtracted, on the force as on the
    /// outputs. (It was taken as no drift, and a force offset in every hit
    /// of a campaign moved M by 6-23 % with nothing said.)
    #[test]
    fn constant_offset_is_flagged_and_removed() {
        let names = |s: &str| vec![s.to_string()];
        let settings = QualitySettings::default();
        // 0.02 m/s^2 is 2 % of the response's peak and 28 standard errors
        // of the 180-sample pre-trigger mean (0.01 / sqrt(180) = 7e-4).
        let (offset, dt_s) = drifting_hit(0.02, 0.0);
        let q = assess_hit(&offset, dt_s, &names("force"), &names("acc"), &settings);
        let flag = q.flags.iter().find(|f| f.check == Check::Drift).unwrap();
        assert_eq!(flag.channel.as_deref(), Some("acc"));
        assert!(flag.message.contains("constant offset"), "{flag:?}");
        let d = q.channels[1].drift.unwrap();
        assert!(d.significant && d.per_s == 0.0, "{d:?}");
        assert!(
            d.z < settings.drift_z && d.offset_z > settings.drift_z,
            "{d:?}"
        );
        // Within 5 standard errors of the pre-trigger mean.
        assert!((d.start - 0.02).abs() < 3.5e-3, "{d:?}");

        // The same on the force: 1 N is 1 % of the 100 N pulse, 24 standard
        // errors of the pre-trigger mean (0.5 / sqrt(180) = 0.037).
        let (clean, _) = drifting_hit(0.0, 0.0);
        let mut pushed = clean.clone();
        pushed.inputs.add_scalar_mut(1.0);
        let campaign = Campaign::new(vec![pushed], dt_s);
        let q = assess_campaign(&campaign, &settings);
        let d = q[0].channels[0].drift.unwrap();
        assert!(d.significant && d.per_s == 0.0, "{d:?}");
        assert!(q[0].channels[1].drift.is_none_or(|d| !d.significant));
        let fixed = remove_drifts(&campaign, &q);
        // The force back to the clean one but for the pre-trigger mean's
        // noise (within 5 standard errors); the output left bit for bit.
        let back = &fixed.records[0].inputs - &clean.inputs;
        assert!(
            back.iter().all(|v| (v - back[0]).abs() < 1e-12),
            "not a constant"
        );
        assert!(back[0].abs() < 0.19, "{}", back[0]);
        assert_eq!(fixed.records[0].outputs, clean.outputs);
        let again = assess_campaign(&fixed, &settings);
        assert!(
            again[0].flags.iter().all(|f| f.check != Check::Drift),
            "{again:?}"
        );
    }

    /// The RMS of samples whose squares overflow (beyond about 1e154) or
    /// underflow (below about 1e-154) is the RMS of the same samples
    /// scaled into range, times the scale: finite, where the plain sum of
    /// squares gave infinity (written as null in the hit quality JSON of a
    /// record with one sample at 1e200) or 0.
    #[test]
    fn rms_of_huge_and_tiny_samples_is_finite() {
        let x: Vec<f64> = (0..1000).map(|i| ((i as f64) * 0.37).sin()).collect();
        let plain = rms_about(&x, 0.1);
        for scale in [1e200, 1e300, 1e-170, 1e-300] {
            let y: Vec<f64> = x.iter().map(|v| v * scale).collect();
            let r = rms_about(&y, 0.1 * scale);
            // Scaling by a power of ten rounds every sample once (1.1e-16)
            // and the sum of 1000 terms adds up to ~1e-13: 1e-12 is safe.
            assert!(
                (r / scale - plain).abs() <= 1e-12 * plain,
                "{scale:e}: {r:e} against {:e}",
                plain * scale
            );
        }
        // One wild sample among ordinary ones: the RMS is that sample's
        // share, 1e200 / sqrt(n), within rounding (the others add 1e-400
        // of it).
        let mut y = x.clone();
        y[500] = 1e200;
        let r = rms_about(&y, 0.0);
        assert!((r - 1e200 / 1000f64.sqrt()).abs() <= 1e-15 * r, "{r:e}");
        // Ordinary samples keep the plain sum, bit for bit.
        let direct = (x.iter().map(|v| (v - 0.1) * (v - 0.1)).sum::<f64>() / 1000.0).sqrt();
        assert_eq!(plain.to_bits(), direct.to_bits());
        assert_eq!(rms_about(&[0.0, 0.0], 0.0), 0.0);
        assert_eq!(rms_about(&[3.0, 3.0], 3.0), 0.0);
        assert_eq!(rms_about(&[], 1.0), 0.0);
    }

    /// A record with one sample at 1e200 in an output (a transmission
    /// error): every statistic of the channel's quality is finite, so that
    /// none is null in the JSON of the (dropped) hit. The RMS squared its
    /// samples and overflowed to infinity, and `snr_db` with it.
    #[test]
    fn wild_sample_gives_finite_channel_statistics() {
        let names = |s: &str| vec![s.to_string()];
        // -1.7e308: the RMS is finite (3.8e306 over 4096 samples) but over
        // the noise it overflowed, and `snr_db` was infinite.
        for wild in [1e200, -1.7e308] {
            let (mut hit, dt_s) = drifting_hit(0.0, 0.0);
            let n = hit.len();
            hit.outputs[(0, n / 2)] = wild;
            let q = assess_hit(
                &hit,
                dt_s,
                &names("force"),
                &names("acc"),
                &QualitySettings::default(),
            );
            let acc = &q.channels[1];
            assert!(acc.rms.is_finite() && acc.rms > 1e190, "{acc:?}");
            let snr = acc.snr_db.expect("the record has a pre-trigger");
            assert!(snr.is_finite(), "{acc:?}");
            assert!(acc.tail_ratio.is_some_and(f64::is_finite), "{acc:?}");
            assert!(q.crest_factor.is_finite(), "{q:?}");
            // The output's entry has no null field (an input's
            // `tail_ratio` is null by design: an output statistic).
            let json = serde_json::to_string(acc).unwrap();
            assert!(!json.contains("null"), "{json}");
        }
    }

    #[test]
    fn median_of_odd_and_even() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[]), 0.0);
    }

    #[test]
    fn default_settings_are_valid_and_checked() {
        QualitySettings::default().check().unwrap();
        let bad = QualitySettings {
            double_hit_ratio: -1.0,
            ..Default::default()
        };
        assert!(bad.check().unwrap_err().contains("double_hit_ratio"));
    }
}
