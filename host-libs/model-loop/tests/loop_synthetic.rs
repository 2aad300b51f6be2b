//! The model loop on data from the tests' own simulator (tests/common): one hidden effect at
//! a time, at two magnitudes, at the thesis's 50 ms and at 1 ms sampling, with two noise
//! levels. `diagnose` must name the hidden effect first, fitting with it must lower the
//! held-out error, and the fitted parameter must be near the truth; with nothing hidden the
//! verdict is "none", with an out-of-catalog tone it is "unexplained".
mod common;

use common::*;
use pam_model::RobotModel;
use pam_model_loop::diagnose::Verdict;
use pam_model_loop::diagnose::{diagnose, Diagnosis, Settings};
use pam_model_loop::effects::Experiment;

/// (sampling period, noise, duration): the thesis's 50 ms with light noise, and 1 ms with
/// heavier noise (shorter, so the suite stays quick).
const REGIMES: [(f64, f64, f64); 2] = [(0.05, 0.2, 90.0), (0.001, 0.8, 40.0)];

fn run_dynamic(hidden: Hidden, dt: f64, noise: f64, duration: f64, seed: u64) -> Diagnosis {
    let model = RobotModel::<f64>::thesis();
    let tr = dynamic(&DynConfig {
        dt_s: dt,
        noise_n: noise,
        duration_s: duration,
        hidden,
        seed,
        ..Default::default()
    });
    diagnose(&tr, &model, Experiment::Dynamic, Settings::default())
        .unwrap()
        .0
}

fn run_step(hidden: Hidden, dt: f64, noise: f64, duration: f64, seed: u64) -> Diagnosis {
    let model = RobotModel::<f64>::thesis();
    let tr = step(&StepConfig {
        dt_s: dt,
        noise_n: noise,
        duration_s: duration,
        hidden,
        seed,
        ..Default::default()
    });
    diagnose(&tr, &model, Experiment::Step, Settings::default())
        .unwrap()
        .0
}

/// The hidden effect is named first, lowers the held-out error on average over the axes,
/// and `check` accepts its fitted parameters.
fn assert_found(
    d: &Diagnosis,
    id: &str,
    label: &str,
    check: impl Fn(&std::collections::BTreeMap<String, f64>) -> Result<(), String>,
) {
    let top = &d.effects[0];
    assert_eq!(d.verdict, Verdict::Effect, "{label}: {d:#?}");
    assert_eq!(
        top.id,
        id,
        "{label}: ranking {:?}",
        d.effects
            .iter()
            .map(|e| (&e.id, &e.shape, e.score, e.accepted, e.folds.t))
            .collect::<Vec<_>>()
    );
    let before = d.base.nrmse.fx.powi(2) + d.base.nrmse.fy.powi(2);
    let after = top.nrmse.fx.powi(2) + top.nrmse.fy.powi(2);
    assert!(
        after < before,
        "{label}: held-out error {after} not below {before}"
    );
    if let Err(e) = check(&top.params) {
        panic!("{label}: {e}; params {:?}", top.params);
    }
}

fn near(
    params: &std::collections::BTreeMap<String, f64>,
    name: &str,
    truth: f64,
    rel: f64,
) -> Result<(), String> {
    let v = *params.get(name).ok_or(format!("no parameter {name}"))?;
    if (v - truth).abs() <= rel * truth.abs() {
        Ok(())
    } else {
        Err(format!(
            "{name} = {v}, truth {truth} (±{:.0} %)",
            rel * 100.0
        ))
    }
}

#[test]
fn carrier_ball_friction_is_found_with_its_coulomb_force() {
    for (k, &(dt, noise, dur)) in REGIMES.iter().enumerate() {
        for c in [1.0, 3.0] {
            let d = run_dynamic(
                Hidden::Friction { coulomb_n: c },
                dt,
                noise,
                dur,
                10 + k as u64,
            );
            assert_found(
                &d,
                "carrier_ball_friction",
                &format!("dt {dt} c {c}"),
                |p| near(p, "coulomb_n", c, 0.15),
            );
        }
    }
}

#[test]
fn velocity_squared_is_found_with_its_coefficient() {
    for (k, &(dt, noise, dur)) in REGIMES.iter().enumerate() {
        for c in [40.0, 120.0] {
            let d = run_dynamic(Hidden::VelocitySquared { c }, dt, noise, dur, 20 + k as u64);
            assert_found(&d, "velocity_squared", &format!("dt {dt} c {c}"), |p| {
                near(p, "coeff_n_s2_per_m2", c, 0.2)
            });
        }
    }
}

