//! Decimation of records sampled far above the structure's band.
//!
//! A frame whose modes lie below 20 Hz recorded at 500 Hz gives OKID and
//! ERA records whose modes sit at a few percent of the Nyquist frequency:
//! eight times the samples for the same information, poles crowded near
//! `z = 1`, Hankel matrices that must span many more samples. Such records
//! are decimated before identification, as a spectrum analyzer would
//! have recorded them at the lower rate:
//!
//! - **Band.** The FRFs of the records (H1 of every output to the forces:
//!   hits zero-padded to the longest, or Welch segments of continuous runs)
//!   are summed over the outputs; the modes are the local maxima standing
//!   [`PEAK_OVER_MEDIAN`] times above the median over the analysis band
//!   (up to `fs / 2.56`). The highest one, `f_top`, is the top of the
//!   structural band.
//! - **Factor.** The largest integer `D` with `f_top <= MAX_BAND_FRACTION *
//!   fs / (2 D)`: the modes stay below 0.4 of the new Nyquist frequency
//!   (the analyzer span `fs / 2.56` is 0.78 of it, so the band stays well
//!   inside the flat pass band). `D < 2` leaves the records as they are.
//! - **Filter.** A linear-phase low-pass FIR by the Kaiser window method
//!   (`sim::analyzer::kaiser_lowpass`, the simulator's own analyzer filter):
//!   pass band to `fs_new / 2.56`, stop band from `fs_new / 2` at 100 dB,
//!   applied centred (zero phase: outputs stay aligned with the force) and
//!   evaluated only at the kept samples `0, D, 2D, ...`. Samples before a
//!   record read as zero (a structure at rest before the record, as OKID
//!   assumes unless told otherwise); kept samples whose filter reaches past
//!   the record's end are dropped (`dropped_end_samples`). The records are
//!   then band-limited records at the new rate, which the default
//!   `bandlimited` intersample model describes.

use ident::Campaign;
use ident::frf::estimate::{Averaging, FrfParams, HitAveraging, WelchAveraging};
use nalgebra::DMatrix;
use serde::Serialize;

/// Upper edge of the structural band as a fraction of the new Nyquist
/// frequency: 0.4. ERA/DC and the band-limited OKID model are accurate for
/// modes up to 0.3 of the Nyquist frequency (paper case 1 at 64 Hz: 9.15 Hz,
/// 0.29) and the analyzer span reaches 0.78 of it; 0.4 keeps the top mode
/// inside both with room for its half-power band.
pub const MAX_BAND_FRACTION: f64 = 0.4;

/// Longest block of a hammer record searched for the modes' peaks: 65536
/// samples (a line spacing of `fs / 65536`: 0.008 Hz at 512 Hz, finer than
/// the half-power band of a 0.1 %-damped mode at 4 Hz). A hammer response
/// that has not died away within it still shows its peaks, widened.
pub const PEAK_BLOCK: usize = 1 << 16;

/// A peak of the summed FRF magnitude squared counts as a mode when it is
/// this many times the median over the analysis band: 10 (10 dB). Lightly
/// damped modes (damping below 5 %) peak 20 dB and more above the mass line
/// that fills the band above them (paper case 1: 40 dB and more); the
/// scatter of H1 over a few averages at 1 % noise is well under a factor 2.
pub const PEAK_OVER_MEDIAN: f64 = 10.0;

/// Stop-band attenuation of the decimation filter, dB: the simulator's
/// analyzer default, below the 16-bit quantization of rig ADCs.
pub const ATTENUATION_DB: f64 = 100.0;

/// What `--decimate` asks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum DecimationSetting {
    /// Decimate by the factor the modes' band allows (see the module docs).
    #[default]
    Auto,
    /// Never decimate.
    Off,
    /// Decimate by this factor (1: not at all).
    Factor(usize),
}

impl std::str::FromStr for DecimationSetting {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.trim() {
            "auto" => Ok(Self::Auto),
            "off" => Ok(Self::Off),
            t => match t.parse::<usize>() {
                Ok(n) if n >= 1 => Ok(Self::Factor(n)),
                _ => Err(format!(
                    "expected auto, off or a decimation factor of 1 or more, got '{s}'"
                )),
            },
        }
    }
}

/// The decimation filter.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DecimationFilter {
    /// `kaiser-fir`: linear-phase FIR by the Kaiser window method, applied
    /// centred (zero phase).
    pub kind: &'static str,
    /// Taps (odd).
    pub taps: usize,
    /// Pass-band edge, Hz.
    pub passband_hz: f64,
    /// Stop-band edge, Hz.
    pub stopband_hz: f64,
    /// Stop-band attenuation, dB.
    pub attenuation_db: f64,
}

