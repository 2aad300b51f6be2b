//! The statistics that accept an effect and that say when two cannot be told apart.
//!
//! An effect's gain is measured fold by fold (blocked cross-validation over time, or
//! contiguous blocks of the held-out part): r_k = 1 − SSE_k(with) / SSE_k(without). Its mean
//! must exceed the fold-to-fold spread — a one-sided t-test — or its gains must be positive
//! beyond chance by their signs and ranks — Wilcoxon's signed-rank test, robust to gains
//! that differ from fold to fold (a drift's, largest at the ends; a cubic's, large only
//! where the operator went far) and to a few small losing folds. Each takes half the
//! level; the level is per family unless `Settings::bonferroni` splits it over the families.
//! (A plain sign test was used before: it rejected effects that lost two folds by a little
//! and won eight by much, and on 80 controls of the second generator the rank test raised
//! no false alarm either; docs/model-loop.md.)
//! Cross-validation folds share most of their training data, which makes the r_k
//! correlated; the t-test's variance then uses Nadeau and Bengio's correction (1/K +
//! n_test/n_train instead of 1/K), and the signed-rank test's null variance is widened by
//! the same factor, which keeps both at their level.

use super::cv::FoldScores;
use statrs::distribution::{ContinuousCDF, Normal, StudentsT};

/// The gain of one model over another, fold by fold.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct FoldTest {
    /// 1 − Σ SSE(with) / Σ SSE(without), pooled over the folds.
    pub improvement: f64,
    /// The same pooled gain with the fold that gains most (in SSE) left out: a pooled gain
    /// that one fold carries is that fold's evidence alone.
    pub improvement_without_best: f64,
    /// Mean and standard deviation of the per-fold gains.
    pub fold_mean: f64,
    pub fold_sd: f64,
    pub folds: usize,
    /// Mean over its (corrected) standard error.
    pub t: f64,
    /// Folds where the effect fits better, and the one-sided sign-test p-value of that
    /// count (reported; the decision uses `rank_p`).
    pub wins: usize,
    pub sign_p: f64,
    /// The one-sided p-value of Wilcoxon's signed-rank test on the per-fold gains: the
    /// sign test weighted by the gains' ranks, so that a few small losing folds do not
    /// outweigh large winning ones (an effect seen only where the trial goes far). Exact
    /// on held-out blocks; on cross-validated folds its null is widened for their overlap.
    pub rank_p: f64,
    /// The per-fold gains r_k, in fold order.
    pub gains: Vec<f64>,
}

/// The values' signs and doubled ranks (1-based, ties given their mean rank, so that
/// twice a mean rank stays an integer), zeros and non-finite values dropped: W⁺ and the
/// ranks.
fn doubled_ranks(values: &[f64]) -> (usize, Vec<usize>) {
    let mut nz: Vec<f64> = values
        .iter()
        .copied()
        .filter(|v| *v != 0.0 && v.is_finite())
        .collect();
    let n = nz.len();
    nz.sort_by(|a, b| a.abs().total_cmp(&b.abs()));
    let mut rank2 = vec![0usize; n];
    let mut i = 0;
    while i < n {
        let mut j = i;
        while j + 1 < n && nz[j + 1].abs() == nz[i].abs() {
            j += 1;
        }
        for r in rank2.iter_mut().take(j + 1).skip(i) {
            *r = i + j + 2; // (i+1 + j+1), twice the mean rank
        }
        i = j + 1;
    }
    let w_plus: usize = (0..n).filter(|&k| nz[k] > 0.0).map(|k| rank2[k]).sum();
    (w_plus, rank2)
}

/// Wilcoxon's signed-rank test, one-sided (the values are positive), exact: P(W⁺ ≥ w⁺)
/// under the null of values symmetric about zero. Zeros are dropped; tied magnitudes get
/// their mean rank (counted in half ranks so the null distribution stays exact over the
/// sign flips).
pub fn signed_rank_p(values: &[f64]) -> f64 {
    let (w_plus, rank2) = doubled_ranks(values);
    let n = rank2.len();
    if n == 0 {
        return 1.0;
    }
    let total: usize = rank2.iter().sum();
    // the number of sign patterns giving each W⁺ (in half ranks)
    let mut ways = vec![0.0f64; total + 1];
    ways[0] = 1.0;
    for &r in &rank2 {
        for s in (r..=total).rev() {
            ways[s] += ways[s - r];
        }
    }
    let tail: f64 = ways[w_plus..].iter().sum();
    tail / 2f64.powi(n as i32)
}

