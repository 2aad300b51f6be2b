//! The identified rig (`TwinConfig::identified_rig`, `pam_twin::rig`) against Table 5.2:
//! the open loop delivers about 0.57 of the requested force step, the gain plane (eq. 5.2,
//! the default flat plane at 0.57) brings it back to about 1, and the closed loop runs on it
//! at every §5.2 pose. Figures from the logs (`pam_twin::step_metrics`).

use pam_twin::simulate::{run_trial, Experiment, TrialSpec};
use pam_twin::step_metrics::{force_steps, StepFigures};

fn steps(feed_forward: bool, closed_loop: bool) -> Vec<StepFigures> {
    let mut spec = TrialSpec::new(Experiment::ForceStep);
    spec.identified_rig = true;
    spec.feed_forward = feed_forward;
    spec.closed_loop = closed_loop;
    let mut all = Vec::new();
    for pose in 0..9 {
        spec.pose = pose;
        let log = run_trial(&spec).unwrap_or_else(|e| panic!("pose {pose}: {e}"));
        all.extend(force_steps(&log).unwrap());
    }
    all
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.partial_cmp(b).unwrap());
    v[v.len() / 2]
}

/// Table 5.2: G = 0.57 over the poses, open loop without the gain plane. The steps to
/// ±27.3 N are lower where a muscle reaches a limit (as on the default twin), so the median
/// is the figure; the steps between ±18.2 N all give the rig's ratio.
#[test]
fn open_loop_step_gain_is_table_5_2s() {
    let all = steps(false, false);
    assert_eq!(all.len(), 9 * 24);
    let g = median(all.iter().map(|s| s.gain).collect());
    println!("identified rig, open loop: median step gain {g:.3} (Table 5.2: 0.57)");
    assert!((0.55..=0.59).contains(&g), "median gain {g}");
    for s in all
        .iter()
        .filter(|s| s.from_n.abs() < 19.0 && s.to_n.abs() < 19.0)
    {
        assert!((0.53..=0.61).contains(&s.gain), "{s:?}");
    }
    // the default twin is the model: its steps between ±18.2 N have gain 1
    let mut spec = TrialSpec::new(Experiment::ForceStep);
    spec.pose = 4;
    let log = run_trial(&spec).unwrap();
    for s in force_steps(&log).unwrap() {
        if s.from_n.abs() < 19.0 && s.to_n.abs() < 19.0 {
            assert!((s.gain - 1.0).abs() < 0.03, "default twin {s:?}");
        }
    }
}

/// §5.4: dividing the command by the plane brings the open loop's gain back to about 1,
/// and the closed loop (with the plane as its gain schedule) holds every pose to the
/// reference where the rig has the force.
#[test]
fn gain_plane_corrects_and_closed_loop_runs_on_the_rig() {
    let ff = steps(true, false);
    let g = median(ff.iter().map(|s| s.gain).collect());
    println!("identified rig, open loop + gain plane: median step gain {g:.3}");
    assert!((0.97..=1.03).contains(&g), "median gain {g}");
    let cl = steps(true, true);
    let within: Vec<&StepFigures> = cl
        .iter()
        .filter(|s| s.from_n.abs() < 19.0 && s.to_n.abs() < 19.0)
        .collect();
    for s in &within {
        assert!((s.gain - 1.0).abs() < 0.01, "{s:?}");
        assert!(s.overshoot_pct < 10.0, "{s:?}");
        assert!(s.settling_s < 0.35, "{s:?}");
    }
}

/// Without the gain plane the closed loop meets the rig's 0.57 that it is not told about; it
/// measures it (`pam_control::plant_gain`: within the first step from the force's ratio to the
/// nominal plant's, then at every steady level) and divides its command by it, as the plane
/// would. Every step the rig can deliver (within ±18.2 N) settles within 0.28 s over three
/// noise seeds (0.294–0.302 s without the measurement: the designed loop at g = 0.57, its
/// slowest pole −11 /s instead of −26 /s), without overshoot, at gain 1.
#[test]
fn closed_loop_without_the_plane_measures_the_rigs_gain_and_settles_within_0_28_s() {
    let mut spec = TrialSpec::new(Experiment::ForceStep);
    spec.identified_rig = true;
    spec.closed_loop = true;
    for seed in 0..3 {
        spec.seed = seed;
        let mut worst = 0.0f64;
        for pose in 0..9 {
            spec.pose = pose;
            let log = run_trial(&spec).unwrap_or_else(|e| panic!("seed {seed} pose {pose}: {e}"));
            for s in force_steps(&log).unwrap() {
                if s.from_n.abs() > 19.0 || s.to_n.abs() > 19.0 {
                    continue;
                }
                assert!(
                    (s.gain - 1.0).abs() < 0.01,
                    "seed {seed} pose {pose}: {s:?}"
                );
                assert!(s.overshoot_pct < 10.0, "seed {seed} pose {pose}: {s:?}");
                worst = worst.max(s.settling_s);
            }
        }
        println!("identified rig, closed loop, no plane, seed {seed}: worst settling {worst:.3} s");
        assert!(worst <= 0.28, "seed {seed}: worst settling {worst:.3} s");
    }
}

/// The ±27.3 N levels lie beyond what the rig's 0.57 muscles give at some of the §5.2 poses.
/// The closed loop scales such a target to what they can give, its direction kept
/// (`RobotModel::reachable_force_scale`), and says so (`Limited::TARGET` in the log's
/// `limited` column). Before, one joint saturated while the other still followed: the force
/// turned up to 6.2 N into the axis that did not step, and the approach to the unreachable
/// level overshot its steady value by 26–38 % (docs/closed-loop.md). Every step at the nine
/// poses, with and without the plane, two seeds: the axis that did not step within 0.3 N of
/// its reference; the steps within reach ≤ 10 % overshoot at gain 1 ± 0.01; the steps to or
/// from an unreachable level ≤ 0.5 N beyond their steady value, and only those involving
/// the ±27.3 N levels are declared out of reach.
#[test]
fn unreachable_levels_are_scaled_to_the_capability_with_the_direction_kept() {
    for feed_forward in [false, true] {
        for seed in 0..2 {
            let mut spec = TrialSpec::new(Experiment::ForceStep);
            spec.identified_rig = true;
            spec.closed_loop = true;
            spec.feed_forward = feed_forward;
            spec.seed = seed;
            let mut out_of_reach = 0;
            for pose in 0..9 {
                spec.pose = pose;
                let log = run_trial(&spec).unwrap_or_else(|e| panic!("pose {pose}: {e}"));
                for s in force_steps(&log).unwrap() {
                    let at = format!("plane {feed_forward} seed {seed} pose {pose}: {s:?}");
                    assert!(s.cross_error_n < 0.3, "{at}");
                    if s.out_of_reach {
                        out_of_reach += 1;
                        assert!(s.from_n.abs() > 19.0 || s.to_n.abs() > 19.0, "{at}");
                        assert!(s.overshoot_n < 0.5, "{at}");
                    } else {
                        assert!(s.overshoot_pct < 10.0, "{at}");
                        assert!((s.gain - 1.0).abs() < 0.01, "{at}");
                    }
                }
            }
            println!("plane {feed_forward} seed {seed}: {out_of_reach} steps out of reach");
            assert!(out_of_reach >= 4, "plane {feed_forward} seed {seed}");
        }
    }
}
