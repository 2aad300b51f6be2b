//! The step trial (thesis §5.2–5.3, fig. 4.1): the handle blocked at one of the nine step
//! poses, a force reference stepping on one axis at a time, the currents from the open-loop
//! inverse model, and the measured force = the reference through G ωn²/(s² + 2ζωn s + ωn²)
//! (Table 5.2, perturbed), discretised exactly at a fine sub-step.

use pam_model::RobotModel;
use rand::Rng;
use rand_chacha::ChaCha8Rng;

use crate::case::{CaseSpec, Shape, StepLevels, StepOrder, STREAM_LEVELS};
use crate::effect::{named, EffectModel};
use crate::robot;
use crate::signal::{first_order_lag, interp, perturb, play, Forces, SecondOrder};

/// Fine grid of the step simulation.
pub const FINE_S: f64 = 0.0005;
/// Table 5.2: G, ζ, ωn.
pub const TABLE_5_2: (f64, f64, f64) = (0.57, 0.42, 23.04);

/// One hold of the reference.
#[derive(Clone, Copy, Debug)]
pub struct Segment {
    pub start_s: f64,
    pub ref_n: [f64; 2],
    pub currents_ma: [f64; 4],
    /// Channel pressures the converters are set to.
    pub setpoint_bar: [f64; 4],
}

/// The noise-free step trial on the fine grid.
pub struct StepBase {
    pub t_s: Vec<f64>,
    pub alpha_rad: [f64; 2],
    pub segments: Vec<Segment>,
    /// Segment index of each fine sample.
    pub seg_of: Vec<usize>,
    /// Force reference per axis on the fine grid.
    pub ref_n: [Vec<f64>; 2],
    pub gain: [f64; 2],
    pub zeta: f64,
    pub omega_n_rad_s: f64,
    pub filters: [SecondOrder; 2],
    pub step_n: f64,
    pub stiffness_nm_per_rad: [f64; 2],
    pub force_n: Forces,
}

impl StepBase {
    /// The measured force for inputs `u` (force-command units, before the gain).
    pub fn respond(&self, u: &[Vec<f64>; 2]) -> Forces {
        let y = [self.filters[0].run(&u[0]), self.filters[1].run(&u[1])];
        y[0].iter().zip(&y[1]).map(|(a, b)| [*a, *b]).collect()
    }
}

/// The joint stiffness that lets every level up to ±3 steps through (§5.2: the highest of
/// the minimum stiffnesses of the extreme forces), and whether the model reaches each level.
fn feasible(model: &RobotModel<f64>, alpha: [f64; 2], step_n: f64) -> Option<[f64; 2]> {
    let extremes: Vec<[f64; 2]> = [[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]]
        .iter()
        .map(|d| [3.0 * step_n * d[0], 3.0 * step_n * d[1]])
        .collect();
    let mut k = [0.0f64; 2];
    for f in &extremes {
        let tau = model.kinematics.joint_torques(alpha, *f);
        for j in 0..2 {
            let (lo, _hi) = model.capability(j, alpha[j]).stiffness_range(tau[j])?;
            k[j] = k[j].max(lo);
        }
    }
    let k = k.map(|x| x * 1.02);
    for lvl in -3..=3 {
        for ax in 0..2 {
            let mut f = [0.0; 2];
            f[ax] = lvl as f64 * step_n;
            let (p, limited) = robot::force_pressures(model, alpha, f, k);
            let cur = robot::currents_ma(model, p);
            let back = robot::model_force_n(model, alpha, robot::pressures_bar(model, cur));
            let err = ((back[0] - f[0]).powi(2) + (back[1] - f[1]).powi(2)).sqrt();
            if limited || err > 0.05 + 0.01 * f[ax].abs() {
                return None;
            }
        }
    }
    Some(k)
}

/// The fine grid's length for a step case.
pub fn fine_len(spec: &CaseSpec) -> usize {
    (spec.duration_s / FINE_S).round() as usize + 1
}

