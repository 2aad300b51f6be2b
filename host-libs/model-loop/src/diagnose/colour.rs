//! The load cell's coloured noise as the null of the slow decisions. A load cell's noise has
//! a 1/f part below a corner of a few Hz (and an autoregressive part): the residual's level
//! then wanders more than a short-range correlation allows, and a straight line through a
//! finite record of it is not zero. Neither is an effect. The noise's spectrum is measured
//! on the octaves above the slow band (where a wander or a drift puts little) as a power
//! law f^−β, β between 0 (white) and 1 (a 1/f noise, the steepest a stationary sensor noise
//! is taken to be: a spectrum steeper than that below its measured band is a random walk,
//! a wander, not a sensor's noise), and extended into the slow band. One spectrum of the
//! residual: it costs no more than a fit.

use pam_numerics::spectrum::amplitude_spectrum;
use pam_numerics::spectrum::on_even_times;
use pam_numerics::stats::WANDER_BINS;
use statrs::distribution::{ChiSquared, ContinuousCDF, FisherSnedecor};

/// Octaves of the spectrum above the slow band that the noise's law is fitted on.
const REFERENCE_OCTAVES: usize = 5;
/// The slow band: the spectrum's bins the wander test's bin means resolve.
const SLOW_BINS: usize = WANDER_BINS / 2;
/// Bins of the law a straight line's share is summed over (the rest is < 0.1 % of it).
const TREND_BINS: usize = 512;

/// The residual's noise as a power law and its slow band against it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct ColouredNoise {
    /// β of the noise's spectrum f^−β.
    pub exponent: f64,
    /// log₂ of the anchor's bin and of its power per bin (amplitude², N²).
    anchor: (f64, f64),
    /// Power in the slow band over the extended noise's.
    pub ratio: f64,
    /// Probability of a ratio this large from the noise alone, F(2 · slow bins, 2 · slow
    /// bins).
    pub p_value: f64,
    /// The slow band's upper edge, Hz.
    pub low_hz: f64,
}

impl ColouredNoise {
    /// The law's power (amplitude², N²) at bin `k` of the record's spectrum.
    pub fn power_at(&self, k: f64) -> f64 {
        let (x0, y0) = self.anchor;
        2f64.powf(y0 - self.exponent * (k.log2() - x0))
    }

    /// The RMS (N) of the straight line a least-squares fit finds in a record of this
    /// noise alone, at the quantile `1 − level`. A bin's sine has a share 6/(π² k²) of
    /// its variance along a line over the record (its cosine none), and the line's
    /// coefficient is a normal sum of them: χ² with one degree of freedom.
    pub fn trend_bound_n(&self, level: f64) -> f64 {
        let variance: f64 = (1..=TREND_BINS)
            .map(|k| {
                let k = k as f64;
                // the sine's mean square is half the bin's sine power, itself half its power
                3.0 / (std::f64::consts::PI.powi(2) * k * k) * self.power_at(k) / 2.0
            })
            .sum();
        let q = ChiSquared::new(1.0)
            .map(|c| c.inverse_cdf(1.0 - level.clamp(1e-12, 0.5)))
            .unwrap_or(f64::INFINITY);
        (q * variance).sqrt()
    }
}

/// The residual `r` (sampled at `t_s`, period `dt_s`): its straight line taken out first (a
/// 1/f noise's power below 1/T shows in a finite record as a trend, whose leakage falls as
/// f^−2 over the slow band; a line is the catalog's drift, judged as an effect), its
/// spectrum's power per bin over [`REFERENCE_OCTAVES`] octaves above the slow band fitted
/// as f^−β, and the slow band's power against the law's. `None` for a record too short for
/// three octaves.
pub(super) fn coloured_noise(r: &[f64], t_s: &[f64], dt_s: f64) -> Option<ColouredNoise> {
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
    let low = SLOW_BINS;
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
    let mut noise = ColouredNoise {
        exponent,
        anchor: octaves[0],
        ratio: 0.0,
        p_value: 1.0,
        low_hz: spec.freq_hz.get(low).copied().unwrap_or(0.0),
    };
    let predicted: f64 = (1..=low).map(|k| noise.power_at(k as f64)).sum();
    let actual: f64 = power[1..=low].iter().sum();
    if !(predicted > 0.0) {
        return None;
    }
    noise.ratio = actual / predicted;
    noise.p_value = FisherSnedecor::new(2.0 * low as f64, 2.0 * low as f64)
        .map(|f| 1.0 - f.cdf(noise.ratio))
        .unwrap_or(1.0);
    Some(noise)
}

