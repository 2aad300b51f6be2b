//! `cargo xtask eval [--quick] [--only NAME[,NAME…]] [--list]`: the evaluation suites, and
//! the results page they make (docs/results.md).
//!
//! Every section of the page is the output of commands listed here: the page says, above
//! each table, the date, the commit and the commands, so anyone can make it again. A full
//! run rewrites docs/results.md; `--only` reruns the named sections and keeps the others'
//! last output (each between its `<!-- eval:NAME -->` markers), the page always in the
//! order of [`SECTIONS`] and nothing on it that no command wrote. `--quick` runs smaller
//! plans as a smoke test and prints the page instead of writing it, since its figures are
//! not those the page reports.

use std::path::Path;
use std::process::Command;
use std::time::Instant;

use crate::{cargo_in, root, run_streaming};

/// How a section turns its commands' output into markdown.
#[derive(Clone, Copy)]
enum Kind {
    /// The confusion runs: one row per run (what was named, the false alarms, the time),
    /// and the first run's confusion matrix below the rows.
    Confusion,
    /// Test binaries: one row per binary (passed, failed, seconds).
    Suites,
    /// Each command prints markdown rows; the section's header goes above them all.
    Rows(&'static str),
    /// Each command prints its own markdown tables, shown under the command.
    Tables,
    /// Lines that contain one of these words, in a text block under the command.
    Lines(&'static [&'static str]),
}

struct Section {
    name: &'static str,
    title: &'static str,
    intro: &'static str,
    kind: Kind,
    /// The cargo arguments of each run (`quick` selects the smaller plans).
    runs: fn(quick: bool) -> Vec<Vec<String>>,
}

/// The words of a command; a trailing `--` with no arguments after it is left out.
fn words(s: &str) -> Vec<String> {
    let mut w: Vec<String> = s.split_whitespace().map(String::from).collect();
    if w.last().is_some_and(|l| l == "--") {
        w.pop();
    }
    w
}

fn confusion(args: &str) -> Vec<String> {
    words(&format!(
        "run --release -q -p pam-eval --example confusion -- --jobs 2 {args}"
    ))
}

fn confusion_runs(quick: bool) -> Vec<Vec<String>> {
    let full = [
        "--logs 320 --seed0 430000",
        "--logs 320 --seed0 430000 --nuisance random",
        "--logs 320 --seed0 520000 --motion random",
        "--logs 320 --seed0 560000 --motion random --step-levels random --nuisance random",
        "--experiment dynamic --logs 160 --seed0 500000 --motion reach_and_hold",
        "--experiment dynamic --logs 160 --seed0 500000 --motion multisine",
        "--experiment dynamic --logs 160 --seed0 500000 --motion circles",
        "--experiment dynamic --logs 160 --seed0 500000 --motion sines",
        "--experiment step --logs 160 --seed0 540000 --step-levels lattice",
        "--experiment step --logs 160 --seed0 540000 --step-levels continuous",
        "--experiment step --logs 160 --seed0 540000 --step-levels diagonal",
        "--experiment step --logs 320 --seed0 430000 --nuisance jitter=0.25",
        "--experiment step --logs 320 --seed0 440000 --step-order x_then_y",
        "--family none --logs 400 --seed0 120000",
        "--family unexplained --experiment dynamic --logs 40 --seed0 130000",
    ];
    let quick_plans = [
        "--logs 40 --seed0 430000",
        "--logs 40 --seed0 560000 --motion random --step-levels random --nuisance random",
    ];
    let plans: &[&str] = if quick { &quick_plans } else { &full };
    plans.iter().map(|a| confusion(a)).collect()
}

fn crossgen(args: &str) -> Vec<String> {
    words(&format!(
        "run --release -q -p pam-eval --example crossgen -- --jobs 2 {args}"
    ))
}

fn physgen_runs(quick: bool) -> Vec<Vec<String>> {
    let logs = if quick { 8 } else { 60 };
    [700_000, 710_000]
        .iter()
        .map(|seed| {
            crossgen(&format!(
                "--generators physgen --logs {logs} --seed0 {seed}"
            ))
        })
        .collect()
}

