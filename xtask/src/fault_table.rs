//! `cargo xtask fault-table [--write]`: the consequences of every fault kind from every mode,
//! held and free, measured on the twin in fast-forward (`pam-emulator`'s `fault_table`
//! example, release build), headed by the date and the commit. Printed; with `--write` it
//! also replaces the section between [`BEGIN`] and [`END`] in hil-tests/README.md.

use std::path::Path;
use std::process::{Command, Stdio};

use crate::{cargo_in, root};

/// The markers around the generated section of hil-tests/README.md.
pub const BEGIN: &str = "<!-- fault-table:begin (cargo xtask fault-table --write) -->";
pub const END: &str = "<!-- fault-table:end -->";

pub fn fault_table(args: &[String]) -> i32 {
    let write = match args {
        [] => false,
        [a] if a == "--write" => true,
        _ => {
            eprintln!("usage: cargo xtask fault-table [--write]");
            return 2;
        }
    };
    let root = root();
    let stamp = format!(
        "Measured {} at commit {} (`cargo xtask fault-table`, release build, fast-forward).",
        output(Command::new("date").args(["-u", "+%Y-%m-%d %H:%M UTC"])),
        commit(&root)
    );
    let run = cargo_in(&root)
        .args([
            "run",
            "--release",
            "-p",
            "pam-emulator",
            "--example",
            "fault_table",
            "--",
            "--stamp",
            &stamp,
        ])
        .stderr(Stdio::inherit())
        .output();
    let table = match run {
        Ok(o) if o.status.success() => String::from_utf8_lossy(&o.stdout).into_owned(),
        Ok(o) => {
            eprintln!("xtask: the fault table failed ({})", o.status);
            return 1;
        }
        Err(e) => {
            eprintln!("xtask: could not start cargo: {e}");
            return 1;
        }
    };
    print!("{table}");
    if !write {
        return 0;
    }
    write_readme_section(&root.join("hil-tests/README.md"), BEGIN, END, &table)
}

/// Rewrites the part of `readme` between `begin` and `end` with `section`; the exit code.
pub fn write_readme_section(readme: &Path, begin: &str, end: &str, section: &str) -> i32 {
    match std::fs::read_to_string(readme)
        .map_err(|e| e.to_string())
        .and_then(|text| replace_between(&text, begin, end, section))
        .and_then(|text| std::fs::write(readme, text).map_err(|e| e.to_string()))
    {
        Ok(()) => {
            eprintln!("xtask: {} rewritten", readme.display());
            0
        }
        Err(e) => {
            eprintln!("xtask: {}: {e}", readme.display());
            1
        }
    }
}

/// `text` with everything between `begin` and the next `end` replaced by `section`.
pub fn replace_between(
    text: &str,
    begin: &str,
    end: &str,
    section: &str,
) -> Result<String, String> {
    let start = text
        .find(begin)
        .ok_or_else(|| format!("no `{begin}` marker"))?
        + begin.len();
    let stop = start
        + text[start..]
            .find(end)
            .ok_or_else(|| format!("no `{end}` marker after the first"))?;
    Ok(format!(
        "{}\n\n{}\n{}",
        &text[..start],
        section.trim_end(),
        &text[stop..]
    ))
}

/// The date and commit of a measurement, for a stamp.
pub fn date_and_commit(root: &Path) -> (String, String) {
    (
        output(Command::new("date").args(["-u", "+%Y-%m-%d %H:%M UTC"])),
        commit(root),
    )
}

fn output(cmd: &mut Command) -> String {
    cmd.output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
        .unwrap_or_else(|| "?".into())
}

/// The short commit, `-dirty` with uncommitted changes.
fn commit(root: &Path) -> String {
    let hash = output(
        Command::new("git")
            .current_dir(root)
            .args(["rev-parse", "--short", "HEAD"]),
    );
    let dirty = !output(
        Command::new("git")
            .current_dir(root)
            .args(["status", "--porcelain"]),
    )
    .is_empty();
    if dirty {
        format!("{hash}-dirty")
    } else {
        hash
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_section_between_the_markers_is_replaced_and_the_rest_kept() {
        let text = format!("# A\n{BEGIN}\nold table\n{END}\n# B\n");
        let out = replace_between(&text, BEGIN, END, "new table\n").unwrap();
        assert_eq!(out, format!("# A\n{BEGIN}\n\nnew table\n{END}\n# B\n"));
        // idempotent
        assert_eq!(
            replace_between(&out, BEGIN, END, "new table\n").unwrap(),
            out
        );
        assert!(replace_between("# A\n", BEGIN, END, "x").is_err());
        assert!(replace_between(&format!("{BEGIN} no end"), BEGIN, END, "x").is_err());
    }
}