/// At 1 ms only: on this simulator (Cartesian stiffness, joint-space cubic) at 50 ms the
/// loop ranks pose_dependence above nonlinear_stiffness (both reduce the error; see the
/// report). On the twin, whose stiffness is in joint space like the rig's, it is found at
/// 50 ms too (pam-eval's tests/twin_loop.rs).
#[test]
fn nonlinear_stiffness_is_found_with_its_cubic_coefficient() {
    for (k, &(dt, noise, dur)) in REGIMES.iter().enumerate().skip(1) {
        for c in [15.0, 40.0] {
            let d = run_dynamic(Hidden::Cubic { cubic_n: c }, dt, noise, dur, 30 + k as u64);
            assert_found(&d, "nonlinear_stiffness", &format!("dt {dt} c {c}"), |p| {
                cable_cubic_near(p, c, 0.2)
            });
        }
    }
}

/// The cable cubic `c` of ΔF = −c (Δε/0.01)³ from either shape of the family: the cable
/// cubic itself (`cubic_n`), or the joint-space cubic about the trial's equilibrium,
/// −k (α − α0)³ per joint. This simulator's trials rest at the centre (α0 = 0), where the
/// two shapes are the same function and the data picks either by a hair (0.0816 against
/// 0.0815 of the error removed, seed 31): there k = 2cR (R/l0/0.01)³, and each joint's
/// k must give `c`.
fn cable_cubic_near(
    p: &std::collections::BTreeMap<String, f64>,
    c: f64,
    rel: f64,
) -> Result<(), String> {
    if p.contains_key("cubic_n") {
        return near(p, "cubic_n", c, rel);
    }
    let model = RobotModel::<f64>::thesis();
    for (j, name) in ["cubic_nm_per_rad3_joint1", "cubic_nm_per_rad3_joint2"]
        .iter()
        .enumerate()
    {
        let k = *p.get(*name).ok_or(format!("neither cubic_n nor {name}"))?;
        let jp = &model.params.joints[j];
        let r = jp.pulley_radius_m;
        let u = r / jp.muscle_rest_length_m / 0.01;
        let as_cable = k / (2.0 * r * u * u * u);
        if (as_cable - c).abs() > rel * c {
            return Err(format!(
                "{name} = {k} is a cable cubic of {as_cable}, truth {c} (±{:.0} %)",
                rel * 100.0
            ));
        }
    }
    Ok(())
}

#[test]
fn muscle_hysteresis_is_found_with_its_torque_and_width() {
    for (k, &(dt, noise, dur)) in REGIMES.iter().enumerate() {
        for fraction in [0.03, 0.08] {
            let d = run_dynamic(
                Hidden::Hysteresis {
                    fraction,
                    width: 0.002,
                },
                dt,
                noise,
                dur,
                40 + k as u64,
            );
            // amplitude = R · fraction · (F1 + F2), 150 N per cable in the simulator
            let t1 = 0.07 * fraction * 300.0;
            assert_found(
                &d,
                "muscle_hysteresis",
                &format!("dt {dt} fraction {fraction}"),
                |p| {
                    near(p, "torque_nm_joint1", t1, 0.25)?;
                    near(p, "width", 0.002, 0.6)
                },
            );
        }
    }
}

