//! Static summary plots as inline SVG: full page width (a viewBox scaled to the page),
//! round 1-2-5 ticks, a legend per panel.

use super::ticks::{num, Ticks};
use std::fmt::Write;

/// Width of every figure's coordinate system; the page scales it to its own width.
pub const W: f64 = 1200.0;
pub const MEASURED: &str = "#333333";
pub const BEFORE: &str = "#1f77b4";
pub const AFTER: &str = "#d62728";
pub const COLORS: [&str; 4] = [BEFORE, AFTER, "#2ca02c", "#9467bd"];
const FONT: &str = r#"font-family="sans-serif""#;

pub fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

fn open(out: &mut String, h: f64, title: &str) {
    let _ = write!(
        out,
        r##"<svg class="fig" xmlns="http://www.w3.org/2000/svg" viewBox="0 0 {W} {h}" width="100%" preserveAspectRatio="xMidYMin meet"><rect width="{W}" height="{h}" fill="#fff"/><text x="{}" y="20" font-size="16" font-weight="bold" text-anchor="middle" {FONT}>{}</text>"##,
        W / 2.0,
        esc(title)
    );
}

/// A plotting rectangle in figure coordinates and its two axes.
struct Frame {
    x0: f64,
    x1: f64,
    y0: f64,
    y1: f64,
    xt: Ticks,
    yt: Ticks,
    /// Height of the legend band between the panel's title and its frame.
    band: f64,
}

/// Legend items laid out in rows of `width`: (row, x offset) per item, and the rows.
fn legend_layout(items: &[(&str, &str, bool)], width: f64) -> (Vec<(usize, f64)>, usize) {
    let (mut row, mut x) = (0, 0.0);
    let mut at = Vec::new();
    for (label, _, _) in items {
        let w = 6.8 * label.chars().count() as f64 + 44.0;
        if x > 0.0 && x + w > width {
            row += 1;
            x = 0.0;
        }
        at.push((row, x));
        x += w;
    }
    (at, if items.is_empty() { 0 } else { row + 1 })
}

/// Height of the legend band for these items over `width`.
fn band(items: &[(&str, &str, bool)], width: f64) -> f64 {
    18.0 * legend_layout(items, width).1 as f64
}

impl Frame {
    fn px(&self, v: f64) -> f64 {
        self.x0 + (v - self.xt.lo) / (self.xt.hi - self.xt.lo) * (self.x1 - self.x0)
    }
    fn py(&self, v: f64) -> f64 {
        self.y0 - (v - self.yt.lo) / (self.yt.hi - self.yt.lo) * (self.y0 - self.y1)
    }
    /// Border, grid, tick labels and axis titles; x tick labels only when `x_labels`.
    fn draw(&self, out: &mut String, title: &str, xl: &str, yl: &str, x_labels: bool) {
        let (x0, x1, y0, y1) = (self.x0, self.x1, self.y0, self.y1);
        let _ = write!(
            out,
            r#"<text x="{}" y="{}" font-size="14" text-anchor="middle" {FONT}>{}</text>"#,
            (x0 + x1) / 2.0,
            y1 - 8.0 - self.band,
            esc(title)
        );
        for &v in &self.yt.values {
            let y = self.py(v);
            let _ = write!(
                out,
                r##"<line x1="{x0}" y1="{y:.1}" x2="{x1}" y2="{y:.1}" stroke="#e4e4e4"/><text x="{}" y="{:.1}" font-size="12" text-anchor="end" {FONT}>{}</text>"##,
                x0 - 5.0,
                y + 4.0,
                self.yt.label(v)
            );
        }
        if x_labels {
            for &v in &self.xt.values {
                let x = self.px(v);
                let _ = write!(
                    out,
                    r##"<line x1="{x:.1}" y1="{y0}" x2="{x:.1}" y2="{y1}" stroke="#eeeeee"/><text x="{x:.1}" y="{}" font-size="12" text-anchor="middle" {FONT}>{}</text>"##,
                    y0 + 16.0,
                    self.xt.label(v)
                );
            }
        }
        let _ = write!(
            out,
            r##"<rect x="{x0}" y="{y1}" width="{}" height="{}" fill="none" stroke="#999"/><text x="{}" y="{}" font-size="13" text-anchor="middle" {FONT}>{}</text><text x="{}" y="{}" font-size="13" text-anchor="middle" {FONT} transform="rotate(-90 {} {})">{}</text>"##,
            x1 - x0,
            y0 - y1,
            (x0 + x1) / 2.0,
            y0 + 34.0,
            esc(xl),
            x0 - 50.0,
            (y0 + y1) / 2.0,
            x0 - 50.0,
            (y0 + y1) / 2.0,
            esc(yl)
        );
    }
    /// The legend in the band above the frame.
    fn legend(&self, out: &mut String, items: &[(&str, &str, bool)]) {
        let (at, _) = legend_layout(items, self.x1 - self.x0);
        for ((label, color, dashed), (row, dx)) in items.iter().zip(at) {
            let y = self.y1 - self.band + 18.0 * row as f64 + 6.0;
            let x = self.x0 + dx;
            let dash = if *dashed {
                r#" stroke-dasharray="6 3""#
            } else {
                ""
            };
            let _ = write!(
                out,
                r##"<line x1="{x}" y1="{y}" x2="{}" y2="{y}" stroke="{color}" stroke-width="2.5"{dash}/><text x="{}" y="{}" font-size="12" {FONT}>{}</text>"##,
                x + 24.0,
                x + 30.0,
                y + 4.0,
                esc(label)
            );
        }
    }
}

