//! Single-sided amplitude spectra (a real FFT of the whole mean-removed signal, any length)
//! and the detection of narrow peaks that no smooth model explains.

use realfft::RealFftPlanner;

/// Single-sided amplitude spectrum.
#[derive(Clone, Debug)]
pub struct Spectrum {
    pub freq_hz: Vec<f64>,
    pub amplitude: Vec<f64>,
    /// Complex values (for phase-aware uses), same bins.
    pub re: Vec<f64>,
    pub im: Vec<f64>,
}

/// `x` sampled at `t_s` on an even grid of `dt_s` from `t_s[0]` (linear interpolation)
/// when the sampling is uneven, for a spectrum: a jittered clock's times drift from
/// k·dt as a random walk, which smears a tone's line if the rows are taken as even.
/// Borrowed as it is when the sampling is even.
pub fn on_even_times<'a>(t_s: &[f64], x: &'a [f64], dt_s: f64) -> std::borrow::Cow<'a, [f64]> {
    use std::borrow::Cow;
    let n = t_s.len().min(x.len());
    if n < 2 || !(dt_s > 0.0) || !crate::interp::is_uneven(&t_s[..n], dt_s) {
        return Cow::Borrowed(x);
    }
    let t0 = t_s[0];
    let m = ((t_s[n - 1] - t0) / dt_s + 1e-9).floor() as usize + 1;
    let grid: Vec<f64> = (0..m).map(|k| t0 + k as f64 * dt_s).collect();
    Cow::Owned(crate::interp::linear_at(&t_s[..n], &x[..n], &grid))
}

/// Amplitude spectrum of `x` sampled every `dt_s`: |X(f)|·2/N (DC and the Nyquist bin not
/// doubled) of all N samples, mean removed, without zero padding: the bins fall on k/(N·dt)
/// exactly. The FFT is realfft's, which handles any N (mixed radix, or Bluestein's
/// algorithm for a length with a large prime factor).
pub fn amplitude_spectrum(x: &[f64], dt_s: f64) -> Spectrum {
    let n = x.len();
    if n < 2 {
        // one sample: its mean removed, nothing is left
        return Spectrum {
            freq_hz: vec![0.0; n],
            amplitude: vec![0.0; n],
            re: vec![0.0; n],
            im: vec![0.0; n],
        };
    }
    let m = x.iter().sum::<f64>() / n as f64;
    let mut input: Vec<f64> = x.iter().map(|v| v - m).collect();
    let fft = RealFftPlanner::<f64>::new().plan_fft_forward(n);
    let mut bins = fft.make_output_vec();
    fft.process(&mut input, &mut bins)
        .expect("the buffers come from the plan, so their lengths match it");
    let half = bins.len();
    let df = 1.0 / (n as f64 * dt_s);
    let scale = 2.0 / n as f64;
    // the Nyquist bin exists only for an even N
    let unpaired = |k: usize| k == 0 || (n.is_multiple_of(2) && k == n / 2);
    Spectrum {
        freq_hz: (0..half).map(|k| k as f64 * df).collect(),
        amplitude: bins
            .iter()
            .enumerate()
            .map(|(k, c)| c.norm() * if unpaired(k) { 0.5 } else { 1.0 } * scale)
            .collect(),
        re: bins.iter().map(|c| c.re * scale).collect(),
        im: bins.iter().map(|c| c.im * scale).collect(),
    }
}

/// A narrow spectral line: power far above the local background.
#[derive(Clone, Debug, PartialEq)]
pub struct Peak {
    pub freq_hz: f64,
    pub amplitude: f64,
    /// Peak power / median power of the neighbourhood.
    pub prominence: f64,
    /// Share of the signal's variance in the line (±2 bins).
    pub variance_share: f64,
}

