//! The model loop judged strictly (right verdict, right first family, no family in the
//! final model that is not in the log) on the three generators, and the refinement gate
//! `min_family_gain` calibrated on one generator and validated on the others.
//!
//! `cargo run -p pam-eval --release --example crossgen -- [--generators physgen,synth,twin]
//!  [--logs N] [--seed0 S] [--gains 0.01,0.03,0.08] [--lags 0,0.01,0.02] [--jobs 2]
//!  [--experiment dynamic|step] [--dump DIR]`
//!
//! `--dump DIR` writes every log not judged strictly right to `DIR/<generator>-<seed>.csv`,
//! for `pamctl model diagnose` to take apart.
//!
//! Each generator's N logs (about a quarter controls, carrying the generator's sensor
//! behaviour) are diagnosed at every point of the grid (the refinement gate
//! `min_family_gain` × the delay's floor `converter_lag_s`; the loop's defaults when
//! not given); the tables show, per generator and point, the strict accuracy and the false
//! alarms; then, at the default point, the effect logs by footprint (`pam_eval::footprint`:
//! how many carry an effect under the model loop's materiality line, and how many of the
//! misses are those); then the cross-generator table: the point that is best on X (most logs
//! strictly right, then fewest false alarms) scored on Y.
//!
//! Where a diagnosis leaves a joint's friction against the muscles' hysteresis open and
//! names the same trial at the other stiffness level, the run makes that log (pam-physgen
//! and the twin can) and decides the pair (`pam_model_loop::stiffness_pair`), as a user
//! following the diagnosis would: the main table's "strictly right after them" scores the
//! final model with the pair's family in place of the two left open. Where a step log's
//! diagnosis says it has too few steps to decide and about how many would (at most
//! [`MORE_STEPS_MAX`] times its own), the run makes the same trial that much longer
//! (pam-physgen and pam-synth can; the twin's step test is its fixed 24 steps) and scores
//! that log's final model instead. Where a step log's diagnosis leaves a family within the
//! converters' spread, the run makes the same trial at a higher co-contraction (pam-physgen
//! can) and decides the pair (`pam_model_loop::spread_pair`): a family it names comes first.
//!
//! - physgen: pam-physgen, the rig's physics (rigid-body arm, gas-volume muscles, LuGre,
//!   Maxwell-slip, Bouc–Wen, a load cell's 1/f and AR noise, a tare in the sensor frame);
//! - synth: pam-synth's balanced plan;
//! - twin: the digital twin's effects (as `pamctl simulate --with SPEC` draws them) at the
//!   five Table 4.1 points (1 and 10 ms) and at step poses within ±10° (10 ms).

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

use pam_eval::cases::{case, Case};
use pam_eval::footprint::Footprints;
use pam_eval::strict::{self, FinalModel, Strict, Tally};
use pam_ident::Trial;
use pam_model::RobotModel;
use pam_model_loop::diagnose::{diagnose, Settings};
use pam_model_loop::effects::{Experiment, Family};
use pam_model_loop::spread_pair::saturation_or_spread;

/// The decision's two calibrated thresholds: the refinement gate and the delay's
/// floor (the converters' own lag).
#[derive(Clone, Copy)]
struct Point {
    gain: f64,
    lag_s: f64,
}

/// The final model at every gain of the grid, for one converter lag. The greedy sequence
/// is deterministic: when the smallest and the largest gain give the same final model,
/// every family after the first was let in (or left out) with a margin outside the grid, so
/// every gain between gives it too, and only those two diagnoses are run. The families left
/// undecided only grow with the gain, so the same holds for them.
fn final_models_at(
    trial: &Trial,
    experiment: Experiment,
    gains: &[f64],
    lag_s: f64,
) -> Result<Vec<FinalModel>, String> {
    let model = RobotModel::<f64>::thesis();
    let at = |g: f64| -> Result<FinalModel, String> {
        let settings = Settings {
            min_family_gain: g,
            converter_lag_s: lag_s,
            ..Settings::default()
        };
        let (d, _) = diagnose(trial, &model, experiment, settings).map_err(|e| e.to_string())?;
        let v = serde_json::to_value(&d).map_err(|e| e.to_string())?;
        Ok(strict::read(&v))
    };
    let lo = at(gains[0])?;
    if gains.len() == 1 {
        return Ok(vec![lo]);
    }
    let hi = at(gains[gains.len() - 1])?;
    if lo.families == hi.families && lo.verdict == hi.verdict && lo.undecided == hi.undecided {
        return Ok(vec![lo; gains.len()]);
    }
    let mut out = vec![lo];
    for &g in &gains[1..gains.len() - 1] {
        out.push(at(g)?);
    }
    out.push(hi);
    Ok(out)
}

