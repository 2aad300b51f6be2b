//! One thesis experiment on the twin, from a plain description ([`TrialSpec`]) to its log:
//! what `pamctl simulate` runs.
//!
//! ```
//! use pam_twin::simulate::{run_trial, Experiment, TrialSpec};
//! let mut spec = TrialSpec::new(Experiment::Dynamic);
//! spec.duration_s = 0.5;
//! spec.period_s = 0.01;
//! spec.effects = vec!["carrier_ball_friction:coulomb_n=3".into()];
//! let log = run_trial(&spec).unwrap();
//! assert_eq!(log.len(), 50);
//! ```

use std::fmt;
use std::str::FromStr;

use pam_log::Log;

use crate::effects::{EffectError, EffectSet};
use crate::experiments::{
    dynamic_trial, force_step_test, static_trial, ExperimentConfig, ExperimentError,
    StiffnessLevel, STEP_POSES_DEG,
};
use crate::impedance_trial::{impedance_trial, VirtualImpedance};
use crate::plant::TwinConfig;

/// The thesis protocols the twin runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Experiment {
    /// §4.2 dynamic trial at a Table 4.1 point (`dynamic_trial`).
    Dynamic,
    /// §4.2 static trial at a Table 4.1 point (`static_trial`).
    Static,
    /// §5.2 force-step test at one of the nine poses (`force_step_test`).
    ForceStep,
    /// Impedance mode at a Table 4.1 point with the dynamic trial's operator
    /// (`impedance_trial`).
    Impedance,
}

impl Experiment {
    /// Every experiment, in the order of their names in messages.
    pub const ALL: [Experiment; 4] = [
        Experiment::Dynamic,
        Experiment::Static,
        Experiment::ForceStep,
        Experiment::Impedance,
    ];

    /// The name on the command line: `dynamic`, `static`, `force_step`.
    pub fn name(self) -> &'static str {
        match self {
            Experiment::Dynamic => "dynamic",
            Experiment::Static => "static",
            Experiment::ForceStep => "force_step",
            Experiment::Impedance => "impedance",
        }
    }
}

impl fmt::Display for Experiment {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Experiment {
    type Err = SimulateError;
    fn from_str(s: &str) -> Result<Self, SimulateError> {
        Experiment::ALL
            .into_iter()
            .find(|e| e.name() == s)
            .ok_or_else(|| SimulateError::UnknownExperiment(s.to_string()))
    }
}

/// A stiffness level by name (`low`, `high`), with the simulator's error.
pub fn parse_stiffness(s: &str) -> Result<StiffnessLevel, SimulateError> {
    s.parse()
        .map_err(|_| SimulateError::UnknownStiffness(s.to_string()))
}

/// One trial: the experiment, where and how it runs, and what the twin hides.
#[derive(Clone, Debug, PartialEq)]
pub struct TrialSpec {
    pub experiment: Experiment,
    /// Table 4.1 point, 1–5 (dynamic and static trials). Default 1.
    pub point: usize,
    /// Index into [`STEP_POSES_DEG`], 0–8 (force-step test). Default 0.
    pub pose: usize,
    /// Default [`StiffnessLevel::Low`] (dynamic and static trials).
    pub stiffness: StiffnessLevel,
    /// Length of a dynamic trial, s. Default 90.
    pub duration_s: f64,
    /// Loop and logging period, s. Default 0.001 (the thesis's loop: 0.05).
    pub period_s: f64,
    /// Seed of the twin's noise, effects and operator path. Default 0.
    pub seed: u64,
    /// Load-cell noise (standard deviation per axis, N); `None` keeps the twin's default.
    pub loadcell_noise_n: Option<f64>,
    /// Effect specs, `id` or `id:name=value,...` (`effects::parse`). Default none.
    pub effects: Vec<String>,
    /// Gain-plane feed-forward in force mode. Default off.
    pub feed_forward: bool,
    /// Closed-loop force mode (force-step test). Default off.
    pub closed_loop: bool,
    /// Multiplier of the closed loop's designed feedback gains. Default 1.
    pub gain_scale: f64,
    /// Impedance trial: the virtual stiffness (N/m) and damping (N·s/m), both axes.
    pub impedance: VirtualImpedance,
    /// The rig as the thesis measured it: Table 5.2's force ratio and Fig. 4.3's stiffness
    /// (`TwinConfig::identified_rig`)
    /// instead of the thesis's model. Default off.
    pub identified_rig: bool,
}

impl TrialSpec {
    /// The defaults above for `experiment`.
    pub fn new(experiment: Experiment) -> Self {
        TrialSpec {
            experiment,
            point: 1,
            pose: 0,
            stiffness: StiffnessLevel::Low,
            duration_s: 90.0,
            period_s: 0.001,
            seed: 0,
            loadcell_noise_n: None,
            effects: Vec::new(),
            feed_forward: false,
            closed_loop: false,
            gain_scale: 1.0,
            impedance: VirtualImpedance {
                stiffness_n_per_m: [0.0; 2],
                damping_n_s_per_m: [5.0; 2],
                mass_kg: [0.0; 2],
            },
            identified_rig: false,
        }
    }

