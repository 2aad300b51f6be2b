//! Step trials on the thesis's protocol (§5.2: every step on X, then every step on Y) with
//! an effect that acts on X's force only. The last 20 % of such a log holds Y's steps only,
//! so a loop scored there has no held-out evidence for the effect; holding out every fifth
//! step gives it X's steps too (`pam_ident::held_out`).
mod common;

use common::*;
use pam_model::RobotModel;
use pam_model_loop::diagnose::Verdict;
use pam_model_loop::diagnose::{diagnose, Diagnosis, Settings};
use pam_model_loop::effects::Experiment;

fn x_then_y(hidden: Hidden, hidden_on_x_only: bool, seed: u64) -> Diagnosis {
    let model = RobotModel::<f64>::thesis();
    let tr = step(&StepConfig {
        dt_s: 0.01,
        noise_n: 0.2,
        duration_s: 90.0,
        hidden,
        seed,
        x_then_y: true,
        hidden_on_x_only,
        ..Default::default()
    });
    diagnose(&tr, &model, Experiment::Step, Settings::default())
        .unwrap()
        .0
}

fn ranking(d: &Diagnosis) -> Vec<(&str, f64, bool)> {
    d.effects
        .iter()
        .map(|e| (e.id.as_str(), e.improvement, e.accepted))
        .collect()
}

#[test]
fn an_effect_on_x_alone_is_found_on_the_thesis_protocol() {
    let cases = [
        (Hidden::Saturation { max_n: 6.0 }, "pressure_saturation"),
        (
            Hidden::SlewLimit { rate_n_per_s: 30.0 },
            "asymmetric_ip_rates",
        ),
    ];
    for (k, (hidden, id)) in cases.into_iter().enumerate() {
        let d = x_then_y(hidden, true, 40 + k as u64);
        assert_eq!(d.verdict, Verdict::Effect, "{id}: {:?}", ranking(&d));
        assert_eq!(d.effects[0].id, id, "{id}: {:?}", ranking(&d));
        // X's held-out steps carry the evidence: X's error falls by a third at least
        // (scored on the last 20 %, where X holds still at 0, it fell by 14–17 %, from
        // NRMSE 1.2: a misfit level, not a step), and it removes twice the held-out error
        // the next family does (there: 0.183 against hysteresis's 0.183)
        assert!(
            d.effects[0].nrmse.fx < 0.67 * d.base.nrmse.fx,
            "{id}: held-out NRMSE fx {} against the base's {}",
            d.effects[0].nrmse.fx,
            d.base.nrmse.fx
        );
        assert!(
            d.effects[0].improvement > 2.0 * d.effects[1].improvement,
            "{id}: {:?}",
            ranking(&d)
        );
    }
}

#[test]
fn nothing_hidden_on_the_thesis_protocol_gives_none() {
    for seed in [50, 51] {
        let d = x_then_y(Hidden::None, false, seed);
        assert_eq!(d.verdict, Verdict::None, "seed {seed}: {:?}", ranking(&d));
    }
}

/// The independent generator (`pam-synth`) in the thesis's order: case `index` of
/// `confusion --logs 320 --seed0 440000 --experiment step --step-order x_then_y`, its family
/// as drawn, and the verdict's family (`None` for "none").
fn synth_x_then_y(index: u64) -> (pam_synth::Family, Option<String>) {
    use pam_synth::case::StepOrder;
    let plan = pam_synth::balanced::plan(320, 440_000, Some(pam_synth::Experiment::Step));
    let spec = pam_synth::CaseSpec {
        step_order: StepOrder::XThenY,
        ..plan[index as usize].clone()
    };
    assert_eq!(spec.seed, 440_000 + index, "the plan changed");
    let g = pam_synth::generate(&spec).expect("generating");
    let log = pam_log::read_str(&g.log_text, None).expect("the generated log");
    let trial = pam_ident::Trial::from_log(&log).unwrap();
    let d = diagnose(
        &trial,
        &RobotModel::thesis(),
        Experiment::Step,
        Settings::default(),
    )
    .unwrap()
    .0;
    let named = (d.verdict == Verdict::Effect).then(|| d.effects[0].id.clone());
    (spec.family, named)
}

/// On that run the last-fifth split gave 277/320 with 11 false alarms in 80 controls; every
/// fifth step gives 305/320 and 1 (docs/model-loop.md, "Which rows are held out"). Two
/// controls it named `asymmetric_ip_rates`, a saturation it called "none" and a hysteresis
/// it named saturation; and a case that would crash a split that lost a step's last row.
#[test]
fn the_independent_generator_in_the_thesis_order() {
    for index in [27, 139] {
        let (family, named) = synth_x_then_y(index);
        assert_eq!(family, pam_synth::Family::None);
        assert_eq!(named, None, "control {index}");
    }
    for (index, want, id) in [
        (60, pam_synth::Family::Saturation, "pressure_saturation"),
        (129, pam_synth::Family::Hysteresis, "muscle_hysteresis"),
        // a trial step of the rate fit went NaN and the simulation's clamp panicked
        (232, pam_synth::Family::RateLimits, "asymmetric_ip_rates"),
    ] {
        let (family, named) = synth_x_then_y(index);
        assert_eq!(family, want);
        assert_eq!(named.as_deref(), Some(id), "case {index}");
    }
}
