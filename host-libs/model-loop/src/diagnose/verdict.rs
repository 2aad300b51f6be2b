//! The verdict of a diagnosis, and the doubt it cannot show: what is missing most (an
//! effect, a structure no effect explains, or nothing), and a lag the data cannot place.

use std::collections::BTreeMap;

use super::diagnosis::{EffectReport, Verdict};
use super::unexplained::UnexplainedReport;
use super::ModelFit;
use super::Warning;

/// The verdict names what is missing most: a structure no effect explains (a tone, a
/// wander) that carries more of the residual than the accepted effects removed of the
/// base's error outweighs them (they stay listed and accepted); a twin's few-millisecond
/// lag accepted at 0.2 % beside a 60 Hz line that carries most of the residual is not the
/// story of that log. (What was removed: the held-out gain of the accepted set, or the best
/// accepted effect's own gain — the cross-validated one in a dynamic trial — where that is
/// larger.)
pub(super) fn verdict_of<'r>(
    reports: impl Iterator<Item = &'r EffectReport>,
    some_kept: bool,
    current_fit: &ModelFit,
    e_base: f64,
    unexplained: &[UnexplainedReport],
) -> Verdict {
    let removed = reports.filter(|r| r.accepted).map(|r| r.improvement).fold(
        1.0 - current_fit.relative_mse() / e_base.max(1e-300),
        f64::max,
    );
    let largest_unexplained = unexplained
        .iter()
        .map(|u| u.variance_share)
        .fold(0.0, f64::max);
    if some_kept && (unexplained.is_empty() || largest_unexplained <= removed) {
        Verdict::Effect
    } else if !unexplained.is_empty() {
        Verdict::Unexplained
    } else {
        Verdict::None
    }
}

/// Honest doubt where the verdict cannot show it: a delay between the force and the
/// encoder samples removes more than half a per cent of the held-out error, but not beyond
/// the fold-to-fold spread. The base cannot take a lag in (its pneumatic term only
/// stiffens, its mass keeps a floor), so the lag may be there; the log cannot confirm it,
/// and the user should know.
pub(super) fn lag_warning(delay: Option<&EffectReport>) -> Option<Warning> {
    let delay = delay.filter(|d| !d.accepted && d.improvement > 0.005)?;
    Some(Warning::ForceLagsMotion {
        delay_ms: 1000.0 * delay_length_s(&delay.params).unwrap_or(0.0),
        improvement: delay.improvement,
    })
}

/// A delay family's length in its fitted parameters: a dead time's, or a sensor filter's
/// group delay.
pub(super) fn delay_length_s(params: &BTreeMap<String, f64>) -> Option<f64> {
    params
        .get("delay_s")
        .or_else(|| params.get("group_delay_s"))
        .copied()
}
