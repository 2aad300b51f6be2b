//! A step family or the converters' spread, from the same step trial at two co-contractions.
//!
//! At one pose and one co-contraction, the force steps of a step trial are a linear map of
//! the commanded currents: the four converters' spread (each channel's own gain and offset)
//! is then a share of each axis's force in the other, and a supply limit whose ceiling only
//! the largest steps reach can look the same; steps that settle a little apart by level
//! and direction, which the spread leaves too, are fitted in part by a muscle hysteresis
//! or a slew. A diagnosis refuses such a family as within the spread ([`WithinSpread`]).
//! Raising the co-contraction raises every channel's pressure: the spread keeps its share
//! of the steps, while a ceiling the supply sets is crossed by more of them and the
//! muscles' hysteresis grows, beyond what the spread can take up. So the same schedule at another co-contraction (`pamctl experiment step
//! --co-contraction high`) tells them apart: a family the spread hides in a log that names
//! nothing else, and that the other log names alone, is the log's; where neither log names
//! it beyond the spread, the spread explains the steps at both, and no family is named.
//! Where either log names another family, the pair does not decide: the muscles'
//! hysteresis grows with the pressure too, and at the higher co-contraction is taken for a
//! ceiling as often as not (pam-physgen's Bouc–Wen step logs).

use pam_ident::trial::Trial;
use pam_ident::IdentError;
use pam_model::RobotModel;
use serde::Serialize;

use crate::diagnose::{diagnose, Settings, Verdict, WithinSpread};
use crate::effects::{Experiment, Family};

/// The two logs' mean commanded currents must differ by at least this factor (RMS of the
/// four channels' log ratios) for the comparison to say anything: the co-contraction is
/// what changes between them.
pub const MIN_CURRENT_RATIO: f64 = 1.05;

/// The separating experiment, in words.
pub const SEPARATING_EXPERIMENT: &str = "repeat the step trial at the same pose at a higher co-contraction (`pamctl experiment step --co-contraction high`) and give both logs to `pamctl model diagnose A.csv B.csv`";

/// What one log of the pair says.
#[derive(Clone, Debug, Serialize)]
pub struct SpreadPairLog {
    pub verdict: Verdict,
    /// The families of its final model, in order.
    pub final_model: Vec<Family>,
    /// The families it cannot tell from the spread.
    pub within_spread: Vec<WithinSpread>,
    /// The mean commanded current of each channel (mA).
    pub mean_current_ma: [f64; 4],
}

/// The decision on a pair of step logs.
#[derive(Clone, Debug, Serialize)]
pub struct SpreadPair {
    /// The family one log left within the spread and the other names beyond it; `None`
    /// when no family is (the spread explains the steps at both co-contractions), or the
    /// pair cannot tell.
    pub family: Option<Family>,
    /// Whether the pair can say anything: the co-contraction differs between the logs.
    pub decided: bool,
    pub evidence: String,
    pub logs: [SpreadPairLog; 2],
}

fn mean_currents(t: &Trial) -> [f64; 4] {
    let Some(c) = &t.current_ma else {
        return [f64::NAN; 4];
    };
    c.each_ref()
        .map(|v| v.iter().sum::<f64>() / v.len().max(1) as f64)
}

fn log_of(
    t: &Trial,
    model: &RobotModel<f64>,
    settings: Settings,
) -> Result<SpreadPairLog, IdentError> {
    let (d, _) = diagnose(t, model, Experiment::Step, settings)?;
    Ok(SpreadPairLog {
        verdict: d.verdict,
        final_model: d.final_families(),
        within_spread: d.within_spread.clone(),
        mean_current_ma: mean_currents(t),
    })
}

/// RMS over the four channels of ln(b's mean current / a's).
fn current_ratio(a: &SpreadPairLog, b: &SpreadPairLog) -> f64 {
    let mut s = 0.0;
    for c in 0..4 {
        s += (b.mean_current_ma[c] / a.mean_current_ma[c]).ln().powi(2);
    }
    (s / 4.0).sqrt().exp()
}

/// Decides a family the converters' spread hides, from the same step trial at two
/// co-contractions (either order).
pub fn saturation_or_spread(
    a: &Trial,
    b: &Trial,
    model: &RobotModel<f64>,
    settings: Settings,
) -> Result<SpreadPair, IdentError> {
    let logs = [log_of(a, model, settings)?, log_of(b, model, settings)?];
    Ok(decide(logs))
}

