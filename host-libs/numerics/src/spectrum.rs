//! Single-sided amplitude spectra (radix-2 FFT on a zero-padded, mean-removed signal) and
//! the detection of narrow peaks that no smooth model explains.

use std::f64::consts::PI;

fn fft_in_place(re: &mut [f64], im: &mut [f64]) {
    let n = re.len();
    let mut j = 0;
    for i in 1..n {
        let mut bit = n >> 1;
        while j & bit != 0 {
            j ^= bit;
            bit >>= 1;
        }
        j |= bit;
        if i < j {
            re.swap(i, j);
            im.swap(i, j);
        }
    }
    let mut len = 2;
    while len <= n {
        let ang = -2.0 * PI / len as f64;
        let (wr, wi) = (ang.cos(), ang.sin());
        for start in (0..n).step_by(len) {
            let (mut cr, mut ci) = (1.0, 0.0);
            for k in 0..len / 2 {
                let (a, b) = (start + k, start + k + len / 2);
                let tr = re[b] * cr - im[b] * ci;
                let ti = re[b] * ci + im[b] * cr;
                re[b] = re[a] - tr;
                im[b] = im[a] - ti;
                re[a] += tr;
                im[a] += ti;
                let ncr = cr * wr - ci * wi;
                ci = cr * wi + ci * wr;
                cr = ncr;
            }
        }
        len <<= 1;
    }
}

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

/// Amplitude spectrum of `x` sampled every `dt_s`: |X(f)|·2/N (DC not doubled), without
/// zero padding when `pad` is false (bins then fall on k/(N·dt) exactly for N a power of
/// two; otherwise the signal is truncated to the largest power of two, keeping the bins
/// honest rather than interpolated).
pub fn amplitude_spectrum(x: &[f64], dt_s: f64) -> Spectrum {
    let mut n = 1usize;
    while n * 2 <= x.len() {
        n *= 2;
    }
    let m = x[..n].iter().sum::<f64>() / n as f64;
    let mut re: Vec<f64> = x[..n].iter().map(|v| v - m).collect();
    let mut im = vec![0.0; n];
    if n >= 2 {
        fft_in_place(&mut re, &mut im);
    }
    let half = n / 2 + 1;
    let df = 1.0 / (n as f64 * dt_s);
    let scale = 2.0 / n as f64;
    Spectrum {
        freq_hz: (0..half).map(|k| k as f64 * df).collect(),
        amplitude: (0..half)
            .map(|k| {
                (re[k] * re[k] + im[k] * im[k]).sqrt()
                    * if k == 0 || k == n / 2 { 0.5 } else { 1.0 }
                    * scale
            })
            .collect(),
        re: re[..half].iter().map(|v| v * scale).collect(),
        im: im[..half].iter().map(|v| v * scale).collect(),
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
/// `min_share` of the variance. The neighbourhood is ±max(20 bins, 5 % of the frequency).
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
            // the neighbourhood: ±20 bins, or 40 bins below the top of the spectrum
            let w = 20usize;
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
    use super::*;

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
        let mut state = 12345u64;
        let x: Vec<f64> = (0..16384)
            .map(|_| {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
            })
            .collect();
        let s = amplitude_spectrum(&x, 0.001);
        assert!(narrow_peaks(&s, 30.0, 0.02).is_empty());
    }

    #[test]
    fn a_tone_at_the_nyquist_frequency_is_a_peak() {
        // 50 Hz sampled every 50 ms: ±A alternating
        let mut state = 99u64;
        let x: Vec<f64> = (0..2048)
            .map(|i| {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                let noise = ((state >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 0.3;
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
