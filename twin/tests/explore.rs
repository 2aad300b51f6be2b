mod common;
use common::*;
use pam_model::RobotModel;
use pam_twin::experiments::*;

#[test]
#[ignore]
fn explore() {
    let cfg = ExperimentConfig::thesis();
    let model = RobotModel::new(cfg.twin.params);
    for level in [StiffnessLevel::Low, StiffnessLevel::High] {
        let log = dynamic_trial(&cfg, 1, level, 90.0).unwrap();
        let fit = fit_msd(&log, &model, [0.0, 0.0]);
        let k = trial_stiffness(&model, [0.0, 0.0], level);
        println!("{level:?} model K_C {:?}", model.cartesian_stiffness([0.0, 0.0], k).unwrap());
        println!("model M_C {:?}", model.cartesian_mass([0.0, 0.0]).unwrap());
        println!("{fit:?}");
    }
    for (i, pose) in STEP_POSES_DEG.iter().enumerate() {
        let log = force_step_test(&cfg, *pose).unwrap();
        let st = analyse_steps(&log);
        let g: Vec<String> = st.iter().map(|s| format!("{:.2}/{:.2}/{:.1}", s.gain, s.zeta.unwrap_or(f64::NAN), s.omega_n_rad_s.unwrap_or(f64::NAN))).collect();
        println!("pose {i} {pose:?}: {}", g.join(" "));
    }
}