/// The decision on two logs' diagnoses.
pub fn decide(logs: [SpreadPairLog; 2]) -> SpreadPair {
    let ratio = current_ratio(&logs[0], &logs[1]);
    if !(ratio >= MIN_CURRENT_RATIO) {
        return SpreadPair {
            family: None,
            decided: false,
            evidence: format!(
                "the two logs' currents differ by a factor of {ratio:.3} (at least {MIN_CURRENT_RATIO} needed): they are not the same trial at two co-contractions"
            ),
            logs,
        };
    }
    // a family hidden by the spread in a log that names nothing beyond it, and the whole
    // story at the other co-contraction: where either log names more, the hidden family's
    // growth is entangled with theirs (the muscles' hysteresis grows with the pressure as
    // a ceiling's share does), and the pair cannot single it out
    let mut named: Vec<(Family, usize)> = Vec::new();
    for (hid, other) in [(0, 1), (1, 0)] {
        if !logs[hid].final_model.is_empty() {
            continue;
        }
        for w in &logs[hid].within_spread {
            if logs[other].final_model == [w.family] && !named.iter().any(|(f, _)| *f == w.family) {
                named.push((w.family, other));
            }
        }
    }
    let hidden: Vec<&str> = logs
        .iter()
        .flat_map(|l| l.within_spread.iter().map(|w| w.family.name()))
        .collect();
    let (family, evidence) = match named.as_slice() {
        [] if hidden.is_empty() => (
            None,
            format!("neither log has a family the spread hides (currents ×{ratio:.2} between them)"),
        ),
        [] => (
            None,
            format!(
                "{} stays within the converters' spread at both co-contractions (currents ×{ratio:.2}): the spread explains the steps, no family is named",
                hidden.join(", ")
            ),
        ),
        [(f, at)] => (
            Some(*f),
            format!(
                "{} is within the converters' spread in log {} and named beyond it in log {} (currents ×{ratio:.2}): an effect that grows with the channels' levels, which the spread does not",
                f.name(),
                if *at == 0 { "B" } else { "A" },
                if *at == 0 { "A" } else { "B" },
            ),
        ),
        _ => (
            None,
            format!(
                "{} are each hidden by the spread in one log and named in the other: the pair cannot tell which",
                named.iter().map(|(f, _)| f.name()).collect::<Vec<_>>().join(", ")
            ),
        ),
    };
    SpreadPair {
        family,
        decided: true,
        evidence,
        logs,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn log(final_model: &[Family], hidden: &[Family], current_ma: f64) -> SpreadPairLog {
        SpreadPairLog {
            verdict: if final_model.is_empty() {
                Verdict::None
            } else {
                Verdict::Effect
            },
            final_model: final_model.to_vec(),
            within_spread: hidden
                .iter()
                .map(|&family| WithinSpread {
                    family,
                    improvement: 0.02,
                    spread_improvement: 0.03,
                    beyond_spread: 0.0,
                })
                .collect(),
            mean_current_ma: [current_ma; 4],
        }
    }

    #[test]
    fn hidden_in_one_named_in_the_other_is_named() {
        let p = decide([
            log(&[], &[Family::Saturation], 8.0),
            log(&[Family::Saturation], &[], 10.0),
        ]);
        assert_eq!(p.family, Some(Family::Saturation));
        assert!(p.decided);
        // either order
        let p = decide([
            log(&[Family::Saturation], &[], 10.0),
            log(&[], &[Family::Saturation], 8.0),
        ]);
        assert_eq!(p.family, Some(Family::Saturation));
    }

    #[test]
    fn a_pair_with_more_to_it_than_the_hidden_family_is_not_decided() {
        // the other log names it with another family, first or second
        for other in [
            [Family::Delay, Family::Saturation],
            [Family::Saturation, Family::Hysteresis],
        ] {
            let p = decide([log(&[], &[Family::Saturation], 8.0), log(&other, &[], 10.0)]);
            assert_eq!(p.family, None, "{other:?}");
        }
        // the first log names a family beyond the spread already
        let p = decide([
            log(&[Family::Hysteresis], &[Family::Saturation], 8.0),
            log(&[Family::Saturation], &[], 10.0),
        ]);
        assert_eq!(p.family, None);
    }

    #[test]
    fn hidden_in_both_is_the_spread() {
        let p = decide([
            log(&[], &[Family::Saturation], 8.0),
            log(&[], &[Family::Saturation], 10.0),
        ]);
        assert_eq!(p.family, None);
        assert!(p.decided);
        assert!(p.evidence.contains("spread explains"), "{}", p.evidence);
    }

    #[test]
    fn a_family_named_without_being_hidden_is_not_the_pairs() {
        let p = decide([log(&[], &[], 8.0), log(&[Family::RateLimits], &[], 10.0)]);
        assert_eq!(p.family, None);
    }

    #[test]
    fn the_same_co_contraction_decides_nothing() {
        let p = decide([
            log(&[], &[Family::Saturation], 8.0),
            log(&[Family::Saturation], &[], 8.1),
        ]);
        assert_eq!(p.family, None);
        assert!(!p.decided);
    }
}
