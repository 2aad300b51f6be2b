//! The experiment a step log's diagnosis names when it cannot tell a family from the four
//! converters' spread: the same trial at a higher co-contraction
//! (`pam_eval::cases::OtherStiffness`, as `pamctl experiment step --co-contraction high`
//! asks), decided with the first log by `pam_model_loop::spread_pair`.

use pam_eval::cases::{case, Case};
use pam_eval::strict::{self, FinalModel};
use pam_ident::Trial;
use pam_model::RobotModel;
use pam_model_loop::diagnose::{diagnose, Settings};
use pam_model_loop::effects::{Experiment, Family};
use pam_model_loop::spread_pair::{saturation_or_spread, SpreadPair};

/// The step trial of a case's log.
fn trial(c: &Case) -> Trial {
    Trial::from_log(c.log.as_ref().expect("the generator makes the log")).expect("trial")
}

/// A case's step log's final model, as the diagnosis JSON gives it.
fn first_log(c: &Case) -> FinalModel {
    let model = RobotModel::<f64>::thesis();
    let (d, _) =
        diagnose(&trial(c), &model, Experiment::Step, Settings::default()).expect("diagnose");
    strict::read(&serde_json::to_value(&d).expect("json"))
}

/// The first log's final model and the pair's decision.
fn paired(c: &Case) -> (FinalModel, SpreadPair) {
    let model = RobotModel::<f64>::thesis();
    let a = trial(c);
    let first = first_log(c);
    let b = c
        .other_stiffness
        .as_ref()
        .expect("pam-physgen makes the trial at another co-contraction")
        .trial()
        .expect("the second log");
    let pair = saturation_or_spread(&a, &b, &model, Settings::default()).expect("the pair");
    (first, pair)
}

/// pam-physgen's supply limits whose one log the converters' spread explains as well (the
/// cross-generator plan's step logs 760026 and 760037, measured: `none` with the saturation
/// within the spread) are named `saturation` by the pair, the higher co-contraction's log
/// naming it alone.
#[test]
fn a_supply_limit_the_spread_hides_is_named_by_the_pair() {
    for k in [26, 37] {
        let c = case("physgen", 150, 760_000, k, Some(Experiment::Step));
        assert_eq!(c.family, "saturation", "{}", c.label);
        let (first, pair) = paired(&c);
        eprintln!("{}: {first:?}; {}", c.label, pair.evidence);
        assert!(first.families.is_empty(), "{}: {first:?}", c.label);
        assert!(
            first.within_spread.iter().any(|f| f == "saturation"),
            "{}: {first:?}",
            c.label
        );
        assert!(pair.decided, "{}: {}", c.label, pair.evidence);
        assert_eq!(
            pair.family,
            Some(Family::Saturation),
            "{}: {}",
            c.label,
            pair.evidence
        );
        assert_eq!(pair.logs[1].final_model, [Family::Saturation]);
        let raised = (0..4)
            .filter(|&i| pair.logs[1].mean_current_ma[i] > pair.logs[0].mean_current_ma[i])
            .count();
        assert!(raised >= 2, "{}: {:?}", c.label, pair.logs);
    }
}

/// A step control whose first log names nothing, with `hidden` among the families within
/// the spread (any family, if `None`), and whose pair names none: the spread explains the
/// steps at both co-contractions.
fn assert_the_spread_stays(c: &Case, hidden: Option<&str>) {
    assert_eq!(c.family, "none", "{}", c.label);
    assert_eq!(c.experiment, Experiment::Step, "{}", c.label);
    let (first, pair) = paired(c);
    eprintln!("{}: {first:?}; {}", c.label, pair.evidence);
    assert!(first.families.is_empty(), "{}: {first:?}", c.label);
    let within = |f: &String| hidden.is_none_or(|h| f == h);
    assert!(
        first.within_spread.iter().any(within),
        "{}: {first:?}",
        c.label
    );
    assert!(pair.decided, "{}: {}", c.label, pair.evidence);
    assert_eq!(pair.family, None, "{}: {}", c.label, pair.evidence);
}

/// A control of the same plan (760028, measured: `none`, a family within the spread) stays
/// `none`: at the higher co-contraction the spread still explains the steps.
#[test]
fn a_controls_spread_stays_the_spread_at_the_higher_co_contraction() {
    assert_the_spread_stays(
        &case("physgen", 150, 760_000, 28, Some(Experiment::Step)),
        None,
    );
}

/// A step control whose four converters differ enough that their spread removes most of
/// the base's held-out error (the cross-generator plan's log 720007, measured: the spread
/// removes 86 %; a muscle hysteresis 19 % alone and nothing once the spread is in the base)
/// names nothing: the hysteresis is within the spread, and the pair leaves it there.
#[test]
fn a_controls_hysteresis_the_spread_explains_is_not_named() {
    assert_the_spread_stays(&case("physgen", 400, 720_000, 7, None), Some("hysteresis"));
}

/// A muscle hysteresis of the same plan (720034, Bouc–Wen, footprint 5 %) keeps its name:
/// with the converters' spread in the base it still removes its share of the error.
#[test]
fn a_muscle_hysteresis_keeps_its_gain_beyond_the_spread() {
    let c = case("physgen", 400, 720_000, 34, None);
    assert_eq!(c.family, "hysteresis", "{}", c.label);
    assert_eq!(c.experiment, Experiment::Step, "{}", c.label);
    let says = first_log(&c);
    eprintln!("{}: {says:?}", c.label);
    assert_eq!(says.families, ["hysteresis"], "{}: {says:?}", c.label);
    assert!(
        !says.within_spread.iter().any(|f| f == "hysteresis"),
        "{}: {says:?}",
        c.label
    );
}
