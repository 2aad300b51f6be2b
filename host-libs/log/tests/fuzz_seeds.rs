//! The seed corpus of the `log_reader` fuzz target (`fuzz/corpus/log_reader/`), generated
//! with this crate's writer: a minimal log, one with every known column and metadata, one
//! with unknown columns (quoted names, text values), and the same with CRLF line ends and a
//! byte-order mark.
//!
//! The test fails when the files differ from what is generated today;
//! `PAM_WRITE_FUZZ_SEEDS=1 cargo test -p pam-log --test fuzz_seeds` rewrites them.

use pam_log::{col, read_str, Log};
use std::path::PathBuf;

fn rows(log: &mut Log, n: usize) {
    for i in 0..n {
        let row: Vec<f64> = (0..log.columns().len())
            .map(|c| {
                if c == 0 {
                    i as f64 * 0.001
                } else {
                    (i * 7 + c) as f64 * 0.25 - 3.0
                }
            })
            .collect();
        log.push_row(&row);
    }
}

fn seeds() -> Vec<String> {
    let mut minimal = Log::new(&col::REQUIRED);
    rows(&mut minimal, 3);

    let mut full = Log::new(&col::KNOWN);
    full.set_meta("source", "pamctl record");
    full.set_meta("device", "tcp://127.0.0.1:7878");
    rows(&mut full, 5);

    let mut unknown = Log::new(&col::REQUIRED);
    rows(&mut unknown, 2);
    let text = unknown.to_csv_string();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let header = lines
        .iter()
        .position(|l| !l.starts_with('#'))
        .expect("a header");
    lines[header].push_str(",\"note, free\",mode");
    for l in &mut lines[header + 1..] {
        l.push_str(",\"a \"\"quoted\"\" text\",joint");
    }
    let unknown = lines.join("\n") + "\n";

    let crlf_bom = format!("\u{feff}{}", minimal.to_csv_string().replace('\n', "\r\n"));
    vec![
        minimal.to_csv_string(),
        full.to_csv_string(),
        unknown,
        crlf_bom,
    ]
}

fn corpus_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("fuzz/corpus/log_reader")
}

fn seed_files_on_disk() -> Vec<(String, Vec<u8>)> {
    let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(corpus_dir())
        .expect("the corpus directory")
        .map(|e| e.expect("a directory entry").path())
        .filter_map(|p| {
            let name = p.file_name()?.to_str()?.to_string();
            name.starts_with("seed")
                .then(|| (name, std::fs::read(&p).expect("a seed file")))
        })
        .collect();
    files.sort();
    files
}

#[test]
fn every_seed_is_a_valid_log() {
    for (i, s) in seeds().iter().enumerate() {
        let log = read_str(s, None).unwrap_or_else(|e| panic!("seed{i}: {e}"));
        assert!(!log.is_empty(), "seed{i}");
    }
}

#[test]
fn the_fuzz_seed_corpus_is_generated_by_the_writer() {
    let mut expected: Vec<(String, Vec<u8>)> = seeds()
        .into_iter()
        .enumerate()
        .map(|(i, s)| (format!("seed{i}"), s.into_bytes()))
        .collect();
    if std::env::var_os("PAM_WRITE_FUZZ_SEEDS").is_some() {
        for (name, _) in seed_files_on_disk() {
            std::fs::remove_file(corpus_dir().join(name)).expect("remove an old seed");
        }
        for (name, bytes) in &expected {
            std::fs::write(corpus_dir().join(name), bytes).expect("write a seed");
        }
    }
    expected.sort();
    assert!(
        seed_files_on_disk() == expected,
        "fuzz/corpus/log_reader is not the generated seed corpus: \
         PAM_WRITE_FUZZ_SEEDS=1 cargo test -p pam-log --test fuzz_seeds"
    );
}