    /// The experiment's configuration: the twin (rig, seed, noise, effects) and the loop.
    pub fn config(&self) -> Result<ExperimentConfig, SimulateError> {
        let mut twin = if self.identified_rig {
            TwinConfig::identified_rig()
        } else {
            TwinConfig::thesis()
        };
        twin.seed = self.seed;
        if let Some(n) = self.loadcell_noise_n {
            if !(n.is_finite() && n >= 0.0) {
                return Err(SimulateError::Noise(n));
            }
            twin.sensors.loadcell_noise_n = [n; 2];
        }
        twin.effects = EffectSet::parse_list(&self.effects).map_err(SimulateError::Effects)?;
        let mut cfg = ExperimentConfig::new(twin);
        cfg.period_s = self.period_s;
        cfg.feed_forward = self.feed_forward;
        cfg.closed_loop = self.closed_loop;
        cfg.gain_scale = self.gain_scale;
        Ok(cfg)
    }
}

/// Why a trial could not run.
#[derive(Debug)]
pub enum SimulateError {
    /// Not `dynamic`, `static` or `force_step`.
    UnknownExperiment(String),
    /// Not `low` or `high`.
    UnknownStiffness(String),
    /// A force-step pose index outside 0–8.
    Pose(usize),
    /// A negative or non-finite load-cell noise.
    Noise(f64),
    /// An effect spec that does not parse or repeats an effect.
    Effects(EffectError),
    /// The experiment refused its configuration or failed on the way.
    Experiment(ExperimentError),
}

impl fmt::Display for SimulateError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SimulateError::UnknownExperiment(s) => {
                let names: Vec<&str> = Experiment::ALL.iter().map(|e| e.name()).collect();
                write!(
                    f,
                    "unknown experiment `{s}` (expected {})",
                    names.join(", ")
                )
            }
            SimulateError::UnknownStiffness(s) => {
                write!(f, "stiffness `{s}`: expected low or high")
            }
            SimulateError::Pose(p) => write!(
                f,
                "pose {p}: expected 0..{} (an index into the §5.2 poses)",
                STEP_POSES_DEG.len() - 1
            ),
            SimulateError::Noise(n) => {
                write!(f, "load-cell noise {n} N: expected a finite value ≥ 0")
            }
            SimulateError::Effects(e) => write!(f, "effects: {e}"),
            SimulateError::Experiment(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for SimulateError {}

/// Runs the trial and returns its log (format v1, with the experiment's metadata).
pub fn run_trial(spec: &TrialSpec) -> Result<Log, SimulateError> {
    let cfg = spec.config()?;
    let log = match spec.experiment {
        Experiment::Dynamic => dynamic_trial(&cfg, spec.point, spec.stiffness, spec.duration_s),
        Experiment::Static => static_trial(&cfg, spec.point, spec.stiffness),
        Experiment::ForceStep => {
            let pose = *STEP_POSES_DEG
                .get(spec.pose)
                .ok_or(SimulateError::Pose(spec.pose))?;
            force_step_test(&cfg, pose)
        }
        Experiment::Impedance => impedance_trial(&cfg, spec.point, spec.impedance, spec.duration_s),
    };
    log.map_err(SimulateError::Experiment)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_unknown_names_are_refused() {
        for e in Experiment::ALL {
            assert_eq!(e.name().parse::<Experiment>().unwrap(), e);
        }
        let e = "force-step".parse::<Experiment>().unwrap_err();
        assert_eq!(
            e.to_string(),
            "unknown experiment `force-step` (expected dynamic, static, force_step, impedance)"
        );
        assert_eq!(parse_stiffness("high").unwrap(), StiffnessLevel::High);
        assert!(matches!(
            parse_stiffness("medium"),
            Err(SimulateError::UnknownStiffness(_))
        ));
    }

    #[test]
    fn spec_reaches_the_twin_and_the_loop() {
        let mut spec = TrialSpec::new(Experiment::Static);
        spec.seed = 9;
        spec.loadcell_noise_n = Some(0.4);
        spec.period_s = 0.02;
        spec.feed_forward = true;
        spec.effects = vec!["mains_hum".into(), "loadcell_drift:offset_x_n=2".into()];
        let cfg = spec.config().unwrap();
        assert_eq!(cfg.twin.seed, 9);
        assert_eq!(cfg.twin.sensors.loadcell_noise_n, [0.4, 0.4]);
        assert_eq!(cfg.period_s, 0.02);
        assert!(cfg.feed_forward);
        assert_eq!(cfg.twin.effects.specs().len(), 2);
        assert_eq!(
            TrialSpec::new(Experiment::Static)
                .config()
                .unwrap()
                .twin
                .sensors,
            TwinConfig::thesis().sensors
        );
    }

    #[test]
    fn bad_values_are_typed_errors() {
        let mut spec = TrialSpec::new(Experiment::ForceStep);
        spec.pose = 9;
        assert!(matches!(run_trial(&spec), Err(SimulateError::Pose(9))));
        let mut spec = TrialSpec::new(Experiment::Dynamic);
        spec.loadcell_noise_n = Some(-1.0);
        assert!(matches!(run_trial(&spec), Err(SimulateError::Noise(_))));
        let mut spec = TrialSpec::new(Experiment::Dynamic);
        spec.effects = vec!["no_such_effect".into()];
        assert!(matches!(run_trial(&spec), Err(SimulateError::Effects(_))));
        let mut spec = TrialSpec::new(Experiment::Static);
        spec.point = 6;
        let e = run_trial(&spec).unwrap_err();
        assert!(matches!(e, SimulateError::Experiment(_)), "{e}");
    }
}
