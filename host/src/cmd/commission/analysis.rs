//! What the commissioning's measurements say about the wiring: pure functions of the
//! measured and the model's joint motions and forces, so that each verdict is unit-tested.

/// Relative tolerance of an encoder's scale: measured over model joint motion.
pub const SCALE_TOLERANCE: f64 = 0.2;
/// Largest force, N, the load cell may read with nothing touching the handle.
pub const TARE_TOLERANCE_N: f64 = 3.0;
/// Largest difference, rad (≈ 0.9°), between a joint's angle at equal pressures and the
/// model's equilibrium there: the encoder's zero.
pub const ZERO_TOLERANCE_RAD: f64 = 0.015;

/// How far joint `joint` (0-based) moved, rad, when output channel `channel` was raised.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ChannelResponse {
    pub channel: usize,
    /// Measured joint motion (through the device's encoders).
    pub measured_rad: [f64; 2],
    /// The model's joint motion for the same loop currents.
    pub model_rad: [f64; 2],
}

/// A fix the configuration record can take (`pamctl commission --apply`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ConfigFix {
    /// Negate encoder `0`'s sign.
    EncoderSign(usize),
    /// Multiply encoder `0`'s counts per revolution by `1`.
    EncoderScale(usize, f64),
    /// Divide load-cell axis `0`'s gain by `1` (positive: the device refuses a sign change).
    LoadCellGain(usize, f64),
    /// Add `1` rad to encoder `0`'s zero.
    EncoderZero(usize, f64),
    /// The channel map as measured: channel k, commanded through the stored map, drives
    /// the converter of channel `0[k]`; the stored map is composed with it.
    ChannelMap([u8; 4]),
}

/// One finding: what is wrong and the change that fixes it.
#[derive(Clone, Debug, PartialEq)]
pub struct Finding {
    /// The change to the configuration record that fixes it, when there is one.
    pub fix: Option<ConfigFix>,
    /// Short name of the fault (stable: tests and scripts match on it).
    pub fault: &'static str,
    pub detail: String,
    pub advice: String,
}

fn joint_and_sign(d: [f64; 2]) -> (usize, f64) {
    let j = if d[0].abs() >= d[1].abs() { 0 } else { 1 };
    (j, d[j].signum())
}

