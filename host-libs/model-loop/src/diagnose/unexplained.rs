//! Structure left in the residual that no effect accounts for: spectral lines and a slow
//! wander of the level.

use super::colour::coloured_noise;
use super::resolution::encoder_floor;
use super::Loop;
use super::ModelFit;
use super::Settings;
use super::Warning;
use crate::effects::Experiment;
use pam_numerics::spectrum::amplitude_spectrum;
use pam_numerics::spectrum::narrow_peaks;
use pam_numerics::spectrum::on_even_times;
use pam_numerics::stats::rms;
use pam_numerics::stats::std_dev;
use pam_numerics::stats::{wander_test, WANDER_BINS, WANDER_LEVEL, WANDER_MIN_SHARE};
use serde::Serialize;

/// A wander whose variance the encoders' rounding alone gives at least this share of is
/// judged against white noise, not the load cell's colour: the rounding, frozen at rests,
/// puts its power in the slow band and the octaves just above it, where the noise's law is
/// measured, and colours the residual itself (a reach-and-hold trial's rounding of a
/// third of a wander's amplitude turns a white residual's law to f^−0.9).
const ROUNDING_SHARE: f64 = 1.0 / 16.0;

/// Whether the encoders' rounding (a wander of `expected_n` RMS alone) colours a slow
/// change of `change_n` RMS: then the change is judged against white noise.
pub(super) fn rounding_colours(expected_n: f64, change_n: f64) -> bool {
    expected_n * expected_n >= ROUNDING_SHARE * change_n * change_n
}

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
    pub set_aside: Vec<Warning>,
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
        // a level that moves by less than the encoders' rounding does (frozen while the
        // handle rests) cannot be told from it: said, not named
        let floor = floor.get_or_init(|| encoder_floor(lp, fit));
        if let Some(f) = floor.filter(|f| w.amplitude_n <= f.bound_n[a]) {
            set_aside.push(Warning::WanderWithinEncoderRounding {
                axis: a,
                amplitude_n: w.amplitude_n,
                step_rad: f.step_rad,
                expected_n: f.expected_n[a],
                bound_n: f.bound_n[a],
                draws: super::resolution::DRAWS,
            });
            continue;
        }
        // the load cell's own noise is coloured (1/f below a corner of a few Hz): its bin
        // means vary more than a short-range correlation allows, and that is no structure.
        // Asked after the rounding: a residual whose slow band the rounding fills keeps
        // the white null (its frozen levels would colour the law, and excuse a wander)
        let rounding_colours = floor
            .as_ref()
            .is_some_and(|f| rounding_colours(f.expected_n[a], w.amplitude_n));
        let c = (!rounding_colours)
            .then(|| coloured_noise(&r, &p.t_s, p.dt_s))
            .flatten();
        if let Some(c) = c.filter(|c| c.p_value > WANDER_LEVEL) {
            set_aside.push(Warning::WanderWithinColouredNoise {
                axis: a,
                amplitude_n: w.amplitude_n,
                low_hz: c.low_hz,
                ratio: c.ratio,
                exponent: c.exponent,
                p_value: c.p_value,
            });
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

    #[test]
    fn short_logs_are_not_tested() {
        assert!(wander_test(&[0.0; 300]).is_none());
    }
}
