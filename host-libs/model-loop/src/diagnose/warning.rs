//! What a diagnosis or a comparison warns of: a type per case, with its message.
//!
//! A warning is written to the JSON as its message (a string), as it reads in the report
//! and in `pamctl`'s text output; code and tests match the variant.

use std::fmt;

use serde::{Serialize, Serializer};

use super::SpikeReport;
use super::{StepsToDecide, WithinSpread};
use crate::effects::Experiment;
use crate::effects::Family;
use pam_ident::msd::MassWarning;

/// A warning of the model loop.
#[derive(Clone, Debug, PartialEq)]
pub enum Warning {
    /// The base's fitted mass matrix is implausible.
    Mass(MassWarning),
    /// Isolated spikes in the force were bridged before the fits.
    Spikes(SpikeReport),
    /// The log's sampling was uneven and it was resampled to its median period.
    Resampled,
    /// The log's sampling is uneven; the model takes the logged times.
    UnevenSampling {
        shortest_s: f64,
        longest_s: f64,
        experiment: Experiment,
    },
    /// A residual's level wanders by no more than the encoders' rounding puts in it: no
    /// effect is named for it.
    WanderWithinEncoderRounding {
        /// 0 fx, 1 fy.
        axis: usize,
        amplitude_n: f64,
        /// One count of each encoder.
        step_rad: [f64; 2],
        expected_n: f64,
        bound_n: f64,
        draws: usize,
    },
    /// A residual's level wanders by no more than the load cell's own coloured noise (its
    /// spectrum above the slow band, extended into it) allows: no effect is named for it.
    WanderWithinColouredNoise {
        /// 0 fx, 1 fy.
        axis: usize,
        amplitude_n: f64,
        /// The slow band's upper edge, Hz.
        low_hz: f64,
        /// The slow band's power over the extended noise's.
        ratio: f64,
        /// β of the noise's spectrum f^−β.
        exponent: f64,
        p_value: f64,
    },
    /// The load cell's tare in its own frame turns with the handle: its turning part was
    /// taken out of the force before the fits.
    TareInSensorFrame {
        /// The tare along the cell's X and Z, N.
        sensor_n: [f64; 2],
        /// RMS of the part taken out, per handle axis, N.
        turning_rms_n: [f64; 2],
        /// The share of the base's training residual it removes.
        gain: f64,
    },
    /// The force may lag the motion: a delay removes part of the held-out error, but
    /// within the fold-to-fold spread.
    ForceLagsMotion {
        delay_ms: f64,
        /// The share of the held-out error the rejected delay removes.
        improvement: f64,
    },
    /// A step trial: a family removes part of the held-out error, but not consistently
    /// across the held-out steps; the log has too few steps to decide, and about
    /// `steps_needed` would, four times in five if the gain is real (the fold test's t grows
    /// as the square root of the steps).
    TooFewSteps {
        family: Family,
        /// The share of the base's held-out error it removes.
        improvement: f64,
        /// The fold test that left it open, its t and critical t.
        test: StepTest,
        t: f64,
        t_critical: f64,
        steps: usize,
        /// `None`: its gain is not positive across the held-out blocks on average.
        steps_needed: Option<usize>,
    },
    /// A step trial: a share of each axis's force in the other (the four converters'
    /// spread at one pose) explains what a family does: a saturation removes no more of
    /// the held-out error than the spread, another family nothing material beyond it. The
    /// log cannot tell the family from that spread.
    WithinConverterSpread {
        family: Family,
        /// The share of the base's held-out error it removes.
        improvement: f64,
        /// The share the converters' spread removes.
        spread_improvement: f64,
        /// The share of the error the spread leaves that the family removes on top of it.
        beyond_spread: f64,
    },
    /// An axis's reference does not step in the held-out part (a step trial).
    ReferenceStill { axis: usize },
    /// The model explains little of an axis in the held-out part.
    LowR2 { axis: usize, r2: f64 },
}

/// Which fold test of a step trial left a family open.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StepTest {
    /// The held-out part's blocks.
    HeldOutBlocks,
    /// The cross-validation over every step, each scored by a fit that never saw it.
    AllSteps,
}

impl StepTest {
    fn phrase(self) -> &'static str {
        match self {
            StepTest::HeldOutBlocks => "across the held-out blocks",
            StepTest::AllSteps => "over all the steps, each scored by a fit that never saw it",
        }
    }
}

