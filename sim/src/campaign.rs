//! Campaigns: several hammer hits (or shaker records) on one floor,
//! recorded by the analyzer chain (or held), with the rig's effects and
//! noise; and the truth they were simulated from.
//!
//! # Random streams
//! All randomness comes from ChaCha8 streams derived from the campaign seed
//! with [`derive_seed`] and a tag: 1 the hammer pulses, 2 the white noise,
//! 3 the shaker signals, 4 the coloured noise. A stream is only created
//! when its feature is on, and switching a feature on never changes what
//! the other streams draw.
//!
//! # Order of the recording operations
//! For every channel of every record: the plant and the analyzer chain (or
//! the hold) give the clean channel; then the channel gain
//! ([`crate::rig::ChannelError`]); white noise, then coloured noise (their
//! levels from the RMS of the channel at this point); offset and drift; the
//! ADC (clipping, quantization); last the force polarity.

use rand::SeedableRng;
use rand::rngs::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::analyzer::AnalyzerSettings;
use crate::error::{SimError, positive};
use crate::excitation::{Excitation, RecordTiming};
use crate::hammer::{HammerSettings, Pulse};
use crate::model::Model;
use crate::noise::{NoiseSettings, add_white, rms};
use crate::response::{AnalyzerEngine, Channels, HeldEngine, SignalEngine};
use crate::rig::{ChannelErrors, Plant, RigSettings, RigTruth};

/// Analysis sampling of the records.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Sampling {
    /// Analysis sample rate, Hz (default 64).
    #[serde(default = "default_rate")]
    pub sample_rate_hz: f64,
    /// Samples per record (default 2048).
    #[serde(default = "default_samples")]
    pub samples: usize,
    /// Samples recorded before the trigger instant (nominal hit time).
    #[serde(default = "default_pretrigger")]
    pub pretrigger_samples: usize,
}

fn default_rate() -> f64 {
    64.0
}
fn default_samples() -> usize {
    2048
}
fn default_pretrigger() -> usize {
    32
}

impl Default for Sampling {
    fn default() -> Self {
        Sampling {
            sample_rate_hz: default_rate(),
            samples: default_samples(),
            pretrigger_samples: default_pretrigger(),
        }
    }
}

impl Sampling {
    /// Sample interval, s.
    pub fn dt_s(&self) -> f64 {
        1.0 / self.sample_rate_hz
    }
}

/// How the records are acquired.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case", deny_unknown_fields)]
pub enum Acquisition {
    /// Spectrum-analyzer chain: analog anti-alias filter, high-rate ADC,
    /// decimation FIR. Records are band-limited.
    Analyzer(AnalyzerSettings),
    /// Force held constant over each analysis sample (zero-order hold), no
    /// analyzer chain: the discrete model is exactly the ZOH one.
    Held,
}

impl Default for Acquisition {
    fn default() -> Self {
        Acquisition::Analyzer(AnalyzerSettings::default())
    }
}

/// Everything about a campaign except the structure.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CampaignSettings {
    /// Hits (records) per campaign.
    pub hits: usize,
    /// The impact hammer (`[campaign.hammer]`); its floor is the input
    /// floor for every excitation.
    pub hammer: HammerSettings,
    /// Analysis sampling.
    #[serde(default)]
    pub sampling: Sampling,
    /// How the records are acquired (analyzer chain by default).
    #[serde(default)]
    pub acquisition: Acquisition,
    /// Measurement noise and ADC.
    #[serde(default)]
    pub noise: NoiseSettings,
    /// Record the force with inverted sign (a reversed hammer or
    /// accelerometer polarity, as in the paper's case 2).
    #[serde(default)]
    pub invert_force_polarity: bool,
    /// Shaker excitation instead of the hammer (`[campaign.excitation]`).
    /// The `[campaign.hammer]` table is still required and must name the
    /// shaker's floor: it is where the rest of the harness reads the input
    /// floor.
    #[serde(default, skip_serializing_if = "Excitation::is_hammer")]
    pub excitation: Excitation,
    /// Rig effects (`[campaign.rig]`), all off by default.
    #[serde(default, skip_serializing_if = "RigSettings::is_off")]
    pub rig: RigSettings,
}

impl CampaignSettings {
    /// Timing of one record: trigger instant and record length, s.
    pub fn timing(&self) -> RecordTiming {
        let dt = self.sampling.dt_s();
        RecordTiming {
            trigger_s: self.sampling.pretrigger_samples as f64 * dt,
            record_s: self.sampling.samples as f64 * dt,
        }
    }
}

