//! Arbitrary bytes as a log-format-v1 file: the reader never panics, refuses with a typed
//! error that points inside the text, and what it accepts is a well-formed log that the
//! writer writes back to the same log.
#![no_main]

use libfuzzer_sys::fuzz_target;
use pam_log::{col, read_str, ErrorKind, Log};

/// The writer does not quote: it can only give back column names that need no quoting and
/// that the reader does not trim or take for a comment.
fn writable_names(log: &Log) -> bool {
    log.columns().iter().enumerate().all(|(i, n)| {
        !n.contains([',', '"', '\r', '\n']) && n.trim() == n && !(i == 0 && n.starts_with('#'))
    })
}

/// Values equal, NaN equal to NaN (unknown columns hold NaN for what is not a number).
fn same_values(a: &Log, b: &Log) -> bool {
    a.len() == b.len()
        && a.columns() == b.columns()
        && (0..a.len()).all(|i| {
            a.row(i)
                .iter()
                .zip(b.row(i))
                .all(|(x, y)| x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan()))
        })
}

/// The metadata as the writer gives it back: without `format` (it writes its own first),
/// line breaks as spaces.
fn written_meta(log: &Log) -> Vec<(String, String)> {
    log.meta
        .iter()
        .filter(|(k, _)| k != "format")
        .map(|(k, v)| (k.clone(), v.replace(['\n', '\r'], " ")))
        .collect()
}

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let lines = text.split('\n').count();
    match read_str(&text, None) {
        Err(e) => {
            let line = e.line.expect("a parse error names its line");
            assert!(
                line >= 1 && line <= lines,
                "error line {line} of {lines}: {e}"
            );
            if let Some(column) = e.column {
                assert!(column >= 1, "column {column}: {e}");
            }
            assert!(!e.message.is_empty());
            assert_ne!(e.kind, ErrorKind::Io, "no I/O in read_str: {e}");
            let _ = e.to_string();
        }
        Ok(log) => {
            assert!(!log.is_empty(), "an accepted log has samples");
            for name in col::REQUIRED {
                let column = log.column(name).expect("required columns are there");
                assert_eq!(column.len(), log.len());
            }
            for name in log.columns() {
                let column = log.column(name).expect("every header column");
                assert_eq!(column.len(), log.len(), "ragged column {name}");
                if col::is_known(name) {
                    assert!(column.iter().all(|v| v.is_finite()), "{name} not finite");
                }
            }
            let t = log.column(col::T_S).expect("required");
            assert!(t.windows(2).all(|w| w[0] < w[1]), "time not increasing");
            let _ = log.sample_period_s();
            if writable_names(&log) {
                let again = read_str(&log.to_csv_string(), None)
                    .unwrap_or_else(|e| panic!("the writer's own output is refused: {e}"));
                assert!(same_values(&log, &again), "values changed on a round trip");
                assert_eq!(written_meta(&log), written_meta(&again), "metadata changed");
            }
        }
    }
});
