//! Hidden effects of the dynamic trial, each in this generator's own functional form. A
//! mechanical effect adds a term e to −f (the force the hand needs on top of the MSD), so
//! the logged force is f_base − e; joint-space effects reach the handle through J⁻ᵀ.

use pam_model::RobotModel;
use rand::Rng;
use rand_chacha::ChaCha8Rng;

use crate::case::Shape;
use crate::dynamic::{DynBase, FINE_S};
use crate::effect::{named, EffectModel};
use crate::robot::{mul, torque_to_force};
use crate::signal::{interp, log_uniform, play, Forces};

fn rms(x: impl Iterator<Item = f64>) -> f64 {
    let (mut s, mut n) = (0.0, 0usize);
    for v in x {
        s += v * v;
        n += 1;
    }
    (s / n.max(1) as f64).sqrt()
}

/// −e for every sample from a per-sample function (the unit contribution to the log).
fn unit_from(b: &DynBase, mut e: impl FnMut(usize) -> [f64; 2]) -> Forces {
    (0..b.t_s.len())
        .map(|i| {
            let v = e(i);
            [-v[0], -v[1]]
        })
        .collect()
}

/// Joint-1-heavy weighting of per-joint torques: joint 2's pulley is smaller (45 vs 70 mm).
const JOINT_WEIGHT: [f64; 2] = [1.0, 0.6];

