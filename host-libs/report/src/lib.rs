//! Self-contained HTML reports of the model loop: where the model fails — over time
//! (zoomable plotly.js plots; the library is embedded in the page, nothing is loaded), over
//! the workspace, over velocity, over frequency and per step — before and after the added
//! effects, with the ranked effects and the error falling step by step.
//!
//! Files: `lib.rs` the pages, `sections.rs` the views, `plots.rs` the zoomable time series
//! and decimation, `charts.rs` bars, heat maps and scatter, `bins.rs` the binning. Every
//! plot is plotly's.

// `!(x > y)` is deliberate: it is true for NaN, so a NaN never passes a check.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
// Per-axis loops index several parallel arrays at once.
#![allow(clippy::needless_range_loop)]

pub mod bins;
pub mod charts;
pub mod plots;
pub mod sections;

use pam_ident::trial::Prepared;
use pam_model_loop::diagnose::{Comparison, Diagnosis, ModelFit};
use plots::{AFTER, BEFORE};
use sections::{shown, where_it_fails};
use std::fmt::Write;

/// Text as HTML.
pub fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// A value in a table: 3–4 significant digits.
pub fn num(v: f64) -> String {
    if v == 0.0 {
        "0".into()
    } else if !v.is_finite() {
        format!("{v}")
    } else if v.abs() >= 1e4 || v.abs() < 1e-3 {
        format!("{v:.3e}")
    } else {
        let d = (3 - v.abs().log10().floor() as i32).clamp(0, 6) as usize;
        format!("{v:.d$}")
    }
}

/// An HTML page being assembled.
pub struct Page {
    body: String,
    plots: usize,
}

const STYLE: &str = "body{font-family:sans-serif;margin:16px 24px;background:#fafafa;color:#222;line-height:1.35}\
table{border-collapse:collapse;margin:8px 0}td,th{border:1px solid #bbb;padding:3px 8px;font-size:13px;vertical-align:top}\
th{background:#e8eef5}td:first-child{white-space:nowrap}td.num{text-align:right;font-variant-numeric:tabular-nums}tr.yes td{background:#eaf6ea}\
h2{margin-top:30px;border-bottom:1px solid #ccc}h3{margin-top:20px}\
.zoomable{width:100%;margin:8px 0;border:1px solid #ddd;background:#fff}p.note{color:#555;font-size:13px}\
ul.evidence li{margin:4px 0;font-size:14px}p.warn{background:#fff4d6;border-left:4px solid #e0a000;padding:6px 10px}";

impl Page {
    pub fn new(title: &str) -> Self {
        Page {
            body: format!("<h1>{}</h1>", esc(title)),
            plots: 0,
        }
    }
    pub fn h2(&mut self, s: &str) {
        let _ = write!(self.body, "<h2>{}</h2>", esc(s));
    }
    pub fn p(&mut self, s: &str) {
        let _ = write!(self.body, "<p>{}</p>", esc(s));
    }
    pub fn note(&mut self, s: &str) {
        let _ = write!(self.body, "<p class=\"note\">{}</p>", esc(s));
    }
    pub fn raw(&mut self, s: &str) {
        self.body.push_str(s);
    }
    /// A plotly plot (the library is added to the page once, by [`Page::finish`]).
    pub fn plotly(&mut self, s: &str) {
        self.body.push_str(s);
    }
    /// A fresh element id for a plot.
    pub fn next_id(&mut self) -> String {
        self.plots += 1;
        format!("plot{}", self.plots)
    }
    /// A table; cells that parse as numbers are right-aligned; a row whose first cell
    /// starts with '✓' is highlighted.
    pub fn table(&mut self, head: &[&str], rows: &[Vec<String>]) {
        self.body.push_str("<table><tr>");
        for h in head {
            let _ = write!(self.body, "<th>{}</th>", esc(h));
        }
        self.body.push_str("</tr>");
        for r in rows {
            let hl = r.first().is_some_and(|c| c.starts_with('✓'));
            self.body
                .push_str(if hl { "<tr class=\"yes\">" } else { "<tr>" });
            for c in r {
                let numeric = c
                    .trim_end_matches(" %")
                    .replace('−', "-")
                    .parse::<f64>()
                    .is_ok();
                let cls = if numeric { " class=\"num\"" } else { "" };
                let _ = write!(self.body, "<td{cls}>{}</td>", esc(c));
            }
            self.body.push_str("</tr>");
        }
        self.body.push_str("</table>");
    }
    pub fn finish(self) -> String {
        let js = if self.plots > 0 {
            plots::plotly_js()
        } else {
            String::new()
        };
        format!(
            "<!DOCTYPE html><html><head><meta charset=\"utf-8\"><meta name=\"viewport\" content=\"width=device-width\"><title>pamctl model report</title><style>{STYLE}</style>{js}</head><body>{}</body></html>",
            self.body
        )
    }
}