#[cfg(test)]
mod tests {
    use super::*;
    use pam_numerics::stats::{wander_test, WANDER_LEVEL};
    use pam_twin::rng::Rng;

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

    /// The RMS of the least-squares straight line through `r`.
    fn line_rms(r: &[f64]) -> f64 {
        let n = r.len() as f64;
        let mx = (n - 1.0) / 2.0;
        let my = r.iter().sum::<f64>() / n;
        let sxx: f64 = (0..r.len()).map(|i| (i as f64 - mx).powi(2)).sum();
        let sxy: f64 = (0..r.len()).map(|i| (i as f64 - mx) * (r[i] - my)).sum();
        (sxy / sxx) * (sxx / n).sqrt()
    }

    #[test]
    fn a_load_cells_flicker_noise_is_not_a_wander_but_a_wander_on_it_is() {
        let n = 18_000; // 90 s at 5 ms
        let t: Vec<f64> = (0..n).map(|i| i as f64 * 0.005).collect();
        let mut flagged_by_white_null = 0;
        for seed in 0..8 {
            let r = pink_noise(&mut Rng::new(100 + seed), n, 1.0 + 0.6 * seed as f64, 1.5);
            let w = wander_test(&r).expect("long enough");
            flagged_by_white_null += usize::from(w.p_value <= WANDER_LEVEL);
            let c = coloured_noise(&r, &t, 0.005).expect("long enough");
            assert!(c.p_value > WANDER_LEVEL, "seed {seed}: {c:?}");
        }
        // the short-range null alone takes the flicker for a wander
        assert!(flagged_by_white_null > 0);
        // a slow wander (periods 45 and 22 s) of about the noise's own size on top is found
        let r: Vec<f64> = pink_noise(&mut Rng::new(7), n, 3.0, 1.5)
            .into_iter()
            .zip(&t)
            .map(|(e, t)| e + 2.5 * ((t * std::f64::consts::TAU / 45.0).sin() + (t / 3.5).cos()))
            .collect();
        let c = coloured_noise(&r, &t, 0.005).expect("long enough");
        assert!(c.p_value < WANDER_LEVEL, "{c:?}");
    }

    #[test]
    fn the_line_through_flicker_noise_stays_within_its_bound_and_a_drift_does_not() {
        let n = 18_000;
        let t: Vec<f64> = (0..n).map(|i| i as f64 * 0.005).collect();
        let level = 0.01;
        let mut beyond = 0;
        for seed in 0..12 {
            let r = pink_noise(&mut Rng::new(300 + seed), n, 1.0 + 0.4 * seed as f64, 1.5);
            let c = coloured_noise(&r, &t, 0.005).expect("long enough");
            beyond += usize::from(line_rms(&r).abs() > c.trend_bound_n(level));
        }
        assert!(beyond <= 1, "{beyond} of 12 lines beyond the bound");
        // white noise has a bound of a white record's line: a drift of 0.1 σ over the trial
        // stands out of it
        let mut rng = Rng::new(9);
        let drift: Vec<f64> = (0..n)
            .map(|i| rng.normal() + 0.1 * (i as f64 / n as f64 - 0.5) * 12f64.sqrt())
            .collect();
        let c = coloured_noise(&drift, &t, 0.005).expect("long enough");
        assert!(c.exponent < 0.3, "{c:?}");
        assert!(line_rms(&drift).abs() > c.trend_bound_n(level), "{c:?}");
    }
}