fn crossgen_runs(quick: bool) -> Vec<Vec<String>> {
    // 300 logs a generator: a strict rate of 70 % is then known to ±2.6 % (one binomial
    // standard deviation), finer than the differences between grid points it ranks.
    let logs = if quick { 8 } else { 300 };
    vec![crossgen(&format!(
        "--generators physgen,synth,twin --logs {logs} --seed0 720000 --gains 0.01,0.03,0.08 --lags 0,0.01,0.02"
    ))]
}

fn suite_runs(quick: bool) -> Vec<Vec<String>> {
    // one command per test binary: cargo names the binary on its standard error, which the
    // page does not read, so each row is named from its own command
    ["synth_matrix", "twin_loop"]
        .iter()
        .map(|test| {
            let mut args = words(&format!("test --release -p pam-eval --test {test}"));
            if !quick {
                args.extend(words("--features suites"));
            }
            args.extend(words("-- --test-threads=2"));
            args
        })
        .collect()
}

fn friction_pair_runs(quick: bool) -> Vec<Vec<String>> {
    let args = if quick {
        "--pairs 5 --seed0 1001 --generator physgen"
    } else {
        "--pairs 40 --seed0 1001"
    };
    vec![words(&format!(
        "run --release -q -p pam-eval --example friction_pairs -- {args} --jobs 2"
    ))]
}

fn speed_runs(quick: bool) -> Vec<Vec<String>> {
    if quick {
        return Vec::new();
    }
    vec![words("bench -p pam-model-loop --bench diagnose")]
}

fn force_step_runs(quick: bool) -> Vec<Vec<String>> {
    let full = [
        "",
        "--feed-forward",
        "--identified-rig",
        "--identified-rig --feed-forward",
        "--closed-loop",
        "--closed-loop --feed-forward",
        "--closed-loop --identified-rig",
        "--closed-loop --identified-rig --feed-forward",
        "--closed-loop --identified-rig --within 19",
        "--closed-loop --identified-rig --feed-forward --within 19",
        "--closed-loop --with asymmetric_ip_rates",
        "--closed-loop --with cable_slip",
        "--closed-loop --with pose_dependence",
        "--closed-loop --with pressure_saturation",
        "--closed-loop --with transport_delay:delay_s=0.01",
        "--closed-loop --period 0.002",
        "--closed-loop --period 0.005",
        "--closed-loop --period 0.01",
    ];
    let plans: &[&str] = if quick { &full[4..5] } else { &full };
    plans
        .iter()
        .map(|a| {
            words(&format!(
                "run --release -q -p pam-twin --example force_step_table -- {a} --seed 0"
            ))
        })
        .collect()
}

fn margin_runs(quick: bool) -> Vec<Vec<String>> {
    let scales: &[&str] = if quick { &[""] } else { &["", "1 0.3", "1.5"] };
    scales
        .iter()
        .map(|s| {
            words(&format!(
                "run --release -q -p pam-twin --example closed_loop_margins -- {s}"
            ))
        })
        .collect()
}

fn impedance_runs(quick: bool) -> Vec<Vec<String>> {
    let mut runs = vec![words(
        "run --release -q -p pam-eval --example impedance_check -- 1 30",
    )];
    let bias: &[&str] = if quick {
        &["300 10 0"]
    } else {
        &[
            "0 5 0",
            "300 5 0",
            "653 5 0",
            "0 10 0",
            "300 10 0",
            "653 10 0",
            "0 20 0",
            "300 20 0",
            "653 20 0",
            "0 20 0.5",
            "0 20 1",
            "300 20 0.5",
        ]
    };
    runs.extend(bias.iter().map(|kbm| {
        words(&format!(
            "run --release -q -p pam-eval --example impedance_bias -- {kbm} 1 30"
        ))
    }));
    runs
}

fn host_model_runs(quick: bool) -> Vec<Vec<String>> {
    if quick {
        return Vec::new();
    }
    vec![words("bench -p pam-model")]
}

