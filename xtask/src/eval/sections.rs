//! The results page's sections: what each runs (full, or the smaller `--quick` plans) and
//! how its output becomes markdown.

/// How a section turns its commands' output into markdown.
#[derive(Clone, Copy)]
pub(super) enum Kind {
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

pub(super) struct Section {
    pub(super) name: &'static str,
    pub(super) title: &'static str,
    pub(super) intro: &'static str,
    pub(super) kind: Kind,
    /// The cargo arguments of each run (`quick` selects the smaller plans).
    pub(super) runs: fn(quick: bool) -> Vec<Vec<String>>,
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
    // 400 logs a generator: a hundred controls (every fourth log), and a strict rate of
    // 70 % known to ±2.3 % (one binomial standard deviation), finer than the differences
    // between grid points it ranks. The
    // delay's floor stays at its default here: each value of it diagnoses every log again
    // (pam-physgen's step logs take 10–80 s each), which would make the section hours long;
    // `--lags 0,0.01,0.02` on the same command adds it to the grid.
    let logs = if quick { 8 } else { 400 };
    vec![crossgen(&format!(
        "--generators physgen,synth,twin --logs {logs} --seed0 720000 --gains 0.01,0.03,0.08"
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

pub(super) const SECTIONS: &[Section] = &[
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
\"Of them decided\" counts the strictly right logs whose diagnosis did not also say the log \
cannot tell the family from another: where it did, the right family came first by the order of a \
tie, which the definition still counts as right. \"Stacked\" counts logs whose first family is \
right but whose final model holds another; \
\"undecided\" counts logs, not right, whose family is among those the diagnosis says one log cannot \
tell apart, with the experiment that would (a joint's friction and the muscles' hysteresis at one \
stiffness level: \"stiffness pairs run\" and \"strictly right after them\" are the final model \
once that experiment was run and decided, as in the cross-generator section, where a step log \
with too few steps to decide is followed by the longer trial its diagnosis asks for, and one \
with a family within the converters' spread by the same steps at a higher co-contraction, as well). The second table counts \
the effect logs by their footprint, as the cross-generator section's does.",
        kind: Kind::Tables,
        runs: physgen_runs,
    },
    Section {
        name: "crossgen",
        title: "Calibrated on one generator, validated on the others",
        intro: "The decision's refinement gate `min_family_gain` on a grid (a family after the \
first enters the final model only if it removes that share of the base's error beyond another \
shape of a family already in it; two families within it of each other are ambiguous), over the \
same logs of pam-physgen, pam-synth and the twin (`pamctl simulate \
--with SPEC`'s effects, two magnitudes, Table 4.1's points at 1 and 10 ms, step poses within ±10° at 10 ms), judged \
strictly. Where a diagnosis says one log cannot tell a joint's friction from the muscles' \
hysteresis and names the same trial at the other stiffness level, the run makes that log with \
the generator (pam-physgen and the twin can; pam-synth has no stiffness level) and decides the \
pair as `pamctl model diagnose A.csv B.csv` does: \"stiffness pairs run\" counts them, \
\"strictly right after them\" scores the final model with the pair's family in place of the \
two left open. Where a step log has too few steps to decide and its diagnosis asks for about N \
(at most four times its own), the run makes the same trial that long (pam-physgen and pam-synth \
can; the twin's step test is its fixed 24 steps) and scores that log's final model instead: \
\"longer step trials run\" counts them, \"false alarms after them\" the controls then named. \
Where a step log's diagnosis cannot tell a family from the converters' spread, the run makes the \
same steps at a higher co-contraction (pam-physgen can: `pamctl experiment step --co-contraction \
high`'s protocol; pam-synth and the twin have no co-contraction to set) and decides the pair as \
`pamctl model diagnose A.csv B.csv` does (`pam_model_loop::spread_pair`): \"co-contraction pairs \
run\" counts them, and a family the pair names comes first in the final model scored after them. \
The second table counts the effect logs by their footprint: the RMS change the effect \
makes in the force over the force's spread, both axes pooled (`pam_eval::footprint`; pam-physgen \
and pam-synth report it, the twin's log is drawn again from the same seed without the effect). An \
effect under the model loop's materiality line (0.5 % of the signal) is one the protocol hardly \
exercises and no decision can name; the strict counts above take those logs as they are, and the \
table says how many of the misses they are. The third table picks the point best on one \
generator (most logs strictly right, then fewest false alarms) and scores it on each of the others.",
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
two apart. \"Cannot tell\" counts as wrong; in brackets, the pairs of which neither log shows a \
direction-dependent torque at all (the generator's effect too small, or a Bouc–Wen loop so far \
from saturation that the base's spring takes it up). The last column leaves those out.",
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
