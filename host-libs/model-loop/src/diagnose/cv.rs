//! Blocked cross-validation over time for dynamic trials.
//!
//! The trial is cut into [`FOLDS`] contiguous blocks. Each block in turn is held out, the
//! model (base variant, and the effect's shape, chosen again on the other blocks) is fitted
//! on the rest and scored on it. Normal equations add over rows, so each candidate's
//! per-block normal equations are computed once and every fold's training normal is the
//! total minus its block: a fold costs a few small solves, not a pass over the data.
//! The trial is on the 5 ms analysis grid ([`analysis_trial`]): every row is scored.

use super::Loop;
use super::ModelFit;
use crate::effects::DynCtx;
use crate::effects::DynTerm;
use crate::effects::ModelEffect;
use crate::effects::Shape;
use pam_numerics::lsq;
use std::ops::Range;

/// Number of contiguous folds.
pub const FOLDS: usize = 10;

/// Held-out sums of squares per fold, pooled over the scored axes.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FoldScores {
    /// Σ residual² on each held-out block.
    pub sse: Vec<f64>,
    /// Σ (measured − block mean)² on each held-out block.
    pub sst: Vec<f64>,
}

impl FoldScores {
    /// Σ sse / Σ sst: the cross-validated relative MSE.
    pub fn relative_mse(&self) -> f64 {
        let s: f64 = self.sst.iter().sum();
        if s > 0.0 {
            self.sse.iter().sum::<f64>() / s
        } else {
            f64::NAN
        }
    }
}

/// Per-block data shared by every candidate: the blocks, their Σy² and Σ(y − ȳ)², and
/// each base variant's normal equations on each block.
pub(super) struct CvCache {
    blocks: Vec<Range<usize>>,
    yty: Vec<f64>,
    sst: Vec<f64>,
    base: Vec<Vec<lsq::Normal>>,
}

fn add_into(acc: &mut lsq::Normal, n: &lsq::Normal, sign: f64) {
    if acc.rhs.is_empty() {
        acc.rhs = vec![0.0; n.rhs.len()];
        acc.gram = vec![vec![0.0; n.rhs.len()]; n.rhs.len()];
    }
    for (a, b) in acc.rhs.iter_mut().zip(&n.rhs) {
        *a += sign * b;
    }
    for (ra, rb) in acc.gram.iter_mut().zip(&n.gram) {
        for (a, b) in ra.iter_mut().zip(rb) {
            *a += sign * b;
        }
    }
}

fn empty_normal() -> lsq::Normal {
    lsq::Normal {
        gram: Vec::new(),
        rhs: Vec::new(),
    }
}

/// One candidate model of a fold's choice: its variant, columns and per-block normals.
struct Candidate {
    variant: usize,
    ncols: usize,
    positive: Vec<usize>,
    blocks: Vec<lsq::Normal>,
    total: lsq::Normal,
    /// Σ y² of the candidate's target (shifted for a delay) on each block.
    yty: Vec<f64>,
}

impl<'a> Loop<'a> {
    pub(super) fn cv_cache(&self) -> &CvCache {
        self.cv.get_or_init(|| {
            let p = &self.p;
            // the last rows are left out of every fold: a delay's target is the force
            // `shift` samples later, which the log does not hold there (the last sample
            // stands in), so a delay's last fold lost on rows no model could fit; the
            // same rows go for every model, so the comparison stays fair
            let tail = (crate::effects::MAX_DYNAMIC_DELAY_S / p.dt_s).ceil() as usize + 1;
            let n = p.len() - tail.min(p.len() / 20);
            let blocks: Vec<Range<usize>> = (0..FOLDS)
                .map(|k| (k * n / FOLDS)..((k + 1) * n / FOLDS))
                .collect();
            let t0 = self.target(0);
            let y = &t0.y;
            let target = [y[0].as_slice(), y[1].as_slice()];
            let mut yty = Vec::new();
            let mut sst = Vec::new();
            for r in &blocks {
                let (mut s2, mut st) = (0.0, 0.0);
                for a in 0..2 {
                    let v = &y[a][r.clone()];
                    let m = v.iter().sum::<f64>() / v.len().max(1) as f64;
                    s2 += v.iter().map(|x| x * x).sum::<f64>();
                    st += v.iter().map(|x| (x - m).powi(2)).sum::<f64>();
                }
                yty.push(s2);
                sst.push(st);
            }
            let base = self
                .base_variants
                .iter()
                .map(|bv| {
                    blocks
                        .iter()
                        .map(|r| lsq::normal_equations(&bv.cols, &target, r.clone()))
                        .collect()
                })
                .collect();
            CvCache {
                blocks,
                yty,
                sst,
                base,
            }
        })
    }

    fn candidate(
        &self,
        v: usize,
        terms: &[DynTerm],
        memo: &mut lsq::GramMemo,
    ) -> Option<Candidate> {
        let (cols, _, positive, shift, nb) = self.assemble(v, terms)?;
        let c = self.cv_cache();
        let t = self.target(shift);
        let blocks: Vec<lsq::Normal> = c
            .blocks
            .iter()
            .enumerate()
            .map(|(b, r)| {
                let known = c.base[v][b].prefix(nb);
                Self::normal_with_known(&known, &cols, &t.y, shift, r.clone(), memo)
            })
            .collect();
        let yty = if shift == 0 {
            c.yty.clone()
        } else {
            c.blocks
                .iter()
                .map(|r| {
                    (0..2)
                        .map(|a| t.y[a][r.clone()].iter().map(|v| v * v).sum::<f64>())
                        .sum()
                })
                .collect()
        };
        let mut total = empty_normal();
        for b in &blocks {
            add_into(&mut total, b, 1.0);
        }
        Some(Candidate {
            variant: v,
            ncols: cols.len(),
            positive,
            blocks,
            total,
            yty,
        })
    }

