//! The summary figures, drawn by plotly.js like the time series: grouped bars, heat maps
//! over the workspace on one colour scale, and a thinned scatter.

use crate::bins::Grid;
use crate::plots::{round_sig, round_to, BEFORE};
use plotly::common::{ColorBar, ColorScale, ColorScalePalette, Marker, Mode, Title};
use plotly::layout::{Axis, BarMode};
use plotly::{Bar, Configuration, HeatMap, Layout, Plot, Scatter};

/// A figure's layout: its title, a horizontal legend above the plot and room for labels.
fn layout(title: &str, height: usize) -> Layout {
    crate::plots::framed(title, height, 60)
}

fn axis(title: &str) -> Axis {
    Axis::new()
        .title(Title::with_text(title))
        .zero_line(false)
        .auto_margin(true)
}

/// The plot as a `<div>` and its inline script (plotly.js must be on the page before it).
fn div(mut plot: Plot, layout: Layout, id: &str) -> String {
    plot.set_layout(layout);
    plot.set_configuration(Configuration::new().responsive(true).display_logo(false));
    format!(
        "<div class=\"zoomable\">{}</div>",
        plot.to_inline_html(Some(id))
    )
}

/// Grouped bars: one group per label, one bar per series (name, colour, values). A value
/// that is not finite has no bar.
pub fn bars(
    id: &str,
    title: &str,
    y_title: &str,
    labels: &[String],
    series: &[(&str, &'static str, Vec<f64>)],
) -> String {
    let mut plot = Plot::new();
    for (name, color, values) in series {
        let y: Vec<Option<f64>> = values
            .iter()
            .map(|v| v.is_finite().then(|| round_sig(*v, 4)))
            .collect();
        plot.add_trace(
            Bar::new(labels.to_vec(), y)
                .name(*name)
                .marker(Marker::new().color(*color)),
        );
    }
    let x_axis = Axis::new()
        .auto_margin(true)
        .type_(plotly::layout::AxisType::Category);
    div(
        plot,
        layout(title, 380)
            .bar_mode(BarMode::Group)
            .x_axis(x_axis)
            .y_axis(axis(y_title).range_mode(plotly::layout::RangeMode::ToZero)),
        id,
    )
}

/// Heat maps side by side (at most four), on one colour scale from 0 to the largest value,
/// the cells drawn to scale. Cells without a value are left grey.
pub fn heat_maps(
    id: &str,
    title: &str,
    x_title: &str,
    y_title: &str,
    unit: &str,
    panels: &[(&str, &Grid)],
) -> String {
    let panels = &panels[..panels.len().min(4)];
    let n = panels.len().max(1);
    let vmax = panels
        .iter()
        .flat_map(|p| p.1.values.iter().flatten())
        .fold(0.0f64, |m, v| m.max(*v));
    let gap = 0.08;
    let width = (1.0 - gap * (n - 1) as f64) / n as f64;
    let mut plot = Plot::new();
    let mut layout = layout(title, 520).plot_background_color("#f0f0f0");
    let mut annotations = Vec::new();
    for (k, (label, g)) in panels.iter().enumerate() {
        let centres = |e: &[f64]| -> Vec<f64> {
            let d = centre_decimals(e);
            e.windows(2)
                .map(|w| round_to((w[0] + w[1]) / 2.0, d))
                .collect()
        };
        let nx = g.x_edges.len() - 1;
        let z: Vec<Vec<Option<f64>>> = g
            .values
            .chunks(nx)
            .map(|row| row.iter().map(|v| v.map(|v| round_sig(v, 4))).collect())
            .collect();
        let (xa, ya) = if k == 0 {
            ("x".to_string(), "y".to_string())
        } else {
            (format!("x{}", k + 1), format!("y{}", k + 1))
        };
        plot.add_trace(
            HeatMap::new(centres(&g.x_edges), centres(&g.y_edges), z)
                .name(*label)
                .zmin(0.0)
                .zmax(if vmax > 0.0 { vmax } else { 1.0 })
                .color_scale(ColorScale::Palette(ColorScalePalette::Viridis))
                .show_scale(k + 1 == panels.len())
                .color_bar(ColorBar::new().title(Title::with_text(unit)))
                .x_axis(&xa)
                .y_axis(&ya),
        );
        let x0 = k as f64 * (width + gap);
        let xaxis = axis(x_title).domain(&[x0, x0 + width]).anchor(&ya);
        // the workspace to scale: a millimetre is as long in y as in x
        let yaxis = axis(y_title).anchor(&xa).scale_anchor(&xa);
        layout = match k {
            0 => layout.x_axis(xaxis).y_axis(yaxis),
            1 => layout.x_axis2(xaxis).y_axis2(yaxis),
            2 => layout.x_axis3(xaxis).y_axis3(yaxis),
            _ => layout.x_axis4(xaxis).y_axis4(yaxis),
        };
        annotations.push(
            plotly::layout::Annotation::new()
                .text(*label)
                .x_ref("paper")
                .y_ref("paper")
                .x(x0 + width / 2.0)
                .y(1.0)
                .show_arrow(false)
                .y_anchor(plotly::common::Anchor::Bottom),
        );
    }
    div(plot, layout.annotations(annotations), id)
}

/// Decimals that print the cell centres of these edges exactly enough (a tenth of a cell).
fn centre_decimals(edges: &[f64]) -> i32 {
    let step = edges
        .windows(2)
        .map(|w| w[1] - w[0])
        .fold(f64::INFINITY, f64::min);
    if step.is_finite() && step > 0.0 {
        (1 - step.log10().floor() as i32).max(0)
    } else {
        3
    }
}

/// A scatter of at most 3000 points (evenly thinned).
pub fn scatter(
    id: &str,
    title: &str,
    x_title: &str,
    y_title: &str,
    x: &[f64],
    y: &[f64],
) -> String {
    let stride = (x.len() / 3000).max(1);
    let (x, y): (Vec<f64>, Vec<f64>) = x
        .iter()
        .zip(y)
        .step_by(stride)
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .map(|(x, y)| (round_sig(*x, 4), round_sig(*y, 4)))
        .unzip();
    let mut plot = Plot::new();
    plot.add_trace(
        Scatter::new(x, y)
            .mode(Mode::Markers)
            .marker(Marker::new().color(BEFORE).size(5).opacity(0.45))
            .show_legend(false),
    );
    div(
        plot,
        layout(title, 380)
            .x_axis(axis(x_title))
            .y_axis(axis(y_title)),
        id,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bars_leave_out_what_is_not_scored() {
        let s = bars(
            "b",
            "t",
            "NRMSE",
            &["base".into(), "+ friction".into()],
            &[
                ("fx", BEFORE, vec![0.5, 0.25]),
                ("fy", "#d62728", vec![f64::NAN, 0.1]),
            ],
        );
        assert!(s.contains("\"type\":\"bar\""), "{s}");
        assert!(s.contains("[null,0.1]"), "a NaN has no bar: {s}");
        assert!(s.contains("\"barmode\":\"group\""));
    }

    #[test]
    fn heat_maps_share_one_colour_scale() {
        let g = Grid {
            x_edges: vec![0.0, 1.0, 2.0],
            y_edges: vec![0.0, 1.0],
            values: vec![Some(1.0), None],
        };
        let s = heat_maps("h", "w", "x", "y", "N", &[("before", &g), ("after", &g)]);
        assert_eq!(s.matches("\"type\":\"heatmap\"").count(), 2);
        assert_eq!(s.matches("\"zmax\":1.0").count(), 2, "{s}");
        assert!(s.contains("[[1.0,null]]"), "an empty cell is a gap: {s}");
        assert!(s.contains("\"scaleanchor\":\"x2\""), "drawn to scale");
    }

    #[test]
    fn scatter_is_thinned() {
        let x: Vec<f64> = (0..9000).map(|i| i as f64).collect();
        let s = scatter("s", "t", "x", "y", &x, &x);
        let points = s
            .split("\"x\":[")
            .nth(1)
            .unwrap()
            .split(']')
            .next()
            .unwrap();
        assert_eq!(points.matches(',').count() + 1, 3000);
    }
}