fn data_range<'a>(vals: impl Iterator<Item = &'a f64>) -> (f64, f64) {
    vals.filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(*v), hi.max(*v))
        })
}

/// One line (with dots at the points when `dots`).
pub struct Series<'a> {
    pub label: String,
    pub x: &'a [f64],
    pub y: &'a [f64],
    pub color: &'static str,
    pub dashed: bool,
    pub dots: bool,
}

/// A panel of lines.
pub struct LinePanel<'a> {
    pub title: String,
    pub x_label: &'a str,
    pub y_label: &'a str,
    pub series: Vec<Series<'a>>,
    /// Include y = 0 in the range.
    pub with_zero: bool,
}

/// Panels of lines on a grid of `cols` columns, each `panel_h` high.
pub fn line_panels(title: &str, panels: &[LinePanel], cols: usize, panel_h: f64) -> String {
    let cols = cols.max(1);
    let rows = panels.len().div_ceil(cols).max(1);
    let cell_w = W / cols as f64;
    let legend_h = panels
        .iter()
        .map(|p| {
            let it: Vec<(&str, &str, bool)> = p
                .series
                .iter()
                .map(|s| (s.label.as_str(), s.color, s.dashed))
                .collect();
            band(&it, cell_w - 88.0)
        })
        .fold(0.0, f64::max);
    let cell_h = panel_h + 70.0 + legend_h;
    let h = 34.0 + rows as f64 * cell_h;
    let mut out = String::new();
    open(&mut out, h, title);
    for (k, p) in panels.iter().enumerate() {
        let (r, c) = (k / cols, k % cols);
        let (mut xr, mut yr) = (
            data_range(p.series.iter().flat_map(|s| s.x.iter())),
            data_range(p.series.iter().flat_map(|s| s.y.iter())),
        );
        if p.with_zero {
            yr = (yr.0.min(0.0), yr.1.max(0.0));
        }
        if !xr.0.is_finite() {
            xr = (0.0, 1.0);
        }
        let f = Frame {
            x0: c as f64 * cell_w + 72.0,
            x1: (c + 1) as f64 * cell_w - 16.0,
            y0: 34.0 + r as f64 * cell_h + 30.0 + legend_h + panel_h,
            y1: 34.0 + r as f64 * cell_h + 30.0 + legend_h,
            xt: Ticks::inside(xr.0, xr.1, if cols > 1 { 5 } else { 10 }),
            yt: Ticks::new(yr.0, yr.1, 5),
            band: legend_h,
        };
        let f = if xr.1 > xr.0 {
            f
        } else {
            Frame {
                xt: Ticks::new(xr.0, xr.1, 5),
                ..f
            }
        };
        f.draw(&mut out, &p.title, p.x_label, p.y_label, true);
        for s in &p.series {
            let mut d = String::new();
            let mut pen_up = true;
            for (x, y) in s.x.iter().zip(s.y) {
                if !(x.is_finite() && y.is_finite()) {
                    pen_up = true;
                    continue;
                }
                let _ = write!(
                    d,
                    "{}{:.1},{:.1}",
                    if pen_up { "M" } else { "L" },
                    f.px(*x),
                    f.py(*y)
                );
                pen_up = false;
                if s.dots {
                    let _ = write!(
                        out,
                        r#"<circle cx="{:.1}" cy="{:.1}" r="3" fill="{}"/>"#,
                        f.px(*x),
                        f.py(*y),
                        s.color
                    );
                }
            }
            let dash = if s.dashed {
                r#" stroke-dasharray="6 3""#
            } else {
                ""
            };
            let _ = write!(
                out,
                r#"<path d="{d}" fill="none" stroke="{}" stroke-width="1.8"{dash}/>"#,
                s.color
            );
        }
        let items: Vec<(&str, &str, bool)> = p
            .series
            .iter()
            .map(|s| (s.label.as_str(), s.color, s.dashed))
            .collect();
        f.legend(&mut out, &items);
    }
    out.push_str("</svg>");
    out
}

