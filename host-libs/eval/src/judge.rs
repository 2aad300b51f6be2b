//! Judging the model loop against the truth, through the diagnosis's JSON only (so the
//! loop's Rust types can change freely), and the confusion matrix of many cases. Shared
//! by the `confusion` example and the `synth_matrix` suite.

use std::collections::BTreeMap;

use pam_effect_id::EffectId;
use serde::Serialize;
use serde_json::Value;

use pam_synth::case::Family;
use pam_synth::truth::Truth;

/// What the loop said, read from `serde_json::to_value(&diagnosis)`.
#[derive(Clone, Debug, Default, Serialize)]
pub struct LoopSays {
    /// `effect`, `none` or `unexplained`.
    pub verdict: String,
    /// The family of `effects[0]` when the verdict is `effect`.
    pub named: Option<String>,
    pub ambiguous: Vec<String>,
    pub top_improvement: Option<f64>,
}

fn name_of(v: &Value) -> Option<String> {
    match v {
        Value::String(s) => Some(s.clone()),
        Value::Object(o) => o.get("family").and_then(Value::as_str).map(str::to_string),
        _ => None,
    }
}

pub fn read(v: &Value) -> LoopSays {
    let verdict = v["verdict"].as_str().unwrap_or("?").to_string();
    let first = &v["effects"][0];
    let named = if verdict == "effect" {
        first["family"].as_str().map(str::to_string).or_else(|| {
            // a diagnosis without family names: its catalog id names the family
            first["id"].as_str().map(|id| {
                id.parse::<EffectId>()
                    .ok()
                    .and_then(EffectId::family)
                    .map_or(id.to_string(), |f| f.name().to_string())
            })
        })
    } else {
        None
    };
    let ambiguous = v["ambiguous"]
        .as_array()
        .map(|a| a.iter().filter_map(name_of).collect())
        .unwrap_or_default();
    LoopSays {
        verdict,
        named,
        ambiguous,
        top_improvement: first["improvement"].as_f64(),
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Outcome {
    Right,
    /// The loop named another family but listed the truth among those it cannot tell apart.
    RightAmbiguous,
    Wrong,
}

pub fn judge(truth: &Truth, says: &LoopSays) -> Outcome {
    let t = truth.family.name();
    let plain = match truth.family {
        Family::None => says.verdict == "none",
        Family::Unexplained => says.verdict == "unexplained",
        _ => says.verdict == "effect" && says.named.as_deref() == Some(t),
    };
    if plain {
        Outcome::Right
    } else if says.verdict == "effect" && says.ambiguous.iter().any(|a| a == t) {
        Outcome::RightAmbiguous
    } else {
        Outcome::Wrong
    }
}

/// One judged case.
#[derive(Clone, Debug, Serialize)]
pub struct CaseResult {
    pub truth: Truth,
    pub says: LoopSays,
    pub outcome: Outcome,
    pub seconds: f64,
    /// Set when the log could not be generated or diagnosed.
    pub error: Option<String>,
}

/// One line per case.
pub fn case_line(r: &CaseResult) -> String {
    let t = &r.truth;
    let mark = match r.outcome {
        Outcome::Right => "ok ",
        Outcome::RightAmbiguous => "ok~",
        Outcome::Wrong => "BAD",
    };
    format!(
        "{mark} seed {:>6} {:<7} {:<22} {:<20} dt {:>5.3} size {:>5.3} -> {:<11} {:<22} impr {:>6} {:>5.2}s{}{}",
        t.seed,
        t.experiment.name(),
        t.family.name(),
        t.shape.name(),
        t.dt_s,
        t.relative_size,
        r.says.verdict,
        r.says.named.as_deref().unwrap_or("-"),
        r.says
            .top_improvement
            .map(|x| format!("{x:.3}"))
            .unwrap_or("-".into()),
        r.seconds,
        if t.nuisances.is_none() {
            String::new()
        } else {
            format!("  [{}]", t.nuisances.describe())
        },
        r.error
            .as_ref()
            .map(|e| format!("  ERROR {e}"))
            .unwrap_or_default()
    )
}

/// Totals of a run.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Summary {
    pub cases: usize,
    pub right: usize,
    pub right_ambiguous: usize,
    pub controls: usize,
    pub false_alarms: usize,
    pub per_experiment: BTreeMap<String, (usize, usize)>,
    pub median_s: f64,
    pub max_s: f64,
}

impl Summary {
    pub fn accuracy(&self) -> f64 {
        (self.right + self.right_ambiguous) as f64 / self.cases.max(1) as f64
    }
    pub fn false_alarm_rate(&self) -> f64 {
        self.false_alarms as f64 / self.controls.max(1) as f64
    }
}

pub fn summarise(results: &[CaseResult]) -> Summary {
    let mut s = Summary {
        cases: results.len(),
        ..Default::default()
    };
    for r in results {
        let ok = r.outcome != Outcome::Wrong;
        match r.outcome {
            Outcome::Right => s.right += 1,
            Outcome::RightAmbiguous => s.right_ambiguous += 1,
            Outcome::Wrong => {}
        }
        if r.truth.family == Family::None {
            s.controls += 1;
            if r.says.verdict != "none" {
                s.false_alarms += 1;
            }
        }
        let e = s
            .per_experiment
            .entry(r.truth.experiment.name().to_string())
            .or_default();
        e.0 += ok as usize;
        e.1 += 1;
    }
    let mut secs: Vec<f64> = results.iter().map(|r| r.seconds).collect();
    secs.sort_by(f64::total_cmp);
    s.median_s = secs.get(secs.len() / 2).copied().unwrap_or(0.0);
    s.max_s = secs.last().copied().unwrap_or(0.0);
    s
}

/// The markdown confusion matrix (rows: experiment / truth; columns: what the loop said)
/// and the totals.
pub fn report(results: &[CaseResult]) -> String {
    let mut cols: Vec<String> = Family::ALL
        .iter()
        .filter(|f| !matches!(f, Family::None | Family::Unexplained))
        .map(|f| f.name().to_string())
        .collect();
    cols.extend(["none", "unexplained", "ambiguous", "other"].map(String::from));
    let mut rows: BTreeMap<(String, Family), BTreeMap<String, usize>> = BTreeMap::new();
    for r in results {
        let col = if r.outcome == Outcome::RightAmbiguous {
            "ambiguous".to_string()
        } else if r.says.verdict == "effect" {
            r.says.named.clone().unwrap_or("other".into())
        } else {
            r.says.verdict.clone()
        };
        let col = if cols.contains(&col) {
            col
        } else {
            "other".into()
        };
        *rows
            .entry((r.truth.experiment.name().to_string(), r.truth.family))
            .or_default()
            .entry(col)
            .or_default() += 1;
    }
    let short = |c: &str| match c {
        "stiffness_nonlinearity" => "stiff_nl".to_string(),
        "pose_dependence" => "pose".to_string(),
        "rate_limits" => "rates".to_string(),
        "saturation" => "satur".to_string(),
        "hysteresis" => "hyster".to_string(),
        "unexplained" => "unexpl".to_string(),
        "ambiguous" => "ambig".to_string(),
        c => c.to_string(),
    };
    let mut out = String::new();
    out.push_str("| truth | n | right |");
    for c in &cols {
        out.push_str(&format!(" {} |", short(c)));
    }
    out.push('\n');
    out.push_str(&"|---".repeat(cols.len() + 3));
    out.push_str("|\n");
    for ((exp, fam), counts) in &rows {
        let n: usize = counts.values().sum();
        let right = results
            .iter()
            .filter(|r| r.truth.experiment.name() == exp && r.truth.family == *fam)
            .filter(|r| r.outcome != Outcome::Wrong)
            .count();
        out.push_str(&format!("| {exp}/{} | {n} | {right} |", fam.name()));
        for c in &cols {
            match counts.get(c) {
                Some(k) => out.push_str(&format!(" {k} |")),
                None => out.push_str(" · |"),
            }
        }
        out.push('\n');
    }
    let s = summarise(results);
    out.push_str(&format!(
        "\naccuracy {}/{} = {:.1} % (plain right {}, right-ambiguous {})\n",
        s.right + s.right_ambiguous,
        s.cases,
        100.0 * s.accuracy(),
        s.right,
        s.right_ambiguous
    ));
    for (e, (ok, n)) in &s.per_experiment {
        out.push_str(&format!(
            "  {e}: {ok}/{n} = {:.1} %\n",
            100.0 * *ok as f64 / (*n).max(1) as f64
        ));
    }
    out.push_str(&format!(
        "false alarms over controls: {}/{} = {:.1} %\n",
        s.false_alarms,
        s.controls,
        100.0 * s.false_alarm_rate()
    ));
    out.push_str(&format!(
        "seconds per log: median {:.2}, max {:.2}\n",
        s.median_s, s.max_s
    ));
    out
}
