//! The rows of a trial that a fit is scored on and never fitted to.
//!
//! A dynamic trial (and a step trial with few steps) holds out its last 20 %. A step trial
//! with at least [`MIN_STEPS_INTERLEAVED`] steps holds out every fifth step instead: the
//! thesis's protocol (§5.2) steps X first and Y after, so its last fifth holds Y's steps
//! only, and an effect that shows on X's steps alone would have no held-out evidence
//! (docs/model-loop.md, "Which rows are held out"). A step model is driven by the
//! converters' set-points, not by the measured force, so a held-out step in the middle of
//! the log is as unseen by the fit as the log's end.

use crate::step_detection::ReferenceStep;
use std::ops::Range;

/// Fewest steps for which every fifth one is held out (two held-out steps at least);
/// below it the last 20 % is.
pub const MIN_STEPS_INTERLEAVED: usize = 10;

/// Of every `EVERY_NTH_STEP` steps, the last is held out (a fifth, as the tail's 20 %).
const EVERY_NTH_STEP: usize = 5;

/// How the held-out rows were chosen.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HeldOutKind {
    /// The last 20 % of the trial.
    LastFifth,
    /// Every fifth step of the reference, from its start to the next step.
    EveryFifthStep,
    /// Nothing: a fit on every row.
    Nothing,
}

/// The held-out rows of a trial of `n` samples: sorted, disjoint ranges.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct HeldOut {
    n: usize,
    ranges: Vec<Range<usize>>,
    kind: HeldOutKind,
    /// The reference's steps, fitted and held out, when every fifth is held out.
    steps: Option<usize>,
}

impl HeldOut {
    /// The last 20 % of `n` samples (from ⌊4n/5⌋).
    pub fn last_fifth(n: usize) -> Self {
        let split = (n * 4) / 5;
        HeldOut {
            n,
            ranges: std::iter::once(split..n)
                .filter(|r| !r.is_empty())
                .collect(),
            kind: HeldOutKind::LastFifth,
            steps: None,
        }
    }

    /// No row held out: a fit on all `n`.
    pub fn nothing(n: usize) -> Self {
        HeldOut {
            n,
            ranges: Vec::new(),
            kind: HeldOutKind::Nothing,
            steps: None,
        }
    }

    /// Every fifth of `steps` (the 5th, 10th, …: each held-out step follows four fitted
    /// ones), or `None` with fewer than [`MIN_STEPS_INTERLEAVED`] steps. `levels[k]` is
    /// step k's reference (both axes). A step whose level lies outside the levels of the
    /// fitted steps is not held out but a neighbour within them is: the fitted rows would
    /// say nothing of that level, so any parameter acting there alone (a knee above every
    /// fitted command) is free, and the held-out score would judge a guess.
    pub fn every_fifth_step(
        steps: &[ReferenceStep],
        levels: &[[f64; 2]],
        n: usize,
    ) -> Option<Self> {
        if steps.len() < MIN_STEPS_INTERLEAVED || levels.len() != steps.len() {
            return None;
        }
        let mut held: Vec<usize> = Vec::new();
        for k in (EVERY_NTH_STEP - 1..steps.len()).step_by(EVERY_NTH_STEP) {
            // k, then its neighbours outwards, the first whose level the others span
            let candidates = (0..EVERY_NTH_STEP as isize / 2 + 1)
                .flat_map(|d| [k as isize + d, k as isize - d])
                .filter_map(|c| usize::try_from(c).ok())
                .filter(|&c| c < steps.len() && !held.contains(&c));
            for c in candidates {
                if spanned(levels, &held, c) {
                    held.push(c);
                    break;
                }
            }
        }
        held.sort_unstable();
        let ranges: Vec<Range<usize>> = held
            .iter()
            .map(|&k| steps[k].start.min(n)..steps[k].end.min(n))
            .filter(|r| !r.is_empty())
            .collect();
        let sorted = ranges.windows(2).all(|w| w[0].end <= w[1].start);
        (sorted && !ranges.is_empty()).then_some(HeldOut {
            n,
            ranges,
            kind: HeldOutKind::EveryFifthStep,
            steps: Some(steps.len()),
        })
    }