/// Grouped bars: one group per label, one bar per series (label, colour, values).
pub fn bars(title: &str, yl: &str, labels: &[String], series: &[(&str, &str, Vec<f64>)]) -> String {
    let items: Vec<(&str, &str, bool)> = series.iter().map(|s| (s.0, s.1, false)).collect();
    let legend_h = band(&items, W - 88.0);
    let h = 330.0 + legend_h;
    let mut out = String::new();
    open(&mut out, h, title);
    let hi = data_range(series.iter().flat_map(|s| s.2.iter())).1;
    let long = labels.iter().map(|l| l.chars().count()).max().unwrap_or(0);
    let slot_w = (W - 88.0) / labels.len().max(1) as f64;
    let rotate = long as f64 * 7.0 > slot_w;
    let f = Frame {
        x0: 72.0,
        x1: W - 16.0,
        y0: if rotate { h - 110.0 } else { h - 50.0 },
        y1: 46.0 + legend_h,
        xt: Ticks::new(0.0, labels.len().max(1) as f64, 5),
        yt: Ticks::new(0.0, if hi.is_finite() { hi } else { 1.0 }, 5),
        band: legend_h,
    };
    f.draw(&mut out, "", "", yl, false);
    let slot = (f.x1 - f.x0) / labels.len().max(1) as f64;
    let bw = slot * 0.8 / series.len().max(1) as f64;
    for (i, l) in labels.iter().enumerate() {
        for (k, (_, color, v)) in series.iter().enumerate() {
            let val = v.get(i).copied().unwrap_or(f64::NAN);
            if !val.is_finite() {
                continue;
            }
            let x = f.x0 + i as f64 * slot + 0.1 * slot + k as f64 * bw;
            let y = f.py(val);
            let _ = write!(
                out,
                r#"<rect x="{x:.1}" y="{y:.1}" width="{bw:.1}" height="{:.1}" fill="{color}"><title>{}: {}</title></rect>"#,
                (f.y0 - y).max(0.0),
                esc(l),
                num(val)
            );
        }
        let cx = f.x0 + (i as f64 + 0.5) * slot;
        if rotate {
            let _ = write!(
                out,
                r#"<text x="{cx:.1}" y="{}" font-size="11" text-anchor="end" {FONT} transform="rotate(-40 {cx:.1} {})">{}</text>"#,
                f.y0 + 14.0,
                f.y0 + 14.0,
                esc(l)
            );
        } else {
            let _ = write!(
                out,
                r#"<text x="{cx:.1}" y="{}" font-size="12" text-anchor="middle" {FONT}>{}</text>"#,
                f.y0 + 16.0,
                esc(l)
            );
        }
    }
    f.legend(&mut out, &items);
    out.push_str("</svg>");
    out
}