/// The noise-free step trial. `iterations` are the fine-grid indices of the loop's
/// iterations: every change of the reference moves to the first at or after its draw (on
/// even sampling they coincide).
pub fn build(
    spec: &CaseSpec,
    model: &RobotModel<f64>,
    rng: &mut ChaCha8Rng,
    iterations: &[usize],
) -> StepBase {
    let alpha = robot::step_pose_rad(spec.site);
    let mut step_n = rng.random_range(5.0..10.0);
    let stiffness = loop {
        if let Some(k) = feasible(model, alpha, step_n) {
            break k;
        }
        step_n *= 0.85;
        if step_n < 3.5 {
            // the pretension stiffness at a small step always works near the centre
            break feasible(model, alpha, step_n).unwrap_or([80.0, 35.0]);
        }
    };
    let (g0, z0, w0) = TABLE_5_2;
    let gain = [g0 * perturb(rng, 0.15), g0 * perturb(rng, 0.15)];
    let zeta = z0 * perturb(rng, 0.15);
    let omega = w0 * perturb(rng, 0.15);
    let filters = gain.map(|g| SecondOrder::new(g, zeta, omega, FINE_S));

    // the schedule: rest at 0, then random walks over ±3 steps on one axis at a time,
    // back to 0 before switching axis; holds 1.5–4 s on the sampling grid
    let dt = spec.dt_s;
    let on_grid = |t: f64| (t / dt).round() * dt;
    let mut segs: Vec<(f64, [f64; 2])> = vec![(0.0, [0.0; 2])];
    let mut t = on_grid(rng.random_range(2.0..3.0));
    let drawn_axis = rng.random_range(0..2usize);
    let mut axis = match spec.step_order {
        StepOrder::Alternating => drawn_axis,
        StepOrder::XThenY => 0,
    };
    let mut level = 0i32;
    let mut rng_levels = crate::rng(spec.seed, STREAM_LEVELS);
    let mut last_ref = [0.0; 2];
    let mut moves = 0;
    let mut planned = rng.random_range(4..9);
    while t < spec.duration_s - 1.0 {
        let next = if moves >= planned {
            0
        } else {
            loop {
                let l = rng.random_range(-3..=3i32);
                if l != level && (l - level).abs() <= 3 {
                    break l;
                }
            }
        };
        let mut r = [0.0; 2];
        r[axis] = next as f64 * step_n;
        if next != 0 {
            let reachable = |f: [f64; 2]| !robot::force_pressures(model, alpha, f, stiffness).1;
            r = other_levels(spec.step_levels, &mut rng_levels, r, last_ref, axis, step_n)
                .find(|f| reachable(*f))
                .unwrap_or(r);
        }
        last_ref = r;
        segs.push((t, r));
        level = next;
        moves += 1;
        if moves > planned {
            // a run ends back at 0: the next run's axis
            axis = match spec.step_order {
                StepOrder::Alternating => 1 - axis,
                StepOrder::XThenY => usize::from(t >= spec.duration_s / 2.0),
            };
            moves = 0;
            planned = rng.random_range(4..9);
        }
        t += on_grid(rng.random_range(1.5..4.0)).max(dt);
    }
    let on_iteration = |t: f64| {
        let k = iterations.partition_point(|&i| (i as f64 * FINE_S) < t - 1e-9);
        iterations.get(k).map_or(t, |&i| i as f64 * FINE_S)
    };
    let segments: Vec<Segment> = segs
        .iter()
        .map(|&(start_s, ref_n)| {
            let start_s = on_iteration(start_s);
            let (p, _) = robot::force_pressures(model, alpha, ref_n, stiffness);
            let currents_ma = robot::currents_ma(model, p);
            Segment {
                start_s,
                ref_n,
                currents_ma,
                setpoint_bar: robot::pressures_bar(model, currents_ma),
            }
        })
        .collect();
    let n = fine_len(spec);
    let t_s: Vec<f64> = (0..n).map(|i| i as f64 * FINE_S).collect();
    let mut seg_of = Vec::with_capacity(n);
    let mut s = 0;
    for &t in &t_s {
        while s + 1 < segments.len() && segments[s + 1].start_s <= t + 1e-9 {
            s += 1;
        }
        seg_of.push(s);
    }
    let ref_n = [0, 1].map(|ax| seg_of.iter().map(|&s| segments[s].ref_n[ax]).collect());
    let mut base = StepBase {
        t_s,
        alpha_rad: alpha,
        segments,
        seg_of,
        ref_n,
        gain,
        zeta,
        omega_n_rad_s: omega,
        filters,
        step_n,
        stiffness_nm_per_rad: stiffness,
        force_n: Vec::new(),
    };
    base.force_n = base.respond(&base.ref_n);
    base
}

