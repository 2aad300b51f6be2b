//! `pam-physgen --out DIR --cases N --seed S [--controls M] [--duration-s D]
//! [--stiffness-level L]`: writes N logs (M of them controls, a quarter by default) and their
//! truth files, `DIR/physgen_SEED.csv`. `--stiffness-level` (0–1) makes every trial at that
//! stiffness instead of the drawn one (`pam_physgen::generate_at_stiffness`): run it twice
//! with the same seed for the pair of logs that separates friction from hysteresis (dynamic)
//! or a supply limit from the converters' spread (step).

use std::path::PathBuf;
use std::process::ExitCode;

use pam_physgen::{generate, generate_at_stiffness, write_files, CaseSpec};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

const USAGE: &str = "usage: pam-physgen --out DIR --cases N --seed S [--controls M] \
     [--duration-s D] [--stiffness-level L]";

fn run(args: &[String]) -> Result<(), String> {
    let (mut out, mut cases, mut seed, mut controls, mut duration) = (None, None, None, None, None);
    let mut level = None;
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = || {
            it.next()
                .cloned()
                .ok_or_else(|| format!("{a} needs a value\n{USAGE}"))
        };
        let num = |s: String| s.parse::<u64>().map_err(|e| format!("{a}: {e}"));
        match a.as_str() {
            "--out" => out = Some(PathBuf::from(value()?)),
            "--cases" => cases = Some(num(value()?)? as usize),
            "--seed" => seed = Some(num(value()?)?),
            "--controls" => controls = Some(num(value()?)? as usize),
            "--duration-s" => {
                duration = Some(value()?.parse::<f64>().map_err(|e| format!("{a}: {e}"))?)
            }
            "--stiffness-level" => {
                let l = value()?.parse::<f64>().map_err(|e| format!("{a}: {e}"))?;
                if !(0.0..=1.0).contains(&l) {
                    return Err(format!("{a}: {l} is not in 0–1\n{USAGE}"));
                }
                level = Some(l)
            }
            "-h" | "--help" => return Err(USAGE.into()),
            other => return Err(format!("unknown argument `{other}`\n{USAGE}")),
        }
    }
    let out = out.ok_or(USAGE)?;
    let cases = cases.ok_or(USAGE)?;
    let seed0 = seed.ok_or(USAGE)?;
    let controls = controls.unwrap_or(cases / 4).min(cases);
    std::fs::create_dir_all(&out).map_err(|e| format!("{}: {e}", out.display()))?;
    let mut draw = ChaCha8Rng::seed_from_u64(seed0);
    let (mut k_eff, mut k_ctl) = (0usize, 0usize);
    for i in 0..cases {
        let seed = seed0 + i as u64;
        // spread the controls evenly through the suite
        let control = controls > 0 && (i * controls) / cases != ((i + 1) * controls) / cases;
        let spec = if control {
            k_ctl += 1;
            CaseSpec::control(k_ctl - 1, seed)
        } else {
            k_eff += 1;
            CaseSpec::effect_case(k_eff - 1, seed, &mut draw)
        };
        let path = out.join(format!("physgen_{seed}.csv"));
        let start = std::time::Instant::now();
        let g = match level {
            Some(l) => generate_at_stiffness(&spec, duration, l),
            None => generate(&spec, duration),
        }
        .map_err(|e| format!("seed {seed}: {e}\n  help: {}", e.help()))?;
        write_files(&g, &path)
            .map_err(|e| format!("{}: {e}\n  help: {}", path.display(), e.help()))?;
        eprintln!(
            "[{}/{cases}] {}: {} {} ({}), severity {:.2}, relative size {:.3}, {:.2} s",
            i + 1,
            path.display(),
            g.truth.experiment,
            g.truth.physical_effect,
            g.truth.family,
            g.truth.severity,
            g.truth.relative_size,
            start.elapsed().as_secs_f64()
        );
    }
    Ok(())
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match run(&args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
