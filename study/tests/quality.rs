//! Hit quality checks (the `records` crate) on simulated campaigns: clean
//! campaigns pass; double hits, clipping, long pulses, short records, noisy
//! and empty hits are flagged.

use std::path::Path;

use ident::Record;
use nalgebra::DMatrix;
use records::quality::{Check, HitQuality, QualitySettings, assess_campaign, assess_hit};
use sim::{Acquisition, AdcSettings, Campaign, DoubleHit, NoiseSettings, Simulator};
use study::LoadedScenario;

fn scenario(name: &str) -> LoadedScenario {
    LoadedScenario::load(
        &Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../scenarios")
            .join(name),
    )
    .unwrap()
}

/// A simulator of a bundled scenario after `edit`.
fn simulator(name: &str, edit: impl FnOnce(&mut study::Scenario)) -> (Simulator, LoadedScenario) {
    let s = scenario(name);
    let mut sc = s.scenario.clone();
    edit(&mut sc);
    (sc.simulator(s.model.clone()).unwrap(), s)
}

fn noise(fraction: f64) -> NoiseSettings {
    NoiseSettings {
        fraction,
        ..Default::default()
    }
}

fn assess(c: &Campaign, settings: &QualitySettings) -> Vec<HitQuality> {
    assess_campaign(&c.to_ident(), settings)
}

fn checks(q: &HitQuality) -> Vec<Check> {
    q.flags.iter().map(|f| f.check).collect()
}

#[test]
fn clean_campaigns_raise_no_quality_warning() {
    let mut worst_ratio: f64 = 0.0;
    let mut worst_drop: f64 = 0.0;
    let mut worst_tail: f64 = 0.0;
    let mut lowest_snr = f64::INFINITY;
    for name in [
        "paper-case1.toml",
        "paper-case2.toml",
        "frame-three-storey.toml",
    ] {
        for held in [false, true] {
            for fraction in [0.0, 0.01] {
                let (sim, _) = simulator(name, |s| {
                    if held {
                        s.campaign.acquisition = Acquisition::Held;
                    }
                    s.campaign.noise = noise(fraction);
                });
                for seed in [1, 2] {
                    for (i, q) in assess(&sim.simulate(seed), &QualitySettings::default())
                        .iter()
                        .enumerate()
                    {
                        let what = format!(
                            "{name} held={held} noise={fraction} seed={seed} hit {}",
                            i + 1
                        );
                        assert!(q.flags.is_empty(), "{what}: {:?}", q.flags);
                        let p = q.pulse.as_ref().expect("a hit");
                        worst_ratio = worst_ratio.max(p.double_hit_ratio);
                        worst_drop = worst_drop.max(p.spectrum_drop_db);
                        worst_tail = worst_tail.max(q.max_tail_ratio().unwrap());
                        if let Some(s) = q.min_snr_db() {
                            lowest_snr = lowest_snr.min(s);
                        }
                        // Every channel has its noise and SNR measured (SNR
                        // null only for exactly noise-free held records).
                        assert_eq!(q.channels.len(), 1 + sim.model().dofs());
                        assert!(q.channels.iter().all(|c| c.noise_rms.is_some()), "{what}");
                    }
                }
            }
        }
    }
    eprintln!(
        "clean campaigns: largest second pulse {worst_ratio:.3}, spectrum fall {worst_drop:.2} dB, tail ratio {worst_tail:.4}, lowest SNR {lowest_snr:.1} dB"
    );
    // Margins to the thresholds (0.1, 12 dB, 0.05, 20 dB). A held impulse
    // split over two samples falls up to 9.4 dB at fs/2.56.
    assert!(worst_ratio < 0.03 && worst_drop < 10.0 && worst_tail < 0.03 && lowest_snr > 30.0);
}

#[test]
fn double_hits_are_flagged_with_their_ratio_and_delay() {
    for held in [false, true] {
        // Delays of 4 to 40 samples (and in between), ratios 0.2 and 0.5.
        for delay_samples in [4.0, 6.5, 10.0, 40.0] {
            for ratio in [0.2, 0.5] {
                let (sim, _) = simulator("paper-case1.toml", |s| {
                    if held {
                        s.campaign.acquisition = Acquisition::Held;
                    }
                    s.campaign.hits = 5;
                    s.campaign.hammer.double_hit = Some(DoubleHit {
                        delay_s: delay_samples / 64.0,
                        ratio,
                    });
                });
                for q in assess(&sim.simulate(3), &QualitySettings::default()) {
                    let what = format!("held={held} delay={delay_samples} ratio={ratio}");
                    assert!(checks(&q).contains(&Check::DoubleHit), "{what}: {q:?}");
                    assert!(!q.passed());
                    let p = q.pulse.unwrap();
                    assert!(
                        (p.double_hit_ratio - ratio).abs() < 0.25 * ratio,
                        "{what}: measured {}",
                        p.double_hit_ratio
                    );
                    let d = p.double_hit_delay_s.unwrap() * 64.0;
                    assert!((d - delay_samples).abs() <= 1.0, "{what}: delay {d}");
                }
            }
        }
    }
}

