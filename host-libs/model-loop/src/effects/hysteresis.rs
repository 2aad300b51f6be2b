//! Hysteresis of the muscles: direction-dependent force that turns over a small excursion.

use super::DynCtx;
use super::DynTerm;
use super::Experiment;
use super::Family;
use super::ModelEffect;
use super::Shape;
use super::ShapeParam;
use crate::response::StepExtra;
use pam_numerics::lsq::Column;
use pam_numerics::stats::rms;

/// Dahl-type hysteresis of each muscle pair: a direction state z ∈ [−1, 1] that turns
/// over a contraction change `width` (grid); the torque loss is proportional to z.
pub struct MuscleHysteresis;
impl ModelEffect for MuscleHysteresis {
    fn id(&self) -> &'static str {
        "muscle_hysteresis"
    }
    fn family(&self) -> Option<Family> {
        Some(Family::Hysteresis)
    }
    fn shape_name(&self) -> &'static str {
        "dahl"
    }
    fn summary(&self) -> &'static str {
        "direction-dependent muscle force (Dahl friction of the braid), a torque that reverses over a small excursion (§4.2, §5.1)"
    }
    fn signature(&self) -> &'static str {
        "residual follows the direction of the last motion and turns over a small displacement (loops against displacement)"
    }
    fn applies(&self, _e: Experiment) -> bool {
        true
    }
    fn step_extras(&self) -> &'static [StepExtra] {
        &[StepExtra::Hysteresis]
    }
    fn shapes(&self, _ctx: &DynCtx) -> Vec<Shape> {
        [0.0005, 0.001, 0.002, 0.004, 0.008]
            .iter()
            .map(|&w| Shape(vec![(ShapeParam::Width, w)]))
            .collect()
    }
    fn dynamic_term(&self, ctx: &DynCtx, shape: &Shape) -> DynTerm {
        let p = ctx.p;
        let width = shape.get(ShapeParam::Width).unwrap_or(0.0);
        let mut cols = Vec::new();
        for j in 0..2 {
            let jp = &ctx.model.params.joints[j];
            let eps_per_rad = jp.pulley_radius_m / jp.muscle_rest_length_m;
            let a = &p.alpha_smooth_rad[j];
            // z of muscle 2 (ε2 = ε0 + (R/l0)α); muscle 1's is its opposite
            let mut z = vec![0.0; p.len()];
            let mut zi = 0.0f64;
            for i in 1..p.len() {
                let de = eps_per_rad * (a[i] - a[i - 1]);
                let s = if de > 0.0 { 1.0 } else { -1.0 };
                zi = (zi + de / width * (1.0 - zi * s)).clamp(-1.0, 1.0);
                z[i] = zi;
            }
            // ΔF_i = −fraction·F_i·z_i, z1 = −z2 → Δτ = R(ΔF2 − ΔF1) = −R·fraction·(F1 + F2)·z2
            let name = ["torque_nm_joint1", "torque_nm_joint2"][j];
            cols.push(ctx.torque_column(name, |i| {
                let mut t = [0.0; 2];
                t[j] = -z[i];
                t
            }));
        }
        DynTerm {
            columns: cols,
            positive: vec![0, 1],
            ..Default::default()
        }
    }
    fn report_params(
        &self,
        ctx: &DynCtx,
        fitted: &[(String, f64)],
        shape: &Shape,
    ) -> Vec<(String, f64)> {
        let mut v = fitted.to_vec();
        v.push(("width".into(), shape.get(ShapeParam::Width).unwrap_or(0.0)));
        // fraction = amplitude / (R (F1 + F2)) with the muscle forces of the model at the
        // commanded pressures (from the logged currents), when the log has them
        if let Some(cur) = &ctx.p.current_ma {
            let model = ctx.model;
            let mut fr = Vec::new();
            for j in 0..2 {
                let i0 = 0;
                let ch: [f64; 4] = [cur[0][i0], cur[1][i0], cur[2][i0], cur[3][i0]]
                    .map(|c| model.params.ip.pressure_bar(c));
                let jp = model.joint_pressures_bar(ch);
                let pose = model.pose(j, ctx.p.alpha0_rad[j]);
                let f = pose.forces_n(jp[j]);
                let r = model.params.joints[j].pulley_radius_m;
                let sum = f[0].max(0.0) + f[1].max(0.0);
                if sum > 1.0 {
                    fr.push(fitted[j].1 / (r * sum));
                }
            }
            if !fr.is_empty() {
                v.push(("fraction".into(), fr.iter().sum::<f64>() / fr.len() as f64));
            }
        }
        v
    }
}