fn fuzz_runs(quick: bool) -> Vec<Vec<String>> {
    let runs = if quick { 100_000 } else { 10_000_000 };
    crate::fuzz::TARGETS
        .iter()
        .map(|(t, _)| {
            words(&format!(
                "xtask fuzz --target {t} --runs {runs} --sanitizer none"
            ))
        })
        .collect()
}

fn fuzz_rate_runs(quick: bool) -> Vec<Vec<String>> {
    let seconds = if quick { 10 } else { 60 };
    vec![words(&format!(
        "xtask fuzz --time {seconds} --sanitizer none"
    ))]
}

fn qemu_runs(_quick: bool) -> Vec<Vec<String>> {
    vec![words("xtask qemu-bench")]
}

const SECTIONS: &[Section] = &[
    Section {
        name: "synth",
        title: "The model loop on the second generator",
        intro: "Each run draws a balanced plan of logs from pam-synth (every fourth a control) and \
judges the loop's diagnosis, through its JSON, against the hidden truth (`pam_eval::judge`). \
\"Named\" counts logs whose hidden family the loop named first or listed in `ambiguous`; \
\"false alarms\" counts controls for which it named an effect. Below the rows, the first run's \
confusion matrix (rows: the truth; columns: what the loop named first).",
        kind: Kind::Confusion,
        runs: confusion_runs,
    },
    Section {
        name: "physgen",
        title: "The model loop on the physics generator, judged strictly",
        intro: "Each run draws logs from pam-physgen (the rig's physics: rigid-body arm with its \
Coriolis terms, muscles as gas volumes behind their regulators, LuGre, Maxwell-slip and Bouc–Wen, \
a load cell with white, 1/f and autoregressive noise and a tare fixed in the sensor frame, four \
converters that differ; about a quarter controls) and judges the final model strictly \
(`pam_eval::strict`): right only with the right verdict, the right first family and no family in \
the final model that is not in the log; a false alarm is a control whose verdict is not `none`. \
\"Stacked\" counts logs whose first family is right but whose final model holds another.",
        kind: Kind::Tables,
        runs: physgen_runs,
    },
    Section {
        name: "crossgen",
        title: "Calibrated on one generator, validated on the others",
        intro: "The decision's two thresholds on a grid: the refinement gate `min_family_gain` (a \
family after the first enters the final model only if it removes that share of the base's error \
beyond another shape of a family already in it) and the step delay's floor `converter_lag_s` (a \
step delay shorter than it is the converters' own lag), over the same logs of pam-physgen, pam-synth and the twin (`pamctl simulate \
--with SPEC`'s effects, two magnitudes, Table 4.1's points at 1 and 10 ms, step poses within ±10° at 10 ms), judged \
strictly. The second table picks the point best on one generator (most logs strictly right, then \
fewest false alarms) and scores it on each of the others.",
        kind: Kind::Tables,
        runs: crossgen_runs,
    },
    Section {
        name: "suites",
        title: "The accuracy suites",
        intro: "The full accuracy suites of pam-eval: 3 × 80 short pam-synth logs held to floors \
(`synth_matrix`), and every twin effect at two magnitudes, sampling periods and noise levels \
(`twin_loop`). `cargo test` runs a fast subset of each as a regression floor.",
        kind: Kind::Suites,
        runs: suite_runs,
    },
    Section {
        name: "friction-pairs",
        title: "Friction or hysteresis, from two stiffness levels",
        intro: "The same dynamic trial at Table 4.1's K_low and K_high, with friction (pam-physgen: \
LuGre or Maxwell-slip in the joints, LuGre at the handle; the twin: the carrier ball) or with the \
muscles' hysteresis (pam-physgen: Bouc–Wen growing with pressure; the twin: a share of the \
muscles' force), decided by `pam_model_loop::stiffness_pair` (`pamctl model diagnose A.csv \
B.csv`): friction keeps its torque, hysteresis grows with the pressure. One log cannot tell the \
two apart. \"Cannot tell\" counts as wrong.",
        kind: Kind::Tables,
        runs: friction_pair_runs,
    },
    Section {
        name: "speed",
        title: "Speed of the model loop",
        intro: "Criterion's estimate of one `diagnose` (low, estimate, high).",
        kind: Kind::Lines(&["time:"]),
        runs: speed_runs,
    },
    Section {
        name: "force-steps",
        title: "Closed-loop force steps (§5.2, nine poses)",
        intro: "The §5.2 force steps at the nine poses on the twin, seed 0, 24 steps a pose. 5 % \
settling to the new steady value; overshoot beyond it; step gain g = Δsteady/Δreference; \
\"other axis\" is the worst steady error on the axis that did not step; \"out of reach\" counts \
the steps to or from a level the loop scaled (`Limited::TARGET`), with their worst overshoot.",
        kind: Kind::Rows(
            "| twin, mode | settling worst (s) | settling mean (s) | overshoot worst (%) | mean \\|g − 1\\| | gain range | other axis (N) | out of reach | poses faulted |\n|---|---|---|---|---|---|---|---|---|",
        ),
        runs: force_step_runs,
    },
    Section {
        name: "margins",
        title: "Closed-loop margins",
        intro: "A frequency sweep of L = C·g·H·e^(−sτ), the designed PID with its derivative filter; \
the arguments scale the integral and all gains (`-- KI_SCALE [GAIN_SCALE]`).",
        kind: Kind::Tables,
        runs: margin_runs,
    },
    Section {
        name: "impedance",
        title: "Impedance rendering",
        intro: "Impedance mode on the twin at point 1, 30 s of the scripted operator (0.1–2 Hz, \
±4 cm); K, B, M identified by the dynamic trial's fit. `impedance_check` sweeps K at B = 5; \
`impedance_bias -- K B M` renders one virtual impedance.",
        kind: Kind::Tables,
        runs: impedance_runs,
    },
    Section {
        name: "host-model",
        title: "The robot model on the host",
        intro: "Criterion's estimate of one full model evaluation of both joints (low, estimate, \
high), in f32 as on the target and in f64 as on the host. The firmware's flash and static RAM \
are printed by `cargo xtask firmware` and `./test.sh`.",
        kind: Kind::Lines(&["time:"]),
        runs: host_model_runs,
    },
    Section {
        name: "qemu",
        title: "The robot model on the target",
        intro: "Instruction counts on the Cortex-M4F in QEMU (`-icount shift=0`) and the f32 model \
against the f64 reference, with libm and with micromath. The budget is 5000 instructions per \
control step, checked by the QEMU suite.",
        kind: Kind::Lines(&["] bench", "] precision"]),
        runs: qemu_runs,
    },
    Section {
        name: "fuzz",
        title: "Fuzzing runs",
        intro: "cargo-fuzz with libFuzzer, release builds without a sanitizer, one worker each; new units go to a scratch corpus in the target directory and the seed corpus is only read (docs/fuzzing.md). Each run's last line: executions, seconds, the average rate and the crashes.",
        kind: Kind::Lines(&["executions in"]),
        runs: fuzz_runs,
    },
    Section {
        name: "fuzz-rate",
        title: "Fuzzing rates on an idle machine",
        intro: "A minute per target with nothing else running (the load average is on each line): \
the rate a target reaches alone. On this 2-core machine a build on the other core more than \
halves it, so the long runs above, made beside other work, are slower.",
        kind: Kind::Lines(&["executions in"]),
        runs: fuzz_rate_runs,
    },
];

