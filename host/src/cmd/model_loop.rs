//! `pamctl model compare | diagnose | fit`: the model loop on one log (logic in pam-ident).

use anyhow::Context;
use clap::Args;
use pam_ident::{FilterSettings, Trial};
use pam_model::RobotModel;
use pam_model_loop::diagnose::{self, Settings, Verdict};
use pam_model_loop::effects::{self, Experiment};
use pam_model_loop::{spread_pair, stiffness_pair};
use pam_report as report;
use std::io::Write;
use std::path::{Path, PathBuf};

#[derive(Args, Debug, Clone)]
pub struct LoopArgs {
    /// Log file (format v1).
    pub log: PathBuf,
    /// dynamic | step. Default: the log's `# experiment = …` metadata, else `step` when the
    /// log has a force reference that steps, else `dynamic`.
    #[arg(long)]
    pub experiment: Option<String>,
    /// Effects to add to the base model, comma-separated catalog ids.
    #[arg(long = "with", value_delimiter = ',', value_name = "ID,...")]
    pub with: Vec<String>,
    /// Machine-readable output.
    #[arg(long)]
    pub json: bool,
    /// Write a self-contained HTML report here.
    #[arg(long, value_name = "FILE.html")]
    pub report: Option<PathBuf>,
    /// Cut-off of the zero-phase Butterworth on the derivatives, Hz.
    #[arg(long, default_value_t = 8.0)]
    pub cutoff_hz: f64,
    /// Order of that filter.
    #[arg(long, default_value_t = 10)]
    pub order: usize,
}

#[derive(Args, Debug, Clone)]
pub struct DiagnoseArgs {
    #[command(flatten)]
    pub loop_args: LoopArgs,
    /// A second log: the same trial at another stiffness. Dynamic: Table 4.1's other
    /// level; the muscles' hysteresis grows with their pressure and friction does not, so
    /// the pair tells the two apart where one log cannot. Step: the same pose at the other
    /// co-contraction (`pamctl experiment step --co-contraction both`); a supply's ceiling
    /// takes a larger share of the steps there and the converters' spread does not.
    pub other: Option<PathBuf>,
}

/// Reads a log into a trial; errors carry file, line and column (from pam-log).
pub fn read_trial(path: &Path) -> anyhow::Result<(Trial, pam_log::Log)> {
    let log = pam_log::read_path(path)?;
    let trial = Trial::from_log(&log)?;
    Ok((trial, log))
}

pub fn experiment_of(
    arg: &Option<String>,
    log: &pam_log::Log,
    trial: &Trial,
) -> anyhow::Result<Experiment> {
    if let Some(e) = arg {
        return Ok(e.parse()?);
    }
    if let Some(e) = log.meta("experiment") {
        match e.trim() {
            "force_step" | "step" => return Ok(Experiment::Step),
            "dynamic" | "static" => return Ok(Experiment::Dynamic),
            _ => {}
        }
    }
    let steps = trial.force_ref_n.as_ref().is_some_and(|r| {
        r.iter()
            .any(|c| c.windows(2).any(|w| (w[1] - w[0]).abs() > 1e-9))
    });
    Ok(if steps {
        Experiment::Step
    } else {
        Experiment::Dynamic
    })
}

fn settings(a: &LoopArgs) -> Settings {
    Settings {
        filter: FilterSettings {
            order: a.order,
            cutoff_hz: a.cutoff_hz,
        },
        ..Settings::default()
    }
}

fn write_report(path: &Path, html: &str) -> anyhow::Result<()> {
    std::fs::write(path, html).with_context(|| format!("{}", path.display()))
}

fn json_out(out: &mut impl Write, v: &impl serde::Serialize) -> anyhow::Result<()> {
    let s = serde_json::to_string_pretty(v)?;
    Ok(writeln!(out, "{s}")?)
}

/// Runs `work` with a progress bar on stderr when stderr is a terminal (a diagnosis of a
/// long 1 kHz log takes seconds): preparing, each effect fitted, combining.
fn with_progress<T>(work: impl FnOnce(&(dyn Fn(diagnose::Progress) + Sync)) -> T) -> T {
    use std::io::IsTerminal;
    if !std::io::stderr().is_terminal() {
        return work(&|_| {});
    }
    let bar = indicatif::ProgressBar::new_spinner();
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{spinner} {msg} [{bar:30}] {pos}/{len} effects, {elapsed}",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
        .progress_chars("=> "),
    );
    bar.set_message("preparing the trial and the base model");
    bar.enable_steady_tick(std::time::Duration::from_millis(120));
    let update = |p: diagnose::Progress| match p {
        diagnose::Progress::BaseFitted { effects } => {
            bar.set_length(effects as u64);
            bar.set_message("fitting each effect with the base");
        }
        diagnose::Progress::EffectDone { .. } => bar.inc(1),
        diagnose::Progress::Combining => bar.set_message("combining the accepted effects"),
    };
    let out = work(&update);
    bar.finish_and_clear();
    out
}

