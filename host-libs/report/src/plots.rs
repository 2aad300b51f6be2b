//! Zoomable plots drawn by plotly.js (the `plotly` crate with `plotly_embed_js`: the page
//! carries the library itself, nothing is loaded), and the decimation that keeps long
//! series small.

use plotly::common::{DashType, Line, Mode, Title};
use plotly::layout::{
    Axis, AxisType, HoverMode, Legend, Margin, Shape, ShapeLayer, ShapeLine, ShapeType,
};
use plotly::{Configuration, Layout, Plot, Scatter};

/// The measured signal's colour.
pub const MEASURED: &str = "#333333";
/// The first model's colour ("before").
pub const BEFORE: &str = "#1f77b4";
/// The last model's colour ("after").
pub const AFTER: &str = "#d62728";
/// The colours of the models compared, in order.
pub const COLORS: [&str; 4] = [BEFORE, AFTER, "#2ca02c", "#9467bd"];

/// The `<script>` holding plotly.js, once per page. The crate's offline bundle also carries
/// MathJax (2 MB), which these plots do not use; only the plotly.js script is kept.
pub fn plotly_js() -> String {
    let all = Plot::offline_js_sources();
    let scripts: Vec<&str> = all
        .split_inclusive("</script>")
        .filter(|s| s.contains("<script"))
        .collect();
    scripts
        .iter()
        .find(|s| s.contains("plotly.js"))
        .map(|s| s.trim().to_string())
        .unwrap_or_else(|| all.clone())
}

/// Min/max decimation: the samples are cut into `buckets` runs of consecutive samples and
/// each run keeps its smallest and largest value, in time order. A plot at about one bucket
/// per pixel looks the same as the full series (every peak is kept). Non-finite samples
/// are dropped. Series no longer than 2 × `buckets` are returned as they are.
pub fn min_max(x: &[f64], y: &[f64], buckets: usize) -> (Vec<f64>, Vec<f64>) {
    let n = x.len().min(y.len());
    let finite = |i: &usize| x[*i].is_finite() && y[*i].is_finite();
    if n <= 2 * buckets.max(1) {
        return (0..n).filter(finite).map(|i| (x[i], y[i])).unzip();
    }
    let mut out = (
        Vec::with_capacity(2 * buckets),
        Vec::with_capacity(2 * buckets),
    );
    for b in 0..buckets {
        let (s, e) = (b * n / buckets, (b + 1) * n / buckets);
        let mut lo: Option<usize> = None;
        let mut hi: Option<usize> = None;
        for i in (s..e).filter(finite) {
            if lo.is_none_or(|l| y[i] < y[l]) {
                lo = Some(i);
            }
            if hi.is_none_or(|h| y[i] > y[h]) {
                hi = Some(i);
            }
        }
        let (Some(lo), Some(hi)) = (lo, hi) else {
            continue;
        };
        for i in [lo.min(hi), lo.max(hi)] {
            if out.0.last() != Some(&x[i]) {
                out.0.push(x[i]);
                out.1.push(y[i]);
            }
        }
    }
    out
}

/// Spectra: the largest amplitude in each of `buckets` logarithmically spaced frequency
/// bands (a line stays visible at any zoom); bins at f ≤ 0 are dropped.
pub fn max_per_log_bucket(f: &[f64], a: &[f64], buckets: usize) -> (Vec<f64>, Vec<f64>) {
    let pts: Vec<(f64, f64)> = f
        .iter()
        .zip(a)
        .filter(|(f, a)| **f > 0.0 && a.is_finite())
        .map(|(f, a)| (*f, *a))
        .collect();
    if pts.len() <= buckets {
        return pts.into_iter().unzip();
    }
    let (l0, l1) = (pts[0].0.ln(), pts[pts.len() - 1].0.ln());
    let width = (l1 - l0) / buckets as f64;
    let mut out: (Vec<f64>, Vec<f64>) = (Vec::new(), Vec::new());
    let mut current: Option<(usize, f64, f64)> = None;
    for (f, a) in pts {
        let b = (((f.ln() - l0) / width) as usize).min(buckets - 1);
        match current {
            Some((cb, _, ca)) if cb == b => {
                if a > ca {
                    current = Some((b, f, a));
                }
            }
            _ => {
                if let Some((_, cf, ca)) = current {
                    out.0.push(cf);
                    out.1.push(ca);
                }
                current = Some((b, f, a));
            }
        }
    }
    if let Some((_, cf, ca)) = current {
        out.0.push(cf);
        out.1.push(ca);
    }
    out
}

/// Rounds to `d` decimals so the page's JSON carries short numbers (n / 10ᵈ prints as the
/// decimal it stands for).
pub fn round_to(v: f64, d: i32) -> f64 {
    if d >= 0 {
        let p = 10f64.powi(d.min(15));
        (v * p).round() / p
    } else {
        let p = 10f64.powi((-d).min(15));
        (v / p).round() * p
    }
}

