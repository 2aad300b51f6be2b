//! The strict judgement: what the user takes home is the final model, so a diagnosis is
//! right only with the right verdict, the right first family, and no family in the final
//! model that is not in the log. Read through the diagnosis's JSON only, like [`crate::judge`],
//! and on the truth's family name only, so every generator (pam-synth, the twin, pam-physgen)
//! is scored by the same rule.

use std::collections::BTreeMap;

use serde::Serialize;
use serde_json::Value;

/// What the loop said, strictly: the verdict, the first family and the final model's
/// families in order.
#[derive(Clone, Debug, Default, Serialize)]
pub struct FinalModel {
    /// `effect`, `none`, `unexplained` (or `error`).
    pub verdict: String,
    /// The family of `effects[0]` when the verdict is `effect`.
    pub first: Option<String>,
    /// The families of the effects in the last step of the sequence (the final model), in
    /// the order they entered.
    pub families: Vec<String>,
    /// The families the log cannot tell apart (the first is `first`), when the diagnosis
    /// names the experiment that would.
    pub undecided: Vec<String>,
    /// A step trial: the steps the log has and the fewest steps any family it has too few
    /// to decide on would need (the same trial, longer, is the experiment that decides).
    pub more_steps: Option<(usize, usize)>,
    /// A step trial: the families the log cannot tell from the converters' spread (the
    /// same trial at another co-contraction is the experiment that decides).
    pub within_spread: Vec<String>,
}

impl FinalModel {
    /// Whether the diagnosis says the log cannot tell `family` from another (with the
    /// experiment that would).
    pub fn left_open(&self, family: &str) -> bool {
        self.undecided.iter().any(|u| u == family)
    }

    /// Whether the diagnosis leaves friction against hysteresis open: the same trial at
    /// the other stiffness level decides it (`pam_model_loop::stiffness_pair`).
    pub fn awaits_stiffness_pair(&self) -> bool {
        self.verdict == "effect" && self.left_open("friction") && self.left_open("hysteresis")
    }

    /// Whether the diagnosis leaves a family within the converters' spread: the same step
    /// trial at another co-contraction decides it (`pam_model_loop::spread_pair`).
    pub fn awaits_co_contraction_pair(&self) -> bool {
        !self.within_spread.is_empty()
    }

    /// The final model once the step trial at another co-contraction has named `family`
    /// beyond the converters' spread: it comes first, before what the log had named.
    /// Unchanged when the pair named nothing, or a family the log did not hide.
    pub fn beyond_spread(&self, family: Option<&str>) -> FinalModel {
        let Some(named) = family.filter(|f| self.within_spread.iter().any(|w| w == f)) else {
            return self.clone();
        };
        let mut families = vec![named.to_string()];
        families.extend(self.families.iter().filter(|f| *f != named).cloned());
        FinalModel {
            verdict: "effect".into(),
            first: Some(named.to_string()),
            families,
            undecided: Vec::new(),
            more_steps: self.more_steps,
            within_spread: Vec::new(),
        }
    }

    /// The final model once the separating experiment has named `family`: it takes the
    /// place of every family left open, and nothing is left open. Unchanged when the
    /// experiment named nothing, or a family the diagnosis did not leave open.
    pub fn settled(&self, family: Option<&str>) -> FinalModel {
        let Some(named) = family.filter(|f| self.left_open(f)) else {
            return self.clone();
        };
        let mut families: Vec<String> = Vec::new();
        for f in &self.families {
            let f = if self.left_open(f) { named } else { f.as_str() };
            if !families.iter().any(|g| g == f) {
                families.push(f.to_string());
            }
        }
        FinalModel {
            verdict: self.verdict.clone(),
            first: self.first.as_ref().map(|f| {
                if self.left_open(f) {
                    named.to_string()
                } else {
                    f.clone()
                }
            }),
            families,
            undecided: Vec::new(),
            more_steps: self.more_steps,
            within_spread: self.within_spread.clone(),
        }
    }
}

/// Reads the final model from `serde_json::to_value(&diagnosis)`.
pub fn read(v: &Value) -> FinalModel {
    let verdict = v["verdict"].as_str().unwrap_or("?").to_string();
    let effects = v["effects"].as_array().cloned().unwrap_or_default();
    let family_of_effect = |id: &str| {
        effects.iter().find_map(|e| {
            let same = e["effect"].as_str() == Some(id)
                || e["other_shapes"]
                    .as_array()
                    .is_some_and(|o| o.iter().any(|s| s["effect"].as_str() == Some(id)));
            same.then(|| e["family"].as_str().unwrap_or(id).to_string())
        })
    };
    let families: Vec<String> = v["steps"]
        .as_array()
        .and_then(|s| s.last())
        .and_then(|s| s["effects"].as_array())
        .map(|ids| {
            ids.iter()
                .filter_map(Value::as_str)
                .map(|id| family_of_effect(id).unwrap_or_else(|| id.to_string()))
                .collect()
        })
        .unwrap_or_default();
    let first = (verdict == "effect")
        .then(|| effects.first().and_then(|e| e["family"].as_str()))
        .flatten()
        .map(str::to_string);
    let undecided = if v["separating_experiment"].is_string() {
        v["ambiguous"]
            .as_array()
            .map(|a| {
                a.iter()
                    .filter_map(Value::as_str)
                    .map(str::to_string)
                    .collect()
            })
            .unwrap_or_default()
    } else {
        Vec::new()
    };
    let more_steps = v["too_few_steps"].as_array().and_then(|a| {
        a.iter()
            .filter_map(|s| Some((s["steps"].as_u64()?, s["steps_needed"].as_u64()?)))
            .min_by_key(|&(_, need)| need)
            .map(|(have, need)| (have as usize, need as usize))
    });
    let within_spread = v["within_spread"]
        .as_array()
        .map(|a| {
            a.iter()
                .filter_map(|w| w["family"].as_str())
                .map(str::to_string)
                .collect()
        })
        .unwrap_or_default();
    FinalModel {
        verdict,
        first,
        families,
        undecided,
        more_steps,
        within_spread,
    }
}