fn pct(v: f64) -> String {
    format!("{:.1} %", 100.0 * v)
}

fn nrmse_bars(
    page: &mut Page,
    title: &str,
    labels: &[String],
    fx: Vec<f64>,
    fy: Vec<f64>,
) -> String {
    charts::bars(
        &page.next_id(),
        title,
        "held-out NRMSE",
        labels,
        &[("fx", BEFORE, fx), ("fy", AFTER, fy)],
    )
}

fn step_label(effects: &[String]) -> String {
    if effects.is_empty() {
        "base".into()
    } else {
        format!("base + {}", effects.join(" + "))
    }
}

/// Fields of an effect's report that only some versions of the diagnosis have: a column
/// each when any effect carries it.
const OPTIONAL: [(&str, &str); 3] = [
    ("family", "family"),
    ("shape", "shape"),
    ("ambiguous", "ambiguous with"),
];

fn optional_field(e: &serde_json::Value, key: &str) -> String {
    match e.get(key) {
        Some(serde_json::Value::String(s)) => s.clone(),
        Some(serde_json::Value::Bool(b)) => if *b { "yes" } else { "" }.into(),
        Some(serde_json::Value::Array(a)) => a
            .iter()
            .map(|v| v.as_str().map_or_else(|| v.to_string(), str::to_string))
            .collect::<Vec<_>>()
            .join(", "),
        Some(serde_json::Value::Null) | None => String::new(),
        Some(v) => v.to_string(),
    }
}

/// The diagnose page: ranked effects, the error falling step by step, and where the base
/// model and the model with the accepted effects fail.
pub fn diagnosis_page(d: &Diagnosis, fits: &[ModelFit], p: &Prepared) -> String {
    let mut page = Page::new(&format!("Model diagnosis — {} experiment", d.experiment));
    summary(&mut page, d, p);
    page.h2("Effects tested (best first)");
    effects_table(&mut page, d);
    evidence(&mut page, d);
    if !d.unexplained.is_empty() {
        page.h2("Unexplained structure");
        for u in &d.unexplained {
            page.p(&format!("{} in {}: {}", u.kind, u.signal, u.detail));
        }
    }
    page.h2("The error falling as effects are added");
    error_falling(&mut page, d, fits);
    where_models_fail(&mut page, fits, p);
    if !d.warnings.is_empty() {
        page.h2("Warnings");
        for w in &d.warnings {
            page.p(&w.to_string());
        }
    }
    page.finish()
}

/// The verdict, the log, the base model and whether the log can tell the effects apart.
fn summary(page: &mut Page, d: &Diagnosis, p: &Prepared) {
    page.p(&format!(
        "Verdict: {}. {} samples every {:.4} s; {} (NRMSE = RMS(residual)/std(measured)).",
        d.verdict,
        d.samples,
        d.sample_period_s,
        p.held_out.describe()
    ));
    page.p(&format!(
        "Base model: NRMSE fx {:.4}, fy {:.4}; R² fx {:.3}, fy {:.3}.",
        d.base.nrmse.fx, d.base.nrmse.fy, d.base.r2.fx, d.base.r2.fy
    ));
    // fields of newer diagnoses, read through serde so the page builds with either
    let dj = serde_json::to_value(d).unwrap_or_default();
    let ambiguous = optional_field(&dj, "ambiguous");
    if !ambiguous.is_empty() {
        let mut text = format!(
            "Ambiguous: this log cannot tell {} apart.",
            ambiguous.replace(", ", " and ")
        );
        let why = optional_field(&dj, "ambiguity_evidence");
        if !why.is_empty() {
            let _ = write!(text, " {why}.");
        }
        let sep = optional_field(&dj, "separating_experiment");
        if !sep.is_empty() {
            let _ = write!(text, " To separate them: {sep}");
        }
        let _ = write!(page.body, "<p class=\"warn\">{}</p>", esc(&text));
    }
}

