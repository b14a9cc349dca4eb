//! Time to identify one 10-hit campaign (paper case 1, 2048 samples per
//! hit, 1 % noise) with each intersample assumption, and the stabilization
//! diagram of the report.

use std::path::Path;

use criterion::{Criterion, criterion_group, criterion_main};
use frameid::experiment::campaign_records;
use frameid::scenario::LoadedScenario;
use ident::pipeline::StabilizationCriteria;

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
        let records = campaign_records(&campaign);
        let identifier = s.identifier();
        c.bench_function(&format!("identify 10-hit campaign ({label})"), |b| {
            b.iter(|| identifier.identify(&records, campaign.dt_s).unwrap())
        });
        if label.starts_with("analyzer") {
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
