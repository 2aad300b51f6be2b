//! Force-step analysis (§5.3): step detection, gain, overshoot → ζ, peak time → ωn per
//! step and per pose, a least-squares fit of the second-order model
//! H(s) = G ωn² / (s² + 2ζωn s + ωn²) to the whole response, and the gain plane (eq. 5.2).
//!
//! The response simulator takes optional extra terms so that the model-side effects of
//! the catalog (delay, asymmetric rates, saturation, pose-dependent gain, drift, hysteresis)
//! are parametrised transforms of this one model.

use crate::lm;
use crate::trial::{mean, Prepared};
use serde::Serialize;
use std::f64::consts::PI;

/// One detected step on one axis.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct StepResult {
    pub axis: usize,
    pub t_start_s: f64,
    pub t_end_s: f64,
    pub ref_before_n: f64,
    pub ref_after_n: f64,
    pub gain: f64,
    pub overshoot: f64,
    pub zeta: Option<f64>,
    pub peak_time_s: Option<f64>,
    pub omega_n_rad_s: Option<f64>,
    pub alpha_rad: [f64; 2],
}

/// Steps of the reference (or of the measured force when there is no reference):
/// |ΔF| > `threshold_n` between consecutive samples starts a new step (§5.3).
pub fn detect_steps(signal: &[f64], threshold_n: f64) -> Vec<usize> {
    let mut starts = vec![0];
    for i in 1..signal.len() {
        if (signal[i] - signal[i - 1]).abs() > threshold_n {
            // a step spread over consecutive samples counts once
            if i - *starts.last().unwrap() > 1 {
                starts.push(i);
            } else {
                *starts.last_mut().unwrap() = i;
            }
        }
    }
    starts
}

/// ζ from the overshoot ratio Mp = e^{−πζ/√(1−ζ²)}.
pub fn zeta_from_overshoot(mp: f64) -> Option<f64> {
    if !(mp > 0.0 && mp < 1.0) {
        return None;
    }
    let l = mp.ln();
    Some(-l / (PI * PI + l * l).sqrt())
}

/// Graphical estimates for each step on each axis whose reference changes.
pub fn analyse_steps(p: &Prepared, threshold_n: f64) -> Vec<StepResult> {
    let mut out = Vec::new();
    let n = p.len();
    for axis in 0..2 {
        let (sig, uses_ref) = match &p.force_ref_n {
            Some(r) => (&r[axis], true),
            None => (&p.force_n[axis], false),
        };
        let starts = detect_steps(sig, threshold_n);
        for w in 0..starts.len() {
            let s = starts[w];
            let e = starts.get(w + 1).copied().unwrap_or(n);
            if s == 0 || e <= s + 4 {
                continue;
            }
            let y = &p.force_n[axis];
            let before = &y[s.saturating_sub(((e - s) / 10).max(2)).max(if w > 0 {
                starts[w - 1]
            } else {
                0
            })..s];
            let y0 = mean(before);
            let tail = &y[e - ((e - s) / 5).max(1)..e];
            let yss = mean(tail);
            let (u0, u1) = if uses_ref {
                (sig[s - 1], sig[s])
            } else {
                (y0, yss)
            };
            let du = u1 - u0;
            if du.abs() < 1e-9 {
                continue;
            }
            let dir = (yss - y0).signum();
            let (ip, peak) = (s..e)
                .map(|i| (i, y[i]))
                .max_by(|a, b| (dir * a.1).total_cmp(&(dir * b.1)))
                .unwrap();
            let amp = yss - y0;
            let overshoot = if amp.abs() > 0.0 {
                (peak - yss) / amp
            } else {
                0.0
            };
            let zeta = zeta_from_overshoot(overshoot);
            let tp = p.t_s[ip] - p.t_s[s - 1];
            let wn = zeta.map(|z| PI / (tp * (1.0 - z * z).sqrt()));
            out.push(StepResult {
                axis,
                t_start_s: p.t_s[s],
                t_end_s: p.t_s[e - 1],
                ref_before_n: u0,
                ref_after_n: u1,
                gain: amp / du,
                overshoot,
                zeta,
                peak_time_s: zeta.map(|_| tp),
                omega_n_rad_s: wn,
                alpha_rad: [mean(&p.alpha_rad[0][s..e]), mean(&p.alpha_rad[1][s..e])],
            });
        }
    }
    out
}

