//! Fits of dynamic trials: the base variants plus the effects' regressors, the shape
//! choice, and the delay (a shift of the measured force, see [`Loop::target`]).

use super::base::Stiffness;
use super::cv::FREE_SHAPES;
use super::held_out_scores;
use super::BaseRanking;
use super::DynColumns;
use super::Loop;
use super::ModelFit;
use super::Target;
use super::VariantFit;
use super::Warning;
use super::SHORTLIST;
use crate::effects::DynCtx;
use crate::effects::DynTerm;
use crate::effects::Experiment;
use crate::effects::ModelEffect;
use crate::effects::Shape;
use crate::effects::ShapeParam;
use pam_ident::msd;
use pam_numerics::lsq;
use pam_numerics::lsq::Column;
use std::collections::BTreeMap;

impl<'a> Loop<'a> {
    pub(super) fn dyn_columns(
        &self,
        ctx: &DynCtx,
        variant: usize,
        effects: &[(&dyn ModelEffect, Shape)],
    ) -> Option<DynColumns> {
        let terms: Vec<DynTerm> = effects
            .iter()
            .map(|(e, s)| e.dynamic_term(ctx, s))
            .collect();
        self.assemble(variant, &terms)
    }

    /// The columns of a fit with variant `variant` and the effects' terms (computed once and
    /// shared by every variant: their columns are shared, not copied).
    pub(super) fn assemble(&self, variant: usize, terms: &[DynTerm]) -> Option<DynColumns> {
        let bv = &self.base_variants[variant];
        let preload = bv.stiffness == Stiffness::ForceLawWithPreload;
        // an effect's own constant (an offset, an equilibrium shift) replaces the base's;
        // the load cell's tare in its frame is the base's alone (an effect's fit leaves it
        // out: its turning part is near what a pose-dependent effect turns with)
        let constant = bv.offset && terms.iter().any(|t| t.carries_constant);
        let tare_out = bv.tare && !terms.is_empty();
        let nb = bv.cols.len()
            - if constant || tare_out {
                2 + if bv.tare { 2 } else { 0 }
            } else {
                0
            };
        let base_cols = &bv.cols[..nb];
        let mut positive: Vec<usize> = self.base_variants[variant].positive();
        let mut delay = 0.0f64;
        let mut lowpass_hz = 0.0f64;
        let mut extra = Vec::new();
        if tare_out && !constant {
            // the offsets, after the tare left out
            extra.extend(bv.cols[bv.cols.len() - 2..].iter().cloned());
        }
        let mut ranges = Vec::new();
        for term in terms {
            let term = term.clone();
            if preload && term.carries_constant {
                return None;
            }
            delay = delay.max(term.base_delay_s);
            if term.force_lowpass_hz > 0.0 {
                lowpass_hz = term.force_lowpass_hz;
            }
            let start = nb + extra.len();
            positive.extend(term.positive.iter().map(|i| start + i));
            extra.extend(term.columns);
            ranges.push((start, nb + extra.len()));
        }
        let mut cols = base_cols.to_vec();
        cols.extend(extra);
        let (shift, fraction) = self.delay_split(delay);
        if lowpass_hz > 0.0 {
            // the measured force is the model's through the sensor's filter, so is every
            // regressor (a new Gram block: nb = 0); each column is filtered once for all
            // the variants, shapes and folds that use it
            let mut lowpassed = self.lowpassed.lock().expect("filtered columns");
            let cols: Option<Vec<Column>> = cols
                .iter()
                .map(|c| {
                    let c = if fraction > 0.0 {
                        later_by(c, fraction)
                    } else {
                        c.clone()
                    };
                    lowpassed.column(&c, lowpass_hz, self.p.dt_s)
                })
                .collect();
            return Some((cols?, ranges, positive, shift, 0));
        }
        if fraction > 0.0 {
            // the regressors at a fraction of a sample later: their Gram block differs from
            // the cached base's, so none is reused (nb = 0)
            let cols = cols.iter().map(|c| later_by(c, fraction)).collect();
            return Some((cols, ranges, positive, shift, 0));
        }
        Some((cols, ranges, positive, shift, nb))
    }