/// At 1 ms only, for the reason given at `nonlinear_stiffness_is_found_…`.
///
/// Over ten operator paths (seeds): every one must name pose_dependence first, and the
/// fitted quadratic force field must match the hidden one where the handle went. The field
/// is checked, not one coefficient: the six coefficients of the quadratic form are
/// correlated (their errors trade off), while the field over the visited displacements is
/// what the data determines. The median over the paths must be within 25 % (g = 4) and
/// 12 % (g = 10); one path (seed 51) is 1.3 and 0.53 off — its fit puts −746 N/m² on
/// y² in Y at both sizes, a term the hidden effect does not have; the same path with
/// nothing hidden fits the same term: estimation noise on a path that stays within 7 mm
/// RMS in x (docs/model-loop.md).
#[test]
fn pose_dependent_stiffness_is_found() {
    let model = RobotModel::<f64>::thesis();
    let (_, &(dt, noise, dur)) = REGIMES.iter().enumerate().nth(1).unwrap();
    for (g, median_limit) in [(4.0, 0.25), (10.0, 0.12)] {
        let mut errors = Vec::new();
        for seed in 48..58u64 {
            let tr = dynamic(&DynConfig {
                dt_s: dt,
                noise_n: noise,
                duration_s: dur,
                hidden: Hidden::PoseQuadratic { k_per_m: g },
                seed,
                ..Default::default()
            });
            let d = diagnose(&tr, &model, Experiment::Dynamic, Settings::default())
                .unwrap()
                .0;
            let label = format!("dt {dt} g {g} seed {seed}");
            assert_found(&d, "pose_dependence", &label, |_| Ok(()));
            // K(x) = K (1 + g·dx): the X force gains g·dx·(K_xx dx + K_xy dy), the Y force
            // g·dx·(K_yx dx + K_yy dy)
            let truth = [
                [g * K[0][0], g * K[0][1], 0.0],
                [g * K[1][0], g * K[1][1], 0.0],
            ];
            let q = &d.effects[0].params;
            let fitted = [["qx_xx", "qx_xy", "qx_yy"], ["qy_xx", "qy_xy", "qy_yy"]]
                .map(|row| row.map(|n| q.get(&format!("{n}_n_per_m2")).copied().unwrap_or(0.0)));
            errors.push(field_error(&tr, &model, &fitted, &truth));
        }
        let mut sorted = errors.clone();
        sorted.sort_by(f64::total_cmp);
        let median = (sorted[4] + sorted[5]) / 2.0;
        assert!(
            median <= median_limit,
            "g {g}: median field error {median:.3} > {median_limit}; per seed {errors:.3?}"
        );
    }
}

/// The relative RMS difference of two quadratic force fields (per axis, coefficients of
/// dx², dx·dy, dy²) over the trial's displacements about their mean.
fn field_error(
    tr: &pam_ident::Trial,
    model: &RobotModel<f64>,
    fitted: &[[f64; 3]; 2],
    truth: &[[f64; 3]; 2],
) -> f64 {
    let xs: Vec<[f64; 2]> = (0..tr.t_s.len())
        .step_by(10)
        .map(|i| {
            model
                .kinematics
                .forward_user([tr.alpha_rad[0][i], tr.alpha_rad[1][i]])
        })
        .collect();
    let mean = [0, 1].map(|a| xs.iter().map(|x| x[a]).sum::<f64>() / xs.len() as f64);
    let (mut diff, mut size) = (0.0, 0.0);
    for x in &xs {
        let (dx, dy) = (x[0] - mean[0], x[1] - mean[1]);
        let basis = [dx * dx, dx * dy, dy * dy];
        for a in 0..2 {
            let f = |c: &[f64; 3]| (0..3).map(|k| c[k] * basis[k]).sum::<f64>();
            diff += (f(&fitted[a]) - f(&truth[a])).powi(2);
            size += f(&truth[a]).powi(2);
        }
    }
    (diff / size.max(1e-300)).sqrt()
}

#[test]
fn loadcell_drift_is_found_with_offset_and_drift() {
    for (k, &(dt, noise, dur)) in REGIMES.iter().enumerate() {
        for (o, r) in [(1.0, 0.01), (3.0, 0.03)] {
            let d = run_dynamic(
                Hidden::Drift {
                    offset_n: o,
                    drift_n_per_s: r,
                },
                dt,
                noise,
                dur,
                60 + k as u64,
            );
            assert_found(&d, "loadcell_drift", &format!("dt {dt} offset {o}"), |p| {
                near(p, "offset_x_n", o, 0.1)?;
                near(p, "drift_x_n_per_s", r, 0.2)
            });
        }
    }
}

/// A force that lags the motion in a dynamic trial by a pure delay (a sensor-sync delay:
/// what a 30–40 ms loop with filtering produces) is named a delay, with its size. The
/// base model's pneumatic term is a lag of another shape (a high-pass of the displacement),
/// which the fold test tells apart — not always: 40 ms at 20 ms sampling is absorbed by it
/// (docs/model-loop.md).
#[test]
fn a_lagging_force_in_a_dynamic_trial_is_named_a_delay() {
    for (delay_s, dt, noise, duration, seed) in [
        (0.06, 0.01, 0.3, 90.0, 71),
        (0.08, 0.05, 0.2, 90.0, 74),
        (0.05, 0.005, 0.3, 60.0, 73),
        (0.1, 0.02, 0.3, 90.0, 75),
    ] {
        let d = run_dynamic(Hidden::Delay { delay_s }, dt, noise, duration, seed);
        assert_found(
            &d,
            "transport_delay",
            &format!("delay {delay_s} s at {dt} s"),
            |p| near(p, "delay_s", delay_s, 0.3),
        );
    }
}

