//! `pamctl model …` end to end: the binary's output and exit codes.
mod cli;

use cli::pamctl;

#[test]
fn capability_at_neutral_pose_reports_thesis_stiffness() {
    let (code, out, _) = pamctl(&["model", "capability"]);
    assert_eq!(code, 0);
    assert!(out.contains("K_min 59.45, K_max 122.43"), "{out}");
    assert!(out.contains("K_min 26.63, K_max 51.88"), "{out}");
    assert!(out.contains("handle at (+0.0000, +0.0000) m"), "{out}");
}

#[test]
fn angle_outside_range_is_an_error_that_names_the_range() {
    let (code, _, err) = pamctl(&["model", "capability", "--alpha1-deg", "30"]);
    assert_eq!(code, 1);
    assert!(
        err.contains("outside joint 1's range [-22.5, 22.5]"),
        "{err}"
    );
}

#[test]
fn inverse_reports_clamping_and_channel_currents() {
    let (code, out, _) = pamctl(&[
        "model",
        "inverse",
        "--torque-nm",
        "200,0",
        "--stiffness-nm-per-rad",
        "60,27",
    ]);
    assert_eq!(code, 0);
    assert!(
        out.contains("CLAMPED: torque outside the joint's range"),
        "{out}"
    );
    // the unclamped joint 2 request is attainable and not flagged
    assert_eq!(out.matches("CLAMPED").count(), 1, "{out}");
    assert_eq!(out.matches("mA").count(), 4, "{out}");
}

#[test]
fn inverse_needs_two_values_per_list() {
    let (code, _, err) = pamctl(&["model", "inverse", "--torque-nm", "1,2,3"]);
    assert_eq!(code, 1);
    assert!(
        err.contains("--torque-nm takes two comma-separated values"),
        "{err}"
    );
}

#[test]
fn table41_lists_five_points() {
    let (code, out, _) = pamctl(&["model", "table41"]);
    assert_eq!(code, 0);
    assert_eq!(out.lines().count(), 6, "{out}");
    assert!(out.contains("109.8 [110.0]"), "{out}");
}