/// `diagnose LOG [OTHER]`: one log's diagnosis, and with a second log of the same trial at
/// the other stiffness level, the pair's decision: friction or hysteresis (dynamic trials),
/// a family or the converters' spread (step trials).
pub fn diagnose(args: &DiagnoseArgs, out: &mut impl Write) -> anyhow::Result<()> {
    let a = &args.loop_args;
    let Some(other) = &args.other else {
        return diagnose_one(a, out);
    };
    let model = RobotModel::<f64>::thesis();
    let (trial_a, log_a) = read_trial(&a.log)?;
    let (trial_b, log_b) = read_trial(other)?;
    let exp_a = experiment_of(&a.experiment, &log_a, &trial_a)?;
    let exp_b = experiment_of(&a.experiment, &log_b, &trial_b)?;
    if exp_a != exp_b {
        anyhow::bail!(
            "{} is a {} trial and {} a {} one: a pair is the same trial at two stiffness levels",
            a.log.display(),
            exp_a.name(),
            other.display(),
            exp_b.name()
        );
    }
    if exp_a == Experiment::Step {
        return diagnose_step_pair(a, other, [&trial_a, &trial_b], &model, out);
    }
    let pair = stiffness_pair::friction_or_hysteresis(&trial_a, &trial_b, &model, settings(a))?;
    if a.json {
        return first_log_json_with(a, "friction_or_hysteresis", &pair, out);
    }
    first_log_then_pair(a, other, "friction or hysteresis", out)?;
    let named = pair.family.map_or("cannot tell", |f| f.name());
    writeln!(out, "  {named}: {}", pair.evidence)?;
    if let Some(x) = &pair.separating_experiment {
        writeln!(out, "  to separate them: {x}")?;
    }
    for w in &pair.warnings {
        writeln!(out, "warning: {w}")?;
    }
    Ok(())
}

/// The first log's diagnosis as JSON, with a pair's decision added under `key`.
fn first_log_json_with(
    a: &LoopArgs,
    key: &str,
    pair: &impl serde::Serialize,
    out: &mut impl Write,
) -> anyhow::Result<()> {
    let mut d = Vec::new();
    diagnose_one(
        &LoopArgs {
            json: true,
            ..a.clone()
        },
        &mut d,
    )?;
    let mut v: serde_json::Value = serde_json::from_slice(&d)?;
    v[key] = serde_json::to_value(pair)?;
    json_out(out, &v)
}

/// The first log's diagnosis in words, then the heading of the pair's decision.
fn first_log_then_pair(
    a: &LoopArgs,
    other: &Path,
    what: &str,
    out: &mut impl Write,
) -> anyhow::Result<()> {
    writeln!(out, "{}:", a.log.display())?;
    diagnose_one(a, out)?;
    writeln!(out)?;
    writeln!(
        out,
        "{what}, from {} and {}:",
        a.log.display(),
        other.display()
    )?;
    Ok(())
}

/// Two step logs of the same pose at two co-contractions: a family the converters' spread
/// hides in one log, decided from the pair (`pam_model_loop::spread_pair`).
fn diagnose_step_pair(
    a: &LoopArgs,
    other: &Path,
    trials: [&Trial; 2],
    model: &RobotModel<f64>,
    out: &mut impl Write,
) -> anyhow::Result<()> {
    let pair = spread_pair::saturation_or_spread(trials[0], trials[1], model, settings(a))?;
    if a.json {
        return first_log_json_with(a, "family_or_spread", &pair, out);
    }
    first_log_then_pair(a, other, "a family or the converters' spread", out)?;
    let named = match (pair.family, pair.decided) {
        (Some(f), _) => f.name(),
        (None, true) => "no family",
        (None, false) => "cannot tell",
    };
    writeln!(out, "  {named}: {}", pair.evidence)?;
    for (path, log) in [(a.log.as_path(), &pair.logs[0]), (other, &pair.logs[1])] {
        let families: Vec<&str> = log.final_model.iter().map(|f| f.name()).collect();
        let hidden: Vec<&str> = log.within_spread.iter().map(|w| w.family.name()).collect();
        writeln!(
            out,
            "  {}: final model [{}], within the spread [{}], mean currents {:.2} {:.2} {:.2} {:.2} mA",
            path.display(),
            families.join(", "),
            hidden.join(", "),
            log.mean_current_ma[0],
            log.mean_current_ma[1],
            log.mean_current_ma[2],
            log.mean_current_ma[3]
        )?;
    }
    Ok(())
}