#[test]
fn close_double_hits_that_merge_with_the_pulse_are_caught_by_the_spectrum() {
    // Two equal pulses 2 samples apart cancel near fs/4, inside the band.
    let (sim, _) = simulator("paper-case1.toml", |s| {
        s.campaign.hits = 5;
        s.campaign.hammer.double_hit = Some(DoubleHit {
            delay_s: 2.0 / 64.0,
            ratio: 1.0,
        });
    });
    for q in assess(&sim.simulate(4), &QualitySettings::default()) {
        assert!(
            checks(&q).contains(&Check::LongPulse) || checks(&q).contains(&Check::DoubleHit),
            "{:?}",
            q.flags
        );
    }
}

#[test]
fn clipped_channels_are_flagged() {
    let (sim, _) = simulator("paper-case1.toml", |s| {
        s.campaign.hits = 5;
        s.campaign.noise.adc = Some(AdcSettings {
            force_range_n: 100.0,
            acceleration_range_m_s2: 3.0,
            bits: None,
        });
    });
    for q in assess(&sim.simulate(5), &QualitySettings::default()) {
        let f = q
            .flags
            .iter()
            .find(|f| f.check == Check::Clipping)
            .expect("clipping flagged");
        assert_eq!(f.channel.as_deref(), Some("acc1"), "{f:?}");
        let acc1 = &q.channels[1];
        assert!(acc1.clip_samples >= 2 && acc1.clip_run >= 2, "{acc1:?}");
        assert!(q.channels[0].clip_samples <= 1, "the force is not clipped");
    }
    // A force clipped on one sample only: invisible in the samples, caught
    // with the declared range.
    let (sim, _) = simulator("paper-case1.toml", |s| {
        s.campaign.hits = 3;
        s.campaign.noise.adc = Some(AdcSettings {
            force_range_n: 1.2,
            acceleration_range_m_s2: 100.0,
            bits: None,
        });
    });
    let declared = QualitySettings {
        force_range: Some(1.2),
        acceleration_range: Some(100.0),
        ..Default::default()
    };
    for q in assess(&sim.simulate(6), &declared) {
        let f = q
            .flags
            .iter()
            .find(|f| f.check == Check::Clipping)
            .expect("clipping at the declared range");
        assert_eq!(f.channel.as_deref(), Some("force"));
        assert!(f.message.contains("declared range"), "{}", f.message);
        assert!(q.channels[0].range_samples >= 1);
    }
}

#[test]
fn long_pulses_are_flagged_with_their_equivalent_duration() {
    for held in [false, true] {
        let (sim, _) = simulator("paper-case1.toml", |s| {
            if held {
                s.campaign.acquisition = Acquisition::Held;
            }
            s.campaign.hits = 3;
            s.campaign.hammer.duration_s = 0.05;
        });
        for q in assess(&sim.simulate(7), &QualitySettings::default()) {
            assert_eq!(checks(&q), vec![Check::LongPulse], "held={held}");
            let p = q.pulse.unwrap();
            // A 50 ms half-sine falls 17.4 dB at 25 Hz; held over samples
            // of 15.6 ms it looks a little longer.
            eprintln!(
                "held={held}: 50 ms pulse falls {:.1} dB, equivalent {:.1} ms",
                p.spectrum_drop_db,
                1e3 * p.equivalent_duration_s
            );
            assert!((16.0..22.0).contains(&p.spectrum_drop_db), "{p:?}");
            assert!((p.equivalent_duration_s - 0.05).abs() < 0.0075, "{p:?}");
        }
    }
    // 3 ms (the scenario's): flat band, about 3 ms measured.
    let (sim, _) = simulator("paper-case1.toml", |s| {
        s.campaign.hits = 3;
        s.campaign.noise = noise(0.0);
    });
    for q in assess(&sim.simulate(7), &QualitySettings::default()) {
        let p = q.pulse.unwrap();
        assert!(p.spectrum_drop_db < 0.2);
        assert!((p.equivalent_duration_s - 0.003).abs() < 0.001, "{p:?}");
    }
}

#[test]
fn records_that_end_before_the_decay_are_flagged() {
    let (sim, _) = simulator("paper-case1.toml", |s| {
        s.campaign.hits = 3;
        s.campaign.sampling.samples = 512;
    });
    for q in assess(&sim.simulate(8), &QualitySettings::default()) {
        assert!(checks(&q).iter().all(|&c| c == Check::NotDecayed), "{q:?}");
        assert_eq!(q.flags.len(), 2, "both outputs");
        assert!(q.max_tail_ratio().unwrap() > 0.15);
    }
}

