//! Structure left in the residual that no effect accounts for: spectral lines and a slow
//! wander of the level.

use super::resolution::encoder_floor;
use super::Loop;
use super::ModelFit;
use super::Settings;
use crate::effects::Experiment;
use pam_numerics::spectrum::amplitude_spectrum;
use pam_numerics::spectrum::narrow_peaks;
use pam_numerics::spectrum::on_even_times;
use pam_numerics::stats::rms;
use pam_numerics::stats::std_dev;
use pam_numerics::stats::{wander_test, WANDER_BINS, WANDER_LEVEL, WANDER_MIN_SHARE};
use serde::Serialize;
use statrs::distribution::{ContinuousCDF, FisherSnedecor};

/// Structure in the residual that no catalog effect explains (a tone, a slow wander).
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct UnexplainedReport {
    pub kind: String,
    pub signal: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub frequency_hz: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub amplitude_n: Option<f64>,
    pub variance_share: f64,
    pub detail: String,
}

/// Structure left in the residual of `fit` that no effect accounts for: narrow spectral
/// lines that are not lines of the motion (or of the reference) itself.
pub fn unexplained_structure(lp: &Loop, fit: &ModelFit, s: &Settings) -> Vec<UnexplainedReport> {
    structure(lp, fit, s).found
}

/// What [`structure`] found, and what it set aside as the encoders' resolution.
pub(super) struct Structure {
    pub found: Vec<UnexplainedReport>,
    /// A wander within the encoders' rounding: a warning for the user.
    pub set_aside: Vec<String>,
}

/// [`unexplained_structure`] with what it set aside.
pub(super) fn structure(lp: &Loop, fit: &ModelFit, s: &Settings) -> Structure {
    let p = &lp.p;
    let mut set_aside = Vec::new();
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
        .map(|x| amplitude_spectrum(&on_even_times(&p.t_s, x, p.dt_s), p.dt_s))
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
        let spec = amplitude_spectrum(&on_even_times(&p.t_s, &r, p.dt_s), p.dt_s);
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
    // drawn only for a wander that would be named (it costs a few hundred passes)
    let floor = std::cell::OnceCell::new();
    for a in axes {
        let r = fit.residual(a);
        let Some(w) = wander_test(&r) else {
            continue;
        };
        // significant against the residual's own short-range correlation, and material:
        // the wander's amplitude is a share of the measured force's spread, like an effect
        let signal_sd = std_dev(&p.force_n[a]);
        let material =
            w.amplitude_n >= s.min_effect_size * signal_sd && w.share >= WANDER_MIN_SHARE;
        if !((w.p_value <= WANDER_LEVEL && material) || w.share >= s.structure_min_share) {
            continue;
        }
        // the load cell's own noise is coloured (1/f below a corner of a few Hz): its bin
        // means vary more than a short-range correlation allows, and that is no structure
        let c = coloured_null(&r, &p.t_s, p.dt_s);
        if let Some(c) = c.filter(|c| c.p_value > WANDER_LEVEL) {
            set_aside.push(format!(
                "the {} residual's level wanders by {:.3} N RMS, but no more than its own coloured noise allows: below {:.2} Hz it holds {:.1} × the power that the noise's spectrum above (falling as f^−{:.2}, a load cell's 1/f noise at most) extends to (p = {:.1e}), so none is named",
                names[a],
                w.amplitude_n,
                c.low_hz,
                c.ratio,
                c.exponent,
                c.p_value
            ));
            continue;
        }
        // a level that moves by less than the encoders' rounding does (frozen while the
        // handle rests) cannot be told from it: said, not named
        let floor = floor.get_or_init(|| encoder_floor(lp, fit));
        if let Some(f) = floor.filter(|f| w.amplitude_n <= f.bound_n[a]) {
            set_aside.push(format!(
                "the {} residual's level wanders by {:.3} N RMS, within what the encoders' counts ({:.4}° and {:.4}°) put in its level through the model (expected {:.3} N RMS, up to {:.3} N in {} draws of it: the rounding is frozen while a count is held): the log cannot tell a slow effect of that size from the encoders' rounding, so none is named",
                names[a],
                w.amplitude_n,
                f.step_rad[0].to_degrees(),
                f.step_rad[1].to_degrees(),
                f.expected_n[a],
                f.bound_n[a],
                super::resolution::DRAWS
            ));
            continue;
        }
        out.push(UnexplainedReport {
            kind: "slow_wander".into(),
            signal: names[a].into(),
            frequency_hz: None,
            amplitude_n: Some(w.amplitude_n),
            variance_share: w.share,
            detail: format!(
                "the {} residual's level wanders over the trial: its means over {} time bins vary {:.1} × as much as its own short-range correlation allows (p = {:.1e}), an amplitude of {:.2} N RMS ({:.0} % of its variance), and no catalog effect removes it",
                names[a],
                WANDER_BINS,
                w.variance_ratio,
                w.p_value,
                w.amplitude_n,
                100.0 * w.share
            ),
        });
    }
    Structure {
        found: out,
        set_aside,
    }
}

