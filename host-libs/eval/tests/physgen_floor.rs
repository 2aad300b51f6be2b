//! The model loop on a few logs of the physics generator (pam-physgen: rigid-body arm,
//! gas-volume muscles behind their regulators, literature friction and hysteresis, a load
//! cell with coloured noise and a tare in the sensor frame), judged strictly: the right
//! verdict, the right first family and no family in the final model that is not in the log.
//! A regression floor; the full runs are `cargo xtask eval --only physgen` and
//! `--only crossgen`.

use pam_eval::cases::OtherStiffness;
use pam_eval::pairs::decide;
use pam_eval::strict::{self, Tally};
use pam_ident::Trial;
use pam_model::RobotModel;
use pam_model_loop::diagnose::{diagnose, diagnose_with, Diagnosis, Settings, Verdict, Warning};
use pam_model_loop::effects::{Experiment, ModelEffect};
use pam_physgen::{generate, CaseSpec, Effect};

/// Short logs keep the test within a few seconds.
const DURATION_S: f64 = 30.0;

/// The truth's family, the final model, and what the loop found unexplained (for the report).
fn judged(spec: &CaseSpec) -> (String, strict::FinalModel, String) {
    let (d, family) = diagnosed(spec, Some(DURATION_S));
    let v = serde_json::to_value(&d).expect("json");
    let unexplained = v["unexplained"]
        .as_array()
        .map(|u| {
            u.iter()
                .filter_map(|x| x["detail"].as_str())
                .collect::<Vec<_>>()
                .join("; ")
        })
        .unwrap_or_default();
    (family, strict::read(&v), unexplained)
}

#[test]
fn the_physics_generators_logs_hold_the_floor() {
    // dynamic logs only: a step log is slow to integrate in a debug build
    let dynamic = |effect, seed, severity| CaseSpec {
        experiment: pam_physgen::Experiment::Dynamic,
        effect,
        seed,
        severity,
    };
    let specs = [
        CaseSpec::control(0, 801),
        CaseSpec::control(2, 803),
        dynamic(Effect::HandleLugre, 804, 0.9),
        dynamic(Effect::AmplifierLag, 805, 0.8),
    ];
    let mut t = Tally::default();
    let mut lines = Vec::new();
    for s in &specs {
        let (family, says, unexplained) = judged(s);
        let j = t.add(&family, &says);
        lines.push(format!(
            "{:?} {} {}: truth {family} -> {} {:?} final {:?}: {j:?} {unexplained}",
            s.experiment,
            s.effect.name(),
            s.seed,
            says.verdict,
            says.first,
            says.families
        ));
    }
    let report = lines.join("\n");
    eprintln!("{report}");
    assert!(
        t.right >= FLOOR_RIGHT,
        "{} of {} strictly right:\n{report}",
        t.right,
        t.cases
    );
    assert_eq!(t.false_alarms, 0, "a control raised an alarm:\n{report}");
}

/// Measured 4/4 strictly right and 0/2 false alarms with a null that knows the load cell
/// (its tare in its own frame in the base, a wander or a drift judged against the
/// residual's coloured noise); without it 1/4 and 2/2 (the 1/f noise read as a slow
/// wander). The floor is one log under the measure, and no control may raise an alarm.
const FLOOR_RIGHT: usize = 3;

/// A log of the physics generator (`duration_s`: `None` its full length), diagnosed with
/// the default settings, and its truth's family.
fn diagnosed(spec: &CaseSpec, duration_s: Option<f64>) -> (Diagnosis, String) {
    let g = generate(spec, duration_s).expect("generating");
    let experiment = match spec.experiment {
        pam_physgen::Experiment::Dynamic => Experiment::Dynamic,
        pam_physgen::Experiment::Step => Experiment::Step,
    };
    let log = pam_log::read_str(&g.log_text, None).expect("reading the log");
    let trial = Trial::from_log(&log).expect("a trial");
    let (d, _) = diagnose(
        &trial,
        &RobotModel::thesis(),
        experiment,
        Settings::default(),
    )
    .expect("diagnosing");
    (d, g.truth.family)
}

/// A step log of the physics generator at its full length, diagnosed.
fn step_log(spec: &CaseSpec) -> (Diagnosis, String) {
    diagnosed(spec, None)
}

/// A step control of the physics generator, diagnosed.
fn step_control(seed: u64) -> Diagnosis {
    step_log(&CaseSpec::control(1, seed)).0
}

