//! Friction or hysteresis, from the same dynamic trial at two stiffness levels.
//!
//! In one log a direction-dependent torque that turns over a small excursion after each
//! reversal fits friction in the joints and the muscles' hysteresis alike: the pressures
//! are constant through a dynamic trial, so nothing in it tells a torque that scales with
//! them from one that does not. The muscles' hysteresis is the braid's friction, whose
//! normal load is the pressure: it grows at least in proportion to the muscles' pressure
//! (the co-contraction that sets the joint stiffness), and with their force where it is a
//! share of the force. A bearing's or a pulley's friction, or the carrier ball's, does not
//! change with it. Run the trial at Table 4.1's other stiffness level and compare: the same
//! per-joint torque in both logs is friction; a torque that grows with the pressure is
//! hysteresis.
//!
//! The torque of each log is the per-joint Maxwell-slip torque at full slip (the catalog's
//! [`MaxwellSlip`], at the breakaway angle that fits both logs best together), fitted with
//! the base model; the pressures are the logged currents' through the converters' nominal
//! gain. The decision is the growth `g`, the slope of ln(torque ratio) on ln(pressure ratio) over the
//! two joints (each weighted by its smaller torque): friction predicts 0, hysteresis at
//! least 1 where it saturates in both logs (more where it follows the force, which grows
//! faster than the pressure as the muscles leave their slack), less where the stiffer log's
//! smaller excursions leave it short of saturation. The split, [`GROWTH_SPLIT`], was set
//! on pam-physgen's pairs of seeds 1–40 and is validated on other seeds and on the twin
//! (`cargo xtask eval --only friction-pairs`); within [`GROWTH_DOUBT`] of it the pair cannot tell.

use crate::diagnose::{Loop, Settings};
use crate::effects::SLIP_BREAKAWAYS_RAD;
use crate::effects::{
    DynCtx, DynTerm, Experiment, Family, MaxwellSlip, ModelEffect, PreslidingFriction, Shape,
    ShapeParam,
};
use pam_ident::trial::Trial;
use pam_ident::IdentError;
use pam_model::RobotModel;
use serde::Serialize;

/// The growth `g` that separates the two: friction below, hysteresis at or above. Friction's
/// growth scatters about 0 by the fits' noise (within ±0.15 over 40 pam-physgen pairs,
/// seeds 1–40: LuGre and Maxwell-slip in the joints, LuGre at the handle); the muscles'
/// hysteresis grows with the pressure at 1 or more when it is fully reversed in both logs,
/// and less (0.5–1 over the same seeds' Bouc–Wen) when the stiffer log's smaller excursions
/// leave it short of saturation. So the split lies nearer 0 than halfway.
pub const GROWTH_SPLIT: f64 = 0.35;
/// Growths within this of [`GROWTH_SPLIT`] are too close to call.
pub const GROWTH_DOUBT: f64 = 0.1;
/// The two logs' muscle pressures must differ by at least this factor (RMS of the log
/// ratios over the joints, weighted as `g`) for the comparison to say anything.
pub const MIN_PRESSURE_RATIO: f64 = 1.15;
/// Below this share of the base model's training residual removed in both logs, neither
/// log shows a direction-dependent torque to compare.
pub const MIN_TRAIN_GAIN: f64 = 0.005;

/// The separating experiment, in words.
pub const SEPARATING_EXPERIMENT: &str = "repeat the same trial at Table 4.1's other stiffness level (K_low ↔ K_high: the muscles' pressure changes, a bearing's friction does not) and give both logs to `pamctl model diagnose A.csv B.csv`; slow reversals (well below 1 Hz) show the loop's shape best";

/// The Maxwell-slip breakaway angles tried (rad): the catalog's grid. Both logs are compared
/// at the one that fits them best together, so a change of shape is not read as a change of
/// size.
pub const BREAKAWAYS_RAD: [f64; 5] = SLIP_BREAKAWAYS_RAD;

/// The catalog's Maxwell-slip at the k-th of [`BREAKAWAYS_RAD`] (an id of its own each, as
/// the loop keeps the shapes it chose per id).
struct SlipAt(usize);
const SLIP_IDS: [&str; 5] = [
    "maxwell_slip_0.3mrad",
    "maxwell_slip_0.6mrad",
    "maxwell_slip_1.2mrad",
    "maxwell_slip_2.5mrad",
    "maxwell_slip_5mrad",
];
impl ModelEffect for SlipAt {
    fn id(&self) -> &'static str {
        SLIP_IDS[self.0]
    }
    fn summary(&self) -> &'static str {
        MaxwellSlip.summary()
    }
    fn signature(&self) -> &'static str {
        MaxwellSlip.signature()
    }
    fn applies(&self, e: Experiment) -> bool {
        MaxwellSlip.applies(e)
    }
    fn shapes(&self, _ctx: &DynCtx) -> Vec<Shape> {
        vec![Shape(vec![(
            ShapeParam::BreakawayRad,
            BREAKAWAYS_RAD[self.0],
        )])]
    }
    fn dynamic_term(&self, ctx: &DynCtx, shape: &Shape) -> DynTerm {
        MaxwellSlip.dynamic_term(ctx, shape)
    }
}

