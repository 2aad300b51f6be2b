//! The generator's contract: deterministic per seed, each shape changes the force and
//! nothing else, the effect lands at its relative size, the log reads back as format v1.

use pam_synth::{columns, generate, CaseSpec, Experiment, Family, Shape};

/// A short case of `shape` (fast enough for the tone).
fn short(seed: u64, e: Experiment, shape: Shape) -> CaseSpec {
    let mut c = CaseSpec::random(seed, Some(e), Some(shape.family())).unwrap();
    c.dt_s = if shape.needs_fast_sampling() {
        0.005
    } else {
        0.01
    };
    c.duration_s = 15.0;
    c.with_shape(shape).unwrap()
}

fn all_cases() -> Vec<(Experiment, Shape)> {
    let mut v = Vec::new();
    for e in Experiment::ALL {
        for s in Shape::ALL {
            if s != Shape::Control && s.experiments().contains(&e) {
                v.push((e, s));
            }
        }
    }
    v
}

#[test]
fn same_seed_same_log() {
    for e in Experiment::ALL {
        let spec = CaseSpec::random(42, Some(e), None).unwrap();
        let a = generate(&spec).unwrap();
        let b = generate(&spec).unwrap();
        assert_eq!(a.log_text, b.log_text);
        assert_eq!(a.truth, b.truth);
        let other = generate(&CaseSpec { seed: 43, ..spec }).unwrap();
        assert_ne!(a.log_text, other.log_text);
    }
}

#[test]
fn each_shape_changes_the_force_and_nothing_else() {
    for (i, (e, s)) in all_cases().into_iter().enumerate() {
        let spec = short(100 + i as u64, e, s);
        let control = CaseSpec {
            family: Family::None,
            shape: Shape::Control,
            ..spec.clone()
        };
        let with = pam_log::read_str(&generate(&spec).unwrap().log_text, None).unwrap();
        let without = pam_log::read_str(&generate(&control).unwrap().log_text, None).unwrap();
        for c in columns(e) {
            let (a, b) = (with.column(c).unwrap(), without.column(c).unwrap());
            let diff = a
                .iter()
                .zip(b)
                .map(|(x, y)| (x - y).abs())
                .fold(0.0, f64::max);
            if c == "fx_n" || c == "fy_n" {
                continue;
            }
            assert_eq!(diff, 0.0, "{} changes {c}", s.name());
        }
        let diff: f64 = ["fx_n", "fy_n"]
            .iter()
            .map(|c| {
                let (a, b) = (with.column(c).unwrap(), without.column(c).unwrap());
                a.iter()
                    .zip(b)
                    .map(|(x, y)| (x - y).abs())
                    .fold(0.0, f64::max)
            })
            .fold(0.0, f64::max);
        assert!(diff > 0.01, "{} leaves the force alone ({diff})", s.name());
    }
}

#[test]
fn relative_size_lands_in_range() {
    for (i, (e, s)) in all_cases().into_iter().enumerate() {
        for k in 0..1u64 {
            let spec = short(500 + 10 * i as u64 + k, e, s);
            let t = generate(&spec).unwrap().truth;
            assert!(
                (0.02 * 0.95..=0.25 * 1.05).contains(&t.relative_size),
                "{}: relative size {} (target {})",
                s.name(),
                t.relative_size,
                t.target_relative_size
            );
            assert!(!t.params.is_empty(), "{} has no parameters", s.name());
        }
    }
}