/// What was done to the sampling rate, and why.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Decimation {
    /// Samples of the records per sample kept (1: not decimated).
    pub factor: usize,
    /// Rate of the records as read, Hz.
    pub original_rate_hz: f64,
    /// Rate identified, Hz.
    pub rate_hz: f64,
    /// How the factor was chosen: `auto` or `given` (`--decimate N`).
    pub chosen: &'static str,
    /// Highest mode found in the records' FRFs, Hz (null when not searched
    /// or none stands out).
    pub highest_mode_hz: Option<f64>,
    /// Every mode found by the peak search, Hz, ascending.
    pub peaks_hz: Vec<f64>,
    /// The filter (null when not decimated).
    pub filter: Option<DecimationFilter>,
    /// Samples dropped at the end of every record (the filter would read
    /// past it), at the original rate.
    pub dropped_end_samples: usize,
    /// Half the filter's length in samples at the new rate: the samples at
    /// the start of a record that the filter mixes with the zeros assumed
    /// before it (cut when the structure is not at rest).
    pub settling_samples: usize,
    /// Why this factor, in words.
    pub reason: String,
}

/// The structural band of `campaign` from its FRFs: the frequencies of the
/// peaks (ascending, Hz), see the module docs. `continuous` chooses Welch
/// segments over one block per hit.
pub fn mode_peaks_hz(campaign: &Campaign, continuous: bool) -> Vec<f64> {
    // Hammer records longer than PEAK_BLOCK: the peaks are sought in one
    // block of that length per hit, from a sixteenth of it before the
    // force's peak (an FFT of the whole record would cost memory in
    // proportion to it: 270 MB at 10^6 samples).
    let longest = campaign.records.iter().map(|r| r.len()).max().unwrap_or(0);
    if !continuous && longest > PEAK_BLOCK {
        let records = campaign
            .records
            .iter()
            .map(|r| {
                let n = r.len();
                let len = n.min(PEAK_BLOCK);
                let peak = (0..n)
                    .max_by(|&a, &b| {
                        let at = |k: usize| r.inputs.column(k).amax();
                        at(a).total_cmp(&at(b))
                    })
                    .unwrap_or(0);
                let start = peak.saturating_sub(PEAK_BLOCK / 16).min(n - len);
                ident::Record::new(
                    r.inputs.columns(start, len).into_owned(),
                    r.outputs.columns(start, len).into_owned(),
                )
            })
            .collect();
        let blocks = Campaign::named(
            records,
            campaign.dt_s,
            campaign.inputs.clone(),
            campaign.outputs.clone(),
            campaign.labels.clone(),
        );
        return mode_peaks_hz(&blocks, false);
    }
    let lengths: Vec<usize> = campaign.records.iter().map(|r| r.len()).collect();
    let shortest = lengths.iter().copied().min().unwrap_or(0);
    let longest = lengths.iter().copied().max().unwrap_or(0);
    let params = if continuous {
        // Eight segments of the shortest run at least, a power of two.
        let mut len = 1usize;
        while len * 2 <= (shortest / 8).max(64) {
            len *= 2;
        }
        FrfParams::hits().averaging(Averaging::Welch(WelchAveraging::new(len.min(shortest))))
    } else {
        FrfParams::hits().averaging(Averaging::Hits(HitAveraging {
            block_len: Some(longest),
            ..Default::default()
        }))
    };
    let Ok(est) = params.estimate(&campaign.records, campaign.dt_s) else {
        return Vec::new();
    };
    let f = &est.frf.frequency_hz;
    let band_hz = 1.0 / (2.56 * campaign.dt_s);
    let s: Vec<f64> = est
        .frf
        .values
        .iter()
        .map(|h| h.iter().map(|z| z.norm_sqr()).sum())
        .collect();
    let inside: Vec<usize> = (1..f.len()).filter(|&k| f[k] <= band_hz).collect();
    if inside.len() < 8 {
        return Vec::new();
    }
    let mut sorted: Vec<f64> = inside.iter().map(|&k| s[k]).collect();
    sorted.sort_by(f64::total_cmp);
    let median = sorted[sorted.len() / 2];
    // A local maximum over +-3 lines (a resonance spans several lines; the
    // scatter of a noisy line does not make its neighbours a peak).
    let half = 3;
    inside
        .iter()
        .copied()
        .filter(|&k| {
            let lo = k.saturating_sub(half).max(1);
            let hi = (k + half).min(f.len() - 1);
            s[k] > PEAK_OVER_MEDIAN * median && (lo..=hi).all(|j| j == k || s[j] < s[k])
        })
        .map(|k| f[k])
        .collect()
}

