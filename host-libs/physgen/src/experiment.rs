//! The thesis's two trials as inputs to the plant: the dynamic trial (§4.3: the converters
//! hold the pressures of one of Table 4.1's points at a stiffness between its levels while
//! an operator moves the handle) and the step trial (§5.2: the handle blocked at one of the
//! nine poses, a force reference stepping on one axis at a time through the open-loop
//! inverse model of fig. 4.1). Only the controller's side (what the currents are) comes
//! from pam-model: the rig does what the physics says.

use pam_model::protocols::STEP_HIGH_PRESSURE_SHARE;
use pam_model::thesis::{STEP_POSES_DEG, TABLE_4_1};
use pam_model::RobotModel;
use rand::Rng;
use rand_chacha::ChaCha8Rng;

/// The handle rests this long before the operator starts (the loop's equilibrium is the
/// mean of the first 0.1 s).
pub const REST_S: f64 = 0.6;
const RAMP_S: f64 = 2.5;

/// Currents (mA) for per-joint muscle pressures (the channel map and eq. 2.2).
pub fn currents_ma(model: &RobotModel<f64>, joint_bar: [[f64; 2]; 2]) -> [f64; 4] {
    model
        .channel_pressures_bar(joint_bar)
        .map(|p| model.params.ip.current_for(p).current_ma)
}

/// The operator's path: a few sines per axis about the start, faded in (quintic).
#[derive(Clone, Debug)]
pub struct OperatorPath {
    /// Per axis: (amplitude m, frequency Hz, phase rad).
    pub sines: [Vec<(f64, f64, f64)>; 2],
}

impl OperatorPath {
    pub fn draw(rng: &mut ChaCha8Rng) -> Self {
        let axis = |rng: &mut ChaCha8Rng| {
            let n = rng.random_range(3..6);
            let amp = rng.random_range(0.01..0.035);
            (0..n)
                .map(|_| {
                    (
                        amp / (n as f64).sqrt() * rng.random_range(0.5..1.2),
                        rng.random_range(0.1..1.6),
                        rng.random_range(0.0..std::f64::consts::TAU),
                    )
                })
                .collect()
        };
        OperatorPath {
            sines: [axis(rng), axis(rng)],
        }
    }

    pub fn scale(&mut self, r: f64) {
        for s in self.sines.iter_mut().flatten() {
            s.0 *= r;
        }
    }

    /// Offset from the start and its velocity at t.
    pub fn eval(&self, t: f64) -> ([f64; 2], [f64; 2]) {
        let u = ((t - REST_S) / RAMP_S).clamp(0.0, 1.0);
        let w = 10.0 * u.powi(3) - 15.0 * u.powi(4) + 6.0 * u.powi(5);
        let wd = if (0.0..1.0).contains(&u) && t > REST_S {
            (30.0 * u * u - 60.0 * u.powi(3) + 30.0 * u.powi(4)) / RAMP_S
        } else {
            0.0
        };
        let mut x = [0.0; 2];
        let mut v = [0.0; 2];
        for ax in 0..2 {
            for &(a, f, ph) in &self.sines[ax] {
                let om = std::f64::consts::TAU * f;
                let s = (om * t + ph).sin() - ph.sin();
                x[ax] += w * a * s;
                v[ax] += wd * a * s + w * a * om * (om * t + ph).cos();
            }
        }
        (x, v)
    }
}

/// Table 4.1's point `site` (1–5) in radians.
pub fn point_rad(site: usize) -> [f64; 2] {
    let (a1, a2, _) = TABLE_4_1[(site - 1).min(4)];
    [a1.to_radians(), a2.to_radians()]
}

/// §5.2's step pose `site` (1–9) in radians.
pub fn step_pose_rad(site: usize) -> [f64; 2] {
    let p = STEP_POSES_DEG[(site - 1).min(8)];
    [p[0].to_radians(), p[1].to_radians()]
}

/// The dynamic trial's constant currents at a stiffness `level` (0–1) between the point's
/// levels, and the joint stiffness asked.
pub fn dynamic_currents(
    model: &RobotModel<f64>,
    alpha0: [f64; 2],
    level: f64,
) -> ([f64; 4], [f64; 2]) {
    let mut kj = [0.0; 2];
    for j in 0..2 {
        let (lo, hi) = model.capability(j, alpha0[j]).trial_stiffness_levels();
        kj[j] = lo + level * (hi - lo);
    }
    let sol = model.inverse(alpha0, [0.0, 0.0], kj);
    (
        currents_ma(model, [sol[0].pressure_bar, sol[1].pressure_bar]),
        kj,
    )
}

/// One hold of the step trial's reference.
#[derive(Clone, Copy, Debug)]
pub struct Hold {
    pub start_s: f64,
    pub ref_n: [f64; 2],
    pub currents_ma: [f64; 4],
}