const PAGE_HEAD: &str = "# Results\n\n**Generated by `cargo xtask eval`; do not edit by hand.** \
Every section says when it was measured, on which commit and with which commands, so anyone can \
run it again (`cargo xtask eval --only NAME` makes one section). The reference pages \
([model-loop.md](model-loop.md), [closed-loop.md](closed-loop.md), [impedance.md](impedance.md)) \
say how things work. The machine is a shared 2-core host; timings move by ±15 % from run to run.\n";

pub fn eval(args: &[String]) -> i32 {
    let quick = args.iter().any(|a| a == "--quick");
    let only = args
        .iter()
        .position(|a| a == "--only")
        .map(|i| args.get(i + 1).cloned().unwrap_or_default());
    if args.iter().any(|a| a == "--list") {
        for s in SECTIONS {
            println!("{:12} {}", s.name, s.title);
        }
        return 0;
    }
    let wanted: Option<Vec<&str>> = only.as_deref().map(|o| o.split(',').collect());
    let unknown = wanted.as_ref().is_some_and(|w| {
        w.iter()
            .any(|name| !SECTIONS.iter().any(|s| s.name == *name))
    });
    let chosen: Vec<&Section> = SECTIONS
        .iter()
        .filter(|s| wanted.as_ref().is_none_or(|w| w.contains(&s.name)))
        .collect();
    if chosen.is_empty() || unknown {
        eprintln!(
            "usage: cargo xtask eval [--quick] [--only NAME[,NAME...]] [--list]; NAME is one of:"
        );
        for s in SECTIONS {
            eprintln!("  {}", s.name);
        }
        return 2;
    }
    let stamp = stamp();
    let started = Instant::now();
    let mut failed = false;
    let mut blocks = Vec::new();
    for (k, s) in chosen.iter().enumerate() {
        eprintln!(
            "== eval [{}/{}] {}: {} ({:.0} s so far)",
            k + 1,
            chosen.len(),
            s.name,
            s.title,
            started.elapsed().as_secs_f64()
        );
        let (md, ok) = section(s, quick, &stamp);
        failed |= !ok;
        blocks.push((s.name, md));
    }
    eprintln!(
        "== eval: {} section(s) in {:.0} s",
        blocks.len(),
        started.elapsed().as_secs_f64()
    );
    if quick {
        for (_, md) in &blocks {
            println!("{md}");
        }
    } else if let Err(e) = write_page(&root().join("docs/results.md"), &blocks, only.is_some()) {
        eprintln!("xtask: writing docs/results.md: {e}");
        return 1;
    } else {
        eprintln!("== eval: docs/results.md written");
    }
    i32::from(failed)
}

