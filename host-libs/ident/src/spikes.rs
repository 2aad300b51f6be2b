//! Isolated spikes in the measured force: a corrupted frame, a knock on the load cell's
//! cable. They are not an effect of the robot, and a few of them can double a log's
//! residual variance, which hides a real effect behind "none".
//!
//! A spike is found on the base model's residual, not on the force itself: the force of a
//! dynamic trial sampled at 50 ms curves more from one sample to the next than a small spike
//! rises, while the residual is smooth wherever the base describes the arm. A row is a
//! spike when its residual departs from the median by more than [`SPIKE_SIGMAS`] robust
//! standard deviations (1.4826 × the median absolute deviation, which the spikes themselves
//! do not inflate), in a run of at most [`MAX_RUN`] rows, with the rows on either side
//! back within half that. A residual that stays off (a missing step of friction, a drift)
//! is not isolated and stays. The caller protects rows where a short residual burst is
//! evidence (the first samples after a reference step, where a delay or a rate limit shows).

/// Robust standard deviations beyond which an isolated residual is a spike. For Gaussian
/// noise the chance of one row beyond 8σ is 10⁻¹⁵.
pub const SPIKE_SIGMAS: f64 = 8.0;
/// The longest run of rows one spike may cover (a spike between two samples of a
/// resampled log spreads over two).
pub const MAX_RUN: usize = 2;

/// The robust standard deviation of `x` about its median: 1.4826 × MAD, and the median.
pub fn robust_scale(x: &[f64]) -> (f64, f64) {
    if x.is_empty() {
        return (0.0, 0.0);
    }
    let med = median(x.to_vec());
    let mad = median(x.iter().map(|v| (v - med).abs()).collect());
    (1.4826 * mad, med)
}

fn median(mut v: Vec<f64>) -> f64 {
    let n = v.len();
    let mid = n / 2;
    let (_, m, _) = v.select_nth_unstable_by(mid, |a, b| a.total_cmp(b));
    *m
}

/// How far each row of `x` departs from the straight line through its two neighbours (0 at
/// the ends): a spike's height, a smooth signal's curvature.
pub fn pointedness(x: &[f64]) -> Vec<f64> {
    let n = x.len();
    (0..n)
        .map(|i| {
            if i == 0 || i + 1 >= n {
                0.0
            } else {
                x[i] - 0.5 * (x[i - 1] + x[i + 1])
            }
        })
        .collect()
}

/// The rows that are spikes of `measured` (see the module's comment): isolated outliers of
/// `residual` that also stick out of the measured signal itself, by more than
/// [`SPIKE_SIGMAS`] robust deviations of its [`pointedness`] over the log, in the
/// residual's direction. The second test keeps a short residual burst on a smooth signal
/// (a mismatch in a step's oscillation, a friction reversal at coarse sampling) out. Rows
/// for which `protected` is true are never flagged and never count as a run's calm side.
pub fn spikes(measured: &[f64], residual: &[f64], protected: &dyn Fn(usize) -> bool) -> Vec<usize> {
    let candidates = isolated_runs(residual, protected);
    if candidates.is_empty() {
        return Vec::new();
    }
    let point = pointedness(measured);
    let (sigma_p, med_p) = robust_scale(&point);
    let mut rows = Vec::new();
    for (start, end) in candidates {
        let (before, after) = (start - 1, end + 1);
        let (a, b) = (measured[before], measured[after]);
        let span = (after - before) as f64;
        let sticks_out = (start..=end).any(|j| {
            let line = a + (b - a) * (j - before) as f64 / span;
            let d = measured[j] - line;
            d.signum() == residual[j].signum() && (d - med_p).abs() > SPIKE_SIGMAS * sigma_p
        });
        if sticks_out {
            rows.extend(start..=end);
        }
    }
    rows
}

/// The rows of `residual` that are isolated outliers (see the module's comment); rows for
/// which `protected` is true are never flagged and never count as a run's calm side.
pub fn isolated_outliers(residual: &[f64], protected: &dyn Fn(usize) -> bool) -> Vec<usize> {
    isolated_runs(residual, protected)
        .into_iter()
        .flat_map(|(s, e)| s..=e)
        .collect()
}

