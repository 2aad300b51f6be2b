//! The logs the cross-generator runs diagnose (`examples/crossgen.rs`), one per index of a
//! plan: pam-physgen's, pam-synth's and the twin's, each with its truth's family, the
//! effect's footprint ([`crate::footprint`]) and, where the generator can run it, the
//! separating experiment the diagnosis may name for a joint's friction against the
//! muscles' hysteresis: the same trial at the other stiffness level ([`OtherStiffness`]);
//! and, for a step log with too few steps to decide, the same trial longer ([`MoreSteps`]).

use pam_effect_id::EffectId;
use pam_ident::Trial;
use pam_log::Log;
use pam_model_loop::effects::Experiment;
use pam_twin::experiments::{ExperimentConfig, StiffnessLevel};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The same trial at the other stiffness level, as the generator makes it: the same rig,
/// operator and effect (one seed), only the muscles' co-contraction changed.
#[derive(Clone, Debug)]
pub enum OtherStiffness {
    /// pam-physgen's case at this level (0 = the point's K_low, 1 = its K_high), for
    /// `duration_s` (the drawn duration when `None`, as the first log's).
    Physgen {
        spec: pam_physgen::CaseSpec,
        level: f64,
        duration_s: Option<f64>,
    },
    /// The twin's dynamic trial at this Table 4.1 point and level.
    Twin {
        config: Box<ExperimentConfig>,
        point: usize,
        level: StiffnessLevel,
        duration_s: f64,
    },
}

impl OtherStiffness {
    /// The other stiffness level of a pam-physgen log whose truth is `truth`. Dynamic:
    /// K_high where the log was drawn nearer K_low, K_low otherwise. Step (drawn at the
    /// lowest co-contraction that lets every level through): 80 % of the way to the highest
    /// that does, as `pamctl experiment step --co-contraction high` asks on a rig
    /// (`pam_model::protocols::step_test_stiffness_at`).
    pub fn physgen(
        spec: &pam_physgen::CaseSpec,
        truth: &pam_physgen::Truth,
        duration_s: Option<f64>,
    ) -> Option<OtherStiffness> {
        let level = match spec.experiment {
            pam_physgen::Experiment::Dynamic => {
                let drawn = *truth.base.get("stiffness_level")?;
                if drawn < 0.5 {
                    1.0
                } else {
                    0.0
                }
            }
            pam_physgen::Experiment::Step => 0.8,
        };
        Some(OtherStiffness::Physgen {
            spec: *spec,
            level,
            duration_s,
        })
    }

    /// Runs the trial.
    pub fn trial(&self) -> Result<Trial, String> {
        let log = match self {
            OtherStiffness::Physgen {
                spec,
                level,
                duration_s,
            } => pam_physgen::generate_at_stiffness(spec, *duration_s, *level)
                .map_err(|e| e.to_string())
                .and_then(|g| pam_log::read_str(&g.log_text, None).map_err(|e| e.to_string()))?,
            OtherStiffness::Twin {
                config,
                point,
                level,
                duration_s,
            } => pam_twin::experiments::dynamic_trial(config, *point, *level, *duration_s)
                .map_err(|e| e.to_string())?,
        };
        Trial::from_log(&log).map_err(|e| e.to_string())
    }
}

/// The same step trial, longer, as the generator makes it: the same rig and effect (one
/// seed), the schedule drawn again for the longer duration.
#[derive(Clone, Debug)]
pub enum MoreSteps {
    Physgen(pam_physgen::CaseSpec),
    Synth(Box<pam_synth::CaseSpec>),
}

impl MoreSteps {
    /// Runs the trial `first` was, lengthened from its `steps` to about `steps_needed`
    /// (the generators draw steps at an even rate over the trial).
    pub fn trial_with_steps(
        &self,
        first: &Trial,
        steps: usize,
        steps_needed: usize,
    ) -> Result<Trial, String> {
        let span_s = match (first.t_s.first(), first.t_s.last()) {
            (Some(a), Some(b)) if steps > 0 => b - a,
            _ => return Err("the first trial has no steps to lengthen".into()),
        };
        self.trial((span_s * steps_needed as f64 / steps as f64).ceil())
    }

    /// Runs the trial for `duration_s`.
    pub fn trial(&self, duration_s: f64) -> Result<Trial, String> {
        let text = match self {
            MoreSteps::Physgen(spec) => pam_physgen::generate(spec, Some(duration_s))
                .map(|g| g.log_text)
                .map_err(|e| e.to_string())?,
            MoreSteps::Synth(spec) => pam_synth::generate(&pam_synth::CaseSpec {
                duration_s,
                ..(**spec).clone()
            })
            .map(|g| g.log_text)
            .map_err(|e| e.to_string())?,
        };
        let log = pam_log::read_str(&text, None).map_err(|e| e.to_string())?;
        Trial::from_log(&log).map_err(|e| e.to_string())
    }
}

