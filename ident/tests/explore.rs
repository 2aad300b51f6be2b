mod common;
use common::*;
use pam_ident::diagnose::{diagnose, Settings};
use pam_ident::effects::Experiment;
use pam_model::RobotModel;

#[test]
#[ignore]
fn explore() {
    let model = RobotModel::<f64>::thesis();
    let cases = vec![
        Hidden::None,
        Hidden::Friction { coulomb_n: 2.0 },
        Hidden::VelocitySquared { c: 40.0 },
        Hidden::Cubic { cubic_n: 15.0 },
        Hidden::Hysteresis { fraction: 0.04, width: 0.002 },
        Hidden::PoseQuadratic { k_per_m: 5.0 },
        Hidden::Drift { offset_n: 1.5, drift_n_per_s: 0.01 },
        Hidden::Delay { delay_s: 0.04 },
        Hidden::Hum { amplitude_n: 0.8, freq_hz: 50.0 },
    ];
    for dt in [0.05, 0.001] {
        for h in &cases {
            let tr = dynamic(&DynConfig { dt_s: dt, hidden: *h, ..Default::default() });
            let t0 = std::time::Instant::now();
            let (d, _) = diagnose(&tr, &model, Experiment::Dynamic, Settings::default()).unwrap();
            let top: Vec<String> = d.effects.iter().take(3).map(|e| format!("{}({:.3},{:.3})", e.id, e.improvement, e.score)).collect();
            println!("dt {dt} {:?}: verdict {} base {:.3}/{:.3} top {:?} unexpl {} [{:?}] params {:?}", h, d.verdict, d.base.nrmse.fx, d.base.nrmse.fy, top, d.unexplained.len(), t0.elapsed(), d.effects[0].params);
        }
    }
}

#[test]
#[ignore]
fn explore_step() {
    let model = RobotModel::<f64>::thesis();
    let cases = vec![
        Hidden::None,
        Hidden::Delay { delay_s: 0.04 },
        Hidden::SlewLimit { rate_n_per_s: 40.0 },
        Hidden::Saturation { max_n: 8.0 },
        Hidden::Hysteresis { fraction: 0.8, width: 0.0 },
        Hidden::Drift { offset_n: 1.0, drift_n_per_s: 0.01 },
        Hidden::Hum { amplitude_n: 0.8, freq_hz: 50.0 },
    ];
    for dt in [0.05, 0.001] {
        for h in &cases {
            let tr = step(&StepConfig { dt_s: dt, hidden: *h, ..Default::default() });
            let t0 = std::time::Instant::now();
            let (d, _) = diagnose(&tr, &model, Experiment::Step, Settings::default()).unwrap();
            let top: Vec<String> = d.effects.iter().take(3).map(|e| format!("{}({:.3},{:.3})", e.id, e.improvement, e.score)).collect();
            println!("dt {dt} {:?}: verdict {} base {:.3}/{:.3} {:?} top {:?} unexpl {} [{:?}] params {:?}", h, d.verdict, d.base.nrmse.fx, d.base.nrmse.fy, d.base.params, top, d.unexplained.len(), t0.elapsed(), d.effects[0].params);
        }
    }
}
