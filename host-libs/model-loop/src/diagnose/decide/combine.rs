//! The final model: the accepted families added best first while each pays for itself,
//! and a family after the first only where no other shape of one already in it removes as
//! much (a refinement, reported as such).

use super::Judge;
use crate::diagnose::diagnosis::Refinement;
use crate::diagnose::selection::fold_test;
use crate::diagnose::tried::Tried;
use crate::diagnose::ModelFit;
use crate::effects::ModelEffect;

impl<'l, 'a> Judge<'l, 'a> {
    /// Greedy: add accepted effects best first while each still pays for itself, and a
    /// family after the first only while it removes more than a refinement of the families
    /// already in would ([`Judge::refinement`]). Returns the fits in order (base first), the
    /// effects kept, the last fit and the families left out as refinements.
    pub(super) fn combine<'e>(
        &self,
        reports: &[Tried<'e>],
    ) -> (
        Vec<ModelFit>,
        Vec<&'e dyn ModelEffect>,
        ModelFit,
        Vec<Refinement>,
    ) {
        let (dynamic, settings, base) = (self.dynamic, &self.settings, self.base);
        let mut fits = vec![base.clone()];
        let mut current: Vec<&dyn ModelEffect> = Vec::new();
        let mut kept: Vec<&Tried<'e>> = Vec::new();
        let mut current_fit = base.clone();
        let mut current_folds = self.base_folds.clone();
        let mut refinements = Vec::new();
        for t in reports.iter().filter(|r| r.report.accepted).take(4) {
            let mut trial_set = current.clone();
            trial_set.push(t.effect);
            let f = match (&t.fit, current.is_empty()) {
                (Some(alone), true) => alone.clone(),
                _ => self.lp.fit(&trial_set),
            };
            let mut folds_if_kept = None;
            let pays = if current.is_empty() {
                true
            } else if dynamic {
                let folds = self.folds_of(&trial_set, &f);
                let test = fold_test(&current_folds, &folds, true);
                let ok = test.significant(self.t_crit, self.level)
                    && test.improvement > settings.min_significant_improvement;
                if ok {
                    folds_if_kept = Some(folds);
                }
                ok
            } else {
                let gain = 1.0 - f.relative_mse() / current_fit.relative_mse().max(1e-300);
                let added = f.added_params - current_fit.added_params;
                gain - settings.penalty_per_param * added as f64 > settings.min_improvement
            };
            if !pays {
                continue;
            }
            if !current.is_empty() {
                if let Some(r) = self.refinement(t, &f, &current, &kept, &current_fit) {
                    refinements.push(r);
                    continue;
                }
            }
            if let Some(folds) = folds_if_kept {
                current_folds = folds;
            } else if current.is_empty() && dynamic {
                current_folds = t.folds.clone();
            }
            current = trial_set;
            kept.push(t);
            current_fit = f.clone();
            fits.push(f);
        }
        (fits, current, current_fit, refinements)
    }

    /// `t` on top of the model `current` (whose families are `kept`) removes `f`'s share
    /// of the base's held-out error: a refinement when, beyond what the best other shape
    /// of a family already in the model removes on top of it, that is less than
    /// `min_family_gain`. A first effect whose true shape is not the catalog's leaves a
    /// residual other families fit a little of too; that is not a second effect.
    fn refinement(
        &self,
        t: &Tried,
        f: &ModelFit,
        current: &[&dyn ModelEffect],
        kept: &[&Tried],
        current_fit: &ModelFit,
    ) -> Option<Refinement> {
        let e_base = self.e_base.max(1e-300);
        let e_now = current_fit.relative_mse();
        let removes = (e_now - f.relative_mse()) / e_base;
        let refined = kept
            .iter()
            .flat_map(|k| k.alternatives.iter())
            .filter(|a| !current.iter().any(|c| c.id() == a.id()))
            .map(|a| {
                let mut set = current.to_vec();
                set.push(*a);
                let g = (e_now - self.lp.fit(&set).relative_mse()) / e_base;
                (*a, g)
            })
            .max_by(|x, y| x.1.total_cmp(&y.1));
        let refined_removes = refined.map_or(0.0, |(_, g)| g.max(0.0));
        if removes - refined_removes >= self.settings.min_family_gain {
            return None;
        }
        let family = t.report.family.map_or(t.report.id.as_str(), |f| f.name());
        let evidence = match refined {
            Some((a, _)) => format!(
                "{family} ({}) removes {:.1} % more of the base model's error on top of the final model, and a shape of a family already in it ({}) {:.1} %: less than {:.0} % apart, the log cannot tell a second effect from a shape outside the catalog",
                t.report.shape,
                100.0 * removes,
                a.id(),
                100.0 * refined_removes,
                100.0 * self.settings.min_family_gain
            ),
            None => format!(
                "{family} ({}) removes {:.1} % more of the base model's error on top of the final model: less than {:.0} %, too little to tell a second effect from the first one's shape",
                t.report.shape,
                100.0 * removes,
                100.0 * self.settings.min_family_gain
            ),
        };
        Some(Refinement {
            id: t.report.id.clone(),
            family: t.report.family,
            shape: t.report.shape.clone(),
            removes,
            refined_by: refined.map(|(a, _)| a.id().to_string()),
            refined_removes,
            evidence,
        })
    }
}
