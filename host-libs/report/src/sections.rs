//! The sections that show where a model fails: over time (zoomable), over the workspace,
//! over velocity, over frequency and per step, each for the fits compared (before/after).

use crate::bins::{by_variable, grid_rms, quantile, workspace_edges, Grid};
use crate::charts;
use crate::plots::{self, Stack, Trace, COLORS, MEASURED};
use crate::Page;
use pam_ident::step_detection::{reference_steps, ReferenceStep};
use pam_ident::trial::Prepared;
use pam_model_loop::diagnose::ModelFit;
use pam_model_loop::effects::Experiment;
use pam_numerics::spectrum::amplitude_spectrum;
use pam_numerics::stats::rms;

/// A fit as the page shows it: its label and colour.
pub struct Shown<'a> {
    pub label: String,
    pub fit: &'a ModelFit,
    pub color: &'static str,
}

/// `fits` labelled, first blue ("before"), last red ("after").
pub fn shown<'a>(fits: &[(String, &'a ModelFit)]) -> Vec<Shown<'a>> {
    fits.iter()
        .enumerate()
        .map(|(k, (label, fit))| Shown {
            label: label.clone(),
            fit,
            color: COLORS[k % COLORS.len()],
        })
        .collect()
}

const AXES: [&str; 2] = ["fx", "fy"];
/// Pixel-ish buckets of the decimated time series (min and max of each are kept).
const BUCKETS: usize = 1600;

fn signal_name(f: &ModelFit, axis: usize) -> String {
    match f.experiment {
        Experiment::Dynamic => format!("−{}", AXES[axis]),
        _ => AXES[axis].to_string(),
    }
}

/// Measured vs. predicted and the residual over the whole trial, zoomable, the held-out
/// part shaded.
pub fn time_series(page: &mut Page, p: &Prepared, fits: &[Shown]) {
    let Some(first) = fits.first() else { return };
    let t = &p.t_s;
    let mut panels = Vec::new();
    for axis in 0..2 {
        let (x, y) = plots::min_max(t, &first.fit.measured[axis], BUCKETS);
        let mut traces = vec![Trace::new("measured", x, y, MEASURED)];
        for s in fits {
            let (x, y) = plots::min_max(t, &s.fit.predicted[axis], BUCKETS);
            traces.push(Trace::new(&s.label, x, y, s.color));
        }
        panels.push((format!("{} [N]", signal_name(first.fit, axis)), traces));
    }
    for axis in 0..2 {
        let mut traces = Vec::new();
        for s in fits {
            let (x, y) = plots::min_max(t, &s.fit.residual(axis), BUCKETS);
            traces.push(Trace::new(&s.label, x, y, s.color));
        }
        panels.push((format!("residual {} [N]", AXES[axis]), traces));
    }
    let id = page.next_id();
    let t_end = t.last().copied().unwrap_or(0.0);
    let held: Vec<(f64, f64)> = p
        .held_out
        .ranges()
        .iter()
        .map(|r| {
            let at = |i: usize| t.get(i).copied().unwrap_or(t_end);
            (at(r.start), at(r.end.saturating_sub(1)))
        })
        .collect();
    page.plotly(&plots::stack(Stack {
        id: &id,
        title:
            "Measured and predicted force, and the residual (drag to zoom, double-click to reset)",
        x_title: "t [s]",
        panels,
        shade: (!held.is_empty()).then_some((held, p.held_out.label())),
        panel_height: 190,
        log_x: false,
        log_y: false,
        with_zero: false,
    }));
}

/// |residual| (both scored axes) binned over the handle position, one map per fit on one
/// colour scale. Skipped when the handle hardly moves.
pub fn workspace(page: &mut Page, p: &Prepared, fits: &[Shown]) {
    let x: Vec<f64> = p.x_m[0].iter().map(|v| v * 1e3).collect();
    let y: Vec<f64> = p.x_m[1].iter().map(|v| v * 1e3).collect();
    let spread =
        (quantile(&x, 0.995) - quantile(&x, 0.005)).max(quantile(&y, 0.995) - quantile(&y, 0.005));
    if !(spread > 2.0) {
        page.p(&format!(
            "The handle moves over {spread:.2} mm only: no residual map over the workspace."
        ));
        return;
    }
    let e = workspace_edges(&x, &y, 14);
    let grids: Vec<(String, Grid)> = fits
        .iter()
        .map(|s| {
            let mag: Vec<f64> = (0..x.len())
                .map(|i| {
                    s.fit
                        .axes
                        .iter()
                        .map(|&a| (s.fit.measured[a][i] - s.fit.predicted[a][i]).powi(2))
                        .sum::<f64>()
                        .sqrt()
                })
                .collect();
            (s.label.clone(), grid_rms(&x, &y, &mag, &e, 20))
        })
        .collect();
    let panels: Vec<(&str, &Grid)> = grids.iter().map(|(l, g)| (l.as_str(), g)).collect();
    let id = page.next_id();
    page.plotly(&charts::heat_maps(
        &id,
        "RMS |residual| over the handle position (whole trial; grey: fewer than 20 samples)",
        "x [mm]",
        "y [mm]",
        "N",
        &panels,
    ));
}

