//! Impedance mode on the twin: the commanded virtual stiffness against the K that
//! `pamctl ident dynamic` identifies on the impedance trial's log, and the interaction force
//! in transparent mode (K = 0).
//!
//! ```sh
//! cargo run --release -p pam-eval --example impedance_check -- [POINT] [SECONDS] [EFFECT]
//! ```

use pam_ident::msd;
use pam_ident::trial::Trial;
use pam_ident::FilterSettings;
use pam_model::RobotModel;
use pam_numerics::stats::rms;
use pam_twin::experiments::{trial_stiffness, ExperimentConfig, StiffnessLevel};
use pam_twin::impedance_trial::{impedance_trial, VirtualImpedance};
use pam_twin::TwinConfig;

fn main() {
    let mut args = std::env::args().skip(1);
    let point: usize = args.next().map(|v| v.parse().expect("POINT")).unwrap_or(1);
    let seconds: f64 = args
        .next()
        .map(|v| v.parse().expect("SECONDS"))
        .unwrap_or(30.0);
    let effect: Option<String> = args.next();
    let model = RobotModel::<f64>::thesis();
    let alpha = pam_twin::experiments::TABLE_4_1_POINTS_DEG[point - 1].map(f64::to_radians);
    // the open loop's stiffest Cartesian K at the point (K_max per joint), for the scale
    let k_max_joint = [0, 1].map(|j| model.capability(j, alpha[j]).k_max.stiffness_nm_per_rad);
    let kc_max = model.cartesian_stiffness(alpha, k_max_joint).unwrap();
    let k_low = trial_stiffness(&model, alpha, StiffnessLevel::Low);
    let kc_min = model.cartesian_stiffness(alpha, k_low).unwrap();
    println!(
        "point {point}: open loop K_C at K_min diag ({:.0}, {:.0}) N/m, at K_max diag ({:.0}, {:.0}) N/m",
        kc_min.0[0][0], kc_min.0[1][1], kc_max.0[0][0], kc_max.0[1][1]
    );
    println!("| commanded K (N/m) | identified K_xx, K_yy (N/m) | error | B_xx, B_yy (N·s/m) | R² X, Y | RMS force (N) |");
    println!("|---|---|---|---|---|---|");
    let k_top = 1.5 * kc_max.0[0][0].max(kc_max.0[1][1]);
    for k in [0.0, 100.0, 300.0, 600.0, k_top.round()] {
        let mut twin = TwinConfig::thesis();
        if let Some(e) = &effect {
            twin.effects =
                pam_twin::EffectSet::parse_list(std::slice::from_ref(e)).expect("effect");
        }
        let cfg = ExperimentConfig::new(twin);
        let imp = VirtualImpedance {
            stiffness_n_per_m: [k, k],
            damping_n_s_per_m: [5.0, 5.0],
            mass_kg: [0.0, 0.0],
        };
        let log = match impedance_trial(&cfg, point, imp, seconds) {
            Ok(l) => l,
            Err(e) => {
                println!("| {k:.0} | faulted: {e} | | | | |");
                continue;
            }
        };
        let trial = Trial::from_log(&log).expect("trial");
        let p = trial
            .prepare(&model, FilterSettings::default())
            .expect("prepared");
        let f = msd::fit_dynamic(&p, model.cartesian_mass(p.alpha0_rad));
        let km = f
            .matrices
            .iter()
            .find(|m| m.name.starts_with('K'))
            .expect("K");
        let bm = f
            .matrices
            .iter()
            .find(|m| m.name.starts_with('B'))
            .expect("B");
        let (kx, ky) = (km.matrix[0][0], km.matrix[1][1]);
        let err = if k > 0.0 {
            format!(
                "{:+.1} %, {:+.1} %",
                100.0 * (kx - k) / k,
                100.0 * (ky - k) / k
            )
        } else {
            "—".into()
        };
        let fx = log.column("fx_n").unwrap();
        let fy = log.column("fy_n").unwrap();
        println!(
            "| {k:.0} | {kx:.1}, {ky:.1} | {err} | {:.1}, {:.1} | {:.3}, {:.3} | {:.2}, {:.2} |",
            bm.matrix[0][0],
            bm.matrix[1][1],
            f.test[0].r2,
            f.test[1].r2,
            rms(fx),
            rms(fy)
        );
    }
}