    /// The folds of a cross-validation over `steps`: fold j holds out steps j, j + k,
    /// j + 2k, … of `k` = `folds`, each one whose level the steps the fold fits span (as in
    /// [`HeldOut::every_fifth_step`]; one outside them stays fitted, in every fold). Every
    /// step is held out once at most, so the folds together score nearly every step on a
    /// fit that never saw it. Empty with fewer steps than folds.
    pub fn step_folds(
        steps: &[ReferenceStep],
        levels: &[[f64; 2]],
        n: usize,
        folds: usize,
    ) -> Vec<Self> {
        if folds < 2 || steps.len() < folds || levels.len() != steps.len() {
            return Vec::new();
        }
        (0..folds)
            .filter_map(|j| {
                let fold: Vec<usize> = (j..steps.len()).step_by(folds).collect();
                // the fold's other steps are held out too: a level is spanned by the rest
                let ranges: Vec<Range<usize>> = fold
                    .iter()
                    .filter(|&&c| {
                        let others: Vec<usize> = fold.iter().copied().filter(|&o| o != c).collect();
                        spanned(levels, &others, c)
                    })
                    .map(|&k| steps[k].start.min(n)..steps[k].end.min(n))
                    .filter(|r| !r.is_empty())
                    .collect();
                (!ranges.is_empty()).then_some(HeldOut {
                    n,
                    ranges,
                    kind: HeldOutKind::EveryFifthStep,
                    steps: Some(steps.len()),
                })
            })
            .collect()
    }

    pub fn kind(&self) -> HeldOutKind {
        self.kind
    }

    /// The reference's steps, fitted and held out, when every fifth is held out.
    pub fn steps(&self) -> Option<usize> {
        self.steps
    }

    /// First row of the held-out tail (the last range, if it runs to the trial's end), else
    /// the trial's length: for the last fifth, ⌊4n/5⌋.
    pub fn tail_start(&self) -> usize {
        match self.ranges.last() {
            Some(r) if r.end == self.n => r.start,
            _ => self.n,
        }
    }

    /// The held-out ranges, in time order.
    pub fn ranges(&self) -> &[Range<usize>] {
        &self.ranges
    }

    /// The held-out rows, in time order.
    pub fn rows(&self) -> impl Iterator<Item = usize> + '_ {
        self.ranges.iter().flat_map(|r| r.clone())
    }

    /// Number of held-out rows.
    pub fn len(&self) -> usize {
        self.ranges.iter().map(|r| r.len()).sum()
    }

    pub fn is_empty(&self) -> bool {
        self.ranges.is_empty()
    }

    /// The fitted (training) ranges, in time order: the complement of the held-out ones.
    pub fn train_ranges(&self) -> Vec<Range<usize>> {
        let mut out = Vec::with_capacity(self.ranges.len() + 1);
        let mut start = 0;
        for r in &self.ranges {
            if r.start > start {
                out.push(start..r.start);
            }
            start = r.end;
        }
        if start < self.n {
            out.push(start..self.n);
        }
        out
    }

    /// The fitted (training) rows, in time order.
    pub fn train_rows(&self) -> impl Iterator<Item = usize> {
        self.train_ranges().into_iter().flatten()
    }

    /// One past the last training row: a simulation that fits the training rows need not
    /// run further.
    pub fn train_end(&self) -> usize {
        self.train_ranges().last().map_or(0, |r| r.end)
    }

    /// Is row `i` held out?
    pub fn contains(&self, i: usize) -> bool {
        let k = self.ranges.partition_point(|r| r.end <= i);
        self.ranges.get(k).is_some_and(|r| r.contains(&i))
    }

    /// How the fits were fitted and scored, for a report's first line.
    pub fn describe(&self) -> String {
        match self.kind {
            HeldOutKind::LastFifth => "fitted on the first 80 %, scored on the last 20 %".into(),
            HeldOutKind::EveryFifthStep => format!(
                "fitted on four steps of every five, scored on the fifth ({} steps held out, {:.0} % of the samples)",
                self.ranges.len(),
                100.0 * self.len() as f64 / self.n.max(1) as f64
            ),
            HeldOutKind::Nothing => "fitted and scored on every sample".into(),
        }
    }

    /// How a report names the held-out part.
    pub fn label(&self) -> &'static str {
        match self.kind {
            HeldOutKind::LastFifth => "held-out 20 %",
            HeldOutKind::EveryFifthStep => "held out",
            HeldOutKind::Nothing => "",
        }
    }
}