/// `YYYY-MM-DD, <commit>` (with `+changes` when the tree, the results page aside, differs
/// from the commit).
fn stamp() -> String {
    let out = |cmd: &mut Command| {
        cmd.current_dir(root())
            .output()
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
            .unwrap_or_default()
    };
    let date = out(Command::new("date").args(["-u", "+%F"]));
    let commit = out(Command::new("git").args(["rev-parse", "--short", "HEAD"]));
    // the page itself is left out: a run of several `--only` writes it before the next
    let dirty = !out(Command::new("git").args([
        "status",
        "--porcelain",
        "--untracked-files=no",
        "--",
        ".",
        ":!docs/results.md",
    ]))
    .is_empty();
    format!("{date}, {commit}{}", if dirty { " +changes" } else { "" })
}

/// Runs a section's commands; returns its markdown and whether every command succeeded.
fn section(s: &Section, quick: bool, stamp: &str) -> (String, bool) {
    let runs = (s.runs)(quick);
    let mut ok = true;
    let mut body = String::new();
    let mut rows = Vec::new();
    let mut first_matrix = None;
    for (i, args) in runs.iter().enumerate() {
        eprintln!("-- [{}/{}] cargo {}", i + 1, runs.len(), args.join(" "));
        let t = Instant::now();
        let (code, lines) = run_streaming(cargo_in(&root()).args(args));
        let seconds = t.elapsed().as_secs_f64();
        ok &= code == 0;
        let failed_note = if code == 0 { "" } else { " (FAILED)" };
        match s.kind {
            Kind::Confusion => {
                rows.push(confusion_row(args, &lines, seconds, failed_note));
                if first_matrix.is_none() {
                    first_matrix = Some(table_lines(&lines));
                }
            }
            Kind::Suites => rows.extend(suite_rows(args, &lines, failed_note)),
            Kind::Rows(_) => rows.extend(
                table_lines(&lines)
                    .into_iter()
                    .map(|r| format!("{r} `{}`{failed_note} |", after_dashes(args))),
            ),
            Kind::Tables => {
                body.push_str(&format!("`{}`{failed_note}\n\n", after_dashes(args)));
                body.push_str(&table_lines(&lines).join("\n"));
                body.push_str("\n\n");
            }
            Kind::Lines(words) => {
                body.push_str("```text\n");
                for (i, l) in lines.iter().enumerate() {
                    if !words.iter().any(|w| l.contains(w)) {
                        continue;
                    }
                    // criterion puts a long name on a line of its own, the figures indented
                    // on the next: keep the name with them
                    if l.starts_with(char::is_whitespace) && i > 0 {
                        body.push_str(lines[i - 1].trim_end());
                        body.push('\n');
                    }
                    body.push_str(l.trim_end());
                    body.push('\n');
                }
                body.push_str(&format!("```\n{}\n", failed_note.trim()));
            }
        }
    }
    let commands: Vec<String> = runs
        .iter()
        .map(|a| format!("cargo {}", a.join(" ")))
        .collect();
    let mut md = format!(
        "<!-- eval:{} -->\n## {}\n\n{}\n\nMeasured {stamp}{} by `cargo xtask eval --only {}`:\n\n```sh\n{}\n```\n\n",
        s.name,
        s.title,
        s.intro,
        if quick { " (quick plans)" } else { "" },
        s.name,
        commands.join("\n")
    );
    match s.kind {
        Kind::Confusion => {
            md.push_str(
                "| run | named | false alarms | median s/log | wall s |\n|---|---|---|---|---|\n",
            );
            md.push_str(&rows.join("\n"));
            md.push_str("\n\nThe first run's confusion matrix:\n\n");
            md.push_str(&first_matrix.unwrap_or_default().join("\n"));
            md.push('\n');
        }
        Kind::Suites => {
            md.push_str("| suite | passed | failed | seconds |\n|---|---|---|---|\n");
            md.push_str(&rows.join("\n"));
            md.push('\n');
        }
        Kind::Rows(header) => {
            md.push_str(&header.replacen(" |\n", " | command |\n", 1));
            md.push_str("---|\n");
            md.push_str(&rows.join("\n"));
            md.push('\n');
        }
        Kind::Tables | Kind::Lines(_) => md.push_str(body.trim_end()),
    }
    md.push_str(&format!("\n<!-- /eval:{} -->\n", s.name));
    (md, ok)
}

