//! The loop on dynamic trials whose operator moves otherwise than the generator's first
//! motion (pam-synth's `motion.rs`). Reach-and-hold is the case that failed: while the
//! handle rests, the encoders' rounding is frozen, and the model predicts the force of the
//! rounded angle, so the residual takes a new level at every rest. On 40 controls
//! (`confusion --logs 160 --seed0 500000 --experiment dynamic --motion reach_and_hold`)
//! 8 were named "unexplained" (a slow wander) and one a load-cell drift; with the encoders'
//! counts taken from the log's own lattice and carried through the fitted model
//! (`diagnose::encoder_floor`), a wander or a drift within that rounding is said and not
//! named. Real slow effects of 2–3 % under the same motion must still be named.

use pam_ident::Trial;
use pam_model::RobotModel;
use pam_model_loop::diagnose::{
    compare, diagnose, encoder_floor, loop_without_spikes, Diagnosis, Settings, Warning,
};
use pam_model_loop::effects::Experiment as LoopExperiment;
use pam_synth::{CaseSpec, Experiment, Family, NuisancePlan, OperatorMotion, Shape};

const SEED0: u64 = 500000;

mod synth_cases;
use synth_cases::{named, plan_case, trial_of};

/// The dynamic case with `seed` of the plan, checked to be the case it was, with the
/// operator's motion `motion`.
fn case(seed: u64, shape: Shape, motion: OperatorMotion) -> CaseSpec {
    let mut spec = plan_case(SEED0, seed, Some(Experiment::Dynamic), shape);
    spec.motion = motion;
    spec
}

fn trial(spec: &CaseSpec) -> Trial {
    trial_of(spec).0
}

/// A wander set aside as the encoders' rounding.
fn is_rounding(w: &Warning) -> bool {
    matches!(w, Warning::WanderWithinEncoderRounding { .. })
}

fn diagnosed(spec: &CaseSpec) -> Diagnosis {
    let model = RobotModel::<f64>::thesis();
    let settings = Settings::default();
    diagnose(&trial(spec), &model, LoopExperiment::Dynamic, settings)
        .unwrap()
        .0
}

#[test]
fn a_frozen_encoder_count_is_neither_a_wander_nor_a_drift() {
    let cases = [
        (500023, "unexplained before: a wander"),
        (500035, "unexplained before: a wander"),
        (500051, "a drift before"),
    ];
    let mut wrong = Vec::new();
    for (seed, before) in cases {
        let d = diagnosed(&case(seed, Shape::Control, OperatorMotion::ReachAndHold));
        if named(&d) != "none" {
            wrong.push(format!("control {seed} ({before}) named {}", named(&d)));
        }
        let said = d.warnings.iter().any(is_rounding)
            || d.effects
                .iter()
                .any(|e| e.evidence.contains("their rounding"));
        if !said {
            wrong.push(format!(
                "control {seed}: nothing says why the slow structure was not named: {:?}",
                d.warnings
            ));
        }
    }
    // recorded with jitter and lost frames, the log is resampled and its angles leave the
    // lattice: the counts are read at the logged rows
    let mut spec = case(500035, Shape::Control, OperatorMotion::ReachAndHold);
    spec.nuisances = NuisancePlan::parse("jitter=0.3,drops=0.01")
        .unwrap()
        .for_seed(500035);
    let d = diagnosed(&spec);
    let resampled = d.warnings.contains(&Warning::Resampled);
    let said = d.warnings.iter().any(is_rounding);
    assert!(
        resampled && said && named(&d) == "none",
        "resampled control 500035 named {}: {:?}",
        named(&d),
        d.warnings
    );
}

#[test]
fn slow_effects_beyond_the_rounding_are_still_named_under_reach_and_hold() {
    let cases = [
        (500022, Shape::SlowWander, "unexplained"),
        (500142, Shape::SlowWander, "unexplained"),
        (500138, Shape::OffsetExponential, "drift"),
        (500065, Shape::OffsetLinear, "drift"),
    ];
    let mut wrong = Vec::new();
    for (seed, shape, want) in cases {
        let d = diagnosed(&case(seed, shape, OperatorMotion::ReachAndHold));
        if named(&d) != want {
            wrong.push(format!("{seed} {shape:?}: named {}, not {want}", named(&d)));
        }
    }
    assert!(wrong.is_empty(), "{wrong:#?}");
}

