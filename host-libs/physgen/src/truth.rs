//! The truth file beside each log, in the judge's format (pam-synth's `Truth`: the same
//! field names, so `pam_synth::judge` scores these logs), with what this generator adds.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::sensor::LoadCellNoise;

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Truth {
    pub experiment: String,
    /// The model loop's family (`none` for a control).
    pub family: String,
    /// The closest shape name of the judge's format.
    pub shape: String,
    pub seed: u64,
    pub dt_s: f64,
    pub duration_s: f64,
    pub samples: usize,
    /// White load-cell noise per channel (N) and the coloured part's standard deviation.
    pub noise_n: f64,
    pub coloured_noise_n: f64,
    /// Dynamic: Table 4.1's point; step: §5.2's pose (1–9).
    pub site: usize,
    pub alpha_deg: [f64; 2],
    pub target_relative_size: f64,
    /// RMS(the effect's part of the force) / std(logged force), both axes pooled: the log
    /// simulated without the effect (same seed) is the reference.
    pub relative_size: f64,
    /// The effect's physical parameters, units in the names; empty for a control.
    pub params: BTreeMap<String, f64>,
    /// The nominal rig of this log: hand, stiffness asked, converters' spread.
    pub base: BTreeMap<String, f64>,
    pub generator: String,
    /// The physical effect (`handle_lugre`, `joint_lugre`, …) and where it acts.
    pub physical_effect: String,
    pub location: String,
    pub severity: f64,
    pub load_cell: LoadCellNoise,
}

impl Truth {
    pub fn to_json(&self) -> Result<String, serde_json::Error> {
        serde_json::to_string_pretty(self)
    }
}
