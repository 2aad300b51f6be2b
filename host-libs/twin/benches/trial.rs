//! Speed of the twin: a 90 s dynamic trial at 1 kHz with the real controller in the loop
//! (it should take well under a second).

use criterion::{criterion_group, criterion_main, Criterion};
use pam_twin::experiments::{dynamic_trial, ExperimentConfig, StiffnessLevel};

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("twin");
    g.sample_size(10);
    g.bench_function("dynamic_trial_90s_1khz_point1", |b| {
        let cfg = ExperimentConfig::thesis();
        b.iter(|| dynamic_trial(&cfg, 1, StiffnessLevel::Low, 90.0).expect("trial"))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
