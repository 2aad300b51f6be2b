//! What one generated log is: experiment, hidden effect (family and shape), sampling,
//! duration, noise and the relative size the effect is scaled to. `CaseSpec::random`
//! draws a balanced case from a seed.

use pam_effect_id::Family as EffectFamily;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::error::SynthError;

/// The two trial types of the thesis: §4.3 (operator moves the handle) and §5.2 (blocked
/// handle, force steps).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Experiment {
    Dynamic,
    Step,
}

impl Experiment {
    pub const ALL: [Experiment; 2] = [Experiment::Dynamic, Experiment::Step];

    pub fn name(self) -> &'static str {
        match self {
            Experiment::Dynamic => "dynamic",
            Experiment::Step => "step",
        }
    }

    pub fn parse(s: &str) -> Result<Self, SynthError> {
        Self::ALL
            .into_iter()
            .find(|e| e.name() == s)
            .ok_or_else(|| SynthError::UnknownName {
                what: "experiment",
                name: s.to_string(),
                choices: "dynamic, step".into(),
            })
    }
}

/// The truth label. The effect families are the model loop's ([`EffectFamily`]); `None` is a
/// control and `Unexplained` a structure outside the loop's catalog.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, PartialOrd, Ord)]
#[serde(rename_all = "snake_case")]
pub enum Family {
    None,
    Friction,
    Drag,
    Hysteresis,
    Backlash,
    StiffnessNonlinearity,
    PoseDependence,
    Drift,
    Delay,
    RateLimits,
    Saturation,
    Unexplained,
}

impl Family {
    pub const ALL: [Family; 12] = [
        Family::None,
        Family::Friction,
        Family::Drag,
        Family::Hysteresis,
        Family::Backlash,
        Family::StiffnessNonlinearity,
        Family::PoseDependence,
        Family::Drift,
        Family::Delay,
        Family::RateLimits,
        Family::Saturation,
        Family::Unexplained,
    ];

    /// The model loop's family this label names; `None` for the control and for a
    /// structure outside the families.
    pub fn effect_family(self) -> Option<EffectFamily> {
        use EffectFamily as F;
        Some(match self {
            Family::None | Family::Unexplained => return None,
            Family::Friction => F::Friction,
            Family::Drag => F::Drag,
            Family::Hysteresis => F::Hysteresis,
            Family::Backlash => F::Backlash,
            Family::StiffnessNonlinearity => F::StiffnessNonlinearity,
            Family::PoseDependence => F::PoseDependence,
            Family::Drift => F::Drift,
            Family::Delay => F::Delay,
            Family::RateLimits => F::RateLimits,
            Family::Saturation => F::Saturation,
        })
    }

    /// The snake_case name: the model loop's family name, `none` or `unexplained`.
    pub fn name(self) -> &'static str {
        match (self, self.effect_family()) {
            (_, Some(f)) => f.name(),
            (Family::None, None) => "none",
            _ => "unexplained",
        }
    }

    pub fn parse(s: &str) -> Result<Self, SynthError> {
        Self::ALL
            .into_iter()
            .find(|f| f.name() == s)
            .ok_or_else(|| SynthError::UnknownName {
                what: "family",
                name: s.to_string(),
                choices: Self::ALL.map(|f| f.name()).join(", "),
            })
    }

    /// The shapes of this family that can show in `experiment` (empty: not in that experiment).
    pub fn shapes(self, experiment: Experiment) -> Vec<Shape> {
        Shape::ALL
            .into_iter()
            .filter(|s| s.family() == self && s.experiments().contains(&experiment))
            .collect()
    }

    /// The families (controls included) that exist in `experiment`.
    pub fn of(experiment: Experiment) -> Vec<Family> {
        Self::ALL
            .into_iter()
            .filter(|f| !f.shapes(experiment).is_empty())
            .collect()
    }
}

/// One functional form of a family. Names are unique across families.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, PartialOrd, Ord)]
#[serde(rename_all = "snake_case")]
pub enum Shape {
    /// The control: no hidden effect.
    Control,
    Coulomb,
    ViscousPlusCoulomb,
    Stribeck,
    Lugre,
    Quadratic,
    BoucWen,
    ElasticLoop,
    MaxwellSlip,
    /// Step test: the steady state depends on the direction of the last step.
    DirectionOffset,
    /// Step test: a play (backlash) operator of the commanded force.
    ForcePlay,
    JointPlay,
    CubicNeutral,
    CubicEquilibrium,
    CartesianLinear,
    JointGainPlane,
    OffsetLinear,
    OffsetExponential,
    SensorSync,
    DeadTime,
    TubeLag,
    OutputSlew,
    InputSlew,
    HardClip,
    TanhKnee,
    PressureCap,
    MainsTone,
    SlowWander,
}

