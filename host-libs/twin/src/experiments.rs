//! Scripted versions of the thesis protocols, run with the real controller
//! (`pam_control::Controller`, f32) in the loop, written in log format v1.
//!
//! - [`dynamic_trial`]: §4.2 — joint mode at a Table 4.1 point, zero torque, K_low or K_high;
//!   an operator moves the handle for 90 s along a smooth random path (multi-sine, 0.1–2 Hz,
//!   ±4 cm: the 8 cm square of Fig. 4.2b), seeded.
//! - [`static_trial`]: §4.2 — the same set-up, the handle held 5 s at each of 9 points (centre,
//!   corners and edge midpoints of the 8 cm square).
//! - [`force_step_test`]: §5.2 — handle blocked at one of the nine poses, force mode, steps of
//!   9.1 N from 0 to 27.3 N then down to −27.3 N, along X then Y; the stiffness is the highest
//!   of the minimum stiffnesses that deliver ±27.3 N along either axis.
//!
//! The loop: at each period the controller reads the previous sample, its currents are held
//! by the twin over the period, and one log row is written per period with the sample and
//! the currents computed from it.

use pam_control::Mode;
use pam_log::Log;
use pam_model::{RobotModel, Vec2};

use crate::harness::err;
pub(crate) use crate::harness::Rig;
pub use crate::harness::{ExperimentConfig, ExperimentError, OperatorPath};
use crate::plant::HandleCondition;

// The thesis's protocols (Table 4.1's points and stiffness levels, §5.2's poses, steps and
// stiffness, the static trial's holds) live in pam-model; re-exported for the twin's users.
pub use pam_model::protocols::{
    static_points, step_levels, step_test_stiffness, trial_stiffness, StiffnessLevel,
};
pub use pam_model::thesis::{STEP_MAX_N, STEP_N, STEP_POSES_DEG, TABLE_4_1_POINTS_DEG};

fn deg2rad(a: [f64; 2]) -> Vec2<f64> {
    [a[0].to_radians(), a[1].to_radians()]
}

pub(crate) fn point_alpha(point: usize) -> Result<Vec2<f64>, ExperimentError> {
    if !(1..=5).contains(&point) {
        return Err(err(format!(
            "point {point} is not one of the five Table 4.1 points (1–5)"
        )));
    }
    Ok(deg2rad(TABLE_4_1_POINTS_DEG[point - 1]))
}

/// §4.2 dynamic trial at a Table 4.1 point (1–5).
pub fn dynamic_trial(
    cfg: &ExperimentConfig,
    point: usize,
    level: StiffnessLevel,
    duration_s: f64,
) -> Result<Log, ExperimentError> {
    let alpha = point_alpha(point)?;
    if !(duration_s.is_finite() && duration_s > 0.0) {
        return Err(err(format!("duration {duration_s} s must be positive")));
    }
    let (mut rig, centre, k) = settle_at_point(cfg, alpha, level)?;
    let path = OperatorPath::new(
        centre,
        cfg.path_amplitude_m,
        cfg.path_band_hz,
        duration_s,
        cfg.twin.seed,
    );
    let n = rig.periods(duration_s);
    for i in 0..n {
        let t = i as f64 * cfg.period_s;
        let hand = |off: f64| {
            let (p, v) = path.at(t + off);
            HandleCondition::moved(p, v)
        };
        rig.period(hand, None, Some(path.at(t).0), true)?;
    }
    Ok(rig.finish(
        cfg,
        "dynamic",
        &[
            ("point", point.to_string()),
            ("stiffness", level.name().into()),
            ("k_joint_nm_per_rad", format!("{:.3} {:.3}", k[0], k[1])),
            ("x0_user_m", format!("{:.6} {:.6}", centre[0], centre[1])),
        ],
    ))
}

/// The start of a static or dynamic trial (§4.2): joint mode at the point with the trial's
/// stiffness and zero torque, the hand holding the handle there for the settling time.
/// Returns the rig, the point in the user frame and the joint stiffness.
fn settle_at_point(
    cfg: &ExperimentConfig,
    alpha: Vec2<f64>,
    level: StiffnessLevel,
) -> Result<(Rig, Vec2<f64>, Vec2<f64>), ExperimentError> {
    let model = RobotModel::new(cfg.controller_params);
    let k = trial_stiffness(&model, alpha, level);
    let mut rig = Rig::new(cfg, alpha, false, true)?;
    let centre = rig.twin.model().kinematics.forward_user(alpha);
    rig.arm(Mode::Joint {
        alpha_rad: [alpha[0] as f32, alpha[1] as f32],
        torque_nm: [0.0; 2],
        stiffness_nm_per_rad: [k[0] as f32, k[1] as f32],
    })?;
    let hold = HandleCondition::held_at(centre);
    for _ in 0..rig.periods(cfg.settle_s) {
        rig.period(|_| hold, None, None, false)?;
    }
    Ok((rig, centre, k))
}

