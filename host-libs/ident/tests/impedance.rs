//! Impedance mode on the twin (issue 14): the K that the dynamic identification (§4.3,
//! `pamctl ident dynamic`) finds on an impedance trial's log is the commanded K, from the
//! transparent mode to 1.5 × the open loop's stiffest K at the point.

use pam_ident::msd;
use pam_ident::trial::{rms, Trial};
use pam_ident::FilterSettings;
use pam_model::RobotModel;
use pam_twin::experiments::ExperimentConfig;
use pam_twin::impedance_trial::{impedance_trial, VirtualImpedance};
use pam_twin::TwinConfig;

/// (identified diagonal K, N/m; RMS interaction force per axis, N)
fn trial(k_n_per_m: f64) -> ([f64; 2], [f64; 2]) {
    let model = RobotModel::<f64>::thesis();
    let cfg = ExperimentConfig::new(TwinConfig::thesis());
    let imp = VirtualImpedance {
        stiffness_n_per_m: [k_n_per_m; 2],
        damping_n_s_per_m: [5.0; 2],
        mass_kg: [0.0; 2],
    };
    let log = impedance_trial(&cfg, 1, imp, 20.0).expect("no fault");
    let p = Trial::from_log(&log)
        .unwrap()
        .prepare(&model, FilterSettings::default())
        .unwrap();
    let f = msd::fit_dynamic(&p, model.cartesian_mass(p.alpha0_rad));
    let k = f.matrices.iter().find(|m| m.name.starts_with('K')).unwrap();
    let force = [log.column("fx_n").unwrap(), log.column("fy_n").unwrap()];
    (
        [k.matrix[0][0], k.matrix[1][1]],
        [rms(force[0]), rms(force[1])],
    )
}

#[test]
fn identified_k_is_the_commanded_k_from_transparent_to_stiffer_than_open_loop() {
    let model = RobotModel::<f64>::thesis();
    let k_max_joint = [0, 1].map(|j| model.capability(j, 0.0).k_max.stiffness_nm_per_rad);
    let kc_max = model.cartesian_stiffness([0.0; 2], k_max_joint).unwrap();
    let k_top = 1.5 * kc_max.0[0][0].max(kc_max.0[1][1]);
    for k in [300.0, k_top] {
        let (kid, _) = trial(k);
        println!(
            "commanded {k:.0} N/m: identified {:.1}, {:.1}",
            kid[0], kid[1]
        );
        for a in 0..2 {
            assert!((kid[a] - k).abs() < 0.1 * k, "K {k}: identified {kid:?}");
        }
    }
    // transparent: the open loop's least stiffness at point 1 is ≈ 86 / 221 N/m diagonal;
    // closed, what the operator feels stays within a few N/m and a fraction of a newton
    let (kid, f_rms) = trial(0.0);
    println!("transparent: identified {kid:?} N/m, RMS force {f_rms:?} N");
    assert!(kid.iter().all(|k| k.abs() < 10.0), "{kid:?}");
    assert!(f_rms.iter().all(|f| *f < 1.0), "{f_rms:?}");
}
