//! Honest doubt where the verdict cannot show it: a 48 ms sensor-sync delay sampled every
//! 50 ms (the second generator, seed 505) is absorbed by the base's pneumatic lag, and the
//! delay's gain stays inside the fold-to-fold spread. The verdict is "none", but the
//! diagnosis must say that the force lags the motion and that the data cannot tell why;
//! the same motion without the delay must not get that warning.

use pam_ident::Trial;
use pam_model::RobotModel;
use pam_model_loop::diagnose::{diagnose, Settings};
use pam_model_loop::diagnose::{Verdict, Warning};
use pam_model_loop::effects::Experiment;
use pam_synth::{generate, CaseSpec, Family, Shape};

fn warnings(spec: &CaseSpec) -> (Verdict, Vec<Warning>) {
    let g = generate(spec).expect("generating");
    let log = pam_log::read_str(&g.log_text, None).expect("log");
    let trial = Trial::from_log(&log).expect("trial");
    let (d, _) = diagnose(
        &trial,
        &RobotModel::thesis(),
        Experiment::Dynamic,
        Settings::default(),
    )
    .expect("diagnosis");
    (d.verdict, d.warnings)
}

#[test]
fn a_lag_the_data_cannot_place_is_reported_not_hidden() {
    let delayed = CaseSpec::random(
        505,
        Some(pam_synth::Experiment::Dynamic),
        Some(Family::Delay),
    )
    .expect("spec");
    assert_eq!(delayed.dt_s, 0.05);
    let (verdict, w) = warnings(&delayed);
    let lag = w
        .iter()
        .find(|w| matches!(w, Warning::ForceLagsMotion { .. }));
    assert!(
        verdict == Verdict::Effect || lag.is_some(),
        "verdict {verdict}, warnings {w:?}"
    );
    // the same case without the delay: same motion, currents and noise
    let control = CaseSpec {
        family: Family::None,
        shape: Shape::Control,
        ..delayed
    };
    let (verdict, w) = warnings(&control);
    assert_eq!(verdict, Verdict::None);
    assert!(
        !w.iter()
            .any(|w| matches!(w, Warning::ForceLagsMotion { .. })),
        "{w:?}"
    );
}