/// An elastic loop: the handle is stiffer moving away from the equilibrium than coming
/// back (loading and unloading stiffness differ), per axis, ≥ 0.
pub struct ElasticLoop;
impl ModelEffect for ElasticLoop {
    fn id(&self) -> &'static str {
        "elastic_loop"
    }
    fn family(&self) -> Option<Family> {
        Some(Family::Hysteresis)
    }
    fn shape_name(&self) -> &'static str {
        "elastic_loop"
    }
    fn summary(&self) -> &'static str {
        "stiffer when moving away from the equilibrium than when coming back (loading ≠ unloading)"
    }
    fn signature(&self) -> &'static str {
        "residual ∝ displacement while it grows, ≈ 0 while it shrinks (a loop pinched at the equilibrium)"
    }
    fn applies(&self, e: Experiment) -> bool {
        e == Experiment::Dynamic
    }
    fn dynamic_term(&self, ctx: &DynCtx, _s: &Shape) -> DynTerm {
        let p = ctx.p;
        let mut cols = Vec::new();
        for (a, name) in [
            (0, "extra_loading_k_x_n_per_m"),
            (1, "extra_loading_k_y_n_per_m"),
        ] {
            // the share of the stiffness that acts only while |Δx| grows; smoothed over
            // 2 % of the axis's typical speed × displacement so a reversal is not a jump
            let scale = 0.02 * rms(&p.dx_m[a]) * rms(&p.v_m_s[a]);
            let col: Vec<f64> = (0..p.len())
                .map(|i| {
                    let (d, v) = (p.dx_m[a][i], p.v_m_s[a][i]);
                    let u = d * v;
                    d * 0.5 * (1.0 + u / (u * u + scale * scale).sqrt())
                })
                .collect();
            cols.push(Column::on(name, a, col));
        }
        DynTerm {
            columns: cols,
            positive: vec![0, 1],
            ..Default::default()
        }
    }
}

/// The breakaway angles (rad) of the Maxwell-slip shapes: the muscles' hysteresis and a
/// joint's generalized Maxwell-slip friction share them.
pub(crate) const SLIP_BREAKAWAYS_RAD: [f64; 5] = [0.0003, 0.0006, 0.0012, 0.0025, 0.005];

/// The state of three elasto-plastic elements in parallel (breakaway angles δ, 2δ, 4δ)
/// driven by the angle `a_rad`, as the share of the torque at full slip (−1 to 1): each
/// sticks until it is deflected by its breakaway angle, then slips.
pub(crate) fn maxwell_slip_state(a_rad: &[f64], delta_rad: f64) -> Vec<f64> {
    let delta = delta_rad.max(1e-6);
    let widths = [delta, 2.0 * delta, 4.0 * delta];
    let mut z = [0.0f64; 3];
    let mut col = vec![0.0; a_rad.len()];
    for i in 1..a_rad.len() {
        let da = a_rad[i] - a_rad[i - 1];
        let mut sum = 0.0;
        for (zk, w) in z.iter_mut().zip(widths) {
            *zk = (*zk + da).clamp(-w, w);
            sum += *zk / w;
        }
        col[i] = sum / 3.0;
    }
    col
}

/// Maxwell-slip hysteresis of the muscle pairs: per joint, elasto-plastic elements that
/// stick until their breakaway angle (δ, 2δ, 4δ; δ a grid in rad) and then slip — the
/// braid's friction seen as a torque; the torque at full slip ≥ 0 per joint.
pub struct MaxwellSlip;
impl ModelEffect for MaxwellSlip {
    fn id(&self) -> &'static str {
        "maxwell_slip"
    }
    fn family(&self) -> Option<Family> {
        Some(Family::Hysteresis)
    }
    fn shape_name(&self) -> &'static str {
        "maxwell_slip"
    }
    fn summary(&self) -> &'static str {
        "elasto-plastic elements per joint that stick and slip (Maxwell-slip hysteresis of the braid)"
    }
    fn signature(&self) -> &'static str {
        "after each reversal the residual turns over a few millimetres, then holds (loops against displacement)"
    }
    fn applies(&self, e: Experiment) -> bool {
        e == Experiment::Dynamic
    }
    fn shapes(&self, _ctx: &DynCtx) -> Vec<Shape> {
        SLIP_BREAKAWAYS_RAD
            .iter()
            .map(|&d| Shape(vec![(ShapeParam::BreakawayRad, d)]))
            .collect()
    }
    fn dynamic_term(&self, ctx: &DynCtx, shape: &Shape) -> DynTerm {
        let p = ctx.p;
        let delta = shape.get(ShapeParam::BreakawayRad).unwrap_or(0.0);
        let mut cols = Vec::new();
        for (j, name) in [(0, "slip_torque_nm_joint1"), (1, "slip_torque_nm_joint2")] {
            let col = maxwell_slip_state(&p.alpha_smooth_rad[j], delta);
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

/// A muscle's hysteresis that grows with its pressure, in a step trial: each converter's
/// muscle loses force in proportion to its pressure in the direction its pressure last
/// moved (the braid's friction, pressed by the pressure, opposes the change). Where steps on
/// one axis move all four pressures, each muscle keeps its own direction, which a handle
/// offset that follows each axis's reference (the `dahl` shape's step form) cannot hold.
pub struct PressureHysteresis;
impl ModelEffect for PressureHysteresis {
    fn id(&self) -> &'static str {
        "pressure_hysteresis"
    }
    fn family(&self) -> Option<Family> {
        Some(Family::Hysteresis)
    }
    fn shape_name(&self) -> &'static str {
        "pressure_proportional"
    }
    fn summary(&self) -> &'static str {
        "each muscle's force loses a share of its pressure in the direction the pressure last moved (hysteresis growing with pressure)"
    }
    fn signature(&self) -> &'static str {
        "steps settle short in the direction they came from, by more at higher pressures"
    }
    fn applies(&self, e: Experiment) -> bool {
        e == Experiment::Step
    }
    fn step_extras(&self) -> &'static [StepExtra] {
        &[StepExtra::ChannelHysteresis]
    }
}