/// The warnings of `d` that say a family had too few steps to decide.
fn too_few_steps(d: &Diagnosis) -> Vec<String> {
    d.warnings
        .iter()
        .filter(|w| matches!(w, Warning::TooFewSteps { .. }))
        .map(ToString::to_string)
        .collect()
}

/// Step controls of the physics generator: four converters and muscles that each differ,
/// each converter with a dead time of 1–4 ms and the fill of its muscle. Each of these five
/// was named an effect (rate limits or a delay, 10–12 ms) while the base had no dead time
/// and one split's held-out gain decided a step trial. With the held-out steps' spread
/// weighed and the converters' own lag in the base, each is `none`.
#[test]
fn step_controls_of_a_rig_whose_converters_lag_are_not_named() {
    let mut lines = Vec::new();
    let mut named = 0;
    for seed in [900_005, 900_007, 900_011, 900_017, 900_019] {
        let d = step_control(seed);
        if d.verdict != Verdict::None {
            named += 1;
        }
        lines.push(format!(
            "{seed}: {:?}; {}",
            d.verdict,
            too_few_steps(&d).join(" | ")
        ));
    }
    let report = lines.join("\n");
    eprintln!("{report}");
    assert_eq!(named, 0, "a step control was named:\n{report}");
}

/// In step controls a muscle's force is a few per cent off a line through its levels: the
/// converters' spread, and the muscle's force–length law at joints that give a little
/// under the load. A saturation took that for a knee below every level leveling off past
/// them: seed 720003's fourth converter capped at 0 bar toward 9 bar (41 % of the held-out
/// error removed, t = 2.5), seed 720059's converters all bent from 0 bar toward 7.7 bar.
/// A saturation that levels off within the levels, one channel's cap at or above that
/// channel's lowest level, leaves both controls `none`.
#[test]
fn a_muscle_whose_force_bends_over_all_its_levels_is_not_a_saturation() {
    for seed in [720_003, 720_059] {
        let d = step_control(seed);
        assert_eq!(d.verdict, Verdict::None, "{seed}: {:?}", d.warnings);
    }
}

/// The four converters each have their own gain, so at one pose each axis's force holds a
/// share of the other's (seed 720319's fy follows fx's steps by about 4 %). A saturation
/// took that up with a knee inside every channel's levels: 42–57 % of the held-out error
/// removed in these three controls, where a share of each axis's force in the other
/// removes as much or more. Within that spread, no saturation is named, and a warning says
/// the log cannot tell the two apart and which steps would.
#[test]
fn the_converters_spread_is_not_a_saturation() {
    let mut lines = Vec::new();
    for seed in [720_135, 720_191, 720_319] {
        let d = step_control(seed);
        let spread: Vec<String> = d
            .warnings
            .iter()
            .filter(|w| matches!(w, Warning::WithinConverterSpread { .. }))
            .map(ToString::to_string)
            .collect();
        lines.push(format!("{seed}: {:?}; {}", d.verdict, spread.join(" | ")));
    }
    let report = lines.join("\n");
    eprintln!("{report}");
    assert!(
        lines
            .iter()
            .all(|l| l.contains(": None; saturation removes")),
        "{report}"
    );
}

/// Seed 720043's load cell has a 1/f part (corner a few Hz) whose wander over the log a
/// straight line takes 9 % of the held-out error from (t = 3.4 across the held-out blocks).
/// Its change is within the line the residual's own coloured noise puts in a record of
/// that length, so the control is `none`, as in dynamic trials.
#[test]
fn a_load_cells_flicker_in_a_step_control_is_not_a_drift() {
    let d = step_control(720_043);
    assert_eq!(d.verdict, Verdict::None, "{:?}", d.warnings);
}

/// A gain of a few per cent that some held-out steps show and others do not is not named:
/// a warning says which family the log has too few steps to decide on, and how many would.
/// Seed 900017's rate limits remove 2.6 % of the held-out error at t = 1.8 across the
/// held-out blocks.
#[test]
fn a_gain_the_held_out_steps_do_not_show_alike_is_too_few_steps_to_decide() {
    let d = step_control(900_017);
    let warned = too_few_steps(&d);
    assert_eq!(d.verdict, Verdict::None, "{warned:?}");
    assert!(
        warned.iter().any(|w| w.contains("steps would decide")),
        "no family was left undecided: {:?}",
        d.warnings
    );
}