/// Margin above the highest frequency of `--modes` taken as the top of the
/// band: 1.1 (the structural mode nearest a given frequency is what is
/// chosen; a guess 10 % low still keeps the mode inside
/// [`MAX_BAND_FRACTION`] of the new Nyquist frequency, which leaves room
/// up to 0.4 of it).
pub const MODES_MARGIN: f64 = 1.1;

/// The factor for `setting` on `campaign` (records at `1 / dt_s`),
/// with the peaks found and the reason. When the user chose the model's
/// modes (`--band` or `--modes` in `modes`), the band's top (or the highest
/// frequency given, times [`MODES_MARGIN`]) decides instead of the highest
/// peak of the records: modes above it are not wanted, and the decimation
/// filter takes them out.
pub fn choose(
    campaign: &Campaign,
    continuous: bool,
    setting: DecimationSetting,
    modes: &ident::ModeSelection,
) -> (usize, Vec<f64>, String) {
    let fs = 1.0 / campaign.dt_s;
    match setting {
        DecimationSetting::Off => (1, Vec::new(), "--decimate off".into()),
        DecimationSetting::Factor(d) => (d, Vec::new(), format!("--decimate {d}")),
        DecimationSetting::Auto => {
            let chosen_top = match modes {
                ident::ModeSelection::Band { high_hz, .. } => {
                    Some((*high_hz, format!("the top of --band, {} Hz,", records::numfmt::sig(*high_hz, 4))))
                }
                ident::ModeSelection::Near { frequencies_hz } => frequencies_hz
                    .iter()
                    .copied()
                    .fold(None, |m: Option<f64>, f| Some(m.map_or(f, |m| m.max(f))))
                    .map(|f| {
                        (
                            MODES_MARGIN * f,
                            format!(
                                "the highest of --modes, {} Hz, with a {MODES_MARGIN} margin ({} Hz),",
                                records::numfmt::sig(f, 4),
                                records::numfmt::sig(MODES_MARGIN * f, 4)
                            ),
                        )
                    }),
                ident::ModeSelection::Auto => None,
            };
            if let Some((top, what)) = chosen_top {
                let peaks: Vec<f64> = mode_peaks_hz(campaign, continuous)
                    .into_iter()
                    .filter(|&f| f <= top)
                    .collect();
                let d = ((MAX_BAND_FRACTION * fs / (2.0 * top)).floor() as usize).max(1);
                let sig = |x: f64| records::numfmt::sig(x, 4);
                let reason = if d < 2 {
                    format!(
                        "{what} is at {} of the Nyquist frequency ({} Hz): no room to decimate",
                        sig(top / (fs / 2.0)),
                        sig(fs / 2.0)
                    )
                } else {
                    format!(
                        "{what} is at {} of the Nyquist frequency ({} Hz); the largest factor keeping it below {MAX_BAND_FRACTION} of the new one is {d} ({} Hz, Nyquist {} Hz); modes above it are filtered out",
                        sig(top / (fs / 2.0)),
                        sig(fs / 2.0),
                        sig(fs / d as f64),
                        sig(fs / (2.0 * d as f64))
                    )
                };
                return (d, peaks, reason);
            }
            let peaks = mode_peaks_hz(campaign, continuous);
            let Some(&top) = peaks.last() else {
                return (
                    1,
                    peaks,
                    "no mode stands out in the records' FRFs: not decimated".into(),
                );
            };
            let d = (MAX_BAND_FRACTION * fs / (2.0 * top)).floor() as usize;
            let sig = |x: f64| records::numfmt::sig(x, 4);
            if d < 2 {
                let reason = format!(
                    "the highest mode, {} Hz, is at {} of the Nyquist frequency ({} Hz): no room to decimate (the modes must stay below {MAX_BAND_FRACTION} of it)",
                    sig(top),
                    sig(top / (fs / 2.0)),
                    sig(fs / 2.0)
                );
                (1, peaks, reason)
            } else {
                let reason = format!(
                    "the highest mode, {} Hz, is at {} of the Nyquist frequency ({} Hz); the largest factor keeping it below {MAX_BAND_FRACTION} of the new one is {d} ({} Hz, Nyquist {} Hz)",
                    sig(top),
                    sig(top / (fs / 2.0)),
                    sig(fs / 2.0),
                    sig(fs / d as f64),
                    sig(fs / (2.0 * d as f64))
                );
                (d, peaks, reason)
            }
        }
    }
}