const AXES: [&str; 2] = ["fx", "fy"];

impl Warning {
    /// A step family the log has too few steps to decide on, as the diagnosis's JSON lists
    /// it (`None` for every other warning).
    pub fn steps_to_decide(&self) -> Option<StepsToDecide> {
        match *self {
            Warning::TooFewSteps {
                family,
                steps,
                steps_needed,
                ..
            } => Some(StepsToDecide {
                family,
                steps,
                steps_needed,
            }),
            _ => None,
        }
    }

    /// A step family the log cannot tell from the converters' spread, as the diagnosis's
    /// JSON lists it (`None` for every other warning).
    pub fn within_spread(&self) -> Option<WithinSpread> {
        match *self {
            Warning::WithinConverterSpread {
                family,
                improvement,
                spread_improvement,
                beyond_spread,
            } => Some(WithinSpread {
                family,
                improvement,
                spread_improvement,
                beyond_spread,
            }),
            _ => None,
        }
    }
}

impl fmt::Display for Warning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Warning::Mass(m) => write!(f, "{m}"),
            Warning::Spikes(s) => {
                let times: Vec<String> = s.first_t_s.iter().map(|t| format!("{t:.3}")).collect();
                write!(
                    f,
                    "{} isolated spike{} in the force (the largest {:.2} N; t = {} s{}) bridged by \
                     their neighbours before the fits: a corrupted frame or a knock on the load cell, \
                     not the robot",
                    s.rows,
                    if s.rows == 1 { "" } else { "s" },
                    s.largest_n,
                    times.join(", "),
                    if s.rows > s.first_t_s.len() {
                        ", …"
                    } else {
                        ""
                    }
                )
            }
            Warning::Resampled => write!(
                f,
                "the log's sampling is uneven (dropped frames?): it was resampled to its median \
                 period"
            ),
            Warning::UnevenSampling {
                shortest_s,
                longest_s,
                experiment,
            } => {
                let treatment = match experiment {
                    Experiment::Step => "the step model is simulated at the logged times",
                    Experiment::Dynamic => "the derivatives take the logged times",
                };
                write!(
                    f,
                    "the log's sampling is uneven ({:.1}–{:.1} ms between rows: jitter, lost frames): \
                     {treatment}",
                    shortest_s * 1e3,
                    longest_s * 1e3
                )
            }
            Warning::WanderWithinEncoderRounding {
                axis,
                amplitude_n,
                step_rad,
                expected_n,
                bound_n,
                draws,
            } => write!(
                f,
                "the {} residual's level wanders by {:.3} N RMS, within what the encoders' counts ({:.4}° and {:.4}°) put in its level through the model (expected {:.3} N RMS, up to {:.3} N in {} draws of it: the rounding is frozen while a count is held): the log cannot tell a slow effect of that size from the encoders' rounding, so none is named",
                AXES[*axis],
                amplitude_n,
                step_rad[0].to_degrees(),
                step_rad[1].to_degrees(),
                expected_n,
                bound_n,
                draws
            ),
            Warning::WanderWithinColouredNoise {
                axis,
                amplitude_n,
                low_hz,
                ratio,
                exponent,
                p_value,
            } => write!(
                f,
                "the {} residual's level wanders by {:.3} N RMS, but no more than its own coloured noise allows: below {:.2} Hz it holds {:.1} × the power that the noise's spectrum above (falling as f^−{:.2}, a load cell's 1/f noise at most) extends to (p = {:.1e}), so none is named",
                AXES[*axis],
                amplitude_n,
                low_hz,
                ratio,
                exponent,
                p_value
            ),
            Warning::TareInSensorFrame {
                sensor_n,
                turning_rms_n,
                gain,
            } => write!(
                f,
                "the load cell's tare in its own frame ({:.2} N along X, {:.2} N along Z) turns with the handle: its turning part ({:.3} N RMS in fx, {:.3} N in fy, {:.1} % of the base's training residual) was taken out of the force before the fits: a sensor's offset, not an effect",
                sensor_n[0],
                sensor_n[1],
                turning_rms_n[0],
                turning_rms_n[1],
                100.0 * gain
            ),
            Warning::WithinConverterSpread {
                family,
                improvement,
                spread_improvement,
                beyond_spread,
            } => {
                let spread = "a share of each axis's force in the other (the four converters' spread, at one pose a linear change of the steps)";
                if *family == Family::Saturation {
                    write!(
                        f,
                        "{} removes {:.1} % of the held-out error, but {spread} removes {:.1} %",
                        family.name(),
                        100.0 * improvement,
                        100.0 * spread_improvement,
                    )?;
                } else {
                    let beyond = if *beyond_spread > 0.0 {
                        format!("{:.1} %", 100.0 * beyond_spread)
                    } else {
                        "nothing".to_string()
                    };
                    write!(
                        f,
                        "{} removes {:.1} % of the held-out error, but {spread} removes {:.1} %, and with the spread in the base it removes {beyond} of what is left",
                        family.name(),
                        100.0 * improvement,
                        100.0 * spread_improvement,
                    )?;
                }
                write!(
                    f,
                    ": the log cannot tell the two apart, so it is not named. To tell them: {} (the channels' pressures then change: a ceiling is crossed more often and the muscles' hysteresis grows, while the spread keeps its share)",
                    crate::spread_pair::SEPARATING_EXPERIMENT
                )
            }
            Warning::ForceLagsMotion {
                delay_ms,
                improvement,
            } => write!(
                f,
                "the force may lag the motion: a delay of {delay_ms:.0} ms between the force and \
                 the encoder samples removes {:.1} % of the held-out error, but within the \
                 fold-to-fold spread, so no delay is named. To confirm or rule it out: check the \
                 logger's timestamps, or sample faster (≤ 5 ms) with quick reversals",
                100.0 * improvement
            ),
            Warning::TooFewSteps {
                family,
                improvement,
                test,
                t,
                t_critical,
                steps,
                steps_needed,
            } => {
                // a t past its critical value: the gain holds step by step but is too small
                let why = if t >= t_critical {
                    " and its gain holds step by step"
                } else {
                    ", but not step by step alike"
                };
                let small = if t >= t_critical {
                    ", but over all the steps it is too small to name"
                } else {
                    ""
                };
                write!(
                    f,
                    "{} removes {:.1} % of the held-out error{why} (t = {t:.1} {}, {t_critical:.1} needed){small}: {steps} steps are too few to decide, so it is not named",
                    family.name(),
                    100.0 * improvement,
                    test.phrase(),
                )?;
                match steps_needed {
                    Some(k) => write!(
                        f,
                        "; about {k} steps would decide (four times in five if the gain is real)"
                    ),
                    None => write!(f, "; more steps of the same levels would decide"),
                }
            }
            Warning::ReferenceStill { axis } => write!(
                f,
                "{}'s reference does not step in the held-out part: its NRMSE and R² there measure the noise",
                AXES[*axis]
            ),
            Warning::LowR2 { axis, r2 } => write!(
                f,
                "held-out R² of {} is {:.2}: the model explains little of this axis",
                AXES[*axis], r2
            ),
        }
    }
}