/// The signed-rank test on the gains of cross-validated folds. Every two folds share most
/// of their training rows, so their gains are positively correlated and the exact test,
/// which takes them as independent, would count one fit's luck once per fold. W⁺'s
/// variance under the null is widened by the t-test's correction
/// ([`mean_variance_factor`] over its value for independent gains, 1 + n/(n − 1)), in the
/// normal approximation with a continuity correction.
pub fn signed_rank_p_cross_validated(values: &[f64]) -> f64 {
    let (w_plus, rank2) = doubled_ranks(values);
    let n = rank2.len();
    if n < 2 {
        return 1.0;
    }
    // in half ranks: each rank adds r/2 with probability ½
    let mean = rank2.iter().sum::<usize>() as f64 / 2.0;
    let variance = rank2.iter().map(|&r| (r * r) as f64).sum::<f64>() / 4.0;
    let widened = variance * n as f64 * mean_variance_factor(n, true);
    // one half rank step (doubled units: 1) as the continuity correction
    let z = (w_plus as f64 - mean - 1.0) / widened.sqrt();
    Normal::standard().sf(z)
}

/// The signed-rank test's p on fold gains: widened on cross-validated folds, exact on
/// held-out blocks of one fit.
fn rank_p(values: &[f64], cross_validated: bool) -> f64 {
    if cross_validated {
        signed_rank_p_cross_validated(values)
    } else {
        signed_rank_p(values)
    }
}

