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

#[test]
#[ignore]
fn twin_matrix() {
    use pam_twin::experiments::ExperimentConfig;
    let cases: Vec<(&str, Experiment)> = vec![
        ("carrier_ball_friction:coulomb_n=1", Experiment::Dynamic),
        ("carrier_ball_friction:coulomb_n=3", Experiment::Dynamic),
        ("velocity_squared:coeff_n_s2_per_m2=150", Experiment::Dynamic),
        ("velocity_squared:coeff_n_s2_per_m2=400", Experiment::Dynamic),
        ("muscle_hysteresis:fraction=0.04", Experiment::Dynamic),
        ("muscle_hysteresis:fraction=0.08", Experiment::Dynamic),
        ("pose_dependence:gain_per_rad_1=0.3,gain_per_rad_2=-0.2", Experiment::Dynamic),
        ("pose_dependence:gain_per_rad_1=0.8,gain_per_rad_2=-0.5", Experiment::Dynamic),
        ("cable_slip:backlash_rad=0.008", Experiment::Dynamic),
        ("cable_slip:backlash_rad=0.016", Experiment::Dynamic),
        ("asymmetric_ip_rates:inflation_s=2.412,deflation_s=1.608", Experiment::Step),
        ("asymmetric_ip_rates:inflation_s=4,deflation_s=2.5", Experiment::Step),
    ];
    for (period, noise, dur) in [(0.05, 0.15, 90.0), (0.001, 0.6, 60.0), (0.01, 0.3, 90.0)] {
        for (spec, e) in &cases {
            let mut tw = TwinConfig::thesis();
            tw.seed = 7;
            tw.sensors.loadcell_noise_n = [noise; 2];
            tw.effects = EffectSet::parse_list(&[*spec]).unwrap();
            let mut cfg = ExperimentConfig::new(tw);
            cfg.period_s = period;
            let log = if *e == Experiment::Dynamic { dynamic_trial(&cfg, 1, StiffnessLevel::Low, dur).unwrap() } else { force_step_test(&cfg, [0.0, 0.0]).unwrap() };
            let tr = Trial::from_log(&log).unwrap();
            let (d, _) = diagnose(&tr, &RobotModel::<f64>::thesis(), *e, Settings::default()).unwrap();
            let top = &d.effects[0];
            println!("M {period} {spec:<58} {} top {} ({:.3}) params {:?}", d.verdict, top.id, top.improvement, top.params.iter().map(|(k, v)| format!("{k}={v:.3}")).collect::<Vec<_>>());
        }
    }
}

#[test]
#[ignore]
fn twin_rates_debug() {
    let mut tw = TwinConfig::thesis();
    tw.seed = 91;
    tw.sensors.loadcell_noise_n = [0.6; 2];
    tw.effects = EffectSet::parse_list(&["asymmetric_ip_rates:inflation_s=4,deflation_s=2.5"]).unwrap();
    let mut cfg = pam_twin::experiments::ExperimentConfig::new(tw);
    cfg.period_s = 0.001;
    let log = force_step_test(&cfg, [0.0, 0.0]).unwrap();
    let tr = Trial::from_log(&log).unwrap();
    let (d, _) = diagnose(&tr, &RobotModel::<f64>::thesis(), Experiment::Step, Settings::default()).unwrap();
    println!("{:#?}", d.base);
    for e in &d.effects { println!("{} {:.4} {:?} {:?}", e.id, e.improvement, e.nrmse, e.params); }
}