#[test]
fn log_reads_back_with_the_rig_columns_and_no_truth() {
    for e in Experiment::ALL {
        let spec = CaseSpec::random(7, Some(e), Some(Family::Drift)).unwrap();
        let g = generate(&spec).unwrap();
        let log = pam_log::read_str(&g.log_text, None).unwrap();
        assert_eq!(log.columns(), columns(e).as_slice());
        assert_eq!(log.len(), spec.samples());
        assert_eq!(log.meta("experiment"), Some(e.name()));
        assert_eq!(log.meta("generator"), Some("pam-synth"));
        assert!(
            !g.log_text.contains("drift"),
            "the truth leaked into the log"
        );
        let t = log.column("t_s").unwrap();
        assert!((t[1] - t[0] - spec.dt_s).abs() < 1e-9);
        // a step log's reference steps on one axis at a time
        if e == Experiment::Step {
            let (rx, ry) = (
                log.column("fx_ref_n").unwrap(),
                log.column("fy_ref_n").unwrap(),
            );
            assert!(rx.iter().zip(ry).all(|(x, y)| *x == 0.0 || *y == 0.0));
            assert!(rx.iter().any(|x| *x > 3.0) || ry.iter().any(|y| *y > 3.0));
            assert!(rx.iter().any(|x| *x < -3.0) || ry.iter().any(|y| *y < -3.0));
        }
    }
}

/// The reference's levels, one per hold, from a step log.
fn reference_levels(spec: &CaseSpec) -> Vec<[f64; 2]> {
    let log = pam_log::read_str(&generate(spec).unwrap().log_text, None).unwrap();
    let (x, y) = (
        log.column(pam_log::col::FX_REF_N).unwrap(),
        log.column(pam_log::col::FY_REF_N).unwrap(),
    );
    let mut out: Vec<[f64; 2]> = Vec::new();
    for (a, b) in x.iter().zip(y) {
        if out.last() != Some(&[*a, *b]) {
            out.push([*a, *b]);
        }
    }
    out
}

/// The step levels do what they say: the lattice one axis at a time in whole steps; any
/// level (mostly off the lattice) one axis at a time; both axes at once. Neither the motion
/// nor the levels move a step log's other draws: the lattice is the first schedule.
#[test]
fn step_levels_lie_where_they_say() {
    use pam_synth::case::StepLevels;
    let spec = CaseSpec::random(77, Some(Experiment::Step), Some(Family::None)).unwrap();
    let step_n = generate(&spec).unwrap().truth.base["step_n"];
    let whole = |v: f64| ((v / step_n) - (v / step_n).round()).abs() < 1e-9;
    let lattice = reference_levels(&spec);
    assert!(lattice.len() > 8);
    assert!(lattice
        .iter()
        .all(|l| whole(l[0]) && whole(l[1]) && l[0] * l[1] == 0.0));
    let levels = |l: StepLevels| {
        reference_levels(&CaseSpec {
            step_levels: l,
            ..spec.clone()
        })
    };
    let continuous = levels(StepLevels::Continuous);
    assert!(continuous.iter().all(|l| l[0] * l[1] == 0.0));
    let off = continuous.iter().filter(|l| !whole(l[0] + l[1])).count();
    assert!(off * 2 > continuous.len(), "{continuous:?}");
    let diagonal = levels(StepLevels::Diagonal);
    let both = diagonal
        .iter()
        .filter(|l| l[0] != 0.0 && l[1] != 0.0)
        .count();
    assert!(both * 3 > diagonal.len(), "{diagonal:?}");
    // the holds are the lattice's: the same number of changes at the same times
    assert_eq!(continuous.len(), lattice.len());
    let moved = CaseSpec {
        motion: pam_synth::OperatorMotion::Circles,
        ..spec.clone()
    };
    assert_eq!(
        generate(&moved).unwrap().log_text,
        generate(&spec).unwrap().log_text
    );
}

#[test]
fn truth_labels_cover_the_model_loops_families_by_their_names() {
    let labelled: Vec<pam_effect_id::Family> = Family::ALL
        .into_iter()
        .filter_map(Family::effect_family)
        .collect();
    assert_eq!(labelled, pam_effect_id::Family::ALL);
    for f in Family::ALL {
        let json = serde_json::to_string(&f).unwrap();
        assert_eq!(json, format!("\"{}\"", f.name()));
    }
}
