//! Logs of the independent generator (`pam-synth`) the loop once got wrong, kept so the
//! causes stay mended. Each is one case of the confusion run's plan
//! (`confusion --logs 320 --seed0 9000`), checked to be the case it was; the loop must name
//! the family the generator hid and recover its parameters in the generator's own units.
//! - 9022: a hard clip of the measured force at 11.3 N (a rig with gain ≈ 0.55), named
//!   hysteresis while the saturation's starting grid was screened at gain 1.
//! - 9257: the handle force slewing at 73 N/s up, 42 N/s down, behind a drive from the
//!   currents; the rate family then had limits in bar/s only, which fit another rate per
//!   axis, and the verdict was "none".
//! - 9058: quadratic drag of 71 N·s²/m² at 2 ms, named backlash: the last raw velocity
//!   sample (a count's jump) was the pivot of the derivative filter's end padding, so the
//!   last 70 ms carried a velocity of 0.26 m/s that was not there, and every fold's drag
//!   fit with that block in training came out negative (clamped to zero).
//! - 820 of `confusion --family delay --period-s 0.05 --seed0 800`: a sensor-sync delay
//!   sampled every 50 ms, named backlash while the delay family had whole samples only
//!   (0 or 50 ms for a lag between them).
//! - 70040 of `confusion --logs 320 --seed0 70000`: a 19 ms sensor-sync delay at 5 ms
//!   sampling, "none" while the folds scored the trial's last rows, where a delayed fit's
//!   target is the last sample standing in: its last fold lost 8.6 %, every other won.
//! - 70018 of the same run: a Maxwell-slip hysteresis at 5 ms that changes the prediction
//!   by 2.5 % of the signal and wins 9 of 10 folds (t = 2.7), "none" while the dynamic
//!   decision also asked the cross-validated gain for 0.2 % of the error beyond its
//!   parameters' penalty: in a noisy log a real effect removes only 0.4 %.
//! - 70245 of the same run: a Stribeck friction at 5 ms (2.4 % of the force, winning 8 of
//!   10 folds, signed-rank p 0.032), "none" at the old level of 2.5 % per one-sided test.
//! - 70237 of the same run: a slow wander of the level (11 % of the force) at 2 ms, "none"
//!   while a wander had to carry 20 % of the residual's variance; now it is a variance ratio
//!   against the residual's own short-range correlation.

use pam_ident::Trial;
use pam_model::RobotModel;
use pam_model_loop::diagnose::{diagnose, Settings};
use pam_model_loop::effects::Experiment as LoopExperiment;
use pam_synth::balanced::plan;
use pam_synth::{generate, Family, Shape};
use serde_json::Value;

const SEED0: u64 = 9000;

/// The case at `index` of the plan, its truth's parameters and the diagnosis as JSON.
fn diagnosis_of(index: usize, family: Family, shape: Shape) -> (Value, Value) {
    diagnosis_as(index, family, shape, LoopExperiment::Step)
}

fn diagnosis_as(
    index: usize,
    family: Family,
    shape: Shape,
    experiment: LoopExperiment,
) -> (Value, Value) {
    let spec = plan(index + 1, SEED0, None)[index].clone();
    assert_eq!(
        (spec.family, spec.shape),
        (family, shape),
        "the plan changed"
    );
    diagnosis_of_spec(&spec, experiment)
}

/// `spec`'s log generated and diagnosed: the diagnosis and the truth's parameters as JSON.
fn diagnosis_of_spec(spec: &pam_synth::CaseSpec, experiment: LoopExperiment) -> (Value, Value) {
    let g = generate(spec).expect("generating");
    let log = pam_log::read_str(&g.log_text, None).expect("the generated log");
    let trial = Trial::from_log(&log).unwrap();
    let (d, _) = diagnose(
        &trial,
        &RobotModel::thesis(),
        experiment,
        Settings::default(),
    )
    .unwrap();
    (
        serde_json::to_value(&d).unwrap(),
        serde_json::to_value(&g.truth.params).unwrap(),
    )
}

fn near(got: &Value, want: &Value, tol: f64, what: &str) {
    let (g, w) = (got.as_f64().unwrap(), want.as_f64().unwrap());
    assert!((g - w).abs() <= tol * w.abs(), "{what}: {g} against {w}");
}

#[test]
fn a_hard_clip_of_the_measured_force_is_a_saturation_at_its_level() {
    let (d, truth) = diagnosis_of(22, Family::Saturation, Shape::HardClip);
    assert_eq!(d["verdict"], "effect", "{d:#}");
    let top = &d["effects"][0];
    assert_eq!(top["family"], "saturation", "{d:#}");
    near(&top["params"]["max_n"], &truth["knee_n"], 0.05, "the clip");
}

