//! The generator's typed errors.

use thiserror::Error;

#[derive(Debug, Error)]
pub enum SynthError {
    /// The shape belongs to another family than the one asked for.
    #[error("shape `{shape}` is not a shape of family `{family}`")]
    ShapeNotInFamily { shape: String, family: String },
    /// The shape cannot show in this experiment (e.g. `friction` in a blocked-handle step test).
    #[error("shape `{shape}` does not exist in {experiment} trials")]
    ShapeNotInExperiment { shape: String, experiment: String },
    #[error("unknown {what} `{name}`; one of: {choices}")]
    UnknownName {
        what: &'static str,
        name: String,
        choices: String,
    },
    /// A mains tone must be resolvable: sampled at 5 ms or faster.
    #[error("the mains tone needs a sampling period ≤ 5 ms, not {dt_s} s")]
    ToneNotResolved { dt_s: f64 },
    #[error("sampling period {dt_s} s: must be a whole number of milliseconds between 1 and 50")]
    BadPeriod { dt_s: f64 },
    #[error("duration {duration_s} s is out of 5–200 s")]
    BadDuration { duration_s: f64 },
    #[error("noise {noise_n} N is out of 0–5 N")]
    BadNoise { noise_n: f64 },
    /// The random operator motion left the robot's reach or joint range.
    #[error("the handle motion leaves the workspace at t = {t_s} s")]
    OutOfReach { t_s: f64 },
    #[error("writing the log: {0}")]
    Io(#[from] std::io::Error),
    #[error("serialising the truth: {0}")]
    Json(#[from] serde_json::Error),
}