    /// A dynamic fit's least squares: the stiffness form's parameters ≥ 0 and the mass
    /// diagonals (columns 0 and 2 of every variant) at least [`Settings::mass_floor_share`]
    /// of the robot's own Cartesian inertia. The links' inertia beyond the load cell is
    /// known from their geometry; without the floor a fit "explains" a force that lags the
    /// motion by a lower damping and a vanishing mass (f(t − τ) ≈ f − τḟ), and a delay the
    /// data shows plainly would be absorbed by a base no rig could have.
    pub(super) fn solve_dynamic(&self, ne: &lsq::Normal, positive: &[usize]) -> Vec<f64> {
        let [fx, fy] = self.mass_floor_kg;
        lsq::solve_bounded(ne, positive, &[(0, fx), (2, fy)])
    }

    /// A delay as whole samples of the measured force's shift and the fraction of a sample
    /// the regressors move later. A whole-sample delay shifts the measured force, not the
    /// regressors: every fit then shares the base's cached Gram matrix (only X'y is new).
    /// A fractional one shifts the force by the next whole sample and interpolates the
    /// regressors (filtered motion, smooth) back by the rest — not the force: interpolating
    /// the force would average its noise and favour itself.
    pub(super) fn delay_split(&self, delay_s: f64) -> (usize, f64) {
        if delay_s <= 0.0 {
            return (0, 0.0);
        }
        let samples = delay_s / self.p.dt_s;
        let whole = samples.round();
        if (samples - whole).abs() < 1e-6 {
            return (whole as usize, 0.0);
        }
        let shift = samples.ceil();
        (shift as usize, shift - samples)
    }

    /// The fit's target (−f, [`msd::target`]) `shift` samples later — the force a model
    /// of the motion at t explains when the force is sampled `shift` periods late — and
    /// its Σ y² over the training rows (cached per shift).
    pub(super) fn target(&self, shift: usize) -> std::sync::Arc<Target> {
        let mut cache = self.targets.lock().expect("target cache");
        if let Some(t) = cache.get(&shift) {
            return t.clone();
        }
        let y0 = msd::target(&self.p);
        let n = y0[0].len();
        let y = if shift == 0 {
            y0
        } else {
            y0.map(|v| (0..n).map(|i| v[(i + shift).min(n - 1)]).collect())
        };
        let yty_train = (0..2)
            .map(|a| y[a][..self.p.split()].iter().map(|v| v * v).sum::<f64>())
            .sum();
        let t = std::sync::Arc::new(Target {
            y: y.map(std::sync::Arc::new),
            yty_train,
        });
        cache.insert(shift, t.clone());
        t
    }

    /// Normal equations of `cols` (the first `nb` the variant's base columns, whose Gram
    /// block is `known`'s) against the target shifted by `shift`; `memo` serves the column
    /// products fits over the same rows share.
    pub(super) fn normal_with_known(
        known: &lsq::Normal,
        cols: &[Column],
        y: &[std::sync::Arc<Vec<f64>>; 2],
        shift: usize,
        rows: std::ops::Range<usize>,
        memo: &mut lsq::GramMemo,
    ) -> lsq::Normal {
        lsq::normal_equations_shared_target(known, cols, y, rows, memo, shift > 0)
    }

    /// Information criterion of a fit of `ncols` columns with variant `v`: the pneumatic
    /// variants count one more parameter for their chosen dynamics.
    pub(super) fn criterion(&self, rss: f64, ncols: usize, v: usize) -> f64 {
        let k = ncols + usize::from(self.base_variants[v].pneumatic.0 > 0.0);
        let n = self.n_eff.max(10.0);
        n * rss.max(1e-300).ln() + k as f64 * n.ln()
    }

    pub(super) fn choose_shape(&self, ctx: &DynCtx, e: &dyn ModelEffect) -> Shape {
        self.ranked_shapes(ctx, e)
            .into_iter()
            .next()
            .unwrap_or_default()
    }

