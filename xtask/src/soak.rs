//! `cargo xtask soak [--hours H] [--seed S] [--write]`: the soak example in release, its
//! arguments passed on (it checks them); `--write` rewrites the soak's section of
//! hil-tests/README.md with the run's summary and tables.

use std::process::Stdio;

use crate::fault_table::{date_and_commit, write_readme_section};
use crate::{cargo_in, root};

const BEGIN: &str = "<!-- soak:begin (cargo xtask soak --hours 1 --seed 1 --write) -->";
const END: &str = "<!-- soak:end -->";

pub fn soak(args: &[String]) -> i32 {
    let write = args.iter().any(|a| a == "--write");
    let passed: Vec<&String> = args.iter().filter(|a| *a != "--write").collect();
    let root = root();
    let (date, commit) = date_and_commit(&root);
    let mut cmd = cargo_in(&root);
    cmd.args([
        "run",
        "--release",
        "-p",
        "pam-emulator",
        "--example",
        "soak",
        "--",
    ])
    .args(&passed)
    .stderr(Stdio::inherit());
    let out = match cmd.output() {
        Ok(o) => o,
        Err(e) => {
            eprintln!("xtask: could not start cargo: {e}");
            return 1;
        }
    };
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    print!("{text}");
    if !out.status.success() {
        eprintln!("xtask: the soak failed ({})", out.status);
        return 1;
    }
    if !write {
        return 0;
    }
    let words: Vec<String> = passed.iter().map(|a| a.to_string()).collect();
    let section = format!(
        "Measured {date} at commit {commit} (`cargo xtask soak {}`, release build, fast-forward):\n\n{}",
        words.join(" "),
        markdown(&text)
    );
    write_readme_section(&root.join("hil-tests/README.md"), BEGIN, END, &section)
}

/// The soak's output as markdown: its tables as they are, the lines between them in text
/// blocks, the progress lines (`  N s emulated in …`) left out.
fn markdown(output: &str) -> String {
    let mut md = String::new();
    let mut in_text = false;
    for line in output.lines() {
        if line.starts_with("  ") && line.contains(" emulated in ") {
            continue;
        }
        let table = line.starts_with('|');
        if table == in_text {
            md.push_str(if in_text { "```\n\n" } else { "\n```text\n" });
            in_text = !table;
        }
        md.push_str(line);
        md.push('\n');
    }
    if in_text {
        md.push_str("```\n");
    }
    md.trim_start().to_string()
}

#[cfg(test)]
mod tests {
    use super::markdown;

    #[test]
    fn tables_stay_tables_and_the_rest_goes_in_text_blocks_without_the_progress() {
        let out = "soak: 1 h emulated, seed 1\n  61 s emulated in 0 s: 1 frames\nperiods 3\n| a | b |\n|---|---|\n| 1 | 2 |\nworst: 8 periods\n";
        let md = markdown(out);
        assert!(!md.contains("61 s emulated in"), "{md}");
        assert!(
            md.starts_with("```text\nsoak: 1 h emulated, seed 1\nperiods 3\n```\n\n| a | b |\n"),
            "{md}"
        );
        assert!(
            md.ends_with("| 1 | 2 |\n\n```text\nworst: 8 periods\n```\n"),
            "{md}"
        );
    }
}
