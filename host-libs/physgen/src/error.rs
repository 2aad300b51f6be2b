//! The generator's errors.

use thiserror::Error;

#[derive(Debug, Error)]
pub enum PhysgenError {
    #[error("the operator's path leaves the joint range at t = {t_s:.2} s")]
    OutOfReach { t_s: f64 },
    #[error("the simulation diverged at t = {t_s:.3} s ({what})")]
    Diverged { t_s: f64, what: &'static str },
    #[error("writing the log: {0}")]
    Io(#[from] std::io::Error),
    #[error("writing the truth file: {0}")]
    Json(#[from] serde_json::Error),
}

impl PhysgenError {
    /// What to do about it.
    pub fn help(&self) -> &'static str {
        match self {
            PhysgenError::OutOfReach { .. } => "draw another seed",
            PhysgenError::Diverged { .. } => {
                "a parameter draw made the plant unstable; report the seed"
            }
            PhysgenError::Io(_) => "check that the output folder exists and is writable",
            PhysgenError::Json(_) => "report the seed",
        }
    }
}
