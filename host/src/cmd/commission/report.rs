//! The commissioning report: Markdown for the record, HTML with the plots a person looks at.

use super::CommissionState;
use anyhow::Context;
use pam_report::plots::{stack, Stack, Trace};
use pam_report::Page;
use std::path::Path;

const STEP_TITLES: [(&str, &str); 4] = [
    (
        "channels",
        "Step 1: encoders and I/P channel map (handle free)",
    ),
    (
        "loadcell",
        "Step 2: the load cell (handle blocked, open-loop force steps)",
    ),
    (
        "converters",
        "Step 3: the converters' step response, per channel (handle blocked)",
    ),
    (
        "closed_loop",
        "Step 4: first closed-loop force step at low gain (handle blocked)",
    ),
];

fn title(name: &str) -> &str {
    STEP_TITLES
        .iter()
        .find(|(n, _)| *n == name)
        .map_or(name, |(_, t)| t)
}

fn verdict(state: &CommissionState) -> String {
    match &state.failed {
        Some(step) => format!("stopped at the step `{step}`"),
        None => format!("passed: {}", state.passed.join(", ")),
    }
}

pub fn markdown(path: &Path, state: &CommissionState) -> anyhow::Result<()> {
    let mut s = format!(
        "# Commissioning report\n\n{}; {:.1} s on the rig.\n",
        verdict(state),
        state.seconds
    );
    if !state.responses.is_empty() {
        s += "\n## Step 1: encoders and I/P channel map\n\n";
        s += "| channel | joint 1 measured, rad | joint 1 model | joint 2 measured | joint 2 model |\n|---|---|---|---|---|\n";
        for r in &state.responses {
            s += &format!(
                "| {} | {:+.4} | {:+.4} | {:+.4} | {:+.4} |\n",
                r.channel + 1,
                r.measured_rad[0],
                r.model_rad[0],
                r.measured_rad[1],
                r.model_rad[1]
            );
        }
    }
    if let Some(f) = state.tare_n {
        s += &format!(
            "\nLoad cell at rest: ({:+.2}, {:+.2}) N (tolerance {} N)\n",
            f[0],
            f[1],
            super::analysis::TARE_TOLERANCE_N
        );
    }
    s += "\n## Bounds: the largest values the telemetry showed\n\n| step | largest joint speed, rad/s | bound | largest handle force, N | bound | time, s |\n|---|---|---|---|---|---|\n";
    for r in &state.steps {
        s += &format!(
            "| {} | {:.3} | {} | {:.2} | {} | {:.1} |\n",
            r.name,
            r.max_speed_rad_s,
            r.speed_bound_rad_s,
            r.max_force_n,
            r.force_bound_n,
            r.seconds
        );
    }
    for r in state.steps.iter().filter(|r| !r.checks.is_empty()) {
        s += &format!(
            "\n## {}\n\n| check | measured | expected | tolerance |\n|---|---|---|---|\n",
            title(&r.name)
        );
        for c in &r.checks {
            s += &format!("| {} | {} | {} | {} |\n", c[0], c[1], c[2], c[3]);
        }
    }
    s += "\n## Findings\n\n";
    if state.findings.is_empty() {
        s += "none: wired as configured\n";
    }
    for f in &state.findings {
        s += &format!("- **{}**: {}. Fix: {}\n", f[0], f[1], f[2]);
    }
    std::fs::write(path, s).with_context(|| format!("cannot write {}", path.display()))
}

pub fn html(path: &Path, state: &CommissionState) -> anyhow::Result<()> {
    let mut page = Page::new("Commissioning report");
    page.p(&format!(
        "{}; {:.1} s on the rig.",
        verdict(state),
        state.seconds
    ));
    page.h2("Findings");
    if state.findings.is_empty() {
        page.p("none: wired as configured");
    } else {
        let rows: Vec<Vec<String>> = state.findings.iter().map(|f| f.to_vec()).collect();
        page.table(&["fault", "what was measured", "fix"], &rows);
    }
    page.h2("Bounds: the largest values the telemetry showed");
    let rows: Vec<Vec<String>> = state
        .steps
        .iter()
        .map(|r| {
            vec![
                r.name.clone(),
                format!("{:.3}", r.max_speed_rad_s),
                format!("{}", r.speed_bound_rad_s),
                format!("{:.2}", r.max_force_n),
                format!("{}", r.force_bound_n),
                format!("{:.1}", r.seconds),
            ]
        })
        .collect();
    page.table(
        &[
            "step",
            "largest joint speed, rad/s",
            "bound",
            "largest handle force, N",
            "bound",
            "time, s",
        ],
        &rows,
    );
    if !state.responses.is_empty() {
        page.h2(title("channels"));
        let rows: Vec<Vec<String>> = state
            .responses
            .iter()
            .map(|r| {
                vec![
                    format!("{}", r.channel + 1),
                    format!("{:+.4}", r.measured_rad[0]),
                    format!("{:+.4}", r.model_rad[0]),
                    format!("{:+.4}", r.measured_rad[1]),
                    format!("{:+.4}", r.model_rad[1]),
                ]
            })
            .collect();
        page.table(
            &[
                "channel",
                "joint 1 measured, rad",
                "joint 1 model",
                "joint 2 measured",
                "joint 2 model",
            ],
            &rows,
        );
    }
    for r in &state.steps {
        if r.name != "channels" {
            page.h2(title(&r.name));
        }
        if !r.checks.is_empty() {
            let rows: Vec<Vec<String>> = r.checks.iter().map(|c| c.to_vec()).collect();
            page.table(&["check", "measured", "expected", "tolerance"], &rows);
        }
        let col = |i: usize| r.trace.iter().map(|s| s[i]).collect::<Vec<f64>>();
        let t = col(0);
        let id = page.next_id();
        let mut forces = vec![
            Trace::new("Fx measured", t.clone(), col(3), "#1f77b4"),
            Trace::new("Fy measured", t.clone(), col(4), "#d62728"),
        ];
        if r.name != "channels" {
            for (i, name, color) in [(5, "Fx command", "#1f77b4"), (6, "Fy command", "#d62728")] {
                let mut tr = Trace::new(name, t.clone(), col(i), color);
                tr.dashed = true;
                forces.push(tr);
            }
        }
        page.plotly(&stack(Stack {
            id: &id,
            title: title(&r.name),
            x_title: "time, s",
            panels: vec![
                (
                    "joint angle, rad".into(),
                    vec![
                        Trace::new("α1", t.clone(), col(1), "#2ca02c"),
                        Trace::new("α2", t.clone(), col(2), "#9467bd"),
                    ],
                ),
                ("handle force, N".into(), forces),
            ],
            shade: None,
            panel_height: 220,
            log_x: false,
            log_y: false,
            with_zero: false,
        }));
    }
    std::fs::write(path, page.finish()).with_context(|| format!("cannot write {}", path.display()))
}
