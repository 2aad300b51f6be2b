//! Force-step analysis (§5.3): step detection, gain, overshoot → ζ, peak time → ωn per
//! step and per pose, a least-squares fit of the second-order model
//! H(s) = G ωn² / (s² + 2ζωn s + ωn²) to the whole response, and the gain plane (eq. 5.2).
//!
//! The response simulator takes optional extra terms so that the model-side effects of
//! the catalog (delay, asymmetric rates, saturation, pose-dependent gain, drift, hysteresis)
//! are parametrised transforms of this one model.

use crate::step_detection::detect_steps;
use crate::trial::Prepared;
use pam_numerics::lm::{self, LmSummary};
use pam_numerics::second_order::SecondOrderStep;
use pam_numerics::stats::mean;
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
pub fn fit_gain_plane(poses: &[PoseAverage]) -> Result<[[f64; 3]; 2], crate::IdentError> {
    let mut out = [[0.0; 3]; 2];
    for axis in 0..2 {
        let pts: Vec<&PoseAverage> = poses.iter().filter(|p| p.axis == axis).collect();
        if pts.len() < 3 {
            return Err(crate::IdentError::TooFewPoses {
                axis: ["X", "Y"][axis],
                poses: pts.len(),
            });
        }
        let n = pts.len();
        let cols = vec![
            pam_numerics::lsq::Column::on("p1", 0, pts.iter().map(|p| p.alpha_rad[0]).collect()),
            pam_numerics::lsq::Column::on("p2", 0, pts.iter().map(|p| p.alpha_rad[1]).collect()),
            pam_numerics::lsq::Column::on("p3", 0, vec![1.0; n]),
        ];
        let y: Vec<f64> = pts.iter().map(|p| p.gain).collect();
        let zero = vec![0.0; n];
        let ne = pam_numerics::lsq::normal_equations(&cols, &[&y, &zero], 0..n);
        let th = pam_numerics::lsq::solve(&ne, &[]);
        out[axis] = [th[0], th[1], th[2]];
    }
    Ok(out)
}

/// The second-order response of one axis from reference to force (§5.3, Table 5.2).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct StepParams {
    pub gain: f64,
    pub zeta: f64,
    pub omega_n_rad_s: f64,
}

impl StepParams {
    pub fn base(gain: f64, zeta: f64, omega_n_rad_s: f64) -> Self {
        StepParams {
            gain,
            zeta,
            omega_n_rad_s,
        }
    }
}

/// Simulates y'' + 2ζωn y' + ωn² y = ωn² G u(t), integrated with the exact zero-order-hold
/// solution per sample, from `y_start` at rest. (The model loop's step model, with the
/// catalog's effects, is [`crate::response`].)
pub fn simulate(p: &StepParams, t_s: &[f64], u: &[f64], y_start: f64, out: &mut [f64]) {
    let n = t_s.len();
    if n == 0 {
        return;
    }
    let dt = if n > 1 {
        (t_s[n - 1] - t_s[0]) / (n - 1) as f64
    } else {
        1.0
    };
    let mut y = y_start;
    let mut yd = 0.0;
    let zoh = SecondOrderStep::new(p.omega_n_rad_s, p.zeta, dt);
    for i in 0..n {
        out[i] = y;
        let target = p.gain * u[i];
        let (ny, nyd) = zoh.step(y - target, yd);
        y = ny + target;
        yd = nyd;
    }
}

/// A whole-response fit of one axis and how its Levenberg–Marquardt ended.
#[derive(Clone, Debug, PartialEq)]
pub struct AxisFit {
    pub params: StepParams,
    pub lm: LmSummary,
}

impl AxisFit {
    /// True when the fit ended at a minimum; otherwise [`AxisFit::params`] are the last
    /// iterate of a fit that ran out of iterations.
    pub fn reached_a_minimum(&self) -> bool {
        self.lm.reached_a_minimum()
    }
}

/// Least-squares fit of one axis (G, ζ, ωn) on rows [0, fit_end), from `start`. `None`
/// without a force reference; an error when the fit's parameters are not finite.
pub fn fit_axis(
    p: &Prepared,
    axis: usize,
    start: &StepParams,
    fit_end: usize,
) -> Result<Option<AxisFit>, crate::IdentError> {
    let Some(reference) = p.force_ref_n.as_ref() else {
        return Ok(None);
    };
    let u = &reference[axis];
    let y = &p.force_n[axis];
    let n = fit_end.min(p.len());
    // the simulation runs on every sample; the residuals are taken every ≥ 5 ms so a
    // 1 kHz log costs no more to fit than a 200 Hz one
    let stride = ((0.005 / p.dt_s).floor() as usize).max(1);
    let sel: Vec<usize> = (0..n).step_by(stride).collect();
    let t = &p.t_s[..n];
    let init = [start.gain, start.zeta, start.omega_n_rad_s];
    let report = lm::minimize(&init, &[(1, 0.02), (2, 0.1)], sel.len(), 30, |v, r| {
        let mut buf = vec![0.0; n];
        simulate(
            &StepParams::base(v[0], v[1], v[2]),
            t,
            &u[..n],
            y[0],
            &mut buf,
        );
        for (j, &i) in sel.iter().enumerate() {
            r[j] = buf[i] - y[i];
        }
    });
    if !report.is_finite() {
        return Err(crate::IdentError::FitNotFinite {
            fit: "step-response",
            termination: report.termination,
        });
    }
    let theta = &report.theta;
    Ok(Some(AxisFit {
        params: StepParams::base(theta[0], theta[1], theta[2]),
        lm: report.summary(),
    }))
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
