mod common;
use common::*;
use pam_model::RobotModel;
use pam_twin::experiments::*;

#[test]
#[ignore]
fn explore() {
    for wn in [23.04, 5.0, 1.0] {
        let mut cfg = ExperimentConfig::thesis();
        cfg.twin.params.ip.natural_freq_rad_s = wn;
        cfg.twin.params.ip.damping_ratio = 0.7;
        cfg.settle_s = 20.0;
        let model = RobotModel::new(cfg.twin.params);
        let log = dynamic_trial(&cfg, 1, StiffnessLevel::Low, 90.0).unwrap();
        let fit = fit_msd(&log, &model, [0.0, 0.0]);
        println!("wn {wn}: {fit:?}");
    }
}
