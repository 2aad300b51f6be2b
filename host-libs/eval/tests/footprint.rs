//! The footprint of the twin's effects on a step test: the same seed without the effect
//! draws the same noise, so what differs is the effect's alone.

use pam_eval::footprint::footprint;
use pam_log::Log;
use pam_twin::experiments::{force_step_test, ExperimentConfig};
use pam_twin::{EffectSet, TwinConfig};

fn step_log(spec: Option<&str>, seed: u64, pose: [f64; 2]) -> Log {
    let mut tw = TwinConfig::thesis();
    tw.seed = seed;
    if let Some(spec) = spec {
        tw.effects = EffectSet::parse_list(&[spec]).expect("a known effect");
    }
    let mut cfg = ExperimentConfig::new(tw);
    cfg.period_s = 0.01;
    force_step_test(&cfg, pose).expect("the step test runs")
}

/// The twin's default pressure saturation has its knee at 3.2 bar, which the step
/// protocol's set-points at this pose hardly reach: the log is the control's to a few
/// hundred-thousandths of the signal (a noise drawn again would differ by a few per cent).
/// The cross-generator table counts such logs apart from the misses.
#[test]
fn a_saturation_whose_knee_the_steps_hardly_reach_leaves_almost_no_footprint() {
    let (seed, pose) = (720_021, [5.2, -8.4]);
    let without = step_log(None, seed, pose);
    let default = step_log(Some("pressure_saturation"), seed, pose);
    let low_knee = step_log(
        Some("pressure_saturation:max_bar=3.5,knee_bar=2.8"),
        seed,
        pose,
    );
    let f = footprint(&default, &without).expect("both logs hold the force");
    assert!(
        f < 5e-4,
        "the default knee is out of the steps' reach: footprint {f}"
    );
    let f = footprint(&low_knee, &without).expect("both logs hold the force");
    assert!(
        f > 0.005,
        "a knee at 2.8 bar changes the steps: footprint {f}"
    );
}
