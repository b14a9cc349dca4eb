//! Time to identify one 10-hit campaign (paper case 1, 2048 samples per
//! hit, 1 % noise) with each intersample assumption, to refine it by
//! maximum likelihood, the Cramér–Rao bound, and the stabilization diagram
//! of the report.

use std::path::Path;

use criterion::{Criterion, criterion_group, criterion_main};
use ident::pipeline::StabilizationCriteria;
use ident::refine::SecondOrder;
use study::LoadedScenario;

fn bench_identify(c: &mut Criterion) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/paper-case1.toml");
    let loaded = LoadedScenario::load(&path).expect("bundled scenario loads");
    for (label, acquisition) in [
        ("analyzer, bandlimited", sim::Acquisition::default()),
        ("held, zoh", sim::Acquisition::Held),
    ] {
        let mut s = loaded.scenario.clone();
        s.campaign.acquisition = acquisition;
        let campaign = s.simulator(loaded.model.clone()).unwrap().simulate(1);
        let records = campaign.to_ident().records;
        let identifier = s.identifier();
        c.bench_function(&format!("identify 10-hit campaign ({label})"), |b| {
            b.iter(|| identifier.identify(&records, campaign.dt_s).unwrap())
        });
        let id = identifier.identify(&records, campaign.dt_s).unwrap();
        let refiner = s.refiner();
        let initial = SecondOrder::from_identification(&id);
        c.bench_function(
            &format!("refine 10-hit campaign by maximum likelihood ({label})"),
            |b| b.iter(|| refiner.refine(&records, campaign.dt_s, &initial).unwrap()),
        );
        if label.starts_with("analyzer") {
            let truth = study::experiment::TrueModel::new(loaded.model.clone()).unwrap();
            let simulator = s.simulator(loaded.model.clone()).unwrap();
            c.bench_function("Cramér–Rao bound of a 10-hit campaign (analyzer)", |b| {
                b.iter(|| {
                    study::experiment::cramer_rao_bound(
                        &simulator,
                        &refiner,
                        s.acquisition_intersample(),
                        &truth,
                        &s.campaign.noise,
                        1,
                    )
                    .unwrap()
                })
            });
            let valid = identifier.check().unwrap();
            c.bench_function("stabilization diagram to order 24", |b| {
                b.iter(|| {
                    valid
                        .stabilization(
                            &records,
                            campaign.dt_s,
                            24,
                            StabilizationCriteria::default(),
                        )
                        .unwrap()
                })
            });
        }
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20);
    targets = bench_identify
}
criterion_main!(benches);
