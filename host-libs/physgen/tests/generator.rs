//! The generator's logs: read by pam-log's strict reader, truth files the judge reads,
//! the same per seed.

use pam_physgen::{generate, CaseSpec, Effect, Experiment};

fn spec(experiment: Experiment, effect: Effect, seed: u64) -> CaseSpec {
    CaseSpec {
        experiment,
        effect,
        seed,
        severity: 0.5,
    }
}

#[test]
fn logs_pass_the_strict_reader_and_truth_files_parse_as_the_judges() {
    for (e, f) in [
        (Experiment::Dynamic, Effect::JointLugre),
        (Experiment::Step, Effect::ChokedFlow),
        (Experiment::Dynamic, Effect::Control),
    ] {
        let g = generate(&spec(e, f, 11), Some(8.0)).unwrap();
        let log = pam_log::read_str(&g.log_text, None).unwrap();
        assert_eq!(log.len(), 8000);
        assert_eq!(log.meta("experiment"), Some(e.name()));
        assert_eq!(log.column("fx_ref_n").is_some(), e == Experiment::Step);
        let t: pam_synth::Truth = serde_json::from_str(&g.truth.to_json().unwrap()).unwrap();
        assert_eq!(t.family.name(), f.family());
        if f == Effect::Control {
            assert_eq!(g.truth.relative_size, 0.0);
        } else {
            assert!(g.truth.relative_size > 0.0);
        }
    }
}

#[test]
fn the_same_seed_gives_the_same_log_and_another_seed_another() {
    let a = generate(
        &spec(Experiment::Dynamic, Effect::MuscleBoucWen, 5),
        Some(6.0),
    )
    .unwrap();
    let b = generate(
        &spec(Experiment::Dynamic, Effect::MuscleBoucWen, 5),
        Some(6.0),
    )
    .unwrap();
    let c = generate(
        &spec(Experiment::Dynamic, Effect::MuscleBoucWen, 6),
        Some(6.0),
    )
    .unwrap();
    assert_eq!(a.log_text, b.log_text);
    assert_eq!(a.truth, b.truth);
    assert_ne!(a.log_text, c.log_text);
}

#[test]
fn the_tare_turns_with_the_handle_and_the_angles_are_encoder_counts() {
    let g = generate(&spec(Experiment::Dynamic, Effect::Control, 21), Some(6.0)).unwrap();
    let log = pam_log::read_str(&g.log_text, None).unwrap();
    let q = std::f64::consts::TAU / 8000.0;
    for a in log.column("alpha1_rad").unwrap() {
        assert!(((a / q) - (a / q).round()).abs() < 1e-6);
    }
    assert!(g.truth.load_cell.tare_n.iter().any(|t| t.abs() > 0.0));
    assert!(g.truth.load_cell.pink_n > 0.0 && g.truth.load_cell.ar_n > 0.0);
}

#[test]
fn a_step_trial_at_a_higher_co_contraction_keeps_its_schedule_and_its_supply() {
    let s = spec(Experiment::Step, Effect::SupplyLimit, 21);
    let low = generate(&s, Some(30.0)).unwrap();
    let high = pam_physgen::generate_at_stiffness(&s, Some(30.0), 0.8).unwrap();
    let read = |g: &pam_physgen::Generated| pam_log::read_str(&g.log_text, None).unwrap();
    let (a, b) = (read(&low), read(&high));
    // the same references, the same supply ceiling
    for c in ["fx_ref_n", "fy_ref_n"] {
        assert_eq!(a.column(c), b.column(c), "{c}");
    }
    assert_eq!(low.truth.params["cap_bar"], high.truth.params["cap_bar"]);
    // every joint at least as stiff, one stiffer, so every channel's mean current higher
    let k = |g: &pam_physgen::Generated, j: usize| {
        g.truth.base[&format!("joint_stiffness_nm_per_rad_{j}")]
    };
    assert!((1..=2).all(|j| k(&high, j) >= k(&low, j)));
    assert!((1..=2).any(|j| k(&high, j) > 1.05 * k(&low, j)));
    let mean = |l: &pam_log::Log, c: &str| {
        let v = l.column(c).unwrap();
        v.iter().sum::<f64>() / v.len() as f64
    };
    let raised = ["i1_ma", "i2_ma", "i3_ma", "i4_ma"]
        .iter()
        .filter(|c| mean(&b, c) > mean(&a, c))
        .count();
    assert!(raised >= 2, "{raised} channels raised");
    assert_eq!(high.truth.base["step_stiffness_level"], 0.8);
}
