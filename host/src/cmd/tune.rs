//! `pamctl tune LOG`: the closed force loop's gain scale from a force-step log.
//!
//! The log's steps are identified as in `pamctl ident step` (§5.3: per axis G, ζ, ωn, a
//! least-squares second-order fit, `pam_ident::step`); `pam_twin::tune` proposes the gain
//! scale of the designed loop for that plant and predicts its 9.1 N step. Nothing is sent to
//! the device: the user applies the scale with `pamctl set force … --closed-loop
//! --gain-scale S` (the link carries only the gain scale; the protocol is unchanged).
//! The loop measures the plant's static gain itself and divides its command by it
//! (`pam_control::plant_gain`, within 0.5–2): the plant it runs against, and the one the
//! scale is proposed for, is G / Ĝ, not the identified G.

use crate::cmd::model_loop::read_trial;
use anyhow::{anyhow, bail, Context};
use clap::Args;
use pam_ident::{step, FilterSettings};
use pam_model::RobotModel;
use pam_twin::tune::{self, Proposal, StepPlant};
use std::io::Write;
use std::path::PathBuf;

#[derive(Args, Debug)]
pub struct TuneArgs {
    /// A force-step log (`pamctl simulate --experiment force_step --out F`, or `pamctl
    /// experiment` on the rig), recorded with the `--feed-forward` setting the closed loop
    /// will use: the gain it shows is the gain the loop sees.
    pub log: PathBuf,
    /// Transport delay of the rig on top of the loop's own, ms (the step fit does not
    /// identify it; the thesis found < 50 ms, Table 5.1).
    #[arg(long, default_value_t = 0.0)]
    pub delay_ms: f64,
    /// The loop's period, ms (the firmware's default: 1).
    #[arg(long, default_value_t = 1.0)]
    pub period_ms: f64,
    /// A new step starts where |ΔF| between samples exceeds this (thesis: 3 N).
    #[arg(long, default_value_t = 3.0)]
    pub threshold_n: f64,
    #[arg(long)]
    pub json: bool,
}

#[derive(serde::Serialize)]
struct AxisJson {
    axis: &'static str,
    gain: f64,
    zeta: f64,
    omega_n_rad_s: f64,
    gain_scale: f64,
    kp: f64,
    ki_per_s: f64,
    kd_s: f64,
    gain_margin: f64,
    phase_margin_deg: f64,
    band_gain_margin: f64,
    band_phase_margin_deg: f64,
    settling_s: f64,
    overshoot_pct: f64,
    band_worst_settling_s: f64,
    designed_settling_s: f64,
    designed_overshoot_pct: f64,
}

#[derive(serde::Serialize)]
struct TuneJson {
    log: String,
    axes: Vec<AxisJson>,
    /// One scale for both axes (the wire carries one): the smaller proposal.
    gain_scale: f64,
    /// The prediction of each axis at that scale.
    settling_s: Vec<f64>,
    overshoot_pct: Vec<f64>,
}

/// The identified plant as the closed loop sees it once it has measured its gain: G / Ĝ, Ĝ
/// the loop's measurement (G within its range 0.5–2).
fn as_the_loop_sees(plant: &StepPlant) -> StepPlant {
    use pam_control::plant_gain::{PLANT_GAIN_MAX, PLANT_GAIN_MIN};
    let measured = plant
        .gain
        .clamp(PLANT_GAIN_MIN as f64, PLANT_GAIN_MAX as f64);
    StepPlant {
        gain: plant.gain / measured,
        ..*plant
    }
}

