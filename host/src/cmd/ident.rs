//! `pamctl ident …`: identification as in the thesis (§4.3–4.6, §5.3), logic in pam-ident.

use crate::cmd::model_loop::read_trial;
use clap::{Args, Subcommand};
use pam_ident::msd::{self, MatrixReport, TimeFit};
use pam_ident::{freq, step, FilterSettings};
use pam_model::RobotModel;
use std::io::Write;
use std::path::PathBuf;

#[derive(Subcommand, Debug)]
pub enum IdentCommand {
    /// Mass-spring-damper fit of a dynamic trial in the time domain (§4.3, eq. 4.29–4.30).
    Dynamic(TimeArgs),
    /// Pure-spring fit of a static trial (eq. 4.27–4.28).
    Static(TimeArgs),
    /// Impedance fit in the frequency domain (§4.4, eq. 4.35 in 2 DoF), started from the
    /// time-domain fit.
    Freq(FreqArgs),
    /// Force-step analysis (§5.3): per-step G, ζ, ωn, per-pose averages, least-squares
    /// second-order fit, and the gain plane (eq. 5.2) over the logs' poses.
    Step(StepArgs),
}

#[derive(Args, Debug)]
pub struct TimeArgs {
    pub log: PathBuf,
    #[arg(long, default_value_t = 8.0)]
    pub cutoff_hz: f64,
    #[arg(long, default_value_t = 10)]
    pub order: usize,
    #[arg(long)]
    pub json: bool,
}

#[derive(Args, Debug)]
pub struct FreqArgs {
    #[command(flatten)]
    pub time: TimeArgs,
    /// Highest angular frequency used in the fit, rad/s (thesis: 22).
    #[arg(long, default_value_t = 22.0)]
    pub band_rad_s: f64,
}

#[derive(Args, Debug)]
pub struct StepArgs {
    /// One log per pose.
    #[arg(required = true)]
    pub logs: Vec<PathBuf>,
    /// A new step starts where |ΔF| between samples exceeds this (thesis: 3 N).
    #[arg(long, default_value_t = 3.0)]
    pub threshold_n: f64,
    #[arg(long)]
    pub json: bool,
}

pub fn run(cmd: IdentCommand, out: &mut impl Write) -> anyhow::Result<()> {
    match cmd {
        IdentCommand::Dynamic(a) => time(&a, true, out),
        IdentCommand::Static(a) => time(&a, false, out),
        IdentCommand::Freq(a) => frequency(&a, out),
        IdentCommand::Step(a) => steps(&a, out),
    }
}

fn print_matrix(out: &mut impl Write, m: &MatrixReport) -> anyhow::Result<()> {
    if !m.positive_definite {
        return Ok(writeln!(
            out,
            "  {} = [[{:9.3}, {:9.3}], [{:9.3}, {:9.3}]]  no ellipse: not positive definite (λ {:.3}, {:.3})",
            m.name, m.matrix[0][0], m.matrix[0][1], m.matrix[1][0], m.matrix[1][1], m.eigenvalues[0], m.eigenvalues[1]
        )?);
    }
    Ok(writeln!(
        out,
        "  {} = [[{:9.3}, {:9.3}], [{:9.3}, {:9.3}]]  ellipse: λ {:.3}, {:.3}; area {:.4e}; aspect {:.2}; orientation {:.1}°",
        m.name, m.matrix[0][0], m.matrix[0][1], m.matrix[1][0], m.matrix[1][1], m.eigenvalues[0], m.eigenvalues[1], m.area, m.aspect_ratio, m.orientation_deg
    )?)
}