#[test]
fn a_slew_of_the_handle_force_is_a_rate_limit_in_newtons_per_second() {
    let (d, truth) = diagnosis_of(257, Family::RateLimits, Shape::OutputSlew);
    assert_eq!(d["verdict"], "effect", "{d:#}");
    let top = &d["effects"][0];
    assert_eq!(top["family"], "rate_limits", "{d:#}");
    assert_eq!(top["shape"], "force_slew", "{d:#}");
    near(
        &top["params"]["force_rise_n_per_s"],
        &truth["rise_n_per_s"],
        0.1,
        "rise",
    );
    near(
        &top["params"]["force_fall_n_per_s"],
        &truth["fall_n_per_s"],
        0.1,
        "fall",
    );
}

#[test]
fn quadratic_drag_is_found_although_the_last_velocity_sample_jumps() {
    let (d, truth) = diagnosis_as(58, Family::Drag, Shape::Quadratic, LoopExperiment::Dynamic);
    assert_eq!(d["verdict"], "effect", "{d:#}");
    let top = &d["effects"][0];
    assert_eq!(top["family"], "drag", "{d:#}");
    near(
        &top["params"]["coeff_n_s2_per_m2"],
        &truth["drag_n_s2_per_m2"],
        0.1,
        "the drag coefficient",
    );
}

/// A dynamic trial sampled at the thesis's 50 ms whose force lags the motion by a fraction
/// of a sample: the delay family interpolates the regressors, so the lag is found and
/// measured between the samples.
#[test]
fn a_delay_between_two_samples_is_a_delay_at_its_length() {
    use pam_synth::case::{CaseSpec, MAX_SAMPLES};
    let mut spec = CaseSpec::random(
        820,
        Some(pam_synth::Experiment::Dynamic),
        Some(Family::Delay),
    )
    .expect("the case");
    assert_eq!(spec.shape, Shape::SensorSync, "the draw changed");
    spec.dt_s = 0.05;
    spec.duration_s = f64::min(spec.duration_s, MAX_SAMPLES as f64 * spec.dt_s);
    let (d, truth) = diagnosis_of_spec(&spec, LoopExperiment::Dynamic);
    let delay = truth["delay_s"].as_f64().unwrap();
    let off_grid = (delay / 0.05 - (delay / 0.05).round()).abs();
    assert!(off_grid > 0.2, "the lag {delay} s is near a whole sample");
    assert_eq!(d["verdict"], "effect", "{d:#}");
    let top = &d["effects"][0];
    assert_eq!(top["family"], "delay", "{d:#}");
    // closer than either whole sample (0 or 50 ms, both 23 ms off). Not closer: at 50 ms
    // the operator's slow motion leaves a lag partly traded against damping and mass, and
    // the estimates over 30 such logs ran 0–17 ms long (docs/model-loop.md); this one 40 ms
    let got = top["params"]["delay_s"].as_f64().unwrap();
    assert!((got - delay).abs() < 0.02, "{got} against {delay}");
}

/// The dynamic folds leave out the trial's last rows for every model: a delay's target
/// there (the force `shift` samples later) is not in the log.
#[test]
fn a_delay_is_not_judged_on_rows_past_the_end_of_the_log() {
    let spec = plan(41, 70000, None)[40].clone();
    assert_eq!(
        (spec.family, spec.shape),
        (Family::Delay, Shape::SensorSync),
        "the plan changed"
    );
    let (d, truth) = diagnosis_of_spec(&spec, LoopExperiment::Dynamic);
    assert_eq!(d["verdict"], "effect", "{d:#}");
    let top = &d["effects"][0];
    assert_eq!(top["family"], "delay", "{d:#}");
    let gains = top["folds"]["gains"].as_array().unwrap();
    assert!(
        gains.last().unwrap().as_f64().unwrap() > 0.0,
        "the last fold: {gains:?}"
    );
    // at motion well below its corner a load cell's low-pass is a lag of its group delay:
    // a dead time between two 5 ms samples and a filter of that group delay fit alike, and
    // the family's first shape is either; the lag is the one asked for
    let lag = top["params"]
        .get("delay_s")
        .or_else(|| top["params"].get("group_delay_s"))
        .unwrap_or(&Value::Null);
    near(lag, &truth["delay_s"], 0.15, "the delay");
}