/// Every effect tested, best first, with the optional columns any of them carries.
fn effects_table(page: &mut Page, d: &Diagnosis) {
    let json: Vec<serde_json::Value> = d
        .effects
        .iter()
        .map(|e| serde_json::to_value(e).unwrap_or_default())
        .collect();
    let extras: Vec<Vec<String>> = json
        .iter()
        .map(|e| OPTIONAL.iter().map(|(k, _)| optional_field(e, k)).collect())
        .collect();
    let shown_extra: Vec<usize> = (0..OPTIONAL.len())
        .filter(|&i| extras.iter().any(|x| !x[i].is_empty()))
        .collect();
    let rows: Vec<Vec<String>> = d
        .effects
        .iter()
        .zip(&extras)
        .map(|(e, extra)| {
            let mut r = vec![
                format!("{}{}", if e.accepted { "✓ " } else { "" }, e.id),
                format!("{:.4}", e.nrmse.fx),
                format!("{:.4}", e.nrmse.fy),
                pct(e.improvement),
                e.added_params.to_string(),
                format!("{:.3}", e.score),
                pct(e.effect_size),
                if e.accepted { "yes" } else { "no" }.into(),
            ];
            r.extend(shown_extra.iter().map(|&i| extra[i].clone()));
            r.push(
                e.params
                    .iter()
                    .map(|(k, v)| format!("{k} = {}", num(*v)))
                    .collect::<Vec<_>>()
                    .join(", "),
            );
            r
        })
        .collect();
    let mut head = vec![
        "effect",
        "NRMSE fx",
        "NRMSE fy",
        "held-out error removed",
        "params",
        "score",
        "prediction change",
        "accepted",
    ];
    head.extend(shown_extra.iter().map(|&i| OPTIONAL[i].1));
    head.push("fitted");
    page.table(&head, &rows);
}

/// The evidence of each accepted effect.
fn evidence(page: &mut Page, d: &Diagnosis) {
    let accepted: Vec<_> = d.effects.iter().filter(|e| e.accepted).collect();
    if accepted.is_empty() {
        return;
    }
    page.raw("<h3>Evidence</h3><ul class=\"evidence\">");
    for e in accepted {
        let _ = write!(
            page.body,
            "<li><b>{}</b>: {}</li>",
            esc(&e.id),
            esc(&e.evidence)
        );
    }
    page.raw("</ul>");
}

/// The held-out NRMSE of each step of the final model; an axis whose reference never
/// changes (step trials) is not scored and has no bar.
fn error_falling(page: &mut Page, d: &Diagnosis, fits: &[ModelFit]) {
    let labels: Vec<String> = d
        .steps
        .iter()
        .map(|s| match s.effects.last() {
            None => "base".to_string(),
            Some(e) => format!("+ {e}"),
        })
        .collect();
    let scored = |a: usize| fits.first().is_none_or(|f| f.axes.contains(&a));
    let col = |a: usize, v: f64| if scored(a) { v } else { f64::NAN };
    let bars = nrmse_bars(
        page,
        "held-out NRMSE per step",
        &labels,
        d.steps.iter().map(|s| col(0, s.nrmse.fx)).collect(),
        d.steps.iter().map(|s| col(1, s.nrmse.fy)).collect(),
    );
    page.plotly(&bars);
    for a in (0..2).filter(|&a| !scored(a)) {
        page.note(&format!(
            "{} is not scored: its reference does not change in this trial.",
            ["fx", "fy"][a]
        ));
    }
}

/// Where the base model and the final model fail, and the base residual against the term
/// of the first effect.
fn where_models_fail(page: &mut Page, fits: &[ModelFit], p: &Prepared) {
    let (Some(base), Some(last)) = (fits.first(), fits.last()) else {
        return;
    };
    let mut list = vec![("base model".to_string(), base)];
    if fits.len() > 1 {
        list.push((step_label(&last.effect_ids), last));
        page.h2(&format!(
            "Where the model fails: the base model (blue) and {} (red)",
            step_label(&last.effect_ids)
        ));
    } else {
        page.h2("Where the base model fails (no effect was accepted)");
    }
    where_it_fails(page, p, &shown(&list));
    if fits.len() > 1 {
        page.h2("Base residual against the term of the first effect");
        let second = &fits[1];
        sections::term_scatter(
            page,
            base,
            second,
            &second.effect_ids.last().cloned().unwrap_or_default(),
        );
    }
}