/// The variance of the mean of `n` fold gains over one gain's: 1/n for independent folds,
/// Nadeau and Bengio's 1/n + 1/(n − 1) for cross-validated folds (their training sets
/// overlap; n_test/n_train = 1/(n − 1) for n equal folds).
fn mean_variance_factor(n: usize, cross_validated: bool) -> f64 {
    if cross_validated && n > 1 {
        1.0 / n as f64 + 1.0 / (n - 1) as f64
    } else {
        1.0 / n.max(1) as f64
    }
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
    /// The gain is significant at `level`: by the t-test or by the signed-rank test, each
    /// at half the level.
    pub fn significant(&self, t_critical_half: f64, level: f64) -> bool {
        self.t >= t_critical_half || (self.folds > 0 && self.rank_p <= level / 2.0)
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
    let se = (var * mean_variance_factor(n, cross_validated)).sqrt();
    let (sw, sb): (f64, f64) = (with.sse[..k].iter().sum(), without.sse[..k].iter().sum());
    let wins = gains.iter().filter(|g| **g > 0.0).count();
    let best = (0..k)
        .max_by(|&i, &j| (without.sse[i] - with.sse[i]).total_cmp(&(without.sse[j] - with.sse[j])));
    let (sw_rest, sb_rest) = best.map_or((sw, sb), |b| (sw - with.sse[b], sb - without.sse[b]));
    FoldTest {
        wins,
        sign_p: sign_test_p(wins, n),
        rank_p: rank_p(&gains, cross_validated),
        gains: gains.clone(),
        improvement: if sb > 0.0 { 1.0 - sw / sb } else { 0.0 },
        improvement_without_best: if k > 1 && sb_rest > 0.0 {
            1.0 - sw_rest / sb_rest
        } else {
            0.0
        },
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
    let se = (var * mean_variance_factor(n, cv)).sqrt();
    let wins = diffs.iter().filter(|d| **d > 0.0).count();
    FoldTest {
        wins,
        sign_p: sign_test_p(wins, n),
        rank_p: rank_p(&diffs, cv),
        gains: diffs.clone(),
        improvement: mean,
        improvement_without_best: mean,
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
    fn the_signed_rank_test_weighs_the_losing_folds_by_their_size() {
        // all ten positive: the same as the sign test
        let all: Vec<f64> = (1..=10).map(|k| k as f64).collect();
        assert!((signed_rank_p(&all) - 1.0 / 1024.0).abs() < 1e-12);
        // the two smallest lose: W⁺ = 52, P(W⁺ ≥ 52) = P(W⁻ ≤ 3) = 5/1024
        let mut small_losses = all.clone();
        small_losses[0] = -1.0;
        small_losses[1] = -2.0;
        assert!((signed_rank_p(&small_losses) - 5.0 / 1024.0).abs() < 1e-12);
        // the two largest lose: W⁻ = 19, far from significant
        let mut large_losses = all.clone();
        large_losses[8] = -9.0;
        large_losses[9] = -10.0;
        assert!(signed_rank_p(&large_losses) > 0.1);
        // symmetric values: about one half
        let sym = [-3.0, -1.0, 1.0, 3.0, -2.0, 2.0];
        let p = signed_rank_p(&sym);
        assert!(p > 0.4 && p < 0.7, "{p}");
        // ties share their rank; the null stays a distribution (p = 1 at W⁺ = 0)
        assert!((signed_rank_p(&[-1.0, -1.0, -2.0]) - 1.0).abs() < 1e-12);
        assert!((signed_rank_p(&[1.0, 1.0, 1.0]) - 1.0 / 8.0).abs() < 1e-12);
    }

    #[test]
    fn a_pooled_gain_one_fold_carries_is_nothing_without_it() {
        let base = scores(&[1.0, 1.0, 10.0, 1.0, 1.0, 1.0]);
        // one fold the base misses badly, fixed; the others a little worse
        let one = scores(&[1.02, 1.01, 2.0, 1.03, 1.0, 1.02]);
        let t = fold_test(&base, &one, false);
        assert!(t.improvement > 0.5, "{t:?}");
        assert!(t.improvement_without_best < 0.0, "{t:?}");
        // the same pooled gain spread over every fold stays with the best fold left out
        let spread = scores(&[0.4, 0.4, 4.0, 0.4, 0.4, 0.4]);
        let t = fold_test(&base, &spread, false);
        assert!((t.improvement - 0.6).abs() < 1e-9, "{t:?}");
        assert!((t.improvement_without_best - 0.6).abs() < 1e-9, "{t:?}");
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

    /// Gains of ten folds that share one component (correlation 1/9 between any two, the
    /// overlap of ten-fold cross-validation's training sets) around a zero mean: the exact
    /// test, which takes the folds as independent, rejects far more often than its level;
    /// the widened one keeps to it.
    #[test]
    fn the_rank_test_on_cross_validated_folds_keeps_its_level() {
        let mut rng = pam_twin::rng::Rng::new(4242);
        let (draws, n, rho, level) = (4000, 10, 1.0f64 / 9.0, 0.05);
        let (mut exact, mut widened) = (0usize, 0usize);
        for _ in 0..draws {
            let shared = rho.sqrt() * rng.normal();
            let gains: Vec<f64> = (0..n)
                .map(|_| shared + (1.0 - rho).sqrt() * rng.normal())
                .collect();
            exact += usize::from(signed_rank_p(&gains) <= level);
            widened += usize::from(signed_rank_p_cross_validated(&gains) <= level);
        }
        let (exact, widened) = (exact as f64 / draws as f64, widened as f64 / draws as f64);
        eprintln!("at {level}: the exact test rejects {exact}, the widened {widened}");
        assert!(exact > 1.4 * level, "exact test rejects {exact}");
        assert!(
            widened <= 1.2 * level && widened > 0.3 * level,
            "widened test rejects {widened}"
        );
        // ten winning folds of ten still pass at the level; eight of ten, losing the
        // smallest and the fourth smallest, pass the exact test only
        let all: Vec<f64> = (1..=10).map(|k| k as f64).collect();
        assert!(signed_rank_p_cross_validated(&all) <= level);
        let eight = [-1.0, 2.0, 3.0, -4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0];
        assert!(signed_rank_p(&eight) <= level);
        assert!(signed_rank_p_cross_validated(&eight) > level);
    }
}
