//! The model loop against an independent generator (`pam-synth`): N balanced cases, each
//! diagnosed and judged through the diagnosis's JSON; per-case lines, the confusion matrix,
//! accuracy, false alarms and timings.
//!
//! `cargo run -p pam-eval --release --example confusion -- --logs 300 --seed0 1000
//!  [--experiment dynamic|step] [--family F] [--period-s DT] [--jobs 2] [--out DIR] [--json FILE] [--only SEED,SEED] [--set NAME=VALUE] [--step-order alternating|x_then_y]
//!  [--nuisance none|random|jitter=J,drops=R,heavy_tails,spikes=R,lsb=N]
//!  [--motion sines|multisine|reach_and_hold|circles|random]
//!  [--step-levels lattice|continuous|diagonal|random]`

use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

use pam_eval::judge::{self, CaseResult, LoopSays, Outcome};
use pam_ident::Trial;
use pam_model::RobotModel;
use pam_model_loop::diagnose::{diagnose, Settings};
use pam_model_loop::effects::Experiment as LoopExperiment;
use pam_synth::balanced;
use pam_synth::case::{StepLevelsPlan, StepOrder};
use pam_synth::{generate, CaseSpec, Experiment, Family, MotionPlan, NuisancePlan};

struct Args {
    logs: usize,
    seed0: u64,
    experiment: Option<Experiment>,
    /// Only this family (no controls): to look at one family's misses.
    family: Option<Family>,
    jobs: usize,
    /// Every log sampled at this period instead of the generator's draw (e.g. the thesis
    /// rig's 30–40 ms, which the generator does not draw); the length is kept in seconds.
    period_s: Option<f64>,
    out: Option<PathBuf>,
    json: Option<PathBuf>,
    /// Only these seeds of the plan (e.g. a run's misses), keeping the plan's draw.
    only: Option<Vec<u64>>,
    /// The loop's settings; `--set NAME=VALUE` changes one (to measure a trade-off).
    settings: Settings,
    /// Every step log's axes in this order instead of the generator's (e.g. the thesis's
    /// `x_then_y`, §5.2), keeping the plan's draw.
    step_order: Option<StepOrder>,
    /// What the recordings add that is not an effect (jitter, drops, heavy tails, spikes,
    /// quantisation; pam-synth's `nuisance.rs`), the same for every log or drawn per seed.
    nuisance: Option<NuisancePlan>,
    /// How the operator moves in the dynamic logs (pam-synth's `motion.rs`), the same for
    /// every log or drawn per seed.
    motion: Option<MotionPlan>,
    /// Where the step logs' levels lie (pam-synth's `StepLevels`), the same for every log or
    /// drawn per seed.
    step_levels: Option<StepLevelsPlan>,
}

fn parse() -> Result<Args, String> {
    let mut a = Args {
        logs: 100,
        seed0: 1000,
        experiment: None,
        family: None,
        jobs: 2,
        period_s: None,
        out: None,
        json: None,
        only: None,
        settings: Settings::default(),
        step_order: None,
        nuisance: None,
        motion: None,
        step_levels: None,
    };
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut it = args.iter();
    while let Some(k) = it.next() {
        let mut v = || it.next().cloned().ok_or(format!("{k} needs a value"));
        match k.as_str() {
            "--logs" => a.logs = v()?.parse().map_err(|e| format!("--logs: {e}"))?,
            "--seed0" => a.seed0 = v()?.parse().map_err(|e| format!("--seed0: {e}"))?,
            "--experiment" => {
                a.experiment = Some(Experiment::parse(&v()?).map_err(|e| e.to_string())?)
            }
            "--family" => a.family = Some(Family::parse(&v()?).map_err(|e| e.to_string())?),
            "--jobs" => a.jobs = v()?.parse().map_err(|e| format!("--jobs: {e}"))?,
            "--period-s" => {
                a.period_s = Some(v()?.parse().map_err(|e| format!("--period-s: {e}"))?)
            }
            "--out" => a.out = Some(PathBuf::from(v()?)),
            "--step-order" => {
                a.step_order = Some(StepOrder::parse(&v()?).map_err(|e| e.to_string())?)
            }
            "--json" => a.json = Some(PathBuf::from(v()?)),
            "--nuisance" => {
                a.nuisance = Some(NuisancePlan::parse(&v()?).map_err(|e| e.to_string())?)
            }
            "--motion" => a.motion = Some(MotionPlan::parse(&v()?).map_err(|e| e.to_string())?),
            "--step-levels" => {
                a.step_levels = Some(StepLevelsPlan::parse(&v()?).map_err(|e| e.to_string())?)
            }
            "--set" => {
                let kv = v()?;
                let (k, x) = kv
                    .split_once('=')
                    .ok_or(format!("--set NAME=VALUE, got `{kv}`"))?;
                let x: f64 = x.parse().map_err(|e| format!("--set {k}: {e}"))?;
                let s = &mut a.settings;
                match k {
                    "alpha" => s.alpha = x,
                    "min_improvement" => s.min_improvement = x,
                    "min_significant_improvement" => s.min_significant_improvement = x,
                    "penalty_per_param" => s.penalty_per_param = x,
                    "min_effect_size" => s.min_effect_size = x,
                    other => return Err(format!("--set: no setting `{other}`")),
                }
            }
            "--only" => {
                let seeds = v()?
                    .split(',')
                    .map(|s| s.trim().parse::<u64>())
                    .collect::<Result<Vec<_>, _>>()
                    .map_err(|e| format!("--only: a comma-separated list of seeds: {e}"))?;
                a.only = Some(seeds);
            }
            other => return Err(format!("unknown argument `{other}`")),
        }
    }
    Ok(a)
}

