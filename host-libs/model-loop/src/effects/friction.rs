//! Friction at the handle: the carrier ball's dry friction and quadratic drag.

use super::hysteresis::{maxwell_slip_state, SLIP_BREAKAWAYS_RAD};
use super::DynCtx;
use super::DynTerm;
use super::Experiment;
use super::Family;
use super::ModelEffect;
use super::Shape;
use super::ShapeParam;
use pam_numerics::lsq::Column;

/// Dry friction of the carrier ball: a force of constant size against the handle velocity,
/// smoothed over a speed (grid), like Coulomb friction.
pub struct CarrierBallFriction;
impl ModelEffect for CarrierBallFriction {
    fn id(&self) -> &'static str {
        "carrier_ball_friction"
    }
    fn family(&self) -> Option<Family> {
        Some(Family::Friction)
    }
    fn shape_name(&self) -> &'static str {
        "coulomb"
    }
    fn summary(&self) -> &'static str {
        "Coulomb friction of the carrier ball against the handle velocity (§6.2)"
    }
    fn signature(&self) -> &'static str {
        "residual jumps with the sign of the velocity"
    }
    fn applies(&self, e: Experiment) -> bool {
        e == Experiment::Dynamic
    }
    fn shapes(&self, _ctx: &DynCtx) -> Vec<Shape> {
        [0.001, 0.003, 0.01, 0.03, 0.1]
            .iter()
            .map(|&w| Shape(vec![(ShapeParam::SmoothingMS, w)]))
            .collect()
    }
    fn dynamic_term(&self, ctx: &DynCtx, shape: &Shape) -> DynTerm {
        let w = shape.get(ShapeParam::SmoothingMS).unwrap_or(0.0);
        let v = &ctx.p.v_m_s;
        let (mut x, mut y) = (Vec::new(), Vec::new());
        for i in 0..ctx.p.len() {
            let s = v[0][i].hypot(v[1][i]);
            // v̂ · s/√(s² + w²): the direction of motion, faded in over w
            let k = 1.0 / (s * s + w * w).sqrt();
            x.push(v[0][i] * k);
            y.push(v[1][i] * k);
        }
        DynTerm {
            columns: vec![Column::both("coulomb_n", x, y)],
            positive: vec![0],
            ..Default::default()
        }
    }
}

/// Quadratic drag c·|v|·v at the handle.
pub struct VelocitySquared;
impl ModelEffect for VelocitySquared {
    fn id(&self) -> &'static str {
        "velocity_squared"
    }
    fn family(&self) -> Option<Family> {
        Some(Family::Drag)
    }
    fn shape_name(&self) -> &'static str {
        "quadratic"
    }
    fn summary(&self) -> &'static str {
        "force growing with the square of the handle speed, c·|v|·v (§4.6)"
    }
    fn signature(&self) -> &'static str {
        "residual grows with the square of the speed, with the velocity's sign"
    }
    fn applies(&self, e: Experiment) -> bool {
        e == Experiment::Dynamic
    }
    fn dynamic_term(&self, ctx: &DynCtx, _s: &Shape) -> DynTerm {
        let v = &ctx.p.v_m_s;
        let (mut x, mut y) = (Vec::new(), Vec::new());
        for i in 0..ctx.p.len() {
            let s = v[0][i].hypot(v[1][i]);
            x.push(s * v[0][i]);
            y.push(s * v[1][i]);
        }
        DynTerm {
            columns: vec![Column::both("coeff_n_s2_per_m2", x, y)],
            positive: vec![0],
            ..Default::default()
        }
    }
}

