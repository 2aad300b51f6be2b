//! Identification of the PAM rehabilitation robot from logs, as in the thesis (§4.3–4.6,
//! §5.3), and the preparation of a log that the model loop (pam-model-loop) starts from:
//! the trial and its filtered signals, the held-out rows, the steps of a step trial, the
//! load cell's spikes.
//!
//! Host only, f64. Uses only what a log contains: time, encoder angles, measured force,
//! the force reference of step experiments.

// `!(x > y)` is deliberate: it is true for NaN, so a NaN never passes a check.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
// Two-axis and per-joint loops index several parallel arrays at once.
#![allow(clippy::needless_range_loop)]

pub mod error;
pub mod freq;
pub mod held_out;
pub mod msd;
pub mod spikes;
pub mod step;
pub mod step_detection;
pub mod trial;

pub use error::IdentError;
pub use trial::{FilterSettings, Prepared, Trial};