/// One recorded hit (or shaker record).
#[derive(Debug, Clone, PartialEq)]
pub struct Hit {
    /// The pulses actually applied (truth); empty for shaker records.
    pub pulses: Vec<Pulse>,
    /// Recorded force at the hit floor, N.
    pub force: Vec<f64>,
    /// Recorded absolute acceleration of every floor, m/s^2.
    pub accelerations: Vec<Vec<f64>>,
}

/// A simulated campaign.
#[derive(Debug, Clone, PartialEq)]
pub struct Campaign {
    /// Sample interval of the records, s.
    pub dt_s: f64,
    /// Hit floor, 1-based.
    pub hit_floor: usize,
    /// The records, in order.
    pub hits: Vec<Hit>,
}

#[derive(Debug, Clone)]
enum Engine {
    Analyzer(Box<AnalyzerEngine>),
    Held(HeldEngine),
    /// Shaker signal through the analyzer chain.
    Signal(Box<SignalEngine>),
    /// Shaker signal held per analysis sample.
    HeldSignal(HeldEngine),
}

/// A model and campaign settings, checked, with the response engine built
/// once; [`Simulator::simulate`] then draws campaigns cheaply.
#[derive(Debug, Clone)]
pub struct Simulator {
    model: Model,
    settings: CampaignSettings,
    engine: Engine,
    plant: Plant,
    channel_errors: Option<ChannelErrors>,
}

/// Largest campaign held in memory, bytes: hits x samples x channels x 8.
/// A simulated campaign (and every trial of a sweep, one per worker
/// thread) is held whole; 4 GiB leaves room on a 16 GB machine and is
/// about 25 000 hits of the paper's records.
pub const MAX_CAMPAIGN_BYTES: u64 = 4 << 30;

/// Refuses a campaign whose samples would not fit in
/// [`MAX_CAMPAIGN_BYTES`], naming the field that makes it too large.
fn check_campaign_size(hits: usize, samples: usize, channels: usize) -> Result<(), SimError> {
    let gib = |b: u128| b as f64 / (1u64 << 30) as f64;
    let record = samples as u128 * channels as u128 * 8;
    if record > MAX_CAMPAIGN_BYTES as u128 {
        return Err(SimError::invalid(
            "sampling.samples",
            format!(
                "{samples} samples x {channels} channels need {:.1} GiB per record; at most {:.0} GiB of samples are held in memory",
                gib(record),
                gib(MAX_CAMPAIGN_BYTES as u128)
            ),
        ));
    }
    let total = record * hits as u128;
    if total > MAX_CAMPAIGN_BYTES as u128 {
        return Err(SimError::invalid(
            "hits",
            format!(
                "{hits} hits of {samples} samples x {channels} channels need {:.1} GiB; at most {:.0} GiB of samples are held in memory",
                gib(total),
                gib(MAX_CAMPAIGN_BYTES as u128)
            ),
        ));
    }
    Ok(())
}

impl Simulator {
    /// Checks the settings against the model and builds the response
    /// engine. Errors name the field relative to `[campaign]`.
    pub fn new(model: Model, settings: CampaignSettings) -> Result<Self, SimError> {
        let n = model.dofs();
        if settings.hits == 0 {
            return Err(SimError::invalid("hits", "must be at least 1"));
        }
        settings.hammer.check(n)?;
        settings.noise.check()?;
        settings.rig.check(n)?;
        let s = &settings.sampling;
        let fs = positive("sampling.sample_rate_hz", s.sample_rate_hz)?;
        if s.samples < 16 {
            return Err(SimError::invalid(
                "sampling.samples",
                format!("must be at least 16, got {}", s.samples),
            ));
        }
        if s.pretrigger_samples >= s.samples {
            return Err(SimError::invalid(
                "sampling.pretrigger_samples",
                format!("must be below the record length {}", s.samples),
            ));
        }
        check_campaign_size(settings.hits, s.samples, n + 1)?;
        if let Some(crate::noise::ColouredNoise {
            spectrum:
                crate::noise::NoiseSpectrum::Pink {
                    min_frequency_hz: Some(f),
                },
            ..
        }) = &settings.noise.coloured
            && *f >= fs / 2.0
        {
            return Err(SimError::invalid(
                "noise.coloured.spectrum.min_frequency_hz",
                format!(
                    "must be below the Nyquist frequency ({} Hz), got {f} Hz",
                    fs / 2.0
                ),
            ));
        }
        let design = match &settings.acquisition {
            Acquisition::Analyzer(a) => Some(a.design(fs)?),
            Acquisition::Held => None,
        };
        if let Some(floor) = settings.excitation.floor() {
            let grid_rate = design.as_ref().map_or(fs, |d| d.internal_rate_hz);
            settings.excitation.check(n, grid_rate, settings.timing())?;
            if floor != settings.hammer.floor {
                return Err(SimError::invalid(
                    "excitation.floor",
                    format!(
                        "the shaker drives floor {floor} but hammer.floor is {}; they must agree (the input floor is read from the hammer table)",
                        settings.hammer.floor
                    ),
                ));
            }
        }
        let input = settings.hammer.floor - 1;
        let plant = Plant::new(&model, input, &settings.rig);
        let shaker = !settings.excitation.is_hammer();
        let engine = match (&design, shaker) {
            (Some(design), false) => Engine::Analyzer(Box::new(AnalyzerEngine::with_plant(
                &plant,
                settings.hammer.duration_s,
                1.0 / fs,
                s.samples,
                design,
            ))),
            (None, false) => Engine::Held(HeldEngine::with_plant(&plant, 1.0 / fs, s.samples)),
            (Some(design), true) => Engine::Signal(Box::new(SignalEngine::new(
                &plant,
                1.0 / fs,
                s.samples,
                design,
            ))),
            (None, true) => Engine::HeldSignal(HeldEngine::with_plant(&plant, 1.0 / fs, s.samples)),
        };
        let channel_errors = settings.rig.channel_errors(n);
        Ok(Simulator {
            model,
            settings,
            engine,
            plant,
            channel_errors,
        })
    }

