//! The diagnosis does not depend on how many threads run it: every parallel part (the
//! effects, the cutoffs' preparations, the base variants, the step drive's candidates, the
//! step fit's screen and refinement, the Levenberg–Marquardt Jacobian) collects its results
//! in a fixed order and chooses among them as a serial loop would. The same second-generator
//! logs are diagnosed on one, two and three threads and the `--json` must be identical.

use pam_ident::Trial;
use pam_model::RobotModel;
use pam_model_loop::diagnose::{diagnose, Settings};
use pam_model_loop::effects::Experiment as LoopExperiment;
use pam_synth::balanced::plan;
use pam_synth::{generate, Experiment, Family};

fn diagnosis_on(threads: usize, trial: &Trial, experiment: LoopExperiment) -> String {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("a thread pool");
    pool.install(|| {
        let (d, _) = diagnose(
            trial,
            &RobotModel::thesis(),
            experiment,
            Settings::default(),
        )
        .expect("a diagnosis");
        serde_json::to_string(&d).expect("JSON")
    })
}

#[test]
fn the_diagnosis_is_the_same_on_one_two_and_three_threads() {
    let cases = plan(40, 9000, None);
    // a dynamic trial with an effect, and a step trial whose fit screens a grid of starts
    let dynamic = cases
        .iter()
        .find(|c| c.experiment == Experiment::Dynamic && c.family == Family::Friction)
        .expect("a dynamic friction case in the plan");
    let step = cases
        .iter()
        .find(|c| c.experiment == Experiment::Step && c.family == Family::RateLimits)
        .expect("a step rate-limit case in the plan");
    for (spec, experiment) in [
        (dynamic, LoopExperiment::Dynamic),
        (step, LoopExperiment::Step),
    ] {
        let g = generate(spec).expect("generating");
        let log = pam_log::read_str(&g.log_text, None).expect("the generated log");
        let trial = Trial::from_log(&log).expect("a trial");
        let one = diagnosis_on(1, &trial, experiment);
        assert!(one.contains("\"verdict\":\"effect\""), "{one}");
        for threads in [2, 3] {
            assert_eq!(
                diagnosis_on(threads, &trial, experiment),
                one,
                "{spec:?} on {threads} threads"
            );
        }
    }
}
