//! Backlash and slip of joint 1's cable in its pulley groove.

use super::DynCtx;
use super::DynTerm;
use super::Experiment;
use super::Family;
use super::ModelEffect;
use super::Shape;
use super::ShapeParam;

/// Joint-1 cable: backlash in the pulley groove (play, grid) and slip that creeps while the
/// joint torque exceeds what the groove holds (hold torque, grid).
pub struct CableSlip;
impl ModelEffect for CableSlip {
    fn id(&self) -> &'static str {
        "cable_slip"
    }
    fn family(&self) -> Option<Family> {
        Some(Family::Backlash)
    }
    fn shape_name(&self) -> &'static str {
        "play_and_creep"
    }
    fn summary(&self) -> &'static str {
        "joint-1 cable backlash and slip in the pulley groove under high torque (§2.3, §6.2)"
    }
    fn signature(&self) -> &'static str {
        "the equilibrium of joint 1 creeps after high-torque phases; a dead band in joint 1's restoring torque"
    }
    fn applies(&self, e: Experiment) -> bool {
        e == Experiment::Dynamic
    }
    fn shapes(&self, ctx: &DynCtx) -> Vec<Shape> {
        let tmax = ctx.joint_torque_nm[0]
            .iter()
            .fold(0.0f64, |m, v| m.max(v.abs()));
        let mut v = Vec::new();
        for b in [0.0, 0.002, 0.004, 0.008, 0.016] {
            for frac in [0.3, 0.5, 0.7, 0.85] {
                v.push(Shape(vec![
                    (ShapeParam::BacklashRad, b),
                    (ShapeParam::HoldTorqueNm, frac * tmax),
                ]));
            }
        }
        v
    }
    fn dynamic_term(&self, ctx: &DynCtx, shape: &Shape) -> DynTerm {
        let p = ctx.p;
        let n = p.len();
        let a = &p.alpha_smooth_rad[0];
        let half = 0.5 * shape.get(ShapeParam::BacklashRad).unwrap_or(0.0);
        let hold = shape.get(ShapeParam::HoldTorqueNm).unwrap_or(0.0);
        // play operator minus the angle: what the muscles do not see
        let mut play = vec![0.0; n];
        let mut t = a[0];
        for i in 0..n {
            if a[i] > t + half {
                t = a[i] - half;
            } else if a[i] < t - half {
                t = a[i] + half;
            }
            play[i] = t - a[i];
        }
        // accumulated torque excess: the slip angle up to a rate constant
        let mut slip = vec![0.0; n];
        let mut s = 0.0;
        for i in 1..n {
            let tq = ctx.joint_torque_nm[0][i - 1];
            let excess = tq.abs() - hold;
            if excess > 0.0 {
                s += tq.signum() * excess * (p.t_s[i] - p.t_s[i - 1]);
            }
            slip[i] = s;
        }
        // Both coefficients are joint 1's stiffness times what the cable does, so neither
        // may be negative: the slip's, K·(slip rate), because the cable gives way in the
        // direction the torque pulls (a coefficient of the other sign is a torque that
        // winds itself up, which no groove makes: free, the accumulated excess is a slow
        // random walk that takes up the load cell's 1/f wander); the play's, K, because
        // the muscles pull back by −K·(play offset).
        let mut cols = vec![ctx.torque_column("slip_nm_per_nm_s", |i| [slip[i], 0.0])];
        if half > 0.0 {
            cols.push(ctx.torque_column("play_stiffness_nm_per_rad", |i| [-play[i], 0.0]));
        }
        let positive = (0..cols.len()).collect();
        DynTerm {
            columns: cols,
            positive,
            ..Default::default()
        }
    }
}

/// Play between a joint's muscles and its encoder: the muscles' side follows the encoder
/// only outside a dead band of the play (grid), so the restoring torque lags by half the
/// play after each reversal. One play for the rig (on whichever joint has it: both are
/// fitted), a torque per radian of offset per joint.
pub struct JointPlay;
impl ModelEffect for JointPlay {
    fn id(&self) -> &'static str {
        "joint_play"
    }
    fn family(&self) -> Option<Family> {
        Some(Family::Backlash)
    }
    fn shape_name(&self) -> &'static str {
        "joint_play"
    }
    fn summary(&self) -> &'static str {
        "play between a joint's muscles and its encoder (a dead band in the restoring torque)"
    }
    fn signature(&self) -> &'static str {
        "after each reversal of a joint the restoring force stays put over the play, then follows"
    }
    fn applies(&self, e: Experiment) -> bool {
        e == Experiment::Dynamic
    }
    fn shapes(&self, _ctx: &DynCtx) -> Vec<Shape> {
        [0.0005, 0.001, 0.002, 0.004, 0.008, 0.012]
            .iter()
            .map(|&b| Shape(vec![(ShapeParam::BacklashRad, b)]))
            .collect()
    }
    fn dynamic_term(&self, ctx: &DynCtx, shape: &Shape) -> DynTerm {
        let p = ctx.p;
        let half = 0.5 * shape.get(ShapeParam::BacklashRad).unwrap_or(0.0);
        let mut cols = Vec::new();
        for (j, name) in [
            (0, "play_stiffness_nm_per_rad_joint1"),
            (1, "play_stiffness_nm_per_rad_joint2"),
        ] {
            let a = &p.alpha_smooth_rad[j];
            let mut t = a[0];
            let mut off = vec![0.0; p.len()];
            for i in 0..p.len() {
                if a[i] > t + half {
                    t = a[i] - half;
                } else if a[i] < t - half {
                    t = a[i] + half;
                }
                off[i] = t - a[i];
            }
            // the muscles' angle is the encoder's plus the offset: Δτ = −K·offset
            cols.push(ctx.torque_column(name, |i| {
                let mut tq = [0.0; 2];
                tq[j] = -off[i];
                tq
            }));
        }
        DynTerm {
            columns: cols,
            positive: vec![0, 1],
            ..Default::default()
        }
    }
}