/// The floor is the encoders' count through the model: found on the generator's 8000-count
/// encoders, of the size the stiffness gives, and absent on a sines trial whose angles were
/// moved off the lattice (as a resampling or an interpolating encoder would).
#[test]
fn the_floor_is_the_count_through_the_stiffness() {
    let model = RobotModel::<f64>::thesis();
    let spec = case(500035, Shape::Control, OperatorMotion::ReachAndHold);
    let t = trial(&spec);
    let (lp, base, _) =
        loop_without_spikes(&t, &model, LoopExperiment::Dynamic, Settings::default()).unwrap();
    let floor = encoder_floor(&lp, &base).expect("a floor on counted angles");
    // `pamctl model compare` says it too
    let said = compare(&lp, &base).warnings;
    assert!(said.iter().any(is_rounding), "{said:?}");
    let count = 2.0 * std::f64::consts::PI / 8000.0;
    for q in floor.step_rad {
        assert!((q / count - 1.0).abs() < 1e-6, "count {q} rad");
    }
    // K J q/√12 with the thesis's K (a few hundred N/m) and J (≈ 0.3–0.5 m/rad): a few
    // hundredths of a newton, of which the holds keep a share
    for a in 0..2 {
        let (e, b) = (floor.expected_n[a], floor.bound_n[a]);
        assert!(
            (0.005..0.1).contains(&e) && b > e && b < 3.0 * e,
            "{floor:?}"
        );
    }

    let mut off = t.clone();
    for (i, a) in off.alpha_rad[0].iter_mut().enumerate() {
        *a += 1e-7 * ((i * 7919) % 1000) as f64;
    }
    let (lp, base, _) =
        loop_without_spikes(&off, &model, LoopExperiment::Dynamic, Settings::default()).unwrap();
    let floor = encoder_floor(&lp, &base).expect("joint 2 still counted");
    assert_eq!(floor.step_rad[0], 0.0, "joint 1 is off its lattice");
}

/// Controls under reach-and-hold, short (45 s) and at the generator's mixed sampling: the
/// a loop that does not allow for the encoders' rounding names a wander or a drift on about
/// a quarter of them.
#[test]
fn controls_under_reach_and_hold_raise_few_alarms() {
    const CONTROLS: u64 = 24;
    let model = RobotModel::<f64>::thesis();
    let alarms: Vec<String> = (0..CONTROLS)
        .map(|k| {
            let mut spec =
                CaseSpec::random(610_000 + k, Some(Experiment::Dynamic), Some(Family::None))
                    .unwrap();
            spec.motion = OperatorMotion::ReachAndHold;
            spec.duration_s = spec.duration_s.min(45.0).min(25_000.0 * spec.dt_s).round();
            spec
        })
        .collect::<Vec<_>>()
        .chunks(12)
        .flat_map(|chunk| {
            std::thread::scope(|s| {
                let handles: Vec<_> = chunk
                    .iter()
                    .map(|spec| {
                        let model = &model;
                        s.spawn(move || {
                            let d = diagnose(
                                &trial(spec),
                                model,
                                LoopExperiment::Dynamic,
                                Settings::default(),
                            )
                            .unwrap()
                            .0;
                            (spec.seed, named(&d))
                        })
                    })
                    .collect();
                handles
                    .into_iter()
                    .map(|h| h.join().unwrap())
                    .collect::<Vec<_>>()
            })
        })
        .filter(|(_, said)| said != "none")
        .map(|(seed, said)| format!("control {seed} named {said}"))
        .collect();
    println!("{alarms:#?}");
    assert!(
        alarms.len() <= 1,
        "{} of {CONTROLS}: {alarms:#?}",
        alarms.len()
    );
}
