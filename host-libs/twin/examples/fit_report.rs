//! Fits the eq. 4.30 mass-spring-damper to the point-1 dynamic trial (K_low) with each
//! catalog effect switched on alone, and with a slower pressure regulation, and prints the
//! matrices next to the thesis's. A diagnostic for the README's "Known gap" section.
//!
//! `cargo run -p pam-twin --release --example fit_report`

#[path = "../tests/common/mod.rs"]
mod common;

use pam_model::RobotModel;
use pam_twin::effects::{self, EffectSet};
use pam_twin::experiments::{dynamic_trial, ExperimentConfig, StiffnessLevel};

fn row(name: &str, cfg: &ExperimentConfig) {
    let model = RobotModel::new(cfg.twin.params);
    match dynamic_trial(cfg, 1, StiffnessLevel::Low, 90.0) {
        Ok(log) => {
            let f = common::fit_msd(&log, &model, [0.0; 2]);
            println!(
                "{name:<34} K {:6.1} {:6.1} {:6.1} | B {:6.1} {:6.1} {:6.1} | M {:6.2} {:6.2} {:6.2} | R² {:.2} {:.2}",
                f.k.0[0][0], f.k.0[0][1], f.k.0[1][1], f.b.0[0][0], f.b.0[0][1], f.b.0[1][1], f.m.0[0][0], f.m.0[0][1], f.m.0[1][1], f.r2[0], f.r2[1]
            );
        }
        Err(e) => println!("{name:<34} {e}"),
    }
}

fn main() {
    println!(
        "{:<34} K xx/xy/yy            | B xx/xy/yy           | M xx/xy/yy          ",
        ""
    );
    println!("{:<34} K  253.7  107.1  364.0 | B   26.6    9.4    0.9 | M   0.93  -0.05  -0.03 | R² 0.28–0.98", "thesis (temporal fit, §4.3)");
    println!("{:<34} K  145.9   73.5  387.0 |", "thesis (static trial)");
    row(
        "twin, base chain (thesis model)",
        &ExperimentConfig::thesis(),
    );
    row(
        "twin, identified rig",
        &ExperimentConfig::new(pam_twin::TwinConfig::identified_rig()),
    );
    for e in effects::catalog() {
        let mut cfg = ExperimentConfig::thesis();
        cfg.twin.effects = EffectSet::none().with(e.boxed_clone()).unwrap();
        row(&format!("+ {}", e.id()), &cfg);
    }
    for wn in [10.0, 5.0] {
        let mut cfg = ExperimentConfig::thesis();
        cfg.twin.params.ip.natural_freq_rad_s = wn;
        cfg.settle_s = 10.0;
        row(&format!("regulator ωn {wn} rad/s (not default)"), &cfg);
    }
    let mut cfg = ExperimentConfig::thesis();
    cfg.twin.pneumatics.polytropic_index = 0.0;
    row("isobaric muscles (no air dynamics)", &cfg);
}