fn diagnose_one(a: &LoopArgs, out: &mut impl Write) -> anyhow::Result<()> {
    let model = RobotModel::<f64>::thesis();
    let (trial, log) = read_trial(&a.log)?;
    let exp = experiment_of(&a.experiment, &log, &trial)?;
    let (d, fits) = with_progress(|progress| {
        diagnose::diagnose_observed(
            &trial,
            &model,
            exp,
            settings(a),
            &pam_model_loop::effects::catalog(),
            progress,
        )
    })?;
    if let Some(path) = &a.report {
        // the samples the fits were made on (the analysis grid)
        let p = diagnose::analysis_trial(&trial, &model, exp, settings(a))?;
        write_report(path, &report::diagnosis_page(&d, &fits, &p))?;
    }
    if a.json {
        return json_out(out, &d);
    }
    writeln!(
        out,
        "experiment: {}, {} samples every {:.4} s; {}",
        d.experiment, d.samples, d.sample_period_s, d.held_out
    )?;
    writeln!(
        out,
        "base model: held-out NRMSE fx {:.4}, fy {:.4} (R² {:.3}, {:.3})",
        d.base.nrmse.fx, d.base.nrmse.fy, d.base.r2.fx, d.base.r2.fy
    )?;
    writeln!(out, "verdict: {}", d.verdict)?;
    if d.verdict == Verdict::Unexplained && d.effects.iter().any(|e| e.accepted) {
        writeln!(
            out,
            "  (an effect below is worth its parameters, but the structure listed after them carries more of the residual than it removes)"
        )?;
    }
    if !d.ambiguous.is_empty() {
        let names: Vec<&str> = d.ambiguous.iter().map(|f| f.name()).collect();
        writeln!(
            out,
            "ambiguous: the log cannot tell {} apart",
            names.join(" and ")
        )?;
        if let Some(why) = &d.ambiguity_evidence {
            writeln!(out, "  {why}")?;
        }
        if let Some(x) = &d.separating_experiment {
            writeln!(out, "  to separate them: {x}")?;
        }
    }
    for e in &d.effects {
        let family = e.family.map(|f| f.name()).unwrap_or(e.id.as_str());
        writeln!(
            out,
            "  {:<22} {:<24} NRMSE fx {:.4}, fy {:.4}  removes {:>6.1} %  t {:>5.1}  score {:+.3}{}",
            family,
            e.shape,
            e.nrmse.fx,
            e.nrmse.fy,
            100.0 * e.improvement,
            e.folds.t,
            e.score,
            if e.accepted {
                "  <- worth its parameters"
            } else {
                ""
            }
        )?;
        if e.accepted {
            writeln!(out, "      {}", e.evidence)?;
            let ps: Vec<String> = e
                .params
                .iter()
                .map(|(k, v)| format!("{k} = {v:.4}"))
                .collect();
            writeln!(out, "      fitted: {}", ps.join(", "))?;
        }
    }
    for u in &d.unexplained {
        writeln!(out, "unexplained: {} in {}: {}", u.kind, u.signal, u.detail)?;
    }
    if d.steps.len() > 1 {
        writeln!(out, "step by step:")?;
        for s in &d.steps {
            writeln!(
                out,
                "  base{:<40} NRMSE fx {:.4}, fy {:.4}",
                s.effects
                    .iter()
                    .map(|e| format!(" + {e}"))
                    .collect::<String>(),
                s.nrmse.fx,
                s.nrmse.fy
            )?;
        }
    }
    if let Some(last) = d.steps.last().filter(|s| !s.effects.is_empty()) {
        writeln!(out, "final model: base + {}", last.effects.join(" + "))?;
    }
    for r in &d.refinements {
        writeln!(out, "not in the final model: {}", r.evidence)?;
    }
    for w in &d.warnings {
        writeln!(out, "warning: {w}")?;
    }
    Ok(())
}

