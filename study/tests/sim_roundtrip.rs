//! Round trips through the simulator with known truth: simulate a campaign
//! of a bundled scenario, identify it with `ident`, compare with the model
//! it was simulated from. Two and three storeys; held records with the
//! `zoh` assumption and analyzer records with `bandlimited`.

use std::path::Path;

use ident::{Identification, Identifier, Intersample};
use sim::{Acquisition, Model, NoiseSettings};
use study::LoadedScenario;
use study::score::rel_fro;

fn scenario(name: &str) -> LoadedScenario {
    LoadedScenario::load(
        &Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../scenarios")
            .join(name),
    )
    .unwrap()
}

#[derive(Debug)]
struct Errors {
    f: f64,
    xi: f64,
    m: f64,
    k: f64,
    damping_mkr: f64,
    damping_rayleigh: f64,
}

fn errors(id: &Identification, model: &Model) -> Errors {
    let modal = model.modal().unwrap();
    let n = model.dofs();
    assert_eq!(id.frequencies_hz.len(), n, "every structural mode is found");
    let worst = |a: &[f64], b: &[f64]| {
        (0..n)
            .map(|j| (a[j] / b[j] - 1.0).abs())
            .fold(0.0, f64::max)
    };
    Errors {
        f: worst(&id.frequencies_hz, &modal.frequencies_hz),
        xi: worst(&id.damping_ratios, &modal.damping_ratios),
        m: rel_fro(&id.mass, &model.mass),
        k: rel_fro(&id.stiffness, &model.stiffness),
        damping_mkr: rel_fro(&id.damping_mkr, &model.damping),
        damping_rayleigh: rel_fro(&id.damping_rayleigh, &model.damping),
    }
}

fn run(
    name: &str,
    acquisition: Acquisition,
    intersample: Intersample,
    noise: f64,
    seed: u64,
) -> Errors {
    let s = scenario(name);
    let mut sc = s.scenario.clone();
    sc.campaign.acquisition = acquisition;
    let sim = sc.simulator(s.model.clone()).unwrap();
    let noise = NoiseSettings {
        fraction: noise,
        ..Default::default()
    };
    let campaign = sim.simulate_with_noise(seed, &noise);
    let id = Identifier::default()
        .intersample(intersample)
        .identify(&campaign.to_ident().records, campaign.dt_s)
        .unwrap();
    errors(&id, &s.model)
}

const TWO_AND_THREE_STOREYS: [&str; 3] = [
    "paper-case1.toml",
    "paper-case2.toml",
    "frame-three-storey.toml",
];

#[test]
fn noise_free_held_records_with_zoh_are_recovered_exactly() {
    for name in TWO_AND_THREE_STOREYS {
        let e = run(name, Acquisition::Held, Intersample::Zoh, 0.0, 1);
        // The held records follow the ZOH discrete model exactly: only
        // rounding remains (measured <= 5e-12 on every quantity). The issue's
        // tolerances: f 0.01 %, xi 1 %, M and K 0.1 %.
        assert!(
            e.f < 1e-4 && e.xi < 1e-2 && e.m < 1e-3 && e.k < 1e-3,
            "{name}: {e:?}"
        );
        assert!(
            e.m < 1e-9 && e.k < 1e-9 && e.damping_mkr < 1e-9,
            "{name}: exact model, rounding only: {e:?}"
        );
    }
}

#[test]
fn noise_free_analyzer_records_with_bandlimited_are_recovered() {
    for name in TWO_AND_THREE_STOREYS {
        let e = run(
            name,
            Acquisition::default(),
            Intersample::Bandlimited,
            0.0,
            1,
        );
        // Band-limited records have no exact finite-order discrete model;
        // OKID with input leads and ERA from Markov offset 10 leave
        // <= 2e-5 in M and K and ~1e-3 in the MKR damping (measured). The
        // issue's tolerances: f 0.01 %, xi 1 %, M and K 0.1 %.
        assert!(
            e.f < 1e-4 && e.xi < 1e-2 && e.m < 1e-3 && e.k < 1e-3,
            "{name}: {e:?}"
        );
        // The MKR damping from exact-in-band data: within 1 % (measured
        // 8e-4 to 1.2e-3).
        assert!(e.damping_mkr < 1e-2, "{name}: {e:?}");
    }
}

#[test]
fn zoh_conversion_on_analyzer_records_biases_m_and_k_by_percents() {
    // NOTES: the ZOH step is wrong for band-limited records. Measured on
    // paper case 1: M 5 %, K 7 %, MKR damping 85x its size. The test pins
    // that the bias is real (> 1 %) so the default cannot silently regress.
    let e = run(
        "paper-case1.toml",
        Acquisition::default(),
        Intersample::Zoh,
        0.0,
        1,
    );
    assert!(e.m > 0.01 && e.k > 0.01 && e.damping_mkr > 1.0, "{e:?}");
}

#[test]
fn one_percent_noise_over_ten_hits() {
    for name in TWO_AND_THREE_STOREYS {
        for (acquisition, intersample) in [
            (Acquisition::default(), Intersample::Bandlimited),
            (Acquisition::Held, Intersample::Zoh),
        ] {
            for seed in [1, 2, 3] {
                let e = run(name, acquisition.clone(), intersample, 0.01, seed);
                // The tolerances at 1 % noise over 10 hits: f 0.05 %,
                // M and K 1 %, Rayleigh damping 10 % (measured worst over
                // these 18 cases: f 6e-5, M 3.8e-3, K 1.2e-3, Rayleigh
                // 9.4e-3); `errors` also asserts the automatic order found
                // every mode.
                assert!(
                    e.f < 5e-4 && e.m < 1e-2 && e.k < 1e-2 && e.damping_rayleigh < 0.1,
                    "{name} {intersample:?} seed {seed}: {e:?}"
                );
            }
        }
    }
}
