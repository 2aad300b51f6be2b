//! Run a twin trial: the §4.2 dynamic trial at Table 4.1's first point, on the thesis's rig
//! with one hidden effect, written as a log (format v1) that `pamctl model diagnose` reads.
//!
//! ```sh
//! cargo run -p pam-twin --example twin_trial -- trial.csv carrier_ball_friction
//! ```
//!
//! The effect is a catalog id, `id:param=value,...` or nothing (`pamctl simulate
//! --list-effects` lists them); the seed fixes the twin's noise and operator.

use pam_twin::experiments::{dynamic_trial, ExperimentConfig, StiffnessLevel};
use pam_twin::{EffectSet, TwinConfig};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let out = args.next().unwrap_or_else(|| "trial.csv".into());
    let effect = args.next();

    let mut twin = TwinConfig::thesis();
    twin.seed = 1;
    if let Some(spec) = &effect {
        twin.effects = EffectSet::parse_list(&[spec.as_str()])?;
    }
    let mut cfg = ExperimentConfig::new(twin);
    cfg.period_s = 0.01; // 100 Hz: a short log that still shows the dynamics

    let log = dynamic_trial(&cfg, 1, StiffnessLevel::Low, 30.0)?;
    log.write_path(&out)?;
    println!(
        "{} rows of a 30 s dynamic trial ({}) written to {out}",
        log.len(),
        effect.as_deref().unwrap_or("no hidden effect")
    );
    Ok(())
}