pub fn run(a: TuneArgs, out: &mut impl Write) -> anyhow::Result<()> {
    let (trial, _) = read_trial(&a.log)?;
    if trial.force_ref_n.is_none() {
        bail!(
            "{}: a step log needs the force reference columns fx_ref_n, fy_ref_n",
            a.log.display()
        );
    }
    let model = RobotModel::<f64>::thesis();
    let p = trial.prepare(&model, FilterSettings::default())?;
    let steps = step::analyse_steps(&p, a.threshold_n);
    let period_s = a.period_ms * 1e-3;
    let mut axes: Vec<(usize, StepPlant, Proposal)> = Vec::new();
    for axis in 0..2 {
        if !steps.iter().any(|s| s.axis == axis) {
            continue;
        }
        let init = step::initial_params(&steps, axis);
        let f = match step::fit_axis(&p, axis, &init, p.len())
            .map_err(|e| anyhow!("{} axis {}: {e}", a.log.display(), ["X", "Y"][axis]))?
        {
            Some(fit) => {
                if !fit.reached_a_minimum() {
                    eprintln!("warning: {}", crate::cmd::ident::fit_warning(axis, &fit));
                }
                fit.params
            }
            None => init,
        };
        let plant = StepPlant {
            gain: f.gain,
            zeta: f.zeta,
            omega_n_rad_s: f.omega_n_rad_s,
            delay_s: a.delay_ms * 1e-3,
        };
        let proposal = tune::propose(&as_the_loop_sees(&plant), period_s)
            .map_err(|e| anyhow!("{} axis {}: {e}", a.log.display(), ["X", "Y"][axis]))?;
        axes.push((axis, plant, proposal));
    }
    if axes.is_empty() {
        bail!("{}: no force step found", a.log.display());
    }
    let scale = axes
        .iter()
        .map(|(_, _, p)| p.gain_scale)
        .fold(f64::INFINITY, f64::min);
    let cfg = pam_control::ForceLoopConfig::designed();
    let at_scale: Vec<tune::Prediction> = axes
        .iter()
        .map(|(_, plant, _)| tune::predict(&cfg, scale, &as_the_loop_sees(plant), period_s))
        .collect();
    if a.json {
        let j = TuneJson {
            log: a.log.display().to_string(),
            axes: axes
                .iter()
                .map(|(axis, pl, pr)| AxisJson {
                    axis: ["X", "Y"][*axis],
                    gain: pl.gain,
                    zeta: pl.zeta,
                    omega_n_rad_s: pl.omega_n_rad_s,
                    gain_scale: pr.gain_scale,
                    kp: pr.kp,
                    ki_per_s: pr.ki_per_s,
                    kd_s: pr.kd_s,
                    gain_margin: pr.margins.gain_margin,
                    phase_margin_deg: pr.margins.phase_margin_deg,
                    band_gain_margin: pr.margins_in_band.gain_margin,
                    band_phase_margin_deg: pr.margins_in_band.phase_margin_deg,
                    settling_s: pr.prediction.settling_s,
                    overshoot_pct: pr.prediction.overshoot_pct,
                    band_worst_settling_s: pr.worst_in_band.settling_s,
                    designed_settling_s: pr.designed.settling_s,
                    designed_overshoot_pct: pr.designed.overshoot_pct,
                })
                .collect(),
            gain_scale: scale,
            settling_s: at_scale.iter().map(|p| p.settling_s).collect(),
            overshoot_pct: at_scale.iter().map(|p| p.overshoot_pct).collect(),
        };
        let s = serde_json::to_string_pretty(&j).context("the proposal as JSON")?;
        return Ok(writeln!(out, "{s}")?);
    }
    writeln!(out, "{}:", a.log.display())?;
    for (axis, pl, pr) in &axes {
        let w = pl.omega_n_rad_s;
        writeln!(
            out,
            "  {}: H(s) = {:.1} / (s² + {:.2} s + {:.1})  (G {:.3}, ζ {:.3}, ωn {:.2} rad/s), delay {:.1} ms + the loop's {:.1} ms",
            ["X", "Y"][*axis],
            pl.gain * w * w,
            2.0 * pl.zeta * w,
            w * w,
            pl.gain,
            pl.zeta,
            w,
            pl.delay_s * 1e3,
            1.5 * a.period_ms
        )
        ?;
        writeln!(
            out,
            "     proposed gain scale {:.2} (kp {:.2}, ki {:.1} /s, kd {:.3} s): GM {:.1} ({:.1} dB), PM {:.0}° at G; least over G ÷/× {}: GM {:.1}, PM {:.0}°",
            pr.gain_scale,
            pr.kp,
            pr.ki_per_s,
            pr.kd_s,
            pr.margins.gain_margin,
            20.0 * pr.margins.gain_margin.log10(),
            pr.margins.phase_margin_deg,
            tune::GAIN_SPREAD,
            pr.margins_in_band.gain_margin,
            pr.margins_in_band.phase_margin_deg
        )
        ?;
        writeln!(
            out,
            "     predicted {} N step: 5 % settling {:.3} s, overshoot {:.1} % (worst over the band {:.3} s); designed gains: {:.3} s, {:.1} %",
            tune::PREDICTED_STEP_N,
            pr.prediction.settling_s,
            pr.prediction.overshoot_pct,
            pr.worst_in_band.settling_s,
            pr.designed.settling_s,
            pr.designed.overshoot_pct
        )
        ?;
    }
    let preds: Vec<String> = axes
        .iter()
        .zip(&at_scale)
        .map(|((axis, _, _), p)| {
            format!(
                "{} {:.3} s, {:.1} %",
                ["X", "Y"][*axis],
                p.settling_s,
                p.overshoot_pct
            )
        })
        .collect();
    writeln!(
        out,
        "gain scale {scale:.2} (one for both axes, the smaller): predicted {}",
        preds.join("; ")
    )?;
    writeln!(
        out,
        "apply (nothing was sent): pamctl set force --force-n FX,FY --closed-loop [--feed-forward, as in the log] --gain-scale {scale:.2}"
    )?;
    Ok(())
}