/// Averages of the per-step estimates of one axis (one pose per log).
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct PoseAverage {
    pub axis: usize,
    pub alpha_rad: [f64; 2],
    pub steps: usize,
    pub gain: f64,
    pub zeta: Option<f64>,
    pub omega_n_rad_s: Option<f64>,
}

pub fn pose_averages(steps: &[StepResult]) -> Vec<PoseAverage> {
    (0..2)
        .filter_map(|axis| {
            let s: Vec<&StepResult> = steps.iter().filter(|s| s.axis == axis).collect();
            if s.is_empty() {
                return None;
            }
            let avg_opt = |f: &dyn Fn(&StepResult) -> Option<f64>| {
                let v: Vec<f64> = s.iter().filter_map(|r| f(r)).collect();
                (!v.is_empty()).then(|| mean(&v))
            };
            Some(PoseAverage {
                axis,
                alpha_rad: [
                    mean(&s.iter().map(|r| r.alpha_rad[0]).collect::<Vec<_>>()),
                    mean(&s.iter().map(|r| r.alpha_rad[1]).collect::<Vec<_>>()),
                ],
                steps: s.len(),
                gain: mean(&s.iter().map(|r| r.gain).collect::<Vec<_>>()),
                zeta: avg_opt(&|r| r.zeta),
                omega_n_rad_s: avg_opt(&|r| r.omega_n_rad_s),
            })
        })
        .collect()
}

/// Eq. 5.2 over poses: G(α1, α2) = p1 α1 + p2 α2 + p3, least squares per axis.
pub fn fit_gain_plane(poses: &[PoseAverage]) -> Result<[[f64; 3]; 2], String> {
    let mut out = [[0.0; 3]; 2];
    for axis in 0..2 {
        let pts: Vec<&PoseAverage> = poses.iter().filter(|p| p.axis == axis).collect();
        if pts.len() < 3 {
            return Err(format!(
                "the gain plane needs at least 3 poses per axis; axis {} has {}",
                ["X", "Y"][axis],
                pts.len()
            ));
        }
        let n = pts.len();
        let cols = vec![
            crate::lsq::Column::on("p1", 0, pts.iter().map(|p| p.alpha_rad[0]).collect()),
            crate::lsq::Column::on("p2", 0, pts.iter().map(|p| p.alpha_rad[1]).collect()),
            crate::lsq::Column::on("p3", 0, vec![1.0; n]),
        ];
        let y: Vec<f64> = pts.iter().map(|p| p.gain).collect();
        let zero = vec![0.0; n];
        let ne = crate::lsq::normal_equations(&cols, &[&y, &zero], 0..n);
        let th = crate::lsq::solve(&ne, &[]);
        out[axis] = [th[0], th[1], th[2]];
    }
    Ok(out)
}

/// Parameters of the second-order response of one axis, base and extras. Extras at their
/// neutral value leave the base model unchanged.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct StepParams {
    pub gain: f64,
    pub zeta: f64,
    pub omega_n_rad_s: f64,
    /// Transport delay of the reference.
    pub delay_s: f64,
    /// Largest rates at which the driving force may rise and fall (flow-limited I/P
    /// converters), N/s.
    pub rise_n_per_s: f64,
    pub fall_n_per_s: f64,
    /// The driving force saturates softly, L·tanh(target/L) (pressure saturation).
    pub force_limit_n: f64,
    /// dG/dα1, dG/dα2 (pose-dependent gain, eq. 5.2).
    pub gain_slope_per_rad: [f64; 2],
    /// Offset that follows the direction of the last reference change (hysteresis).
    pub hysteresis_n: f64,
    /// Load-cell offset and drift.
    pub offset_n: f64,
    pub drift_n_per_s: f64,
}

