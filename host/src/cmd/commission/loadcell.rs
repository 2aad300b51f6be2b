//! What the blocked handle's force steps say about the load cell and about joint 1's
//! muscles: pure functions of the commanded and measured forces, unit-tested.
//!
//! With the handle blocked, open-loop force mode commands F (user frame); the load cell
//! measures F' = M F. A right rig gives M ≈ I. A load cell wired wrong in its own frame
//! (axes, signs, gains, angle: eq. 2.1, 2.6–2.7) gives M = R A Rᵀ, with R the rotation of
//! the load-cell frame at the pose and A the fault in that frame. A joint whose two muscles
//! are exchanged reverses that joint's torque: M = J⁻ᵀ S Jᵀ with S = diag(±1). An inverted
//! encoder changes nothing at the neutral pose (the pose is its zero), so M ≈ I tells it
//! from exchanged muscles.

use super::analysis::{ConfigFix, Finding};
use pam_model::{Mat2, RobotModel, Vec2};

/// Largest element of |A − expected| still taken as a match.
pub const MATRIX_TOLERANCE: f64 = 0.15;
/// Largest angle, degrees, of the load cell on the handle still taken as right.
pub const ANGLE_TOLERANCE_DEG: f64 = 5.0;

/// The force map measured by steps along X and along Y of `step_n` each: `dx`, `dy` are
/// the measured force changes, N (user frame).
pub fn force_map(step_n: f64, dx: Vec2<f64>, dy: Vec2<f64>) -> Mat2<f64> {
    Mat2::new(
        dx[0] / step_n,
        dy[0] / step_n,
        dx[1] / step_n,
        dy[1] / step_n,
    )
}

/// What the force map `m`, measured at `alpha_rad`, says; `reversed_joint` is the joint
/// step 1 saw turn backwards, if any. An empty list: the load cell is as configured.
pub fn diagnose(
    model: &RobotModel<f64>,
    alpha_rad: Vec2<f64>,
    m: &Mat2<f64>,
    reversed_joint: Option<usize>,
) -> Vec<Finding> {
    let k = &model.kinematics;
    let j = k.jacobian(alpha_rad);
    let mut out = Vec::new();
    // the torque map S = Jᵀ M J⁻ᵀ: diag(−1, 1) when joint 1's muscles are exchanged
    if let Some(jinv_t) = j.transpose().inverse() {
        let s = j.transpose().mul(m).mul(&jinv_t);
        for joint in 0..2 {
            let mut d = [1.0, 1.0];
            d[joint] = -1.0;
            if s.max_abs_diff(&Mat2::diag(d[0], d[1])) < 2.0 * MATRIX_TOLERANCE {
                out.push(muscles_exchanged(joint));
                return out;
            }
        }
    }
    let identity = m.max_abs_diff(&Mat2::diag(1.0, 1.0)) < MATRIX_TOLERANCE;
    if let Some(joint) = reversed_joint.filter(|_| identity) {
        out.push(encoder_inverted(joint));
    }
    if identity {
        return out;
    }
    // the fault in the load cell's own frame: A = Rᵀ M R
    let r = sensor_frame(model, alpha_rad);
    let a = r.transpose().mul(m).mul(&r);
    let near = |x: f64, y: f64| (x - y).abs() < MATRIX_TOLERANCE;
    let [[a00, a01], [a10, a11]] = a.0;
    let diagonal = near(a01, 0.0) && near(a10, 0.0);
    let axis_name = ["x", "z"];
    if diagonal {
        for (axis, g) in [a00, a11].into_iter().enumerate() {
            if near(g, -1.0) {
                out.push(Finding {
                    fix: None,
                    fault: "loadcell_inverted",
                    detail: format!(
                        "the load cell's {} axis reads {g:+.2}× the force (model: +1)",
                        axis_name[axis]
                    ),
                    advice: format!(
                        "exchange the {} bridge's signal wires, or negate [robot] load_cell gain_n_per_v[{axis}]",
                        axis_name[axis]
                    ),
                });
            } else if !near(g, 1.0) {
                out.push(Finding {
                    fix: (g > 0.0).then_some(ConfigFix::LoadCellGain(axis, g)),
                    fault: "loadcell_gain",
                    detail: format!(
                        "the load cell's {} axis reads {g:.2}× the model's force (eq. 2.1)",
                        axis_name[axis]
                    ),
                    advice: format!(
                        "divide [robot] load_cell gain_n_per_v[{axis}] by {g:.2} (check the amplifier's gain setting)"
                    ),
                });
            }
        }
    } else if near(a00, 0.0) && near(a11, 0.0) && a01 > 0.0 && a10 > 0.0 {
        // exchanged ADC inputs: each channel read with the other's gain, so the two
        // off-diagonal terms are the gains' ratio and its inverse
        out.push(Finding {
            fix: None,
            fault: "loadcell_axes_swapped",
            detail: "the load cell's x channel reads the z force and z the x force".into(),
            advice: "exchange the load cell's two channels at the ADC inputs (ADC1 ↔ ADC2)".into(),
        });
    } else if near(a00, a11) && near(a01, -a10) {
        let deg = a10.atan2(a00).to_degrees();
        if deg.abs() > ANGLE_TOLERANCE_DEG {
            out.push(Finding {
                fix: None,
                fault: "loadcell_rotated",
                detail: format!(
                    "the load cell is turned {deg:+.1}° on the handle (eq. 2.6–2.7 expect 0°, tolerance {ANGLE_TOLERANCE_DEG}°)"
                ),
                advice: format!(
                    "turn the load cell {:+.1}° on the handle so that its x axis lies along the forearm link",
                    -deg
                ),
            });
        }
    }
    if out.is_empty() {
        out.push(Finding {
            fix: None,
            fault: "loadcell_unexplained",
            detail: format!(
                "the blocked handle's forces follow [[{a00:.2}, {a01:.2}], [{a10:.2}, {a11:.2}]] × the command in the load cell's frame (model: identity)"
            ),
            advice: "check the load cell's wiring, gains and mounting one at a time".into(),
        });
    }
    out
}