/// What one log shows.
#[derive(Clone, Debug, Serialize)]
pub struct LogTorque {
    /// The breakaway angle both logs are compared at (rad).
    pub breakaway_rad: f64,
    /// Per joint, the direction-dependent torque at full slip (N·m).
    pub torque_nm: [f64; 2],
    /// The torques and training gains at each of [`BREAKAWAYS_RAD`].
    #[serde(skip)]
    pub per_breakaway: Vec<([f64; 2], f64)>,
    /// Per joint, the two muscles' summed force at the trial's pose and pressures (N).
    pub muscle_force_sum_n: [f64; 2],
    /// The mean of each joint's two muscle pressures (bar).
    pub mean_pressure_bar: [f64; 2],
    /// Share of the base model's training residual the torque removes.
    pub train_gain: f64,
    /// The handle's presliding friction force (N) fitted instead, and the share it removes.
    pub handle_force_n: f64,
    pub handle_train_gain: f64,
    /// The trial's pose (rad).
    pub alpha0_rad: [f64; 2],
}

/// The decision on a pair of logs.
#[derive(Clone, Debug, Serialize)]
pub struct PairVerdict {
    /// `friction` or `hysteresis`; `None` when the pair cannot tell.
    pub family: Option<Family>,
    /// Slope of ln(torque ratio) on ln(pressure ratio): ≈ 0 friction, up to 1 or more
    /// hysteresis.
    pub growth: f64,
    /// The handle's friction force was compared rather than the joints' torque (it fits
    /// both logs better).
    pub at_handle: bool,
    pub logs: [LogTorque; 2],
    /// Per joint, torque B / torque A, pressure B / pressure A and force B / force A.
    pub torque_ratio: [f64; 2],
    pub pressure_ratio: [f64; 2],
    pub force_ratio: [f64; 2],
    pub evidence: String,
    /// When `family` is `None`: what would decide.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub separating_experiment: Option<String>,
    pub warnings: Vec<String>,
}

/// Measures one dynamic log: the per-joint direction-dependent torque and the muscles'
/// summed force.
pub fn log_torque(
    trial: &Trial,
    model: &RobotModel<f64>,
    settings: Settings,
) -> Result<LogTorque, IdentError> {
    let lp = Loop::new(trial, model, Experiment::Dynamic, settings)?;
    let per_breakaway: Vec<([f64; 2], f64)> = (0..BREAKAWAYS_RAD.len())
        .map(|k| {
            let fit = lp.fit(&[&SlipAt(k)]);
            let params = fit.params.get(SLIP_IDS[k]);
            let torque = ["slip_torque_nm_joint1", "slip_torque_nm_joint2"].map(|k| {
                params
                    .and_then(|p| p.get(k))
                    .copied()
                    .unwrap_or(0.0)
                    .max(0.0)
            });
            (torque, fit.train_gain)
        })
        .collect();
    let best = (0..per_breakaway.len())
        .max_by(|&i, &j| per_breakaway[i].1.total_cmp(&per_breakaway[j].1))
        .unwrap_or(0);
    let handle = lp.fit(&[&PreslidingFriction]);
    let handle_force_n = handle
        .params
        .get("presliding_friction")
        .and_then(|p| p.get("coulomb_n"))
        .copied()
        .unwrap_or(0.0)
        .max(0.0);
    let p = &lp.p;
    let alpha0_rad = p.alpha0_rad;
    let (mut force, mut pressure) = ([0.0; 2], [0.0; 2]);
    if let Some(cur) = &p.current_ma {
        let n = cur[0].len().max(1) as f64;
        let mean_ma = [0, 1, 2, 3].map(|c| cur[c].iter().sum::<f64>() / n);
        let ch = mean_ma.map(|c| model.params.ip.pressure_bar(c));
        let jp = model.joint_pressures_bar(ch);
        for j in 0..2 {
            let f = model.pose(j, alpha0_rad[j]).forces_n(jp[j]);
            force[j] = f[0].max(0.0) + f[1].max(0.0);
            pressure[j] = 0.5 * (jp[j][0] + jp[j][1]);
        }
    }
    Ok(LogTorque {
        breakaway_rad: BREAKAWAYS_RAD[best],
        torque_nm: per_breakaway[best].0,
        train_gain: per_breakaway[best].1,
        per_breakaway,
        muscle_force_sum_n: force,
        mean_pressure_bar: pressure,
        handle_force_n,
        handle_train_gain: handle.train_gain,
        alpha0_rad,
    })
}

