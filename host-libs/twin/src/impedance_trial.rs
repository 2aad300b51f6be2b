//! The impedance trial: the robot in impedance mode about a Table 4.1 point, the
//! scripted operator of the dynamic trial (§4.2) moving the handle, logged like a dynamic
//! trial so that `pamctl ident dynamic` identifies the rendered K, B, M.

use pam_log::Log;
use pam_model::Vec2;

use pam_control::Mode;

use crate::experiments::{point_alpha, ExperimentConfig, ExperimentError, OperatorPath, Rig};
use crate::plant::HandleCondition;

/// The virtual spring-damper-mass of an impedance trial (diagonal, user frame).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VirtualImpedance {
    pub stiffness_n_per_m: Vec2<f64>,
    pub damping_n_s_per_m: Vec2<f64>,
    pub mass_kg: Vec2<f64>,
}

/// Impedance mode about Table 4.1 point `point` (1–5) for `duration_s` of operator motion.
pub fn impedance_trial(
    cfg: &ExperimentConfig,
    point: usize,
    imp: VirtualImpedance,
    duration_s: f64,
) -> Result<Log, ExperimentError> {
    let alpha = point_alpha(point)?;
    if !(duration_s.is_finite() && duration_s > 0.0) {
        return Err(ExperimentError {
            message: format!("duration {duration_s} s must be positive"),
            partial_log: None,
        });
    }
    let mut rig = Rig::new(cfg, alpha, false, true)?;
    let centre = rig.twin.model().kinematics.forward_user(alpha);
    let f32v = |v: Vec2<f64>| [v[0] as f32, v[1] as f32];
    rig.arm(Mode::Impedance {
        target_user_m: f32v(centre),
        stiffness_n_per_m: f32v(imp.stiffness_n_per_m),
        damping_n_s_per_m: f32v(imp.damping_n_s_per_m),
        mass_kg: f32v(imp.mass_kg),
    })?;
    let hold = HandleCondition::held_at(centre);
    for _ in 0..rig.periods(cfg.settle_s) {
        rig.period(|_| hold, None, None, false)?;
    }
    let path = OperatorPath::new(
        centre,
        cfg.path_amplitude_m,
        cfg.path_band_hz,
        duration_s,
        cfg.twin.seed,
    );
    for i in 0..rig.periods(duration_s) {
        let t = i as f64 * cfg.period_s;
        let hand = |off: f64| {
            let (p, v) = path.at(t + off);
            HandleCondition::moved(p, v)
        };
        rig.period(hand, None, Some(path.at(t).0), true)?;
    }
    let k = imp.stiffness_n_per_m;
    let b = imp.damping_n_s_per_m;
    Ok(rig.finish(
        cfg,
        "impedance",
        &[
            ("point", point.to_string()),
            ("virtual_k_n_per_m", format!("{} {}", k[0], k[1])),
            ("virtual_b_n_s_per_m", format!("{} {}", b[0], b[1])),
            (
                "virtual_m_kg",
                format!("{} {}", imp.mass_kg[0], imp.mass_kg[1]),
            ),
            ("x0_user_m", format!("{:.6} {:.6}", centre[0], centre[1])),
        ],
    ))
}