/// A few held-out steps do not decide. Seed 720303's rate limits removed 57 % of the
/// held-out error, nearly all of it at one step the base misses badly (−0.2 % without that
/// block). Seeds 730015 and 730079 hold out four of their 20 and 21 steps, which the six
/// held-out blocks cut in parts: a saturation and a pose dependence passed the blocks'
/// t-test. What
/// the held-out steps leave open the cross-validation over every step decides, and it names
/// none of these.
#[test]
fn a_few_held_out_steps_do_not_decide_a_step_control() {
    let mut lines = Vec::new();
    for seed in [720_303, 730_015, 730_079] {
        let d = step_control(seed);
        lines.push(format!(
            "{seed}: {:?} {:?}; {}",
            d.verdict,
            d.effects
                .iter()
                .filter(|e| e.accepted)
                .map(|e| &e.id)
                .collect::<Vec<_>>(),
            too_few_steps(&d).join(" | ")
        ));
    }
    let report = lines.join("\n");
    eprintln!("{report}");
    assert!(lines.iter().all(|l| l.contains(": None ")), "{report}");
}

/// Friction in the joints' bearings, in one dynamic log: at one stiffness level the
/// catalog's joint friction and the muscles' hysteresis remove nearly the same share of the
/// error (a torque that turns over a small angle after each reversal; the joint friction's
/// Maxwell-slip shapes are the hysteresis family's own), so one log cannot say which. A log
/// should be named friction, or be undecided between the two with the two-stiffness
/// experiment named; then that experiment, run and decided with the first log
/// (`pam_model_loop::stiffness_pair`), must name friction.
///
/// Measured 4 of these 4 undecided, each settled as friction by the pair. Without the joint
/// friction's Maxwell-slip shapes 3 of 4 (seed 813 named hysteresis by more than the margin:
/// its LuGre's stiction 1.2–2 × its Coulomb torque is a Stribeck peak none of the LuGre or
/// Coulomb shapes has); 2 of 4 while only the fold-by-fold spread made two families
/// ambiguous. The floors are one log under the measure.
#[test]
fn joint_friction_in_one_log_is_friction_or_undecided_with_the_deciding_experiment() {
    let specs = [
        (Effect::JointLugre, 811, 0.5),
        (Effect::JointMaxwellSlip, 812, 0.7),
        (Effect::JointLugre, 813, 0.9),
        (Effect::JointMaxwellSlip, 814, 0.3),
    ];
    let mut lines = Vec::new();
    let (mut told, mut settled) = (0, 0);
    for (effect, seed, severity) in specs {
        let spec = CaseSpec {
            experiment: pam_physgen::Experiment::Dynamic,
            effect,
            seed,
            severity,
        };
        let (family, says, _) = judged(&spec);
        let j = strict::judge(&family, &says);
        told += usize::from(matches!(
            j,
            strict::Strict::Right | strict::Strict::Undecided
        ));
        // the experiment the diagnosis names, run as a user would
        let pair = says.awaits_stiffness_pair().then(|| {
            let g = generate(&spec, Some(DURATION_S)).expect("generating");
            let other = OtherStiffness::physgen(&spec, &g.truth, Some(DURATION_S))
                .expect("a dynamic log's stiffness level");
            let a = pam_log::read_str(&g.log_text, None).expect("reading the log");
            let a = Trial::from_log(&a).expect("a trial");
            let b = other.trial().expect("the other stiffness level");
            decide(&a, &b).expect("deciding the pair").family
        });
        let named = pair.flatten().map(|f| f.name());
        let after = strict::judge(&family, &says.settled(named));
        settled += usize::from(after == strict::Strict::Right);
        lines.push(format!(
            "{} {seed}: {} {:?}, undecided {:?}, final {:?}: {j:?}; the pair named {named:?}: {after:?}",
            effect.name(),
            says.verdict,
            says.first,
            says.undecided,
            says.families
        ));
    }
    let report = lines.join("\n");
    eprintln!("{report}");
    assert!(
        told >= 3,
        "{told} of 4 named friction or left undecided with the experiment:\n{report}"
    );
    assert!(
        settled >= 3,
        "{settled} of 4 strictly right once the named experiment was run:\n{report}"
    );
}

