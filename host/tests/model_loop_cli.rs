//! `pamctl model compare|diagnose|fit` and `pamctl ident …` end to end, on logs written
//! with pam-log from the identification tests' independent simulator.
#[path = "../../host-libs/model-loop/tests/common/mod.rs"]
mod common;

mod cli;

use cli::{pamctl, tmpdir, write_log};
use common::*;

fn json(s: &str) -> serde_json::Value {
    serde_json::from_str(s).unwrap_or_else(|e| panic!("not JSON ({e}): {s}"))
}

#[test]
fn diagnose_json_follows_the_schema_and_names_the_hidden_effect() {
    let dir = tmpdir("diag");
    let d = dir.path();
    let log = d.join("friction.csv");
    write_log(
        &log,
        &dynamic(&DynConfig {
            dt_s: 0.02,
            duration_s: 60.0,
            hidden: Hidden::Friction { coulomb_n: 2.5 },
            seed: 11,
            ..Default::default()
        }),
        "dynamic",
    );
    let (code, out, err) = pamctl(&[
        "model",
        "diagnose",
        log.to_str().unwrap(),
        "--experiment",
        "dynamic",
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let v = json(&out);
    assert_eq!(v["experiment"], "dynamic");
    assert!(v["base"]["nrmse"]["fx"].as_f64().unwrap() > 0.0);
    assert!(v["base"]["nrmse"]["fy"].as_f64().unwrap() > 0.0);
    assert_eq!(v["verdict"], "effect");
    let effects = v["effects"].as_array().unwrap();
    assert_eq!(effects[0]["id"], "carrier_ball_friction");
    for e in effects {
        assert!(e["nrmse"]["fx"].is_number() && e["nrmse"]["fy"].is_number());
        assert!(e["params"].is_object() && e["evidence"].is_string());
    }
    // the accepted families first, each group best first; one entry per family
    let key = |e: &serde_json::Value| {
        (
            !e["accepted"].as_bool().unwrap(),
            -e["score"].as_f64().unwrap(),
        )
    };
    assert!(effects
        .windows(2)
        .all(|w| key(&w[0]).partial_cmp(&key(&w[1])) != Some(std::cmp::Ordering::Greater)));
    assert_eq!(effects[0]["family"], "friction");
    let mut families: Vec<&str> = effects
        .iter()
        .map(|e| e["family"].as_str().unwrap())
        .collect();
    let n = families.len();
    families.sort();
    families.dedup();
    assert_eq!(families.len(), n, "one entry per family");
    let c = effects[0]["params"]["coulomb_n"].as_f64().unwrap();
    assert!((c - 2.5).abs() < 0.3, "coulomb {c}");
    assert!(v["unexplained"].is_array());
}

#[test]
fn fit_and_compare_report_errors_before_and_after() {
    let dir = tmpdir("fit");
    let d = dir.path();
    let log = d.join("v2.csv");
    write_log(
        &log,
        &dynamic(&DynConfig {
            dt_s: 0.01,
            duration_s: 60.0,
            hidden: Hidden::VelocitySquared { c: 60.0 },
            seed: 5,
            ..Default::default()
        }),
        "dynamic",
    );
    let (code, out, err) = pamctl(&[
        "model",
        "fit",
        log.to_str().unwrap(),
        "--with",
        "velocity_squared",
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let v = json(&out);
    for ax in ["fx", "fy"] {
        assert!(v["after"][ax].as_f64().unwrap() < v["before"][ax].as_f64().unwrap());
    }
    let c = v["params"]["velocity_squared"]["coeff_n_s2_per_m2"]
        .as_f64()
        .unwrap();
    assert!((c - 60.0).abs() < 10.0, "{c}");
    let (code, out, err) = pamctl(&["model", "compare", log.to_str().unwrap(), "--json"]);
    assert_eq!(code, 0, "{err}");
    let v = json(&out);
    assert_eq!(v["experiment"], "dynamic");
    assert!(v["worst_windows"].as_array().unwrap().len() >= 3);
    assert_eq!(v["error_by_speed"].as_array().unwrap().len(), 4);
    // plain text works too
    let (code, out, _) = pamctl(&[
        "model",
        "compare",
        log.to_str().unwrap(),
        "--with",
        "velocity_squared",
    ]);
    assert_eq!(code, 0);
    assert!(out.contains("held-out NRMSE"), "{out}");
    let (code, _, err) = pamctl(&[
        "model",
        "fit",
        log.to_str().unwrap(),
        "--with",
        "no_such_effect",
    ]);
    assert_eq!(code, 1);
    assert!(err.contains("unknown effect `no_such_effect`"), "{err}");
}

#[test]
fn ident_commands_reproduce_the_simulated_matrices() {
    let dir = tmpdir("ident");
    let d = dir.path();
    let log = d.join("dyn.csv");
    write_log(
        &log,
        &dynamic(&DynConfig {
            dt_s: 0.01,
            duration_s: 90.0,
            noise_n: 0.3,
            seed: 2,
            ..Default::default()
        }),
        "dynamic",
    );
    let (code, out, err) = pamctl(&["ident", "dynamic", log.to_str().unwrap(), "--json"]);
    assert_eq!(code, 0, "{err}");
    let v = json(&out);
    let k = &v["matrices"][2]["matrix"];
    assert!(
        (k[0][0].as_f64().unwrap() - K[0][0]).abs() < 0.05 * K[0][0],
        "{k}"
    );
    assert!(
        (k[1][1].as_f64().unwrap() - K[1][1]).abs() < 0.05 * K[1][1],
        "{k}"
    );
    let (code, out, err) = pamctl(&["ident", "freq", log.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("R² of the force spectra"), "{out}");
    let (code, out, _) = pamctl(&["ident", "static", log.to_str().unwrap()]);
    assert_eq!(code, 0);
    assert!(out.contains("K = "), "{out}");
    let steplog = d.join("step.csv");
    write_log(
        &steplog,
        &step(&StepConfig {
            dt_s: 0.01,
            duration_s: 40.0,
            ..Default::default()
        }),
        "step",
    );
    let (code, out, err) = pamctl(&["ident", "step", steplog.to_str().unwrap(), "--json"]);
    assert_eq!(code, 0, "{err}");
    let v = json(&out);
    let f = &v["logs"][0]["fitted"][0];
    assert!((f["gain"].as_f64().unwrap() - 0.57).abs() < 0.02, "{f}");
    assert!((f["zeta"].as_f64().unwrap() - 0.42).abs() < 0.05, "{f}");
    assert!(
        (f["omega_n_rad_s"].as_f64().unwrap() - 23.04).abs() < 1.5,
        "{f}"
    );
    assert!(v["gain_plane_error"]
        .as_str()
        .unwrap()
        .contains("at least 3 poses"));
}

#[test]
fn malformed_logs_give_file_line_column_errors_not_panics() {
    let dir = tmpdir("bad");
    let d = dir.path();
    let head = "t_s,alpha1_rad,alpha2_rad,fx_n,fy_n,i1_ma,i2_ma,i3_ma,i4_ma\n";
    let good_row = |t: f64| format!("{t},0,0,0.1,0.2,12,12,12,12\n");
    let cases: Vec<(&str, String, &str)> = vec![
        (
            "missing_column.csv",
            "t_s,alpha1_rad,alpha2_rad,fx_n,i1_ma,i2_ma,i3_ma,i4_ma\n0,0,0,0,12,12,12,12\n".into(),
            "fy_n",
        ),
        (
            "text.csv",
            format!("{head}{}0.01,0,0,abc,0.2,12,12,12,12\n", good_row(0.0)),
            ":3:",
        ),
        (
            "time.csv",
            format!(
                "{head}{}{}{}",
                good_row(0.0),
                good_row(0.02),
                good_row(0.01)
            ),
            ":4:",
        ),
        (
            "nan.csv",
            format!("{head}{}0.01,0,NaN,0.1,0.2,12,12,12,12\n", good_row(0.0)),
            ":3:",
        ),
    ];
    for (name, text, expect) in cases {
        let p = d.join(name);
        std::fs::write(&p, text).unwrap();
        for sub in [
            vec!["model", "diagnose"],
            vec!["model", "compare"],
            vec!["ident", "dynamic"],
        ] {
            let mut args = sub.clone();
            args.push(p.to_str().unwrap());
            let (code, _, err) = pamctl(&args);
            assert_eq!(code, 1, "{name} {sub:?}: {err}");
            assert!(
                err.contains(name) && err.contains(expect),
                "{name} {sub:?}: {err}"
            );
            assert!(!err.contains("panicked"), "{err}");
        }
    }
}
