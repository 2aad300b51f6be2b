//! What the generator hid in a log: kept out of the log itself, returned beside it and
//! written as a sidecar JSON file.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::case::{Experiment, Family, Shape, StepLevels, StepOrder};
use crate::motion::OperatorMotion;
use crate::nuisance::Nuisances;

/// The ground truth of one generated log.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Truth {
    pub experiment: Experiment,
    /// `none` for a control, `unexplained` for out-of-catalog structure, else the family.
    pub family: Family,
    pub shape: Shape,
    pub seed: u64,
    pub dt_s: f64,
    pub duration_s: f64,
    pub samples: usize,
    /// The order of a step log's axes (a dynamic log's is the default and means nothing).
    #[serde(default)]
    pub step_order: StepOrder,
    /// What the recording added that is not an effect (none by default).
    #[serde(default)]
    pub nuisances: Nuisances,
    /// The operator's motion of a dynamic log (a step log's is the default and means nothing).
    #[serde(default)]
    pub motion: OperatorMotion,
    /// Where a step log's levels lie (a dynamic log's is the default and means nothing).
    #[serde(default)]
    pub step_levels: StepLevels,
    /// Load-cell white noise per axis (N) and the coloured part's standard deviation.
    pub noise_n: f64,
    pub coloured_noise_n: f64,
    /// Dynamic: Table 4.1 point; step: step pose (1–9).
    pub site: usize,
    pub alpha_deg: [f64; 2],
    /// RMS(contribution) / std(logged force), pooled over both axes: asked and achieved.
    pub target_relative_size: f64,
    pub relative_size: f64,
    /// The effect's physical parameters (units in the names); empty for a control.
    pub params: BTreeMap<String, f64>,
    /// The base model that made the log (KBM of the dynamic trial, the step's second order,
    /// stiffness levels), units in the names.
    pub base: BTreeMap<String, f64>,
}

impl Truth {
    pub fn to_json(&self) -> Result<String, serde_json::Error> {
        serde_json::to_string_pretty(self)
    }

    /// One parameter by name.
    pub fn param(&self, name: &str) -> Option<f64> {
        self.params.get(name).copied()
    }
}