/// One log to diagnose: its generator's label, the trial, the truth's family, and the
/// effect's footprint (`pam_eval::footprint`; `None` for a control).
pub struct Case {
    pub label: String,
    pub family: String,
    pub experiment: Experiment,
    pub log: Result<Log, String>,
    pub footprint: Option<f64>,
    /// The same trial at the other stiffness level, where the generator can run it.
    pub other_stiffness: Option<OtherStiffness>,
    /// A step trial: the same trial longer, where the generator can run it.
    pub more_steps: Option<MoreSteps>,
}

/// The footprint of `log`'s effect against the same config drawn without it.
fn footprint_against(log: &Result<Log, String>, without: Result<Log, String>) -> Option<f64> {
    crate::footprint::footprint(log.as_ref().ok()?, &without.ok()?)
}

fn physgen_case(k: usize, seed0: u64, n: usize, only: Option<Experiment>) -> Case {
    use pam_physgen::{generate, CaseSpec, Effect};
    let seed = seed0 + k as u64;
    let controls = n / 4;
    // the controls spread through the plan, as `pam-physgen --cases N` spreads them
    let control = controls > 0 && (k * controls) / n != ((k + 1) * controls) / n;
    let before = (k * controls) / n;
    // the plan's controls alternate dynamic and step, its effects run through the dynamic
    // ones then the step ones: one experiment alone keeps its own in turn
    let (per, skip) = (
        Effect::DYNAMIC.len() + Effect::STEP.len(),
        Effect::DYNAMIC.len(),
    );
    let (control_k, effect_k) = match only {
        None => (before, k - before),
        Some(Experiment::Dynamic) => (2 * before, {
            let i = k - before;
            (i / skip) * per + i % skip
        }),
        Some(Experiment::Step) => (2 * before + 1, {
            let i = k - before;
            let m = per - skip;
            (i / m) * per + skip + i % m
        }),
    };
    let spec = if control {
        CaseSpec::control(control_k, seed)
    } else {
        let mut draw = ChaCha8Rng::seed_from_u64(seed0 ^ (k as u64).wrapping_mul(0x9e37));
        CaseSpec::effect_case(effect_k, seed, &mut draw)
    };
    let experiment = match spec.experiment {
        pam_physgen::Experiment::Dynamic => Experiment::Dynamic,
        pam_physgen::Experiment::Step => Experiment::Step,
    };
    match generate(&spec, None) {
        Ok(g) => Case {
            label: format!(
                "physgen {seed} {} {}",
                g.truth.experiment, g.truth.physical_effect
            ),
            family: g.truth.family.clone(),
            experiment,
            log: pam_log::read_str(&g.log_text, None).map_err(|e| e.to_string()),
            // the generator runs the plant once more without the effect
            footprint: (spec.effect != Effect::Control).then_some(g.truth.relative_size),
            other_stiffness: OtherStiffness::physgen(&spec, &g.truth, None),
            more_steps: (experiment == Experiment::Step).then_some(MoreSteps::Physgen(spec)),
        },
        Err(e) => Case {
            label: format!("physgen {seed}"),
            family: spec.effect.family().into(),
            experiment,
            log: Err(e.to_string()),
            footprint: None,
            other_stiffness: None,
            more_steps: None,
        },
    }
}

fn synth_case(spec: &pam_synth::CaseSpec) -> Case {
    let experiment = match spec.experiment {
        pam_synth::Experiment::Dynamic => Experiment::Dynamic,
        pam_synth::Experiment::Step => Experiment::Step,
    };
    match pam_synth::generate(spec) {
        Ok(g) => Case {
            label: format!(
                "synth {} {} {}",
                spec.seed,
                g.truth.experiment.name(),
                g.truth.shape.name()
            ),
            family: g.truth.family.name().to_string(),
            experiment,
            log: pam_log::read_str(&g.log_text, None).map_err(|e| e.to_string()),
            // the generator measures the effect's own contribution
            footprint: (spec.shape != pam_synth::Shape::Control).then_some(g.truth.relative_size),
            // pam-synth's logs have no stiffness level to change
            other_stiffness: None,
            more_steps: (experiment == Experiment::Step)
                .then(|| MoreSteps::Synth(Box::new(spec.clone()))),
        },
        Err(e) => Case {
            label: format!("synth {}", spec.seed),
            family: spec.family.name().to_string(),
            experiment,
            log: Err(e.to_string()),
            footprint: None,
            other_stiffness: None,
            more_steps: None,
        },
    }
}

/// The twin's effects as `pamctl simulate --with` takes them, two magnitudes each.
const TWIN_DYNAMIC: &[&str] = &[
    "",
    "carrier_ball_friction:coulomb_n=1",
    "carrier_ball_friction:coulomb_n=3",
    "velocity_squared:coeff_n_s2_per_m2=150",
    "velocity_squared:coeff_n_s2_per_m2=400",
    "muscle_hysteresis",
    "muscle_hysteresis:fraction=0.08",
    "pose_dependence:gain_per_rad_1=0.6,gain_per_rad_2=-0.4",
    "cable_slip",
    "cable_slip:backlash_rad=0.01",
    "loadcell_drift",
    "loadcell_drift:offset_x_n=-3,drift_x_n_per_s=0.03",
];
const TWIN_STEP: &[&str] = &[
    "",
    "transport_delay",
    "transport_delay:delay_s=0.02",
    "asymmetric_ip_rates",
    "asymmetric_ip_rates:inflation_s=4,deflation_s=1",
    "pressure_saturation",
    "pressure_saturation:max_bar=3.5,knee_bar=2.8",
];