/// §4.2 static trial: 5 s at each of the nine points, 1.5 s smooth moves between them.
pub fn static_trial(
    cfg: &ExperimentConfig,
    point: usize,
    level: StiffnessLevel,
) -> Result<Log, ExperimentError> {
    let alpha = point_alpha(point)?;
    let (mut rig, centre, k) = settle_at_point(cfg, alpha, level)?;
    let points = static_points(centre, 0.04);
    let (move_s, hold_s) = (1.5, 5.0);
    let mut from = centre;
    for &to in &points {
        // minimum-jerk-like cosine move
        let n_move = rig.periods(move_s);
        let along = |t: f64| {
            let s = (t / move_s).clamp(0.0, 1.0);
            let w = 0.5 - 0.5 * (std::f64::consts::PI * s).cos();
            let dw = if t < move_s {
                0.5 * std::f64::consts::PI * (std::f64::consts::PI * s).sin() / move_s
            } else {
                0.0
            };
            let p = [
                from[0] + w * (to[0] - from[0]),
                from[1] + w * (to[1] - from[1]),
            ];
            (p, [dw * (to[0] - from[0]), dw * (to[1] - from[1])])
        };
        for i in 0..n_move {
            let t = i as f64 * cfg.period_s;
            rig.period(
                |off| {
                    let (p, v) = along(t + off);
                    HandleCondition::moved(p, v)
                },
                None,
                Some(along(t).0),
                true,
            )?;
        }
        for _ in 0..rig.periods(hold_s) {
            rig.period(|_| HandleCondition::held_at(to), None, Some(to), true)?;
        }
        from = to;
    }
    Ok(rig.finish(
        cfg,
        "static",
        &[
            ("point", point.to_string()),
            ("stiffness", level.name().into()),
            ("k_joint_nm_per_rad", format!("{:.3} {:.3}", k[0], k[1])),
            ("x0_user_m", format!("{:.6} {:.6}", centre[0], centre[1])),
        ],
    ))
}

/// The force mode of the configuration: open loop, or closed loop with its gain scale.
pub fn force_mode(cfg: &ExperimentConfig, force_n: Vec2<f32>, stiffness: Vec2<f32>) -> Mode {
    if cfg.closed_loop {
        Mode::ForceClosedLoop {
            force_n,
            stiffness_nm_per_rad: stiffness,
            feed_forward: cfg.feed_forward,
            gain_scale: cfg.gain_scale as f32,
        }
    } else {
        Mode::Force {
            force_n,
            stiffness_nm_per_rad: stiffness,
            feed_forward: cfg.feed_forward,
        }
    }
}

/// §5.2 force-step test at `pose_deg` (blocked handle): the X sequence then the Y sequence,
/// one log with `fx_ref_n`, `fy_ref_n`.
pub fn force_step_test(cfg: &ExperimentConfig, pose_deg: [f64; 2]) -> Result<Log, ExperimentError> {
    let alpha = deg2rad(pose_deg);
    let model = RobotModel::new(cfg.controller_params);
    for j in 0..2 {
        let jp = &cfg.controller_params.joints[j];
        if !(alpha[j] >= jp.alpha_min_rad && alpha[j] <= jp.alpha_max_rad) {
            return Err(err(format!(
                "pose {pose_deg:?}° is outside joint {}'s range",
                j + 1
            )));
        }
    }
    let k = step_test_stiffness(&model, alpha);
    let mut rig = Rig::new(cfg, alpha, true, false)?;
    // the block is in place before the arm is armed: the first sample the controller sees
    // already carries whatever the vented rig presses on it (a rig with a parallel
    // stiffness preloads the block away from its rest)
    rig.hold_before_arming(&HandleCondition::Blocked);
    let stiffness = [k[0] as f32, k[1] as f32];
    let ff = cfg.feed_forward;
    let mode = |f: [f64; 2]| force_mode(cfg, [f[0] as f32, f[1] as f32], stiffness);
    rig.arm(mode([0.0; 2]))?;
    let blocked = HandleCondition::Blocked;
    for _ in 0..rig.periods(cfg.settle_s) {
        rig.period(|_| blocked, Some([0.0; 2]), None, false)?;
    }
    // as an experimenter would: the test starts once the pressures have settled (slow,
    // flow-limited converters need longer than `settle_s`), at most a minute later
    for _ in 0..rig.periods(60.0) {
        if rig.pressure_rate_bar_s < 0.01 {
            break;
        }
        rig.period(|_| blocked, Some([0.0; 2]), None, false)?;
    }
    for axis in 0..2 {
        for level in step_levels() {
            let mut f = [0.0f64; 2];
            f[axis] = level;
            rig.set_mode(mode(f))?;
            for _ in 0..rig.periods(cfg.step_hold_s) {
                rig.period(|_| blocked, Some(f), None, true)?;
            }
        }
    }
    Ok(rig.finish(
        cfg,
        "force_step",
        &[
            ("pose_deg", format!("{} {}", pose_deg[0], pose_deg[1])),
            ("k_joint_nm_per_rad", format!("{:.3} {:.3}", k[0], k[1])),
            ("feed_forward", ff.to_string()),
            ("closed_loop", cfg.closed_loop.to_string()),
            ("gain_scale", cfg.gain_scale.to_string()),
        ],
    ))
}