/// The final model at every point of the grid (lags outer, gains inner).
fn final_models(
    trial: &Trial,
    experiment: Experiment,
    gains: &[f64],
    lags: &[f64],
) -> Result<Vec<FinalModel>, String> {
    let mut out = Vec::new();
    for &lag in lags {
        out.extend(final_models_at(trial, experiment, gains, lag)?);
    }
    Ok(out)
}

/// The case's log as a trial.
fn trial_of(case: &Case) -> Result<Trial, String> {
    let log = case.log.as_ref().map_err(Clone::clone)?;
    Trial::from_log(log).map_err(|e| e.to_string())
}

struct Judged {
    family: String,
    /// One final model per point of the grid.
    says: Vec<FinalModel>,
    /// The same, once the separating experiment the diagnosis named for friction against
    /// hysteresis (the trial at the other stiffness level) has been run and decided.
    settled: Vec<FinalModel>,
    /// Whether that experiment was run.
    paired: bool,
    /// Whether a step log's diagnosis left a family within the converters' spread and the
    /// same trial at another co-contraction was run and decided: `settled` then puts the
    /// family the pair named beyond the spread first.
    spread_paired: bool,
    /// Whether a step log's diagnosis named a longer trial (too few steps to decide) and
    /// it was run: `settled` then holds its final model where the diagnosis named it.
    lengthened: bool,
    /// The effect's footprint (`pam_eval::footprint`), where it was drawn.
    footprint: Option<f64>,
}

fn run(
    generator: &str,
    n: usize,
    seed0: u64,
    grid: &Grid,
    jobs: usize,
    only: Option<Experiment>,
    dump: Option<&std::path::Path>,
) -> Vec<Judged> {
    let next = AtomicUsize::new(0);
    let points = grid.points().len();
    let show = grid.default_index();
    let out: Mutex<Vec<Option<Judged>>> = Mutex::new((0..n).map(|_| None).collect());
    std::thread::scope(|s| {
        for _ in 0..jobs.max(1) {
            s.spawn(|| loop {
                let k = next.fetch_add(1, Ordering::SeqCst);
                if k >= n {
                    break;
                }
                let t = Instant::now();
                let case = case(generator, n, seed0, k, only);
                let trial = trial_of(&case);
                let says = trial
                    .as_ref()
                    .map_err(Clone::clone)
                    .and_then(|tr| final_models(tr, case.experiment, &grid.gains, &grid.lags))
                    .unwrap_or_else(|e| {
                        vec![
                            FinalModel {
                                verdict: format!("error: {e}"),
                                ..Default::default()
                            };
                            points
                        ]
                    });
                let (named, paired) = match &trial {
                    Ok(tr) => stiffness_pair(&case, tr, &says),
                    Err(_) => (None, false),
                };
                let (beyond, spread_pair) = match &trial {
                    Ok(tr) => co_contraction_pair(&case, tr, &says),
                    Err(_) => (None, None),
                };
                let mut settled: Vec<FinalModel> = says
                    .iter()
                    .map(|m| m.settled(named.as_deref()).beyond_spread(beyond.as_deref()))
                    .collect();
                let lengthened = match &trial {
                    Ok(tr) => more_steps(&case, tr, &says, grid),
                    Err(_) => None,
                };
                // the longer trial's final model, with the co-contraction pair's family first
                // where the longer log hides it within the spread too
                if let Some(longer) = &lengthened {
                    for (i, m) in longer.says.iter().enumerate() {
                        if let Some(m) = m {
                            settled[i] = m.beyond_spread(beyond.as_deref());
                        }
                    }
                }
                let mid = &says[show];
                let judged = strict::judge(&case.family, mid);
                let mark = match judged {
                    Strict::Right => "ok ",
                    Strict::Stacked => "stk",
                    Strict::Undecided => "und",
                    Strict::Wrong => "BAD",
                };
                if let (Some(dir), Ok(log), false) =
                    (dump, &case.log, matches!(judged, Strict::Right))
                {
                    let seed = case.label.split_whitespace().nth(1).unwrap_or("case");
                    let path = dir.join(format!("{generator}-{seed}.csv"));
                    if let Err(e) = log.write_path(&path) {
                        eprintln!("cannot write {}: {e}", path.display());
                    }
                }
                let mut footprint = case
                    .footprint
                    .map_or(String::new(), |f| format!(" footprint {:.2} %", 100.0 * f));
                if paired {
                    footprint += &format!(" pair: {}", named.as_deref().unwrap_or("cannot tell"));
                }
                if let Some(line) = &spread_pair {
                    footprint += &format!(" co-contraction pair: {line}");
                }
                if let Some(longer) = &lengthened {
                    if let Some(m) = &longer.says[show] {
                        footprint += &format!(
                            " {} steps: {} [{}]",
                            longer.steps,
                            m.verdict,
                            m.families.join(", ")
                        );
                    }
                }
                eprintln!(
                    "{mark} {:<60} truth {:<12} -> {:<11} {:<22} final [{}]{footprint} {:.1} s",
                    case.label,
                    case.family,
                    mid.verdict,
                    mid.first.as_deref().unwrap_or("-"),
                    mid.families.join(", "),
                    t.elapsed().as_secs_f64()
                );
                out.lock().unwrap()[k] = Some(Judged {
                    family: case.family,
                    says,
                    settled,
                    paired,
                    spread_paired: spread_pair.is_some(),
                    lengthened: lengthened.is_some(),
                    footprint: case.footprint,
                });
            });
        }
    });
    out.into_inner().unwrap().into_iter().flatten().collect()
}

