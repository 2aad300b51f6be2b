//! The statistics that accept an effect and that say when two cannot be told apart.
//!
//! An effect's gain is measured fold by fold (blocked cross-validation over time, or
//! contiguous blocks of the held-out part): r_k = 1 − SSE_k(with) / SSE_k(without). Its mean
//! must exceed the fold-to-fold spread — a one-sided t-test — or it must win in nearly every
//! fold — a sign test, robust to gains that differ from fold to fold. Each takes half the
//! level; the level is per family unless `Settings::bonferroni` splits it over the families.
//! Cross-validation folds share most of their training data, which makes the r_k
//! correlated; the variance then uses Nadeau and Bengio's correction (1/K + n_test/n_train
//! instead of 1/K), which keeps the test honest.

use super::cv::FoldScores;
use statrs::distribution::{ContinuousCDF, StudentsT};

/// The gain of one model over another, fold by fold.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct FoldTest {
    /// 1 − Σ SSE(with) / Σ SSE(without), pooled over the folds.
    pub improvement: f64,
    /// Mean and standard deviation of the per-fold gains.
    pub fold_mean: f64,
    pub fold_sd: f64,
    pub folds: usize,
    /// Mean over its (corrected) standard error.
    pub t: f64,
    /// Folds where the effect fits better, and the one-sided sign-test p-value of that
    /// count (robust to gains that differ from fold to fold, like a drift's, largest at
    /// the ends).
    pub wins: usize,
    pub sign_p: f64,
}

/// P(X ≥ wins) for X ~ Binomial(n, ½).
pub fn sign_test_p(wins: usize, n: usize) -> f64 {
    let mut tail = 0.0;
    let mut c = 1.0f64; // C(n, 0)
    for k in 0..=n {
        if k >= wins {
            tail += c;
        }
        c = c * (n - k) as f64 / (k + 1) as f64;
    }
    tail / 2f64.powi(n as i32)
}

impl FoldTest {
    /// The gain is significant at `level`: by the t-test or by the sign test, each at half
    /// the level.
    pub fn significant(&self, t_critical_half: f64, level: f64) -> bool {
        self.t >= t_critical_half || (self.folds > 0 && self.sign_p <= level / 2.0)
    }
}

/// Compares `with` against `without` (same folds). `cross_validated`: the folds' training
/// sets overlap (apply the correction); otherwise they are held-out blocks of one fit.
pub fn fold_test(without: &FoldScores, with: &FoldScores, cross_validated: bool) -> FoldTest {
    let k = without.sse.len().min(with.sse.len());
    if k == 0 {
        return FoldTest::default();
    }
    let gains: Vec<f64> = (0..k)
        .filter(|&i| without.sse[i] > 0.0)
        .map(|i| 1.0 - with.sse[i] / without.sse[i])
        .collect();
    let n = gains.len();
    let mean = gains.iter().sum::<f64>() / n.max(1) as f64;
    let var = if n > 1 {
        gains.iter().map(|g| (g - mean).powi(2)).sum::<f64>() / (n - 1) as f64
    } else {
        f64::INFINITY
    };
    let factor = if cross_validated && n > 1 {
        1.0 / n as f64 + 1.0 / (n - 1) as f64
    } else {
        1.0 / n.max(1) as f64
    };
    let se = (var * factor).sqrt();
    let (sw, sb): (f64, f64) = (with.sse[..k].iter().sum(), without.sse[..k].iter().sum());
    let wins = gains.iter().filter(|g| **g > 0.0).count();
    FoldTest {
        wins,
        sign_p: sign_test_p(wins, n),
        improvement: if sb > 0.0 { 1.0 - sw / sb } else { 0.0 },
        fold_mean: mean,
        fold_sd: var.sqrt(),
        folds: n,
        t: if se > 0.0 && se.is_finite() {
            mean / se
        } else if mean > 0.0 && var == 0.0 {
            f64::INFINITY
        } else {
            0.0
        },
    }
}

