use pam_ident::diagnose::{diagnose, Settings};
use pam_ident::effects::Experiment;
use pam_ident::Trial;
use pam_model::RobotModel;
use pam_twin::experiments::{dynamic_trial, force_step_test, ExperimentConfig, StiffnessLevel};
use pam_twin::{EffectSet, TwinConfig};

fn run(exp: &str, spec: &str, period: f64, dur: f64, seed: u64) {
    let mut tw = TwinConfig::thesis();
    tw.seed = seed;
    if !spec.is_empty() {
        tw.effects = EffectSet::parse_list(&[spec]).unwrap();
    }
    let mut cfg = ExperimentConfig::new(tw);
    cfg.period_s = period;
    let t0 = std::time::Instant::now();
    let (log, e) = if exp == "dynamic" {
        (dynamic_trial(&cfg, 1, StiffnessLevel::Low, dur).unwrap(), Experiment::Dynamic)
    } else {
        (force_step_test(&cfg, [0.0, 0.0]).unwrap(), Experiment::Step)
    };
    let sim = t0.elapsed();
    let tr = Trial::from_log(&log).unwrap();
    let model = RobotModel::<f64>::thesis();
    let t0 = std::time::Instant::now();
    let (d, _) = diagnose(&tr, &model, e, Settings::default()).unwrap();
    let top: Vec<String> = d.effects.iter().take(3).map(|e| format!("{}({:.3},{}{})", e.id, e.improvement, if e.accepted {"A"} else {""}, "")).collect();
    println!("{exp} {spec:<40} p {period}: {} base {:.3}/{:.3} {:?} unexpl {:?} [sim {:?} diag {:?}]\n     params {:?}", d.verdict, d.base.nrmse.fx, d.base.nrmse.fy, top, d.unexplained.iter().map(|u| (u.signal.clone(), u.frequency_hz)).collect::<Vec<_>>(), sim, t0.elapsed(), d.effects[0].params);
}

#[test]
#[ignore]
fn twin_explore() {
    let which = std::env::var("TWIN_EXP").unwrap_or("dynamic".into());
    let period: f64 = std::env::var("TWIN_PERIOD").map(|s| s.parse().unwrap()).unwrap_or(0.01);
    let dur: f64 = std::env::var("TWIN_DUR").map(|s| s.parse().unwrap()).unwrap_or(60.0);
    let specs = ["", "carrier_ball_friction", "velocity_squared", "nonlinear_stiffness", "muscle_hysteresis", "asymmetric_ip_rates", "pressure_saturation", "pose_dependence", "cable_slip", "transport_delay", "loadcell_drift", "mains_hum"];
    for s in specs {
        run(&which, s, period, dur, 1);
    }
}
