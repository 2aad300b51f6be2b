//! Motion limits through the pamctl binary, as `./run.sh` drives the emulator: a joint
//! target is shaped in firmware, so the arm reaches it without swinging past it.

use pam_hil_tests::{column, exclusive, ok, tmp_dir, Target};
use pam_log::col;

/// `./run.sh`'s move: from home to Table 4.1's point 4 (10°, 6.5°) at 95, 40 N·m/rad. The
/// arm, free, must not pass the target by 1° or more on either joint.
#[test]
fn the_run_sh_joint_move_does_not_overshoot_by_a_degree() {
    let _serial = exclusive();
    let target = Target::acquire(&[]);
    target.prepare(1.0);
    let d = target.address.as_str();
    ok(d, &["arm"]);
    ok(
        d,
        &[
            "set",
            "joint",
            "--alpha-deg",
            "10,6.5",
            "--stiffness-nm-per-rad",
            "95,40",
        ],
    );
    let dir = tmp_dir();
    let file = dir.path().join("joint_move.csv");
    ok(
        d,
        &[
            "record",
            file.to_str().unwrap(),
            "--duration",
            "4",
            "--keep-alive",
            "--quiet",
        ],
    );
    ok(d, &["disarm"]);
    let log = pam_log::read_path(&file).expect("a valid log");
    let targets_deg = [10.0, 6.5];
    for (j, name) in [col::ALPHA1_RAD, col::ALPHA2_RAD].iter().enumerate() {
        let alpha = column(&log, name);
        let peak_deg = alpha
            .iter()
            .map(|a| a.to_degrees())
            .fold(f64::MIN, f64::max);
        let last_deg = alpha.last().copied().unwrap_or(f64::NAN).to_degrees();
        eprintln!(
            "joint {}: peak {peak_deg:.2}°, last {last_deg:.2}° for {}°",
            j + 1,
            targets_deg[j]
        );
        assert!(
            peak_deg < targets_deg[j] + 1.0,
            "joint {}: swings to {peak_deg:.2}° for a {}° target",
            j + 1,
            targets_deg[j]
        );
        assert!(
            (last_deg - targets_deg[j]).abs() < 2.0,
            "joint {}: ends at {last_deg:.2}°, not near {}°",
            j + 1,
            targets_deg[j]
        );
    }
    let faults = column(&log, col::FAULTS);
    assert!(faults.iter().all(|&f| f == 0.0), "faults during the move");
}
