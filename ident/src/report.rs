//! Self-contained HTML reports (inline SVG, no script, no network): measured vs. predicted
//! before and after, residuals against the signature that revealed an effect, the residual
//! spectrum, and the error falling as effects are added.

use crate::diagnose::{Comparison, Diagnosis, ModelFit};
use crate::spectrum::amplitude_spectrum;
use std::fmt::Write;

const W: f64 = 760.0;
const H: f64 = 240.0;
const PAD: f64 = 46.0;
const COLORS: [&str; 4] = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd"];

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

fn range(vals: impl Iterator<Item = f64>) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in vals.filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    if hi - lo < 1e-12 {
        return (lo - 1.0, hi + 1.0);
    }
    let m = 0.05 * (hi - lo);
    (lo - m, hi + m)
}

fn axes(out: &mut String, title: &str, xl: &str, yl: &str, xr: (f64, f64), yr: (f64, f64)) {
    axes_opt(out, title, xl, yl, xr, yr, true)
}

fn axes_opt(
    out: &mut String,
    title: &str,
    xl: &str,
    yl: &str,
    xr: (f64, f64),
    yr: (f64, f64),
    x_ticks: bool,
) {
    let _ = write!(
        out,
        r##"<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{H}" viewBox="0 0 {W} {H}" style="background:#fff;border:1px solid #ccc;margin:4px">"##
    );
    let _ = write!(
        out,
        r##"<text x="{}" y="14" font-size="13" text-anchor="middle" font-family="sans-serif">{}</text>"##,
        W / 2.0,
        esc(title)
    );
    let (x0, x1, y0, y1) = (PAD, W - 10.0, H - 30.0, 22.0);
    let _ = write!(
        out,
        r##"<rect x="{x0}" y="{y1}" width="{}" height="{}" fill="none" stroke="#888"/>"##,
        x1 - x0,
        y0 - y1
    );
    for k in 0..=4 {
        let fx = k as f64 / 4.0;
        let xv = xr.0 + fx * (xr.1 - xr.0);
        let yv = yr.0 + fx * (yr.1 - yr.0);
        let px = x0 + fx * (x1 - x0);
        let py = y0 - fx * (y0 - y1);
        if x_ticks {
            let _ = write!(
                out,
                r##"<text x="{px}" y="{}" font-size="10" text-anchor="middle" font-family="sans-serif">{}</text>"##,
                y0 + 12.0,
                num(xv)
            );
        }
        let _ = write!(
            out,
            r##"<text x="{}" y="{}" font-size="10" text-anchor="end" font-family="sans-serif">{}</text>"##,
            x0 - 3.0,
            py + 3.0,
            num(yv)
        );
        let _ = write!(
            out,
            r##"<line x1="{x0}" y1="{py}" x2="{x1}" y2="{py}" stroke="#eee"/>"##
        );
    }
    let _ = write!(
        out,
        r##"<text x="{}" y="{}" font-size="11" text-anchor="middle" font-family="sans-serif">{}</text>"##,
        (x0 + x1) / 2.0,
        H - 4.0,
        esc(xl)
    );
    let _ = write!(
        out,
        r##"<text x="12" y="{}" font-size="11" text-anchor="middle" font-family="sans-serif" transform="rotate(-90 12 {})">{}</text>"##,
        (y0 + y1) / 2.0,
        (y0 + y1) / 2.0,
        esc(yl)
    );
}

fn num(v: f64) -> String {
    if v == 0.0 {
        "0".into()
    } else if v.abs() >= 1000.0 || v.abs() < 0.01 {
        format!("{v:.2e}")
    } else {
        format!("{v:.3}")
    }
}

fn map(v: f64, r: (f64, f64), a: f64, b: f64) -> f64 {
    a + (v - r.0) / (r.1 - r.0) * (b - a)
}

