//! Stiffness nonlinearity: the cable force's cubic term.

use super::at_start;
use super::from_neutral;
use super::reference_shapes;
use super::DynCtx;
use super::DynTerm;
use super::Experiment;
use super::Family;
use super::ModelEffect;
use super::Shape;
use super::ShapeParam;
use pam_model::RobotModel;
use pam_numerics::lsq::Column;

/// Cubic stiffening of the cable forces with the muscle contraction (per joint).
pub struct NonlinearStiffness;
impl NonlinearStiffness {
    /// Joint torque per unit cable force coefficient c of ΔF = −c·(Δε/0.01)³ per muscle:
    /// Δε = ∓(R/l0)α for the two muscles, τ = R(F2 − F1) → Δτ = −2cR((R/l0)α/0.01)³.
    fn torque_per_n(model: &RobotModel<f64>, j: usize, alpha: f64) -> f64 {
        let jp = &model.params.joints[j];
        let r = jp.pulley_radius_m;
        let u = r / jp.muscle_rest_length_m * alpha / 0.01;
        -2.0 * r * u * u * u
    }
}
impl ModelEffect for NonlinearStiffness {
    fn id(&self) -> &'static str {
        "nonlinear_stiffness"
    }
    fn family(&self) -> Option<Family> {
        Some(Family::StiffnessNonlinearity)
    }
    fn shape_name(&self) -> &'static str {
        "cubic_in_joint_angles"
    }
    fn summary(&self) -> &'static str {
        "restoring joint torque growing with the cube of the excursion (cubic term of the cable force in the contraction, §4.3)"
    }
    fn signature(&self) -> &'static str {
        "residual grows with the cube of the displacement"
    }
    fn applies(&self, e: Experiment) -> bool {
        e == Experiment::Dynamic
    }
    /// The stretch is counted from the neutral pose's pretension (a trial away from it
    /// then also shows the effect as a shift of the equilibrium) or from the start of the
    /// trial (only the change of stiffness shows): chosen on the data.
    fn shapes(&self, _ctx: &DynCtx) -> Vec<Shape> {
        reference_shapes()
    }
    fn dynamic_term(&self, ctx: &DynCtx, s: &Shape) -> DynTerm {
        let p = ctx.p;
        let mut cols = Vec::new();
        for j in 0..2 {
            let a = &p.alpha_smooth_rad[j];
            let t0 = if from_neutral(s) {
                0.0
            } else {
                at_start(p, |i| Self::torque_per_n(ctx.model, j, a[i]))
            };
            let name = ["cubic_n_joint1", "cubic_n_joint2"][j];
            cols.push(ctx.torque_column(name, |i| {
                let mut t = [0.0; 2];
                t[j] = Self::torque_per_n(ctx.model, j, a[i]) - t0;
                t
            }));
        }
        DynTerm {
            columns: cols,
            carries_constant: from_neutral(s),
            ..Default::default()
        }
    }
    fn report_params(
        &self,
        _ctx: &DynCtx,
        fitted: &[(String, f64)],
        s: &Shape,
    ) -> Vec<(String, f64)> {
        let mut v = fitted.to_vec();
        v.extend(s.named());
        // one cubic coefficient for both joints (the twin's parameter), from the two fits
        // weighted towards the joint that moved most is approximated by their mean
        let c = fitted.iter().map(|p| p.1).sum::<f64>() / fitted.len().max(1) as f64;
        v.push(("cubic_n".into(), c));
        v
    }
}

/// A cubic restoring force about the trial's own equilibrium (odd in the displacement, so
/// it does not shift the equilibrium): per joint −c·(α − α0)³ through J⁻ᵀ, or per handle
/// axis −c·Δx³ — a shape chosen on the data.
pub struct CubicAboutEquilibrium;
impl ModelEffect for CubicAboutEquilibrium {
    fn id(&self) -> &'static str {
        "cubic_about_equilibrium"
    }
    fn family(&self) -> Option<Family> {
        Some(Family::StiffnessNonlinearity)
    }
    fn shape_name(&self) -> &'static str {
        "cubic_about_equilibrium"
    }
    fn summary(&self) -> &'static str {
        "restoring force growing with the cube of the excursion from where the trial rests"
    }
    fn signature(&self) -> &'static str {
        "residual grows with the cube of the displacement, odd about the equilibrium"
    }
    fn applies(&self, e: Experiment) -> bool {
        e == Experiment::Dynamic
    }
    fn shapes(&self, _ctx: &DynCtx) -> Vec<Shape> {
        vec![
            Shape(vec![(ShapeParam::JointSpace, 1.0)]),
            Shape(vec![(ShapeParam::JointSpace, 0.0)]),
        ]
    }
    fn dynamic_term(&self, ctx: &DynCtx, s: &Shape) -> DynTerm {
        let p = ctx.p;
        let cols = if s.flag(ShapeParam::JointSpace) {
            (0..2)
                .map(|j| {
                    let a = &p.alpha_smooth_rad[j];
                    let a0 = p.alpha0_rad[j];
                    let name = ["cubic_nm_per_rad3_joint1", "cubic_nm_per_rad3_joint2"][j];
                    // −f = −J⁻ᵀ Δτ with Δτ = −c (α − α0)³: the column is +J⁻ᵀ (α − α0)³
                    ctx.torque_column(name, |i| {
                        let mut t = [0.0; 2];
                        t[j] = -(a[i] - a0).powi(3);
                        t
                    })
                })
                .collect()
        } else {
            (0..2)
                .map(|ax| {
                    let name = ["cubic_n_per_m3_x", "cubic_n_per_m3_y"][ax];
                    Column::on(name, ax, p.dx_m[ax].iter().map(|d| d.powi(3)).collect())
                })
                .collect()
        };
        DynTerm {
            columns: cols,
            ..Default::default()
        }
    }
}
