//! The loop on logs whose recording adds what a rig's does (pam-synth's nuisances): a loop
//! with jitter, and isolated spikes in the force. Each case is one of a confusion run's plan
//! (`confusion --logs 320 --seed0 430000 [--experiment step] --nuisance …`) that the loop
//! got wrong before:
//! - jittered step logs were simulated as if evenly sampled (or, beyond ±25 %, resampled,
//!   which moves a step by up to half a period and draws chords through the rises): a
//!   control was named `rate_limits`, a tube lag "none", and once the model ran at the
//!   logged times a mains tone's line was smeared by the clock's drift until the spectrum
//!   was taken on even times;
//! - a spiked step log with an exponential drift was called "none": a few spikes of 10–30 N
//!   doubled the held-out error.

use pam_ident::Trial;
use pam_model::RobotModel;
use pam_model_loop::diagnose::{diagnose, loop_without_spikes, Diagnosis, Settings, Warning};
use pam_model_loop::effects::Experiment as LoopExperiment;
use pam_synth::{generate, CaseSpec, Experiment, Family, NuisancePlan, Shape};

const SEED0: u64 = 430000;

mod synth_cases;
use synth_cases::{named, plan_case, trial_of};

/// The case with `seed` of the plan (step logs only, or both experiments), checked to be the
/// case it was, with the nuisances of `nuisance`.
fn case(seed: u64, step_only: bool, shape: Shape, nuisance: &str) -> CaseSpec {
    let mut spec = plan_case(SEED0, seed, step_only.then_some(Experiment::Step), shape);
    spec.nuisances = NuisancePlan::parse(nuisance).unwrap().for_seed(seed);
    spec
}

fn diagnosed(spec: &CaseSpec) -> (Diagnosis, String) {
    let (trial, text) = trial_of(spec);
    let model = RobotModel::<f64>::thesis();
    let (d, _) = diagnose(&trial, &model, LoopExperiment::Step, Settings::default()).unwrap();
    (d, text)
}

#[test]
fn a_jittered_step_log_is_simulated_at_its_logged_times() {
    let cases = [
        (430006, Shape::TubeLag, "jitter=0.25", Family::Delay.name()),
        (430027, Shape::Control, "jitter=0.25", "none"),
        (430047, Shape::Control, "jitter=0.15", "none"),
        (430030, Shape::MainsTone, "jitter=0.15", "unexplained"),
    ];
    let mut wrong = Vec::new();
    for (seed, shape, nuisance, want) in cases {
        let spec = case(seed, true, shape, nuisance);
        let (d, _) = diagnosed(&spec);
        if named(&d) != want {
            wrong.push(format!(
                "seed {seed} with {nuisance}: {:?} / {:?}, not {want}",
                d.verdict,
                d.effects.first().map(|e| &e.id)
            ));
        }
        assert!(
            d.warnings
                .iter()
                .any(|w| matches!(w, Warning::Resampled | Warning::UnevenSampling { .. })),
            "seed {seed}: the warnings say nothing of the sampling: {:?}",
            d.warnings
        );
    }
    assert!(wrong.is_empty(), "{wrong:#?}");
}

#[test]
fn spikes_are_bridged_and_the_drift_behind_them_is_named() {
    let spec = case(430041, false, Shape::OffsetExponential, "spikes=0.002");
    let (d, spiked) = diagnosed(&spec);
    assert_eq!(named(&d), Family::Drift.name(), "{:?}", d.verdict);
    // the rows the nuisance spiked: where the log differs from the same seed's without it
    // (the nuisances draw from their own stream)
    let clean = generate(&CaseSpec {
        nuisances: Default::default(),
        ..spec.clone()
    })
    .unwrap();
    let rows = |text: &str| -> Vec<[f64; 3]> {
        let log = pam_log::read_str(text, None).unwrap();
        let t = log.require("t_s").unwrap();
        let (fx, fy) = (log.require("fx_n").unwrap(), log.require("fy_n").unwrap());
        (0..t.len()).map(|i| [t[i], fx[i], fy[i]]).collect()
    };
    let injected: Vec<f64> = rows(&spiked)
        .iter()
        .zip(rows(&clean.log_text))
        .filter(|(a, b)| a[1] != b[1] || a[2] != b[2])
        .map(|(a, _)| a[0])
        .collect();
    let report = d.spikes.as_ref().expect("spikes reported");
    assert!(
        report.rows as f64 >= 0.8 * injected.len() as f64 && report.rows <= injected.len(),
        "bridged {} of {} spikes",
        report.rows,
        injected.len()
    );
    for t in &report.first_t_s {
        assert!(injected.contains(t), "t = {t} s was bridged but not spiked");
    }
    // `pamctl model compare` and `fit` start from the same cleaned loop as the diagnosis
    let log = pam_log::read_str(&spiked, None).unwrap();
    let trial = Trial::from_log(&log).unwrap();
    let model = RobotModel::<f64>::thesis();
    let (_, base, again) =
        loop_without_spikes(&trial, &model, LoopExperiment::Step, Settings::default()).unwrap();
    assert_eq!(again.as_ref(), Some(report));
    assert_eq!([d.base.nrmse.fx, d.base.nrmse.fy], base.nrmse);
    // the same log without spikes: nothing bridged, the same family
    let (d, _) = diagnosed(&CaseSpec {
        nuisances: Default::default(),
        ..spec
    });
    assert!(d.spikes.is_none());
    assert_eq!(named(&d), Family::Drift.name());
}
