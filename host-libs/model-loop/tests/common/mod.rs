//! A small independent simulator for the tests: a handle moved by an "operator" along a sum
//! of sines around a pose (dynamic trials) or blocked while the force reference steps
//! (step trials), with one hidden effect at a time, sensor noise and encoder quantisation.
//! Written separately from the crate's model-side effects (its own formulas and state), so
//! the tests check the loop against data it did not generate itself.
#![allow(dead_code)]

use pam_ident::Trial;
use pam_model::RobotModel;
use std::f64::consts::PI;

/// The project's one seeded generator (ChaCha8), as the twin uses it.
pub use pam_twin::rng::Rng;

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Hidden {
    None,
    Friction {
        coulomb_n: f64,
    },
    VelocitySquared {
        c: f64,
    },
    Cubic {
        cubic_n: f64,
    },
    Hysteresis {
        fraction: f64,
        width: f64,
    },
    PoseQuadratic {
        k_per_m: f64,
    },
    Drift {
        offset_n: f64,
        drift_n_per_s: f64,
    },
    Delay {
        delay_s: f64,
    },
    Hum {
        amplitude_n: f64,
        freq_hz: f64,
    },
    /// Out of the catalog: the force offset wanders slowly (a sine of period `period_s`).
    Wander {
        amplitude_n: f64,
        period_s: f64,
    },
    // step-only
    SlewLimit {
        rate_n_per_s: f64,
    },
    Saturation {
        max_n: f64,
    },
}

pub struct DynConfig {
    pub dt_s: f64,
    pub duration_s: f64,
    pub noise_n: f64,
    pub alpha0_deg: [f64; 2],
    pub seed: u64,
    pub hidden: Hidden,
    /// Amplitude of the operator's motion, m.
    pub motion_m: f64,
}

impl Default for DynConfig {
    fn default() -> Self {
        DynConfig {
            dt_s: 0.01,
            duration_s: 90.0,
            noise_n: 0.3,
            alpha0_deg: [0.0, 0.0],
            seed: 1,
            hidden: Hidden::None,
            motion_m: 0.03,
        }
    }
}

/// Truth of the base model (point 1 of the thesis, rounded).
pub const K: [[f64; 2]; 2] = [[250.0, 100.0], [100.0, 360.0]];
pub const B: [[f64; 2]; 2] = [[20.0, 4.0], [4.0, 15.0]];
pub const M: [[f64; 2]; 2] = [[1.5, 0.2], [0.2, 1.2]];

fn mv(m: &[[f64; 2]; 2], v: [f64; 2]) -> [f64; 2] {
    [
        m[0][0] * v[0] + m[0][1] * v[1],
        m[1][0] * v[0] + m[1][1] * v[1],
    ]
}

