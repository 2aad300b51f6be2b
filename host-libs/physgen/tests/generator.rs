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