/// Runs (first, last row) of isolated outliers, each with a calm row on both sides.
fn isolated_runs(residual: &[f64], protected: &dyn Fn(usize) -> bool) -> Vec<(usize, usize)> {
    let n = residual.len();
    let (sigma, med) = robust_scale(residual);
    if !(sigma > 0.0) || n < 2 * MAX_RUN + 3 {
        return Vec::new();
    }
    let out = |i: usize| (residual[i] - med).abs() > SPIKE_SIGMAS * sigma;
    let calm = |i: usize| (residual[i] - med).abs() <= 0.5 * SPIKE_SIGMAS * sigma && !protected(i);
    let mut runs = Vec::new();
    let mut i = 1;
    while i + 1 < n {
        if !out(i) || protected(i) {
            i += 1;
            continue;
        }
        let mut end = i;
        while end + 1 < n && out(end + 1) && !protected(end + 1) {
            end += 1;
        }
        if end - i < MAX_RUN && end + 1 < n && calm(i - 1) && calm(end + 1) {
            runs.push((i, end));
        }
        i = end + 1;
    }
    runs
}

/// Replaces `values` at `rows` (sorted) by the straight line between the nearest rows not
/// in `rows`.
pub fn bridge(values: &mut [f64], rows: &[usize]) {
    let mut k = 0;
    while k < rows.len() {
        let start = rows[k];
        let mut end = start;
        while k + 1 < rows.len() && rows[k + 1] == end + 1 {
            k += 1;
            end += 1;
        }
        k += 1;
        let (Some(before), true) = (start.checked_sub(1), end + 1 < values.len()) else {
            continue;
        };
        let (a, b) = (values[before], values[end + 1]);
        let span = (end + 1 - before) as f64;
        for (j, v) in values[start..=end].iter_mut().enumerate() {
            *v = a + (b - a) * (j + 1) as f64 / span;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn noise(n: usize, seed: u64) -> Vec<f64> {
        // a small deterministic generator: the sum of 12 uniforms − 6 is close to N(0, 1)
        let mut s = seed;
        (0..n)
            .map(|_| {
                (0..12)
                    .map(|_| {
                        s = s
                            .wrapping_mul(6364136223846793005)
                            .wrapping_add(1442695040888963407);
                        (s >> 11) as f64 / (1u64 << 53) as f64
                    })
                    .sum::<f64>()
                    - 6.0
            })
            .collect()
    }

    #[test]
    fn finds_isolated_spikes_and_nothing_in_gaussian_noise() {
        let mut r = noise(5000, 1);
        assert!(isolated_outliers(&r, &|_| false).is_empty());
        r[100] += 12.0;
        r[2000] -= 20.0;
        r[2001] -= 15.0;
        r[4000] += 30.0;
        r[4001] += 30.0;
        r[4002] += 30.0; // three rows: not a spike
        assert_eq!(isolated_outliers(&r, &|_| false), vec![100, 2000, 2001]);
        // protected rows stay
        assert_eq!(isolated_outliers(&r, &|i| i == 100), vec![2000, 2001]);
    }

    #[test]
    fn a_residual_burst_on_a_smooth_signal_is_not_a_spike() {
        // a signal that curves from row to row (a 50 ms sampled oscillation) and a model
        // that misses one of its bumps: the residual is isolated, the signal is not pointed
        let measured: Vec<f64> = (0..2000).map(|i| 10.0 * (0.9 * i as f64).sin()).collect();
        let mut residual = noise(2000, 3).iter().map(|v| 0.05 * v).collect::<Vec<_>>();
        residual[500] += 1.0;
        assert_eq!(isolated_outliers(&residual, &|_| false), vec![500]);
        assert!(spikes(&measured, &residual, &|_| false).is_empty());
        // a real spike on the same signal: in the residual and in the signal
        let mut spiked = measured.clone();
        spiked[700] += 30.0;
        residual[700] += 30.0;
        assert_eq!(spikes(&spiked, &residual, &|_| false), vec![700]);
    }

    #[test]
    fn a_residual_that_stays_off_is_not_a_spike() {
        let mut r = noise(3000, 2);
        for v in &mut r[1500..] {
            *v += 25.0;
        }
        assert!(isolated_outliers(&r, &|_| false).is_empty());
    }

    #[test]
    fn bridge_draws_the_line_between_neighbours() {
        let mut v = vec![0.0, 1.0, 50.0, -40.0, 4.0, 5.0, 99.0];
        bridge(&mut v, &[2, 3, 6]);
        assert_eq!(&v[..6], &[0.0, 1.0, 2.0, 3.0, 4.0, 5.0]);
        // a last row has no right neighbour and is left as it is
        assert_eq!(v[6], 99.0);
    }
}