/// Dynamic trial. The operator's motion is a sum of sines whose frequencies and phases
/// depend on the seed; position, velocity and acceleration are exact, the encoder angles
/// quantised at 2^16 counts per turn.
pub fn dynamic(c: &DynConfig) -> Trial {
    let model = RobotModel::<f64>::thesis();
    let kin = &model.kinematics;
    let mut rng = Rng::new(c.seed);
    let comps: Vec<([f64; 2], f64, [f64; 2])> = (0..6)
        .map(|k| {
            let f = 0.15 + 2.2 * rng.uniform() * (1.0 + k as f64) / 3.0;
            let amp = [rng.uniform() - 0.3, rng.uniform() - 0.3];
            (
                amp,
                2.0 * PI * f,
                [2.0 * PI * rng.uniform(), 2.0 * PI * rng.uniform()],
            )
        })
        .collect();
    let norm: f64 = comps
        .iter()
        .map(|c| c.0[0].abs() + c.0[1].abs())
        .sum::<f64>()
        / 2.0;
    let scale = c.motion_m / norm.max(1e-9);
    let a0 = [c.alpha0_deg[0].to_radians(), c.alpha0_deg[1].to_radians()];
    let x0 = kin.forward_user(a0);
    let n = (c.duration_s / c.dt_s).round() as usize;
    let q = 2.0 * PI / 65536.0;
    let mut tr = Trial::default();
    // Dahl state per joint (muscle 2's), and a smooth start ramp so the trial starts at rest
    let mut z = [0.0f64; 2];
    let mut prev_alpha = a0;
    // history for the delay
    let mut hist: Vec<[f64; 2]> = Vec::with_capacity(n);
    for i in 0..n {
        let t = i as f64 * c.dt_s;
        let ramp_t = 3.0;
        let (r, rd, rdd) = if t < ramp_t {
            let s = t / ramp_t;
            (
                s * s * (3.0 - 2.0 * s),
                6.0 * s * (1.0 - s) / ramp_t,
                (6.0 - 12.0 * s) / (ramp_t * ramp_t),
            )
        } else {
            (1.0, 0.0, 0.0)
        };
        let (mut d, mut v, mut a) = ([0.0; 2], [0.0; 2], [0.0; 2]);
        for (amp, w, ph) in &comps {
            for ax in 0..2 {
                let s = (w * t + ph[ax]).sin() - ph[ax].sin();
                let cc = (w * t + ph[ax]).cos();
                let g = amp[ax] * scale;
                let (p0, p1, p2) = (g * s, g * w * cc, -g * w * w * (w * t + ph[ax]).sin());
                d[ax] += r * p0;
                v[ax] += rd * p0 + r * p1;
                a[ax] += rdd * p0 + 2.0 * rd * p1 + r * p2;
            }
        }
        let pos = [x0[0] + d[0], x0[1] + d[1]];
        let alpha = kin.inverse_user(pos).expect("reachable");
        // the hand's force on the robot: M a + B v + K d (+ effect)
        let mut h = [0.0; 2];
        let (km, bm, mm) = (mv(&K, d), mv(&B, v), mv(&M, a));
        for ax in 0..2 {
            h[ax] = km[ax] + bm[ax] + mm[ax];
        }
        hist.push(h);
        let speed = v[0].hypot(v[1]);
        let jt = kin.jacobian(alpha).transpose();
        let jit = jt.inverse().expect("regular").0;
        let torque_to_hand = |tau: [f64; 2]| -> [f64; 2] {
            // a disturbance torque on the joints is balanced by the hand: −J⁻ᵀ Δτ
            [
                -(jit[0][0] * tau[0] + jit[0][1] * tau[1]),
                -(jit[1][0] * tau[0] + jit[1][1] * tau[1]),
            ]
        };
        let mut sensor_offset = [0.0; 2];
        match c.hidden {
            Hidden::Friction { coulomb_n } if speed > 0.0 => {
                let k = coulomb_n * (speed / (speed * speed + 0.004f64.powi(2)).sqrt()) / speed;
                h[0] += k * v[0];
                h[1] += k * v[1];
            }
            Hidden::VelocitySquared { c: cq } => {
                h[0] += cq * speed * v[0];
                h[1] += cq * speed * v[1];
            }
            Hidden::Cubic { cubic_n } => {
                // each cable force gains −c (Δε/0.01)³, Δε = ∓(R/l0)(α − α_start);
                // the pair's torque is R (ΔF2 − ΔF1)
                let mut tau = [0.0; 2];
                for j in 0..2 {
                    let jp = &model.params.joints[j];
                    let de2 = jp.pulley_radius_m / jp.muscle_rest_length_m * alpha[j];
                    let de1 = -de2;
                    let df1 = -cubic_n * (de1 / 0.01).powi(3);
                    let df2 = -cubic_n * (de2 / 0.01).powi(3);
                    let de2_0 = jp.pulley_radius_m / jp.muscle_rest_length_m * a0[j];
                    let df1_0 = -cubic_n * (-de2_0 / 0.01).powi(3);
                    let df2_0 = -cubic_n * (de2_0 / 0.01).powi(3);
                    tau[j] = jp.pulley_radius_m * ((df2 - df1) - (df2_0 - df1_0));
                }
                let f = torque_to_hand(tau);
                h[0] += f[0];
                h[1] += f[1];
            }
            Hidden::Hysteresis { fraction, width } => {
                let mut tau = [0.0; 2];
                for j in 0..2 {
                    let jp = &model.params.joints[j];
                    let de =
                        jp.pulley_radius_m / jp.muscle_rest_length_m * (alpha[j] - prev_alpha[j]);
                    let s = if de > 0.0 { 1.0 } else { -1.0 };
                    z[j] = (z[j] + de / width * (1.0 - z[j] * s)).clamp(-1.0, 1.0);
                    // 150 N in each cable at the pretension
                    let z2 = z[j];
                    let z1 = -z[j];
                    let (f1, f2) = (150.0, 150.0);
                    tau[j] = jp.pulley_radius_m * (-fraction * f2 * z2 + fraction * f1 * z1);
                }
                let f = torque_to_hand(tau);
                h[0] += f[0];
                h[1] += f[1];
            }
            Hidden::PoseQuadratic { k_per_m } => {
                // stiffness grows along +x: K(x) = K (1 + k_per_m · dx)
                let s = k_per_m * d[0];
                h[0] += s * km[0];
                h[1] += s * km[1];
            }
            Hidden::Drift {
                offset_n,
                drift_n_per_s,
            } => {
                sensor_offset = [
                    offset_n + drift_n_per_s * t,
                    -0.5 * offset_n + 0.7 * drift_n_per_s * t,
                ];
            }
            Hidden::Delay { delay_s } => {
                let k = i.saturating_sub((delay_s / c.dt_s).round() as usize);
                h = hist[k];
            }
            Hidden::Hum {
                amplitude_n,
                freq_hz,
            } => {
                let s = amplitude_n * (2.0 * PI * freq_hz * t + 0.3).sin();
                sensor_offset = [s, s];
            }
            Hidden::Wander {
                amplitude_n,
                period_s,
            } => {
                h[0] += amplitude_n * (2.0 * PI * t / period_s).sin();
                h[1] += 0.5 * amplitude_n * (2.0 * PI * t / period_s + 1.0).sin();
            }
            _ => {}
        }
        prev_alpha = alpha;
        // the robot's force on the hand, plus the sensor's own errors (sensor frame)
        let off_user = kin.sensor_to_user(alpha, sensor_offset);
        let f = [
            -h[0] + off_user[0] + c.noise_n * rng.normal(),
            -h[1] + off_user[1] + c.noise_n * rng.normal(),
        ];
        tr.t_s.push(t);
        tr.alpha_rad[0].push((alpha[0] / q).round() * q);
        tr.alpha_rad[1].push((alpha[1] / q).round() * q);
        tr.force_n[0].push(f[0]);
        tr.force_n[1].push(f[1]);
    }
    tr
}