/// Runs the experiment a diagnosis names where one log cannot tell a joint's friction from
/// the muscles' hysteresis (the same trial at the other stiffness level), as a user would,
/// and decides the pair: the family it names (`None` when it cannot tell, or fails), and
/// whether it was run (only where some point of the grid left the two open and the
/// generator can run the trial).
fn stiffness_pair(case: &Case, trial: &Trial, says: &[FinalModel]) -> (Option<String>, bool) {
    let Some(other) = &case.other_stiffness else {
        return (None, false);
    };
    if !says.iter().any(FinalModel::awaits_stiffness_pair) {
        return (None, false);
    }
    let verdict = other
        .trial()
        .and_then(|b| pam_eval::pairs::decide(trial, &b));
    match verdict {
        Ok(v) => (v.family.map(Family::name).map(str::to_string), true),
        Err(e) => {
            eprintln!("{}: the stiffness pair failed: {e}", case.label);
            (None, true)
        }
    }
}

/// Runs the experiment a step log's diagnosis names where a family is within the
/// converters' spread (the same trial at another co-contraction), as a user would, and
/// decides the pair (`pam_model_loop::spread_pair`): the family it names beyond the spread
/// (`None` when it names none, or fails), and whether it was run.
fn co_contraction_pair(
    case: &Case,
    trial: &Trial,
    says: &[FinalModel],
) -> (Option<String>, Option<String>) {
    let Some(other) = &case.other_stiffness else {
        return (None, None);
    };
    if case.experiment != Experiment::Step
        || !says.iter().any(FinalModel::awaits_co_contraction_pair)
    {
        return (None, None);
    }
    let model = RobotModel::<f64>::thesis();
    let verdict = other.trial().and_then(|b| {
        saturation_or_spread(trial, &b, &model, Settings::default()).map_err(|e| e.to_string())
    });
    match verdict {
        Ok(v) => {
            let other: Vec<&str> = v.logs[1].final_model.iter().map(|f| f.name()).collect();
            let line = format!(
                "{} (at the other co-contraction [{}])",
                v.family.map_or("spread", Family::name),
                other.join(", ")
            );
            (v.family.map(Family::name).map(str::to_string), Some(line))
        }
        Err(e) => {
            eprintln!("{}: the co-contraction pair failed: {e}", case.label);
            (None, Some("failed".into()))
        }
    }
}

/// The longest trial a step log's diagnosis may name and still be run, as a multiple of the
/// log's own steps: a user runs the longer trial a diagnosis names when it is within reach
/// (an afternoon at the rig); one that needs more than this shows no gain worth following.
const MORE_STEPS_MAX: f64 = 4.0;