/// Generates, diagnoses (as `pamctl model diagnose` would: log text → pam-log → Trial) and
/// judges one case.
pub fn run_case(spec: &CaseSpec, out: Option<&PathBuf>, settings: Settings) -> CaseResult {
    let model = RobotModel::<f64>::thesis();
    let g = match generate(spec) {
        Ok(g) => g,
        Err(e) => panic!("seed {}: generating: {e}", spec.seed),
    };
    if let Some(dir) = out {
        let path = dir.join(format!("synth_{}.csv", spec.seed));
        let _ = pam_synth::write_files(&g, &path);
    }
    let start = Instant::now();
    let exp = match spec.experiment {
        Experiment::Dynamic => LoopExperiment::Dynamic,
        Experiment::Step => LoopExperiment::Step,
    };
    let said = pam_log::read_str(&g.log_text, None)
        .map_err(|e| e.to_string())
        .and_then(|log| Trial::from_log(&log).map_err(|e| e.to_string()))
        .and_then(|trial| diagnose(&trial, &model, exp, settings).map_err(|e| e.to_string()))
        .and_then(|(d, _)| serde_json::to_value(&d).map_err(|e| e.to_string()));
    let seconds = start.elapsed().as_secs_f64();
    match said {
        Ok(v) => {
            let says = judge::read(&v);
            CaseResult {
                outcome: judge::judge(&g.truth, &says),
                truth: g.truth,
                says,
                seconds,
                error: None,
            }
        }
        Err(e) => CaseResult {
            truth: g.truth,
            says: LoopSays {
                verdict: "error".into(),
                ..Default::default()
            },
            outcome: Outcome::Wrong,
            seconds,
            error: Some(e),
        },
    }
}

fn main() {
    let a = match parse() {
        Ok(a) => a,
        Err(e) => {
            eprintln!("{e}\nusage: confusion --logs N --seed0 S [--experiment dynamic|step] [--family F] [--period-s DT] [--jobs 2] [--out DIR] [--json FILE] [--only SEED,SEED] [--set NAME=VALUE] [--step-order alternating|x_then_y] [--nuisance none|random|LIST] [--motion M|random] [--step-levels L|random]");
            std::process::exit(2);
        }
    };
    if let Some(dir) = &a.out {
        std::fs::create_dir_all(dir).expect("creating --out");
    }
    let specs = match a.family {
        None => balanced::plan(a.logs, a.seed0, a.experiment),
        Some(f) => (0..a.logs as u64)
            .map(|i| CaseSpec::random(a.seed0 + i, a.experiment, Some(f)))
            .collect::<Result<Vec<_>, _>>()
            .unwrap_or_else(|e| panic!("--family {}: {e}", f.name())),
    };
    let specs: Vec<CaseSpec> = match &a.only {
        None => specs,
        Some(seeds) => specs
            .into_iter()
            .filter(|s| seeds.contains(&s.seed))
            .collect(),
    };
    let specs: Vec<CaseSpec> = match a.period_s {
        None => specs,
        // a mains tone cannot be drawn slower than 5 ms: those cases are left out
        Some(dt) => specs
            .into_iter()
            .filter(|s| !(s.shape.needs_fast_sampling() && dt > pam_synth::case::TONE_MAX_PERIOD_S))
            .map(|mut s| {
                s.duration_s = f64::min(s.duration_s, pam_synth::case::MAX_SAMPLES as f64 * dt);
                s.dt_s = dt;
                s
            })
            .collect(),
    };
    // the recording's nuisances, the step order and the motion, where asked for, over the
    // plan's draw
    let specs: Vec<CaseSpec> = specs
        .into_iter()
        .map(|s| CaseSpec {
            nuisances: a.nuisance.map_or(s.nuisances, |plan| plan.for_seed(s.seed)),
            step_order: a.step_order.unwrap_or(s.step_order),
            motion: a.motion.map_or(s.motion, |plan| plan.for_seed(s.seed)),
            step_levels: a
                .step_levels
                .map_or(s.step_levels, |plan| plan.for_seed(s.seed)),
            ..s
        })
        .collect();
    let next = AtomicUsize::new(0);
    let done = AtomicUsize::new(0);
    let results: Mutex<Vec<Option<CaseResult>>> = Mutex::new(vec![None; specs.len()]);
    let wall = Instant::now();
    std::thread::scope(|s| {
        for _ in 0..a.jobs.max(1) {
            s.spawn(|| loop {
                let i = next.fetch_add(1, Ordering::SeqCst);
                if i >= specs.len() {
                    break;
                }
                let r = run_case(&specs[i], a.out.as_ref(), a.settings);
                let k = done.fetch_add(1, Ordering::SeqCst) + 1;
                eprintln!("[{k}/{}] {}", specs.len(), judge::case_line(&r));
                results.lock().unwrap()[i] = Some(r);
            });
        }
    });
    let results: Vec<CaseResult> = results
        .into_inner()
        .unwrap()
        .into_iter()
        .flatten()
        .collect();
    for r in &results {
        println!("{}", judge::case_line(r));
    }
    println!();
    print!("{}", judge::report(&results));
    println!(
        "wall time {:.1} s on {} threads",
        wall.elapsed().as_secs_f64(),
        a.jobs
    );
    if let Some(path) = &a.json {
        let s = serde_json::to_string_pretty(&results).expect("serialising results");
        std::fs::write(path, s).expect("writing --json");
    }
}