/// Line plot; series = (label, x, y). Long series are thinned to ≤ 1500 points.
pub fn line_plot(title: &str, xl: &str, yl: &str, series: &[(&str, &[f64], &[f64])]) -> String {
    let mut out = String::new();
    let xr = range(series.iter().flat_map(|s| s.1.iter().copied()));
    let yr = range(series.iter().flat_map(|s| s.2.iter().copied()));
    axes(&mut out, title, xl, yl, xr, yr);
    for (k, (label, x, y)) in series.iter().enumerate() {
        let stride = (x.len() / 1500).max(1);
        let mut d = String::new();
        for (i, (xv, yv)) in x.iter().zip(y.iter()).enumerate().step_by(stride) {
            if !(xv.is_finite() && yv.is_finite()) {
                continue;
            }
            let _ = write!(
                d,
                "{}{:.1},{:.1}",
                if i == 0 { "M" } else { " L" },
                map(*xv, xr, PAD, W - 10.0),
                map(*yv, yr, H - 30.0, 22.0)
            );
        }
        let c = COLORS[k % COLORS.len()];
        let _ = write!(
            out,
            r##"<path d="{d}" fill="none" stroke="{c}" stroke-width="1.2"/>"##
        );
        let _ = write!(
            out,
            r##"<text x="{}" y="{}" font-size="11" fill="{c}" font-family="sans-serif">{}</text>"##,
            PAD + 8.0,
            36.0 + 13.0 * k as f64,
            esc(label)
        );
    }
    out.push_str("</svg>");
    out
}

/// Scatter plot of ≤ 2000 points.
pub fn scatter(title: &str, xl: &str, yl: &str, x: &[f64], y: &[f64]) -> String {
    let mut out = String::new();
    let xr = range(x.iter().copied());
    let yr = range(y.iter().copied());
    axes(&mut out, title, xl, yl, xr, yr);
    let stride = (x.len() / 2000).max(1);
    for (xv, yv) in x.iter().zip(y).step_by(stride) {
        if xv.is_finite() && yv.is_finite() {
            let _ = write!(
                out,
                r##"<circle cx="{:.1}" cy="{:.1}" r="1.4" fill="{}" fill-opacity="0.5"/>"##,
                map(*xv, xr, PAD, W - 10.0),
                map(*yv, yr, H - 30.0, 22.0),
                COLORS[0]
            );
        }
    }
    out.push_str("</svg>");
    out
}

/// Grouped bars: labels on x, one bar per series.
pub fn bars(title: &str, yl: &str, labels: &[String], series: &[(&str, Vec<f64>)]) -> String {
    let mut out = String::new();
    let yr = (
        0.0,
        range(series.iter().flat_map(|s| s.1.iter().copied()).chain([0.0])).1,
    );
    axes_opt(
        &mut out,
        title,
        "",
        yl,
        (0.0, labels.len() as f64),
        yr,
        false,
    );
    let slot = (W - 10.0 - PAD) / labels.len().max(1) as f64;
    let bw = slot * 0.8 / series.len().max(1) as f64;
    for (i, l) in labels.iter().enumerate() {
        for (k, (_, v)) in series.iter().enumerate() {
            let val = v.get(i).copied().unwrap_or(0.0);
            if !val.is_finite() {
                continue;
            }
            let x = PAD + i as f64 * slot + 0.1 * slot + k as f64 * bw;
            let y = map(val, yr, H - 30.0, 22.0);
            let _ = write!(
                out,
                r##"<rect x="{x:.1}" y="{y:.1}" width="{bw:.1}" height="{:.1}" fill="{}"/>"##,
                (H - 30.0 - y).max(0.0),
                COLORS[k % COLORS.len()]
            );
        }
        let _ = write!(
            out,
            r##"<text x="{:.1}" y="{}" font-size="9" text-anchor="middle" font-family="sans-serif">{}</text>"##,
            PAD + (i as f64 + 0.5) * slot,
            H - 18.0,
            esc(l)
        );
    }
    for (k, (label, _)) in series.iter().enumerate() {
        let c = COLORS[k % COLORS.len()];
        let _ = write!(
            out,
            r##"<text x="{}" y="{}" font-size="11" fill="{c}" text-anchor="end" font-family="sans-serif">{}</text>"##,
            W - 16.0,
            36.0 + 13.0 * k as f64,
            esc(label)
        );
    }
    out.push_str("</svg>");
    out
}

/// An HTML page being assembled.
pub struct Page {
    body: String,
}