impl Serialize for Warning {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.collect_str(self)
    }
}

#[cfg(test)]
mod tests {
    use super::{StepTest, Warning};
    use crate::effects::Family;

    fn too_few(test: StepTest, t: f64, steps_needed: Option<usize>) -> String {
        Warning::TooFewSteps {
            family: Family::RateLimits,
            improvement: 0.05,
            test,
            t,
            t_critical: 1.7,
            steps: 20,
            steps_needed,
        }
        .to_string()
    }

    #[test]
    fn a_step_familys_warning_names_the_test_that_left_it_open() {
        let short = too_few(StepTest::AllSteps, 1.2, Some(41));
        assert!(short.contains("not step by step alike"), "{short}");
        assert!(short.contains("over all the steps"), "{short}");
        assert!(short.contains("about 41 steps would decide"), "{short}");
        let blocks = too_few(StepTest::HeldOutBlocks, 1.2, Some(41));
        assert!(
            blocks.starts_with("rate_limits removes 5.0 % of the held-out error, but not step by step alike (t = 1.2 across the held-out blocks, 1.7 needed): 20 steps are too few to decide"),
            "{blocks}"
        );
        // a gain that holds step by step but is too small is not said to vary
        let small = too_few(StepTest::AllSteps, 2.5, None);
        assert!(!small.contains("not step by step alike"), "{small}");
        assert!(small.contains("too small to name"), "{small}");
    }
}