/// The residual of each axis binned over that axis's velocity: mean (solid) and RMS
/// (dashed) per bin. Skipped when the handle hardly moves.
pub fn velocity(page: &mut Page, p: &Prepared, fits: &[Shown]) {
    let top = (0..2)
        .map(|a| {
            quantile(
                &p.v_m_s[a].iter().map(|v| v.abs()).collect::<Vec<_>>(),
                0.99,
            )
        })
        .fold(0.0f64, f64::max);
    if !(top > 1e-3) {
        page.p("The handle hardly moves (99 % of speeds below 1 mm/s): no residual over velocity.");
        return;
    }
    page.note(
        "Residual over velocity: 30 bins over the central 99 % of each velocity (whole trial); \
         the mean solid with dots, the RMS dashed.",
    );
    for axis in 0..2 {
        let mut traces = Vec::new();
        for s in fits {
            let b = by_variable(&p.v_m_s[axis], &s.fit.residual(axis), 30, 20);
            let mut mean = Trace::new(
                &format!("{}: mean", s.label),
                b.center.clone(),
                b.mean,
                s.color,
            );
            mean.markers = true;
            let mut rms = Trace::new(&format!("{}: RMS", s.label), b.center, b.rms, s.color);
            rms.dashed = true;
            traces.extend([mean, rms]);
        }
        let id = page.next_id();
        page.plotly(&plots::stack(Stack {
            id: &id,
            title: &format!("residual {} against v{}", AXES[axis], ["x", "y"][axis]),
            x_title: if axis == 0 { "vx [m/s]" } else { "vy [m/s]" },
            panels: vec![("residual [N]".to_string(), traces)],
            shade: None,
            panel_height: 300,
            log_x: false,
            log_y: false,
            with_zero: true,
        }));
    }
}

/// Residual amplitude spectra per axis, zoomable, log–log.
pub fn spectrum(page: &mut Page, p: &Prepared, fits: &[Shown]) {
    let mut panels = Vec::new();
    for axis in 0..2 {
        let mut traces = Vec::new();
        for s in fits {
            let sp = amplitude_spectrum(
                &pam_numerics::spectrum::on_even_times(&p.t_s, &s.fit.residual(axis), p.dt_s),
                p.dt_s,
            );
            let (f, a) = plots::max_per_log_bucket(&sp.freq_hz, &sp.amplitude, 700);
            traces.push(Trace::new(&s.label, f, a, s.color));
        }
        panels.push((format!("|residual {}| [N]", AXES[axis]), traces));
    }
    let id = page.next_id();
    page.plotly(&plots::stack(Stack {
        id: &id,
        title: "Residual amplitude spectrum (whole trial; largest bin per display bucket)",
        x_title: "f [Hz]",
        panels,
        shade: None,
        panel_height: 230,
        log_x: true,
        log_y: true,
        with_zero: false,
    }));
}