    /// The effect's shapes, best first by the information criterion of a fit on the
    /// training rows (each with the base variant it fits best).
    pub(super) fn ranked_shapes(&self, ctx: &DynCtx, e: &dyn ModelEffect) -> Vec<Shape> {
        if let Some(s) = self.shapes.lock().expect("shape cache").get(e.id()) {
            return s.clone();
        }
        let shapes = e.shapes(ctx);
        let ranked = if shapes.len() <= 1 {
            if shapes.is_empty() {
                vec![Shape::default()]
            } else {
                shapes
            }
        } else {
            // one shape's columns against every shortlisted variant's: products shared
            let mut memo = lsq::GramMemo::default();
            let mut score = |s: Shape| -> (f64, Shape) {
                let term = [e.dynamic_term(ctx, &s)];
                let mut best = f64::INFINITY;
                for &v in self.shortlist() {
                    let Some((cols, _, positive, shift, nb)) = self.assemble(v, &term) else {
                        continue;
                    };
                    let ne = self.training_normal(v, &cols, shift, nb, &mut memo);
                    let yty = self.target(shift).yty_train;
                    let th = self.solve_dynamic(&ne, &positive);
                    let r = self.criterion(lsq::rss(&ne, yty, &th), cols.len(), v);
                    best = best.min(r);
                }
                (best, s)
            };
            let mut scored: Vec<(f64, Shape)> = shapes.into_iter().map(&mut score).collect();
            scored.sort_by(|a, b| a.0.total_cmp(&b.0));
            // the grid's best, refined between its neighbours where the effect says how
            let finer = scored
                .first()
                .map(|b| e.finer_shapes(ctx, &b.1))
                .unwrap_or_default();
            if !finer.is_empty() {
                scored.extend(finer.into_iter().map(&mut score));
                scored.sort_by(|a, b| a.0.total_cmp(&b.0));
            }
            // a sensor filter's columns: the cross-validation's shapes are the best few,
            // the other corners' are not asked for again
            let corners: Vec<f64> = scored
                .iter()
                .take(FREE_SHAPES)
                .filter_map(|b| b.1.get(ShapeParam::CornerHz))
                .collect();
            if !corners.is_empty() {
                self.lowpassed
                    .lock()
                    .expect("filtered columns")
                    .retain_corners(&corners);
            }
            scored.into_iter().map(|x| x.1).collect()
        };
        self.shapes
            .lock()
            .expect("shape cache")
            .insert(e.id(), ranked.clone());
        ranked
    }

    /// Normal equations of a fit with variant `v` on the training rows against the target
    /// shifted by `shift` (the base part's Gram block from the variant's cache).
    pub(super) fn training_normal(
        &self,
        v: usize,
        cols: &[Column],
        shift: usize,
        base_len: usize,
        memo: &mut lsq::GramMemo,
    ) -> lsq::Normal {
        let known = &self.base_variants[v].normal.prefix(base_len);
        let t = self.target(shift);
        Self::normal_with_known(known, cols, &t.y, shift, 0..self.p.split(), memo)
    }

    /// The base variants effects are fitted with: the [`SHORTLIST`] the base alone fits
    /// best by the criterion. An effect rarely turns a poor variant into the best one, and
    /// every variant costs a pass over the data per shape and per fold.
    pub(super) fn shortlist(&self) -> &[usize] {
        &self.base_ranking().shortlist
    }

    /// Training RSS of the base alone with the variant it prefers.
    pub(super) fn base_alone_rss(&self) -> f64 {
        self.base_ranking().best_rss
    }

    /// The base variants alone, ranked by the criterion on the training rows (cached).
    fn base_ranking(&self) -> &BaseRanking {
        self.base_ranking.get_or_init(|| {
            let yty = self.target(0).yty_train;
            let mut scored: Vec<(f64, f64, usize)> = (0..self.base_variants.len())
                .map(|v| {
                    let bv = &self.base_variants[v];
                    let th = self.solve_dynamic(&bv.normal, &bv.positive());
                    let r = lsq::rss(&bv.normal, yty, &th);
                    (self.criterion(r, bv.cols.len(), v), r, v)
                })
                .collect();
            // stable: among equal criteria the first variant stays first
            scored.sort_by(|a, b| a.0.total_cmp(&b.0));
            BaseRanking {
                best_rss: scored.first().map_or(f64::INFINITY, |x| x.1),
                shortlist: scored.iter().take(SHORTLIST).map(|x| x.2).collect(),
            }
        })
    }