/// The channel map and the encoders from the four single-channel steps (in channel
/// order). An empty list: the wiring is as configured.
pub fn channel_map(responses: &[ChannelResponse; 4]) -> Vec<Finding> {
    let mut findings = Vec::new();
    let expected: Vec<(usize, f64)> = responses
        .iter()
        .map(|r| joint_and_sign(r.model_rad))
        .collect();
    // each joint's motion over the four channels against the model's: an encoder with a
    // wrong count scales all of its joint's motions (an exchange of channels keeps the
    // sums), so the joint a channel moved is judged on motions divided by that scale
    let joint_scale: Vec<f64> = (0..2)
        .map(|j| {
            let m: f64 = responses.iter().map(|r| r.measured_rad[j].abs()).sum();
            let e: f64 = responses.iter().map(|r| r.model_rad[j].abs()).sum();
            if m > 0.0 && e > 0.0 {
                m / e
            } else {
                1.0
            }
        })
        .collect();
    let measured: Vec<(usize, f64)> = responses
        .iter()
        .map(|r| {
            joint_and_sign([
                r.measured_rad[0] / joint_scale[0],
                r.measured_rad[1] / joint_scale[1],
            ])
        })
        .collect();
    // a joint whose both channels turn it backwards: its encoder counts backwards, or its
    // two muscles are exchanged (indistinguishable without the load cell)
    let mut reversed_joint = [false; 2];
    for (j, reversed) in reversed_joint.iter_mut().enumerate() {
        let chans: Vec<usize> = (0..4).filter(|&c| expected[c].0 == j).collect();
        *reversed = !chans.is_empty()
            && chans
                .iter()
                .all(|&c| measured[c].0 == j && measured[c].1 == -expected[c].1);
        if *reversed {
            findings.push(Finding {
                fix: None,
                fault: if j == 0 { "joint1_reversed" } else { "joint2_reversed" },
                detail: format!(
                    "joint {} turned the wrong way for both its channels {} and {}",
                    j + 1,
                    chans[0] + 1,
                    chans[1] + 1
                ),
                advice: format!(
                    "either encoder {} counts backwards (set [calibration] encoder {} sign = -1) or the \
                     joint's two muscle tubes are exchanged (thesis §2.3: swap the tubes of channels {} and {}, \
                     or exchange [joint{}] channel_of_muscle); the load-cell step tells which",
                    j + 1,
                    j + 1,
                    chans[0] + 1,
                    chans[1] + 1,
                    j + 1
                ),
            });
        }
    }
    // channels that drive another channel's muscle
    let mut wrong: Vec<(usize, usize)> = Vec::new();
    for c in 0..4 {
        if reversed_joint[expected[c].0] {
            continue;
        }
        if measured[c] != expected[c] {
            let drives = (0..4).find(|&e| expected[e] == measured[c]);
            wrong.push((c, drives.unwrap_or(c)));
        }
    }
    if !wrong.is_empty() {
        // the permutation the steps measured, when they measured one
        let mut drives = [0u8, 1, 2, 3];
        for &(c, e) in &wrong {
            drives[c] = e as u8;
        }
        let mut seen = [false; 4];
        drives.iter().for_each(|&e| seen[e as usize] = true);
        let permutation = seen.iter().all(|&s| s);
        let list: Vec<String> = wrong
            .iter()
            .map(|(c, e)| format!("channel {} drives the muscle of channel {}", c + 1, e + 1))
            .collect();
        findings.push(Finding {
            fix: permutation.then_some(ConfigFix::ChannelMap(drives)),
            fault: "channels_swapped",
            detail: list.join("; "),
            advice: format!(
                "exchange the I/P converters' cables (or tubes) of channels {}, or store the map as \
                 wired ([calibration] output_of_channel: `pamctl commission --apply`)",
                wrong
                    .iter()
                    .map(|(c, _)| (c + 1).to_string())
                    .collect::<Vec<_>>()
                    .join(" and ")
            ),
        });
    }
    // scale: only once the map is right, and for joints that moved as expected
    for j in (0..2).filter(|_| wrong.is_empty()) {
        let chans: Vec<&ChannelResponse> = responses
            .iter()
            .filter(|r| {
                joint_and_sign(r.model_rad).0 == j && measured[r.channel] == expected[r.channel]
            })
            .collect();
        if chans.is_empty() {
            continue;
        }
        let ratio = chans
            .iter()
            .map(|r| r.measured_rad[j].abs() / r.model_rad[j].abs().max(1e-9))
            .sum::<f64>()
            / chans.len() as f64;
        if (ratio - 1.0).abs() > SCALE_TOLERANCE {
            findings.push(Finding {
                fix: Some(ConfigFix::EncoderScale(j, ratio)),
                fault: if j == 0 {
                    "encoder1_scale"
                } else {
                    "encoder2_scale"
                },
                detail: format!("joint {} moved {ratio:.2}× the model's angle", j + 1),
                advice: format!(
                    "encoder {} gives {ratio:.2}× the configured counts per revolution: multiply \
                     [calibration] encoder {} counts_per_rev by {ratio:.2}",
                    j + 1,
                    j + 1
                ),
            });
        }
    }
    findings
}

/// The encoders' zero: each joint's angle at equal pressures on all four channels against
/// the model's equilibrium for the same currents (the neutral pose), rad.
pub fn encoder_zero(measured_rad: [f64; 2], model_rad: [f64; 2]) -> Vec<Finding> {
    (0..2)
        .filter_map(|j| {
            let error = measured_rad[j] - model_rad[j];
            (error.abs() > ZERO_TOLERANCE_RAD).then(|| Finding {
                fix: Some(ConfigFix::EncoderZero(j, error)),
                fault: if j == 0 { "encoder1_zero" } else { "encoder2_zero" },
                detail: format!(
                    "at equal pressures joint {} reads {:+.2}°, the model's equilibrium is {:+.2}° \
                     (tolerance {:.2}°): the arm was homed off the neutral pose",
                    j + 1,
                    measured_rad[j].to_degrees(),
                    model_rad[j].to_degrees(),
                    ZERO_TOLERANCE_RAD.to_degrees()
                ),
                advice: format!(
                    "add {error:+.4} rad to [calibration] encoder {} zero_rad (`pamctl commission --apply`), \
                     and home the arm at the same mark from now on",
                    j + 1
                ),
            })
        })
        .collect()
}