impl Page {
    pub fn new(title: &str) -> Self {
        let mut body = String::new();
        let _ = write!(body, "<h1>{}</h1>", esc(title));
        Page { body }
    }
    pub fn h2(&mut self, s: &str) {
        let _ = write!(self.body, "<h2>{}</h2>", esc(s));
    }
    pub fn p(&mut self, s: &str) {
        let _ = write!(self.body, "<p>{}</p>", esc(s));
    }
    pub fn raw(&mut self, s: &str) {
        self.body.push_str(s);
    }
    pub fn table(&mut self, head: &[&str], rows: &[Vec<String>]) {
        self.body.push_str("<table><tr>");
        for h in head {
            let _ = write!(self.body, "<th>{}</th>", esc(h));
        }
        self.body.push_str("</tr>");
        for r in rows {
            self.body.push_str("<tr>");
            for c in r {
                let _ = write!(self.body, "<td>{}</td>", esc(c));
            }
            self.body.push_str("</tr>");
        }
        self.body.push_str("</table>");
    }
    pub fn finish(self) -> String {
        format!(
            "<!DOCTYPE html><html><head><meta charset=\"utf-8\"><title>pamctl model report</title><style>body{{font-family:sans-serif;margin:20px;background:#fafafa;color:#222}}table{{border-collapse:collapse;margin:8px 0}}td,th{{border:1px solid #bbb;padding:3px 8px;font-size:13px}}th{{background:#e8eef5}}h2{{margin-top:28px}}</style></head><body>{}</body></html>",
            self.body
        )
    }
}

/// Measured vs predicted on the held-out part, per axis, for several fits.
pub fn measured_vs_predicted(page: &mut Page, t: &[f64], split: usize, fits: &[(&str, &ModelFit)]) {
    for axis in 0..2 {
        let name = ["fx", "fy"][axis];
        let Some((_, first)) = fits.first() else {
            return;
        };
        let mut series: Vec<(&str, &[f64], &[f64])> =
            vec![("measured", &t[split..], &first.measured[axis][split..])];
        let labels: Vec<String> = fits
            .iter()
            .map(|(l, f)| format!("{l} (NRMSE {:.3})", f.nrmse[axis]))
            .collect();
        for ((_, f), l) in fits.iter().zip(&labels) {
            series.push((l.as_str(), &t[split..], &f.predicted[axis][split..]));
        }
        page.raw(&line_plot(
            &format!("{name}: measured and predicted on the held-out 20 %"),
            "t [s]",
            "force [N]",
            &series,
        ));
    }
}

pub fn residual_spectrum(page: &mut Page, fit: &ModelFit, dt_s: f64, label: &str) {
    let mut series_store = Vec::new();
    for axis in 0..2 {
        let r = fit.residual(axis);
        let s = amplitude_spectrum(&r, dt_s);
        series_store.push(s);
    }
    let series: Vec<(&str, &[f64], &[f64])> = vec![
        (
            "fx residual",
            &series_store[0].freq_hz[1..],
            &series_store[0].amplitude[1..],
        ),
        (
            "fy residual",
            &series_store[1].freq_hz[1..],
            &series_store[1].amplitude[1..],
        ),
    ];
    page.raw(&line_plot(
        &format!("residual amplitude spectrum, {label}"),
        "f [Hz]",
        "amplitude [N]",
        &series,
    ));
}

