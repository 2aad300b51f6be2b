//! The model loop on logs from an independent generator (`pam-synth`, not built with the
//! loop): 80 short logs at mixed sampling periods, both experiments, about a quarter
//! controls. The targets are ≥ 95 % right and false alarms ≤ 5 % over the controls;
//! on these short logs the loop reached 82.5 % and 3 of 20 (2026-11-23), 95.0 % and 0 of
//! 20 (2026-11-24) and 97.5 % and 0 of 20 (seventh session); this test holds the level as a floor ([`FLOOR_ACCURACY`],
//! [`CEILING_FALSE_ALARMS`]). The matrix is printed so a failing run shows what the loop
//! confused. The full run (longer logs, as a rig records them):
//! `cargo run -p pam-ident --release --example confusion -- --logs 300`.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

use pam_ident::diagnose::{diagnose, Settings};
use pam_ident::effects::Experiment as LoopExperiment;
use pam_ident::Trial;
use pam_model::RobotModel;
use pam_synth::judge::{self, CaseResult, LoopSays, Outcome};
use pam_synth::{generate, CaseSpec, Experiment};

const CASES: usize = 80;
/// Measured 97.5 % right and 0/20 false alarms (seventh session: the fold test's level
/// calibrated, the wander's variance ratio; 95.0 % in the fourth, 86.2 % and 2/20 before,
/// 82.5 % and 3/20 earlier): the floor the loop must not fall below, two logs under today.
const FLOOR_ACCURACY: f64 = 0.95;
const CEILING_FALSE_ALARMS: f64 = 0.05;
/// The targets, printed next to the result.
const TARGET_ACCURACY: f64 = 0.95;
const TARGET_FALSE_ALARMS: f64 = 0.05;
const SEED0: u64 = 20_000;
/// Short logs keep the test within CI's budget: at most this long and this many samples.
const MAX_DURATION_S: f64 = 45.0;
const MAX_SAMPLES: f64 = 25_000.0;

fn run_case(spec: &CaseSpec) -> CaseResult {
    let g = generate(spec).expect("generating");
    let exp = match spec.experiment {
        Experiment::Dynamic => LoopExperiment::Dynamic,
        Experiment::Step => LoopExperiment::Step,
    };
    let start = Instant::now();
    let said = pam_log::read_str(&g.log_text, None)
        .map_err(|e| e.to_string())
        .and_then(|log| Trial::from_log(&log).map_err(|e| e.to_string()))
        .and_then(|t| {
            diagnose(&t, &RobotModel::thesis(), exp, Settings::default()).map_err(|e| e.to_string())
        })
        .and_then(|(d, _)| serde_json::to_value(&d).map_err(|e| e.to_string()));
    let seconds = start.elapsed().as_secs_f64();
    let (says, error) = match said {
        Ok(v) => (judge::read(&v), None),
        Err(e) => (
            LoopSays {
                verdict: "error".into(),
                ..Default::default()
            },
            Some(e),
        ),
    };
    CaseResult {
        outcome: if error.is_some() {
            Outcome::Wrong
        } else {
            judge::judge(&g.truth, &says)
        },
        truth: g.truth,
        says,
        seconds,
        error,
    }
}

#[test]
fn loop_names_the_hidden_effect_of_independent_logs() {
    let specs: Vec<CaseSpec> = judge::plan(CASES, SEED0, None)
        .into_iter()
        .map(|mut c| {
            c.duration_s = c
                .duration_s
                .min(MAX_DURATION_S)
                .min(MAX_SAMPLES * c.dt_s)
                .round();
            c
        })
        .collect();
    let next = AtomicUsize::new(0);
    let results: Mutex<Vec<Option<CaseResult>>> = Mutex::new(vec![None; specs.len()]);
    std::thread::scope(|s| {
        for _ in 0..2 {
            s.spawn(|| loop {
                let i = next.fetch_add(1, Ordering::SeqCst);
                if i >= specs.len() {
                    break;
                }
                let r = run_case(&specs[i]);
                results.lock().unwrap()[i] = Some(r);
            });
        }
    });
    let results: Vec<CaseResult> = results
        .into_inner()
        .unwrap()
        .into_iter()
        .flatten()
        .collect();
    for r in &results {
        println!("{}", judge::case_line(r));
    }
    println!("\n{}", judge::report(&results));
    let s = judge::summarise(&results);
    println!(
        "accuracy {:.1} % (target ≥ {:.0} %), false alarms {:.1} % (target ≤ {:.0} %)",
        100.0 * s.accuracy(),
        100.0 * TARGET_ACCURACY,
        100.0 * s.false_alarm_rate(),
        100.0 * TARGET_FALSE_ALARMS
    );
    assert!(
        s.accuracy() >= FLOOR_ACCURACY && s.false_alarm_rate() <= CEILING_FALSE_ALARMS + 1e-9,
        "accuracy {:.1} % (floor {:.0} %), false alarms {:.1} % (ceiling {:.0} %)",
        100.0 * s.accuracy(),
        100.0 * FLOOR_ACCURACY,
        100.0 * s.false_alarm_rate(),
        100.0 * CEILING_FALSE_ALARMS
    );
}