/// The muscles' hysteresis in step trials: pam-physgen's Bouc–Wen in each muscle's force,
/// growing with its pressure and following the pressure's own motion (its overshoot
/// included). Steps on one axis move all four pressures, so a handle offset that follows each
/// axis's reference leaves most of it; each muscle's force less a share of its pressure in
/// the direction the pressure last moved (`pressure_hysteresis`) holds it. Each of these
/// four logs must be named hysteresis first, the final model holding nothing else.
/// Measured 4/4; without `pressure_hysteresis` in the catalog 1/4 (two `none`, one `delay`).
#[test]
fn the_muscles_hysteresis_in_step_trials_is_hysteresis() {
    let mut lines = Vec::new();
    let mut right = 0;
    for (seed, severity) in [
        (740_026, 0.3),
        (740_053, 0.6),
        (740_044, 0.85),
        (740_035, 0.9),
    ] {
        let spec = CaseSpec {
            experiment: pam_physgen::Experiment::Step,
            effect: Effect::MuscleBoucWen,
            seed,
            severity,
        };
        let (d, family) = step_log(&spec);
        let says = strict::read(&serde_json::to_value(&d).expect("json"));
        let j = strict::judge(&family, &says);
        right += usize::from(j == strict::Strict::Right);
        lines.push(format!(
            "{seed} ({severity}): {} {:?}, final {:?}: {j:?}",
            says.verdict, says.first, says.families
        ));
    }
    let report = lines.join("\n");
    eprintln!("{report}");
    assert!(right >= 3, "{right} of 4 strictly right:\n{report}");
}

/// The strict judgement of a dynamic pam-physgen log diagnosed against `catalog`.
fn judged_with(spec: &CaseSpec, catalog: &[&dyn ModelEffect]) -> (strict::Strict, String) {
    let g = generate(spec, Some(DURATION_S)).expect("generating");
    let log = pam_log::read_str(&g.log_text, None).expect("reading the log");
    let trial = Trial::from_log(&log).expect("a trial");
    let (d, _) = diagnose_with(
        &trial,
        &RobotModel::thesis(),
        Experiment::Dynamic,
        Settings::default(),
        catalog,
    )
    .expect("diagnosing");
    let says = strict::read(&serde_json::to_value(&d).expect("json"));
    let j = strict::judge(&g.truth.family, &says);
    let line = format!(
        "{} {:?}, final {:?}: {j:?}",
        says.verdict, says.first, says.families
    );
    (j, line)
}

/// The load cell's amplifier filter in dynamic trials: pam-physgen's critically damped
/// second order of corner 2.5–10 Hz on the force samples (a group delay of 30–130 ms, and
/// the operator's faster motion damped). Twelve 30 s logs of a contiguous seed range,
/// across the severities: measured 10 strictly right, with the catalog's `sensor_lowpass`
/// shape or without it (the dead time then takes its place). A base whose pneumatic term
/// may soften the arm at the motion's faster frequencies takes most of such a lag in: 6
/// right with the sign left free. (The weakest corner damps little of the operator's motion, and the
/// rest of the log's misfit hides it: `none`; one is named `drift`.)
#[test]
fn the_load_cell_amplifiers_filter_is_a_delay() {
    let full = pam_model_loop::effects::catalog();
    let without: Vec<&dyn ModelEffect> = full
        .iter()
        .copied()
        .filter(|e| e.id() != "load_cell_filter")
        .collect();
    let mut lines = Vec::new();
    let (mut right, mut right_without) = (0, 0);
    for k in 0..12u64 {
        let spec = CaseSpec {
            experiment: pam_physgen::Experiment::Dynamic,
            effect: Effect::AmplifierLag,
            seed: 750_000 + k,
            severity: (k as f64 + 0.5) / 12.0,
        };
        let (j, line) = judged_with(&spec, &full);
        let (j0, line0) = judged_with(&spec, &without);
        right += usize::from(j == strict::Strict::Right);
        right_without += usize::from(j0 == strict::Strict::Right);
        lines.push(format!(
            "{} ({:.2}): {line}; without the filter: {line0}",
            spec.seed, spec.severity
        ));
    }
    let report = lines.join("\n");
    eprintln!("{report}\n{right} strictly right, {right_without} without the filter's shape");
    assert!(
        right >= 9 && right >= right_without,
        "{right} of 12 strictly right, {right_without} without the filter's shape:\n{report}"
    );
}