/// Stribeck friction: Coulomb friction plus a breakaway force that fades above a speed
/// (grid), f = (c + s·e^{−(v/v_s)²})·v̂, both ≥ 0.
pub struct StribeckFriction;
impl ModelEffect for StribeckFriction {
    fn id(&self) -> &'static str {
        "stribeck_friction"
    }
    fn family(&self) -> Option<Family> {
        Some(Family::Friction)
    }
    fn shape_name(&self) -> &'static str {
        "stribeck"
    }
    fn summary(&self) -> &'static str {
        "friction with a breakaway (static) part that fades with speed (Stribeck)"
    }
    fn signature(&self) -> &'static str {
        "residual jumps with the sign of the velocity, most at low speed"
    }
    fn applies(&self, e: Experiment) -> bool {
        e == Experiment::Dynamic
    }
    fn shapes(&self, _ctx: &DynCtx) -> Vec<Shape> {
        [0.005, 0.01, 0.02, 0.05]
            .iter()
            .map(|&w| Shape(vec![(ShapeParam::StribeckMS, w)]))
            .collect()
    }
    fn dynamic_term(&self, ctx: &DynCtx, shape: &Shape) -> DynTerm {
        let vs = shape.get(ShapeParam::StribeckMS).unwrap_or(0.0);
        // the sign is smoothed over a tenth of the Stribeck speed
        let w = 0.1 * vs;
        let v = &ctx.p.v_m_s;
        let (mut cx, mut cy, mut sx, mut sy) = (vec![], vec![], vec![], vec![]);
        for i in 0..ctx.p.len() {
            let s = v[0][i].hypot(v[1][i]);
            let k = 1.0 / (s * s + w * w).sqrt();
            let bump = (-(s / vs).powi(2)).exp();
            cx.push(v[0][i] * k);
            cy.push(v[1][i] * k);
            sx.push(v[0][i] * k * bump);
            sy.push(v[1][i] * k * bump);
        }
        DynTerm {
            columns: vec![
                Column::both("coulomb_n", cx, cy),
                Column::both("breakaway_n", sx, sy),
            ],
            positive: vec![0, 1],
            ..Default::default()
        }
    }
}

/// Friction with presliding (LuGre-like bristles): before the handle slides, the contact
/// deflects elastically over 30 µm–1 mm (grid), so the friction force turns over that
/// distance after each reversal instead of jumping. It acts at the handle, per axis of
/// motion (the muscles' hysteresis acts per joint). A play operator per axis of
/// that half-width, normalised, one force (≥ 0) for both axes.
pub struct PreslidingFriction;
impl ModelEffect for PreslidingFriction {
    fn id(&self) -> &'static str {
        "presliding_friction"
    }
    fn family(&self) -> Option<Family> {
        Some(Family::Friction)
    }
    fn shape_name(&self) -> &'static str {
        "lugre"
    }
    fn summary(&self) -> &'static str {
        "friction whose force builds up over a tiny presliding distance after each reversal (LuGre bristles)"
    }
    fn signature(&self) -> &'static str {
        "residual follows the direction of motion at the handle, turning over a fraction of a millimetre"
    }
    fn applies(&self, e: Experiment) -> bool {
        e == Experiment::Dynamic
    }
    fn shapes(&self, _ctx: &DynCtx) -> Vec<Shape> {
        [0.00003, 0.0001, 0.0003, 0.001]
            .iter()
            .map(|&d| Shape(vec![(ShapeParam::PreslidingM, d)]))
            .collect()
    }
    fn dynamic_term(&self, ctx: &DynCtx, shape: &Shape) -> DynTerm {
        let p = ctx.p;
        let w = shape.get(ShapeParam::PreslidingM).unwrap_or(0.0).max(1e-7);
        let mut out = [vec![0.0; p.len()], vec![0.0; p.len()]];
        for (a, col) in out.iter_mut().enumerate() {
            let mut z = 0.0f64;
            for i in 1..p.len() {
                z = (z + p.dx_m[a][i] - p.dx_m[a][i - 1]).clamp(-w, w);
                col[i] = z / w;
            }
        }
        let [x, y] = out;
        DynTerm {
            columns: vec![Column::both("coulomb_n", x, y)],
            positive: vec![0],
            ..Default::default()
        }
    }
}