#[test]
fn nothing_hidden_gives_none() {
    for (k, &(dt, noise, dur)) in REGIMES.iter().enumerate() {
        for seed in [1, 2] {
            let d = run_dynamic(Hidden::None, dt, noise, dur, 100 * seed + k as u64);
            assert_eq!(
                d.verdict,
                Verdict::None,
                "dt {dt} seed {seed}: {:?}",
                d.effects
                    .iter()
                    .map(|e| (&e.id, e.score))
                    .collect::<Vec<_>>()
            );
            let d = run_step(Hidden::None, dt, noise, dur, 100 * seed + k as u64);
            assert_eq!(
                d.verdict,
                Verdict::None,
                "step dt {dt} seed {seed}: {:?}",
                d.effects
                    .iter()
                    .map(|e| (&e.id, e.score))
                    .collect::<Vec<_>>()
            );
        }
    }
}

#[test]
fn a_mains_tone_is_unexplained_and_named() {
    for (k, &(dt, noise, dur)) in REGIMES.iter().enumerate() {
        let d = run_dynamic(
            Hidden::Hum {
                amplitude_n: 1.0,
                freq_hz: 50.0,
            },
            dt,
            noise,
            dur,
            80 + k as u64,
        );
        assert_eq!(d.verdict, Verdict::Unexplained, "dt {dt}: {d:#?}");
        let u = &d.unexplained[0];
        assert_eq!(u.kind, "spectral_peak");
        // 50 Hz, or where it aliases at 20 Hz sampling: the Nyquist frequency
        let expect = if dt < 0.01 { 50.0 } else { 10.0 };
        assert!((u.frequency_hz.unwrap() - expect).abs() < 0.2, "{u:?}");
    }
}

#[test]
fn a_slow_wander_is_unexplained_and_named() {
    for (k, &(dt, noise, dur)) in REGIMES.iter().enumerate() {
        let d = run_dynamic(
            Hidden::Wander {
                amplitude_n: 2.0,
                period_s: 25.0,
            },
            dt,
            noise,
            dur,
            90 + k as u64,
        );
        assert!(
            d.unexplained.iter().any(|u| u.kind == "slow_wander"),
            "dt {dt}: {:?} {:?}",
            d.verdict,
            d.unexplained
        );
    }
    // and none in a trial without it
    let d = run_dynamic(Hidden::None, 0.01, 0.3, 90.0, 95);
    assert!(d.unexplained.is_empty(), "{:?}", d.unexplained);
}

#[test]
fn step_effects_are_found_with_their_parameters() {
    for (k, &(dt, noise, dur)) in REGIMES.iter().enumerate() {
        let dur = dur.max(60.0);
        for delay in [0.03, 0.07] {
            let d = run_step(
                Hidden::Delay { delay_s: delay },
                dt,
                noise,
                dur,
                200 + k as u64,
            );
            let truth = (delay / dt).round() * dt;
            assert_found(
                &d,
                "transport_delay",
                &format!("step dt {dt} delay {delay}"),
                |p| near(p, "delay_s", truth, 0.2),
            );
        }
        for rate in [30.0, 60.0] {
            let d = run_step(
                Hidden::SlewLimit { rate_n_per_s: rate },
                dt,
                noise,
                dur,
                210 + k as u64,
            );
            assert_found(
                &d,
                "asymmetric_ip_rates",
                &format!("step dt {dt} rate {rate}"),
                |p| {
                    near(p, "rise_n_per_s", rate, 0.2)?;
                    near(p, "fall_n_per_s", 1.3 * rate, 0.2)
                },
            );
        }
        for max in [6.0, 9.0] {
            let d = run_step(
                Hidden::Saturation { max_n: max },
                dt,
                noise,
                dur,
                220 + k as u64,
            );
            assert_found(
                &d,
                "pressure_saturation",
                &format!("step dt {dt} max {max}"),
                |p| near(p, "max_n", max, 0.15),
            );
        }
        for (o, r) in [(1.0, 0.01), (2.0, 0.03)] {
            let d = run_step(
                Hidden::Drift {
                    offset_n: o,
                    drift_n_per_s: r,
                },
                dt,
                noise,
                dur,
                230 + k as u64,
            );
            assert_found(
                &d,
                "loadcell_drift",
                &format!("step dt {dt} offset {o}"),
                |p| near(p, "offset_n_x", o, 0.15),
            );
        }
        let d = run_step(
            Hidden::Hum {
                amplitude_n: 1.0,
                freq_hz: 50.0,
            },
            dt,
            noise,
            dur,
            240 + k as u64,
        );
        assert_eq!(d.verdict, Verdict::Unexplained, "step dt {dt}: {d:#?}");
    }
}