/// Lines whose power is ≥ `min_prominence` × the local median and that carry at least
/// `min_share` of the variance. The neighbourhood is ±20 bins around the line (40 below it
/// near the top of the spectrum, ±(k − 1) near the bottom) without the line's own ±3; a line
/// needs 8 bins of it, so the lowest seven bins (fewer than eight cycles in the record)
/// hold none.
pub fn narrow_peaks(s: &Spectrum, min_prominence: f64, min_share: f64) -> Vec<Peak> {
    let p: Vec<f64> = s.amplitude.iter().map(|a| a * a).collect();
    let total: f64 = p.iter().skip(1).sum::<f64>().max(1e-300);
    let n = p.len();
    if n < 16 {
        return Vec::new();
    }
    // a cheap background first (medians of blocks of 64 bins), the exact local median only
    // for the few bins that stand out of it
    const BLOCK: usize = 64;
    let block_median: Vec<f64> = p
        .chunks(BLOCK)
        .map(|c| {
            let mut v = c.to_vec();
            v.sort_by(|a, b| a.total_cmp(b));
            v[v.len() / 2]
        })
        .collect();
    let mut out: Vec<Peak> = Vec::new();
    let mut k = 2;
    while k < n {
        let right = if k + 1 < n { p[k + 1] } else { 0.0 };
        let is_max = p[k] >= p[k - 1] && p[k] >= right && p[k] > 0.0;
        let bm = block_median[k / BLOCK].min(block_median[(k / BLOCK).saturating_sub(1)]);
        if is_max && p[k] >= 0.5 * min_prominence * bm {
            // the neighbourhood: ±20 bins, or 40 bins below the top of the spectrum. Near
            // the bottom it stays symmetric (±(k − 1) bins): a one-sided neighbourhood
            // there lies wholly above the line, where a coloured background (a load cell's
            // 1/f noise) is several times lower, and makes a line of any slow bump. The
            // slowest bins, with too few neighbours below them, are no line: a structure of
            // a few cycles per record is a slow wander, and the wander test judges it
            let w = 20usize.min(k - 1);
            let lo = k.saturating_sub(if k + w >= n { 2 * w } else { w }).max(1);
            let hi = (k + w + 1).min(n);
            let mut neigh: Vec<f64> = (lo..hi)
                .filter(|i| i.abs_diff(k) > 3)
                .map(|i| p[i])
                .collect();
            if neigh.len() >= 8 {
                neigh.sort_by(|a, b| a.total_cmp(b));
                let med = neigh[neigh.len() / 2].max(1e-300);
                let line: f64 = p[k.saturating_sub(2)..(k + 3).min(n)].iter().sum();
                let prominence = p[k] / med;
                let share = line / total;
                if prominence >= min_prominence && share >= min_share {
                    out.push(Peak {
                        freq_hz: s.freq_hz[k],
                        amplitude: s.amplitude[k],
                        prominence,
                        variance_share: share,
                    });
                    k += 3;
                    continue;
                }
            }
        }
        k += 1;
    }
    out.sort_by(|a, b| b.variance_share.total_cmp(&a.variance_share));
    out
}

#[cfg(test)]
mod tests {
    use super::{amplitude_spectrum, narrow_peaks};
    use std::f64::consts::PI;

    /// A seeded stream of uniform draws in [0, 1) (a 64-bit linear congruential generator's
    /// top 53 bits): the same noise on every run and every machine.
    fn uniform(seed: u64) -> impl FnMut() -> f64 {
        let mut state = seed;
        move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    /// The spectrum against a direct DFT at lengths that are not powers of two (prime,
    /// odd, even), every bin.
    #[test]
    fn matches_a_direct_dft_at_any_length() {
        for n in [2usize, 7, 90, 1000, 1009] {
            let x: Vec<f64> = (0..n)
                .map(|i| (0.37 * i as f64).sin() + 0.2 * ((i * i) % 13) as f64)
                .collect();
            let s = amplitude_spectrum(&x, 0.01);
            assert_eq!(s.freq_hz.len(), n / 2 + 1);
            let m = x.iter().sum::<f64>() / n as f64;
            for k in 0..=n / 2 {
                let (mut re, mut im) = (0.0, 0.0);
                for (i, v) in x.iter().enumerate() {
                    let a = -2.0 * PI * (k * i) as f64 / n as f64;
                    re += (v - m) * a.cos();
                    im += (v - m) * a.sin();
                }
                let unpaired = k == 0 || (n % 2 == 0 && k == n / 2);
                let amp =
                    (re * re + im * im).sqrt() * 2.0 / n as f64 * if unpaired { 0.5 } else { 1.0 };
                assert!((s.amplitude[k] - amp).abs() < 1e-9, "n {n} bin {k}");
                assert!((s.re[k] - re * 2.0 / n as f64).abs() < 1e-9);
                assert!((s.im[k] - im * 2.0 / n as f64).abs() < 1e-9);
                assert!((s.freq_hz[k] - k as f64 / (n as f64 * 0.01)).abs() < 1e-9);
            }
        }
    }

    /// A tone on a bin of a length that is not a power of two keeps its full amplitude
    /// (truncating to a power of two would put it between bins).
    #[test]
    fn a_tone_on_a_bin_keeps_its_amplitude() {
        let (n, dt) = (3000usize, 0.001);
        let x: Vec<f64> = (0..n)
            .map(|i| 1.5 * (2.0 * PI * 50.0 * i as f64 * dt).cos())
            .collect();
        let s = amplitude_spectrum(&x, dt);
        let k = 150; // 50 Hz at 1/3 Hz per bin
        assert!((s.freq_hz[k] - 50.0).abs() < 1e-9);
        assert!((s.amplitude[k] - 1.5).abs() < 1e-9, "{}", s.amplitude[k]);
    }

    #[test]
    fn sine_amplitude_and_peak_are_found() {
        let dt = 0.001;
        let x: Vec<f64> = (0..8192)
            .map(|i| {
                let t = i as f64 * dt;
                2.0 * (2.0 * PI * 50.0 * t).sin() + 0.3 * ((i * 7919 % 1000) as f64 / 1000.0 - 0.5)
            })
            .collect();
        let s = amplitude_spectrum(&x, dt);
        let k = s
            .amplitude
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(b.1))
            .unwrap()
            .0;
        assert!((s.freq_hz[k] - 50.0).abs() < 0.2);
        let peaks = narrow_peaks(&s, 30.0, 0.05);
        assert!(!peaks.is_empty() && (peaks[0].freq_hz - 50.0).abs() < 0.2);
    }