/// Decides friction or hysteresis from the same dynamic trial at two stiffness levels.
pub fn friction_or_hysteresis(
    a: &Trial,
    b: &Trial,
    model: &RobotModel<f64>,
    settings: Settings,
) -> Result<PairVerdict, IdentError> {
    let (la, lb) = rayon::join(
        || log_torque(a, model, settings),
        || log_torque(b, model, settings),
    );
    let (mut la, mut lb) = (la?, lb?);
    at_common_breakaway(&mut la, &mut lb);
    Ok(decide(la, lb))
}

/// Sets both logs' torque to the breakaway angle that fits them best together (the largest
/// summed training gain).
pub fn at_common_breakaway(a: &mut LogTorque, b: &mut LogTorque) {
    let n = a.per_breakaway.len().min(b.per_breakaway.len());
    let Some(k) = (0..n).max_by(|&i, &j| {
        (a.per_breakaway[i].1 + b.per_breakaway[i].1)
            .total_cmp(&(a.per_breakaway[j].1 + b.per_breakaway[j].1))
    }) else {
        return;
    };
    for l in [a, b] {
        l.breakaway_rad = BREAKAWAYS_RAD[k];
        (l.torque_nm, l.train_gain) = l.per_breakaway[k];
    }
}

/// The decision on two measured logs.
pub fn decide(a: LogTorque, b: LogTorque) -> PairVerdict {
    let mut warnings = Vec::new();
    let apart_deg = (0..2)
        .map(|j| (a.alpha0_rad[j] - b.alpha0_rad[j]).abs().to_degrees())
        .fold(0.0, f64::max);
    if apart_deg > 3.0 {
        warnings.push(format!(
            "the two logs' poses are {apart_deg:.1}° apart: friction at the handle maps to different joint torques at different poses; compare the same trial at the same point"
        ));
    }
    if a.muscle_force_sum_n
        .iter()
        .chain(&b.muscle_force_sum_n)
        .any(|&f| f <= 0.0)
    {
        warnings.push(
            "a log has no currents (or they command no force): the muscles' pressure is unknown"
                .into(),
        );
    }
    let ratio = |x: f64, y: f64| if x > 0.0 && y > 0.0 { y / x } else { f64::NAN };
    let torque_ratio = [0, 1].map(|j| ratio(a.torque_nm[j], b.torque_nm[j]));
    let pressure_ratio = [0, 1].map(|j| ratio(a.mean_pressure_bar[j], b.mean_pressure_bar[j]));
    let force_ratio = [0, 1].map(|j| ratio(a.muscle_force_sum_n[j], b.muscle_force_sum_n[j]));
    // weighted slope through the origin of ln(torque ratio) on ln(pressure ratio)
    let (mut sxy, mut sxx, mut sw) = (0.0, 0.0, 0.0);
    for j in 0..2 {
        let (x, y) = (pressure_ratio[j].ln(), torque_ratio[j].ln());
        let w = a.torque_nm[j].min(b.torque_nm[j]);
        if x.is_finite() && y.is_finite() && w > 0.0 {
            sxy += w * x * y;
            sxx += w * x * x;
            sw += w;
        }
    }
    let joint_growth = if sxx > 0.0 { sxy / sxx } else { f64::NAN };
    // friction at the handle maps into the joints through the Jacobian, which a per-joint
    // torque fits less well: where the handle's friction fits both logs better, its force
    // is what is compared (the muscles' hysteresis acts in the joints, never at the handle)
    let at_handle = a.handle_train_gain > a.train_gain && b.handle_train_gain > b.train_gain;
    let growth = if at_handle {
        let mean_ln_pressure = (pressure_ratio[0].ln() + pressure_ratio[1].ln()) / 2.0;
        ratio(a.handle_force_n, b.handle_force_n).ln() / mean_ln_pressure
    } else {
        joint_growth
    };
    let shown = a
        .train_gain
        .max(b.train_gain)
        .max(a.handle_train_gain)
        .max(b.handle_train_gain)
        >= MIN_TRAIN_GAIN;
    // the weighted RMS of ln(pressure ratio): how far apart the two stiffness levels are
    let spread = if at_handle {
        (pressure_ratio[0].ln().abs() + pressure_ratio[1].ln().abs()) / 2.0
    } else if sw > 0.0 {
        (sxx / sw).sqrt()
    } else {
        0.0
    };
    let describe = format!(
        "torque at full slip {:.3}, {:.3} N·m → {:.3}, {:.3} N·m (×{:.2}, ×{:.2}) while the muscles' pressure goes ×{:.2}, ×{:.2} (joint 1, joint 2): growth {:.2} (0 friction, ≥ 1 hysteresis)",
        a.torque_nm[0],
        a.torque_nm[1],
        b.torque_nm[0],
        b.torque_nm[1],
        torque_ratio[0],
        torque_ratio[1],
        pressure_ratio[0],
        pressure_ratio[1],
        growth
    );
    let describe = if at_handle {
        format!(
            "the handle's friction fits both logs better than a torque in the joints; its force {:.2} N → {:.2} N (×{:.2}) while the muscles' pressure goes ×{:.2}, ×{:.2}: growth {:.2} (0 friction)",
            a.handle_force_n,
            b.handle_force_n,
            ratio(a.handle_force_n, b.handle_force_n),
            pressure_ratio[0],
            pressure_ratio[1],
            growth
        )
    } else {
        describe
    };
    let (family, evidence) = if !shown {
        (
            None,
            format!(
                "neither log shows a direction-dependent torque (it removes {:.2} % and {:.2} % of the base model's residual): nothing to compare",
                100.0 * a.train_gain,
                100.0 * b.train_gain
            ),
        )
    } else if !(spread >= MIN_PRESSURE_RATIO.ln()) {
        (
            None,
            format!(
                "the two logs' muscle pressures differ by too little (×{:.2}) to tell a torque that grows with them: {describe}",
                spread.exp()
            ),
        )
    } else if !((growth - GROWTH_SPLIT).abs() >= GROWTH_DOUBT) {
        (
            None,
            format!("the torque grows part way with the muscles' pressure: {describe}"),
        )
    } else if growth < GROWTH_SPLIT {
        (
            Some(Family::Friction),
            format!("friction: the torque keeps its size while the muscles' pressure changes; {describe}"),
        )
    } else {
        (
            Some(Family::Hysteresis),
            format!("hysteresis of the muscles: the torque grows with their pressure; {describe}"),
        )
    };
    PairVerdict {
        separating_experiment: family.is_none().then(|| SEPARATING_EXPERIMENT.to_string()),
        family,
        growth,
        at_handle,
        logs: [a, b],
        torque_ratio,
        pressure_ratio,
        force_ratio,
        evidence,
        warnings,
    }
}

