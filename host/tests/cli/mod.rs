//! What the `pamctl model|ident` end-to-end tests share: running the binary, a scratch
//! directory, and writing a trial as a format-v1 log.
#![allow(dead_code)] // each test file uses its own part

use pam_ident::Trial;
use std::path::Path;
use std::process::Command;
use tempfile::TempDir;

/// Runs pamctl; (exit code, stdout, stderr).
pub fn pamctl(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_pamctl"))
        .args(args)
        .output()
        .expect("pamctl runs");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into(),
        String::from_utf8_lossy(&out.stderr).into(),
    )
}

/// A fresh directory for a test's files; keep the guard for the whole test: it is removed
/// when the test ends, pass or fail.
pub fn tmpdir(name: &str) -> TempDir {
    tempfile::Builder::new()
        .prefix(&format!("pamctl-loop-{name}-"))
        .tempdir()
        .unwrap()
}

/// Writes a trial as a format-v1 log (currents at a constant pretension).
pub fn write_log(path: &Path, t: &Trial, experiment: &str) {
    let mut cols = vec![
        "t_s",
        "alpha1_rad",
        "alpha2_rad",
        "fx_n",
        "fy_n",
        "i1_ma",
        "i2_ma",
        "i3_ma",
        "i4_ma",
    ];
    if t.force_ref_n.is_some() {
        cols.extend(["fx_ref_n", "fy_ref_n"]);
    }
    let mut w = pam_log::LogWriter::create(path, &cols, &[("experiment", experiment)]).unwrap();
    for i in 0..t.len() {
        let mut row = vec![
            t.t_s[i],
            t.alpha_rad[0][i],
            t.alpha_rad[1][i],
            t.force_n[0][i],
            t.force_n[1][i],
            12.0,
            12.0,
            12.0,
            12.0,
        ];
        if let Some(r) = &t.force_ref_n {
            row.extend([r[0][i], r[1][i]]);
        }
        w.write_row(&row).unwrap();
    }
    w.flush().unwrap();
}