/// The case at `index` of `confusion --logs 320 --seed0 70000`, diagnosed as a dynamic trial.
fn dynamic_case_70000(index: usize, family: Family, shape: Shape) -> (Value, Value) {
    let spec = plan(index + 1, 70000, None)[index].clone();
    assert_eq!(
        (spec.family, spec.shape),
        (family, shape),
        "the plan changed"
    );
    diagnosis_of_spec(&spec, LoopExperiment::Dynamic)
}

#[test]
fn a_material_hysteresis_in_a_noisy_log_is_named() {
    let (d, _) = dynamic_case_70000(18, Family::Hysteresis, Shape::MaxwellSlip);
    assert_eq!(d["verdict"], "effect", "{d:#}");
    assert_eq!(d["effects"][0]["family"], "hysteresis", "{d:#}");
}

/// A Stribeck friction that removes 0.6 % of the cross-validated error, at t = 1.2 with
/// eight folds of ten won. The exact signed-rank test, which counts the ten overlapping
/// folds as independent, passed it (p ≤ 0.05); with its null widened as the t-test's is
/// (p = 0.10) the log does not decide it, and friction leads the families tried.
#[test]
fn a_small_stribeck_friction_the_overlapping_folds_cannot_confirm_leads_but_is_not_named() {
    let (d, _) = dynamic_case_70000(245, Family::Friction, Shape::Stribeck);
    assert_eq!(d["verdict"], "none", "{d:#}");
    let top = &d["effects"][0];
    assert_eq!(top["family"], "friction", "{d:#}");
    assert_eq!(top["folds"]["wins"], 8, "{top:#}");
    let rank_p = top["folds"]["rank_p"].as_f64().unwrap();
    assert!(rank_p > 0.05 && rank_p < 0.2, "{top:#}");
}

#[test]
fn a_slow_wander_below_a_fifth_of_the_residual_is_unexplained() {
    let (d, _) = dynamic_case_70000(237, Family::Unexplained, Shape::SlowWander);
    assert_eq!(d["verdict"], "unexplained", "{d:#}");
    let u = d["unexplained"].as_array().unwrap();
    assert!(
        u.iter()
            .any(|x| x["kind"] == "slow_wander" && x["variance_share"].as_f64().unwrap() < 0.2),
        "{u:?}"
    );
}

/// The step case `seed` of `synth_matrix`'s first plan, cut to the suite's short logs
/// (45 s, at most 25 000 samples), checked to be the case it was, and diagnosed.
fn short_matrix_step_case(seed: u64, family: Family, shape: Shape) -> Value {
    let mut spec = plan(80, 20_000, None)
        .into_iter()
        .find(|c| c.seed == seed)
        .expect("in the plan");
    spec.duration_s = spec.duration_s.min(45.0).min(25_000.0 * spec.dt_s).round();
    assert_eq!(
        (spec.family, spec.shape),
        (family, shape),
        "the plan changed"
    );
    diagnosis_of_spec(&spec, LoopExperiment::Step).0
}

/// A 45 s step log whose x axis steps once, in the held-out last fifth, and whose y axis
/// steps in the training part only: x has no gain the training part could fit. Fitted and
/// scored anyway, its held-out error rewarded a one-muscle cap that "removed" 78 % of it.
/// The loop fits and scores the axes that step in the training part; the log's dead time
/// (9.8 ms) lies within the rig's own lag, so nothing is named.
#[test]
fn an_axis_that_steps_only_in_the_held_out_part_is_not_scored() {
    let d = short_matrix_step_case(20_012, Family::Delay, Shape::DeadTime);
    assert_eq!(d["verdict"], "none", "{d:#}");
}

/// Seed 20006 of `synth_matrix`'s first plan, cut to 45 s: a linear drift of the load
/// cell's offset at 10 ms, in twelve steps. Its two held-out steps remove 3.2 % of their
/// error at t = 1.8 across the held-out blocks, which does not decide; every step scored by
/// a fit of the cross-validation's folds that never saw it shows the gain (t ≈ 2.4), and the
/// drift is named.
#[test]
fn a_gain_few_held_out_steps_leave_open_is_decided_over_every_step() {
    let d = short_matrix_step_case(20_006, Family::Drift, Shape::OffsetLinear);
    assert_eq!(d["verdict"], "effect", "{d:#}");
    assert_eq!(d["effects"][0]["family"], "drift", "{d:#}");
    let evidence = d["effects"][0]["evidence"].as_str().unwrap_or_default();
    assert!(evidence.contains("cross-validated over its"), "{evidence}");
}