/// The longer step trial a diagnosis named, run and diagnosed.
struct Longer {
    /// Its final model at every point of the grid whose diagnosis named it.
    says: Vec<Option<FinalModel>>,
    /// The steps it was asked for.
    steps: usize,
}

/// Runs the longer trial a step log's diagnosis names where it has too few steps to decide
/// (about how many would decide, at the grid's points), as a user would, and diagnoses it.
/// `None` when no point named one within [`MORE_STEPS_MAX`], or the generator cannot run it.
fn more_steps(case: &Case, trial: &Trial, says: &[FinalModel], grid: &Grid) -> Option<Longer> {
    let more = case.more_steps.as_ref()?;
    let within = |m: &FinalModel| {
        m.more_steps
            .filter(|&(have, need)| have > 0 && need as f64 <= MORE_STEPS_MAX * have as f64)
    };
    // one trial serves every point: the most steps any of them asks for
    let (have, need) = says
        .iter()
        .filter_map(within)
        .max_by_key(|&(_, need)| need)?;
    let longer = more
        .trial_with_steps(trial, have, need)
        .and_then(|tr| final_models(&tr, case.experiment, &grid.gains, &grid.lags));
    match longer {
        Ok(l) => Some(Longer {
            says: says
                .iter()
                .zip(l)
                .map(|(m, l)| within(m).map(|_| l))
                .collect(),
            steps: need,
        }),
        Err(e) => {
            eprintln!("{}: the longer trial failed: {e}", case.label);
            None
        }
    }
}

struct Grid {
    gains: Vec<f64>,
    lags: Vec<f64>,
}

impl Grid {
    fn points(&self) -> Vec<Point> {
        self.lags
            .iter()
            .flat_map(|&lag_s| self.gains.iter().map(move |&gain| Point { gain, lag_s }))
            .collect()
    }

    /// The grid point of the loop's default settings (or the middle one).
    fn default_index(&self) -> usize {
        let d = Settings::default();
        self.points()
            .iter()
            .position(|p| {
                (p.gain - d.min_family_gain).abs() < 1e-12
                    && (p.lag_s - d.converter_lag_s).abs() < 1e-12
            })
            .unwrap_or(self.points().len() / 2)
    }
}

fn tally(judged: &[Judged], g: usize) -> Tally {
    let mut t = Tally::default();
    for j in judged {
        t.add(&j.family, &j.says[g]);
    }
    t
}

/// [`tally`] once the named experiments (stiffness pairs, longer step trials) were run and
/// decided.
fn tally_settled(judged: &[Judged], g: usize) -> Tally {
    let mut t = Tally::default();
    for j in judged {
        t.add(&j.family, &j.settled[g]);
    }
    t
}

/// The grid point best on one generator: most logs strictly right, then fewest false
/// alarms, then the point nearest the loop's default.
fn calibrate(judged: &[Judged], grid: &Grid) -> usize {
    let d = grid.default_index() as f64;
    (0..grid.points().len())
        .max_by(|&a, &b| {
            let (ta, tb) = (tally(judged, a), tally(judged, b));
            ta.right
                .cmp(&tb.right)
                .then(tb.false_alarms.cmp(&ta.false_alarms))
                .then(((b as f64 - d).abs()).total_cmp(&(a as f64 - d).abs()))
        })
        .unwrap_or(0)
}

/// The effect logs whose footprint was drawn, at the default point: how many carry an
/// effect under the model loop's materiality line, and how many of the misses are those.
fn footprints(runs: &[(String, Vec<Judged>)], def: usize) {
    let line = Settings::default().min_effect_size;
    let counts: Vec<(&String, Footprints)> = runs
        .iter()
        .map(|(gen, judged)| {
            let mut c = Footprints::new(line);
            for j in judged {
                c.add(&j.family, &j.says[def], j.footprint);
            }
            (gen, c)
        })
        .filter(|(_, c)| c.measured > 0)
        .collect();
    if counts.is_empty() {
        return;
    }
    println!();
    println!("{}", counts[0].1.header());
    for (gen, c) in counts {
        println!("| {gen} | {} |", c.row());
    }
}

