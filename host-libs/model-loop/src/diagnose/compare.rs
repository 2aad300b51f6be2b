//! `compare`: where the model fails (worst windows, error by speed, over the workspace).

use super::recording::sampling_warning;
use super::unexplained::UnexplainedReport;
use super::AxisPair;
use super::Loop;
use super::ModelFit;
use super::Settings;
use super::Warning;
use crate::effects::Experiment;
use pam_ident::msd;
use pam_numerics::stats::rms;
use pam_numerics::stats::std_dev;
use serde::Serialize;
use std::collections::BTreeMap;

/// Convenience for reports: NRMSE per axis of a fit as an AxisPair.
pub fn nrmse_pair(f: &ModelFit) -> AxisPair {
    AxisPair::of(f.nrmse)
}

/// For `compare`: where the model fails.
#[derive(Clone, Debug, Serialize)]
pub struct Comparison {
    pub experiment: String,
    pub effects: Vec<String>,
    pub nrmse: AxisPair,
    pub r2: AxisPair,
    pub params: BTreeMap<String, BTreeMap<String, f64>>,
    /// Worst 1-s windows of the held-out part by residual RMS.
    pub worst_windows: Vec<Window>,
    /// MSE at low and high motion frequency (Table 4.2's split), dynamic trials.
    pub frequency_split: Option<msd::FrequencySplit>,
    /// Largest lines of the residual spectrum.
    pub residual_peaks: Vec<UnexplainedReport>,
    /// Residual RMS per speed quartile (dynamic) / per |reference| quartile (step).
    pub error_by_speed: Vec<Bin>,
    /// Residual RMS per workspace cell (3×3 over the handle positions visited).
    pub error_by_position: Vec<Bin>,
    pub warnings: Vec<Warning>,
}

#[derive(Clone, Debug, Serialize)]
pub struct Window {
    pub t_start_s: f64,
    pub t_end_s: f64,
    pub rms_n: AxisPair,
}

#[derive(Clone, Debug, Serialize)]
pub struct Bin {
    pub label: String,
    pub samples: usize,
    pub rms_n: AxisPair,
}

pub fn compare(lp: &Loop, fit: &ModelFit) -> Comparison {
    let p = &lp.p;
    let n = p.len();
    let r = [fit.residual(0), fit.residual(1)];
    let w = ((1.0 / p.dt_s).round() as usize).max(5);
    let mut windows = Vec::new();
    for range in p.held_out.ranges() {
        let mut s = range.start;
        while s + w <= range.end {
            windows.push(Window {
                t_start_s: p.t_s[s],
                t_end_s: p.t_s[s + w - 1],
                rms_n: AxisPair::of([rms(&r[0][s..s + w]), rms(&r[1][s..s + w])]),
            });
            s += w;
        }
    }
    windows.sort_by(|a, b| (b.rms_n.fx.hypot(b.rms_n.fy)).total_cmp(&a.rms_n.fx.hypot(a.rms_n.fy)));
    windows.truncate(5);
    let speed: Vec<f64> = match lp.experiment {
        Experiment::Dynamic => (0..n).map(|i| p.v_m_s[0][i].hypot(p.v_m_s[1][i])).collect(),
        Experiment::Step => {
            let u = p.force_ref_n.as_ref().expect("step");
            (0..n).map(|i| u[0][i].hypot(u[1][i])).collect()
        }
    };
    let mut sorted = speed.clone();
    sorted.sort_by(|a, b| a.total_cmp(b));
    let q = |f: f64| sorted[((n - 1) as f64 * f) as usize];
    let edges = [q(0.0) - 1e-12, q(0.25), q(0.5), q(0.75), q(1.0) + 1e-12];
    let unit = if lp.experiment == Experiment::Dynamic {
        "m/s"
    } else {
        "N"
    };
    let mut by_speed = Vec::new();
    for k in 0..4 {
        let idx: Vec<usize> = (0..n)
            .filter(|&i| speed[i] > edges[k] && speed[i] <= edges[k + 1])
            .collect();
        by_speed.push(bin(
            &format!("{:.3}–{:.3} {unit}", edges[k].max(0.0), edges[k + 1]),
            &idx,
            &r,
        ));
    }
    let mut by_pos = Vec::new();
    let ext = |v: &[f64]| {
        v.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |m, x| {
            (m.0.min(*x), m.1.max(*x))
        })
    };
    let (ex, ey) = (ext(&p.x_m[0]), ext(&p.x_m[1]));
    let cell = |v: f64, e: (f64, f64)| {
        (((v - e.0) / (e.1 - e.0 + 1e-12)) * 3.0)
            .floor()
            .clamp(0.0, 2.0) as usize
    };
    for cy in 0..3 {
        for cx in 0..3 {
            let idx: Vec<usize> = (0..n)
                .filter(|&i| cell(p.x_m[0][i], ex) == cx && cell(p.x_m[1][i], ey) == cy)
                .collect();
            if !idx.is_empty() {
                by_pos.push(bin(
                    &format!("x cell {}, y cell {} (of 3×3)", cx + 1, cy + 1),
                    &idx,
                    &r,
                ));
            }
        }
    }
    let loose = Settings {
        peak_prominence: 20.0,
        peak_min_share: 0.01,
        ..lp.settings
    };
    let structure = super::unexplained::structure(lp, fit, &loose);
    let split = (lp.experiment == Experiment::Dynamic)
        .then(|| msd::frequency_split(p, &fit.measured, &fit.predicted));
    let mut warnings = fit.warnings.clone();
    warnings.extend(sampling_warning(lp));
    warnings.extend(structure.set_aside);
    let still = |a: usize| {
        lp.experiment == Experiment::Step
            && p.force_ref_n.as_ref().is_some_and(|r| {
                let held: Vec<f64> = p.held_out.rows().map(|i| r[a][i]).collect();
                std_dev(&held) < 1e-3
            })
    };
    for &a in fit.axes.iter() {
        if still(a) {
            warnings.push(Warning::ReferenceStill { axis: a });
        } else if fit.r2[a] < 0.5 {
            warnings.push(Warning::LowR2 {
                axis: a,
                r2: fit.r2[a],
            });
        }
    }
    Comparison {
        experiment: lp.experiment.name().into(),
        effects: fit.effect_ids.clone(),
        nrmse: AxisPair::of(fit.nrmse),
        r2: AxisPair::of(fit.r2),
        params: fit.params.clone(),
        worst_windows: windows,
        frequency_split: split,
        residual_peaks: structure.found,
        error_by_speed: by_speed,
        error_by_position: by_pos,
        warnings,
    }
}

fn bin(label: &str, idx: &[usize], r: &[Vec<f64>; 2]) -> Bin {
    let sel = |a: usize| idx.iter().map(|&i| r[a][i]).collect::<Vec<f64>>();
    Bin {
        label: label.into(),
        samples: idx.len(),
        rms_n: AxisPair::of([rms(&sel(0)), rms(&sel(1))]),
    }
}

impl AxisPair {
    pub fn axis(&self, a: usize) -> f64 {
        self.get(a)
    }
}
