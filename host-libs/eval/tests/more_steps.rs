//! The experiment a step log's diagnosis names when the log has too few steps to decide: the
//! same trial, about as many steps as the diagnosis asks for. The diagnosis says how many
//! (`too_few_steps` in its JSON); the generator makes that trial (`pam_eval::cases::MoreSteps`)
//! and its diagnosis decides.

use pam_eval::cases::{case, Case};
use pam_eval::strict::{self, FinalModel, Strict};
use pam_ident::Trial;
use pam_model::RobotModel;
use pam_model_loop::diagnose::{diagnose, Settings, Verdict, Warning};
use pam_model_loop::effects::Experiment;

/// The final model of `trial`'s diagnosis at the loop's defaults.
fn final_model(trial: &Trial) -> FinalModel {
    let model = RobotModel::<f64>::thesis();
    let (d, _) = diagnose(trial, &model, Experiment::Step, Settings::default()).expect("diagnose");
    let v = serde_json::to_value(&d).expect("json");
    strict::read(&v)
}

/// The trial of `c`, and the longer one its diagnosis names: the first log's final model,
/// the steps it has and asks for, and the longer log's final model.
fn followed(c: &Case) -> (FinalModel, (usize, usize), FinalModel) {
    let log = c.log.as_ref().expect("the generator makes the log");
    let trial = Trial::from_log(log).expect("trial");
    let first = final_model(&trial);
    let (have, need) = first
        .more_steps
        .unwrap_or_else(|| panic!("{}: no longer trial named: {first:?}", c.label));
    let longer = c
        .more_steps
        .as_ref()
        .expect("the generator can lengthen its step trial")
        .trial_with_steps(&trial, have, need)
        .expect("the longer trial");
    (first, (have, need), final_model(&longer))
}

/// pam-synth's exponential settling of the load cell's offset, 4 % of the signal, in a step
/// log of 15 steps: the drift removes a share of the held-out error that the steps do not
/// show alike, so the log cannot decide and says about how many steps would. The same trial
/// that long names the drift alone. (Two of the results page's plan's logs; measured: both
/// undecided at their own length and both named drift at the length asked for.)
#[test]
fn a_drift_too_few_steps_decide_is_named_by_the_longer_trial_the_diagnosis_asks_for() {
    for k in [132, 148] {
        let c = case("synth", 150, 740_000, k, Some(Experiment::Step));
        assert_eq!(c.family, "drift", "{}", c.label);
        let (first, (have, need), longer) = followed(&c);
        eprintln!(
            "{}: {} steps: {first:?}; {need} steps: {longer:?}",
            c.label, have
        );
        assert_eq!(strict::judge("drift", &first), Strict::Wrong, "{}", c.label);
        assert!(need > have, "{}: asks for {need} of {have} steps", c.label);
        assert_eq!(
            strict::judge("drift", &longer),
            Strict::Right,
            "{}: the longer trial says {longer:?}",
            c.label
        );
    }
}

/// The count a diagnosis asks for is a design for a power of four in five: about
/// steps × ((t_critical + 0.84) / t)², the same number in the warning and in the JSON.
#[test]
fn the_steps_a_diagnosis_asks_for_are_in_its_json_and_its_warning() {
    let c = case("synth", 150, 740_000, 132, Some(Experiment::Step));
    let trial = Trial::from_log(c.log.as_ref().expect("log")).expect("trial");
    let model = RobotModel::<f64>::thesis();
    let (d, _) = diagnose(&trial, &model, Experiment::Step, Settings::default()).expect("diagnose");
    assert_eq!(d.verdict, Verdict::None);
    assert!(!d.too_few_steps.is_empty(), "{:?}", d.warnings);
    for s in &d.too_few_steps {
        let warning = d
            .warnings
            .iter()
            .find_map(|w| match *w {
                Warning::TooFewSteps {
                    family,
                    t,
                    t_critical,
                    steps,
                    steps_needed,
                    ..
                } if family == s.family => Some((t, t_critical, steps, steps_needed)),
                _ => None,
            })
            .unwrap_or_else(|| panic!("no warning for {:?}", s.family));
        let (t, t_critical, steps, steps_needed) = warning;
        assert_eq!((steps, steps_needed), (s.steps, s.steps_needed));
        if let Some(need) = s.steps_needed {
            let design = steps as f64 * ((t_critical + 0.84) / t).powi(2);
            assert_eq!(need, design.ceil() as usize, "{s:?}: t {t}, {t_critical}");
            assert!(
                need as f64 > steps as f64 * (t_critical / t).powi(2),
                "more steps than where the expected t only reaches its critical value"
            );
        }
    }
}
