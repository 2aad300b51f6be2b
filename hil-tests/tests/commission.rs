//! `pamctl commission` against the emulator, wired right and wired wrong: a right rig
//! passes with the joints moving as the model says, each miswiring is stopped at with its
//! name and the change that fixes it, and no step drives the arm beyond its bounds.
//! Serialised: each needs the 1 kHz loop undisturbed.

use pam_hil_tests::{exclusive, pamctl, tmp, Target};

/// Runs the commissioning on an emulator wired with `miswire` (none: wired right);
/// its exit code, its output and its report.
fn commission(miswire: Option<&str>) -> (i32, String, String) {
    let sim: Vec<&str> = miswire.map(|m| vec!["--miswire", m]).unwrap_or_default();
    let target = Target::acquire(&sim);
    // a loaded test machine can hold the client back beyond the firmware's 0.1 s
    target.prepare(1.0);
    let name = miswire.unwrap_or("right").replace([':', ',', '='], "_");
    let state = tmp(&format!("commission-{name}.json"));
    let report = tmp(&format!("commission-{name}.md"));
    let _ = std::fs::remove_file(&state);
    let (code, out, err) = pamctl(
        &target.address,
        &[
            "commission",
            "--restart",
            "--state",
            state.to_str().unwrap(),
            "--report",
            report.to_str().unwrap(),
        ],
    );
    let report = std::fs::read_to_string(&report).unwrap_or_default();
    (code, format!("{out}{err}"), report)
}

/// The largest speed and force the output reports, checked against the step's bounds.
fn assert_within_bounds(out: &str) {
    let line = out
        .lines()
        .find(|l| l.contains("largest joint speed"))
        .unwrap_or_else(|| panic!("no bounds line in:\n{out}"));
    let numbers: Vec<f64> = line
        .split(|c: char| !(c.is_ascii_digit() || c == '.'))
        .filter_map(|w| w.parse().ok())
        .collect();
    // speed, its bound, force, its bound
    assert!(numbers.len() >= 4, "{line}");
    assert!(
        numbers[0] <= numbers[1] && numbers[0] > 0.0,
        "speed: {line}"
    );
    assert!(numbers[2] <= numbers[3], "force: {line}");
}

#[test]
fn a_rig_wired_right_commissions_with_the_model_joint_motions() {
    let _serial = exclusive();
    let (code, out, report) = commission(None);
    assert_eq!(code, 0, "{out}");
    assert!(out.contains("step 1 passed"), "{out}");
    assert!(report.contains("none: wired as configured"), "{report}");
    assert_within_bounds(&out);
    // every channel: its joint moved within 20 % of the model's angle, the other joint less
    for line in out
        .lines()
        .filter(|l| l.trim_start().starts_with("channel "))
    {
        let v: Vec<f64> = line
            .split(|c: char| !(c.is_ascii_digit() || c == '.' || c == '-' || c == '+'))
            .filter_map(|w| w.parse().ok())
            .collect();
        let (m, e) = ([v[1], v[2]], [v[3], v[4]]);
        let j = if e[0].abs() > e[1].abs() { 0 } else { 1 };
        assert!((m[j] / e[j] - 1.0).abs() < 0.2, "{line}");
    }
}

#[test]
fn each_miswiring_is_named_with_its_fix() {
    let _serial = exclusive();
    let cases = [
        ("swap_channels:1,3", "channels_swapped", "channels 1 and 3"),
        ("swap_channels:2,4", "channels_swapped", "channels 2 and 4"),
        (
            "swap_joint1_muscles",
            "joint1_reversed",
            "channel_of_muscle",
        ),
        ("encoder_inverted:joint=1", "joint1_reversed", "sign = -1"),
        ("encoder_inverted:joint=2", "joint2_reversed", "sign = -1"),
        (
            "encoder_counts:joint=1,scale=1.3",
            "encoder1_scale",
            "multiply [calibration] encoder 1 counts_per_rev",
        ),
        (
            "encoder_counts:joint=2,scale=0.5",
            "encoder2_scale",
            "multiply [calibration] encoder 2 counts_per_rev",
        ),
        ("tare_offset:x=8", "tare_offset", "pamctl tare"),
    ];
    for (miswire, fault, advice) in cases {
        let (code, out, report) = commission(Some(miswire));
        assert_ne!(code, 0, "{miswire}: passed\n{out}");
        assert!(
            out.contains(&format!("FAULT {fault}")),
            "{miswire}: not named {fault}\n{out}"
        );
        assert!(
            out.contains(advice),
            "{miswire}: advice lacks `{advice}`\n{out}"
        );
        assert!(report.contains(fault), "{miswire}: report\n{report}");
        assert_within_bounds(&out);
    }
}
