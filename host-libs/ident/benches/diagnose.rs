//! `diagnose` on a 90 s two-axis log sampled at 1 kHz (the speed target: < 2 s on a
//! 2-core machine). The log is the digital twin's dynamic trial at point 1 with the carrier
//! ball's friction switched on; it is simulated once, outside the measurement.
use criterion::{criterion_group, criterion_main, Criterion};
use pam_ident::diagnose::{diagnose, Settings};
use pam_ident::effects::Experiment;
use pam_ident::Trial;
use pam_model::RobotModel;
use pam_twin::experiments::{dynamic_trial, force_step_test, ExperimentConfig, StiffnessLevel};
use pam_twin::{EffectSet, TwinConfig};

fn config(spec: &str) -> ExperimentConfig {
    let mut tw = TwinConfig::thesis();
    tw.seed = 1;
    tw.effects = EffectSet::parse_list(&[spec]).unwrap();
    let mut cfg = ExperimentConfig::new(tw);
    cfg.period_s = 0.001;
    cfg
}

fn bench(c: &mut Criterion) {
    let model = RobotModel::<f64>::thesis();
    let log = dynamic_trial(
        &config("carrier_ball_friction"),
        1,
        StiffnessLevel::Low,
        90.0,
    )
    .unwrap();
    let trial = Trial::from_log(&log).unwrap();
    assert_eq!(trial.len(), 90_000);
    let mut g = c.benchmark_group("diagnose");
    g.sample_size(10);
    g.bench_function("dynamic_90s_1khz", |b| {
        b.iter(|| diagnose(&trial, &model, Experiment::Dynamic, Settings::default()).unwrap())
    });
    // the force-step test of §5.2 at 1 kHz (36 s of steps)
    let log = force_step_test(&config("transport_delay"), [0.0, 0.0]).unwrap();
    let trial = Trial::from_log(&log).unwrap();
    g.bench_function("step_test_1khz", |b| {
        b.iter(|| diagnose(&trial, &model, Experiment::Step, Settings::default()).unwrap())
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
