//! `pam-synth`: a second, deliberately simple log generator for testing the model loop,
//! written independently of the digital twin and of the loop (its own functional forms).
//!
//! It writes log-format-v1 logs as a rig would — encoder angles (quantised), load-cell
//! force (noisy), the I/P currents from the open-loop inverse model, and in step trials the
//! force reference — with one hidden effect or none. The truth (family, shape, physical
//! parameters, achieved relative size) never goes into the log: it is returned beside it.

// `!(x >= y)` is deliberate: it is true for NaN, so a NaN never passes a check.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
#![allow(clippy::needless_range_loop)]

pub mod balanced;
pub mod case;
mod dyn_effects;
mod dynamic;
mod effect;
pub mod error;
pub mod motion;
pub mod nuisance;
pub mod plan;
mod robot;
mod sensor;
pub mod signal;
mod step;
pub mod truth;

pub use case::{CaseSpec, Experiment, Family, Shape};
pub use error::SynthError;
pub use motion::{MotionPlan, OperatorMotion};
pub use nuisance::{NuisancePlan, Nuisances};
pub use truth::Truth;

use pam_model::RobotModel;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use effect::{EffectModel, Form};
use signal::{pick, relative_size, Forces};

/// A generated log and what is hidden in it.
#[derive(Clone, Debug)]
pub struct Generated {
    pub log_text: String,
    pub truth: Truth,
}

/// Independent random streams, so a case with and without its effect shares the motion,
/// the currents and the noise.
const STREAM_BASE: u64 = 1;
const STREAM_EFFECT: u64 = 2;
const STREAM_NOISE: u64 = 3;

pub(crate) fn rng(seed: u64, stream: u64) -> ChaCha8Rng {
    let mut r = ChaCha8Rng::seed_from_u64(seed);
    r.set_stream(stream);
    r
}

/// What both trial types hand to the common part: the noise-free base force on the fine
/// grid and the logged columns other than the force.
struct Scene {
    /// The fine-grid index of every logged row (the nuisances' jitter and drops in it).
    rows: Vec<usize>,
    fine_s: f64,
    base_force: Forces,
    alpha_log: Vec<[f64; 2]>,
    currents_log: Vec<[f64; 4]>,
    refs_log: Option<Vec<[f64; 2]>>,
    alpha_deg: [f64; 2],
    base_params: Vec<(String, f64)>,
}

/// Generates the log and its truth.
pub fn generate(spec: &CaseSpec) -> Result<Generated, SynthError> {
    spec.validate()?;
    let model = RobotModel::<f64>::thesis();
    let mut rng_base = rng(spec.seed, STREAM_BASE);
    let mut rng_effect = rng(spec.seed, STREAM_EFFECT);
    let mut rng_noise = rng(spec.seed, STREAM_NOISE);
    let mut rng_nuisance = rng(spec.seed, nuisance::STREAM_NUISANCE);
    let n = spec.samples();
    match spec.experiment {
        Experiment::Dynamic => {
            let b = dynamic::build(spec, &model, &mut rng_base)?;
            let per = (spec.dt_s / dynamic::FINE_S).round() as usize;
            let iterations =
                spec.nuisances
                    .iteration_indices(n, per, b.t_s.len(), &mut rng_nuisance);
            let rows = spec.nuisances.logged_rows(&iterations, &mut rng_nuisance);
            let scene = Scene {
                base_force: b.force_n.clone(),
                alpha_log: pick(&b.alpha_rad, &rows)
                    .into_iter()
                    .map(|a| a.map(robot::quantise))
                    .collect(),
                currents_log: vec![b.currents_ma; rows.len()],
                refs_log: None,
                alpha_deg: b.alpha0_rad.map(f64::to_degrees),
                base_params: dynamic::base_params(&b),
                rows,
                fine_s: dynamic::FINE_S,
            };
            let effect =
                dyn_effects::build(spec.shape, &b, &model, &mut rng_effect).or_else(|| {
                    sensor::build(spec.shape, &b.t_s, &b.alpha_rad, &model, &mut rng_effect)
                });
            finish(spec, scene, effect, &mut rng_noise, &mut rng_nuisance)
        }
        Experiment::Step => {
            let per = (spec.dt_s / step::FINE_S).round() as usize;
            let iterations =
                spec.nuisances
                    .iteration_indices(n, per, step::fine_len(spec), &mut rng_nuisance);
            // the commands change at a loop iteration, as a rig's would
            let b = step::build(spec, &model, &mut rng_base, &iterations);
            let rows = spec.nuisances.logged_rows(&iterations, &mut rng_nuisance);
            let seg_log = pick(&b.seg_of, &rows);
            let alpha_fine = vec![b.alpha_rad; b.t_s.len()];
            let scene = Scene {
                base_force: b.force_n.clone(),
                alpha_log: vec![b.alpha_rad.map(robot::quantise); rows.len()],
                currents_log: seg_log.iter().map(|&s| b.segments[s].currents_ma).collect(),
                refs_log: Some(seg_log.iter().map(|&s| b.segments[s].ref_n).collect()),
                alpha_deg: b.alpha_rad.map(f64::to_degrees),
                base_params: step::base_params(&b),
                rows,
                fine_s: step::FINE_S,
            };
            let effect = step::effect(spec.shape, &b, &model, &mut rng_effect).or_else(|| {
                sensor::build(spec.shape, &b.t_s, &alpha_fine, &model, &mut rng_effect)
            });
            finish(spec, scene, effect, &mut rng_noise, &mut rng_nuisance)
        }
    }
}