fn print_time_fit(out: &mut impl Write, f: &TimeFit) -> anyhow::Result<()> {
    writeln!(
        out,
        "{} trial: {} samples every {:.4} s, equilibrium ({:+.4}, {:+.4}) m",
        f.experiment, f.samples, f.dt_s, f.equilibrium_m[0], f.equilibrium_m[1]
    )?;
    for m in &f.matrices {
        print_matrix(out, m)?;
    }
    writeln!(
        out,
        "held-out 20 %: MSE X {:.3}, Y {:.3} N²; R² X {:.4}, Y {:.4}; NRMSE X {:.4}, Y {:.4}",
        f.test[0].mse, f.test[1].mse, f.test[0].r2, f.test[1].r2, f.test[0].nrmse, f.test[1].nrmse
    )?;
    if let Some(s) = &f.split {
        writeln!(
            out,
            "MSE by motion frequency (Table 4.2; windows of {:.1} s, boundary {:.1} rad/s):",
            s.window_s, s.boundary_rad_s
        )?;
        writeln!(out, "          low freq.  high freq.  full test set")?;
        for a in 0..2 {
            writeln!(
                out,
                "  {}-axis  {:9.3}  {:10.3}  {:13.3}",
                ["X", "Y"][a],
                s.mse_low[a],
                s.mse_high[a],
                s.mse_all[a]
            )?;
        }
    }
    for w in &f.warnings {
        writeln!(out, "warning: {w}")?;
    }
    Ok(())
}

fn json(out: &mut impl Write, v: &impl serde::Serialize) -> anyhow::Result<()> {
    Ok(writeln!(out, "{}", serde_json::to_string_pretty(v)?)?)
}

fn time(a: &TimeArgs, dynamic: bool, out: &mut impl Write) -> anyhow::Result<()> {
    let model = RobotModel::<f64>::thesis();
    let (trial, _) = read_trial(&a.log)?;
    let p = trial.prepare(
        &model,
        FilterSettings {
            order: a.order,
            cutoff_hz: a.cutoff_hz,
        },
    )?;
    let f = if dynamic {
        msd::fit_dynamic(&p, model.cartesian_mass(p.alpha0_rad))
    } else {
        msd::fit_static(&p)
    };
    if a.json {
        return json(out, &f);
    }
    print_time_fit(out, &f)
}

fn frequency(a: &FreqArgs, out: &mut impl Write) -> anyhow::Result<()> {
    let model = RobotModel::<f64>::thesis();
    let (trial, _) = read_trial(&a.time.log)?;
    let p = trial.prepare(
        &model,
        FilterSettings {
            order: a.time.order,
            cutoff_hz: a.time.cutoff_hz,
        },
    )?;
    let t = msd::fit_dynamic(&p, model.cartesian_mass(p.alpha0_rad));
    let f = freq::fit(&p, &t.theta, a.band_rad_s)?;
    if a.time.json {
        return json(out, &f);
    }
    writeln!(
        out,
        "frequency fit up to {} rad/s ({} bins), started from the time-domain fit:",
        f.band_rad_s, f.bins
    )?;
    for m in &f.matrices {
        print_matrix(out, m)?;
    }
    writeln!(
        out,
        "R² of the force spectra (Table 4.4): X {:.4}, Y {:.4}",
        f.r2_spectrum[0], f.r2_spectrum[1]
    )?;
    writeln!(out, "these parameters in the time domain, held-out 20 %: R² X {:.4}, Y {:.4} (time fit: {:.4}, {:.4})", f.test[0].r2, f.test[1].r2, t.test[0].r2, t.test[1].r2)?;
    if !f.lm.reached_a_minimum() {
        writeln!(
            out,
            "warning: the frequency fit {} after {} iterations (cost {:.4e}); its parameters are the last iterate",
            f.lm.termination, f.lm.iterations, f.lm.cost
        )?;
    }
    Ok(())
}

#[derive(serde::Serialize)]
struct StepLogJson {
    log: String,
    steps: Vec<step::StepResult>,
    pose_averages: Vec<step::PoseAverage>,
    fitted: Vec<step::StepParams>,
    transfer_functions: Vec<String>,
    /// A whole-response fit that ran out of iterations, per axis.
    warnings: Vec<String>,
}

#[derive(serde::Serialize)]
struct StepJson {
    logs: Vec<StepLogJson>,
    gain_plane: Option<[[f64; 3]; 2]>,
    gain_plane_error: Option<String>,
}

/// The note for a whole-response fit that did not reach a minimum.
pub(crate) fn fit_warning(axis: usize, fit: &step::AxisFit) -> String {
    format!(
        "axis {}: the whole-response fit {} after {} iterations (cost {:.4e}); its parameters are the last iterate",
        ["X", "Y"][axis],
        fit.lm.termination,
        fit.lm.iterations,
        fit.lm.cost
    )
}