/// `campaign` decimated by `factor` (see the module docs); `factor` 1
/// returns it unchanged. Records too short to keep a sample are kept whole
/// (the identifier refuses them by length).
pub fn decimate(campaign: &Campaign, factor: usize) -> (Campaign, Option<DecimationFilter>, usize) {
    if factor <= 1 {
        return (campaign.clone(), None, 0);
    }
    let fs = 1.0 / campaign.dt_s;
    let fs_new = fs / factor as f64;
    let pass = fs_new / 2.56;
    let stop = fs_new / 2.0;
    let taps = sim::analyzer::kaiser_lowpass(fs, pass, stop, ATTENUATION_DB);
    let half = taps.len() / 2;
    let filter = |x: &[f64], kept: usize| -> Vec<f64> {
        (0..kept)
            .map(|n| {
                let c = n * factor;
                let mut acc = 0.0;
                for (j, h) in taps.iter().enumerate() {
                    // Sample c + j - half; zero before the record.
                    if let Some(i) = (c + j).checked_sub(half) {
                        acc += h * x[i];
                    }
                }
                acc
            })
            .collect()
    };
    let records = campaign
        .records
        .iter()
        .map(|rec| {
            let n = rec.len();
            // Kept samples c = k D with c + half <= n - 1.
            let kept = if n > half {
                (n - 1 - half) / factor + 1
            } else {
                0
            };
            let mat = |m: &DMatrix<f64>| -> DMatrix<f64> {
                let rows: Vec<Vec<f64>> = (0..m.nrows())
                    .map(|i| {
                        let x: Vec<f64> = m.row(i).iter().copied().collect();
                        filter(&x, kept)
                    })
                    .collect();
                DMatrix::from_fn(m.nrows(), kept, |i, k| rows[i][k])
            };
            ident::Record::new(mat(&rec.inputs), mat(&rec.outputs))
        })
        .collect();
    let out = Campaign::named(
        records,
        campaign.dt_s * factor as f64,
        campaign.inputs.clone(),
        campaign.outputs.clone(),
        campaign.labels.clone(),
    );
    let info = DecimationFilter {
        kind: "kaiser-fir",
        taps: taps.len(),
        passband_hz: pass,
        stopband_hz: stop,
        attenuation_db: ATTENUATION_DB,
    };
    (out, Some(info), half)
}

#[cfg(test)]
mod tests {
    use super::*;
    use ident::Record;

    /// A sine well inside the new band passes unchanged (at the kept
    /// samples) and one above the new Nyquist frequency is removed.
    #[test]
    fn passes_the_band_and_stops_what_would_alias() {
        let fs = 512.0;
        let n = 4096;
        let sine = |f: f64| -> Vec<f64> {
            (0..n)
                .map(|i| (2.0 * std::f64::consts::PI * f * i as f64 / fs).sin())
                .collect()
        };
        let low = sine(10.0);
        let high = sine(50.0);
        let rec = Record::new(
            DMatrix::from_row_slice(1, n, &high),
            DMatrix::from_row_slice(1, n, &low),
        );
        let c = Campaign::new(vec![rec], 1.0 / fs);
        let (d, filter, half) = decimate(&c, 8);
        let filter = filter.unwrap();
        assert_eq!(d.dt_s, 8.0 / fs);
        assert!(filter.taps % 2 == 1 && filter.taps / 2 == half);
        let out = &d.records[0];
        // Away from the start (where zeros before the record enter the filter).
        let settle = half / 8 + 1;
        for k in settle..out.len() {
            // 10 Hz, in the pass band: the Kaiser design's ripple is 1e-5 of
            // the amplitude at 100 dB (measured 4.0e-6); 1e-4 leaves a
            // factor 10.
            assert!((out.outputs[(0, k)] - low[8 * k]).abs() < 1e-4, "k = {k}");
            // 50 Hz, beyond the new Nyquist frequency (32 Hz) and in the stop
            // band: attenuated by 100 dB, 1e-5 of the amplitude (measured
            // 4.0e-7); 1e-4 ditto.
            assert!(out.inputs[(0, k)].abs() < 1e-4, "k = {k}");
        }
        // Every kept sample's filter lies inside the record.
        assert!(8 * (out.len() - 1) + half < n);
        assert!(8 * out.len() + half >= n);
    }

    #[test]
    fn settings_parse() {
        assert_eq!("auto".parse(), Ok(DecimationSetting::Auto));
        assert_eq!("off".parse(), Ok(DecimationSetting::Off));
        assert_eq!("4".parse(), Ok(DecimationSetting::Factor(4)));
        assert!("0".parse::<DecimationSetting>().is_err());
        assert!("x".parse::<DecimationSetting>().is_err());
    }
}