/// The full diagnose page.
pub fn diagnosis_page(
    d: &Diagnosis,
    fits: &[ModelFit],
    t: &[f64],
    split: usize,
    dt_s: f64,
) -> String {
    let mut page = Page::new(&format!("Model diagnosis — {} experiment", d.experiment));
    page.p(&format!(
        "Verdict: {}. {} samples every {:.4} s; fitted on the first 80 %, scored on the last 20 % (NRMSE = RMS(residual)/std(measured)).",
        d.verdict, d.samples, d.sample_period_s
    ));
    page.h2("Effects tested (best first)");
    let rows: Vec<Vec<String>> = d
        .effects
        .iter()
        .map(|e| {
            vec![
                e.id.clone(),
                format!("{:.4}", e.nrmse.fx),
                format!("{:.4}", e.nrmse.fy),
                format!("{:.1} %", 100.0 * e.improvement),
                e.added_params.to_string(),
                format!("{:.3}", e.score),
                if e.accepted {
                    "yes".into()
                } else {
                    "no".into()
                },
                e.params
                    .iter()
                    .map(|(k, v)| format!("{k} = {}", num(*v)))
                    .collect::<Vec<_>>()
                    .join(", "),
            ]
        })
        .collect();
    page.p(&format!(
        "Base model: NRMSE fx {:.4}, fy {:.4}; R² fx {:.3}, fy {:.3}.",
        d.base.nrmse.fx, d.base.nrmse.fy, d.base.r2.fx, d.base.r2.fy
    ));
    page.table(
        &[
            "effect",
            "NRMSE fx",
            "NRMSE fy",
            "held-out error removed",
            "params",
            "score",
            "accepted",
            "fitted",
        ],
        &rows,
    );
    for e in d.effects.iter().filter(|e| e.accepted) {
        page.p(&format!("{}: {}", e.id, e.evidence));
    }
    if !d.unexplained.is_empty() {
        page.h2("Unexplained structure");
        for u in &d.unexplained {
            page.p(&format!("{} in {}: {}", u.kind, u.signal, u.detail));
        }
    }
    page.h2("The error falling as effects are added");
    let labels: Vec<String> = d
        .steps
        .iter()
        .map(|s| {
            if s.effects.is_empty() {
                "base".to_string()
            } else {
                format!("+ {}", s.effects.last().cloned().unwrap_or_default())
            }
        })
        .collect();
    page.raw(&bars(
        "held-out NRMSE per step",
        "NRMSE",
        &labels,
        &[
            ("fx", d.steps.iter().map(|s| s.nrmse.fx).collect()),
            ("fy", d.steps.iter().map(|s| s.nrmse.fy).collect()),
        ],
    ));
    page.h2("Measured vs. predicted, before and after");
    if let (Some(base), Some(last)) = (fits.first(), fits.last()) {
        let mut list: Vec<(&str, &ModelFit)> = vec![("base model", base)];
        if fits.len() > 1 {
            list.push(("with the accepted effects", last));
        }
        measured_vs_predicted(&mut page, t, split, &list);
        if fits.len() > 1 {
            page.h2("Base residual against the signature of the first effect");
            let second = &fits[1];
            for axis in 0..2 {
                // the effect's own contribution (what it predicts beyond the base) against
                // the base residual: points on the diagonal are what it explains
                let contrib: Vec<f64> = (0..t.len())
                    .map(|i| second.predicted[axis][i] - base.predicted[axis][i])
                    .collect();
                let res = base.residual(axis);
                page.raw(&scatter(
                    &format!(
                        "{}: base residual vs. the {} term",
                        ["fx", "fy"][axis],
                        second.effect_ids.last().cloned().unwrap_or_default()
                    ),
                    "effect term [N]",
                    "base residual [N]",
                    &contrib,
                    &res,
                ));
            }
            let res0 = base.residual(0);
            let res1 = base.residual(1);
            page.raw(&line_plot(
                "base residual over time",
                "t [s]",
                "residual [N]",
                &[("fx", t, &res0), ("fy", t, &res1)],
            ));
        }
        page.h2("Residual spectrum");
        residual_spectrum(&mut page, last, dt_s, "final model");
    }
    if !d.warnings.is_empty() {
        page.h2("Warnings");
        for w in &d.warnings {
            page.p(w);
        }
    }
    page.finish()
}

