//! Hammer campaigns: several hits on one floor, recorded by the analyzer
//! chain (or held), with noise; and the truth they were simulated from.

use rand::SeedableRng;
use rand::rngs::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::analyzer::AnalyzerSettings;
use crate::error::{SimError, positive};
use crate::hammer::{HammerSettings, Pulse};
use crate::model::Model;
use crate::noise::NoiseSettings;
use crate::response::{AnalyzerEngine, Channels, HeldEngine};

/// Analysis sampling of the records.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Sampling {
    #[serde(default = "default_rate")]
    pub sample_rate_hz: f64,
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
    pub hits: usize,
    pub hammer: HammerSettings,
    #[serde(default)]
    pub sampling: Sampling,
    #[serde(default)]
    pub acquisition: Acquisition,
    #[serde(default)]
    pub noise: NoiseSettings,
    /// Record the force with inverted sign (a reversed hammer or
    /// accelerometer polarity, as in the paper's case 2).
    #[serde(default)]
    pub invert_force_polarity: bool,
}

/// One recorded hit.
#[derive(Debug, Clone, PartialEq)]
pub struct Hit {
    /// The pulses actually applied (truth).
    pub pulses: Vec<Pulse>,
    /// Recorded force at the hit floor, N.
    pub force: Vec<f64>,
    /// Recorded absolute acceleration of every floor, m/s^2.
    pub accelerations: Vec<Vec<f64>>,
}

/// A simulated campaign.
#[derive(Debug, Clone, PartialEq)]
pub struct Campaign {
    pub dt_s: f64,
    /// Hit floor, 1-based.
    pub hit_floor: usize,
    pub hits: Vec<Hit>,
}

#[derive(Debug, Clone)]
enum Engine {
    Analyzer(Box<AnalyzerEngine>),
    Held(HeldEngine),
}

/// A model and campaign settings, checked, with the response engine built
/// once; [`Simulator::simulate`] then draws campaigns cheaply.
#[derive(Debug, Clone)]
pub struct Simulator {
    model: Model,
    settings: CampaignSettings,
    engine: Engine,
}

impl Simulator {
    pub fn new(model: Model, settings: CampaignSettings) -> Result<Self, SimError> {
        let n = model.dofs();
        if settings.hits == 0 {
            return Err(SimError::invalid("hits", "must be at least 1"));
        }
        settings.hammer.check(n)?;
        settings.noise.check()?;
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
        let input = settings.hammer.floor - 1;
        let engine = match &settings.acquisition {
            Acquisition::Analyzer(a) => {
                let design = a.design(fs)?;
                Engine::Analyzer(Box::new(AnalyzerEngine::new(
                    &model,
                    input,
                    settings.hammer.duration_s,
                    1.0 / fs,
                    s.samples,
                    &design,
                )))
            }
            Acquisition::Held => Engine::Held(HeldEngine::new(&model, input, 1.0 / fs, s.samples)),
        };
        Ok(Simulator {
            model,
            settings,
            engine,
        })
    }

    pub fn model(&self) -> &Model {
        &self.model
    }

    pub fn settings(&self) -> &CampaignSettings {
        &self.settings
    }

    /// Noise-free channels (force, then accelerations) for given pulses.
    pub fn clean_response(&self, pulses: &[Pulse]) -> Channels {
        match &self.engine {
            Engine::Analyzer(e) => e.response(pulses),
            Engine::Held(e) => e.response(pulses),
        }
    }

    /// The pulses of every hit for a seed. Pulses and noise use separate
    /// random streams derived from the seed, so campaigns with the same seed
    /// and different noise levels share their pulses.
    pub fn draw_pulses(&self, seed: u64) -> Vec<Vec<Pulse>> {
        let mut rng = ChaCha8Rng::seed_from_u64(derive_seed(seed, 1));
        let trigger =
            self.settings.sampling.pretrigger_samples as f64 * self.settings.sampling.dt_s();
        (0..self.settings.hits)
            .map(|_| self.settings.hammer.draw(&mut rng, trigger))
            .collect()
    }

    /// Simulates a campaign. Bit-identical for the same seed.
    pub fn simulate(&self, seed: u64) -> Campaign {
        self.simulate_with_noise(seed, &self.settings.noise)
    }

    /// Simulates a campaign with other noise settings than the scenario's
    /// (a noise sweep reuses one simulator). The pulses depend on the seed
    /// only, and the normal draws do not depend on the noise level, so
    /// campaigns differing only in noise level share their pulses and the
    /// shape of their noise.
    pub fn simulate_with_noise(&self, seed: u64, noise: &NoiseSettings) -> Campaign {
        let pulses = self.draw_pulses(seed);
        let mut rng = ChaCha8Rng::seed_from_u64(derive_seed(seed, 2));
        let sign = if self.settings.invert_force_polarity {
            -1.0
        } else {
            1.0
        };
        let hits = pulses
            .into_iter()
            .map(|p| {
                let mut ch = self.clean_response(&p);
                for (c, channel) in ch.iter_mut().enumerate() {
                    noise.apply(channel, c == 0, &mut rng);
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