/// Friction in each joint's bearings and pulley: a torque of constant size against the
/// joint's motion, per joint (≥ 0), acting on the arm where it turns rather than at the
/// handle. Its shapes are Coulomb friction faded in over a joint speed (rad/s, grid),
/// LuGre bristles that deflect over a presliding angle (rad, grid) before the joint slides,
/// and the generalized Maxwell-slip form of a bearing's presliding friction (elements that
/// break away at δ, 2δ and 4δ; δ a grid in rad), so the torque turns over that angle after
/// each reversal. Viscous friction in the joints is the base model's damping.
///
/// Within one log the presliding torque is the same signal as the muscles' hysteresis (a
/// torque that turns over a small excursion; the Maxwell-slip shapes are the hysteresis
/// family's own, so the fit cannot prefer either): the pressures are constant through a
/// dynamic trial, and only how the torque changes with them tells the two apart (the same
/// trial at the other stiffness level, [`crate::stiffness_pair`]).
pub struct JointFriction;
impl ModelEffect for JointFriction {
    fn id(&self) -> &'static str {
        "joint_friction"
    }
    fn family(&self) -> Option<Family> {
        Some(Family::Friction)
    }
    fn shape_name(&self) -> &'static str {
        "joint_lugre"
    }
    fn summary(&self) -> &'static str {
        "friction in each joint's bearings and pulley: Coulomb against the joint's motion, or LuGre bristles that deflect over a presliding angle"
    }
    fn signature(&self) -> &'static str {
        "residual is a joint torque that follows the direction of each joint's motion (the same in the two stiffness levels)"
    }
    fn applies(&self, e: Experiment) -> bool {
        e == Experiment::Dynamic
    }
    fn shapes(&self, _ctx: &DynCtx) -> Vec<Shape> {
        let coulomb = [0.003, 0.01, 0.03]
            .iter()
            .map(|&w| Shape(vec![(ShapeParam::SmoothingRadS, w)]));
        let lugre = [0.0004, 0.0015]
            .iter()
            .map(|&d| Shape(vec![(ShapeParam::PreslidingRad, d)]));
        let maxwell_slip = SLIP_BREAKAWAYS_RAD
            .iter()
            .map(|&d| Shape(vec![(ShapeParam::BreakawayRad, d)]));
        coulomb.chain(lugre).chain(maxwell_slip).collect()
    }
    fn dynamic_term(&self, ctx: &DynCtx, shape: &Shape) -> DynTerm {
        let p = ctx.p;
        let n = p.len();
        let mut cols = Vec::new();
        for (j, name) in [(0, "coulomb_nm_joint1"), (1, "coulomb_nm_joint2")] {
            let a = &p.alpha_smooth_rad[j];
            let col = if let Some(d) = shape.get(ShapeParam::BreakawayRad) {
                maxwell_slip_state(a, d)
            } else {
                let mut col = vec![0.0; n];
                if let Some(d) = shape.get(ShapeParam::PreslidingRad) {
                    // the bristles' mean deflection z/z_ss: dz = dα (1 − z·sgn(dα)) / d
                    let d = d.max(1e-7);
                    let mut z = 0.0f64;
                    for i in 1..n {
                        let da = a[i] - a[i - 1];
                        z = (z + da / d * (1.0 - z * da.signum())).clamp(-1.0, 1.0);
                        col[i] = z;
                    }
                } else {
                    let w = shape
                        .get(ShapeParam::SmoothingRadS)
                        .unwrap_or(0.01)
                        .max(1e-6);
                    for i in 0..n {
                        let (lo, hi) = (i.saturating_sub(1), (i + 1).min(n - 1));
                        let dt = (hi - lo) as f64 * p.dt_s;
                        let omega = if dt > 0.0 { (a[hi] - a[lo]) / dt } else { 0.0 };
                        col[i] = omega / (omega * omega + w * w).sqrt();
                    }
                }
                col
            };
            // the friction torque opposes the motion: Δτ = −T·col
            cols.push(ctx.torque_column(name, |i| {
                let mut t = [0.0; 2];
                t[j] = -col[i];
                t
            }));
        }
        DynTerm {
            columns: cols,
            positive: vec![0, 1],
            ..Default::default()
        }
    }
}
