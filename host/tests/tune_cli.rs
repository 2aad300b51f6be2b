//! `pamctl tune` end to end: an open-loop force-step log of the identified rig (which
//! delivers 0.57 of the step, Table 5.2) → the proposed gain scale and its predicted 9.1 N
//! step → the closed loop at that scale on the same twin, measured from its log.
mod cli;

use cli::{pamctl, tmpdir};
use pam_log::read_path;
use pam_twin::step_metrics::force_steps;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.partial_cmp(b).unwrap());
    v[v.len() / 2]
}

/// The prediction holds within 15 % on the twin (median 5 % settling of pose 4's steps
/// between ±18.2 N: measured 0.220 s against 0.220 s predicted when written), the proposal
/// differs from the design (a weaker plant needs more gain), and the tuned loop is faster
/// than the designed one on this rig.
#[test]
fn tune_proposes_a_gain_whose_predicted_settling_the_twin_shows() {
    let dir = tmpdir("tune");
    let d = dir.path();
    let open = d.join("open.csv");
    let sim = |extra: &[&str], out: &std::path::Path| {
        let mut args = vec![
            "simulate",
            "--experiment",
            "force_step",
            "--pose",
            "4",
            "--identified-rig",
        ];
        args.extend_from_slice(extra);
        args.extend_from_slice(&["--out", out.to_str().unwrap()]);
        let (code, _, err) = pamctl(&args);
        assert_eq!(code, 0, "{err}");
    };
    sim(&[], &open);
    let (code, text, err) = pamctl(&["tune", open.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert!(text.contains("apply (nothing was sent)"), "{text}");
    let (code, json, err) = pamctl(&["tune", open.to_str().unwrap(), "--json"]);
    assert_eq!(code, 0, "{err}");
    let j: serde_json::Value = serde_json::from_str(&json).unwrap();
    let scale = j["gain_scale"].as_f64().unwrap();
    let predicted: Vec<f64> = j["settling_s"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    let g = j["axes"][0]["gain"].as_f64().unwrap();
    assert!((0.5..0.65).contains(&g), "identified gain {g}");
    // The loop measures the rig's gain itself and divides by it (`pam_control::plant_gain`),
    // so the plant it runs against is G / Ĝ ≈ 1 and the proposal is the default twin's
    // (1.25). A loop that ran at G would need a scale near 2.2 from the tuner, beyond the
    // tuner's own bound of 2.
    assert!(
        (1.0..1.5).contains(&scale),
        "a plant of gain {g}, measured by the loop: the design's scale for g = 1, not {scale}"
    );
    let measured = |scale: f64| {
        let out = d.join(format!("cl_{scale}.csv"));
        let s = format!("{scale}");
        sim(&["--closed-loop", "--gain-scale", &s], &out);
        let log = read_path(&out).unwrap();
        let steps = force_steps(&log).unwrap();
        let within: Vec<_> = steps
            .iter()
            .filter(|s| s.from_n.abs() < 19.0 && s.to_n.abs() < 19.0)
            .collect();
        [0, 1].map(|axis| {
            median(
                within
                    .iter()
                    .filter(|s| s.axis == axis)
                    .map(|s| s.settling_s)
                    .collect(),
            )
        })
    };
    let tuned = measured(scale);
    let designed = measured(1.0);
    println!("gain scale {scale}: predicted {predicted:?} s, measured {tuned:?} s; designed gains measured {designed:?} s");
    for axis in 0..2 {
        let rel = (tuned[axis] - predicted[axis]).abs() / predicted[axis];
        assert!(
            rel < 0.15,
            "axis {axis}: measured {} vs predicted {}",
            tuned[axis],
            predicted[axis]
        );
        assert!(
            tuned[axis] < designed[axis],
            "axis {axis}: {tuned:?} vs designed {designed:?}"
        );
    }
}