/// The one-sided critical t for `folds` folds at level `alpha` split over `candidates`.
pub fn t_critical(folds: usize, alpha: f64, candidates: usize) -> f64 {
    let dof = folds.saturating_sub(1).max(1) as f64;
    let level = alpha / candidates.max(1) as f64;
    match StudentsT::new(0.0, 1.0, dof) {
        Ok(t) => t.inverse_cdf(1.0 - level),
        Err(_) => f64::INFINITY,
    }
}

/// The per-fold SSE difference of two effects as a test of `a` over `b`, both measured
/// against the same base: is `a` better than `b` beyond the fold-to-fold spread?
pub fn paired_test(base: &FoldScores, a: &FoldScores, b: &FoldScores, cv: bool) -> FoldTest {
    // b plays the "without": a gain > 0 means a fits better than b; normalised by the base
    // so that folds with more structure do not dominate
    let k = base.sse.len().min(a.sse.len()).min(b.sse.len());
    let rel = |s: &FoldScores| FoldScores {
        sse: (0..k).map(|i| s.sse[i] / base.sse[i].max(1e-300)).collect(),
        sst: s.sst[..k].to_vec(),
    };
    let (ra, rb) = (rel(a), rel(b));
    // gains as differences of relative errors (not ratios): rb − ra
    let diffs: Vec<f64> = (0..k).map(|i| rb.sse[i] - ra.sse[i]).collect();
    let n = diffs.len();
    if n < 2 {
        return FoldTest::default();
    }
    let mean = diffs.iter().sum::<f64>() / n as f64;
    let var = diffs.iter().map(|d| (d - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
    let factor = if cv {
        1.0 / n as f64 + 1.0 / (n - 1) as f64
    } else {
        1.0 / n as f64
    };
    let se = (var * factor).sqrt();
    let wins = diffs.iter().filter(|d| **d > 0.0).count();
    FoldTest {
        wins,
        sign_p: sign_test_p(wins, n),
        improvement: mean,
        fold_mean: mean,
        fold_sd: var.sqrt(),
        folds: n,
        t: if se > 0.0 { mean / se } else { 0.0 },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scores(sse: &[f64]) -> FoldScores {
        FoldScores {
            sse: sse.to_vec(),
            sst: vec![1.0; sse.len()],
        }
    }

    #[test]
    fn a_consistent_gain_is_significant_and_noise_is_not() {
        let base = scores(&[10.0; 10]);
        let better = scores(&[8.0, 8.1, 7.9, 8.0, 8.2, 7.8, 8.0, 8.1, 7.9, 8.0]);
        let t = fold_test(&base, &better, true);
        assert!((t.improvement - 0.2).abs() < 1e-3);
        assert!(t.t > t_critical(10, 0.05, 10), "{t:?}");
        let noisy = scores(&[9.0, 11.0, 9.5, 10.6, 9.8, 10.1, 9.2, 10.9, 10.0, 9.9]);
        let t = fold_test(&base, &noisy, true);
        assert!(t.t < t_critical(10, 0.05, 1), "{t:?}");
    }

    #[test]
    fn the_sign_test_counts_folds() {
        assert!((sign_test_p(10, 10) - 1.0 / 1024.0).abs() < 1e-12);
        assert!((sign_test_p(9, 10) - 11.0 / 1024.0).abs() < 1e-12);
        assert!((sign_test_p(0, 10) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn the_critical_value_grows_with_the_candidates() {
        let one = t_critical(10, 0.05, 1);
        assert!((one - 1.833).abs() < 0.01, "{one}");
        assert!(t_critical(10, 0.05, 10) > 2.8);
    }

    #[test]
    fn two_equal_effects_cannot_be_told_apart() {
        let base = scores(&[10.0; 6]);
        let a = scores(&[8.0, 8.3, 7.7, 8.1, 7.9, 8.0]);
        let b = scores(&[8.1, 8.0, 7.9, 8.0, 8.0, 7.9]);
        assert!(paired_test(&base, &a, &b, true).t.abs() < 2.0);
        let c = scores(&[9.5, 9.6, 9.4, 9.5, 9.6, 9.5]);
        assert!(paired_test(&base, &a, &c, true).t > 5.0);
    }
}