impl Shape {
    pub const ALL: [Shape; 28] = [
        Shape::Control,
        Shape::Coulomb,
        Shape::ViscousPlusCoulomb,
        Shape::Stribeck,
        Shape::Lugre,
        Shape::Quadratic,
        Shape::BoucWen,
        Shape::ElasticLoop,
        Shape::MaxwellSlip,
        Shape::DirectionOffset,
        Shape::ForcePlay,
        Shape::JointPlay,
        Shape::CubicNeutral,
        Shape::CubicEquilibrium,
        Shape::CartesianLinear,
        Shape::JointGainPlane,
        Shape::OffsetLinear,
        Shape::OffsetExponential,
        Shape::SensorSync,
        Shape::DeadTime,
        Shape::TubeLag,
        Shape::OutputSlew,
        Shape::InputSlew,
        Shape::HardClip,
        Shape::TanhKnee,
        Shape::PressureCap,
        Shape::MainsTone,
        Shape::SlowWander,
    ];

    pub fn family(self) -> Family {
        use Shape::*;
        match self {
            Control => Family::None,
            Coulomb | ViscousPlusCoulomb | Stribeck | Lugre => Family::Friction,
            Quadratic => Family::Drag,
            BoucWen | ElasticLoop | MaxwellSlip | DirectionOffset | ForcePlay => Family::Hysteresis,
            JointPlay => Family::Backlash,
            CubicNeutral | CubicEquilibrium => Family::StiffnessNonlinearity,
            CartesianLinear | JointGainPlane => Family::PoseDependence,
            OffsetLinear | OffsetExponential => Family::Drift,
            SensorSync | DeadTime | TubeLag => Family::Delay,
            OutputSlew | InputSlew => Family::RateLimits,
            HardClip | TanhKnee | PressureCap => Family::Saturation,
            MainsTone | SlowWander => Family::Unexplained,
        }
    }

    /// The experiments in which this shape is generated.
    pub fn experiments(self) -> &'static [Experiment] {
        use Experiment as E;
        use Shape::*;
        match self {
            Control | OffsetLinear | OffsetExponential | MainsTone => &[E::Dynamic, E::Step],
            Coulomb | ViscousPlusCoulomb | Stribeck | Lugre | Quadratic | BoucWen | ElasticLoop
            | MaxwellSlip | JointPlay | CubicNeutral | CubicEquilibrium | CartesianLinear
            | JointGainPlane | SensorSync | SlowWander => &[E::Dynamic],
            DirectionOffset | ForcePlay | DeadTime | TubeLag | OutputSlew | InputSlew
            | HardClip | TanhKnee | PressureCap => &[E::Step],
        }
    }

    pub fn name(self) -> &'static str {
        use Shape::*;
        match self {
            Control => "control",
            Coulomb => "coulomb",
            ViscousPlusCoulomb => "viscous_plus_coulomb",
            Stribeck => "stribeck",
            Lugre => "lugre",
            Quadratic => "quadratic",
            BoucWen => "bouc_wen",
            ElasticLoop => "elastic_loop",
            MaxwellSlip => "maxwell_slip",
            DirectionOffset => "direction_offset",
            ForcePlay => "force_play",
            JointPlay => "joint_play",
            CubicNeutral => "cubic_neutral",
            CubicEquilibrium => "cubic_equilibrium",
            CartesianLinear => "cartesian_linear",
            JointGainPlane => "joint_gain_plane",
            OffsetLinear => "offset_linear",
            OffsetExponential => "offset_exponential",
            SensorSync => "sensor_sync",
            DeadTime => "dead_time",
            TubeLag => "tube_lag",
            OutputSlew => "output_slew",
            InputSlew => "input_slew",
            HardClip => "hard_clip",
            TanhKnee => "tanh_knee",
            PressureCap => "pressure_cap",
            MainsTone => "mains_tone",
            SlowWander => "slow_wander",
        }
    }

    pub fn parse(s: &str) -> Result<Self, SynthError> {
        Self::ALL
            .into_iter()
            .find(|x| x.name() == s)
            .ok_or_else(|| SynthError::UnknownName {
                what: "shape",
                name: s.to_string(),
                choices: Self::ALL.map(|x| x.name()).join(", "),
            })
    }

    /// Whether the shape needs fast sampling to be seen at all (a 50/60 Hz tone).
    pub fn needs_fast_sampling(self) -> bool {
        self == Shape::MainsTone
    }
}