pub struct StepConfig {
    pub dt_s: f64,
    pub duration_s: f64,
    pub noise_n: f64,
    pub seed: u64,
    pub hidden: Hidden,
    pub gain: f64,
    pub zeta: f64,
    pub omega_n: f64,
    /// Largest reference step, N.
    pub step_n: f64,
    /// The thesis's protocol (§5.2): every step on X first, then every step on Y, instead
    /// of the axes in turn.
    pub x_then_y: bool,
    /// The hidden effect acts on X's force only.
    pub hidden_on_x_only: bool,
}

impl Default for StepConfig {
    fn default() -> Self {
        StepConfig {
            dt_s: 0.01,
            duration_s: 90.0,
            noise_n: 0.2,
            seed: 3,
            hidden: Hidden::None,
            gain: 0.57,
            zeta: 0.42,
            omega_n: 23.04,
            step_n: 20.0,
            x_then_y: false,
            hidden_on_x_only: false,
        }
    }
}

/// Step trial: blocked handle at the neutral pose, the reference steps every 1.5–3 s to a
/// random level on each axis in turn; the force follows H(s) = G ωn²/(s² + 2ζωn s + ωn²),
/// integrated with small Euler sub-steps (not the crate's exact discretisation).
pub fn step(c: &StepConfig) -> Trial {
    let mut rng = Rng::new(c.seed);
    let n = (c.duration_s / c.dt_s).round() as usize;
    let sub = ((c.dt_s / 2e-4).ceil() as usize).max(1);
    let h = c.dt_s / sub as f64;
    let mut refs = [0.0f64; 2];
    let mut next_change = 1.0;
    let mut axis = 0;
    let mut y = [0.0f64; 2];
    let mut yd = [0.0f64; 2];
    let mut driven = [0.0f64; 2];
    let mut hist: Vec<[f64; 2]> = Vec::new();
    let mut hyst_dir = [0.0f64; 2];
    let mut tr = Trial::default();
    let mut fref = [Vec::with_capacity(n), Vec::with_capacity(n)];
    for i in 0..n {
        let t = i as f64 * c.dt_s;
        if t >= next_change {
            if c.x_then_y {
                // X's steps in the first half, back to 0 at its end, then Y's
                axis = usize::from(t >= c.duration_s / 2.0);
                if axis == 1 && refs[0] != 0.0 {
                    hyst_dir[0] = -refs[0].signum();
                    refs[0] = 0.0;
                }
            }
            let new = c.step_n * (2.0 * rng.uniform() - 1.0);
            hyst_dir[axis] = (new - refs[axis]).signum();
            refs[axis] = new;
            if !c.x_then_y {
                axis = 1 - axis;
            }
            next_change = t + 1.5 + 1.5 * rng.uniform();
        }
        hist.push(refs);
        // the sample shows the state at t, before this interval's integration
        let mut off = [0.0; 2];
        match c.hidden {
            Hidden::Drift {
                offset_n,
                drift_n_per_s,
            } => off = [offset_n + drift_n_per_s * t, offset_n - drift_n_per_s * t],
            Hidden::Hum {
                amplitude_n,
                freq_hz,
            } => {
                let s = amplitude_n * (2.0 * PI * freq_hz * t + 0.3).sin();
                off = [s, s];
            }
            _ => {}
        }
        tr.t_s.push(t);
        tr.alpha_rad[0].push(0.0);
        tr.alpha_rad[1].push(0.0);
        for ax in 0..2 {
            tr.force_n[ax].push(y[ax] + off[ax] + c.noise_n * rng.normal());
            fref[ax].push(refs[ax]);
        }
        let u = match c.hidden {
            Hidden::Delay { delay_s } => {
                hist[i.saturating_sub((delay_s / c.dt_s).round() as usize)]
            }
            _ => refs,
        };
        for _ in 0..sub {
            for ax in 0..2 {
                let untouched = c.hidden_on_x_only && ax == 1;
                let mut target = c.gain * if untouched { refs[ax] } else { u[ax] };
                let hidden = if untouched { Hidden::None } else { c.hidden };
                match hidden {
                    Hidden::Saturation { max_n } => target = max_n * (target / max_n).tanh(),
                    Hidden::Hysteresis { fraction, .. } => target += fraction * hyst_dir[ax],
                    _ => {}
                }
                if let Hidden::SlewLimit { rate_n_per_s } = hidden {
                    driven[ax] = target.clamp(
                        driven[ax] - 1.3 * rate_n_per_s * h,
                        driven[ax] + rate_n_per_s * h,
                    );
                } else {
                    driven[ax] = target;
                }
                let acc = c.omega_n * c.omega_n * (driven[ax] - y[ax])
                    - 2.0 * c.zeta * c.omega_n * yd[ax];
                yd[ax] += acc * h;
                y[ax] += yd[ax] * h;
            }
        }
    }
    tr.force_ref_n = Some(fref);
    tr
}