/// The next level where the levels are not the lattice: drawn from `rng` (tried a few times
/// for one the model reaches, else the lattice's `lattice`). `None` on the lattice.
fn other_levels(
    levels: StepLevels,
    rng: &mut ChaCha8Rng,
    lattice: [f64; 2],
    last: [f64; 2],
    axis: usize,
    step_n: f64,
) -> impl Iterator<Item = [f64; 2]> + '_ {
    (0..50).filter_map(move |_| match levels {
        StepLevels::Lattice => None,
        StepLevels::Continuous => {
            let l = rng.random_range(-3.0..3.0) * step_n;
            let mut r = lattice;
            r[axis] = l;
            ((l - last[axis]).abs() >= 0.5 * step_n).then_some(r)
        }
        StepLevels::Diagonal => {
            let r = [0, 1].map(|_| rng.random_range(-2..=2i32) as f64 * step_n);
            let moved = (0..2).all(|a| (r[a] - last[a]).abs() > 1e-9);
            (moved && r != [0.0; 2]).then_some(r)
        }
    })
}

pub fn base_params(b: &StepBase) -> Vec<(String, f64)> {
    named(&[
        ("gain_x", b.gain[0]),
        ("gain_y", b.gain[1]),
        ("zeta", b.zeta),
        ("omega_n_rad_s", b.omega_n_rad_s),
        ("step_n", b.step_n),
        ("joint_stiffness_nm_per_rad_1", b.stiffness_nm_per_rad[0]),
        ("joint_stiffness_nm_per_rad_2", b.stiffness_nm_per_rad[1]),
    ])
}

/// A rate limiter: rises at most `up` N/s, falls at most `down` N/s.
fn slew(x: &[f64], up: f64, down: f64) -> Vec<f64> {
    let mut y = x.first().copied().unwrap_or(0.0);
    x.iter()
        .map(|&v| {
            y += (v - y).clamp(-down * FINE_S, up * FINE_S);
            y
        })
        .collect()
}

fn map_forces(f: &Forces, g: impl Fn(f64) -> f64) -> Forces {
    f.iter().map(|v| [g(v[0]), g(v[1])]).collect()
}