/// Decimals that keep `sig` significant digits of the largest magnitude in `y`.
pub fn decimals_for(y: &[f64], sig: i32) -> i32 {
    let m = y
        .iter()
        .filter(|v| v.is_finite())
        .fold(0.0f64, |m, v| m.max(v.abs()));
    if m > 0.0 {
        sig - 1 - m.log10().floor() as i32
    } else {
        0
    }
}

/// `v` to `sig` significant digits (for logarithmic axes).
pub fn round_sig(v: f64, sig: i32) -> f64 {
    if v == 0.0 || !v.is_finite() {
        return v;
    }
    round_to(v, sig - 1 - v.abs().log10().floor() as i32)
}

fn rounded(v: &[f64], sig: i32) -> Vec<f64> {
    let d = decimals_for(v, sig);
    v.iter().map(|x| round_to(*x, d)).collect()
}

/// One line of a zoomable plot.
pub struct Trace {
    pub name: String,
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    pub color: &'static str,
    pub dashed: bool,
    /// A dot at every point.
    pub markers: bool,
    /// Traces of one group toggle together from the legend (shown once).
    pub group: String,
}

impl Trace {
    pub fn new(name: &str, x: Vec<f64>, y: Vec<f64>, color: &'static str) -> Self {
        Trace {
            name: name.into(),
            x,
            y,
            color,
            dashed: false,
            markers: false,
            group: name.into(),
        }
    }
}

/// Panels stacked over one shared x axis: zooming one zooms all.
pub struct Stack<'a> {
    pub id: &'a str,
    pub title: &'a str,
    pub x_title: &'a str,
    /// (y title, traces) per panel, top first.
    pub panels: Vec<(String, Vec<Trace>)>,
    /// Shaded x ranges (the held-out part), with their label.
    pub shade: Option<(Vec<(f64, f64)>, &'a str)>,
    pub panel_height: usize,
    pub log_x: bool,
    pub log_y: bool,
    /// Include y = 0 in the range.
    pub with_zero: bool,
}

fn axis(title: &str, log: bool) -> Axis {
    let a = Axis::new()
        .title(Title::with_text(title))
        .zero_line(false)
        .auto_margin(true)
        .n_ticks(8);
    if log {
        a.type_(AxisType::Log)
    } else {
        a
    }
}

/// The plot as a `<div>` and its inline script (plotly.js must be on the page before it).
pub fn stack(s: Stack) -> String {
    let mut plot = Plot::new();
    let n = s.panels.len().clamp(1, 8);
    let gap = 0.06;
    let h = (1.0 - gap * (n - 1) as f64) / n as f64;
    let mut seen = std::collections::BTreeSet::new();
    let mut layout = framed(s.title, s.panel_height * n + 110, 50).x_axis(
        axis(s.x_title, s.log_x).anchor(if n == 1 {
            "y".to_string()
        } else {
            format!("y{n}")
        }),
    );
    for (k, (y_title, traces)) in s.panels.into_iter().take(n).enumerate() {
        let top = 1.0 - k as f64 * (h + gap);
        let mut ya = axis(&y_title, s.log_y)
            .domain(&[(top - h).max(0.0), top])
            .anchor("x");
        if s.with_zero {
            ya = ya.range_mode(plotly::layout::RangeMode::ToZero);
        }
        let yname = if k == 0 {
            "y".to_string()
        } else {
            format!("y{}", k + 1)
        };
        layout = match k {
            0 => layout.y_axis(ya),
            1 => layout.y_axis2(ya),
            2 => layout.y_axis3(ya),
            3 => layout.y_axis4(ya),
            4 => layout.y_axis5(ya),
            5 => layout.y_axis6(ya),
            6 => layout.y_axis7(ya),
            _ => layout.y_axis8(ya),
        };
        for t in traces {
            let first = seen.insert(t.group.clone());
            let mut line = Line::new().color(t.color).width(1.2);
            if t.dashed {
                line = line.dash(DashType::Dash);
            }
            let each = |v: Vec<f64>| v.into_iter().map(|x| round_sig(x, 4)).collect();
            let x = if s.log_x { each(t.x) } else { rounded(&t.x, 7) };
            let y = if s.log_y { each(t.y) } else { rounded(&t.y, 5) };
            plot.add_trace(
                Scatter::new(x, y)
                    .name(&t.name)
                    .mode(if t.markers {
                        Mode::LinesMarkers
                    } else {
                        Mode::Lines
                    })
                    .line(line)
                    .legend_group(&t.group)
                    .show_legend(first)
                    .y_axis(&yname),
            );
        }
    }
    if let Some((ranges, label)) = s.shade {
        let shapes = ranges
            .iter()
            .map(|&(x0, x1)| {
                Shape::new()
                    .shape_type(ShapeType::Rect)
                    .x_ref("x")
                    .y_ref("paper")
                    .x0(x0)
                    .x1(x1)
                    .y0(0.0)
                    .y1(1.0)
                    .fill_color("#f2e6a0")
                    .opacity(0.35)
                    .layer(ShapeLayer::Below)
                    .line(ShapeLine::new().width(0.0))
            })
            .collect();
        layout = layout.shapes(shapes);
        // the label once, over the first range
        if let Some(&(x0, x1)) = ranges.first() {
            layout = layout.annotations(vec![plotly::layout::Annotation::new()
                .text(label)
                .x_ref("x")
                .y_ref("paper")
                .x((x0 + x1) / 2.0)
                .y(1.0)
                .show_arrow(false)
                .y_anchor(plotly::common::Anchor::Bottom)]);
        }
    }
    plot.set_layout(layout);
    plot.set_configuration(Configuration::new().responsive(true).display_logo(false));
    format!(
        "<div class=\"zoomable\">{}</div>",
        plot.to_inline_html(Some(s.id))
    )
}