/// The tare: the force the load cell reads, N (user frame), with nothing on the handle.
pub fn tare(force_at_rest_n: [f64; 2]) -> Option<Finding> {
    let f = force_at_rest_n[0].hypot(force_at_rest_n[1]);
    (f > TARE_TOLERANCE_N).then(|| Finding {
        fix: None,
        fault: "tare_offset",
        detail: format!(
            "the load cell reads ({:.1}, {:.1}) N with nothing on the handle (model: 0 N, tolerance {TARE_TOLERANCE_N} N)",
            force_at_rest_n[0], force_at_rest_n[1]
        ),
        advice: "disarm, make sure nothing touches the handle, and run `pamctl tare`".to_string(),
    })
}

#[cfg(test)]
mod tests {
    use super::{channel_map, encoder_zero, tare, ChannelResponse, ConfigFix};

    /// A rig wired as the model: channels 1 and 2 turn joint 1 either way, 3 and 4 joint 2.
    fn right() -> [ChannelResponse; 4] {
        let m = [[0.05, 0.01], [-0.05, -0.01], [0.0, -0.06], [0.0, 0.06]];
        std::array::from_fn(|c| ChannelResponse {
            channel: c,
            measured_rad: m[c],
            model_rad: m[c],
        })
    }

    #[test]
    fn a_right_wiring_has_no_finding() {
        assert!(channel_map(&right()).is_empty());
        assert!(tare([0.5, -0.3]).is_none());
    }

    #[test]
    fn swapped_channels_across_joints_are_named() {
        let mut r = right();
        let (a, b) = (r[1].measured_rad, r[2].measured_rad);
        r[1].measured_rad = b;
        r[2].measured_rad = a;
        let f = channel_map(&r);
        assert_eq!(f.len(), 1, "{f:?}");
        assert_eq!(f[0].fault, "channels_swapped");
        assert!(f[0].advice.contains("channels 2 and 3"), "{}", f[0].advice);
        assert_eq!(f[0].fix, Some(ConfigFix::ChannelMap([0, 2, 1, 3])));
    }

    #[test]
    fn an_arm_homed_off_the_neutral_pose_is_named_with_its_zero() {
        assert!(encoder_zero([0.004, -0.003], [0.0, 0.001]).is_empty());
        let f = encoder_zero([-0.05, 0.001], [0.002, 0.0]);
        assert_eq!(f.len(), 1, "{f:?}");
        assert_eq!(f[0].fault, "encoder1_zero");
        match f[0].fix {
            Some(ConfigFix::EncoderZero(0, e)) => assert!((e + 0.052).abs() < 1e-12),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn a_backwards_joint_and_a_wrong_scale_are_named() {
        let mut r = right();
        for c in [0, 1] {
            r[c].measured_rad[0] = -r[c].measured_rad[0];
        }
        for c in [2, 3] {
            r[c].measured_rad[1] *= 2.0;
        }
        let faults: Vec<&str> = channel_map(&r).iter().map(|f| f.fault).collect();
        assert_eq!(faults, ["joint1_reversed", "encoder2_scale"]);
    }

    #[test]
    fn a_small_encoder_count_is_a_scale_not_a_swap() {
        let mut r = right();
        // joint 2 reads half its motion, less than joint 1's coupled motion for channel 3
        r[2].model_rad = [0.055, -0.08];
        r[2].measured_rad = [0.055, -0.04];
        r[3].measured_rad[1] *= 0.5;
        let faults: Vec<&str> = channel_map(&r).iter().map(|f| f.fault).collect();
        assert_eq!(faults, ["encoder2_scale"]);
    }

    #[test]
    fn a_tare_offset_is_named() {
        assert_eq!(tare([8.0, 0.0]).unwrap().fault, "tare_offset");
    }
}
