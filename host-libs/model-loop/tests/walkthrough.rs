//! The walkthrough of the README and docs/model-loop.md: a twin log with a hidden
//! carrier-ball friction (`pamctl simulate --experiment dynamic --point 1 --with
//! carrier_ball_friction:coulomb_n=3 --seed 7`). The lesson a user takes home is the final
//! model: friction, and nothing the log does not hold.

use pam_ident::trial::Trial;
use pam_model::RobotModel;
use pam_model_loop::diagnose::{diagnose, Settings, Verdict};
use pam_model_loop::effects::Experiment;
use pam_twin::simulate::{run_trial, TrialSpec};

#[test]
fn the_walkthrough_final_model_is_friction_alone() {
    let mut spec = TrialSpec::new(pam_twin::simulate::Experiment::Dynamic);
    spec.point = 1;
    spec.seed = 7;
    spec.effects = vec!["carrier_ball_friction:coulomb_n=3".into()];
    let log = run_trial(&spec).unwrap();
    let trial = Trial::from_log(&log).unwrap();
    let (d, _) = diagnose(
        &trial,
        &RobotModel::<f64>::thesis(),
        Experiment::Dynamic,
        Settings::default(),
    )
    .unwrap();
    for e in &d.effects {
        println!(
            "{} {} accepted {} improvement {:.4} t {:.2} size {:.4}",
            e.id, e.shape, e.accepted, e.improvement, e.folds.t, e.effect_size
        );
    }
    for s in &d.steps {
        println!("step {:?} nrmse {:?}", s.effects, s.nrmse);
    }
    for r in &d.refinements {
        println!("refinement: {}", r.evidence);
    }
    assert_eq!(d.verdict, Verdict::Effect);
    assert_eq!(d.effects[0].id, "carrier_ball_friction");
    let last = d.steps.last().unwrap();
    assert_eq!(
        last.effects,
        ["carrier_ball_friction"],
        "the final model holds a family the log does not"
    );
    // what the other families fitted is said, not dropped
    assert!(
        d.refinements
            .iter()
            .any(|r| r.id == "muscle_hysteresis" && r.removes > 0.0),
        "{:?}",
        d.refinements
    );
}