/// The step schedule: rest at zero force, then runs of 4–8 steps on one axis, then the
/// other, to levels of ±1–3 × `step_n`, each held 2–4 s. The joint stiffness (the muscles'
/// co-contraction) is the lowest that lets every level through unclamped, or, with
/// `level` (0–1), that far towards the highest that does: the same schedule, drawn from the
/// same numbers, at another co-contraction. Returns the holds, the step and the stiffness.
pub fn step_schedule(
    model: &RobotModel<f64>,
    alpha: [f64; 2],
    duration_s: f64,
    rng: &mut ChaCha8Rng,
    level: Option<f64>,
) -> (Vec<Hold>, f64, [f64; 2]) {
    let mut step_n = rng.random_range(4.0..9.0);
    let stiffness = loop {
        if let Some(k) = feasible(model, alpha, step_n) {
            break match level {
                Some(l) => towards_highest(model, alpha, step_n, k, l.clamp(0.0, 1.0)),
                None => k,
            };
        }
        step_n *= 0.85;
        if step_n < 2.0 {
            break [0, 1].map(|j| model.capability(j, alpha[j]).trial_stiffness_levels().0);
        }
    };
    let command = |f: [f64; 2]| {
        let c = model.force_command(alpha, f, stiffness, false);
        currents_ma(model, [c.joints[0].pressure_bar, c.joints[1].pressure_bar])
    };
    let mut holds = vec![Hold {
        start_s: 0.0,
        ref_n: [0.0; 2],
        currents_ma: command([0.0; 2]),
    }];
    let mut t = 3.0;
    let mut axis = rng.random_range(0..2usize);
    let mut level = [0i32; 2];
    while t < duration_s - 1.5 {
        let run = rng.random_range(4..9);
        for _ in 0..run {
            let mut next = level[axis];
            while next == level[axis] {
                next = rng.random_range(-3..=3);
            }
            level[axis] = next;
            let mut f = [0.0; 2];
            f[axis] = next as f64 * step_n;
            holds.push(Hold {
                start_s: t,
                ref_n: f,
                currents_ma: command(f),
            });
            t += rng.random_range(2.0..4.0);
            if t >= duration_s - 1.5 {
                break;
            }
        }
        if level[axis] != 0 && t < duration_s - 1.5 {
            level[axis] = 0;
            holds.push(Hold {
                start_s: t,
                ref_n: [0.0; 2],
                currents_ma: command([0.0; 2]),
            });
            t += rng.random_range(2.0..4.0);
        }
        axis = 1 - axis;
    }
    (holds, step_n, stiffness)
}

/// The stiffness `level` of the way from `lowest` (every level through unclamped) to the
/// highest that still lets every level through: the highest each joint's capability allows
/// at every level's torque, brought down until no command is clamped and every commanded
/// pressure keeps under the protocol's share of the range
/// (`pam_model::protocols::STEP_HIGH_PRESSURE_SHARE`, the controller's side).
fn towards_highest(
    model: &RobotModel<f64>,
    alpha: [f64; 2],
    step_n: f64,
    lowest: [f64; 2],
    level: f64,
) -> [f64; 2] {
    let mut top = [f64::INFINITY; 2];
    for ranges in corner_ranges(model, alpha, step_n) {
        for j in 0..2 {
            if let Some((_, hi)) = ranges[j] {
                top[j] = top[j].min(hi / 1.02);
            }
        }
    }
    let ceiling_bar = STEP_HIGH_PRESSURE_SHARE * model.params.pressure.max_bar;
    let unclamped = |k: [f64; 2]| every_level_within(model, alpha, step_n, k, ceiling_bar);
    let mut l = level;
    for _ in 0..20 {
        let k = [0, 1].map(|j| {
            let hi = if top[j].is_finite() {
                top[j].max(lowest[j])
            } else {
                lowest[j]
            };
            lowest[j] + l * (hi - lowest[j])
        });
        if unclamped(k) {
            return k;
        }
        l *= 0.8;
    }
    lowest
}

/// The stiffness that lets every level up to ±3 steps through unclamped, or `None`.
fn feasible(model: &RobotModel<f64>, alpha: [f64; 2], step_n: f64) -> Option<[f64; 2]> {
    let mut k = [0.0f64; 2];
    for ranges in corner_ranges(model, alpha, step_n) {
        for j in 0..2 {
            let (lo, _) = ranges[j]?;
            k[j] = k[j].max(lo);
        }
    }
    let k = k.map(|x| x * 1.02);
    every_level_within(model, alpha, step_n, k, f64::INFINITY).then_some(k)
}

/// Each joint's stiffness range (`None`: no stiffness holds the torque) at the four corners
/// of the levels, ±3 steps on both axes.
fn corner_ranges(
    model: &RobotModel<f64>,
    alpha: [f64; 2],
    step_n: f64,
) -> [[Option<(f64, f64)>; 2]; 4] {
    [[3.0, 3.0], [3.0, -3.0], [-3.0, 3.0], [-3.0, -3.0]].map(|d: [f64; 2]| {
        let tau = model
            .kinematics
            .joint_torques(alpha, [d[0] * step_n, d[1] * step_n]);
        [0, 1].map(|j| model.capability(j, alpha[j]).stiffness_range(tau[j]))
    })
}

/// Whether every level up to ±3 steps on both axes is commanded at stiffness `k` unclamped,
/// every muscle's pressure at or under `ceiling_bar`.
fn every_level_within(
    model: &RobotModel<f64>,
    alpha: [f64; 2],
    step_n: f64,
    k: [f64; 2],
    ceiling_bar: f64,
) -> bool {
    (-3..=3).all(|a| {
        (-3..=3).all(|b| {
            let f = [a as f64 * step_n, b as f64 * step_n];
            let c = model.force_command(alpha, f, k, false);
            c.joints
                .iter()
                .all(|j| j.limited.0 == 0 && j.pressure_bar.iter().all(|&p| p <= ceiling_bar))
        })
    })
}
