//! How large an effect's change to the prediction is, and how many independent samples a
//! residual is worth: the two quantities every acceptance test of the decision divides by.

use super::Loop;
use super::ModelFit;
use pam_numerics::stats::rms;
use pam_numerics::stats::std_dev;

/// RMS of the change an effect makes to the held-out prediction, over the measured signal's
/// standard deviation on the whole trial; the largest over the scored axes.
pub(super) fn effect_size(base: &ModelFit, f: &ModelFit) -> f64 {
    f.axes
        .iter()
        .map(|&a| change_rms_n(base, f, a) / std_dev(&f.measured[a]).max(1e-12))
        .fold(0.0, f64::max)
}

/// RMS of the change an effect makes to axis `a`'s held-out prediction, N.
pub(super) fn change_rms_n(base: &ModelFit, f: &ModelFit, a: usize) -> f64 {
    let d: Vec<f64> = f
        .held_out
        .rows()
        .map(|i| f.predicted[a][i] - base.predicted[a][i])
        .collect();
    rms(&d)
}

/// n (1 − ρ)/(1 + ρ) over per-axis residuals.
pub(crate) fn effective_samples_of(res: &[Vec<f64>]) -> f64 {
    let mut rho = Vec::new();
    let mut n = 0usize;
    for r in res {
        n += r.len();
        let m = r.iter().sum::<f64>() / r.len().max(1) as f64;
        let var: f64 = r.iter().map(|v| (v - m).powi(2)).sum();
        if var > 0.0 {
            rho.push(
                (r.windows(2).map(|w| (w[0] - m) * (w[1] - m)).sum::<f64>() / var)
                    .clamp(-0.99, 0.999),
            );
        }
    }
    let rho = if rho.is_empty() {
        0.0
    } else {
        rho.iter().sum::<f64>() / rho.len() as f64
    };
    let n = n as f64;
    (n * (1.0 - rho) / (1.0 + rho)).clamp(10.0, n.max(10.0))
}

/// Number of independent samples the training residual is worth: n (1 − ρ)/(1 + ρ) with ρ
/// the lag-one autocorrelation, averaged over the axes.
pub(super) fn effective_samples(lp: &Loop, base: &ModelFit) -> f64 {
    let train: Vec<Vec<f64>> = base
        .axes
        .iter()
        .map(|&a| {
            let r = base.residual(a);
            lp.p.held_out.train_rows().map(|i| r[i]).collect()
        })
        .collect();
    effective_samples_of(&train)
}
