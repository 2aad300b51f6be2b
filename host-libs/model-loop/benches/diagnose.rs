//! `diagnose` on a 90 s two-axis log sampled at 1 kHz, on the 36 s force-step test of §5.2
//! and on the nine poses' step tests in one 324 s log (the targets on a 2-core machine:
//! 0.5 s, 1 s and 4 s). The logs are the digital twin's (the dynamic trial at point 1 with the
//! carrier ball's friction, the step tests with a transport delay), simulated once, outside
//! the measurement.
use criterion::{criterion_group, criterion_main, Criterion};
use pam_ident::Trial;
use pam_model::RobotModel;
use pam_model_loop::diagnose::{diagnose, Settings};
use pam_model_loop::effects::Experiment;
use pam_twin::experiments::{
    dynamic_trial, force_step_test, ExperimentConfig, StiffnessLevel, STEP_POSES_DEG,
};
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
    // the §5.2 protocol whole: the force-step test at each of the nine poses, one after the
    // other in one log (9 × 36 s at 1 kHz; the handle is re-clamped between poses)
    let trial = nine_pose_step_log();
    g.bench_function("step_nine_poses_1khz", |b| {
        b.iter(|| diagnose(&trial, &model, Experiment::Step, Settings::default()).unwrap())
    });
    g.finish();
}

fn nine_pose_step_log() -> Trial {
    let mut all: Option<Trial> = None;
    for (k, pose) in STEP_POSES_DEG.iter().enumerate() {
        let mut cfg = config("transport_delay");
        cfg.twin.seed = 1 + k as u64;
        let t = Trial::from_log(&force_step_test(&cfg, *pose).unwrap()).unwrap();
        all = Some(match all {
            None => t,
            Some(mut a) => {
                let dt = a.t_s[1] - a.t_s[0];
                let shift = a.t_s[a.t_s.len() - 1] + dt - t.t_s[0];
                a.t_s.extend(t.t_s.iter().map(|v| v + shift));
                for i in 0..2 {
                    a.alpha_rad[i].extend(&t.alpha_rad[i]);
                    a.force_n[i].extend(&t.force_n[i]);
                }
                if let (Some(r), Some(tr)) = (&mut a.force_ref_n, &t.force_ref_n) {
                    r[0].extend(&tr[0]);
                    r[1].extend(&tr[1]);
                }
                if let (Some(c), Some(tc)) = (&mut a.current_ma, &t.current_ma) {
                    for i in 0..4 {
                        c[i].extend(&tc[i]);
                    }
                }
                a
            }
        });
    }
    all.expect("nine poses")
}

criterion_group!(benches, bench);
criterion_main!(benches);