/// The arguments after `--` (the example's own), or all of them.
fn after_dashes(args: &[String]) -> String {
    let own = match args.iter().position(|a| a == "--") {
        Some(i) => args[i + 1..].join(" "),
        None if args.first().is_some_and(|a| a == "run") => String::new(),
        None => args.join(" "),
    };
    if own.is_empty() {
        "(no arguments)".into()
    } else {
        own
    }
}

fn table_lines(lines: &[String]) -> Vec<String> {
    lines
        .iter()
        .filter(|l| l.starts_with('|'))
        .cloned()
        .collect()
}

/// One row from the confusion example's summary (`accuracy a/b = …`, `  dynamic: …`,
/// `false alarms over controls: x/y = …`, `seconds per log: median m, …`).
fn confusion_row(args: &[String], lines: &[String], wall_s: f64, note: &str) -> String {
    let after = |prefix: &str| {
        lines
            .iter()
            .find_map(|l| l.trim_start().strip_prefix(prefix).map(str::trim))
            .unwrap_or("—")
            .to_string()
    };
    let named = after("accuracy ");
    let named = named.split(" (").next().unwrap_or("—");
    let per_exp: Vec<String> = ["dynamic:", "step:"]
        .iter()
        .filter_map(|p| {
            lines
                .iter()
                .find(|l| l.trim_start().starts_with(p))
                .map(|l| l.trim().to_string())
        })
        .collect();
    let median = after("seconds per log: median ");
    let median = median.split(',').next().unwrap_or("—");
    format!(
        "| `{}`{note} | {named} ({}) | {} | {median} | {wall_s:.0} |",
        after_dashes(args).replace("--jobs 2 ", ""),
        per_exp.join(", "),
        after("false alarms over controls: ")
    )
}