#[cfg(test)]
mod tests {
    use super::{decide, LogTorque};
    use crate::effects::Family;

    fn log(torque_nm: [f64; 2], pressure_bar: f64, gain: f64) -> LogTorque {
        LogTorque {
            breakaway_rad: 0.001,
            torque_nm,
            per_breakaway: Vec::new(),
            muscle_force_sum_n: [100.0 * pressure_bar; 2],
            mean_pressure_bar: [pressure_bar; 2],
            train_gain: gain,
            handle_force_n: 0.0,
            handle_train_gain: 0.0,
            alpha0_rad: [0.0; 2],
        }
    }

    #[test]
    fn a_torque_that_keeps_its_size_is_friction_and_one_that_grows_is_hysteresis() {
        let v = decide(log([0.5, 0.3], 2.2, 0.3), log([0.52, 0.29], 3.8, 0.3));
        assert_eq!(v.family, Some(Family::Friction), "{}", v.evidence);
        let v = decide(log([0.2, 0.1], 2.2, 0.3), log([0.33, 0.17], 3.8, 0.3));
        assert_eq!(v.family, Some(Family::Hysteresis), "{}", v.evidence);
        assert!((v.growth - 0.92).abs() < 0.05, "{}", v.growth);
    }

    #[test]
    fn a_pair_that_cannot_tell_says_so_and_names_the_experiment() {
        // the same stiffness level twice
        let v = decide(log([0.5, 0.3], 2.2, 0.3), log([0.8, 0.5], 2.3, 0.3));
        assert_eq!(v.family, None, "{}", v.evidence);
        assert!(v.separating_experiment.is_some());
        // no direction-dependent torque in either log
        let v = decide(log([0.01, 0.0], 2.2, 0.001), log([0.02, 0.0], 3.8, 0.001));
        assert_eq!(v.family, None, "{}", v.evidence);
        // halfway between
        let v = decide(log([0.5, 0.3], 2.2, 0.3), log([0.6, 0.36], 3.8, 0.3));
        assert_eq!(v.family, None, "{}: {}", v.growth, v.evidence);
    }

    #[test]
    fn friction_at_the_handle_is_compared_as_a_force() {
        let mut a = log([0.3, 0.1], 2.2, 0.1);
        let mut b = log([0.6, 0.1], 3.8, 0.1);
        (a.handle_force_n, a.handle_train_gain) = (2.0, 0.3);
        (b.handle_force_n, b.handle_train_gain) = (2.05, 0.3);
        let v = decide(a, b);
        assert!(v.at_handle);
        assert_eq!(v.family, Some(Family::Friction), "{}", v.evidence);
    }
}