fn steps(a: &StepArgs, out: &mut impl Write) -> anyhow::Result<()> {
    let model = RobotModel::<f64>::thesis();
    let mut logs = Vec::new();
    let mut poses = Vec::new();
    for path in &a.logs {
        let (trial, _) = read_trial(path)?;
        if trial.force_ref_n.is_none() {
            return Err(anyhow::anyhow!(
                "{}: a step log needs the force reference columns fx_ref_n, fy_ref_n",
                path.display()
            ));
        }
        let p = trial.prepare(&model, FilterSettings::default())?;
        let steps = step::analyse_steps(&p, a.threshold_n);
        let avg = step::pose_averages(&steps);
        let mut fitted = Vec::new();
        let mut tfs = Vec::new();
        let mut warnings = Vec::new();
        for axis in 0..2 {
            if !steps.iter().any(|s| s.axis == axis) {
                continue;
            }
            let init = step::initial_params(&steps, axis);
            let f = match step::fit_axis(&p, axis, &init, p.len())? {
                Some(fit) => {
                    if !fit.reached_a_minimum() {
                        warnings.push(fit_warning(axis, &fit));
                    }
                    fit.params
                }
                None => init,
            };
            let w = f.omega_n_rad_s;
            tfs.push(format!(
                "{}: H(s) = {:.1} / (s² + {:.2} s + {:.1})  (G {:.3}, ζ {:.3}, ωn {:.2} rad/s)",
                ["X", "Y"][axis],
                f.gain * w * w,
                2.0 * f.zeta * w,
                w * w,
                f.gain,
                f.zeta,
                w
            ));
            fitted.push(f);
        }
        poses.extend(avg.iter().cloned());
        logs.push(StepLogJson {
            log: path.display().to_string(),
            steps,
            pose_averages: avg,
            fitted,
            transfer_functions: tfs,
            warnings,
        });
    }
    let plane = step::fit_gain_plane(&poses);
    let j = StepJson {
        logs,
        gain_plane: plane.as_ref().ok().copied(),
        gain_plane_error: plane.as_ref().err().map(|e| e.to_string()),
    };
    if a.json {
        return json(out, &j);
    }
    for l in &j.logs {
        writeln!(out, "{}: {} steps", l.log, l.steps.len())?;
        for s in &l.steps {
            writeln!(
                out,
                "  {} t {:7.2}–{:7.2} s  ref {:+7.2} → {:+7.2} N  G {:.3}  overshoot {:.3}  ζ {}  tp {}  ωn {}",
                ["X", "Y"][s.axis],
                s.t_start_s,
                s.t_end_s,
                s.ref_before_n,
                s.ref_after_n,
                s.gain,
                s.overshoot,
                s.zeta.map_or("-".into(), |v| format!("{v:.3}")),
                s.peak_time_s.map_or("-".into(), |v| format!("{v:.3} s")),
                s.omega_n_rad_s.map_or("-".into(), |v| format!("{v:.2} rad/s"))
            )?;
        }
        for p in &l.pose_averages {
            writeln!(
                out,
                "  average {} at α ({:.1}°, {:.1}°): G {:.3}, ζ {}, ωn {} over {} steps",
                ["X", "Y"][p.axis],
                p.alpha_rad[0].to_degrees(),
                p.alpha_rad[1].to_degrees(),
                p.gain,
                p.zeta.map_or("-".into(), |v| format!("{v:.3}")),
                p.omega_n_rad_s
                    .map_or("-".into(), |v| format!("{v:.2} rad/s")),
                p.steps
            )?;
        }
        for t in &l.transfer_functions {
            writeln!(out, "  least squares, whole response: {t}")?;
        }
        for w in &l.warnings {
            writeln!(out, "warning: {w}")?;
        }
    }
    match (&j.gain_plane, &j.gain_plane_error) {
        (Some(g), _) => {
            for a in 0..2 {
                writeln!(
                    out,
                    "gain plane {}: G = {:.4}·α1 + {:.4}·α2 + {:.4} (α in rad)",
                    ["X", "Y"][a],
                    g[a][0],
                    g[a][1],
                    g[a][2]
                )?;
            }
        }
        (None, Some(e)) => writeln!(out, "gain plane: not fitted ({e})")?,
        _ => {}
    }
    Ok(())
}
