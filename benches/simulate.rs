//! Time to simulate one 10-hit campaign of each paper scenario (analyzer
//! chain, 2048 samples per hit) and the one-off engine construction.

use std::path::Path;

use criterion::{Criterion, criterion_group, criterion_main};
use study::LoadedScenario;

fn scenario(name: &str) -> LoadedScenario {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenarios")
        .join(name);
    LoadedScenario::load(&path).expect("bundled scenario loads")
}

fn bench_simulate(c: &mut Criterion) {
    let case1 = scenario("paper-case1.toml");
    let sim = case1.scenario.simulator(case1.model.clone()).unwrap();
    c.bench_function("simulate 10-hit campaign (paper case 1, analyzer)", |b| {
        let mut seed = 0u64;
        b.iter(|| {
            seed += 1;
            sim.simulate(seed)
        })
    });
    c.bench_function("build analyzer engine (paper case 1)", |b| {
        b.iter(|| case1.scenario.simulator(case1.model.clone()).unwrap())
    });
    let mut held = case1.scenario.clone();
    held.campaign.acquisition = sim::Acquisition::Held;
    let sim_held = held.simulator(case1.model.clone()).unwrap();
    c.bench_function("simulate 10-hit campaign (paper case 1, held)", |b| {
        let mut seed = 0u64;
        b.iter(|| {
            seed += 1;
            sim_held.simulate(seed)
        })
    });
}

criterion_group!(benches, bench_simulate);
criterion_main!(benches);
