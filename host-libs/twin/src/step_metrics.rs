//! Force-step figures measured from a log (the step table): per reference step, the 5 %
//! settling time, the overshoot and the step gain, on the axis that stepped.
//!
//! - A step is a change of `fx_ref_n` or `fy_ref_n` between two rows; it lasts until the
//!   next change (or the end of the log).
//! - The force is smoothed by a centred 21-sample moving average (21 ms at 1 kHz, within
//!   the step so that neighbouring steps do not leak in; its last 10 samples, averaged over
//!   a shortened window, are left out) before the
//!   settling and overshoot are read, so the load cell's noise (0.15 N, 3σ ≈ the 5 % band
//!   of a 9.1 N step) does not decide the settling time.
//! - Steady value: the mean of the raw force over the last 20 % of the hold.
//! - Step gain: Δsteady / Δreference. Overshoot: the largest excursion beyond the new
//!   steady value, in the step's direction, over the measured step |Δsteady|, %.
//! - 5 % settling: from the step to the last sample outside ±5 % of |Δreference| around the
//!   new steady value.
//! - Out of reach: a step to or from a level the controller said it could not reach (the
//!   log's `limited` column has the closed loop's [`Limited::TARGET`] bit on most of that
//!   level's last 20 %: it scaled the target down to what the muscles can give). Such a step's delivered change may be near zero, so its
//!   overshoot is kept apart, in newtons, not as a percentage of that change.
//! - Cross error: |steady − reference| on the axis that did not step, at the new level: a
//!   step that cannot be delivered in full may still be met on its axis by pushing the
//!   other way too (the step gain alone does not see it).

use pam_log::{col, Log, LogError};
use pam_model::Limited;

/// One step's figures.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepFigures {
    /// 0 = X, 1 = Y.
    pub axis: usize,
    pub from_n: f64,
    pub to_n: f64,
    pub settling_s: f64,
    pub overshoot_pct: f64,
    pub gain: f64,
    /// |steady − reference| on the other axis at the new level, N.
    pub cross_error_n: f64,
    /// The largest excursion beyond the new steady value, in the step's direction, N.
    pub overshoot_n: f64,
    /// The controller scaled this step's target to the capability (see the module's notes).
    pub out_of_reach: bool,
}

/// Summary over many steps.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Summary {
    pub steps: usize,
    pub settling_worst_s: f64,
    pub settling_mean_s: f64,
    /// Over the steps within reach (all of them when the log does not say).
    pub overshoot_worst_pct: f64,
    pub gain_error_mean: f64,
    pub gain_min: f64,
    pub gain_max: f64,
    pub cross_error_worst_n: f64,
    /// Steps the controller declared out of reach, and their worst overshoot, N.
    pub out_of_reach_steps: usize,
    pub out_of_reach_overshoot_worst_n: f64,
}

const SMOOTH_HALF: usize = 10;

fn smoothed(x: &[f64]) -> Vec<f64> {
    let n = x.len();
    let mut prefix = vec![0.0; n + 1];
    for i in 0..n {
        prefix[i + 1] = prefix[i] + x[i];
    }
    (0..n)
        .map(|i| {
            let lo = i.saturating_sub(SMOOTH_HALF);
            let hi = (i + SMOOTH_HALF + 1).min(n);
            (prefix[hi] - prefix[lo]) / (hi - lo) as f64
        })
        .collect()
}

/// The figures of every step in a force-step log.
pub fn force_steps(log: &Log) -> Result<Vec<StepFigures>, LogError> {
    let t = log.require(col::T_S)?;
    let refs = [log.require(col::FX_REF_N)?, log.require(col::FY_REF_N)?];
    let force = [log.require(col::FX_N)?, log.require(col::FY_N)?];
    let limited = log.column(col::LIMITED);
    let n = t.len();
    // boundaries: row indices where either reference changes
    let mut starts = vec![0usize];
    for i in 1..n {
        if refs[0][i] != refs[0][i - 1] || refs[1][i] != refs[1][i - 1] {
            starts.push(i);
        }
    }
    starts.push(n);
    // a level's last 20 %: its steady value, and whether the controller scaled its target
    let tail = |a: usize, b: usize| (b - ((b - a) / 5).max(1))..b;
    let steady = |axis: usize, a: usize, b: usize| {
        let r = tail(a, b);
        force[axis][r.clone()].iter().sum::<f64>() / r.len() as f64
    };
    let mut out = Vec::new();
    for w in 1..starts.len() - 1 {
        let (prev, a, b) = (starts[w - 1], starts[w], starts[w + 1]);
        let axis = if refs[0][a] != refs[0][a - 1] { 0 } else { 1 };
        let (r0, r1) = (refs[axis][a - 1], refs[axis][a]);
        let (y0, y1) = (steady(axis, prev, a), steady(axis, a, b));
        let d_ref = r1 - r0;
        let d_y = y1 - y0;
        let dir = d_ref.signum();
        // smoothed within the step only: the next step's response must not leak in
        let full = smoothed(&force[axis][a..b]);
        // the last half-window is averaged over fewer samples (noisier): left out
        let s = &full[..full.len().saturating_sub(SMOOTH_HALF).max(1)];
        let peak = s.iter().map(|v| (v - y1) * dir).fold(0.0, f64::max);
        let band = 0.05 * d_ref.abs();
        // from a level or to a level the controller could not reach
        let out_of_reach = limited.is_some_and(|l| {
            let scaled = |a: usize, b: usize| {
                let r = tail(a, b);
                let bit = Limited::TARGET.0 as u32;
                let n = l[r.clone()]
                    .iter()
                    .filter(|v| (**v as u32) & bit != 0)
                    .count();
                2 * n > r.len()
            };
            scaled(prev, a) || scaled(a, b)
        });
        let last_out = s.iter().rposition(|v| (v - y1).abs() > band);
        let settling_s = match last_out {
            Some(k) if k + 1 < s.len() => t[a + k + 1] - t[a],
            Some(_) => f64::INFINITY,
            None => 0.0,
        };
        out.push(StepFigures {
            axis,
            from_n: r0,
            to_n: r1,
            settling_s,
            overshoot_pct: if d_y.abs() > 1e-9 {
                100.0 * peak / d_y.abs()
            } else {
                f64::INFINITY
            },
            gain: d_y / d_ref,
            cross_error_n: (steady(1 - axis, a, b) - refs[1 - axis][a]).abs(),
            overshoot_n: peak,
            out_of_reach,
        });
    }
    Ok(out)
}

