//! What one log holds: the trial, the physical effect (or none) and its severity, and the
//! model loop's family it counts as.

use rand::Rng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::friction::{BoucWen, LuGre, MaxwellSlip};

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Experiment {
    Dynamic,
    Step,
}

impl Experiment {
    pub fn name(self) -> &'static str {
        match self {
            Experiment::Dynamic => "dynamic",
            Experiment::Step => "step",
        }
    }
}

/// A physical effect beyond the nominal rig.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Effect {
    /// Nothing beyond the nominal rig (the sensors' behaviour is always there).
    Control,
    /// LuGre between the carrier ball and the table.
    HandleLugre,
    /// LuGre in both joints' bearings and pulleys.
    JointLugre,
    /// Generalized Maxwell-slip in both joints.
    JointMaxwellSlip,
    /// Bouc–Wen hysteresis of the muscles' force, growing with pressure.
    MuscleBoucWen,
    /// The load-cell amplifier's anti-alias filter lags the force behind the encoders.
    AmplifierLag,
    /// The supply cannot deliver the highest set-points.
    SupplyLimit,
    /// The valves' flow is choked: the pressure rises and falls at most so fast.
    ChokedFlow,
    /// A long tube adds a transport delay to every converter.
    LongTube,
}

impl Effect {
    pub const DYNAMIC: [Effect; 5] = [
        Effect::HandleLugre,
        Effect::JointLugre,
        Effect::JointMaxwellSlip,
        Effect::MuscleBoucWen,
        Effect::AmplifierLag,
    ];
    pub const STEP: [Effect; 4] = [
        Effect::SupplyLimit,
        Effect::ChokedFlow,
        Effect::LongTube,
        Effect::MuscleBoucWen,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Effect::Control => "control",
            Effect::HandleLugre => "handle_lugre",
            Effect::JointLugre => "joint_lugre",
            Effect::JointMaxwellSlip => "joint_maxwell_slip",
            Effect::MuscleBoucWen => "muscle_bouc_wen",
            Effect::AmplifierLag => "amplifier_lag",
            Effect::SupplyLimit => "supply_limit",
            Effect::ChokedFlow => "choked_flow",
            Effect::LongTube => "long_tube",
        }
    }

    /// The model loop's family (docs/model-loop.md's catalog): friction wherever it acts.
    pub fn family(self) -> &'static str {
        match self {
            Effect::Control => "none",
            Effect::HandleLugre | Effect::JointLugre | Effect::JointMaxwellSlip => "friction",
            Effect::MuscleBoucWen => "hysteresis",
            Effect::AmplifierLag | Effect::LongTube => "delay",
            Effect::SupplyLimit => "saturation",
            Effect::ChokedFlow => "rate_limits",
        }
    }

    /// The closest shape name of the judge's truth format (pam-synth's `Shape`).
    pub fn shape(self) -> &'static str {
        match self {
            Effect::Control => "control",
            Effect::HandleLugre | Effect::JointLugre => "lugre",
            Effect::JointMaxwellSlip => "maxwell_slip",
            Effect::MuscleBoucWen => "bouc_wen",
            Effect::AmplifierLag => "sensor_sync",
            Effect::SupplyLimit => "pressure_cap",
            Effect::ChokedFlow => "output_slew",
            Effect::LongTube => "dead_time",
        }
    }

    /// Where the effect acts.
    pub fn location(self) -> &'static str {
        match self {
            Effect::Control => "none",
            Effect::HandleLugre => "handle",
            Effect::JointLugre | Effect::JointMaxwellSlip => "joints",
            Effect::MuscleBoucWen => "muscles",
            Effect::AmplifierLag => "load_cell",
            Effect::SupplyLimit | Effect::ChokedFlow | Effect::LongTube => "converters",
        }
    }
}

/// One log to generate; everything else is drawn from `seed` inside `generate`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CaseSpec {
    pub experiment: Experiment,
    pub effect: Effect,
    pub seed: u64,
    /// Severity in 0–1: where in the effect's range its parameters lie.
    pub severity: f64,
}