impl StepParams {
    pub fn base(gain: f64, zeta: f64, omega_n_rad_s: f64) -> Self {
        StepParams {
            gain,
            zeta,
            omega_n_rad_s,
            delay_s: 0.0,
            rise_n_per_s: f64::INFINITY,
            fall_n_per_s: f64::INFINITY,
            force_limit_n: f64::INFINITY,
            gain_slope_per_rad: [0.0; 2],
            hysteresis_n: 0.0,
            offset_n: 0.0,
            drift_n_per_s: 0.0,
        }
    }
}

/// Simulates one axis: y'' + 2ζωn y' + ωn² y = ωn² target(t), target = G(α)·u(t − d) (+
/// hysteresis offset) clipped to the saturation band, integrated with the exact
/// zero-order-hold solution per sample. Starts at the first measured value, at rest.
pub fn simulate(
    p: &StepParams,
    t_s: &[f64],
    u: &[f64],
    alpha: [&[f64]; 2],
    y_start: f64,
    out: &mut [f64],
) {
    let n = t_s.len();
    if n == 0 {
        return;
    }
    let dt = if n > 1 {
        (t_s[n - 1] - t_s[0]) / (n - 1) as f64
    } else {
        1.0
    };
    let t0 = t_s[0];
    let delay_samples = p.delay_s.max(0.0) / dt;
    let mut y = y_start;
    let mut yd = 0.0;
    let mut last_dir = 0.0;
    let mut prev_u = u[0];
    let zoh = Zoh::new(p.zeta, p.omega_n_rad_s, dt);
    let mut driven: Option<f64> = None;
    for i in 0..n {
        let offset = p.offset_n + p.drift_n_per_s * (t_s[i] - t0);
        out[i] = y + offset;
        // delayed reference, linear interpolation
        let pos = i as f64 - delay_samples;
        let ud = if pos <= 0.0 {
            u[0]
        } else {
            let k = pos.floor() as usize;
            let fr = pos - k as f64;
            if k + 1 < n {
                u[k] * (1.0 - fr) + u[k + 1] * fr
            } else {
                u[n - 1]
            }
        };
        if (ud - prev_u).abs() > 1e-9 {
            last_dir = (ud - prev_u).signum();
        }
        prev_u = ud;
        let g =
            p.gain + p.gain_slope_per_rad[0] * alpha[0][i] + p.gain_slope_per_rad[1] * alpha[1][i];
        let mut target = g * ud + p.hysteresis_n * last_dir;
        if p.force_limit_n.is_finite() {
            let l = p.force_limit_n.abs().max(1e-6);
            target = l * (target / l).tanh();
        }
        // the driving force follows the target no faster than the rate limits
        let d = match driven {
            None => target,
            Some(prev) => target.clamp(
                prev - p.fall_n_per_s.max(1e-9) * dt,
                prev + p.rise_n_per_s.max(1e-9) * dt,
            ),
        };
        driven = Some(d);
        let target = d;
        let (ny, nyd) = zoh.step(y - target, yd);
        y = ny + target;
        yd = nyd;
    }
}

/// Exact discretisation of e'' + 2ζωn e' + ωn² e = 0 over one sample.
struct Zoh {
    phi: [[f64; 2]; 2],
}

impl Zoh {
    fn new(zeta: f64, wn: f64, dt: f64) -> Self {
        let a = [[0.0, 1.0], [-wn * wn, -2.0 * zeta * wn]];
        // scaling and squaring of a Taylor series
        let norm = (a[1][0].abs() + a[1][1].abs()).max(1.0) * dt;
        let mut sq = 0;
        while norm / f64::powi(2.0, sq) > 0.25 {
            sq += 1;
        }
        let h = dt / f64::powi(2.0, sq);
        let ah = [[0.0, h], [a[1][0] * h, a[1][1] * h]];
        let mut phi = [[1.0, 0.0], [0.0, 1.0]];
        let mut term = [[1.0, 0.0], [0.0, 1.0]];
        for k in 1..14 {
            term = mat_mul(&term, &ah);
            for r in 0..2 {
                for c in 0..2 {
                    term[r][c] /= k as f64;
                    phi[r][c] += term[r][c];
                }
            }
        }
        for _ in 0..sq {
            phi = mat_mul(&phi, &phi);
        }
        Zoh { phi }
    }
    #[inline]
    fn step(&self, e: f64, ed: f64) -> (f64, f64) {
        (
            self.phi[0][0] * e + self.phi[0][1] * ed,
            self.phi[1][0] * e + self.phi[1][1] * ed,
        )
    }
}