/// One row per test binary (named by the command's `--test NAME`): passed, failed, seconds.
fn suite_rows(args: &[String], lines: &[String], note: &str) -> Vec<String> {
    let name = args
        .iter()
        .position(|a| a == "--test")
        .and_then(|i| args.get(i + 1))
        .map_or("?", String::as_str);
    lines
        .iter()
        .filter(|l| l.starts_with("test result:"))
        .map(|l| {
            let (p, f) = crate::cargo_test_counts(std::slice::from_ref(l));
            let secs = l
                .rsplit("finished in ")
                .next()
                .map(|s| s.trim_end_matches('s').trim().to_string())
                .unwrap_or_default();
            format!("| `{name}`{note} | {p} | {f} | {secs} |")
        })
        .collect()
}

/// Writes the page: the head, then each section in the order of [`SECTIONS`], from this
/// run's blocks or (`partial`) from the page's last generated text between its markers.
/// Text outside the markers is not kept: the page holds only what a command wrote.
fn write_page(path: &Path, blocks: &[(&str, String)], partial: bool) -> std::io::Result<()> {
    let old = if partial {
        std::fs::read_to_string(path).unwrap_or_default()
    } else {
        String::new()
    };
    std::fs::write(path, assemble(&old, blocks))
}

/// The page from this run's blocks and the old page's marked sections.
fn assemble(old: &str, blocks: &[(&str, String)]) -> String {
    let mut page = PAGE_HEAD.to_string();
    for s in SECTIONS {
        let new = blocks
            .iter()
            .find(|(n, _)| *n == s.name)
            .map(|(_, md)| md.clone());
        if let Some(md) = new.or_else(|| marked(old, s.name)) {
            page.push('\n');
            page.push_str(md.trim_end());
            page.push('\n');
        }
    }
    page
}

/// A section's text on a page, its markers included.
fn marked(page: &str, name: &str) -> Option<String> {
    let (open, close) = (
        format!("<!-- eval:{name} -->"),
        format!("<!-- /eval:{name} -->"),
    );
    let a = page.find(&open)?;
    let b = page[a..].find(&close)? + a;
    Some(page[a..b + close.len()].to_string())
}

#[cfg(test)]
mod tests {
    use super::{assemble, PAGE_HEAD, SECTIONS};

    fn block(name: &str, body: &str) -> String {
        format!("<!-- eval:{name} -->\n## {name}\n\n{body}\n<!-- /eval:{name} -->\n")
    }

    #[test]
    fn a_partial_run_keeps_the_other_sections_in_their_order_and_drops_unmarked_text() {
        let old = format!(
            "# Old head\n\nhand-written prose\n\n{}\nmore prose\n{}",
            block("qemu", "old counts"),
            block("synth", "old matrix")
        );
        let page = assemble(&old, &[("speed", block("speed", "new times"))]);
        assert!(page.starts_with(PAGE_HEAD));
        assert!(!page.contains("hand-written") && !page.contains("more prose"));
        let at = |name: &str| page.find(&format!("<!-- eval:{name} -->")).unwrap();
        assert!(at("synth") < at("speed") && at("speed") < at("qemu"));
        assert!(page.contains("old counts") && page.contains("new times"));
        assert!(page.contains("old matrix"));
    }

    #[test]
    fn a_rerun_section_replaces_its_old_text() {
        let old = block("speed", "slow");
        let page = assemble(&old, &[("speed", block("speed", "fast"))]);
        assert!(page.contains("fast") && !page.contains("slow"));
        assert_eq!(page.matches("<!-- eval:speed -->").count(), 1);
    }

    #[test]
    fn section_names_are_unique() {
        for (i, s) in SECTIONS.iter().enumerate() {
            assert!(
                SECTIONS[i + 1..].iter().all(|t| t.name != s.name),
                "{}",
                s.name
            );
        }
    }
}
