//! Sweep throughput: trials (simulate + identify + score) per second on 1
//! and 2 threads, paper case 1 at 1 % noise.

use std::path::Path;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use study::LoadedScenario;
use study::experiment::TrueModel;
use study::sweep::{self, Plan};

fn bench_sweep(c: &mut Criterion) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/paper-case1.toml");
    let loaded = LoadedScenario::load(&path).expect("bundled scenario loads");
    let truth = TrueModel::new(loaded.model.clone()).unwrap();
    let trials = 16;
    let plan = Plan {
        scenario: loaded.scenario.clone(),
        noise_levels: vec![0.01],
        trials,
        seed: 1,
        axis: None,
    };
    let mut group = c.benchmark_group("sweep throughput (paper case 1, 1 % noise)");
    group.throughput(Throughput::Elements(trials as u64));
    group.sample_size(10);
    for threads in [1, 2] {
        group.bench_function(format!("{threads} thread(s)"), |b| {
            b.iter(|| sweep::run(&plan, &truth, None, threads, &|| {}).unwrap())
        });
    }
    group.finish();
}

criterion_group!(benches, bench_sweep);
criterion_main!(benches);