/// A lag the log cannot confirm is said, not hidden: two of pam-physgen's weak amplifier
/// filters (30 s logs) whose delay removes more than half a per cent of the error but
/// within the fold-to-fold spread are named `none` with a warning that the force may lag
/// the motion; the controls of the same seeds (the same rig, motion and noise) get no such
/// warning.
#[test]
fn a_lag_the_log_cannot_confirm_is_reported_not_hidden() {
    for k in [6u64, 13] {
        let diagnosis = |effect, severity| {
            let spec = CaseSpec {
                experiment: pam_physgen::Experiment::Dynamic,
                effect,
                seed: 760_000 + k,
                severity,
            };
            diagnosed(&spec, Some(DURATION_S)).0
        };
        let lags = |d: &Diagnosis| {
            d.warnings
                .iter()
                .any(|w| matches!(w, Warning::ForceLagsMotion { .. }))
        };
        let lagged = diagnosis(Effect::AmplifierLag, (k as f64 + 0.5) / 40.0);
        let delay_named = lagged.effects.first().is_some_and(|e| {
            e.accepted && e.family == Some(pam_model_loop::effects::Family::Delay)
        });
        assert!(
            delay_named || lags(&lagged),
            "seed {k}: verdict {}, warnings {:?}",
            lagged.verdict,
            lagged.warnings
        );
        let control = diagnosis(Effect::Control, 0.0);
        assert!(!lags(&control), "seed {k}: {:?}", control.warnings);
    }
}

/// pam-physgen's arm is the model's two segments (eq. 4.14–4.17) with their Coriolis and
/// centrifugal torques, plus the pulleys. A Cartesian mass constant over the trial is that
/// inertia at the start's pose only: across the operator's few centimetres the elbow
/// turns it by several per cent, a residual quadratic in the motion. These five dynamic
/// controls were named `pose_dependence` (3.6–6.1 % of the cross-validated error) or
/// `stiffness_nonlinearity` (0.5–2.4 %) with the constant mass alone; with the arm's own
/// dynamics in the base (which it pays for on each) they are `none`.
#[test]
fn the_arms_own_inertia_is_not_a_pose_dependence() {
    let seeds = [730003, 730019, 730031, 730075, 730099];
    let found: Vec<(u64, Verdict, Vec<String>, Option<f64>)> = seeds
        .iter()
        .map(|&seed| {
            let (d, _) = diagnosed(&CaseSpec::control(0, seed), None);
            let v = serde_json::to_value(&d).expect("json");
            let arm = v["base"]["params"]["rigid_body_scale"].as_f64();
            (seed, d.verdict, strict::read(&v).families, arm)
        })
        .collect();
    let report = format!("{found:#?}");
    for (seed, verdict, _, arm) in &found {
        assert_eq!(*verdict, Verdict::None, "{seed}\n{report}");
        assert!(
            arm.is_some(),
            "{seed}: the base did not take the arm\n{report}"
        );
    }
}

/// A cable that slips in its groove gives way in the direction the torque pulls, so the
/// creep's coefficient (joint 1's stiffness times the slip rate) and the play's (the
/// stiffness) are never negative. Free, the creep's column, the torque's excess summed
/// over time, is a slow random walk that a negative coefficient fits to the load cell's
/// 1/f wander: these two dynamic controls were named `backlash` (play_and_creep with no
/// play, a negative slip rate, 1.5 % and 2.8 % of the cross-validated error).
#[test]
fn a_creep_that_winds_the_torque_up_is_not_a_cable_slip() {
    controls_name_nothing(&[(36, 740_075), (56, 740_115)]);
}

/// Each control (`CaseSpec::control(k, seed)`, at its full length) is `none`.
fn controls_name_nothing(controls: &[(usize, u64)]) {
    for &(k, seed) in controls {
        let (d, _) = diagnosed(&CaseSpec::control(k, seed), None);
        let v = serde_json::to_value(&d).expect("json");
        let families = strict::read(&v).families;
        assert_eq!(d.verdict, Verdict::None, "{seed}: {families:?}");
    }
}

/// Cross-validation's ten folds share most of their training rows, so their gains move
/// together, and the t-test widens its standard error for it. The signed-rank test, the
/// other way a family's gain passes, counted the folds as independent: these dynamic
/// controls were named by it alone, at t = 1.0–1.8 against 1.8 (drift 4.5 %, 2.8 % and
/// 14.3 % of the cross-validated error; `stiffness_nonlinearity` 0.5 % and 1.4 %). With its
/// null widened as the t-test's is, each is `none`.
#[test]
fn folds_that_share_their_training_rows_do_not_name_a_control() {
    controls_name_nothing(&[720_151, 720_219, 720_239, 720_307, 720_371].map(|seed| (0, seed)));
}