    /// The structural model (the truth).
    pub fn model(&self) -> &Model {
        &self.model
    }

    /// The campaign settings.
    pub fn settings(&self) -> &CampaignSettings {
        &self.settings
    }

    /// The continuous system from the applied force to the channels as
    /// delivered to the analyzer (structure plus the rig's continuous
    /// effects).
    pub fn plant(&self) -> &Plant {
        &self.plant
    }

    /// The truth of the rig effects (extra modes, sensor dynamics, channel
    /// errors).
    pub fn rig_truth(&self) -> RigTruth {
        RigTruth::new(&self.settings.rig, self.model.dofs())
    }

    /// Recorded channel per unit applied force at `frequency_hz`, before the
    /// analyzer chain (which is common to all channels) and the noise:
    /// channel 0 the recorded force, 1 + j the recorded acceleration of
    /// floor j + 1, channel gains included. The ratio of channel 1 + j to
    /// channel 0 is the accelerance an ideal identification of these
    /// records finds.
    pub fn recorded_frf(&self, frequency_hz: f64) -> Vec<num_complex::Complex64> {
        let mut h = self.plant.frf(frequency_hz);
        if let Some(e) = &self.channel_errors {
            for (v, g) in h.iter_mut().zip(&e.gain) {
                *v *= *g;
            }
        }
        h
    }

    /// Noise-free channels (force, then accelerations) for given pulses:
    /// the plant and the analyzer chain (or hold), without channel errors.
    ///
    /// # Panics
    /// For shaker excitation (use [`Simulator::clean_records`]).
    pub fn clean_response(&self, pulses: &[Pulse]) -> Channels {
        match &self.engine {
            Engine::Analyzer(e) => e.response(pulses),
            Engine::Held(e) => e.response(pulses),
            Engine::Signal(_) | Engine::HeldSignal(_) => {
                panic!("clean_response takes hammer pulses; this campaign uses a shaker")
            }
        }
    }

    /// The pulses of every hit for a seed (empty for shaker excitation).
    /// Pulses and noise use separate random streams derived from the seed,
    /// so campaigns with the same seed and different noise levels share
    /// their pulses.
    pub fn draw_pulses(&self, seed: u64) -> Vec<Vec<Pulse>> {
        if !self.settings.excitation.is_hammer() {
            return vec![Vec::new(); self.settings.hits];
        }
        let mut rng = ChaCha8Rng::seed_from_u64(derive_seed(seed, 1));
        let trigger =
            self.settings.sampling.pretrigger_samples as f64 * self.settings.sampling.dt_s();
        (0..self.settings.hits)
            .map(|_| self.settings.hammer.draw(&mut rng, trigger))
            .collect()
    }