fn twin_case(k: usize, seed0: u64, only: Option<Experiment>) -> Case {
    use pam_twin::experiments::{dynamic_trial, force_step_test};
    use pam_twin::{EffectSet, TwinConfig};
    let seed = seed0 + k as u64;
    let mut r = ChaCha8Rng::seed_from_u64(seed);
    // a control every fourth log, the effects of each trial in turn between them
    let dynamic = match only {
        Some(e) => e == Experiment::Dynamic,
        None => k.is_multiple_of(2),
    };
    let list = if dynamic { TWIN_DYNAMIC } else { TWIN_STEP };
    let spec = if k % 8 < 2 {
        ""
    } else {
        list[1 + (k / 2) % (list.len() - 1)]
    };
    let family = if spec.is_empty() {
        "none".to_string()
    } else {
        let id = spec.split(':').next().unwrap_or(spec);
        match id.parse::<EffectId>().ok().map(EffectId::family) {
            Some(Some(f)) => f.name().to_string(),
            _ => "unexplained".to_string(),
        }
    };
    let mut tw = TwinConfig::thesis();
    tw.seed = seed;
    // a step test is 24 steps at one pose: at 10 ms (the thesis's rig logs at 30–50 ms)
    let period_s = if dynamic && r.random::<bool>() {
        0.001
    } else {
        0.01
    };
    if !spec.is_empty() {
        match EffectSet::parse_list(&[spec]) {
            Ok(e) => tw.effects = e,
            Err(e) => {
                return Case {
                    label: format!("twin {seed} {spec}"),
                    family,
                    experiment: Experiment::Dynamic,
                    log: Err(e.to_string()),
                    footprint: None,
                    other_stiffness: None,
                    more_steps: None,
                }
            }
        }
    }
    let config = |tw: TwinConfig| {
        let mut cfg = ExperimentConfig::new(tw);
        cfg.period_s = period_s;
        cfg
    };
    // the twin draws its noise and path from the seed alone: the same config without the
    // effect gives the log the effect changed
    let bare = TwinConfig {
        effects: EffectSet::default(),
        ..tw.clone()
    };
    let (cfg, bare) = (config(tw), config(bare));
    let mut other_stiffness = None;
    let (experiment, log, without, where_) = if dynamic {
        // the friction-heavy specs stay at point 1, where the twin's preload is in range
        let point = if spec.starts_with("nonlinear") {
            1
        } else {
            r.random_range(1..=5)
        };
        other_stiffness = Some(OtherStiffness::Twin {
            config: Box::new(cfg.clone()),
            point,
            level: StiffnessLevel::High,
            duration_s: 60.0,
        });
        (
            Experiment::Dynamic,
            dynamic_trial(&cfg, point, StiffnessLevel::Low, 60.0),
            (!spec.is_empty()).then(|| dynamic_trial(&bare, point, StiffnessLevel::Low, 60.0)),
            format!("point {point}"),
        )
    } else {
        let pose = [
            r.random_range(-10.0..10.0f64),
            r.random_range(-10.0..10.0f64),
        ]
        .map(|x| (x * 10.0).round() / 10.0);
        (
            Experiment::Step,
            force_step_test(&cfg, pose),
            (!spec.is_empty()).then(|| force_step_test(&bare, pose)),
            format!("pose {pose:?}"),
        )
    };
    let log = log.map_err(|e| e.to_string());
    Case {
        label: format!(
            "twin {seed} {} {} {where_} {period_s} s",
            if dynamic { "dynamic" } else { "step" },
            if spec.is_empty() { "control" } else { spec }
        ),
        family,
        experiment,
        footprint: without.and_then(|w| footprint_against(&log, w.map_err(|e| e.to_string()))),
        log,
        other_stiffness,
        // the twin's step test is its fixed 24 steps
        more_steps: None,
    }
}

/// The `k`-th of `n` logs of `generator` (`physgen`, `synth` or `twin`) from `seed0`,
/// of one experiment only when `only` says so.
pub fn case(generator: &str, n: usize, seed0: u64, k: usize, only: Option<Experiment>) -> Case {
    match generator {
        "physgen" => physgen_case(k, seed0, n, only),
        "twin" => twin_case(k, seed0, only),
        _ => {
            let only = only.map(|e| match e {
                Experiment::Dynamic => pam_synth::Experiment::Dynamic,
                Experiment::Step => pam_synth::Experiment::Step,
            });
            let plan = pam_synth::balanced::plan(n, seed0, only);
            synth_case(&plan[k])
        }
    }
}
