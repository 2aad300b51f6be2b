//! Cases of a `confusion` run's plan, for the tests that keep what a run got wrong: the case
//! itself, its log as the loop reads it, and what the loop named.
#![allow(dead_code)]

use pam_ident::Trial;
use pam_model_loop::diagnose::Diagnosis;
use pam_synth::balanced::plan;
use pam_synth::{generate, CaseSpec, Experiment, Shape};

/// The case with `seed` of the plan from `seed0` (of `experiment`, or both), checked to be
/// the case it was.
pub fn plan_case(seed0: u64, seed: u64, experiment: Option<Experiment>, shape: Shape) -> CaseSpec {
    let n = (seed - seed0 + 1) as usize;
    let spec = plan(n, seed0, experiment)
        .into_iter()
        .find(|s| s.seed == seed)
        .expect("the seed is in the plan");
    assert_eq!(spec.shape, shape, "the plan changed");
    spec
}

/// The case's log, read as `pamctl model diagnose` reads it, and the log's text.
pub fn trial_of(spec: &CaseSpec) -> (Trial, String) {
    let g = generate(spec).unwrap();
    let log = pam_log::read_str(&g.log_text, None).unwrap();
    (Trial::from_log(&log).unwrap(), g.log_text)
}

/// What the loop named: the first effect's family, or the verdict ("none", "unexplained").
pub fn named(d: &Diagnosis) -> String {
    match d.verdict.name() {
        "effect" => d
            .effects
            .first()
            .and_then(|e| e.family.map(|f| f.name().to_string()))
            .unwrap_or_default(),
        other => other.to_string(),
    }
}