/// The compare page.
pub fn comparison_page(
    c: &Comparison,
    fit: &ModelFit,
    t: &[f64],
    split: usize,
    dt_s: f64,
) -> String {
    let mut page = Page::new(&format!(
        "Model vs. measurement — {} experiment",
        c.experiment
    ));
    page.p(&format!(
        "Model: base{}. Held-out NRMSE fx {:.4}, fy {:.4}; R² fx {:.3}, fy {:.3}.",
        c.effects
            .iter()
            .map(|e| format!(" + {e}"))
            .collect::<String>(),
        c.nrmse.fx,
        c.nrmse.fy,
        c.r2.fx,
        c.r2.fy
    ));
    measured_vs_predicted(&mut page, t, split, &[("model", fit)]);
    page.h2("Error over time (worst 1-s windows of the held-out part)");
    let rows: Vec<Vec<String>> = c
        .worst_windows
        .iter()
        .map(|w| {
            vec![
                format!("{:.2}–{:.2} s", w.t_start_s, w.t_end_s),
                format!("{:.3}", w.rms_n.fx),
                format!("{:.3}", w.rms_n.fy),
            ]
        })
        .collect();
    page.table(&["window", "RMS fx [N]", "RMS fy [N]"], &rows);
    let r0 = fit.residual(0);
    let r1 = fit.residual(1);
    page.raw(&line_plot(
        "residual over time",
        "t [s]",
        "residual [N]",
        &[("fx", t, &r0), ("fy", t, &r1)],
    ));
    if let Some(s) = &c.frequency_split {
        page.h2("Low / high motion frequency (Table 4.2)");
        page.table(
            &["axis", "MSE low", "MSE high", "MSE all"],
            &[0, 1].map(|a| {
                vec![
                    ["X", "Y"][a].to_string(),
                    format!("{:.3}", s.mse_low[a]),
                    format!("{:.3}", s.mse_high[a]),
                    format!("{:.3}", s.mse_all[a]),
                ]
            }),
        );
    }
    residual_spectrum(&mut page, fit, dt_s, "model");
    page.h2("Error over speed and over the workspace");
    let labels: Vec<String> = c.error_by_speed.iter().map(|b| b.label.clone()).collect();
    page.raw(&bars(
        "residual RMS by speed quartile",
        "RMS [N]",
        &labels,
        &[
            ("fx", c.error_by_speed.iter().map(|b| b.rms_n.fx).collect()),
            ("fy", c.error_by_speed.iter().map(|b| b.rms_n.fy).collect()),
        ],
    ));
    let labels: Vec<String> = c
        .error_by_position
        .iter()
        .map(|b| {
            b.label
                .replace(" (of 3×3)", "")
                .replace("x cell ", "x")
                .replace(", y cell ", "/y")
        })
        .collect();
    page.raw(&bars(
        "residual RMS by workspace cell",
        "RMS [N]",
        &labels,
        &[
            (
                "fx",
                c.error_by_position.iter().map(|b| b.rms_n.fx).collect(),
            ),
            (
                "fy",
                c.error_by_position.iter().map(|b| b.rms_n.fy).collect(),
            ),
        ],
    ));
    if !c.warnings.is_empty() {
        page.h2("Plausibility warnings");
        for w in &c.warnings {
            page.p(w);
        }
    }
    page.finish()
}

/// The fit page: before and after.
pub fn fit_page(before: &ModelFit, after: &ModelFit, t: &[f64], split: usize, dt_s: f64) -> String {
    let mut page = Page::new("Model fit with effects");
    page.p(&format!(
        "Effects: {}. Held-out NRMSE before fx {:.4}, fy {:.4}; after fx {:.4}, fy {:.4}.",
        after.effect_ids.join(", "),
        before.nrmse[0],
        before.nrmse[1],
        after.nrmse[0],
        after.nrmse[1]
    ));
    let mut rows = Vec::new();
    for (id, m) in &after.params {
        for (k, v) in m {
            rows.push(vec![id.clone(), k.clone(), num(*v)]);
        }
    }
    page.table(&["effect", "parameter", "value"], &rows);
    page.raw(&bars(
        "held-out NRMSE",
        "NRMSE",
        &["before".into(), "after".into()],
        &[
            ("fx", vec![before.nrmse[0], after.nrmse[0]]),
            ("fy", vec![before.nrmse[1], after.nrmse[1]]),
        ],
    ));
    measured_vs_predicted(&mut page, t, split, &[("before", before), ("after", after)]);
    for axis in 0..2 {
        let contrib: Vec<f64> = (0..t.len())
            .map(|i| after.predicted[axis][i] - before.predicted[axis][i])
            .collect();
        let res = before.residual(axis);
        page.raw(&scatter(
            &format!(
                "{}: residual before vs. the effects' term",
                ["fx", "fy"][axis]
            ),
            "effect term [N]",
            "residual before [N]",
            &contrib,
            &res,
        ));
    }
    residual_spectrum(&mut page, after, dt_s, "after");
    page.finish()
}
