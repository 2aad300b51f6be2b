//! The nulls an effect is refused against when its gain passes the tests: the rig's own
//! lag (a delay), the encoders' rounding and the load cell's coloured noise (a slow
//! change), the converters' spread (a saturation in a step trial), and a step trial with
//! too few steps to decide.

use super::Judge;
use crate::diagnose::colour::coloured_noise;
use crate::diagnose::resolution::encoder_floor;
use crate::diagnose::sizes::change_rms_n;
use crate::diagnose::unexplained::rounding_colours;
use crate::diagnose::verdict::delay_length_s;
use crate::diagnose::FoldTest;
use crate::diagnose::ModelFit;
use crate::diagnose::StepTest;
use crate::diagnose::Warning;
use crate::effects::Family;
use crate::effects::ModelEffect;
use pam_ident::step_detection::reference_steps;
use pam_numerics::lsq;
use pam_numerics::stats::rms;

/// The one-sided normal quantile of a power of 80 %: how far past its critical value a
/// test's expected t must lie to pass four times in five.
const POWER_Z: f64 = 0.84;

impl Judge<'_, '_> {
    /// A delay within the rig's own lag cannot be told from it; the evidence's note when
    /// so. A step trial's base has one second order for the four converters and at most
    /// their own lag as a dead time, while each converter has a dead time of a few
    /// milliseconds and the fill of its muscle. In a dynamic trial the muscles' pressure follows their volume through the
    /// same converters, which the base's pneumatic term holds to first order only, and the
    /// load cell and the encoders are read at different instants of a sample: the twin's
    /// dynamic controls show a delay of 5–6 ms that removes a few tenths of a per cent of
    /// the error. Both are refused below `Settings::converter_lag_s`; the generators' own
    /// delays are 10 ms and longer, mostly far longer.
    pub(super) fn within_lag(&self, e: &dyn ModelEffect, f: &ModelFit) -> Option<String> {
        if e.family() != Some(Family::Delay) {
            return None;
        }
        let own = f.params.get(e.id())?;
        let d = delay_length_s(own)?;
        let floor_s = self.settings.converter_lag_s;
        let what = if self.dynamic {
            "the muscles' pressure following their volume through the converters, which the base's pneumatic term holds to first order only, and the load cell and the encoders read at different instants of a sample"
        } else {
            "a dead time and the muscle's fill, each converter its own, which the base's one second order and one dead time hold only in part"
        };
        (d < floor_s).then(|| {
            format!(
                "; a delay of {:.1} ms lies within the rig's own lag (up to {:.0} ms: {what}): the log cannot tell it from that",
                1000.0 * d,
                1000.0 * floor_s
            )
        })
    }

    /// A slow level change within the encoders' rounding cannot be told from it: (its RMS,
    /// the rounding's bound) when so (drawn only for a drift that would be accepted: it
    /// costs a few hundred passes).
    pub(super) fn within_rounding(&self, e: &dyn ModelEffect, f: &ModelFit) -> Option<(f64, f64)> {
        if e.family() != Some(Family::Drift) {
            return None;
        }
        let fl = (*self.floor.get_or_init(|| encoder_floor(self.lp, self.base)))?;
        // the axis where the change stands out most from the rounding
        let (change, bound) = f
            .axes
            .iter()
            .map(|&a| (change_rms_n(self.base, f, a), fl.bound_n[a]))
            .filter(|&(_, bound)| bound > 0.0)
            .max_by(|x, y| (x.0 / x.1).total_cmp(&(y.0 / y.1)))?;
        (change <= bound).then_some((change, bound))
    }

    /// A slow level change within what the load cell's coloured noise puts in a record's
    /// level cannot be told from it: (its RMS over the trial, the noise's bound, the
    /// noise's exponent) when so. Asked after the rounding; where the encoders' rounding
    /// fills the slow band, the white null stands (the frozen levels would colour the law).
    pub(super) fn within_colour(
        &self,
        e: &dyn ModelEffect,
        f: &ModelFit,
    ) -> Option<(f64, f64, f64)> {
        if e.family() != Some(Family::Drift) {
            return None;
        }
        let p = &self.lp.p;
        let floor = self.floor.get().copied().flatten();
        let mut worst: Option<(f64, f64, f64)> = None;
        for &a in &f.axes {
            let d: Vec<f64> = (0..p.len())
                .map(|i| f.predicted[a][i] - self.base.predicted[a][i])
                .collect();
            let change = rms(&d);
            if floor.is_some_and(|fl| rounding_colours(fl.expected_n[a], change)) {
                return None;
            }
            let noise = coloured_noise(&self.base.residual(a), &p.t_s, p.dt_s)?;
            let bound = noise.trend_bound_n(self.level);
            if !(change <= bound) {
                return None;
            }
            if worst.is_none_or(|w| change / bound > w.0 / w.1) {
                worst = Some((change, bound, noise.exponent));
            }
        }
        worst
    }

