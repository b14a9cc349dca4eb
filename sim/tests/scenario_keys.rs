//! The new `[campaign]` keys as a scenario file writes them: they parse,
//! survive a serialization round trip, simulate, and are reported in the
//! truth.

mod common;

use common::*;
use sim::{CampaignSettings, Excitation, Simulator};

/// Every rig effect and a shaker, as in a scenario's `[campaign]` table
/// (keys relative to `[campaign]`).
const ALL_KEYS: &str = r#"
hits = 2

[hammer]            # still required: its floor is the input floor
floor = 1
duration_s = 0.003
peak_n = 15.0

[excitation]
kind = "burst-random"     # or "random", "chirp"; default: the hammer
floor = 1
rms_n = 2.0               # N, expected RMS during the burst
min_frequency_hz = 1.0
max_frequency_hz = 24.0
burst_fraction = 0.5      # of the record, from the trigger

[sampling]
sample_rate_hz = 64.0
samples = 1024
pretrigger_samples = 32

[noise]
fraction = 0.01
[noise.coloured]
spectrum = { kind = "pink", min_frequency_hz = 0.1 }   # or { kind = "low-pass", corner_hz = 2.0 }
fraction = 0.005
absolute_acceleration_m_s2 = 0.001

[rig]
accelerometer = { resonance_hz = 28.0, damping_ratio = 0.03 }
force_filter = { corner_hz = 200.0, order = 2, applies_to = "measured" }

[[rig.extra_modes]]
label = "torsion"
frequency_hz = 14.5
damping_ratio = 0.008
modal_mass_kg = 0.3
input_participation = 0.2      # m/m at the force point
sensor_participation = [0.3, -0.5]

[[rig.channels]]
channel = "acc2"
gain = 1.03           # calibration error
offset = 0.02         # m/s^2
drift_per_s = 0.0005  # m/s^3

[[rig.channels]]
channel = "force"
offset = -0.05        # N
"#;

#[test]
fn all_new_keys_parse_round_trip_and_simulate() {
    let settings: CampaignSettings = toml::from_str(ALL_KEYS).unwrap();
    assert!(matches!(settings.excitation, Excitation::BurstRandom(_)));
    let json = serde_json::to_string(&settings).unwrap();
    let back: CampaignSettings = serde_json::from_str(&json).unwrap();
    assert_eq!(back, settings);
    let toml_back: CampaignSettings = toml::from_str(&toml::to_string(&settings).unwrap()).unwrap();
    assert_eq!(toml_back, settings);
    let sim = Simulator::new(paper_case1(), settings).unwrap();
    let a = sim.simulate(3);
    assert_eq!(a, sim.simulate(3), "bit-identical for the same seed");
    assert_eq!(a.hits.len(), 2);
    assert!(a.hits.iter().all(|h| h.pulses.is_empty()));
    let truth = sim.rig_truth();
    assert_eq!(truth.extra_modes[0].frequency_hz, 14.5);
    assert_eq!(truth.channels.gain, vec![1.0, 1.0, 1.03]);
    // The truth serializes (for truth files).
    assert!(serde_json::to_string(&truth).unwrap().contains("torsion"));
}

#[test]
fn switching_noise_features_never_changes_the_excitation() {
    // Streams are independent: the shaker signal depends on the seed only.
    let base: CampaignSettings = toml::from_str(ALL_KEYS).unwrap();
    let mut quiet = base.clone();
    quiet.noise = Default::default();
    let (a, b) = (
        Simulator::new(paper_case1(), base.clone()).unwrap(),
        Simulator::new(paper_case1(), quiet).unwrap(),
    );
    let clean_a = a.clean_records(8);
    let clean_b = b.clean_records(8);
    assert_eq!(clean_a, clean_b);
    // And the simulated records differ from the clean ones only by noise
    // below a few percent of the channel level.
    let noisy = a.simulate(8);
    let rel = sim::noise::rms(
        &noisy.hits[0].accelerations[0]
            .iter()
            .zip(&clean_a[0][1])
            .map(|(x, y)| x - y)
            .collect::<Vec<_>>(),
    ) / sim::noise::rms(&clean_a[0][1]);
    // White 1 % plus pink 0.5 % plus 0.001 m/s^2 absolute: about 1.2 %.
    assert!(rel > 0.005 && rel < 0.05, "noise {rel}");
}