    /// Noise-free channels of a shaker record: the signal drawn from `rng`
    /// (the shaker stream) through the plant and the chain (or hold).
    fn shaker_response(&self, rng: &mut ChaCha8Rng) -> Channels {
        let timing = self.settings.timing();
        let ex = &self.settings.excitation;
        let lead_in = match ex {
            Excitation::Random(r) => r.lead_in_s,
            _ => 0.0,
        };
        let dt = self.settings.sampling.dt_s();
        match &self.engine {
            Engine::Signal(e) => {
                let rate = self.settings.sampling.sample_rate_hz * e.oversampling() as f64;
                // One internal step before the start, where the force is 0.
                let start = timing.trigger_s - lead_in;
                let first = (start * rate).ceil() as i64 - 1;
                let count = (e.last_index() - first + 1) as usize;
                let u = ex.force_samples(rate, first, count, timing, rng);
                e.response(&u, first)
            }
            Engine::HeldSignal(e) => {
                let start = timing.trigger_s - lead_in;
                let first = ((start / dt).ceil() as i64).min(0);
                let count = (self.settings.sampling.samples as i64 - first) as usize;
                let u = ex.force_samples(1.0 / dt, first, count, timing, rng);
                e.response_to_held(&u, first)
            }
            Engine::Analyzer(_) | Engine::Held(_) => unreachable!("hammer engines"),
        }
    }

    /// Noise-free records of the campaign of `seed`, as recorded (channel
    /// gains, offsets and drifts included, force polarity applied): what
    /// [`Simulator::simulate`] returns without noise and ADC.
    pub fn clean_records(&self, seed: u64) -> Vec<Channels> {
        let pulses = self.draw_pulses(seed);
        let mut shaker_rng = ChaCha8Rng::seed_from_u64(derive_seed(seed, 3));
        let dt = self.settings.sampling.dt_s();
        pulses
            .iter()
            .map(|p| {
                let mut ch = if self.settings.excitation.is_hammer() {
                    self.clean_response(p)
                } else {
                    self.shaker_response(&mut shaker_rng)
                };
                for (c, channel) in ch.iter_mut().enumerate() {
                    if let Some(e) = &self.channel_errors {
                        e.apply_gain(c, channel);
                        e.apply_offset(c, channel, dt);
                    }
                }
                if self.settings.invert_force_polarity {
                    ch[0].iter_mut().for_each(|v| *v = -*v);
                }
                ch
            })
            .collect()
    }

    /// Simulates a campaign. Bit-identical for the same seed.
    pub fn simulate(&self, seed: u64) -> Campaign {
        self.simulate_with_noise(seed, &self.settings.noise)
    }

    /// Simulates a campaign with other noise settings than the scenario's
    /// (a noise sweep reuses one simulator). The pulses (or shaker signals)
    /// depend on the seed only, and the normal draws do not depend on the
    /// noise level, so campaigns differing only in noise level share their
    /// excitation and the shape of their noise.
    pub fn simulate_with_noise(&self, seed: u64, noise: &NoiseSettings) -> Campaign {
        let pulses = self.draw_pulses(seed);
        let mut rng = ChaCha8Rng::seed_from_u64(derive_seed(seed, 2));
        let mut shaker_rng = (!self.settings.excitation.is_hammer())
            .then(|| ChaCha8Rng::seed_from_u64(derive_seed(seed, 3)));
        let mut coloured_rng = noise
            .coloured
            .as_ref()
            .map(|_| ChaCha8Rng::seed_from_u64(derive_seed(seed, 4)));
        let dt = self.settings.sampling.dt_s();
        let sign = if self.settings.invert_force_polarity {
            -1.0
        } else {
            1.0
        };
        let hits = pulses
            .into_iter()
            .map(|p| {
                let mut ch = match &mut shaker_rng {
                    None => self.clean_response(&p),
                    Some(r) => self.shaker_response(r),
                };
                for (c, channel) in ch.iter_mut().enumerate() {
                    let is_force = c == 0;
                    if let Some(e) = &self.channel_errors {
                        e.apply_gain(c, channel);
                    }
                    let clean_rms = rms(channel);
                    add_white(channel, noise.sigma(clean_rms, is_force), &mut rng);
                    if let (Some(col), Some(r)) = (&noise.coloured, &mut coloured_rng) {
                        col.add(channel, clean_rms, is_force, dt, r);
                    }
                    if let Some(e) = &self.channel_errors {
                        e.apply_offset(c, channel, dt);
                    }
                    noise.digitize(channel, is_force);
                }
                let mut force = ch.remove(0);
                force.iter_mut().for_each(|v| *v *= sign);
                Hit {
                    pulses: p,
                    force,
                    accelerations: ch,
                }
            })
            .collect();
        Campaign {
            dt_s: self.settings.sampling.dt_s(),
            hit_floor: self.settings.hammer.floor,
            hits,
        }
    }
}

/// Independent 64-bit seeds from a base seed and a stream tag (SplitMix64
/// finalizer over the combination).
pub fn derive_seed(seed: u64, tag: u64) -> u64 {
    let mut z = seed ^ tag.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}