/// The residual's slow band against its own coloured noise: the spectrum's power per bin
/// over the octaves above the band the wander test's bin means resolve, fitted as a power
/// law f^−β with β clamped to [0, 1] (from white to a load cell's 1/f noise: a spectrum
/// steeper than 1/f below its measured band is a random walk, a wander, not a sensor's
/// stationary noise), extended into the slow band and compared with what is there.
pub(super) struct ColouredNull {
    /// Power in the slow band over the extended noise's.
    pub ratio: f64,
    /// Probability of a ratio this large from the noise alone, F(2 · slow bins, 2 ·
    /// reference bins).
    pub p_value: f64,
    /// β of the noise's spectrum.
    pub exponent: f64,
    /// The slow band's upper edge, Hz.
    pub low_hz: f64,
}

/// Octaves of the spectrum above the slow band that the noise's law is fitted on.
const REFERENCE_OCTAVES: usize = 5;

pub(super) fn coloured_null(r: &[f64], t_s: &[f64], dt_s: f64) -> Option<ColouredNull> {
    // a 1/f noise's power below 1/T shows in a finite record as a trend, whose leakage
    // falls as f^−2 over the slow band: the straight line is taken out first (a line is
    // the catalog's drift, judged as an effect, not a wander)
    let n = r.len().max(1) as f64;
    let mx = (n - 1.0) / 2.0;
    let my = r.iter().sum::<f64>() / n;
    let sxx: f64 = (0..r.len()).map(|i| (i as f64 - mx).powi(2)).sum();
    let slope = (0..r.len())
        .map(|i| (i as f64 - mx) * (r[i] - my))
        .sum::<f64>()
        / sxx.max(1e-300);
    let detrended: Vec<f64> = (0..r.len())
        .map(|i| r[i] - my - slope * (i as f64 - mx))
        .collect();
    let spec = amplitude_spectrum(&on_even_times(t_s, &detrended, dt_s), dt_s);
    let power: Vec<f64> = spec.amplitude.iter().map(|a| a * a).collect();
    // the bin means resolve the spectrum's first WANDER_BINS / 2 bins
    let low = WANDER_BINS / 2;
    let mut octaves = Vec::new();
    for j in 0..REFERENCE_OCTAVES {
        let (a, b) = (low << j, low << (j + 1));
        if b > power.len() {
            break;
        }
        let mean = power[a..b].iter().sum::<f64>() / (b - a) as f64;
        if mean <= 0.0 {
            return None;
        }
        // the octave's centre in bins (geometric), and its mean power per bin
        octaves.push((((a * b) as f64).sqrt().log2(), mean.log2()));
    }
    if octaves.len() < 3 {
        return None;
    }
    let m = octaves.len() as f64;
    let (mx, my) = (
        octaves.iter().map(|o| o.0).sum::<f64>() / m,
        octaves.iter().map(|o| o.1).sum::<f64>() / m,
    );
    let sxx: f64 = octaves.iter().map(|o| (o.0 - mx).powi(2)).sum();
    let sxy: f64 = octaves.iter().map(|o| (o.0 - mx) * (o.1 - my)).sum();
    let exponent = (-sxy / sxx).clamp(0.0, 1.0);
    // anchored at the nearest octave's measured power
    let (x0, y0) = octaves[0];
    let predicted: f64 = (1..=low)
        .map(|k| 2f64.powf(y0 - exponent * ((k as f64).log2() - x0)))
        .sum();
    let actual: f64 = power[1..=low].iter().sum();
    if predicted <= 0.0 {
        return None;
    }
    let ratio = actual / predicted;
    let p_value = FisherSnedecor::new(2.0 * low as f64, 2.0 * low as f64)
        .map(|f| 1.0 - f.cdf(ratio))
        .unwrap_or(1.0);
    Some(ColouredNull {
        ratio,
        p_value,
        exponent,
        low_hz: spec.freq_hz.get(low).copied().unwrap_or(0.0),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use pam_twin::rng::Rng;

    /// White plus AR(1) noise at 5 ms: `coloured` of it with a time constant `tau_s`.
    fn noise(rng: &mut Rng, n: usize, tau_s: f64, coloured: f64) -> Vec<f64> {
        let rho = (-0.005 / tau_s).exp();
        let mut ar = 0.0;
        (0..n)
            .map(|_| {
                ar = rho * ar + (1.0 - rho * rho).sqrt() * rng.normal();
                rng.normal() + coloured * ar
            })
            .collect()
    }

    #[test]
    fn correlated_noise_is_not_a_wander() {
        // 60 s at 5 ms; the load cell's coloured part at its slowest (0.2 s) and strong
        let mut false_alarms = 0;
        for seed in 0..40 {
            let r = noise(&mut Rng::new(seed), 12_000, 0.2, 1.0);
            let w = wander_test(&r).expect("long enough");
            if w.p_value <= WANDER_LEVEL {
                false_alarms += 1;
            }
            assert!(w.variance_ratio < 3.0, "seed {seed}: {w:?}");
        }
        assert_eq!(false_alarms, 0);
    }

    #[test]
    fn a_slow_wander_is_found_with_its_amplitude() {
        // two slow sines (periods of 30 and 15 s over a 60 s trial), RMS 0.4 of the white
        // noise; the bins (3 s) average a fifth of the faster one's period away, so the
        // amplitude comes out a few per cent low
        let mut rng = Rng::new(7);
        let n = 12_000;
        let wander: Vec<f64> = (0..n)
            .map(|i| {
                let t = i as f64 * 0.005;
                0.4 * ((t * std::f64::consts::TAU / 30.0).sin()
                    + (t * std::f64::consts::TAU / 15.0 + 1.0).sin())
                    / 2f64.sqrt()
            })
            .collect();
        let rms_wander = rms(&wander);
        let r: Vec<f64> = noise(&mut rng, n, 0.1, 0.5)
            .into_iter()
            .zip(&wander)
            .map(|(e, w)| e + w)
            .collect();
        let w = wander_test(&r).expect("long enough");
        assert!(w.p_value < WANDER_LEVEL / 10.0, "{w:?}");
        assert!(w.share > WANDER_MIN_SHARE, "{w:?}");
        assert!(
            (w.amplitude_n / rms_wander - 1.0).abs() < 0.1,
            "{w:?} against {rms_wander}"
        );
    }

    /// White noise plus a 1/f part from 0.01 Hz to `corner_hz` (octave-spaced AR(1)s of
    /// equal variance) at 5 ms, `pink` times the white's standard deviation.
    fn pink_noise(rng: &mut Rng, n: usize, corner_hz: f64, pink: f64) -> Vec<f64> {
        let mut poles = Vec::new();
        let mut f = 0.01;
        while f <= corner_hz {
            poles.push((-std::f64::consts::TAU * f * 0.005).exp());
            f *= 2.0;
        }
        let scale = pink / (poles.len() as f64).sqrt();
        let mut state: Vec<f64> = poles.iter().map(|_| rng.normal()).collect();
        (0..n)
            .map(|_| {
                for (s, a) in state.iter_mut().zip(&poles) {
                    *s = a * *s + (1.0 - a * a).sqrt() * rng.normal();
                }
                rng.normal() + scale * state.iter().sum::<f64>()
            })
            .collect()
    }

    #[test]
    fn a_load_cells_flicker_noise_is_not_a_wander_but_a_wander_on_it_is() {
        let n = 18_000; // 90 s at 5 ms
        let t: Vec<f64> = (0..n).map(|i| i as f64 * 0.005).collect();
        let mut flagged_by_white_null = 0;
        for seed in 0..20 {
            let r = pink_noise(&mut Rng::new(100 + seed), n, 1.0 + 0.25 * seed as f64, 1.5);
            let w = wander_test(&r).expect("long enough");
            flagged_by_white_null += usize::from(w.p_value <= WANDER_LEVEL);
            let c = coloured_null(&r, &t, 0.005).expect("long enough");
            assert!(
                c.p_value > WANDER_LEVEL,
                "seed {seed}: ratio {} β {}",
                c.ratio,
                c.exponent
            );
        }
        // the short-range null alone takes the flicker for a wander
        assert!(flagged_by_white_null > 0);
        // a slow wander (periods 45 and 22 s) of about the noise's own size on top is found
        // (at 0.4 × this size its slow band held 2.3 × the flicker's: within the noise, the
        // log cannot tell it from the flicker)
        let r: Vec<f64> = pink_noise(&mut Rng::new(7), n, 3.0, 1.5)
            .into_iter()
            .zip(&t)
            .map(|(e, t)| e + 2.5 * ((t * std::f64::consts::TAU / 45.0).sin() + (t / 3.5).cos()))
            .collect();
        let c = coloured_null(&r, &t, 0.005).expect("long enough");
        assert!(
            c.p_value < WANDER_LEVEL,
            "ratio {} β {}",
            c.ratio,
            c.exponent
        );
    }

    #[test]
    fn short_logs_are_not_tested() {
        assert!(wander_test(&[0.0; 300]).is_none());
    }
}
