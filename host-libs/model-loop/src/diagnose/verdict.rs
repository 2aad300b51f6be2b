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

/// Honest doubt where the verdict cannot show it: the base describes a force that lags the
/// motion by the muscles' pneumatic lag (its gains negative) and a sensor-sync delay removes
/// a little more, but not beyond the fold-to-fold spread. To first order both are the same
/// lag, so the data cannot say which; the user should know the lag is there.
pub(super) fn lag_warning(
    base: &BTreeMap<String, f64>,
    delay: Option<&EffectReport>,
) -> Option<Warning> {
    let delay = delay.filter(|d| !d.accepted && d.improvement > 0.005)?;
    let kp = |k: &str| base.get(k).copied().unwrap_or(0.0);
    let (kx, ky) = (kp("kp_xx"), kp("kp_yy"));
    if !(kx < 0.0 || ky < 0.0) {
        return None;
    }
    let delay_ms = 1000.0 * delay.params.get("delay_s").copied().unwrap_or(0.0);
    Some(Warning::ForceLagsMotion {
        kp_xx_n_per_m: kx,
        kp_yy_n_per_m: ky,
        delay_ms,
        improvement: delay.improvement,
    })
}