/// Worst and mean over the steps.
pub fn summarize(steps: &[StepFigures]) -> Summary {
    if steps.is_empty() {
        return Summary::default();
    }
    let n = steps.len() as f64;
    Summary {
        steps: steps.len(),
        settling_worst_s: steps.iter().map(|s| s.settling_s).fold(0.0, f64::max),
        settling_mean_s: steps.iter().map(|s| s.settling_s).sum::<f64>() / n,
        overshoot_worst_pct: steps
            .iter()
            .filter(|s| !s.out_of_reach)
            .map(|s| s.overshoot_pct)
            .fold(0.0, f64::max),
        gain_error_mean: steps.iter().map(|s| (s.gain - 1.0).abs()).sum::<f64>() / n,
        gain_min: steps.iter().map(|s| s.gain).fold(f64::INFINITY, f64::min),
        gain_max: steps
            .iter()
            .map(|s| s.gain)
            .fold(f64::NEG_INFINITY, f64::max),
        cross_error_worst_n: steps.iter().map(|s| s.cross_error_n).fold(0.0, f64::max),
        out_of_reach_steps: steps.iter().filter(|s| s.out_of_reach).count(),
        out_of_reach_overshoot_worst_n: steps
            .iter()
            .filter(|s| s.out_of_reach)
            .map(|s| s.overshoot_n)
            .fold(0.0, f64::max),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A synthetic log: a first-order response (τ = 50 ms) of gain `g` to two steps.
    fn synthetic(g: f64, tau: f64) -> Log {
        let mut log = Log::new(&[col::T_S, col::FX_N, col::FY_N, col::FX_REF_N, col::FY_REF_N]);
        let mut y = 0.0;
        let dt = 0.001;
        for i in 0..3000 {
            let r = if i < 1000 {
                0.0
            } else if i < 2000 {
                10.0
            } else {
                -10.0
            };
            y += (g * r - y) * dt / tau;
            log.push_row(&[i as f64 * dt, y, 0.0, r, 0.0]);
        }
        log
    }

    #[test]
    fn first_order_figures_are_recovered() {
        let steps = force_steps(&synthetic(0.8, 0.05)).unwrap();
        assert_eq!(steps.len(), 2);
        for s in &steps {
            assert_eq!(s.axis, 0);
            assert!((s.gain - 0.8).abs() < 0.01, "{s:?}");
            assert!(s.overshoot_pct < 0.5, "{s:?}");
        }
        // 10 N step, gain 0.8: within 0.5 N of 8 N once 8·e^{−t/τ} < 0.5 → t = τ·ln 16
        let expect = 0.05 * (16.0f64).ln();
        assert!(
            (steps[0].settling_s - expect).abs() < 0.015,
            "{:?}",
            steps[0]
        );
        let sum = summarize(&steps);
        assert!((sum.gain_error_mean - 0.2).abs() < 0.01);
        assert!(sum.cross_error_worst_n < 1e-12, "{sum:?}");
        // a response that also pushes the other axis by 0.3 of the step's force
        let mut skew = Log::new(&[col::T_S, col::FX_N, col::FY_N, col::FX_REF_N, col::FY_REF_N]);
        let base = synthetic(1.0, 0.05);
        let (fx, rx) = (
            base.require(col::FX_N).unwrap(),
            base.require(col::FX_REF_N).unwrap(),
        );
        for i in 0..fx.len() {
            skew.push_row(&[i as f64 * 0.001, fx[i], 0.3 * fx[i], rx[i], 0.0]);
        }
        let steps = force_steps(&skew).unwrap();
        assert!(
            (steps[0].cross_error_n - 3.0).abs() < 0.01,
            "{:?}",
            steps[0]
        );
        assert!((steps[0].gain - 1.0).abs() < 0.01, "{:?}", steps[0]);
    }
}
