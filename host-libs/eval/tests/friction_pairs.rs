//! Friction or hysteresis from the same dynamic trial at Table 4.1's two stiffness levels
//! (`pam_model_loop::stiffness_pair`), on pairs of logs from pam-physgen and the twin.
//!
//! Tiers: `cargo test -p pam-eval --test friction_pairs` runs four 30 s pam-physgen pairs
//! (friction in the joints as LuGre and as Maxwell-slip, the muscles' Bouc–Wen twice), each
//! of which must be named right. With `--features suites`, 40 pairs of each truth from each
//! generator, held to 95 % right (`cargo xtask eval --only friction-pairs` prints the table).

use pam_eval::pairs::{physgen_pair, PairCase, PairOutcome, Truth};

fn run_all(cases: &[PairCase], run: fn(&PairCase) -> PairOutcome) -> Vec<(PairCase, PairOutcome)> {
    std::thread::scope(|s| {
        let handles: Vec<_> = cases
            .iter()
            .map(|c| s.spawn(move || (*c, run(c))))
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().expect("a pair's thread"))
            .collect()
    })
}

#[test]
fn a_pair_at_two_stiffness_levels_tells_joint_friction_from_hysteresis() {
    let case = |truth, index, seed| PairCase {
        generator: "physgen",
        truth,
        index,
        seed,
        duration_s: 30.0,
    };
    // indices 0 and 1: LuGre and Maxwell-slip in the joints, which one log names hysteresis
    // (growth 0.07, 0.08); the muscles' Bouc–Wen at severities 0.74 and 0.35 (growth 0.80,
    // 0.75)
    let cases = [
        case(Truth::Friction, 0, 21),
        case(Truth::Friction, 1, 22),
        case(Truth::Hysteresis, 2, 23),
        case(Truth::Hysteresis, 3, 24),
    ];
    for (c, o) in run_all(&cases, physgen_pair) {
        assert_eq!(o.named, Some(c.truth), "{:?}: {}", c.truth, o.line());
    }
}

#[cfg(feature = "suites")]
fn hold(generator: &'static str, run: fn(&PairCase) -> PairOutcome) {
    for truth in [Truth::Friction, Truth::Hysteresis] {
        let cases: Vec<PairCase> = (0..40)
            .map(|k| PairCase {
                generator,
                truth,
                index: k,
                seed: 1 + k as u64,
                duration_s: 60.0,
            })
            .collect();
        let mut right = 0;
        let mut lines = Vec::new();
        for chunk in cases.chunks(2) {
            for (c, o) in run_all(chunk, run) {
                right += usize::from(o.named == Some(c.truth));
                lines.push(o.line());
            }
        }
        assert!(
            right * 100 >= 95 * cases.len(),
            "{generator} {}: {right}/{} right\n{}",
            truth.name(),
            cases.len(),
            lines.join("\n")
        );
    }
}

#[cfg(feature = "suites")]
#[test]
fn forty_physgen_pairs_of_each_are_named_right() {
    hold("physgen", physgen_pair);
}

#[cfg(feature = "suites")]
#[test]
fn forty_twin_pairs_of_each_are_named_right() {
    hold("twin", pam_eval::pairs::twin_pair);
}