/// The sampling periods drawn (the rig's LabVIEW loop ran at 30–40 ms, the firmware at 1–10 ms).
pub const PERIODS_S: [f64; 6] = [0.001, 0.002, 0.005, 0.01, 0.02, 0.05];
/// Longest log, in samples, so the loop runs in about a second.
pub const MAX_SAMPLES: usize = 60_000;
/// The relative size range of a hidden effect: RMS(contribution) / std(logged force).
pub const RELATIVE_SIZE_RANGE: (f64, f64) = (0.02, 0.25);
/// Fastest sampling at which a mains tone is drawn.
pub const TONE_MAX_PERIOD_S: f64 = 0.005;

/// One log to generate. Every other random choice (KBM perturbation, operator path, step
/// schedule, effect parameters, noise) is drawn inside `generate` from `seed`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CaseSpec {
    pub experiment: Experiment,
    pub family: Family,
    pub shape: Shape,
    pub seed: u64,
    pub dt_s: f64,
    pub duration_s: f64,
    /// Standard deviation of the load cell's white noise per axis.
    pub noise_n: f64,
    /// The RMS of the effect's contribution over the std of the logged force.
    pub target_relative_size: f64,
    /// Dynamic: Table 4.1 point 1–5; step: step pose 1–9 (§5.2's order).
    pub site: usize,
    /// Step: the order of the axes' steps.
    #[serde(default)]
    pub step_order: StepOrder,
    /// What the recording adds that is not an effect (`nuisance.rs`); none by default.
    #[serde(default)]
    pub nuisances: crate::nuisance::Nuisances,
    /// Dynamic: how the operator moves the handle (`motion.rs`); the first motion by default.
    #[serde(default)]
    pub motion: crate::motion::OperatorMotion,
    /// Step: where the reference's levels lie.
    #[serde(default)]
    pub step_levels: StepLevels,
}

/// Where a step log's reference levels lie. A rig's users do not all run §5.2's lattice.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StepLevels {
    /// Whole steps of ±1–3 × the log's step on one axis at a time (the generator's first
    /// schedule; §5.2's levels are such a lattice).
    #[default]
    Lattice,
    /// Any level within ±3 steps on one axis at a time, at least half a step from the last.
    Continuous,
    /// Both axes step at once, to whole levels of ±2 steps that both differ from the last.
    Diagonal,
}

impl StepLevels {
    pub const ALL: [StepLevels; 3] = [
        StepLevels::Lattice,
        StepLevels::Continuous,
        StepLevels::Diagonal,
    ];

    pub fn name(self) -> &'static str {
        match self {
            StepLevels::Lattice => "lattice",
            StepLevels::Continuous => "continuous",
            StepLevels::Diagonal => "diagonal",
        }
    }
}

/// The step levels of each log: one for all, or drawn per seed.
pub type StepLevelsPlan = crate::plan::Plan<StepLevels>;

/// The random stream the levels' draw and the levels themselves use (the schedule's
/// holds keep the base stream's draws).
pub const STREAM_LEVELS: u64 = 6;

impl crate::plan::Choice for StepLevels {
    const ALL: &'static [Self] = &StepLevels::ALL;
    const WHAT: &'static str = "step levels";
    const STREAM: u64 = STREAM_LEVELS;
    fn name(self) -> &'static str {
        StepLevels::name(self)
    }
}

/// The order in which a step log steps its axes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StepOrder {
    /// Runs of 4–8 steps on one axis, then on the other, in turn (the generator's draw).
    #[default]
    Alternating,
    /// The thesis's protocol (§5.2): X's steps for the first half of the log, then Y's.
    XThenY,
}

impl StepOrder {
    pub fn parse(s: &str) -> Result<Self, SynthError> {
        match s {
            "alternating" => Ok(StepOrder::Alternating),
            "x_then_y" | "x-then-y" => Ok(StepOrder::XThenY),
            other => Err(SynthError::UnknownName {
                what: "step order",
                name: other.to_string(),
                choices: "alternating, x_then_y".to_string(),
            }),
        }
    }
}