/// How one log was judged strictly.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Strict {
    /// Right verdict, right first family, nothing else in the final model.
    Right,
    /// The right first family, with a family in the final model that is not in the log.
    Stacked,
    /// The right verdict, and the log's family among the ones the diagnosis says it cannot
    /// tell apart (with the experiment that would) but not first, nothing outside them in
    /// the final model: the honest answer where one log cannot decide (a joint's friction
    /// against the muscles' hysteresis at one stiffness level). Not counted as right. (With
    /// the log's family first among them, the judgement is `Right`, as the definition
    /// reads; [`Tally::decided`] counts apart the right ones the log did not leave open.)
    Undecided,
    /// The wrong verdict or the wrong first family.
    Wrong,
}

/// Judges the final model against the truth's family name (`none` for a control,
/// `unexplained` for structure outside the catalog).
pub fn judge(truth_family: &str, says: &FinalModel) -> Strict {
    match truth_family {
        "none" | "unexplained" => {
            if says.verdict == truth_family {
                Strict::Right
            } else {
                Strict::Wrong
            }
        }
        t => {
            if says.verdict == "effect"
                && says.first.as_deref() != Some(t)
                && says.left_open(t)
                && says.families.iter().all(|f| says.left_open(f))
            {
                Strict::Undecided
            } else if says.verdict != "effect" || says.first.as_deref() != Some(t) {
                Strict::Wrong
            } else if says.families.iter().any(|f| f != t) {
                Strict::Stacked
            } else {
                Strict::Right
            }
        }
    }
}

/// Totals of a strictly judged run.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Tally {
    pub cases: usize,
    pub right: usize,
    /// Right first family (or right verdict for a control / unexplained).
    pub first_right: usize,
    /// Strictly right, and the diagnosis did not say the log cannot tell the family from
    /// another: where it did, the family came first only by the order of a tie.
    pub decided: usize,
    pub stacked: usize,
    /// Not right, but the log's family among those the diagnosis says it cannot tell
    /// apart, with the experiment that would ([`Strict::Undecided`]).
    pub undecided: usize,
    pub controls: usize,
    /// Controls whose verdict is not `none`.
    pub false_alarms: usize,
    /// What the controls' false alarms said (the verdict, or the family named first).
    pub alarms: BTreeMap<String, usize>,
    /// Per truth family: (strictly right, cases).
    pub per_family: BTreeMap<String, (usize, usize)>,
}

impl Tally {
    pub fn add(&mut self, truth_family: &str, says: &FinalModel) -> Strict {
        let s = judge(truth_family, says);
        self.cases += 1;
        self.right += usize::from(s == Strict::Right);
        self.decided += usize::from(s == Strict::Right && !says.left_open(truth_family));
        self.first_right += usize::from(matches!(s, Strict::Right | Strict::Stacked));
        self.undecided += usize::from(s == Strict::Undecided);
        self.stacked += usize::from(s == Strict::Stacked);
        if truth_family == "none" {
            self.controls += 1;
            if says.verdict != "none" {
                self.false_alarms += 1;
                let what = says.first.clone().unwrap_or_else(|| says.verdict.clone());
                *self.alarms.entry(what).or_default() += 1;
            }
        }
        let e = self.per_family.entry(truth_family.to_string()).or_default();
        e.0 += usize::from(s == Strict::Right);
        e.1 += 1;
        s
    }

    pub fn accuracy(&self) -> f64 {
        self.right as f64 / self.cases.max(1) as f64
    }

    pub fn false_alarm_rate(&self) -> f64 {
        self.false_alarms as f64 / self.controls.max(1) as f64
    }

    /// `a/b = x %`.
    pub fn ratio(a: usize, b: usize) -> String {
        format!("{a}/{b} = {:.0} %", 100.0 * a as f64 / b.max(1) as f64)
    }