/// Values on a grid of cells: `values[iy * nx + ix]`, `None` for an empty cell.
pub struct Grid {
    pub x_edges: Vec<f64>,
    pub y_edges: Vec<f64>,
    pub values: Vec<Option<f64>>,
}

/// Viridis, 9 stops.
const VIRIDIS: [(u8, u8, u8); 9] = [
    (68, 1, 84),
    (71, 44, 122),
    (59, 81, 139),
    (44, 113, 142),
    (33, 144, 141),
    (39, 173, 129),
    (92, 200, 99),
    (170, 220, 50),
    (253, 231, 37),
];

pub fn viridis(t: f64) -> String {
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let s = t * (VIRIDIS.len() - 1) as f64;
    let i = (s.floor() as usize).min(VIRIDIS.len() - 2);
    let u = s - i as f64;
    let (a, b) = (VIRIDIS[i], VIRIDIS[i + 1]);
    let m = |p: u8, q: u8| (p as f64 + u * (q as f64 - p as f64)).round() as u8;
    format!("#{:02x}{:02x}{:02x}", m(a.0, b.0), m(a.1, b.1), m(a.2, b.2))
}

/// Heat maps side by side on one colour scale (0 to the largest value), with a colour bar.
/// The cells keep the axes' aspect ratio (a workspace is drawn to scale).
pub fn heat_maps(title: &str, xl: &str, yl: &str, unit: &str, panels: &[(&str, &Grid)]) -> String {
    let n = panels.len().max(1);
    let vmax = panels
        .iter()
        .flat_map(|p| p.1.values.iter().flatten())
        .fold(0.0f64, |m, v| m.max(*v));
    let scale = Ticks::new(0.0, if vmax > 0.0 { vmax } else { 1.0 }, 5);
    let bar_w = 110.0;
    let cell_w = (W - bar_w) / n as f64;
    let (gx, gy) = panels
        .first()
        .map(|p| {
            (
                (p.1.x_edges[0], *p.1.x_edges.last().unwrap()),
                (p.1.y_edges[0], *p.1.y_edges.last().unwrap()),
            )
        })
        .unwrap_or(((0.0, 1.0), (0.0, 1.0)));
    // to scale: height over width as in the data, within 220–480 high
    let aspect = (gy.1 - gy.0) / (gx.1 - gx.0).max(1e-12);
    let ph = ((cell_w - 96.0) * aspect).clamp(220.0, 480.0);
    let pw = (ph / aspect.max(1e-12)).min(cell_w - 96.0);
    let h = 34.0 + 30.0 + ph + 50.0;
    let mut out = String::new();
    open(&mut out, h, title);
    for (k, (label, g)) in panels.iter().enumerate() {
        let f = Frame {
            x0: k as f64 * cell_w + 80.0,
            x1: k as f64 * cell_w + 80.0 + pw,
            y0: 64.0 + ph,
            y1: 64.0,
            xt: Ticks::inside(gx.0, gx.1, 5),
            yt: Ticks::inside(gy.0, gy.1, 5),
            band: 0.0,
        };
        let f = Frame {
            xt: Ticks {
                lo: gx.0,
                hi: gx.1,
                ..f.xt
            },
            yt: Ticks {
                lo: gy.0,
                hi: gy.1,
                ..f.yt
            },
            ..f
        };
        f.draw(&mut out, label, xl, yl, true);
        let nx = g.x_edges.len() - 1;
        for (i, v) in g.values.iter().enumerate() {
            let (ix, iy) = (i % nx, i / nx);
            let (xa, xb) = (f.px(g.x_edges[ix]), f.px(g.x_edges[ix + 1]));
            let (ya, yb) = (f.py(g.y_edges[iy + 1]), f.py(g.y_edges[iy]));
            let (fill, tip) = match v {
                Some(v) => (viridis(v / scale.hi), num(*v)),
                None => ("#f0f0f0".to_string(), "no samples".into()),
            };
            let _ = write!(
                out,
                r#"<rect x="{xa:.1}" y="{ya:.1}" width="{:.1}" height="{:.1}" fill="{fill}"><title>{tip}</title></rect>"#,
                xb - xa + 0.3,
                yb - ya + 0.3
            );
        }
    }
    // colour bar
    let bx = ((n - 1) as f64 * cell_w + 80.0 + pw + 24.0).min(W - bar_w + 20.0);
    let (by0, by1) = (64.0 + ph, 64.0);
    let steps = 40;
    for s in 0..steps {
        let t0 = s as f64 / steps as f64;
        let y = by0 - (t0 + 1.0 / steps as f64) * (by0 - by1);
        let _ = write!(
            out,
            r#"<rect x="{bx}" y="{y:.1}" width="18" height="{:.1}" fill="{}"/>"#,
            (by0 - by1) / steps as f64 + 0.5,
            viridis(t0 + 0.5 / steps as f64)
        );
    }
    for &v in &scale.values {
        let y = by0 - v / scale.hi * (by0 - by1);
        let _ = write!(
            out,
            r#"<text x="{}" y="{:.1}" font-size="12" {FONT}>{}</text>"#,
            bx + 24.0,
            y + 4.0,
            scale.label(v)
        );
    }
    let _ = write!(
        out,
        r#"<text x="{}" y="{}" font-size="12" text-anchor="middle" {FONT}>{}</text></svg>"#,
        bx + 9.0,
        by1 - 10.0,
        esc(unit)
    );
    out
}

