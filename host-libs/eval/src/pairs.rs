//! Pairs of dynamic logs of the same trial at Table 4.1's two stiffness levels, with
//! friction or with the muscles' hysteresis, decided by
//! [`pam_model_loop::stiffness_pair`]: the cases of `examples/friction_pairs.rs` and of
//! `tests/friction_pairs.rs`.

use pam_ident::Trial;
use pam_model::RobotModel;
use pam_model_loop::diagnose::Settings;
use pam_model_loop::effects::Family;
use pam_model_loop::stiffness_pair::{friction_or_hysteresis, PairVerdict};
use pam_physgen::{CaseSpec, Effect, Experiment};
use pam_twin::experiments::{dynamic_trial, ExperimentConfig, StiffnessLevel};
use pam_twin::{config::TwinConfig, EffectSet};

/// What a pair holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Truth {
    Friction,
    Hysteresis,
}

impl Truth {
    pub fn name(self) -> &'static str {
        match self {
            Truth::Friction => "friction",
            Truth::Hysteresis => "hysteresis",
        }
    }
}

/// One pair to make: the generator, what it holds, its index in the plan (which picks the
/// form and the size) and its seed.
#[derive(Clone, Copy, Debug)]
pub struct PairCase {
    pub generator: &'static str,
    pub truth: Truth,
    pub index: usize,
    pub seed: u64,
    pub duration_s: f64,
}

/// What the decision said.
#[derive(Clone, Debug)]
pub struct PairOutcome {
    /// The case's form (which friction, where).
    pub form: String,
    pub named: Option<Truth>,
    pub verdict: Option<PairVerdict>,
    pub error: Option<String>,
}

impl PairOutcome {
    /// One line for a listing.
    pub fn line(&self) -> String {
        match (&self.verdict, &self.error) {
            (_, Some(e)) => format!("{}: error {e}", self.form),
            (Some(v), None) => format!(
                "{}: {} (growth {:.2}{}, torque ×{:.2} ×{:.2}, force ×{:.2} ×{:.2}, pressure ×{:.2} ×{:.2}: {:.2} {:.2} → {:.2} {:.2} bar, gain {:.3} {:.3})",
                self.form,
                self.named.map_or("cannot tell", |t| t.name()),
                v.growth,
                if v.at_handle { " at the handle" } else { "" },
                v.torque_ratio[0],
                v.torque_ratio[1],
                v.force_ratio[0],
                v.force_ratio[1],
                v.pressure_ratio[0],
                v.pressure_ratio[1],
                v.logs[0].mean_pressure_bar[0],
                v.logs[0].mean_pressure_bar[1],
                v.logs[1].mean_pressure_bar[0],
                v.logs[1].mean_pressure_bar[1],
                v.logs[0].train_gain,
                v.logs[1].train_gain
            ),
            (None, None) => format!("{}: nothing", self.form),
        }
    }
}

/// A severity in 0–1 spread evenly over the plan (the golden-ratio sequence).
fn severity(index: usize) -> f64 {
    (0.5 + index as f64 * 0.618_033_988_749_895).fract()
}

/// Friction or hysteresis from a dynamic log and the same trial at the other stiffness
/// level, with the loop's default settings and the thesis's model.
pub fn decide(a: &Trial, b: &Trial) -> Result<PairVerdict, String> {
    let model = RobotModel::<f64>::thesis();
    friction_or_hysteresis(a, b, &model, Settings::default()).map_err(|e| e.to_string())
}

fn decided(form: String, logs: Result<[Trial; 2], String>) -> PairOutcome {
    let verdict = logs.and_then(|[a, b]| decide(&a, &b));
    match verdict {
        Ok(v) => PairOutcome {
            form,
            named: match v.family {
                Some(Family::Friction) => Some(Truth::Friction),
                Some(Family::Hysteresis) => Some(Truth::Hysteresis),
                _ => None,
            },
            verdict: Some(v),
            error: None,
        },
        Err(e) => PairOutcome {
            form,
            named: None,
            verdict: None,
            error: Some(e),
        },
    }
}

fn trial_of(text: &str) -> Result<Trial, String> {
    let log = pam_log::read_str(text, None).map_err(|e| e.to_string())?;
    Trial::from_log(&log).map_err(|e| e.to_string())
}

/// A pam-physgen pair: the same rig, operator and effect (one seed) at the point's K_low
/// and K_high. Friction cycles through LuGre in the joints, Maxwell-slip in the joints and
/// LuGre at the handle.
pub fn physgen_pair(c: &PairCase) -> PairOutcome {
    let effect = match c.truth {
        Truth::Friction => [
            Effect::JointLugre,
            Effect::JointMaxwellSlip,
            Effect::HandleLugre,
        ][c.index % 3],
        Truth::Hysteresis => Effect::MuscleBoucWen,
    };
    let spec = CaseSpec {
        experiment: Experiment::Dynamic,
        effect,
        seed: c.seed,
        severity: severity(c.index),
    };
    let form = format!(
        "{} seed {} severity {:.2}",
        effect.name(),
        c.seed,
        spec.severity
    );
    let logs = [0.0, 1.0].map(|level| {
        pam_physgen::generate_at_stiffness(&spec, Some(c.duration_s), level)
            .map_err(|e| e.to_string())
            .and_then(|g| trial_of(&g.log_text))
    });
    let logs = match logs {
        [Ok(a), Ok(b)] => Ok([a, b]),
        [Err(e), _] | [_, Err(e)] => Err(e),
    };
    decided(form, logs)
}

/// A twin pair: the dynamic trial at one of Table 4.1's points (by the index) at K_low and
/// K_high, with the carrier ball's friction (1–4 N) or the muscles' hysteresis (2–6 % of
/// their force).
pub fn twin_pair(c: &PairCase) -> PairOutcome {
    let s = severity(c.index);
    let spec = match c.truth {
        Truth::Friction => format!("carrier_ball_friction:coulomb_n={:.2}", 1.0 + 3.0 * s),
        Truth::Hysteresis => format!("muscle_hysteresis:fraction={:.3}", 0.02 + 0.04 * s),
    };
    let point = 1 + c.index % 5;
    let form = format!("{spec} point {point} seed {}", c.seed);
    let mut tw = TwinConfig::thesis();
    tw.seed = c.seed;
    let logs = EffectSet::parse_list(&[spec.as_str()])
        .map_err(|e| e.to_string())
        .and_then(|effects| {
            tw.effects = effects;
            let cfg = ExperimentConfig::new(tw);
            let run = |level| {
                dynamic_trial(&cfg, point, level, c.duration_s)
                    .map_err(|e| e.to_string())
                    .and_then(|log| Trial::from_log(&log).map_err(|e| e.to_string()))
            };
            Ok([run(StiffnessLevel::Low)?, run(StiffnessLevel::High)?])
        });
    decided(form, logs)
}