impl CaseSpec {
    /// The k-th case of a suite: every effect of both trials in turn, severities drawn.
    pub fn effect_case(k: usize, seed: u64, rng: &mut ChaCha8Rng) -> Self {
        let all: Vec<(Experiment, Effect)> = Effect::DYNAMIC
            .iter()
            .map(|e| (Experiment::Dynamic, *e))
            .chain(Effect::STEP.iter().map(|e| (Experiment::Step, *e)))
            .collect();
        let (experiment, effect) = all[k % all.len()];
        CaseSpec {
            experiment,
            effect,
            seed,
            severity: rng.random::<f64>(),
        }
    }

    pub fn control(k: usize, seed: u64) -> Self {
        CaseSpec {
            experiment: if k.is_multiple_of(2) {
                Experiment::Dynamic
            } else {
                Experiment::Step
            },
            effect: Effect::Control,
            seed,
            severity: 0.0,
        }
    }
}

/// A log-uniform draw between `lo` and `hi` at quantile `u`.
pub fn log_between(lo: f64, hi: f64, u: f64) -> f64 {
    lo * (hi / lo).powf(u.clamp(0.0, 1.0))
}

/// The handle's LuGre at severity `s`: Coulomb 0.5–4 N, stiction 1.2–2 × that.
pub fn handle_lugre(s: f64, rng: &mut ChaCha8Rng) -> LuGre {
    let fc = log_between(0.5, 4.0, s);
    let sigma0 = rng.random_range(2e4..8e4);
    LuGre {
        sigma0,
        sigma1: 0.2 * (sigma0 * 1.0f64).sqrt(),
        sigma2: rng.random_range(0.0..4.0),
        coulomb: fc,
        stiction: fc * rng.random_range(1.2..2.0),
        stribeck_speed: rng.random_range(0.005..0.03),
    }
}

/// Each joint's LuGre: Coulomb 0.1–1.2 N·m at joint 1, 0.6 × that at joint 2.
pub fn joint_lugre(s: f64, rng: &mut ChaCha8Rng) -> [LuGre; 2] {
    let tc = log_between(0.1, 1.2, s);
    let presliding_rad = rng.random_range(2e-4..1.5e-3);
    let ratio = rng.random_range(1.2..1.8);
    let vs = rng.random_range(0.01..0.08);
    [1.0, 0.6].map(|share| {
        let fc = tc * share;
        let sigma0 = fc / presliding_rad;
        LuGre {
            sigma0,
            sigma1: 0.05 * sigma0.sqrt(),
            sigma2: 0.05 * fc,
            coulomb: fc,
            stiction: fc * ratio,
            stribeck_speed: vs,
        }
    })
}

/// Each joint's generalized Maxwell-slip: four elements whose breakaway deflections span
/// 0.2–4 mrad, total breakaway 0.1–1.2 N·m at joint 1 and 0.6 × that at joint 2.
pub fn joint_gms(s: f64, rng: &mut ChaCha8Rng) -> [MaxwellSlip; 2] {
    let tb = log_between(0.1, 1.2, s);
    let d0 = rng.random_range(2e-4..1e-3);
    let ratio = rng.random_range(0.6..0.9);
    [1.0, 0.6].map(|share| {
        let w: Vec<f64> = [0.4, 0.3, 0.2, 0.1]
            .iter()
            .map(|f| f * tb * share)
            .collect();
        let k = w
            .iter()
            .enumerate()
            .map(|(i, wi)| wi / (d0 * 2f64.powi(i as i32)))
            .collect();
        MaxwellSlip {
            k,
            w,
            coulomb_ratio: ratio,
            stribeck_speed: 0.03,
            viscous: 0.02 * tb * share,
        }
    })
}

/// The muscles' Bouc–Wen: a force of 1–6 N per bar (a few per cent of the muscle's force
/// at rest), saturating over 0.2–1 % of contraction.
pub fn muscle_bouc_wen(s: f64, rng: &mut ChaCha8Rng) -> (BoucWen, f64) {
    let beta = rng.random_range(0.5..0.9);
    (
        BoucWen {
            beta,
            gamma: 1.0 - beta,
            n: rng.random_range(1.0..2.0),
            x_ref: rng.random_range(0.002..0.01),
        },
        log_between(1.0, 6.0, s),
    )
}
