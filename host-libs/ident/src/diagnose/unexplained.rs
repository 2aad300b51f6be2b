//! Structure left in the residual that no effect accounts for: spectral lines and a slow
//! wander of the level.

use super::*;

/// Structure left in the residual of `fit` that no effect accounts for: narrow spectral
/// lines that are not lines of the motion (or of the reference) itself.
pub fn unexplained_structure(lp: &Loop, fit: &ModelFit, s: &Settings) -> Vec<UnexplainedReport> {
    let p = &lp.p;
    let mut out = Vec::new();
    let names = ["fx", "fy"];
    // spectra of the inputs: a line in the residual at a line of the input is a misfit of
    // the motion, not an outside disturbance
    let inputs: Vec<Vec<f64>> = match lp.experiment {
        Experiment::Dynamic => vec![p.dx_m[0].clone(), p.dx_m[1].clone()],
        Experiment::Step => p
            .force_ref_n
            .clone()
            .map(|r| r.to_vec())
            .unwrap_or_default(),
    };
    let input_spectra: Vec<_> = inputs
        .iter()
        .map(|x| amplitude_spectrum(x, p.dt_s))
        .collect();
    // a line where an input has energy (≥ 2 % of its largest line, ±2 bins) is a misfit of
    // the motion or of the steps, not an outside disturbance
    let input_has_energy = |f: f64| {
        input_spectra.iter().any(|s| {
            let df = s.freq_hz.get(1).copied().unwrap_or(1.0);
            let k = (f / df).round() as usize;
            let max = s.amplitude.iter().skip(1).cloned().fold(0.0, f64::max);
            (k.saturating_sub(2)..(k + 3).min(s.amplitude.len()))
                .any(|i| s.amplitude[i] >= 0.02 * max)
        })
    };
    for a in 0..2 {
        let r = fit.residual(a);
        if rms(&r) == 0.0 {
            continue;
        }
        let spec = amplitude_spectrum(&r, p.dt_s);
        let df = spec.freq_hz.get(1).copied().unwrap_or(1.0);
        for pk in narrow_peaks(&spec, s.peak_prominence, s.peak_min_share)
            .into_iter()
            .take(3)
        {
            if input_has_energy(pk.freq_hz) {
                continue;
            }
            out.push(UnexplainedReport {
                kind: "spectral_peak".into(),
                signal: names[a].into(),
                frequency_hz: Some(pk.freq_hz),
                amplitude_n: Some(pk.amplitude),
                variance_share: pk.variance_share,
                detail: format!(
                    "a narrow line at {:.2} Hz in the {} residual ({:.0} × the local background, {:.0} % of the residual variance); no catalog effect makes a tone{}",
                    pk.freq_hz,
                    names[a],
                    pk.prominence,
                    100.0 * pk.variance_share,
                    if (pk.freq_hz - 0.5 / p.dt_s).abs() <= 2.0 * df {
                        " (at the Nyquist frequency: possibly a faster tone, e.g. mains at 50 Hz, aliased)"
                    } else {
                        ""
                    }
                ),
            });
        }
    }
    // slow structure: the residual's level wandering over the trial (20 time bins), which
    // neither the model nor a linear drift (the catalog's) accounts for
    // (dynamic trials: a step trial's residual has levels by construction)
    let axes = if lp.experiment == Experiment::Dynamic {
        fit.axes.clone()
    } else {
        Vec::new()
    };
    for a in axes {
        let r = fit.residual(a);
        let share = binned_share(&r, 20);
        if share >= s.structure_min_share {
            out.push(UnexplainedReport {
                kind: "slow_wander".into(),
                signal: names[a].into(),
                frequency_hz: None,
                amplitude_n: None,
                variance_share: share,
                detail: format!(
                    "the {} residual's level wanders over the trial: its means over 20 time bins carry {:.0} % of its variance, and no catalog effect removes it",
                    names[a],
                    100.0 * share
                ),
            });
        }
    }
    out
}

/// Share of the variance of `r` carried by its means over `bins` equal time bins.
fn binned_share(r: &[f64], bins: usize) -> f64 {
    let n = r.len();
    if n < 10 * bins {
        return 0.0;
    }
    let m = r.iter().sum::<f64>() / n as f64;
    let total: f64 = r.iter().map(|v| (v - m).powi(2)).sum();
    if total <= 0.0 {
        return 0.0;
    }
    let mut between = 0.0;
    for b in 0..bins {
        let (lo, hi) = (b * n / bins, (b + 1) * n / bins);
        let mb = r[lo..hi].iter().sum::<f64>() / (hi - lo) as f64;
        between += (hi - lo) as f64 * (mb - m).powi(2);
    }
    between / total
}
