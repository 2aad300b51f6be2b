//! `diagnose_observed` tells where it is: the base first (with the number of effects that
//! follow), every effect once, then the combination — what `pamctl model diagnose` shows as a
//! progress bar on a terminal.
mod common;

use common::*;
use pam_model::RobotModel;
use pam_model_loop::diagnose::{diagnose_observed, diagnose_with, Progress, Settings};
use pam_model_loop::effects::{self, Experiment};
use std::sync::Mutex;

#[test]
fn progress_reports_the_base_every_effect_once_and_the_combination() {
    let trial = dynamic(&DynConfig {
        duration_s: 30.0,
        ..Default::default()
    });
    let model = RobotModel::<f64>::thesis();
    let catalog = effects::catalog();
    let seen = Mutex::new(Vec::new());
    let (d, _) = diagnose_observed(
        &trial,
        &model,
        Experiment::Dynamic,
        Settings::default(),
        &catalog,
        &|p| seen.lock().unwrap().push(p),
    )
    .unwrap();
    let seen = seen.into_inner().unwrap();
    let Some(Progress::BaseFitted { effects: n }) = seen.first().copied() else {
        panic!("the base comes first: {seen:?}");
    };
    let applicable = catalog
        .iter()
        .filter(|e| e.applies(Experiment::Dynamic))
        .count();
    assert_eq!(n, applicable);
    let mut done: Vec<&str> = seen
        .iter()
        .filter_map(|p| match p {
            Progress::EffectDone { effect } => Some(*effect),
            _ => None,
        })
        .collect();
    assert_eq!(done.len(), n, "every effect once: {seen:?}");
    done.sort();
    done.dedup();
    assert_eq!(done.len(), n, "no effect twice: {seen:?}");
    assert_eq!(seen.last(), Some(&Progress::Combining));
    // observing changes nothing
    let (plain, _) = diagnose_with(
        &trial,
        &model,
        Experiment::Dynamic,
        Settings::default(),
        &catalog,
    )
    .unwrap();
    assert_eq!(
        serde_json::to_string(&d).unwrap(),
        serde_json::to_string(&plain).unwrap()
    );
}
