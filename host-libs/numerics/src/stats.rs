//! Statistics of series: moments, correlation, and the test for a slow wander of a level.

use statrs::distribution::{ContinuousCDF, FisherSnedecor};

/// The mean (0 for an empty series).
pub fn mean(s: &[f64]) -> f64 {
    if s.is_empty() {
        0.0
    } else {
        s.iter().sum::<f64>() / s.len() as f64
    }
}

/// The standard deviation (population: over n).
pub fn std_dev(s: &[f64]) -> f64 {
    let m = mean(s);
    (s.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / s.len().max(1) as f64).sqrt()
}

/// The root mean square.
pub fn rms(s: &[f64]) -> f64 {
    (s.iter().map(|v| v * v).sum::<f64>() / s.len().max(1) as f64).sqrt()
}

/// Pearson's correlation of two series of the same length (0 when one is constant).
pub fn correlation(a: &[f64], b: &[f64]) -> f64 {
    let (ma, mb) = (
        a.iter().sum::<f64>() / a.len() as f64,
        b.iter().sum::<f64>() / b.len() as f64,
    );
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        sab += (x - ma) * (y - mb);
        saa += (x - ma).powi(2);
        sbb += (y - mb).powi(2);
    }
    sab / (saa * sbb).sqrt().max(1e-300)
}

/// Time bins over which a wander of the residual's level is looked for.
pub const WANDER_BINS: usize = 20;
/// Batches that estimate the residual's long-run variance (its short-range correlation):
/// ten per bin where the log is long enough, so a batch (0.2–0.6 s of a 40–120 s trial) outlasts the load cell's
/// coloured noise and the operator's motion (≥ 1 Hz) several times over.
pub const WANDER_BATCHES: usize = 200;
/// Level of the wander test (one test per axis, on trials no effect explained). Strict,
/// because a model's misfit under an operator whose vigour changes over the trial also moves
/// the residual's level a little, which the F distribution does not allow for.
pub const WANDER_LEVEL: f64 = 1e-4;
/// Least share of the residual's variance a wander must carry to be named: below it, it is
/// the misfit's own slow structure rather than something outside the model (a control of
/// the second generator at 4 % model error showed a 2.6 % share at p = 7e-5).
pub const WANDER_MIN_SHARE: f64 = 0.04;

/// A slow wander of the residual's level, tested as a variance ratio (Lo & MacKinlay): the
/// variance of the means over [`WANDER_BINS`] bins against what the variance of the means
/// over [`WANDER_BATCHES`] shorter batches predicts for them. A residual without a wander
/// (white or with a correlation shorter than a batch) gives a ratio of 1 within an F
/// distribution; a level that moves over many batches raises the bins' variance
/// `n_bin` times more than the batches'.
#[derive(Debug, Clone, Copy)]
pub struct Wander {
    /// Variance of the bin means over the one predicted from the batches.
    pub variance_ratio: f64,
    /// Probability of a ratio this large without a wander, F(bins − 1, batches − 1).
    pub p_value: f64,
    /// The wander's RMS amplitude with the noise's share of the bin means removed, N.
    pub amplitude_n: f64,
    /// Share of the residual's variance carried by the bin means.
    pub share: f64,
}

pub fn wander_test(r: &[f64]) -> Option<Wander> {
    let n = r.len();
    // at least ten samples a batch and two batches a bin (a short, slowly sampled log has
    // fewer batches, and the F test its degrees of freedom)
    let batches = (n / 10).min(WANDER_BATCHES);
    if batches < 2 * WANDER_BINS {
        return None;
    }
    let m = r.iter().sum::<f64>() / n as f64;
    let total: f64 = r.iter().map(|v| (v - m).powi(2)).sum();
    if total <= 0.0 {
        return None;
    }
    // variance of the block means and the mean block length
    let means_var = |blocks: usize| -> (f64, f64) {
        let mut ss = 0.0;
        for b in 0..blocks {
            let (lo, hi) = (b * n / blocks, (b + 1) * n / blocks);
            let mb = r[lo..hi].iter().sum::<f64>() / (hi - lo) as f64;
            ss += (hi - lo) as f64 * (mb - m).powi(2);
        }
        (ss / n as f64, n as f64 / blocks as f64)
    };
    let (var_bins, len_bin) = means_var(WANDER_BINS);
    let (var_batches, len_batch) = means_var(batches);
    // without a wander, a block mean's variance is the long-run variance over its length
    let predicted = var_batches * len_batch / len_bin;
    if predicted <= 0.0 {
        return None;
    }
    let variance_ratio = var_bins / predicted;
    let p_value = FisherSnedecor::new((WANDER_BINS - 1) as f64, (batches - 1) as f64)
        .map(|f| 1.0 - f.cdf(variance_ratio))
        .unwrap_or(1.0);
    // a wander of variance W adds W to both: var_bins = W + L/len_bin,
    // var_batches = W + L/len_batch; solved for W
    let k = len_batch / len_bin;
    let wander_var = ((var_bins - k * var_batches) / (1.0 - k)).max(0.0);
    Some(Wander {
        variance_ratio,
        p_value,
        amplitude_n: wander_var.sqrt(),
        share: var_bins * n as f64 / total,
    })
}
