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