/// A line of a step overlay: label, colour, x, y.
type OverlayLine = (String, &'static str, Vec<f64>, Vec<f64>);

/// Step trials: the RMS residual of every step per fit, and overlays of the worst steps.
pub fn per_step(page: &mut Page, p: &Prepared, fits: &[Shown]) {
    let Some(reference) = &p.force_ref_n else {
        return;
    };
    let Some(first) = fits.first() else { return };
    let st: Vec<_> = reference_steps(reference, 3.0)
        .into_iter()
        .filter(|s| s.end > s.start + 5)
        .collect();
    if st.is_empty() {
        return;
    }
    let step_rms = |f: &ModelFit, s: &ReferenceStep| {
        let r: Vec<f64> = f
            .axes
            .iter()
            .flat_map(|&a| (s.start..s.end).map(move |i| f.measured[a][i] - f.predicted[a][i]))
            .collect();
        rms(&r)
    };
    let held: Vec<String> = st
        .iter()
        .enumerate()
        .filter(|(_, s)| p.held_out.contains(s.start))
        .map(|(k, _)| (k + 1).to_string())
        .collect();
    let labels: Vec<String> = (1..=st.len()).map(|k| k.to_string()).collect();
    let series: Vec<(&str, &'static str, Vec<f64>)> = fits
        .iter()
        .map(|s| {
            (
                s.label.as_str(),
                s.color,
                st.iter().map(|x| step_rms(s.fit, x)).collect(),
            )
        })
        .collect();
    let id = page.next_id();
    page.plotly(&charts::bars(
        &id,
        &format!(
            "RMS residual per step (both scored axes); held out: {}",
            if held.is_empty() {
                "none".to_string()
            } else {
                format!(
                    "step{} {}",
                    if held.len() > 1 { "s" } else { "" },
                    held.join(", ")
                )
            }
        ),
        "RMS residual [N]",
        &labels,
        &series,
    ));
    // the worst steps of the first fit, in time order
    let mut worst: Vec<usize> = (0..st.len()).collect();
    worst.sort_by(|a, b| series[0].2[*b].total_cmp(&series[0].2[*a]));
    worst.truncate(4);
    worst.sort_unstable();
    let pre = ((0.1 / p.dt_s) as usize).max(1);
    // (step, lines), each line decimated for the page
    let windows: Vec<(usize, Vec<OverlayLine>)> = worst
        .iter()
        .map(|&k| {
            let s = st[k];
            let (a, b) = (
                s.start.saturating_sub(pre),
                s.end.min(s.start + (2.0 / p.dt_s) as usize),
            );
            let x: Vec<f64> = (a..b).map(|i| p.t_s[i] - p.t_s[s.start]).collect();
            let line = |label: &str, color, y: &[f64]| {
                let (x, y) = plots::min_max(&x, &y[a..b], 400);
                (label.to_string(), color, x, y)
            };
            let mut lines = vec![line("measured", MEASURED, &first.fit.measured[s.axis])];
            for f in fits {
                lines.push(line(&f.label, f.color, &f.fit.predicted[s.axis]));
            }
            (k, lines)
        })
        .collect();
    page.note("The worst steps of the first model, measured and predicted.");
    for (k, lines) in windows {
        let s = st[k];
        let ax = s.axis;
        let traces = lines
            .into_iter()
            .map(|(label, color, x, y)| Trace::new(&label, x, y, color))
            .collect();
        let id = page.next_id();
        page.plotly(&plots::stack(Stack {
            id: &id,
            title: &format!(
                "step {} at t = {:.2} s, {}: reference {:.1} → {:.1} N",
                k + 1,
                p.t_s[s.start],
                AXES[ax],
                reference[ax][s.start.saturating_sub(1)],
                reference[ax][s.start]
            ),
            x_title: "time from the step [s]",
            panels: vec![("force [N]".to_string(), traces)],
            shade: None,
            panel_height: 230,
            log_x: false,
            log_y: false,
            with_zero: false,
        }));
    }
}

/// The residual of `before` against what `after` adds to it: points on the diagonal are
/// what the added effects explain.
pub fn term_scatter(page: &mut Page, before: &ModelFit, after: &ModelFit, what: &str) {
    for axis in 0..2 {
        let contrib: Vec<f64> = (0..before.predicted[axis].len())
            .map(|i| after.predicted[axis][i] - before.predicted[axis][i])
            .collect();
        let id = page.next_id();
        page.plotly(&charts::scatter(
            &id,
            &format!("{}: residual before vs. the {what} term", AXES[axis]),
            "effect term [N]",
            "residual before [N]",
            &contrib,
            &before.residual(axis),
        ));
    }
}

/// Every "where does it fail" view for the fits.
pub fn where_it_fails(page: &mut Page, p: &Prepared, fits: &[Shown]) {
    let Some(first) = fits.first() else { return };
    page.h2("Over time");
    time_series(page, p, fits);
    if first.fit.experiment == Experiment::Step {
        page.h2("Per step");
        per_step(page, p, fits);
    }
    page.h2("Over the workspace");
    workspace(page, p, fits);
    page.h2("Over velocity");
    velocity(page, p, fits);
    page.h2("Over frequency");
    spectrum(page, p, fits);
}