fn mat_mul(a: &[[f64; 2]; 2], b: &[[f64; 2]; 2]) -> [[f64; 2]; 2] {
    [
        [
            a[0][0] * b[0][0] + a[0][1] * b[1][0],
            a[0][0] * b[0][1] + a[0][1] * b[1][1],
        ],
        [
            a[1][0] * b[0][0] + a[1][1] * b[1][0],
            a[1][0] * b[0][1] + a[1][1] * b[1][1],
        ],
    ]
}

/// Which extra parameters a fit frees (the base G, ζ, ωn are always free).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StepExtra {
    Delay,
    SlewRate,
    Saturation,
    PoseGain,
    Hysteresis,
    Drift,
}

fn pack(p: &StepParams, extras: &[StepExtra]) -> Vec<f64> {
    let mut v = vec![p.gain, p.zeta, p.omega_n_rad_s];
    for e in extras {
        match e {
            StepExtra::Delay => v.push(p.delay_s),
            StepExtra::SlewRate => {
                v.push(p.rise_n_per_s);
                v.push(p.fall_n_per_s)
            }
            StepExtra::Saturation => v.push(p.force_limit_n),
            StepExtra::PoseGain => v.extend_from_slice(&p.gain_slope_per_rad),
            StepExtra::Hysteresis => v.push(p.hysteresis_n),
            StepExtra::Drift => {
                v.push(p.offset_n);
                v.push(p.drift_n_per_s)
            }
        }
    }
    v
}

fn unpack(v: &[f64], extras: &[StepExtra], template: &StepParams) -> StepParams {
    let mut p = *template;
    p.gain = v[0];
    p.zeta = v[1];
    p.omega_n_rad_s = v[2];
    let mut i = 3;
    for e in extras {
        match e {
            StepExtra::Delay => p.delay_s = v[i],
            StepExtra::SlewRate => {
                p.rise_n_per_s = v[i];
                p.fall_n_per_s = v[i + 1];
                i += 1
            }
            StepExtra::Saturation => p.force_limit_n = v[i],
            StepExtra::PoseGain => {
                p.gain_slope_per_rad = [v[i], v[i + 1]];
                i += 1
            }
            StepExtra::Hysteresis => p.hysteresis_n = v[i],
            StepExtra::Drift => {
                p.offset_n = v[i];
                p.drift_n_per_s = v[i + 1];
                i += 1
            }
        }
        i += 1;
    }
    p
}

pub fn extra_param_count(extras: &[StepExtra]) -> usize {
    pack(&StepParams::base(1.0, 0.5, 10.0), extras).len() - 3
}