    pub(super) fn fit_dynamic(&self, effects: &[&dyn ModelEffect]) -> ModelFit {
        let p = &self.p;
        let ctx = DynCtx::new(p, self.model);
        let y = self.target(0).y.clone().map(|v| v.to_vec());
        let chosen: Vec<(&dyn ModelEffect, Shape)> = effects
            .iter()
            .filter(|e| e.applies(Experiment::Dynamic))
            .map(|e| (*e, self.choose_shape(&ctx, *e)))
            .collect();
        // every base variant; keep the one the training part prefers
        let mut best: Option<VariantFit> = None;
        let mut memo = lsq::GramMemo::default();
        for &v in self.shortlist() {
            let Some((cols, ranges, positive, shift, nb)) = self.dyn_columns(&ctx, v, &chosen)
            else {
                continue;
            };
            let ne = self.training_normal(v, &cols, shift, nb, &mut memo);
            let theta = self.solve_dynamic(&ne, &positive);
            let r = lsq::rss(&ne, self.target(shift).yty_train, &theta);
            let c = self.criterion(r, cols.len(), v);
            if best.as_ref().is_none_or(|b| c < b.0) {
                best = Some((c, v, cols, ranges, theta, r, shift));
            }
        }
        let (_, variant, cols, ranges, theta, fit_rss, shift) = best.expect("variants");
        // the model explains the force `shift` samples late: back on the log's time base
        let pred = lsq::predict(&cols, &theta, p.len())
            .map(|v| (0..v.len()).map(|i| v[i.saturating_sub(shift)]).collect());
        let bv = &self.base_variants[variant];
        let (nrmse, r2) = held_out_scores(p, &y, &pred);
        let mut params = BTreeMap::new();
        // the base's columns end where the first effect's begin
        let nb = ranges.first().map(|r| r.0).unwrap_or(cols.len());
        let mut base: BTreeMap<String, f64> = cols[..nb]
            .iter()
            .zip(&theta)
            .map(|(c, t)| (c.name.clone(), *t))
            .collect();
        base.insert("derivative_cutoff_hz".into(), p.cutoff_hz);
        base.insert("pneumatic_omega_n_rad_s".into(), bv.pneumatic.0);
        base.insert("pneumatic_zeta".into(), bv.pneumatic.1);
        base.insert(
            "joint_space_stiffness".into(),
            if bv.stiffness == Stiffness::Joint {
                1.0
            } else {
                0.0
            },
        );
        let force_law = matches!(
            bv.stiffness,
            Stiffness::ForceLaw | Stiffness::ForceLawAbsolute | Stiffness::ForceLawWithPreload
        );
        base.insert(
            "force_law_stiffness".into(),
            if force_law { 1.0 } else { 0.0 },
        );
        if force_law {
            base.insert(
                "force_law_from_start".into(),
                if bv.stiffness == Stiffness::ForceLawAbsolute {
                    0.0
                } else {
                    1.0
                },
            );
        }
        params.insert("base".to_string(), base);
        let mut added = 0;
        for ((e, s), (a, b)) in chosen.iter().zip(&ranges) {
            let fitted: Vec<(String, f64)> = cols[*a..*b]
                .iter()
                .zip(&theta[*a..*b])
                .map(|(c, t)| (c.name.clone(), *t))
                .collect();
            added += (b - a) + s.0.len();
            params.insert(
                e.id().to_string(),
                e.report_params(&ctx, &fitted, s).into_iter().collect(),
            );
        }
        let warnings = msd::mass_checks(
            &msd::sym(&theta[0..3]),
            self.model.cartesian_mass(p.alpha0_rad),
        )
        .into_iter()
        .map(Warning::Mass)
        .collect();
        let train_gain = if chosen.is_empty() {
            0.0
        } else {
            // against the base alone, with the variant the base alone prefers
            1.0 - fit_rss / self.base_alone_rss().max(1e-300)
        };
        ModelFit {
            experiment: Experiment::Dynamic,
            effect_ids: chosen.iter().map(|(e, _)| e.id().to_string()).collect(),
            params,
            added_params: added,
            nrmse,
            r2,
            axes: vec![0, 1],
            measured: y,
            predicted: pred,
            train_gain,
            held_out: p.held_out.clone(),
            warnings,
        }
    }
}

/// `c` at `fraction` (0–1) of a sample later, by linear interpolation: row i takes the
/// value at t_i + fraction·dt (the last row holds).
fn later_by(c: &Column, fraction: f64) -> Column {
    let shift = |v: &std::sync::Arc<Vec<f64>>| {
        let n = v.len();
        std::sync::Arc::new(
            (0..n)
                .map(|i| (1.0 - fraction) * v[i] + fraction * v[(i + 1).min(n - 1)])
                .collect::<Vec<f64>>(),
        )
    };
    Column {
        name: c.name.clone(),
        axis: [c.axis[0].as_ref().map(shift), c.axis[1].as_ref().map(shift)],
    }
}