/// The rotation from the load cell's frame to the user frame at the pose (eq. 2.6–2.7: by
/// θ1 + θ2, the thesis's angles, which the joint angles α reach through their offsets).
pub fn sensor_frame(model: &RobotModel<f64>, alpha_rad: Vec2<f64>) -> Mat2<f64> {
    let x = model.kinematics.sensor_to_user(alpha_rad, [1.0, 0.0]);
    let z = model.kinematics.sensor_to_user(alpha_rad, [0.0, 1.0]);
    Mat2::new(x[0], z[0], x[1], z[1])
}

fn muscles_exchanged(joint: usize) -> Finding {
    let (a, b) = (2 * joint + 1, 2 * joint + 2);
    Finding {
        fix: None,
        fault: if joint == 0 {
            "joint1_muscles_exchanged"
        } else {
            "joint2_muscles_exchanged"
        },
        detail: format!(
            "with the handle blocked, joint {}'s torque came out reversed (the load cell read the force mirrored through the joint)",
            joint + 1
        ),
        advice: format!(
            "the joint's two muscle tubes are exchanged (thesis §2.3): swap the tubes of channels {a} and {b}, \
             or exchange [joint{}] channel_of_muscle",
            joint + 1
        ),
    }
}

fn encoder_inverted(joint: usize) -> Finding {
    Finding {
        fix: Some(ConfigFix::EncoderSign(joint)),
        fault: if joint == 0 {
            "encoder1_inverted"
        } else {
            "encoder2_inverted"
        },
        detail: format!(
            "joint {} turned backwards with the handle free, yet its torque has the model's sign with the handle blocked",
            joint + 1
        ),
        advice: format!(
            "encoder {} counts backwards: set [calibration] encoder {} sign = -1 (or exchange its A and B lines)",
            joint + 1,
            joint + 1
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::{diagnose, force_map, sensor_frame};
    use pam_model::{Mat2, RobotModel};

    fn faults(m: Mat2<f64>, rev: Option<usize>) -> Vec<&'static str> {
        let model = RobotModel::thesis();
        diagnose(&model, [0.0, 0.0], &m, rev)
            .iter()
            .map(|f| f.fault)
            .collect()
    }

    #[test]
    fn a_right_load_cell_has_no_finding() {
        let m = force_map(10.0, [9.8, 0.3], [-0.2, 10.1]);
        assert!(faults(m, None).is_empty());
    }

    #[test]
    fn each_load_cell_fault_is_named() {
        let model = RobotModel::thesis();
        let at = [0.3, 0.4];
        let r = sensor_frame(&model, at);
        let in_user = |a: Mat2<f64>| r.mul(&a).mul(&r.transpose());
        let name = |a: Mat2<f64>| -> Vec<&'static str> {
            diagnose(&model, at, &in_user(a), None)
                .iter()
                .map(|f| f.fault)
                .collect()
        };
        assert_eq!(name(Mat2::diag(-1.0, 1.0)), ["loadcell_inverted"]);
        assert_eq!(name(Mat2::diag(1.0, 1.5)), ["loadcell_gain"]);
        assert_eq!(
            name(Mat2::new(0.0, 1.0, 1.0, 0.0)),
            ["loadcell_axes_swapped"]
        );
        assert_eq!(
            name(Mat2::rotation(20f64.to_radians())),
            ["loadcell_rotated"]
        );
        assert!(name(Mat2::rotation(2f64.to_radians())).is_empty());
    }

    #[test]
    fn exchanged_muscles_and_an_inverted_encoder_are_told_apart() {
        let model = RobotModel::thesis();
        let at = [0.0, 0.0];
        let j = model.kinematics.jacobian(at);
        let s = Mat2::diag(-1.0, 1.0);
        // F' = J⁻ᵀ S Jᵀ F
        let m = j.transpose().inverse().unwrap().mul(&s).mul(&j.transpose());
        assert_eq!(faults(m, Some(0)), ["joint1_muscles_exchanged"]);
        assert_eq!(faults(Mat2::diag(1.0, 1.0), Some(0)), ["encoder1_inverted"]);
    }
}