/// The frame every figure of the report shares: its title, a horizontal legend above the
/// plot, `bottom_px` below it for the axis' labels.
pub(crate) fn framed(title: &str, height: usize, bottom_px: usize) -> Layout {
    Layout::new()
        .title(Title::with_text(title))
        .height(height)
        .margin(Margin::new().left(70).right(20).top(70).bottom(bottom_px))
        .hover_mode(HoverMode::Closest)
        .legend(
            Legend::new()
                .orientation(plotly::common::Orientation::Horizontal)
                .y(1.0)
                .x(0.0)
                .y_anchor(plotly::common::Anchor::Bottom),
        )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn min_max_keeps_every_peak_and_stays_small() {
        let n = 90_000;
        let x: Vec<f64> = (0..n).map(|i| i as f64 * 1e-3).collect();
        let mut y: Vec<f64> = x.iter().map(|t| (t * 3.0).sin()).collect();
        y[12_345] = 50.0; // a one-sample spike
        y[67_890] = -40.0;
        let (dx, dy) = min_max(&x, &y, 1000);
        assert!(dx.len() <= 2000 && dx.len() >= 1000, "{}", dx.len());
        assert!(dy.contains(&50.0) && dy.contains(&-40.0));
        assert!(dx.windows(2).all(|w| w[1] > w[0]), "time order");
        let (lo, hi) = dy
            .iter()
            .fold((f64::MAX, f64::MIN), |a, v| (a.0.min(*v), a.1.max(*v)));
        assert_eq!((lo, hi), (-40.0, 50.0));
    }

    #[test]
    fn min_max_passes_short_series_and_drops_nan() {
        let x = [0.0, 1.0, 2.0, 3.0];
        let y = [1.0, f64::NAN, 3.0, 4.0];
        let (dx, dy) = min_max(&x, &y, 10);
        assert_eq!(dx, vec![0.0, 2.0, 3.0]);
        assert_eq!(dy, vec![1.0, 3.0, 4.0]);
        let (dx, _) = min_max(&[], &[], 10);
        assert!(dx.is_empty());
    }

    #[test]
    fn log_buckets_keep_the_line() {
        let f: Vec<f64> = (0..32_768).map(|k| k as f64 * 0.01).collect();
        let mut a = vec![0.01; f.len()];
        a[5000] = 3.0; // a line at 50 Hz
        let (df, da) = max_per_log_bucket(&f, &a, 400);
        assert!(df.len() <= 400);
        assert!(df[0] > 0.0);
        let k = da.iter().position(|v| *v == 3.0).unwrap();
        assert!((df[k] - 50.0).abs() < 1e-9);
    }

    #[test]
    fn rounding_gives_short_numbers() {
        assert_eq!(round_to(1.23456789, 3).to_string(), "1.235");
        assert_eq!(round_to(12345.6, -2), 12300.0);
        assert_eq!(round_sig(0.000123456, 3).to_string(), "0.000123");
        assert_eq!(round_sig(98765.4, 2), 99000.0);
        assert_eq!(decimals_for(&[0.5, -12.3], 5), 3);
        assert_eq!(
            serde_json::to_string(&round_to(0.1 + 0.2, 4)).unwrap(),
            "0.3"
        );
    }

    #[test]
    fn the_script_is_plotly_alone() {
        let js = plotly_js();
        assert!(js.starts_with("<script") && js.ends_with("</script>"));
        assert!(js.contains("plotly.js"));
        assert!(js.len() < 5_000_000, "MathJax is not needed");
    }
}