/// Scatter of ≤ 3000 points (evenly thinned).
pub fn scatter(title: &str, xl: &str, yl: &str, x: &[f64], y: &[f64]) -> String {
    let h = 380.0;
    let mut out = String::new();
    open(&mut out, h, title);
    let xr = data_range(x.iter());
    let yr = data_range(y.iter());
    let f = Frame {
        x0: 72.0,
        x1: W - 16.0,
        y0: h - 50.0,
        y1: 56.0,
        xt: Ticks::new(xr.0, xr.1, 10),
        yt: Ticks::new(yr.0, yr.1, 5),
        band: 0.0,
    };
    f.draw(&mut out, "", xl, yl, true);
    // dots as zero-length segments with round caps: one short path
    let stride = (x.len() / 3000).max(1);
    let mut d = String::new();
    for (xv, yv) in x.iter().zip(y).step_by(stride) {
        if xv.is_finite() && yv.is_finite() {
            let _ = write!(d, "M{:.1} {:.1}h0", f.px(*xv), f.py(*yv));
        }
    }
    let _ = write!(
        out,
        r#"<path d="{d}" stroke="{BEFORE}" stroke-opacity="0.45" stroke-width="3.2" stroke-linecap="round"/></svg>"#
    );
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn figures_scale_to_the_page_and_have_round_ticks() {
        let x = [0.0, 1.0, 2.0, 3.0];
        let y = [0.0, 0.31, 0.77, 0.52];
        let s = line_panels(
            "t",
            &[LinePanel {
                title: "p".into(),
                x_label: "x",
                y_label: "y",
                series: vec![Series {
                    label: "a".into(),
                    x: &x,
                    y: &y,
                    color: BEFORE,
                    dashed: false,
                    dots: true,
                }],
                with_zero: true,
            }],
            1,
            200.0,
        );
        assert!(s.contains(r#"width="100%""#) && s.contains("viewBox"));
        assert!(s.contains(">0.2<") && s.contains(">0.8<"), "{s}");
        assert!(!s.contains("0.30000000"));
    }

    #[test]
    fn heat_map_cells_and_colour_bar() {
        let g = Grid {
            x_edges: vec![0.0, 1.0, 2.0],
            y_edges: vec![0.0, 1.0],
            values: vec![Some(1.0), None],
        };
        let s = heat_maps("w", "x", "y", "N", &[("before", &g), ("after", &g)]);
        assert_eq!(s.matches("no samples").count(), 2);
        assert_eq!(viridis(0.0), "#440154");
        assert_eq!(viridis(1.0), "#fde725");
    }
}