/// Scales the effect to its target size, adds the noise and writes the log.
fn finish(
    spec: &CaseSpec,
    scene: Scene,
    effect: Option<EffectModel<'_>>,
    rng_noise: &mut ChaCha8Rng,
    rng_nuisance: &mut ChaCha8Rng,
) -> Result<Generated, SynthError> {
    let n = scene.rows.len();
    let rows = &scene.rows;
    let nuisances = &spec.nuisances;
    let coloured_n = if rng_noise.random::<f64>() < 0.3 {
        spec.noise_n * rng_noise.random_range(0.1..0.5)
    } else {
        0.0
    };
    let tau_s = rng_noise.random_range(0.02..0.2);
    let white_scale = || nuisances.white_scale(rng_nuisance);
    let noise = signal::load_cell_noise(
        rng_noise,
        n,
        spec.dt_s,
        spec.noise_n,
        coloured_n,
        tau_s,
        white_scale,
    );
    let base = pick(&scene.base_force, rows);
    let add = |a: &Forces, b: &Forces| -> Forces {
        a.iter()
            .zip(b)
            .map(|(x, y)| [x[0] + y[0], x[1] + y[1]])
            .collect()
    };
    let with_noise = |f: &Forces| add(f, &noise);
    let (force, rel, params) = match effect {
        None => (with_noise(&base), 0.0, Vec::new()),
        Some(em) => {
            let (lo, hi) = em.lambda_range;
            let target = spec.target_relative_size;
            let at = |lam: f64| -> Forces {
                match &em.form {
                    Form::Additive(unit) => {
                        let u = pick(unit, rows);
                        base.iter()
                            .zip(&u)
                            .map(|(b, u)| [b[0] + lam * u[0], b[1] + lam * u[1]])
                            .collect()
                    }
                    Form::Whole(apply) => pick(&apply(lam), rows),
                }
            };
            let size = |lam: f64| {
                let f = at(lam);
                let contribution: Forces = f
                    .iter()
                    .zip(&base)
                    .map(|(a, b)| [a[0] - b[0], a[1] - b[1]])
                    .collect();
                relative_size(&contribution, &with_noise(&f))
            };
            let lam = signal::solve_strength(lo, hi, target, size);
            let rel = size(lam);
            (with_noise(&at(lam)), rel, (em.params)(lam))
        }
    };
    let mut force = force;
    nuisances.corrupt(&mut force, spec.noise_n, rng_nuisance);
    let log_text = write_log(spec, &scene, &force)?;
    let truth = Truth {
        experiment: spec.experiment,
        family: spec.family,
        shape: spec.shape,
        seed: spec.seed,
        dt_s: spec.dt_s,
        duration_s: spec.duration_s,
        samples: n,
        step_order: spec.step_order,
        nuisances: spec.nuisances,
        motion: spec.motion,
        step_levels: spec.step_levels,
        noise_n: spec.noise_n,
        coloured_noise_n: coloured_n,
        site: spec.site,
        alpha_deg: scene.alpha_deg,
        target_relative_size: if spec.family == Family::None {
            0.0
        } else {
            spec.target_relative_size
        },
        relative_size: rel,
        params: params.into_iter().collect(),
        base: scene.base_params.into_iter().collect(),
    };
    Ok(Generated { log_text, truth })
}

/// The log's columns, as a rig's recording would have them.
pub fn columns(experiment: Experiment) -> Vec<&'static str> {
    let mut c = vec![
        "t_s",
        "alpha1_rad",
        "alpha2_rad",
        "fx_n",
        "fy_n",
        "i1_ma",
        "i2_ma",
        "i3_ma",
        "i4_ma",
    ];
    if experiment == Experiment::Step {
        c.extend(["fx_ref_n", "fy_ref_n"]);
    }
    c
}

fn write_log(spec: &CaseSpec, scene: &Scene, force: &Forces) -> Result<String, SynthError> {
    let period = format!("{}", spec.dt_s);
    let meta = [
        ("experiment", spec.experiment.name()),
        ("generator", "pam-synth"),
        ("sample_period_s", period.as_str()),
    ];
    let mut w = pam_log::LogWriter::new(Vec::new(), &columns(spec.experiment), &meta)?;
    let mut row = Vec::with_capacity(11);
    for (k, &fine) in scene.rows.iter().enumerate() {
        row.clear();
        // the time printed as a rig's clock would: whole microseconds
        row.push((fine as f64 * scene.fine_s * 1e6).round() / 1e6);
        row.extend(scene.alpha_log[k]);
        row.extend(force[k]);
        row.extend(scene.currents_log[k]);
        if let Some(r) = &scene.refs_log {
            row.extend(r[k]);
        }
        w.write_row(&row)?;
    }
    let bytes = w.finish()?;
    Ok(String::from_utf8(bytes).unwrap_or_default())
}

/// Writes `FILE` (the log) and `FILE.truth.json` beside it (`trial.csv` → `trial.truth.json`).
pub fn write_files(generated: &Generated, path: &std::path::Path) -> Result<(), SynthError> {
    std::fs::write(path, &generated.log_text)?;
    std::fs::write(truth_path(path), generated.truth.to_json()?)?;
    Ok(())
}

/// The sidecar's path for a log path.
pub fn truth_path(path: &std::path::Path) -> std::path::PathBuf {
    path.with_extension("truth.json")
}
