//! The loop's settings: its thresholds and levels, with their defaults.

use pam_ident::trial::FilterSettings;

/// Knobs of the loop, with defaults chosen for generality (see docs/model-loop.md).
#[derive(Clone, Copy, Debug)]
pub struct Settings {
    pub filter: FilterSettings,
    /// An effect must remove at least this share of the held-out error (relative MSE)...
    pub min_improvement: f64,
    /// ...after subtracting this much per parameter it adds.
    pub penalty_per_param: f64,
    /// An effect must change the held-out prediction by at least this share of the
    /// measured signal's spread: a statistically clear but physically negligible correction
    /// (a few hundredths of a newton of model bias) is not a missing effect.
    pub min_effect_size: f64,
    /// Steps: below `min_improvement`, an effect still counts when it removes at least this
    /// share and its held-out gain passes the BIC on the held-out part's effective samples.
    /// (Dynamic trials: the cross-validated gain need only pay for its parameters; what makes
    /// an effect material there is `min_effect_size`, a share of the signal, not a share of
    /// an error that the noise dominates.)
    pub min_significant_improvement: f64,
    /// Step detection threshold |ΔF| (§5.3).
    pub step_threshold_n: f64,
    /// Spectral peaks: power ≥ this × the local median...
    pub peak_prominence: f64,
    /// ...carrying at least this share of the residual variance.
    pub peak_min_share: f64,
    /// Slow wander of the residual: share of its variance in 20 time-bin means.
    pub structure_min_share: f64,
    /// Level of the fold test that accepts a family: half for the t-test, half for the
    /// signed-rank test, so each is a one-sided test at `alpha / 2`. The false-alarm rate on
    /// controls is far below it (the other gates below hold too, and a null effect's
    /// cross-validated gain is biased negative by its extra parameters): calibrated on the
    /// controls of two generators (docs/model-loop.md, "Calibration").
    pub alpha: f64,
    /// Split `alpha` over the families tested (Bonferroni) as well.
    pub bonferroni: bool,
    /// Two families whose fold-by-fold difference has |t| below this are reported as
    /// ambiguous.
    pub ambiguity_t: f64,
    /// Dynamic trials: try the derivative filter at 1, 0.6 and 0.4 × its cutoff and keep
    /// the one whose plain base fits the training part best (see
    /// [`prepare_with_best_cutoff`]).
    pub adapt_cutoff: bool,
    /// Dynamic trials: the fitted mass diagonals are kept at least this share of the
    /// robot's rigid-body Cartesian inertia at the trial's pose (0 turns the floor off).
    pub mass_floor_share: f64,
    /// A family after the first enters the final model only if it removes at least this
    /// share of the base model's held-out error beyond what another shape of a family
    /// already in it removes: a first effect whose true shape is not the catalog's leaves
    /// a residual of 0.5–3 % that other families fit too (a refinement, reported as such).
    pub min_family_gain: f64,
    /// A transport delay is a family only when it is longer than this, and the step base
    /// may carry this much dead time. The step base's second order (Table 5.2) was
    /// identified without a dead time, and every converter has one of a few milliseconds
    /// plus the fill of its muscle, each converter its own: a delay that short is the
    /// converters' own lag, not a missing effect. In a dynamic trial the same converters lag the muscles'
    /// pressure behind their volume, and the sensors are read at different instants of a
    /// sample.
    pub converter_lag_s: f64,
    /// Step trials: a family is accepted only when its gain is significant across the
    /// held-out blocks (the fold test of a dynamic trial; only when every block holds a
    /// held-out step of its own) or it removes at least this share of the held-out error,
    /// with the block that gains most left out too. A gain of a few per cent that some
    /// held-out steps show and others do not is what a rig's own step-to-step differences
    /// give as often as a real effect (docs/model-loop.md, "Step trials": too few steps to
    /// decide).
    pub step_decisive_improvement: f64,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            filter: FilterSettings::default(),
            min_improvement: 0.01,
            penalty_per_param: 0.001,
            min_effect_size: 0.005,
            min_significant_improvement: 0.002,
            step_threshold_n: 3.0,
            peak_prominence: 40.0,
            peak_min_share: 0.03,
            structure_min_share: 0.2,
            alpha: 0.1,
            bonferroni: false,
            ambiguity_t: 2.0,
            adapt_cutoff: true,
            mass_floor_share: 0.35,
            min_family_gain: 0.03,
            converter_lag_s: 0.01,
            step_decisive_improvement: 0.5,
        }
    }
}