    /// Cross-validated scores of the base plus `fixed` effects (their shapes as chosen on
    /// the training part) plus, when given, one more effect whose shape each fold chooses
    /// among `shapes`. Every fold also chooses the base variant.
    pub(super) fn cv_dynamic(
        &self,
        fixed: &[&dyn ModelEffect],
        free: Option<(&dyn ModelEffect, &[Shape])>,
    ) -> FoldScores {
        let ctx = DynCtx::new(&self.p, self.model);
        let mut terms: Vec<DynTerm> = fixed
            .iter()
            .map(|e| e.dynamic_term(&ctx, &self.choose_shape(&ctx, *e)))
            .collect();
        let mut candidates = Vec::new();
        let free_terms: Vec<Option<DynTerm>> = match free {
            Some((e, shapes)) => shapes
                .iter()
                .map(|s| Some(e.dynamic_term(&ctx, s)))
                .collect(),
            None => vec![None],
        };
        // the terms' columns against every shortlisted variant's, block by block: the
        // products the variants share are computed once
        let mut memo = lsq::GramMemo::default();
        for ft in free_terms {
            if let Some(t) = ft {
                terms.push(t);
            }
            for &v in self.shortlist() {
                if let Some(c) = self.candidate(v, &terms, &mut memo) {
                    candidates.push(c);
                }
            }
            if free.is_some() {
                terms.pop();
            }
        }
        let cache = self.cv_cache();
        let mut out = FoldScores::default();
        for k in 0..cache.blocks.len() {
            let mut best: Option<(f64, Vec<f64>, usize)> = None;
            for (ci, c) in candidates.iter().enumerate() {
                let mut train = empty_normal();
                add_into(&mut train, &c.total, 1.0);
                add_into(&mut train, &c.blocks[k], -1.0);
                let yty: f64 = c.yty.iter().sum::<f64>() - c.yty[k];
                let th = self.solve_dynamic(&train, &c.positive);
                let crit = self.criterion(lsq::rss(&train, yty, &th), c.ncols, c.variant);
                if best.as_ref().is_none_or(|b| crit < b.0) {
                    best = Some((crit, th, ci));
                }
            }
            let Some((_, th, ci)) = best else {
                continue;
            };
            let sse = lsq::rss(&candidates[ci].blocks[k], candidates[ci].yty[k], &th).max(0.0);
            out.sse.push(sse);
            out.sst.push(cache.sst[k]);
        }
        out
    }
}

/// Shapes of a free effect each fold chooses among: the best few on the training part.
pub(super) const FREE_SHAPES: usize = 3;

impl<'a> Loop<'a> {
    /// Cross-validated scores of the base plus `fixed` plus `e`, whose shape each fold
    /// chooses among its best few.
    pub(super) fn cv_effect(&self, fixed: &[&dyn ModelEffect], e: &dyn ModelEffect) -> FoldScores {
        let ctx = DynCtx::new(&self.p, self.model);
        let mut shapes = self.ranked_shapes(&ctx, e);
        shapes.truncate(FREE_SHAPES);
        self.cv_dynamic(fixed, Some((e, &shapes)))
    }
}

/// Blocks the held-out part of a step trial is scored in.
pub(super) const STEP_BLOCKS: usize = 6;

/// Held-out sums of squares of a fit in `blocks` blocks of its held-out rows, in time
/// order, each of the same number of rows.
pub(super) fn held_out_blocks(f: &ModelFit, blocks: usize) -> FoldScores {
    let rows: Vec<usize> = f.held_out.rows().collect();
    let len = rows.len();
    let mut out = FoldScores::default();
    for b in 0..blocks {
        let r = &rows[b * len / blocks..(b + 1) * len / blocks];
        let (sse, sst) = scores_on(&f.measured, &f.predicted, &f.axes, r.iter().copied());
        out.sse.push(sse);
        out.sst.push(sst);
    }
    out
}

/// Σ (measured − predicted)² and Σ (measured − its mean)² over `axes` on `rows`.
pub(super) fn scores_on(
    measured: &[Vec<f64>; 2],
    predicted: &[Vec<f64>; 2],
    axes: &[usize],
    rows: impl Iterator<Item = usize> + Clone,
) -> (f64, f64) {
    let (mut sse, mut sst) = (0.0, 0.0);
    let count = rows.clone().count().max(1) as f64;
    for &a in axes {
        let (m, p) = (&measured[a], &predicted[a]);
        let mean = rows.clone().map(|i| m[i]).sum::<f64>() / count;
        sse += rows.clone().map(|i| (m[i] - p[i]).powi(2)).sum::<f64>();
        sst += rows.clone().map(|i| (m[i] - mean).powi(2)).sum::<f64>();
    }
    (sse, sst)
}
