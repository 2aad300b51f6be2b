//! Pose dependence of the stiffness and of the step gain (eq. 5.2's plane).

use super::from_neutral;
use super::joint_pressures;
use super::model_torque;
use super::reference_shapes;
use super::DynCtx;
use super::DynTerm;
use super::Experiment;
use super::Family;
use super::ModelEffect;
use super::Shape;
use super::ShapeParam;
use crate::response::StepExtra;
use pam_numerics::lsq::Column;

/// Pose dependence of the stiffness: the restoring force gains terms quadratic in the
/// displacement (a stiffness that changes linearly across the workspace).
pub struct PoseDependence;
impl ModelEffect for PoseDependence {
    fn id(&self) -> &'static str {
        "pose_dependence"
    }
    fn family(&self) -> Option<Family> {
        Some(Family::PoseDependence)
    }
    fn shape_name(&self) -> &'static str {
        "gain_plane"
    }
    fn summary(&self) -> &'static str {
        "stiffness/gain varying over the workspace (§4.6, §5.3: gain plane eq. 5.2)"
    }
    fn signature(&self) -> &'static str {
        "residual depends on where the handle is (even in the displacement) / step gain varies with the pose"
    }
    fn applies(&self, _e: Experiment) -> bool {
        true
    }
    /// Two forms, chosen on the data like any shape: the gain plane acting on the muscle
    /// pressures (needs the currents; 2 parameters), or a restoring force quadratic in the
    /// displacement (6 parameters; any simulator or rig).
    /// With the gain plane, its angles count from the neutral pose (eq. 5.2: a trial away
    /// from it also shows a shift of the equilibrium) or from the start of the trial.
    fn shapes(&self, ctx: &DynCtx) -> Vec<Shape> {
        let mut v = Vec::new();
        if joint_pressures(ctx.p, ctx.model).is_some() {
            for r in reference_shapes() {
                v.push(Shape(
                    [vec![(ShapeParam::QuadraticForm, 0.0)], r.0].concat(),
                ));
            }
        }
        v.push(Shape(vec![(ShapeParam::QuadraticForm, 1.0)]));
        v
    }
    fn dynamic_term(&self, ctx: &DynCtx, shape: &Shape) -> DynTerm {
        // with the pressures known (currents in the log): the pressure part of each joint's
        // torque scaled by a plane in (α1, α2) — the gain plane of eq. 5.2 acting on the
        // muscles; the parameters are the plane's slopes
        let pressures = if !shape.flag(ShapeParam::QuadraticForm) {
            joint_pressures(ctx.p, ctx.model)
        } else {
            None
        };
        if let Some(pr) = pressures {
            let p = ctx.p;
            let a = &p.alpha_smooth_rad;
            let origin = if from_neutral(shape) {
                [0.0; 2]
            } else {
                p.alpha0_rad
            };
            let mut cols = Vec::new();
            for (k, name) in [(0, "gain_per_rad_1"), (1, "gain_per_rad_2")] {
                let v: Vec<[f64; 2]> = (0..p.len())
                    .map(|i| {
                        let mut t = [0.0; 2];
                        for j in 0..2 {
                            t[j] = model_torque(ctx.model, j, a[j][i], pr[i][j]).0
                                * (a[k][i] - origin[k]);
                        }
                        t
                    })
                    .collect();
                // the extra muscle torque is balanced by the hand: −f gains −J⁻ᵀΔτ
                let c = ctx.torque_column(name, |i| v[i]);
                cols.push(c);
            }
            return DynTerm {
                columns: cols,
                carries_constant: from_neutral(shape),
                ..Default::default()
            };
        }
        // without: a stiffness that changes linearly across the workspace, i.e. restoring
        // forces quadratic in the displacement
        let d = &ctx.p.dx_m;
        let sq = |f: &dyn Fn(usize) -> f64| (0..ctx.p.len()).map(f).collect::<Vec<f64>>();
        let xx = sq(&|i| d[0][i] * d[0][i]);
        let xy = sq(&|i| d[0][i] * d[1][i]);
        let yy = sq(&|i| d[1][i] * d[1][i]);
        DynTerm {
            columns: vec![
                Column::on("qx_xx_n_per_m2", 0, xx.clone()),
                Column::on("qx_xy_n_per_m2", 0, xy.clone()),
                Column::on("qx_yy_n_per_m2", 0, yy.clone()),
                Column::on("qy_xx_n_per_m2", 1, xx),
                Column::on("qy_xy_n_per_m2", 1, xy),
                Column::on("qy_yy_n_per_m2", 1, yy),
            ],
            ..Default::default()
        }
    }
    fn step_extras(&self) -> &'static [StepExtra] {
        &[StepExtra::PoseGain]
    }
}