/// Least-squares fit of one axis on rows [0, fit_end), started from `start`.
pub fn fit_axis(
    p: &Prepared,
    axis: usize,
    start: &StepParams,
    extras: &[StepExtra],
    fit_end: usize,
) -> Option<StepParams> {
    let u = &p.force_ref_n.as_ref()?[axis];
    let y = &p.force_n[axis];
    let n = fit_end.min(p.len());
    // the simulation runs on every sample; the residuals are taken every ≥ 5 ms so a
    // 1 kHz log costs no more to fit than a 200 Hz one
    let stride = ((0.005 / p.dt_s).floor() as usize).max(1);
    let mut first = *start;
    let mut init = pack(&first, extras);
    // start saturation at the measured extremes so it begins inactive
    if extras.contains(&StepExtra::Saturation) {
        let peak = y[..n].iter().fold(0.0f64, |m, v| m.max(v.abs()));
        first.force_limit_n = 2.0 * peak.max(0.5);
        init = pack(&first, extras);
    }
    // start the rate limits at the fastest slope seen, so they begin just active
    if extras.contains(&StepExtra::SlewRate) {
        let w = ((0.01 / p.dt_s).round() as usize).max(1);
        let max_slope = (w..n)
            .map(|i| (y[i] - y[i - w]).abs() / (w as f64 * p.dt_s))
            .fold(1.0, f64::max);
        first.rise_n_per_s = max_slope;
        first.fall_n_per_s = max_slope;
        init = pack(&first, extras);
    }
    let sel: Vec<usize> = (0..n).step_by(stride.max(1)).collect();
    let mut buf = vec![0.0; n];
    let t = &p.t_s[..n];
    let a = [&p.alpha_rad[0][..n], &p.alpha_rad[1][..n]];
    let lower = lower_bounds(extras);
    // rate limits start at the fastest slope seen and at fractions of it (the cost surface
    // is flat where a limit is inactive, so one start can stall there)
    let starts: Vec<Vec<f64>> = if extras.contains(&StepExtra::SlewRate) {
        // and with the base's own dynamics as well as faster ones: a base fitted without
        // the limit has slowed itself down to mimic it
        let mut v = Vec::new();
        for f in [1.0, 0.4, 0.15] {
            for fast in [false, true] {
                let mut q = first;
                q.rise_n_per_s *= f;
                q.fall_n_per_s *= f;
                if fast {
                    q.zeta = 0.5;
                    q.omega_n_rad_s *= 2.0;
                }
                v.push(pack(&q, extras));
            }
        }
        v
    } else {
        vec![init]
    };
    let mut best: Option<(Vec<f64>, f64)> = None;
    for s0 in starts {
        let (theta, cost) = lm::minimize(&s0, &lower, sel.len(), 30, |v, r| {
            let q = unpack(v, extras, &first);
            simulate(&q, t, &u[..n], a, y[0], &mut buf);
            for (j, &i) in sel.iter().enumerate() {
                r[j] = buf[i] - y[i];
            }
        });
        if best.as_ref().is_none_or(|b| cost < b.1) {
            best = Some((theta, cost));
        }
    }
    Some(unpack(&best?.0, extras, &first))
}

fn lower_bounds(extras: &[StepExtra]) -> Vec<(usize, f64)> {
    let mut v = vec![(1, 0.02), (2, 0.1)];
    let mut i = 3;
    for e in extras {
        match e {
            StepExtra::Delay => v.push((i, 0.0)),
            StepExtra::Saturation => v.push((i, 0.1)),
            StepExtra::SlewRate => {
                v.push((i, 0.1));
                v.push((i + 1, 0.1))
            }
            _ => {}
        }
        i += match e {
            StepExtra::PoseGain | StepExtra::Drift | StepExtra::SlewRate => 2,
            _ => 1,
        };
    }
    v
}

/// A starting point for the whole-response fit from the graphical estimates.
pub fn initial_params(steps: &[StepResult], axis: usize) -> StepParams {
    let s: Vec<&StepResult> = steps.iter().filter(|s| s.axis == axis).collect();
    let g = if s.is_empty() {
        1.0
    } else {
        mean(&s.iter().map(|r| r.gain).collect::<Vec<_>>())
    };
    let z: Vec<f64> = s.iter().filter_map(|r| r.zeta).collect();
    let w: Vec<f64> = s.iter().filter_map(|r| r.omega_n_rad_s).collect();
    StepParams::base(
        if g.is_finite() && g.abs() > 1e-3 {
            g
        } else {
            1.0
        },
        if z.is_empty() {
            0.7
        } else {
            mean(&z).clamp(0.05, 1.5)
        },
        if w.is_empty() {
            20.0
        } else {
            mean(&w).clamp(0.5, 500.0)
        },
    )
}
