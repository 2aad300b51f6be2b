//! A force that lags the motion is a delay, not the base's: a 48 ms sensor-sync delay
//! sampled every 50 ms (the second generator, seed 505) is named first. The base's
//! pneumatic term only stiffens (the gas in a stretched muscle is compressed), so it cannot
//! take the lag in; the same motion without the delay names nothing and warns of no lag.

use pam_ident::Trial;
use pam_model::RobotModel;
use pam_model_loop::diagnose::{diagnose, Settings};
use pam_model_loop::diagnose::{Verdict, Warning};
use pam_model_loop::effects::Experiment;
use pam_synth::{generate, CaseSpec, Family, Shape};

fn diagnosed(spec: &CaseSpec) -> (Verdict, Option<String>, Vec<Warning>) {
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
    let first = d
        .effects
        .first()
        .filter(|e| e.accepted)
        .map(|e| e.id.clone());
    (d.verdict, first, d.warnings)
}

#[test]
fn a_lag_the_base_cannot_take_in_is_named_a_delay() {
    let delayed = CaseSpec::random(
        505,
        Some(pam_synth::Experiment::Dynamic),
        Some(Family::Delay),
    )
    .expect("spec");
    assert_eq!(delayed.dt_s, 0.05);
    let (verdict, first, w) = diagnosed(&delayed);
    assert_eq!(verdict, Verdict::Effect, "warnings {w:?}");
    assert_eq!(first.as_deref(), Some("transport_delay"), "warnings {w:?}");
    // the same case without the delay: same motion, currents and noise
    let control = CaseSpec {
        family: Family::None,
        shape: Shape::Control,
        ..delayed
    };
    let (verdict, first, w) = diagnosed(&control);
    assert_eq!(verdict, Verdict::None, "{first:?}");
    assert!(
        !w.iter()
            .any(|w| matches!(w, Warning::ForceLagsMotion { .. })),
        "{w:?}"
    );
}