/// Does the level of step `c` lie within the levels of the steps that would be fitted
/// (all but `held` and `c`), on both axes?
fn spanned(levels: &[[f64; 2]], held: &[usize], c: usize) -> bool {
    (0..2).all(|a| {
        let fitted = levels
            .iter()
            .enumerate()
            .filter(|(k, _)| *k != c && !held.contains(k))
            .map(|(_, l)| l[a]);
        let (lo, hi) = fitted.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
        // a tolerance for the reference's rounding
        let tol = 1e-6 * (hi - lo).abs().max(1.0);
        levels[c][a] >= lo - tol && levels[c][a] <= hi + tol
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Steps every 100 samples from 50; the first half on X, the rest on Y.
    fn steps(count: usize, n: usize) -> Vec<ReferenceStep> {
        let starts: Vec<usize> = (0..count).map(|k| 50 + 100 * k).collect();
        starts
            .iter()
            .enumerate()
            .map(|(k, &start)| ReferenceStep {
                start,
                end: starts.get(k + 1).copied().unwrap_or(n),
                axis: usize::from(k >= count / 2),
            })
            .collect()
    }

    /// The §5.2 levels: 12 on X, then the same 12 on Y.
    fn levels_x_then_y() -> Vec<[f64; 2]> {
        let cycle = [
            9.0, 18.0, 27.0, 18.0, 9.0, 0.0, -9.0, -18.0, -27.0, -18.0, -9.0, 0.0,
        ];
        let mut v: Vec<[f64; 2]> = cycle.iter().map(|&x| [x, 0.0]).collect();
        v.extend(cycle.iter().map(|&y| [0.0, y]));
        v
    }

    #[test]
    fn the_last_fifth_is_a_tail_and_its_complement_the_head() {
        let h = HeldOut::last_fifth(100);
        assert_eq!(h.ranges().to_vec(), vec![(80..100)]);
        assert_eq!(h.train_ranges(), vec![0..80]);
        assert_eq!(h.train_end(), 80);
        assert_eq!(h.tail_start(), 80);
        assert_eq!(HeldOut::last_fifth(0).tail_start(), 0);
        assert_eq!(HeldOut::nothing(7).tail_start(), 7);
        assert_eq!(h.len(), 20);
        assert!(h.contains(80) && h.contains(99) && !h.contains(79) && !h.contains(100));
        assert_eq!(h.rows().count() + h.train_rows().count(), 100);
    }

    #[test]
    fn every_fifth_step_holds_out_steps_of_both_axes() {
        let n = 2450;
        let s = steps(24, n);
        let h = HeldOut::every_fifth_step(&s, &levels_x_then_y(), n).expect("24 steps");
        assert_eq!(h.kind(), HeldOutKind::EveryFifthStep);
        let held: Vec<usize> = (0..24).filter(|&k| h.contains(s[k].start)).collect();
        // step 14 is Y's only step to +27 N: its neighbour 15 is held out instead
        assert_eq!(held, vec![4, 9, 15, 19]);
        assert!(held.iter().any(|&k| s[k].axis == 0) && held.iter().any(|&k| s[k].axis == 1));
        // the rest before the first step and the last steps are fitted
        assert!(!h.contains(0) && !h.contains(n - 1));
        assert_eq!(h.train_end(), n);
        assert_eq!(h.len(), 400);
        let mut all: Vec<usize> = h.rows().chain(h.train_rows()).collect();
        all.sort_unstable();
        assert_eq!(all, (0..n).collect::<Vec<_>>());
        // the last fifth of the same log holds Y's steps only
        let tail = HeldOut::last_fifth(n);
        assert!((0..24)
            .filter(|&k| tail.contains(s[k].start))
            .all(|k| s[k].axis == 1));
    }

    #[test]
    fn the_step_folds_hold_out_every_step_once() {
        let n = 2450;
        let s = steps(24, n);
        let folds = HeldOut::step_folds(&s, &levels_x_then_y(), n, 5);
        assert_eq!(folds.len(), 5);
        let held_in = |k: usize| folds.iter().filter(|f| f.contains(s[k].start)).count();
        // steps 2, 8, 14 and 20 are each axis's only step to ±27 N: fitted in every fold;
        // every other step is held out once
        let extremes = [2, 8, 14, 20];
        for k in 0..24 {
            assert_eq!(held_in(k), usize::from(!extremes.contains(&k)), "step {k}");
        }
        // fold j holds out steps j, j + 5, …
        assert!(folds[1].contains(s[1].start) && folds[1].contains(s[16].start));
        assert!(!folds[1].contains(s[2].start) && !folds[1].contains(0));
        // too few steps for the folds: none
        assert!(HeldOut::step_folds(&s[..4], &levels_x_then_y()[..4], n, 5).is_empty());
    }

    #[test]
    fn a_level_no_fitted_step_reaches_is_not_held_out() {
        let n = 2450;
        let s = steps(24, n);
        // step 4 is the only one at 40 N on X, step 9 the only one at −40 N
        let mut levels = levels_x_then_y();
        levels[4] = [40.0, 0.0];
        levels[9] = [-40.0, 0.0];
        let h = HeldOut::every_fifth_step(&s, &levels, n).expect("24 steps");
        let held: Vec<usize> = (0..24).filter(|&k| h.contains(s[k].start)).collect();
        assert_eq!(held, vec![5, 10, 15, 19]);
    }

    #[test]
    fn few_steps_keep_the_last_fifth() {
        let levels: Vec<[f64; 2]> = (0..9).map(|k| [k as f64, 0.0]).collect();
        assert!(HeldOut::every_fifth_step(&steps(9, 1000), &levels, 1000).is_none());
    }
}