fn list(s: String) -> Vec<f64> {
    let mut v: Vec<f64> = s.split(',').filter_map(|x| x.trim().parse().ok()).collect();
    v.sort_by(f64::total_cmp);
    v
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let get = |k: &str| {
        args.iter()
            .position(|a| a == k)
            .and_then(|i| args.get(i + 1).cloned())
    };
    let generators: Vec<String> = get("--generators")
        .unwrap_or("physgen,synth,twin".into())
        .split(',')
        .map(str::to_string)
        .collect();
    let n: usize = get("--logs").and_then(|s| s.parse().ok()).unwrap_or(40);
    let seed0: u64 = get("--seed0")
        .and_then(|s| s.parse().ok())
        .unwrap_or(900_000);
    let jobs: usize = get("--jobs").and_then(|s| s.parse().ok()).unwrap_or(2);
    let only = match get("--experiment").as_deref() {
        None => None,
        Some("dynamic") => Some(Experiment::Dynamic),
        Some("step") => Some(Experiment::Step),
        Some(other) => {
            eprintln!("--experiment dynamic|step, not `{other}`");
            std::process::exit(2);
        }
    };
    let dump = get("--dump").map(std::path::PathBuf::from);
    if let Some(dir) = &dump {
        if let Err(e) = std::fs::create_dir_all(dir) {
            eprintln!("cannot create {}: {e}", dir.display());
            std::process::exit(2);
        }
    }
    let d = Settings::default();
    let grid = Grid {
        gains: list(get("--gains").unwrap_or(d.min_family_gain.to_string())),
        lags: list(get("--lags").unwrap_or(d.converter_lag_s.to_string())),
    };
    if grid.gains.is_empty()
        || grid.lags.is_empty()
        || generators
            .iter()
            .any(|g| !["physgen", "synth", "twin"].contains(&g.as_str()))
    {
        eprintln!("usage: crossgen [--generators physgen,synth,twin] [--logs N] [--seed0 S] [--gains G,G] [--lags S,S] [--jobs J] [--experiment dynamic|step] [--dump DIR]");
        std::process::exit(2);
    }
    let wall = Instant::now();
    let runs: Vec<(String, Vec<Judged>)> = generators
        .iter()
        .map(|g| {
            let judged = run(g, n, seed0, &grid, jobs, only, dump.as_deref());
            (g.clone(), judged)
        })
        .collect();
    let points = grid.points();
    let def = grid.default_index();
    let name = |i: usize| {
        format!(
            "{} / {} ms{}",
            points[i].gain,
            1000.0 * points[i].lag_s,
            if i == def { " (default)" } else { "" }
        )
    };
    println!("| generator | min_family_gain / converter_lag | strictly right | of them decided | first family right | stacked | undecided | stiffness pairs run | co-contraction pairs run | longer step trials run | strictly right after them | false alarms | false alarms after them | alarms said | strictly right per family |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for (gen, judged) in &runs {
        let paired = judged.iter().filter(|j| j.paired).count();
        let spread_paired = judged.iter().filter(|j| j.spread_paired).count();
        let lengthened = judged.iter().filter(|j| j.lengthened).count();
        for i in 0..points.len() {
            let t = tally(judged, i);
            let after = tally_settled(judged, i);
            println!(
                "| {gen} | {} | {} | {} | {} | {} | {} | {paired} | {spread_paired} | {lengthened} | {} | {} | {} | {} | {} |",
                name(i),
                Tally::ratio(t.right, t.cases),
                t.decided,
                Tally::ratio(t.first_right, t.cases),
                t.stacked,
                t.undecided,
                Tally::ratio(after.right, after.cases),
                Tally::ratio(t.false_alarms, t.controls),
                Tally::ratio(after.false_alarms, after.controls),
                t.alarms_said(),
                t.per_family_said()
            );
        }
    }
    footprints(&runs, def);
    if runs.len() > 1 && points.len() > 1 {
        println!();
        println!("| calibrated on | chosen | scored on | strictly right | false alarms |");
        println!("|---|---|---|---|---|");
        for (x, jx) in &runs {
            let c = calibrate(jx, &grid);
            for (y, jy) in &runs {
                let t = tally(jy, c);
                println!(
                    "| {x} | {} | {y}{} | {} | {} |",
                    name(c),
                    if x == y { " (itself)" } else { "" },
                    Tally::ratio(t.right, t.cases),
                    Tally::ratio(t.false_alarms, t.controls)
                );
            }
        }
    }
    eprintln!("wall time {:.0} s", wall.elapsed().as_secs_f64());
}