/// Builds the effect of `shape` on the dynamic trial `b`.
pub fn build<'a>(
    shape: Shape,
    b: &'a DynBase,
    model: &'a RobotModel<f64>,
    rng: &mut ChaCha8Rng,
) -> Option<EffectModel<'a>> {
    let speed = |i: usize| (b.v_m_s[i][0].powi(2) + b.v_m_s[i][1].powi(2)).sqrt();
    let to_handle = |i: usize, tau: [f64; 2]| torque_to_force(model, b.alpha_rad[i], tau);
    let n = b.t_s.len();
    match shape {
        Shape::Coulomb | Shape::ViscousPlusCoulomb | Shape::Stribeck => {
            // isotropic dry friction of the carrier ball, smoothed by tanh
            let vs = log_uniform(rng, 5e-4, 5e-3);
            let v_rms = rms((0..n).map(speed)).max(1e-6);
            let viscous_ratio = if shape == Shape::ViscousPlusCoulomb {
                rng.random_range(0.3..1.0)
            } else {
                0.0
            };
            let (static_ratio, v_st) = if shape == Shape::Stribeck {
                (rng.random_range(1.5..3.0), log_uniform(rng, 5e-3, 3e-2))
            } else {
                (1.0, 1.0)
            };
            let unit = unit_from(b, |i| {
                let s = speed(i);
                let dir = if s > 0.0 {
                    [b.v_m_s[i][0] / s, b.v_m_s[i][1] / s]
                } else {
                    [0.0; 2]
                };
                let level = 1.0 + (static_ratio - 1.0) * (-(s / v_st).powi(2)).exp();
                let dry = level * (s / vs).tanh();
                let visc = viscous_ratio / v_rms;
                [
                    dir[0] * dry + visc * b.v_m_s[i][0],
                    dir[1] * dry + visc * b.v_m_s[i][1],
                ]
            });
            Some(EffectModel::additive(unit, (1e-3, 200.0), move |c| {
                let mut p = named(&[("coulomb_n", c), ("smoothing_m_s", vs)]);
                if shape == Shape::ViscousPlusCoulomb {
                    p.extend(named(&[("viscous_n_s_per_m", c * viscous_ratio / v_rms)]));
                }
                if shape == Shape::Stribeck {
                    p.extend(named(&[
                        ("static_n", c * static_ratio),
                        ("stribeck_m_s", v_st),
                    ]));
                }
                p
            }))
        }
        Shape::Lugre => {
            // per-axis LuGre bristles; with σ0 and the friction levels scaled together the
            // bristle state does not depend on the strength, so the force is linear in it
            let z_ss = log_uniform(rng, 1e-4, 1e-3);
            let static_ratio = rng.random_range(1.2..2.5);
            let v_st = log_uniform(rng, 5e-3, 3e-2);
            let damping_s = log_uniform(rng, 5e-4, 5e-3);
            let sigma0 = 1.0 / z_ss;
            let mut z = [0.0f64; 2];
            let unit = unit_from(b, |i| {
                let mut out = [0.0; 2];
                for ax in 0..2 {
                    let v = b.v_m_s[i][ax];
                    let g = 1.0 + (static_ratio - 1.0) * (-(v / v_st).powi(2)).exp();
                    let a = sigma0 * v.abs() / g;
                    let z_old = z[ax];
                    z[ax] = if a > 0.0 {
                        v / a + (z[ax] - v / a) * (-a * FINE_S).exp()
                    } else {
                        z[ax] + v * FINE_S
                    };
                    let zd = (z[ax] - z_old) / FINE_S;
                    out[ax] = sigma0 * z[ax] + sigma0 * damping_s * zd;
                }
                out
            });
            Some(EffectModel::additive(unit, (1e-3, 200.0), move |c| {
                named(&[
                    ("coulomb_n", c),
                    ("static_n", c * static_ratio),
                    ("stribeck_m_s", v_st),
                    ("bristle_m", z_ss),
                    ("bristle_damping_s", damping_s),
                ])
            }))
        }
        Shape::Quadratic => {
            let unit = unit_from(b, |i| {
                let s = speed(i);
                [s * b.v_m_s[i][0], s * b.v_m_s[i][1]]
            });
            Some(EffectModel::additive(unit, (1e-3, 1e5), |c| {
                named(&[("drag_n_s2_per_m2", c)])
            }))
        }
        Shape::BoucWen => {
            // per joint, n = 1: ż = α̇ − β|α̇|z − γ α̇|z|, |z| ≤ 1/(β + γ) = width
            let width = [
                log_uniform(rng, 2e-3, 1.5e-2),
                log_uniform(rng, 2e-3, 1.5e-2),
            ];
            let beta_share = rng.random_range(0.5..0.9);
            let mut z = [0.0f64; 2];
            let unit = unit_from(b, |i| {
                let mut tau = [0.0; 2];
                for j in 0..2 {
                    let beta = beta_share / width[j];
                    let gamma = (1.0 - beta_share) / width[j];
                    let da = b.alpha_dot_rad_s[i][j] * FINE_S / 4.0;
                    for _ in 0..4 {
                        z[j] += da - beta * da.abs() * z[j] - gamma * da * z[j].abs();
                    }
                    tau[j] = JOINT_WEIGHT[j] * z[j] / width[j];
                }
                to_handle(i, tau)
            });
            Some(EffectModel::additive(unit, (1e-3, 100.0), move |c| {
                named(&[
                    ("torque_nm_joint1", c * JOINT_WEIGHT[0]),
                    ("torque_nm_joint2", c * JOINT_WEIGHT[1]),
                    ("width_rad_joint1", width[0]),
                    ("width_rad_joint2", width[1]),
                    ("beta_share", beta_share),
                ])
            }))
        }
        Shape::ElasticLoop => {
            // stiffer while moving away from the equilibrium than while coming back
            let mut a_rms = [0.0; 2];
            let mut ad_rms = [0.0; 2];
            for j in 0..2 {
                a_rms[j] = rms(b.alpha_rad.iter().map(|a| a[j] - b.alpha0_rad[j])).max(1e-6);
                ad_rms[j] = rms(b.alpha_dot_rad_s.iter().map(|a| a[j])).max(1e-6);
            }
            let sharp = rng.random_range(0.02..0.2);
            let unit = unit_from(b, |i| {
                let mut tau = [0.0; 2];
                for j in 0..2 {
                    let d = b.alpha_rad[i][j] - b.alpha0_rad[j];
                    let away = d * b.alpha_dot_rad_s[i][j] / (a_rms[j] * ad_rms[j] * sharp);
                    tau[j] = JOINT_WEIGHT[j] * d / a_rms[j] * 0.5 * (1.0 + away.tanh());
                }
                to_handle(i, tau)
            });
            Some(EffectModel::additive(unit, (1e-3, 100.0), move |c| {
                named(&[
                    (
                        "extra_stiffness_nm_per_rad_joint1",
                        c * JOINT_WEIGHT[0] / a_rms[0],
                    ),
                    (
                        "extra_stiffness_nm_per_rad_joint2",
                        c * JOINT_WEIGHT[1] / a_rms[1],
                    ),
                    ("switch_sharpness", sharp),
                ])
            }))
        }
        Shape::MaxwellSlip => {
            // four elasto-plastic elements per joint, breakaway 0.5–8 mrad
            let elems: Vec<(f64, f64)> = (0..4)
                .map(|k| {
                    let d = 5e-4 * 2f64.powf(k as f64 + rng.random_range(-0.3..0.3));
                    (d, rng.random_range(0.5..1.5))
                })
                .collect();
            let norm: f64 = elems.iter().map(|(d, w)| d * w).sum();
            let mut z = [[0.0f64; 4]; 2];
            let mut prev = b.alpha_rad[0];
            let unit = unit_from(b, |i| {
                let mut tau = [0.0; 2];
                for j in 0..2 {
                    let da = b.alpha_rad[i][j] - prev[j];
                    for (k, (d, w)) in elems.iter().enumerate() {
                        z[j][k] = (z[j][k] + da).clamp(-d, *d);
                        tau[j] += JOINT_WEIGHT[j] * w * z[j][k] / norm;
                    }
                }
                prev = b.alpha_rad[i];
                to_handle(i, tau)
            });
            let breakaway: Vec<f64> = elems.iter().map(|e| e.0).collect();
            Some(EffectModel::additive(unit, (1e-3, 100.0), move |c| {
                let mut p = named(&[("max_torque_nm_joint1", c * JOINT_WEIGHT[0])]);
                for (k, d) in breakaway.iter().enumerate() {
                    p.push((format!("breakaway_rad_{}", k + 1), *d));
                }
                p
            }))
        }
        Shape::JointPlay => {
            // the muscles' side of one joint lags the encoder's by a play; the spring acts
            // on the muscles' side
            let joint = if rng.random::<f64>() < 0.6 { 0 } else { 1 };
            let enc: Vec<f64> = b.alpha_rad.iter().map(|a| a[joint]).collect();
            let k = b.k_n_per_m;
            let apply = move |play_rad: f64| -> Forces {
                let motor = play(&enc, 0.5 * play_rad);
                (0..n)
                    .map(|i| {
                        let mut am = b.alpha_rad[i];
                        am[joint] = motor[i];
                        let xm = model.kinematics.forward_user(am);
                        let xe = model.kinematics.forward_user(b.alpha_rad[i]);
                        let e = mul(&k, [xm[0] - xe[0], xm[1] - xe[1]]);
                        [b.force_n[i][0] - e[0], b.force_n[i][1] - e[1]]
                    })
                    .collect()
            };
            Some(EffectModel::whole(apply, (2e-4, 1.2e-2), move |p| {
                named(&[("backlash_rad", p), ("joint", joint as f64 + 1.0)])
            }))
        }
        Shape::CubicNeutral | Shape::CubicEquilibrium => {
            // per joint τ = c (Δα/a_ref)³, Δα from the neutral pose (minus its value at the
            // trial's rest, which the operator holds) or from the trial's equilibrium
            let neutral = shape == Shape::CubicNeutral;
            let a_ref = if neutral { 0.1 } else { 0.05 };
            let sign = if rng.random::<f64>() < 0.7 { 1.0 } else { -1.0 };
            let cube = |a: f64| (a / a_ref).powi(3);
            let unit = unit_from(b, |i| {
                let mut tau = [0.0; 2];
                for j in 0..2 {
                    let (a, a0) = (b.alpha_rad[i][j], b.alpha0_rad[j]);
                    let c = if neutral {
                        cube(a) - cube(a0)
                    } else {
                        cube(a - a0)
                    };
                    tau[j] = sign * JOINT_WEIGHT[j] * c;
                }
                to_handle(i, tau)
            });
            Some(EffectModel::additive(unit, (1e-4, 500.0), move |c| {
                named(&[
                    ("cubic_torque_nm_joint1", sign * c * JOINT_WEIGHT[0]),
                    ("cubic_torque_nm_joint2", sign * c * JOINT_WEIGHT[1]),
                    ("reference_angle_rad", a_ref),
                    ("from_neutral_pose", if neutral { 1.0 } else { 0.0 }),
                ])
            }))
        }
        Shape::CartesianLinear | Shape::JointGainPlane => {
            // stiffness scaled by (1 + g·Δα): Cartesian K, or the joint stiffness (gain plane)
            let ang = rng.random_range(0.0..2.0 * std::f64::consts::PI);
            let g = [ang.cos(), ang.sin()];
            let kj = b.joint_stiffness_nm_per_rad;
            let cart = shape == Shape::CartesianLinear;
            let unit = unit_from(b, |i| {
                let da = [
                    b.alpha_rad[i][0] - b.alpha0_rad[0],
                    b.alpha_rad[i][1] - b.alpha0_rad[1],
                ];
                let s = g[0] * da[0] + g[1] * da[1];
                if cart {
                    let f = mul(&b.k_n_per_m, b.dx_m[i]);
                    [s * f[0], s * f[1]]
                } else {
                    to_handle(i, [s * kj[0] * da[0], s * kj[1] * da[1]])
                }
            });
            Some(EffectModel::additive(unit, (1e-3, 200.0), move |c| {
                named(&[
                    ("gain_per_rad_1", c * g[0]),
                    ("gain_per_rad_2", c * g[1]),
                    ("joint_space", if cart { 0.0 } else { 1.0 }),
                ])
            }))
        }
        Shape::SensorSync => {
            let fx: Vec<f64> = b.force_n.iter().map(|f| f[0]).collect();
            let fy: Vec<f64> = b.force_n.iter().map(|f| f[1]).collect();
            let apply = move |d: f64| -> Forces {
                b.t_s
                    .iter()
                    .map(|&t| [interp(&fx, FINE_S, t - d), interp(&fy, FINE_S, t - d)])
                    .collect()
            };
            Some(EffectModel::whole(apply, (0.01, 0.15), |d| {
                named(&[("delay_s", d)])
            }))
        }
        _ => None,
    }
}