    /// What the controls' false alarms said, `drift 2, unexplained 1`.
    pub fn alarms_said(&self) -> String {
        if self.alarms.is_empty() {
            return "—".into();
        }
        self.alarms
            .iter()
            .map(|(k, n)| format!("{k} {n}"))
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// Per truth family, `friction 3/8, delay 1/4`.
    pub fn per_family_said(&self) -> String {
        self.per_family
            .iter()
            .map(|(k, (r, n))| format!("{k} {r}/{n}"))
            .collect::<Vec<_>>()
            .join(", ")
    }
}

#[cfg(test)]
mod tests {
    use super::{judge, read, Strict, Tally};
    use serde_json::json;

    fn diagnosis(verdict: &str, first: &str, final_ids: &[&str]) -> serde_json::Value {
        json!({
            "verdict": verdict,
            "effects": [
                {"family": first, "effect": "a_shape", "other_shapes": [{"effect": "b_shape"}]},
                {"family": "hysteresis", "effect": "maxwell_slip", "other_shapes": []},
            ],
            "steps": [{"effects": []}, {"effects": final_ids}],
        })
    }

    #[test]
    fn a_stacked_family_is_not_right() {
        let alone = read(&diagnosis("effect", "friction", &["a_shape"]));
        assert_eq!(alone.families, ["friction"]);
        assert_eq!(judge("friction", &alone), Strict::Right);
        let stacked = read(&diagnosis(
            "effect",
            "friction",
            &["b_shape", "maxwell_slip"],
        ));
        assert_eq!(stacked.families, ["friction", "hysteresis"]);
        assert_eq!(judge("friction", &stacked), Strict::Stacked);
        assert_eq!(judge("hysteresis", &stacked), Strict::Wrong);
    }

    #[test]
    fn a_log_that_cannot_decide_is_undecided_only_with_the_experiment_named() {
        let mut v = diagnosis("effect", "hysteresis", &["a_shape"]);
        v["ambiguous"] = json!(["hysteresis", "friction"]);
        assert_eq!(judge("friction", &read(&v)), Strict::Wrong);
        v["separating_experiment"] = json!("the other stiffness level");
        let says = read(&v);
        assert_eq!(judge("friction", &says), Strict::Undecided);
        assert_eq!(judge("hysteresis", &says), Strict::Right);
        assert_eq!(judge("drift", &says), Strict::Wrong);
        // a family outside the undecided ones in the final model
        let mut v = diagnosis("effect", "hysteresis", &["a_shape", "maxwell_slip"]);
        v["effects"][1]["family"] = json!("backlash");
        v["ambiguous"] = json!(["hysteresis", "friction"]);
        v["separating_experiment"] = json!("the other stiffness level");
        assert_eq!(judge("friction", &read(&v)), Strict::Wrong);
        let mut t = Tally::default();
        t.add("friction", &says);
        assert_eq!((t.right, t.first_right, t.undecided), (0, 0, 1));
        // right as the definition reads, but not decided: the log left it open
        t.add("hysteresis", &says);
        assert_eq!((t.right, t.decided, t.undecided), (1, 0, 1));
        t.add(
            "hysteresis",
            &read(&diagnosis("effect", "hysteresis", &["a_shape"])),
        );
        assert_eq!((t.right, t.decided), (2, 1));
    }

    #[test]
    fn the_separating_experiment_settles_what_the_log_left_open() {
        let mut v = diagnosis("effect", "hysteresis", &["a_shape"]);
        v["ambiguous"] = json!(["hysteresis", "friction"]);
        v["separating_experiment"] = json!("the other stiffness level");
        let says = read(&v);
        assert!(says.awaits_stiffness_pair());
        let friction = says.settled(Some("friction"));
        assert_eq!(friction.first.as_deref(), Some("friction"));
        assert_eq!(friction.families, ["friction"]);
        assert!(friction.undecided.is_empty() && !friction.awaits_stiffness_pair());
        assert_eq!(judge("friction", &friction), Strict::Right);
        assert_eq!(judge("hysteresis", &friction), Strict::Wrong);
        // the pair could not tell, or named a family the log did not leave open
        assert_eq!(judge("friction", &says.settled(None)), Strict::Undecided);
        assert_eq!(says.settled(Some("drift")).undecided, says.undecided);
        // a family the log did not leave open stays in the final model
        let mut v = diagnosis("effect", "hysteresis", &["a_shape", "maxwell_slip"]);
        v["effects"][1]["family"] = json!("backlash");
        v["ambiguous"] = json!(["hysteresis", "friction"]);
        v["separating_experiment"] = json!("the other stiffness level");
        let stacked = read(&v).settled(Some("friction"));
        assert_eq!(stacked.families, ["friction", "backlash"]);
        assert_eq!(judge("friction", &stacked), Strict::Stacked);
        // one log that decided needs no pair
        assert!(!read(&diagnosis("effect", "friction", &["a_shape"])).awaits_stiffness_pair());
    }

    #[test]
    fn a_control_is_right_only_when_none() {
        let mut t = Tally::default();
        t.add("none", &read(&diagnosis("none", "friction", &[])));
        t.add("none", &read(&diagnosis("effect", "drift", &["a_shape"])));
        assert_eq!((t.right, t.controls, t.false_alarms), (1, 2, 1));
        assert_eq!(t.alarms_said(), "drift 1");
    }
}
