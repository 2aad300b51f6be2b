//! Diagnose a log from Rust: read a log (format v1), prepare it as a trial and ask the model
//! loop which physical effect the thesis's model lacks, then print the diagnosis as the JSON
//! `pamctl model diagnose --json` writes.
//!
//! ```sh
//! cargo run -p pam-twin --example twin_trial -- trial.csv carrier_ball_friction
//! cargo run -p pam-model-loop --release --example diagnose_log -- trial.csv dynamic
//! ```
//!
//! The experiment is `dynamic` (the §4.2 trial, the default) or `step` (the §5.2 force steps).

use pam_ident::Trial;
use pam_model::RobotModel;
use pam_model_loop::diagnose::{diagnose, Settings};
use pam_model_loop::effects::Experiment;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let path = args
        .next()
        .ok_or("usage: diagnose_log LOG.csv [dynamic|step]")?;
    let experiment = match args.next().as_deref() {
        None | Some("dynamic") => Experiment::Dynamic,
        Some("step") => Experiment::Step,
        Some(other) => return Err(format!("unknown experiment {other:?}").into()),
    };

    let log = pam_log::read_path(&path)?;
    let trial = Trial::from_log(&log)?;
    let (diagnosis, _fits) = diagnose(
        &trial,
        &RobotModel::thesis(),
        experiment,
        Settings::default(),
    )?;

    eprintln!("verdict: {:?}", diagnosis.verdict);
    println!("{}", serde_json::to_string_pretty(&diagnosis)?);
    Ok(())
}