    /// A step family the converters' spread explains as well: the spread's share and what
    /// the family removes beyond it, when so. The four converters each have their own
    /// gain, so at one pose each axis's force holds a share of the other's: a 2 × 2 gain on
    /// the base's force. Only steps that move the channels' levels (another co-contraction
    /// level or pose) tell an effect that grows with them from that spread.
    /// - A saturation that holds a channel at its ceiling over every level changes the
    ///   steps linearly as well: it is within the spread when it removes no more of the
    ///   held-out error than the spread does. (No margin: with `Settings::min_family_gain`
    ///   the twin's saturations at a pose off the centre, whose knee and maximum the fit
    ///   recovers, would be refused; a saturation ahead of the spread by less than 3 % can
    ///   still be the log's.)
    /// - Any other family is judged against a base that holds the spread: it is within the
    ///   spread when, with the spread refitted on its own prediction, it removes no more
    ///   than `Settings::min_significant_improvement` of the error the spread leaves. (A
    ///   rig whose converters differ leaves steps that settle a little apart by direction
    ///   and level, which a muscle hysteresis or a slew fits in part; the family that is
    ///   there keeps its gain once the spread is in the base.)
    pub(super) fn within_spread(
        &self,
        e: &dyn ModelEffect,
        f: &ModelFit,
        improvement: f64,
    ) -> Option<SpreadShare> {
        if self.dynamic {
            return None;
        }
        let spread = *self.spread.get_or_init(|| spread_improvement(self.base));
        let with_spread = 1.0 - (1.0 - spread_improvement(f)) * (1.0 - improvement);
        let beyond = 1.0 - (1.0 - with_spread) / (1.0 - spread).max(1e-300);
        let within = if e.family() == Some(Family::Saturation) {
            improvement <= spread
        } else {
            beyond <= self.settings.min_significant_improvement
        };
        within.then_some(SpreadShare { spread, beyond })
    }

    /// What a step effect's evidence adds when the log has too few steps to decide on it:
    /// why the held-out steps do not (`blocks_own_steps`: every held-out block holds a step
    /// of its own; `improvement`: the held-out gain; `test`: the held-out blocks' fold
    /// test); `warned`: a warning says about how many would.
    pub(super) fn too_few_steps_note(
        &self,
        improvement: f64,
        test: &FoldTest,
        blocks_own_steps: bool,
        warned: bool,
    ) -> String {
        let decisive = self.settings.step_decisive_improvement;
        let alike = if blocks_own_steps {
            "the held-out steps do not show the gain alike".to_string()
        } else {
            format!(
                "the log holds out {} steps, too few for the {} blocks to count as evidence",
                self.lp.p.held_out.ranges().len(),
                test.folds
            )
        };
        let size = if improvement >= decisive {
            format!(
                "it removes {:.0} % of their error but {:.1} % without the block that gains most: one step carries it",
                100.0 * improvement,
                100.0 * test.improvement_without_best
            )
        } else {
            format!(
                "it removes less than {:.0} % of their error",
                100.0 * decisive
            )
        };
        format!(
            "; {alike} and {size}: the log has too few steps to decide{}",
            if warned {
                " (a warning says about how many would)"
            } else {
                ""
            }
        )
    }

    /// The warning for a step family the log has too few steps to decide on: the steps it
    /// has and, from the fold test's t (which grows as the square root of the steps), about
    /// how many would decide. `None` for an effect without a family.
    pub(super) fn too_few_steps(
        &self,
        e: &dyn ModelEffect,
        improvement: f64,
        (test, t, t_critical): (StepTest, f64, f64),
    ) -> Option<Warning> {
        let family = e.family()?;
        // the steps the held-out part was chosen from, else those of the force the
        // set-points command
        let p = &self.lp.p;
        let steps = p.held_out.steps().unwrap_or_else(|| {
            p.force_ref_n.as_ref().map_or(0, |r| {
                reference_steps(r, self.settings.step_threshold_n).len()
            })
        });
        // (a t already past its critical value gives no count: the gain failed the rule's
        // size over the steps, not their spread). The count is the design of the trial
        // that would decide: with the t expected to reach its critical value, a trial
        // decides a real gain only half the time; the t expected one `POWER_Z` beyond it
        // decides it four times in five
        let steps_needed = (t > 0.0 && t < t_critical && steps > 0)
            .then(|| (steps as f64 * ((t_critical + POWER_Z) / t).powi(2)).ceil() as usize);
        Some(Warning::TooFewSteps {
            family,
            improvement,
            test,
            t,
            t_critical,
            steps,
            steps_needed,
        })
    }
}

/// What the converters' spread explains of a step trial, with a family it hides.
#[derive(Clone, Copy, Debug)]
pub(super) struct SpreadShare {
    /// The share of the base's held-out error the spread removes.
    pub spread: f64,
    /// The share of the error the spread leaves that the family removes on top of it.
    pub beyond: f64,
}

/// The share of a step trial's held-out base error that the converters' spread removes:
/// each stepping axis's force refitted as a gain on the base's prediction of it, a share of
/// the base's prediction of the other axis and an offset (least squares on the training
/// rows; the base's dynamics are kept, not refitted with it, so its share is if anything
/// understated), scored on the held-out rows as every step family is.
pub(super) fn spread_improvement(base: &ModelFit) -> f64 {
    let mut spread = base.clone();
    for &a in &base.axes {
        let own = &base.predicted[a];
        let other = &base.predicted[1 - a];
        let y = &base.measured[a];
        let mut gram = vec![vec![0.0; 3]; 3];
        let mut rhs = vec![0.0; 3];
        for i in base.held_out.train_rows() {
            let x = [own[i], other[i], 1.0];
            for r in 0..3 {
                rhs[r] += x[r] * y[i];
                for c in 0..3 {
                    gram[r][c] += x[r] * x[c];
                }
            }
        }
        // an axis that does not step leaves its prediction a constant, the offset's column:
        // a ridge of 1e-9 of the diagonal keeps the solve defined
        for (r, row) in gram.iter_mut().enumerate() {
            row[r] *= 1.0 + 1e-9;
        }
        let theta = lsq::solve(&lsq::Normal { gram, rhs }, &[]);
        for (i, p) in spread.predicted[a].iter_mut().enumerate() {
            *p = theta[0] * own[i] + theta[1] * other[i] + theta[2];
        }
    }
    let e_base = base.relative_mse();
    if !(e_base > 0.0) {
        return 0.0;
    }
    1.0 - spread.relative_mse() / e_base
}