#[test]
fn noise_level_snr_and_short_pretriggers() {
    // 1 % noise (of each channel's RMS): about 40 dB on every channel.
    let (sim, _) = simulator("paper-case1.toml", |s| s.campaign.hits = 4);
    for q in assess(&sim.simulate(9), &QualitySettings::default()) {
        for c in &q.channels {
            let snr = c.snr_db.unwrap();
            assert!((30.0..47.0).contains(&snr), "{}: {snr}", c.name);
            assert!(c.noise_rms.unwrap() > 0.0);
        }
        assert_eq!(q.noise_samples, q.hit_sample.unwrap() - 20);
    }
    // 30 % noise: about 10 dB, flagged.
    let (sim, _) = simulator("paper-case1.toml", |s| {
        s.campaign.hits = 4;
        s.campaign.noise = noise(0.3);
    });
    for q in assess(&sim.simulate(9), &QualitySettings::default()) {
        assert!(checks(&q).contains(&Check::LowSnr), "{:?}", q.flags);
        assert!(q.min_snr_db().unwrap() < 15.0);
    }
    // A pre-trigger of 16 samples: too short to measure the noise, said
    // so, but the hit is not failed for it.
    let (sim, _) = simulator("paper-case1.toml", |s| {
        s.campaign.hits = 2;
        s.campaign.sampling.pretrigger_samples = 16;
    });
    for q in assess(&sim.simulate(9), &QualitySettings::default()) {
        assert_eq!(checks(&q), vec![Check::ShortPretrigger]);
        assert!(q.passed());
        assert!(q.channels.iter().all(|c| c.snr_db.is_none()));
    }
}

#[test]
fn records_without_a_hit_are_fatal() {
    let (sim, _) = simulator("paper-case1.toml", |s| s.campaign.hits = 1);
    let c = sim.simulate(10);
    let mut r = c.to_ident().records.remove(0);
    let names = (
        vec!["force".to_string()],
        vec!["acc1".into(), "acc2".into()],
    );
    let clean = assess_hit(&r, c.dt_s, &names.0, &names.1, &Default::default());
    assert!(clean.passed());
    // Zero force.
    r.inputs.fill(0.0);
    let q = assess_hit(&r, c.dt_s, &names.0, &names.1, &Default::default());
    assert!(q.fatal() && !q.passed());
    assert_eq!(checks(&q), vec![Check::NoHit]);
    assert!(q.pulse.is_none() && q.hit_sample.is_none());
    // Only noise (a deterministic pseudo-random sequence).
    let mut state: u64 = 12345;
    for v in r.inputs.iter_mut() {
        let mut sum = 0.0;
        for _ in 0..12 {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            sum += (state >> 11) as f64 / (1u64 << 53) as f64;
        }
        *v = 0.01 * (sum - 6.0);
    }
    let q = assess_hit(&r, c.dt_s, &names.0, &names.1, &Default::default());
    assert_eq!(checks(&q), vec![Check::NoHit]);
    assert!(
        q.flags[0].message.contains("only noise"),
        "{}",
        q.flags[0].message
    );
}

mod props {
    use super::*;
    use proptest::prelude::*;

    /// Sample values that stress the checks: zeros, repeats, extremes,
    /// tiny and huge magnitudes.
    fn value() -> impl Strategy<Value = f64> {
        prop_oneof![
            Just(0.0),
            Just(1.0),
            Just(-1.0),
            Just(1e300),
            Just(-1e-300),
            -10.0..10.0f64,
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(300))]
        /// Any finite record gets a result without panicking, with flags
        /// that match `passed`.
        #[test]
        fn any_finite_record_is_assessed(
            n in 1usize..200,
            outputs in 1usize..4,
            seed in proptest::collection::vec(value(), 1..64),
            dt_s in prop_oneof![Just(1.0 / 64.0), Just(1e-6), Just(10.0)],
        ) {
            let at = |k: usize, c: usize| seed[(k * 7 + c * 13) % seed.len()];
            let r = Record::new(
                DMatrix::from_fn(1, n, |_, k| at(k, 0)),
                DMatrix::from_fn(outputs, n, |i, k| at(k, i + 1)),
            );
            let ins = vec!["force".to_string()];
            let outs: Vec<String> = (0..outputs).map(|i| format!("acc{}", i + 1)).collect();
            let declared = QualitySettings {
                force_range: Some(1.0),
                acceleration_range: Some(5.0),
                ..Default::default()
            };
            for settings in [QualitySettings::default(), declared] {
                let q = assess_hit(&r, dt_s, &ins, &outs, &settings);
                prop_assert_eq!(q.channels.len(), 1 + outputs);
                prop_assert_eq!(q.passed(), q.flags.iter().all(|f| !f.check.fails_hit()));
                prop_assert!(q.flags.iter().all(|f| !f.message.is_empty()));
                // Serializes (non-finite numbers of absurd inputs as null).
                prop_assert!(serde_json::to_string(&q).is_ok());
            }
        }
    }
}