/// Builds the effect of `shape` on the step trial `b`.
pub fn effect<'a>(
    shape: Shape,
    b: &'a StepBase,
    model: &'a RobotModel<f64>,
    rng: &mut ChaCha8Rng,
) -> Option<EffectModel<'a>> {
    let max_abs = b
        .force_n
        .iter()
        .map(|f| f[0].abs().max(f[1].abs()))
        .fold(0.0, f64::max)
        .max(1e-6);
    match shape {
        Shape::DeadTime | Shape::TubeLag => {
            let lag_share = if shape == Shape::TubeLag {
                rng.random_range(0.3..1.0)
            } else {
                0.0
            };
            let apply = move |d: f64| {
                let u = [0, 1].map(|ax| {
                    let delayed: Vec<f64> = b
                        .t_s
                        .iter()
                        .map(|&t| interp(&b.ref_n[ax], FINE_S, t - d))
                        .collect();
                    if lag_share > 0.0 {
                        first_order_lag(&delayed, lag_share * d, FINE_S)
                    } else {
                        delayed
                    }
                });
                b.respond(&u)
            };
            Some(EffectModel::whole(apply, (0.005, 0.15), move |d| {
                let mut p = named(&[("delay_s", d)]);
                if lag_share > 0.0 {
                    p.extend(named(&[("lag_time_constant_s", lag_share * d)]));
                }
                p
            }))
        }
        Shape::OutputSlew | Shape::InputSlew => {
            // λ = 1 / rise rate (s/N); the fall rate is 0.4–0.7× or 1.5–2.5× the rise rate
            let ratio = if rng.random::<f64>() < 0.5 {
                rng.random_range(0.4..0.7)
            } else {
                rng.random_range(1.5..2.5)
            };
            let output = shape == Shape::OutputSlew;
            let apply = move |inv_rate: f64| {
                let up = 1.0 / inv_rate;
                if output {
                    let y = [0, 1].map(|ax| {
                        let col: Vec<f64> = b.force_n.iter().map(|f| f[ax]).collect();
                        slew(&col, up, up * ratio)
                    });
                    y[0].iter().zip(&y[1]).map(|(a, c)| [*a, *c]).collect()
                } else {
                    b.respond(&[0, 1].map(|ax| slew(&b.ref_n[ax], up, up * ratio)))
                }
            };
            Some(EffectModel::whole(apply, (1e-3, 2.0), move |inv| {
                named(&[
                    ("rise_n_per_s", 1.0 / inv),
                    ("fall_n_per_s", ratio / inv),
                    ("on_output", if output { 1.0 } else { 0.0 }),
                ])
            }))
        }
        Shape::HardClip | Shape::TanhKnee => {
            // λ = how far below the largest force the knee sits (share of it)
            let width_share = rng.random_range(0.5..1.0);
            let hard = shape == Shape::HardClip;
            let apply = move |depth: f64| {
                let knee = (1.0 - depth) * max_abs;
                let w = width_share * (max_abs - knee);
                map_forces(&b.force_n, |y| {
                    if y.abs() <= knee {
                        y
                    } else if hard {
                        knee * y.signum()
                    } else {
                        y.signum() * (knee + w * ((y.abs() - knee) / w).tanh())
                    }
                })
            };
            Some(EffectModel::whole(apply, (0.002, 0.8), move |depth| {
                let knee = (1.0 - depth) * max_abs;
                let mut p = named(&[("knee_n", knee)]);
                if !hard {
                    let w = width_share * (max_abs - knee);
                    p.extend(named(&[("max_n", knee + w)]));
                }
                p
            }))
        }
        Shape::PressureCap => {
            // one converter cannot deliver more than a cap: the channel with the widest
            // set-point range; λ = how far the cap sits below its highest set-point (share)
            let range = |c: usize| {
                let it = b.segments.iter().map(|s| s.setpoint_bar[c]);
                (
                    it.clone().fold(f64::INFINITY, f64::min),
                    it.fold(0.0, f64::max),
                )
            };
            let ch = (0..4)
                .max_by(|a, c| {
                    let (ra, rc) = (range(*a), range(*c));
                    (ra.1 - ra.0).total_cmp(&(rc.1 - rc.0))
                })
                .unwrap_or(0);
            let (lo, hi) = range(ch);
            let apply = move |depth: f64| {
                let cap = hi - depth * (hi - lo);
                let deficit: Vec<[f64; 2]> = b
                    .segments
                    .iter()
                    .map(|s| {
                        let mut p = s.setpoint_bar;
                        if p[ch] <= cap {
                            return [0.0; 2];
                        }
                        let full = robot::model_force_n(model, b.alpha_rad, p);
                        p[ch] = cap;
                        let capped = robot::model_force_n(model, b.alpha_rad, p);
                        [capped[0] - full[0], capped[1] - full[1]]
                    })
                    .collect();
                let u = [0, 1].map(|ax| {
                    b.seg_of
                        .iter()
                        .zip(&b.ref_n[ax])
                        .map(|(&s, r)| r + deficit[s][ax])
                        .collect()
                });
                b.respond(&u)
            };
            Some(EffectModel::whole(apply, (0.002, 0.95), move |depth| {
                named(&[
                    ("channel", ch as f64 + 1.0),
                    ("cap_bar", hi - depth * (hi - lo)),
                ])
            }))
        }
        Shape::DirectionOffset | Shape::ForcePlay => {
            let offset = shape == Shape::DirectionOffset;
            let apply = move |h_n: f64| {
                let u = [0, 1].map(|ax| {
                    let r = &b.ref_n[ax];
                    let half = 0.5 * h_n / b.gain[ax];
                    if offset {
                        // the force settles h lower when approached from below
                        let mut dir = 0.0;
                        let mut last = r[0];
                        r.iter()
                            .map(|&x| {
                                if x != last {
                                    dir = (x - last).signum();
                                    last = x;
                                }
                                x - dir * half
                            })
                            .collect()
                    } else {
                        play(r, half)
                    }
                });
                b.respond(&u)
            };
            Some(EffectModel::whole(apply, (0.005, 20.0), move |h| {
                named(&[("loop_width_n", h)])
            }))
        }
        _ => None,
    }
}