fn log_uniform(rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> f64 {
    (lo.ln() + rng.random::<f64>() * (hi.ln() - lo.ln())).exp()
}

impl CaseSpec {
    /// A random case. `experiment`/`family` fix those choices; otherwise a control with
    /// probability 1/4, else a family of the experiment (uniform), then a shape (uniform).
    pub fn random(
        seed: u64,
        experiment: Option<Experiment>,
        family: Option<Family>,
    ) -> Result<Self, SynthError> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5EED_CA5E);
        let experiment = match (experiment, family) {
            (Some(e), _) => e,
            (None, Some(f)) => {
                let ok: Vec<Experiment> = Experiment::ALL
                    .into_iter()
                    .filter(|e| !f.shapes(*e).is_empty())
                    .collect();
                ok[rng.random_range(0..ok.len().max(1))]
            }
            (None, None) => Experiment::ALL[rng.random_range(0..2)],
        };
        let family = match family {
            Some(f) => f,
            None if rng.random::<f64>() < 0.25 => Family::None,
            None => {
                let effects: Vec<Family> = Family::of(experiment)
                    .into_iter()
                    .filter(|f| *f != Family::None)
                    .collect();
                effects[rng.random_range(0..effects.len())]
            }
        };
        let shapes = family.shapes(experiment);
        if shapes.is_empty() {
            return Err(SynthError::ShapeNotInExperiment {
                shape: family.name().into(),
                experiment: experiment.name().into(),
            });
        }
        let mut dt_s = PERIODS_S[rng.random_range(0..PERIODS_S.len())];
        let shape = shapes[rng.random_range(0..shapes.len())];
        let shape = match shape {
            // a tone needs fast sampling: in dynamic trials a slow wander takes its place
            Shape::MainsTone | Shape::SlowWander
                if experiment == Experiment::Dynamic && dt_s > TONE_MAX_PERIOD_S =>
            {
                Shape::SlowWander
            }
            s => s,
        };
        if shape.needs_fast_sampling() && dt_s > TONE_MAX_PERIOD_S {
            dt_s = PERIODS_S[rng.random_range(0..3)];
        }
        let duration_s = match experiment {
            Experiment::Dynamic => rng.random_range(40.0..120.0),
            Experiment::Step => rng.random_range(40.0..100.0),
        };
        let duration_s = f64::min(duration_s, MAX_SAMPLES as f64 * dt_s).round();
        let noise_n = log_uniform(&mut rng, 0.05, 1.0);
        let target_relative_size =
            log_uniform(&mut rng, RELATIVE_SIZE_RANGE.0, RELATIVE_SIZE_RANGE.1);
        let site = match experiment {
            Experiment::Dynamic => rng.random_range(1..=5),
            Experiment::Step => rng.random_range(1..=9),
        };
        let spec = CaseSpec {
            experiment,
            family,
            shape,
            seed,
            dt_s,
            duration_s,
            noise_n,
            target_relative_size,
            site,
            step_order: StepOrder::Alternating,
            nuisances: Default::default(),
            motion: Default::default(),
            step_levels: Default::default(),
        };
        spec.validate()?;
        Ok(spec)
    }

    /// The same case with another shape (its family follows).
    pub fn with_shape(mut self, shape: Shape) -> Result<Self, SynthError> {
        self.shape = shape;
        self.family = shape.family();
        self.validate()?;
        Ok(self)
    }

    /// Samples in the log.
    pub fn samples(&self) -> usize {
        (self.duration_s / self.dt_s).round() as usize
    }

    /// Checks that the combination can be generated.
    pub fn validate(&self) -> Result<(), SynthError> {
        if self.shape.family() != self.family {
            return Err(SynthError::ShapeNotInFamily {
                shape: self.shape.name().into(),
                family: self.family.name().into(),
            });
        }
        if !self.shape.experiments().contains(&self.experiment) {
            return Err(SynthError::ShapeNotInExperiment {
                shape: self.shape.name().into(),
                experiment: self.experiment.name().into(),
            });
        }
        let ms = self.dt_s * 1000.0;
        if !((0.999..=50.001).contains(&ms) && (ms - ms.round()).abs() < 1e-6) {
            return Err(SynthError::BadPeriod { dt_s: self.dt_s });
        }
        if self.shape.needs_fast_sampling() && self.dt_s > TONE_MAX_PERIOD_S + 1e-12 {
            return Err(SynthError::ToneNotResolved { dt_s: self.dt_s });
        }
        if !(5.0..=200.0).contains(&self.duration_s) {
            return Err(SynthError::BadDuration {
                duration_s: self.duration_s,
            });
        }
        self.nuisances.validate()?;
        if !(0.0..=5.0).contains(&self.noise_n) {
            return Err(SynthError::BadNoise {
                noise_n: self.noise_n,
            });
        }
        Ok(())
    }
}
