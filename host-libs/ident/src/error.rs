//! One error type for the identification library. Every variant says what is wrong with
//! the input and, through [`IdentError::help`], what to do about it.

use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum IdentError {
    /// The log lacks a column the identification needs (pam-log says which).
    #[error(transparent)]
    Log(#[from] pam_log::LogError),
    #[error("trial has {samples} samples; at least {needed} are needed")]
    TooFewSamples { samples: usize, needed: usize },
    #[error("column {column} has {len} values, t_s has {expected}")]
    ColumnLength {
        column: &'static str,
        len: usize,
        expected: usize,
    },
    #[error("column {column}, row {row}: not a finite number")]
    NotFinite { column: &'static str, row: usize },
    #[error("t_s is not increasing at row {row}")]
    TimeNotIncreasing { row: usize },
    #[error("the trial has {samples} samples over {duration_s:.2} s; the model loop needs at least {needed_samples} samples over {needed_s} s to judge an effect")]
    TooShortToJudge {
        samples: usize,
        duration_s: f64,
        needed_samples: usize,
        needed_s: f64,
    },
    /// The derivative filter cannot be designed (its order or cutoff).
    #[error(transparent)]
    Filter(#[from] pam_numerics::filter::FilterError),
    #[error("a step experiment needs the force reference columns fx_ref_n, fy_ref_n")]
    NoForceReference,
    #[error("only {bins} spectral bins below {band_rad_s} rad/s: the trial is too short for a frequency fit")]
    TooFewBins { bins: usize, band_rad_s: f64 },
    #[error("the {fit} fit {termination}: its parameters are not finite numbers")]
    FitNotFinite {
        fit: &'static str,
        termination: pam_numerics::lm::Termination,
    },
    #[error("the gain plane needs at least 3 poses per axis; axis {axis} has {poses}")]
    TooFewPoses { axis: &'static str, poses: usize },
    #[error("unknown experiment `{0}` (dynamic | step)")]
    UnknownExperiment(String),
    #[error("unknown effect `{name}` (known: {known})")]
    UnknownEffect { name: String, known: String },
    /// Any of the above, in a named log.
    #[error("{}: {source}", path.display())]
    InLog {
        path: PathBuf,
        #[source]
        source: Box<IdentError>,
    },
}

impl IdentError {
    /// What the user can do about it.
    pub fn help(&self) -> &'static str {
        use IdentError::*;
        match self {
            Log(_) => "record the log with `pamctl record` or `pamctl experiment` (docs/log-format.md lists the columns)",
            TooFewSamples { .. } => "record a longer trial: the fits need at least a few seconds of motion",
            TooShortToJudge { .. } => "record a longer trial (the thesis's dynamic trials last 90 s, its step tests about 40 s)",
            ColumnLength { .. } | NotFinite { .. } | TimeNotIncreasing { .. } => {
                "the log is damaged; record it again or cut the bad rows"
            }
            Filter(_) => {
                "choose a derivative filter cutoff below half the sampling rate (--cutoff-hz)"
            }
            NoForceReference => "record the step test with `pamctl experiment step`, which logs fx_ref_n and fy_ref_n",
            TooFewBins { .. } => "record a longer dynamic trial or widen the band (--band-rad-s)",
            FitNotFinite { .. } => "look for rows of the log where the force or the motion jumps or overflows; a fit of a cleaner stretch of the trial may converge",
            TooFewPoses { .. } => "give the step logs of at least three poses per axis",
            UnknownExperiment(_) => "use --experiment dynamic or --experiment step",
            UnknownEffect { .. } => "docs/model-loop.md lists the families and their shapes",
            InLog { source, .. } => source.help(),
        }
    }

    /// The same error, naming the log it came from.
    pub fn in_log(self, path: Option<&std::path::Path>) -> Self {
        match path {
            Some(p) => IdentError::InLog {
                path: p.to_path_buf(),
                source: Box::new(self),
            },
            None => self,
        }
    }
}

pub type Result<T, E = IdentError> = std::result::Result<T, E>;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_named_log_prefixes_the_message_and_keeps_the_help() {
        let e = IdentError::TooFewSamples {
            samples: 3,
            needed: 20,
        }
        .in_log(Some(std::path::Path::new("trial.csv")));
        assert_eq!(
            e.to_string(),
            "trial.csv: trial has 3 samples; at least 20 are needed"
        );
        assert!(e.help().contains("longer trial"));
    }
}