/// The compare page: one model against the measurement.
pub fn comparison_page(c: &Comparison, fit: &ModelFit, p: &Prepared) -> String {
    let mut page = Page::new(&format!(
        "Model vs. measurement — {} experiment",
        c.experiment
    ));
    let label = step_label(&c.effects);
    page.p(&format!(
        "Model: {label}. Held-out NRMSE fx {:.4}, fy {:.4}; R² fx {:.3}, fy {:.3}.",
        c.nrmse.fx, c.nrmse.fy, c.r2.fx, c.r2.fy
    ));
    if !c.params.is_empty() {
        let mut rows = Vec::new();
        for (id, m) in &c.params {
            for (k, v) in m {
                rows.push(vec![id.clone(), k.clone(), num(*v)]);
            }
        }
        page.table(&["part", "parameter", "value"], &rows);
    }
    if !c.warnings.is_empty() {
        page.h2("Plausibility warnings");
        for w in &c.warnings {
            page.p(&w.to_string());
        }
    }
    page.h2(&format!("Where the model ({label}) fails"));
    where_it_fails(&mut page, p, &shown(&[(label.clone(), fit)]));
    page.h2("Worst 1-s windows of the held-out part");
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
    if let Some(s) = &c.frequency_split {
        page.h2("Low / high motion frequency (Table 4.2)");
        page.table(
            &["axis", "MSE low [N²]", "MSE high [N²]", "MSE all [N²]"],
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
    for pk in &c.residual_peaks {
        page.p(&format!("Residual line: {}", pk.detail));
    }
    page.h2("Held-out error by speed quartile and by workspace cell");
    let rms_bars = |page: &mut Page,
                    title: &str,
                    labels: Vec<String>,
                    bins: &[pam_model_loop::diagnose::Bin]| {
        let bars = charts::bars(
            &page.next_id(),
            title,
            "RMS residual [N]",
            &labels,
            &[
                ("fx", BEFORE, bins.iter().map(|b| b.rms_n.fx).collect()),
                ("fy", AFTER, bins.iter().map(|b| b.rms_n.fy).collect()),
            ],
        );
        page.plotly(&bars);
    };
    let labels = c.error_by_speed.iter().map(|b| b.label.clone()).collect();
    rms_bars(
        &mut page,
        "residual RMS by speed quartile",
        labels,
        &c.error_by_speed,
    );
    let labels = c
        .error_by_position
        .iter()
        .map(|b| {
            b.label
                .replace(" (of 3×3)", "")
                .replace("x cell ", "x")
                .replace(", y cell ", "/y")
        })
        .collect();
    rms_bars(
        &mut page,
        "residual RMS by workspace cell (3×3)",
        labels,
        &c.error_by_position,
    );
    page.finish()
}

/// The fit page: parameters, and the model before and after the effects.
pub fn fit_page(before: &ModelFit, after: &ModelFit, p: &Prepared) -> String {
    let mut page = Page::new("Model fit with effects");
    let label = step_label(&after.effect_ids);
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
    let bars = nrmse_bars(
        &mut page,
        "held-out NRMSE before and after",
        &["before (base)".into(), format!("after ({label})")],
        vec![before.nrmse[0], after.nrmse[0]],
        vec![before.nrmse[1], after.nrmse[1]],
    );
    page.plotly(&bars);
    page.h2(&format!(
        "Where the model fails: before (blue) and after (red, {label})"
    ));
    where_it_fails(
        &mut page,
        p,
        &shown(&[
            ("before (base)".into(), before),
            (format!("after ({label})"), after),
        ]),
    );
    page.h2("Residual before against the effects' term");
    sections::term_scatter(&mut page, before, after, "effects'");
    page.finish()
}

#[cfg(test)]
mod tests {
    use super::{esc, num};

    #[test]
    fn numbers_in_tables() {
        assert_eq!(num(0.0), "0");
        assert_eq!(num(1.98765), "1.988");
        assert_eq!(num(0.0123456), "0.01235");
        assert_eq!(num(123.456), "123.5");
        assert_eq!(num(0.0001234), "1.234e-4");
        assert_eq!(esc("a<b & \"c\""), "a&lt;b &amp; &quot;c&quot;");
    }
}