    #[test]
    fn white_noise_has_no_narrow_peaks() {
        let mut u = uniform(12345);
        let x: Vec<f64> = (0..16384).map(|_| u() - 0.5).collect();
        let s = amplitude_spectrum(&x, 0.001);
        assert!(narrow_peaks(&s, 30.0, 0.02).is_empty());
    }

    /// A load cell's 1/f noise (octave-spaced relaxations, 0.01 Hz up to a few Hz) over
    /// 80 s: its slowest bins rise far above the bins beside them on one side, which a
    /// one-sided neighbourhood took for lines in one record in forty.
    #[test]
    fn a_pink_records_slowest_bins_are_not_lines() {
        let (n, dt) = (16_000usize, 0.005);
        let mut u = uniform(7);
        let mut lines = Vec::new();
        for record in 0..200 {
            // Box–Muller, on (0, 1] for the logarithm
            let mut gauss = || {
                let (a, b) = (1.0 - u(), u());
                (-2.0 * a.ln()).sqrt() * (2.0 * PI * b).cos()
            };
            let poles: Vec<f64> = (0..9)
                .map(|o| (-2.0 * PI * 0.01 * f64::powi(2.0, o) * dt).exp())
                .collect();
            let mut state_of: Vec<f64> = poles.iter().map(|_| gauss()).collect();
            let x: Vec<f64> = (0..n)
                .map(|_| {
                    for (s, a) in state_of.iter_mut().zip(&poles) {
                        *s = a * *s + (1.0 - a * a).sqrt() * gauss();
                    }
                    state_of.iter().sum::<f64>() / 3.0 + gauss()
                })
                .collect();
            let s = amplitude_spectrum(&x, dt);
            lines.extend(
                narrow_peaks(&s, 40.0, 0.03)
                    .into_iter()
                    .map(|p| (record, p.freq_hz)),
            );
        }
        assert!(lines.is_empty(), "{lines:?}");
    }

    /// A slow tone with room for a neighbourhood on both sides is still a line.
    #[test]
    fn a_slow_tone_above_the_lowest_bins_is_a_line() {
        let (n, dt) = (16_000usize, 0.005);
        let mut u = uniform(3);
        let x: Vec<f64> = (0..n)
            .map(|i| {
                let noise = u() - 0.5;
                // bin 12: 12 cycles in the record
                0.3 * (2.0 * PI * 12.0 * i as f64 / n as f64).sin() + noise
            })
            .collect();
        let s = amplitude_spectrum(&x, dt);
        let peaks = narrow_peaks(&s, 40.0, 0.03);
        assert!(
            !peaks.is_empty() && (peaks[0].freq_hz - 12.0 / (n as f64 * dt)).abs() < 1e-9,
            "{peaks:?}"
        );
    }

    #[test]
    fn a_tone_at_the_nyquist_frequency_is_a_peak() {
        // 50 Hz sampled every 50 ms: ±A alternating
        let mut u = uniform(99);
        let x: Vec<f64> = (0..2048)
            .map(|i| {
                let noise = (u() - 0.5) * 0.3;
                0.5 * if i % 2 == 0 { 1.0 } else { -1.0 } + noise
            })
            .collect();
        let s = amplitude_spectrum(&x, 0.05);
        let peaks = narrow_peaks(&s, 30.0, 0.05);
        assert!(
            !peaks.is_empty() && (peaks[0].freq_hz - 10.0).abs() < 0.05,
            "{peaks:?}"
        );
    }
}
