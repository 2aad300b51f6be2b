//! `pam-synth --seed N [--experiment dynamic|step] [--family F] [--shape S] [--period-s DT] [--duration-s S]
//! [--step-order alternating|x_then_y] [--nuisance none|random|jitter=J,drops=R,heavy_tails,spikes=R,lsb=N]
//! [--motion sines|multisine|reach_and_hold|circles|random]
//! [--step-levels lattice|continuous|diagonal|random] --out FILE.csv`: writes one log and `FILE.truth.json`; `--list` lists the shapes.

use std::path::PathBuf;
use std::process::ExitCode;

use pam_synth::case::{StepLevelsPlan, StepOrder};
use pam_synth::{
    generate, write_files, CaseSpec, Experiment, Family, MotionPlan, NuisancePlan, Shape,
    SynthError,
};

const USAGE: &str = "usage: pam-synth --seed N [--experiment dynamic|step] [--family F] \
[--shape S] [--period-s DT] [--duration-s S] [--step-order alternating|x_then_y] \
[--nuisance none|random|jitter=J,drops=R,heavy_tails,spikes=R,lsb=N] \
[--motion sines|multisine|reach_and_hold|circles|random] \
[--step-levels lattice|continuous|diagonal|random] --out FILE.csv | --list";

fn list() {
    for e in Experiment::ALL {
        println!("{}:", e.name());
        for f in Family::of(e) {
            let shapes: Vec<&str> = f.shapes(e).iter().map(|s| s.name()).collect();
            println!("  {:<24} {}", f.name(), shapes.join(", "));
        }
    }
}

fn run(args: &[String]) -> Result<(), String> {
    let mut seed = None;
    let mut duration: Option<f64> = None;
    let mut step_order = None;
    let mut nuisance = None;
    let mut motion = None;
    let mut levels = None;
    let (mut experiment, mut family, mut shape, mut period, mut out) =
        (None, None, None, None, None);
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = || {
            it.next()
                .cloned()
                .ok_or_else(|| format!("{a} needs a value\n{USAGE}"))
        };
        let e = |e: SynthError| e.to_string();
        match a.as_str() {
            "--list" => {
                list();
                return Ok(());
            }
            "--seed" => seed = Some(value()?.parse::<u64>().map_err(|e| e.to_string())?),
            "--experiment" => experiment = Some(Experiment::parse(&value()?).map_err(e)?),
            "--family" => family = Some(Family::parse(&value()?).map_err(e)?),
            "--shape" => shape = Some(Shape::parse(&value()?).map_err(e)?),
            "--period-s" => period = Some(value()?.parse::<f64>().map_err(|e| e.to_string())?),
            "--duration-s" => duration = Some(value()?.parse::<f64>().map_err(|e| e.to_string())?),
            "--out" => out = Some(PathBuf::from(value()?)),
            "--step-order" => step_order = Some(StepOrder::parse(&value()?).map_err(e)?),
            "--nuisance" => nuisance = Some(NuisancePlan::parse(&value()?).map_err(e)?),
            "--motion" => motion = Some(MotionPlan::parse(&value()?).map_err(e)?),
            "--step-levels" => levels = Some(StepLevelsPlan::parse(&value()?).map_err(e)?),
            "-h" | "--help" => return Err(USAGE.into()),
            other => return Err(format!("unknown argument `{other}`\n{USAGE}")),
        }
    }
    let seed = seed.ok_or(USAGE)?;
    let out = out.ok_or(USAGE)?;
    let family = family.or(shape.map(Shape::family));
    let experiment = experiment.or(shape.map(|s| s.experiments()[0]));
    let mut spec = CaseSpec::random(seed, experiment, family).map_err(|e| e.to_string())?;
    if let Some(s) = shape {
        spec = spec.with_shape(s).map_err(|e| e.to_string())?;
    }
    if let Some(order) = step_order {
        spec.step_order = order;
    }
    if let Some(plan) = nuisance {
        spec.nuisances = plan.for_seed(seed);
    }
    if let Some(plan) = motion {
        spec.motion = plan.for_seed(seed);
    }
    if let Some(plan) = levels {
        spec.step_levels = plan.for_seed(seed);
    }
    if let Some(dt) = period {
        spec.dt_s = dt;
        spec.duration_s = spec
            .duration_s
            .min(pam_synth::case::MAX_SAMPLES as f64 * dt)
            .round();
        spec.validate().map_err(|e| e.to_string())?;
    }
    if let Some(d) = duration {
        spec.duration_s = d;
        spec.validate().map_err(|e| e.to_string())?;
    }
    let g = generate(&spec).map_err(|e| e.to_string())?;
    write_files(&g, &out).map_err(|e| e.to_string())?;
    eprintln!(
        "{}: {} {} / {}, {} samples at {} s, relative size {:.3}, nuisances {}, motion {}, step levels {}",
        out.display(),
        g.truth.experiment.name(),
        g.truth.family.name(),
        g.truth.shape.name(),
        g.truth.samples,
        g.truth.dt_s,
        g.truth.relative_size,
        g.truth.nuisances.describe(),
        g.truth.motion.name(),
        g.truth.step_levels.name()
    );
    Ok(())
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match run(&args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("{e}");
            ExitCode::FAILURE
        }
    }
}
