//! Shear-frame simulator with known truth for hammer-test identification.
//!
//! - [`structure`]: an n-storey shear frame from pillar and floor geometry
//!   (lumped mass, tridiagonal stiffness).
//! - [`damping`]: Rayleigh, target-ratio or modal damping, plus dashpots.
//! - [`model`]: M, K and damping checked, state space with acceleration
//!   outputs, modal properties (the truth).
//! - [`hammer`]: half-sine pulses with hit-to-hit variation, double hits.
//! - [`excitation`]: shaker signals instead of the hammer (band-limited
//!   random, burst random, chirps).
//! - [`rig`]: test-rig effects, all off by default: modes outside the shear
//!   model, accelerometer resonance, force filtering, channel gain, offset
//!   and drift.
//! - [`analyzer`] and [`response`]: exact responses through an analyzer
//!   chain (analog anti-alias filter, high-rate ADC, decimation FIR) or with
//!   the force held per sample (zero-order hold).
//! - [`noise`]: Gaussian noise (white and coloured), clipping, quantization.
//! - [`campaign`]: campaigns of hits from a seed.
//!
//! # Conventions
//! SI units throughout, written in names where they matter (`dt_s`,
//! `frequency_hz`, `peak_n`). DOF i (zero-based in code, floor i + 1 in
//! files and messages) is the lateral displacement of floor i + 1; floor 1
//! is the lowest. The damping matrix is called `damping`; `c` is an output
//! matrix. Outputs are absolute accelerations (the base is fixed). Modal
//! results are sorted by ascending natural frequency; mode shapes are
//! scaled so their largest-magnitude component is 1 + 0i. Randomness comes
//! from ChaCha8 streams derived from one `u64` seed: the same seed gives
//! bit-identical campaigns on any machine and thread count.
//!
//! # Example
//!
//! The paper's two-storey test frame from its geometry (section 4: four
//! steel pillars per storey, aluminium floor blocks, 5 g accelerometers),
//! Rayleigh damping with the paper's case-1 coefficients, and one hammer
//! hit on floor 1 recorded with the force held per sample:
//!
//! ```
//! use sim::{
//!     Acquisition, CampaignSettings, DampingSpec, Floor, HammerSettings, Model, Sampling,
//!     Simulator, Storey, StructureSpec,
//! };
//!
//! let storey = |length_m: f64| Storey {
//!     pillars: 4,
//!     pillar_width_m: 0.035,
//!     pillar_thickness_m: 0.001,
//!     length_m,
//!     youngs_modulus_pa: 210e9,
//!     density_kg_m3: 7850.0,
//!     end_condition: Default::default(), // clamped at both ends: 12 E I / L^3
//! };
//! let floor = Floor {
//!     block_length_m: 0.200,
//!     block_width_m: 0.045,
//!     block_height_m: 0.045,
//!     block_density_kg_m3: 2700.0,
//!     sensor_mass_kg: 0.005,
//!     added_mass_kg: 0.0,
//! };
//! let structure = StructureSpec::ShearFrame {
//!     storeys: vec![storey(0.300), storey(0.350)],
//!     floors: vec![floor.clone(), floor],
//! };
//! let m = structure.matrices()?;
//! let rayleigh = DampingSpec::Rayleigh { alpha: 0.1755, beta: 3.2283e-5 };
//! let damping = sim::build_damping(&m.mass, &m.stiffness, &rayleigh, &[])?;
//! let model = Model::new(m.mass, m.stiffness, damping)?;
//!
//! // Storeys of 1089 and 686 N/m, floors of 1.456 and 1.291 kg: the closed
//! // form of this two-mass chain gives 2.605917 Hz for the first mode
//! // (the paper measured 2.73 Hz on the real frame). Rayleigh damping is
//! // proportional, so |lambda| is the undamped frequency exactly; 1e-6
//! // covers the 7 printed digits.
//! let modes = model.modal()?;
//! assert!((modes.frequencies_hz[0] / 2.605917 - 1.0).abs() < 1e-6);
//!
//! let settings = CampaignSettings {
//!     hits: 1,
//!     hammer: HammerSettings {
//!         floor: 1,
//!         duration_s: 0.003,
//!         peak_n: 15.0,
//!         peak_variation: 0.0,
//!         start_jitter_s: 0.0,
//!         double_hit: None,
//!     },
//!     sampling: Sampling { sample_rate_hz: 64.0, samples: 256, pretrigger_samples: 8 },
//!     acquisition: Acquisition::Held,
//!     noise: Default::default(),
//!     invert_force_polarity: false,
//!     excitation: Default::default(),
//!     rig: Default::default(),
//! };
//! let campaign = Simulator::new(model, settings)?.simulate(7);
//! let hit = &campaign.hits[0];
//! assert_eq!(hit.accelerations.len(), 2); // one accelerometer per floor
//! assert_eq!(hit.force.len(), 256);
//!
//! // Held records carry the force's mean over each sample, so the recorded
//! // impulse is the half-sine's (2/pi x peak x duration) up to rounding.
//! let recorded_ns: f64 = hit.force.iter().sum::<f64>() * campaign.dt_s;
//! let applied_ns: f64 = hit.pulses.iter().map(|p| p.impulse_ns()).sum();
//! assert!((recorded_ns / applied_ns - 1.0).abs() < 1e-9);
//! # Ok::<(), sim::SimError>(())
//! ```

#![deny(missing_docs)]

pub mod analyzer;
pub mod campaign;
mod convert;
pub mod damping;
pub mod error;
pub mod excitation;
pub mod hammer;
pub mod model;
pub mod noise;
pub mod response;
pub mod rig;
pub mod structure;

pub use analyzer::AnalyzerSettings;
pub use campaign::{
    Acquisition, Campaign, CampaignSettings, Hit, MAX_CAMPAIGN_BYTES, Sampling, Simulator,
    derive_seed,
};
pub use damping::{DampingSpec, Dashpot, build_damping, matrix_from_rows};
pub use error::SimError;
pub use excitation::{
    BurstRandomExcitation, ChirpExcitation, ChirpSweep, Excitation, RandomExcitation,
};
pub use hammer::{DoubleHit, HammerSettings, Pulse};
pub use model::{ContinuousSystem, ModalProperties, Model};
pub use noise::{AdcSettings, ColouredNoise, NoiseSettings, NoiseSpectrum};
pub use rig::{
    AccelerometerResonance, ChannelError, ExtraMode, ForceFilter, ForceFilterTarget, Plant,
    RigSettings, RigTruth,
};
pub use structure::{EndCondition, Floor, ShearFrame, Storey, StructureMatrices, StructureSpec};