pub fn compare(a: &LoopArgs, out: &mut impl Write) -> anyhow::Result<()> {
    let model = RobotModel::<f64>::thesis();
    let (trial, log) = read_trial(&a.log)?;
    let exp = experiment_of(&a.experiment, &log, &trial)?;
    let catalog = effects::catalog();
    let with = effects::lookup(&catalog, &a.with)?;
    let (lp, _, spikes) = diagnose::loop_without_spikes(&trial, &model, exp, settings(a))?;
    let fit = lp.fit(&with);
    let mut c = diagnose::compare(&lp, &fit);
    if let Some(s) = &spikes {
        c.warnings.insert(0, s.warning());
    }
    if let Some(path) = &a.report {
        write_report(path, &report::comparison_page(&c, &fit, &lp.p))?;
    }
    if a.json {
        return json_out(out, &c);
    }
    writeln!(
        out,
        "model: base{} ({} experiment)",
        c.effects
            .iter()
            .map(|e| format!(" + {e}"))
            .collect::<String>(),
        c.experiment
    )?;
    writeln!(
        out,
        "held-out NRMSE fx {:.4}, fy {:.4}; R² fx {:.3}, fy {:.3}",
        c.nrmse.fx, c.nrmse.fy, c.r2.fx, c.r2.fy
    )?;
    if let Some(s) = &c.frequency_split {
        writeln!(out, "MSE low / high motion frequency (boundary {:.1} rad/s): X {:.3} / {:.3}, Y {:.3} / {:.3} N²", s.boundary_rad_s, s.mse_low[0], s.mse_high[0], s.mse_low[1], s.mse_high[1])?;
    }
    writeln!(out, "worst windows:")?;
    for w in &c.worst_windows {
        writeln!(
            out,
            "  {:8.2}–{:8.2} s  RMS fx {:.3}, fy {:.3} N",
            w.t_start_s, w.t_end_s, w.rms_n.fx, w.rms_n.fy
        )?;
    }
    writeln!(out, "error by speed:")?;
    for b in &c.error_by_speed {
        writeln!(
            out,
            "  {:<24} RMS fx {:.3}, fy {:.3} N ({} samples)",
            b.label, b.rms_n.fx, b.rms_n.fy, b.samples
        )?;
    }
    writeln!(out, "error over the workspace:")?;
    for b in &c.error_by_position {
        writeln!(
            out,
            "  {:<28} RMS fx {:.3}, fy {:.3} N ({} samples)",
            b.label, b.rms_n.fx, b.rms_n.fy, b.samples
        )?;
    }
    for pk in &c.residual_peaks {
        writeln!(out, "residual line: {}", pk.detail)?;
    }
    for (id, m) in &c.params {
        let ps: Vec<String> = m.iter().map(|(k, v)| format!("{k} = {v:.4}")).collect();
        writeln!(out, "{id}: {}", ps.join(", "))?;
    }
    for w in &c.warnings {
        writeln!(out, "warning: {w}")?;
    }
    Ok(())
}

#[derive(serde::Serialize)]
struct FitJson {
    experiment: String,
    effects: Vec<String>,
    before: diagnose::AxisPair,
    after: diagnose::AxisPair,
    params: std::collections::BTreeMap<String, std::collections::BTreeMap<String, f64>>,
    /// Spikes bridged, uneven sampling (as `diagnose` says them).
    warnings: Vec<diagnose::Warning>,
}

pub fn fit(a: &LoopArgs, out: &mut impl Write) -> anyhow::Result<()> {
    let model = RobotModel::<f64>::thesis();
    let (trial, log) = read_trial(&a.log)?;
    let exp = experiment_of(&a.experiment, &log, &trial)?;
    let catalog = effects::catalog();
    let with = effects::lookup(&catalog, &a.with)?;
    if with.is_empty() {
        return Err(anyhow::anyhow!(
            "fit needs --with ID,... (see `pamctl model diagnose` for candidates)"
        ));
    }
    for e in &with {
        if !e.applies(exp) {
            return Err(anyhow::anyhow!(
                "effect `{}` cannot be seen in a {} experiment",
                e.id(),
                exp.name()
            ));
        }
    }
    let (lp, before, spikes) = diagnose::loop_without_spikes(&trial, &model, exp, settings(a))?;
    let after = lp.fit(&with);
    let warnings: Vec<diagnose::Warning> = spikes
        .iter()
        .map(|s| s.warning())
        .chain(diagnose::sampling_warning(&lp))
        .collect();
    if let Some(path) = &a.report {
        write_report(path, &report::fit_page(&before, &after, &lp.p))?;
    }
    let j = FitJson {
        experiment: exp.name().into(),
        effects: after.effect_ids.clone(),
        before: diagnose::nrmse_pair(&before),
        after: diagnose::nrmse_pair(&after),
        params: after.params.clone(),
        warnings,
    };
    if a.json {
        return json_out(out, &j);
    }
    writeln!(
        out,
        "held-out NRMSE before: fx {:.4}, fy {:.4}",
        before.nrmse[0], before.nrmse[1]
    )?;
    writeln!(
        out,
        "held-out NRMSE after:  fx {:.4}, fy {:.4}  (base + {})",
        after.nrmse[0],
        after.nrmse[1],
        after.effect_ids.join(" + ")
    )?;
    for (id, m) in &after.params {
        let ps: Vec<String> = m.iter().map(|(k, v)| format!("{k} = {v:.4}")).collect();
        writeln!(out, "{id}: {}", ps.join(", "))?;
    }
    for w in &j.warnings {
        writeln!(out, "warning: {w}")?;
    }
    Ok(())
}
