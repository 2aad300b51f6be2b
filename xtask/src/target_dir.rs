//! Where cargo puts the artifacts, whatever `CARGO_TARGET_DIR` says.
//!
//! Unset, each workspace builds into its own `target/` (the host workspace into `target/`,
//! the firmware into `firmware/target/`, the QEMU image into `qemu-tests/target/`). Set, it
//! overrides every workspace's target directory: all three build into it. A relative value is
//! relative to the directory cargo runs in, so the xtask, which runs cargo in the firmware's
//! and the QEMU image's directories, first makes it absolute against its own working
//! directory (where `cargo xtask` was typed). The firmware's ELF is then found where cargo
//! says (`cargo metadata`'s `target_directory`), which also honours `build.target-dir` in a
//! cargo configuration file.

use std::ffi::OsStr;
use std::fmt;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The value of `CARGO_TARGET_DIR` made absolute against `cwd`; `None` when it is unset or
/// empty (cargo's default: each workspace's own `target/`).
pub fn absolute_target_dir(value: Option<&OsStr>, cwd: &Path) -> Option<PathBuf> {
    let v = Path::new(value.filter(|v| !v.is_empty())?);
    Some(if v.is_absolute() {
        v.to_path_buf()
    } else {
        cwd.join(v)
    })
}

/// Why the target directory could not be asked of cargo.
#[derive(Debug)]
pub enum TargetDirError {
    /// cargo did not start.
    Start(std::io::Error),
    /// `cargo metadata` failed (its stderr).
    Metadata(String),
    /// Its output has no `target_directory` string.
    NoField,
}

impl fmt::Display for TargetDirError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            TargetDirError::Start(e) => write!(f, "could not start cargo metadata: {e}"),
            TargetDirError::Metadata(e) => write!(f, "cargo metadata failed: {}", e.trim()),
            TargetDirError::NoField => f.write_str("cargo metadata gave no target_directory"),
        }
    }
}

/// The target directory of the workspace `cargo` sees when run with `cmd`'s directory and
/// environment (`cmd` is a `cargo` command without arguments).
pub fn target_directory(mut cmd: Command) -> Result<PathBuf, TargetDirError> {
    let out = cmd
        .args(["metadata", "--format-version", "1", "--no-deps"])
        .output()
        .map_err(TargetDirError::Start)?;
    if !out.status.success() {
        return Err(TargetDirError::Metadata(
            String::from_utf8_lossy(&out.stderr).into_owned(),
        ));
    }
    json_string_field(&String::from_utf8_lossy(&out.stdout), "target_directory")
        .map(PathBuf::from)
        .ok_or(TargetDirError::NoField)
}

/// The first string value of `"key":` in compact JSON (cargo's output), unescaped.
fn json_string_field(json: &str, key: &str) -> Option<String> {
    let start = json.find(&format!("\"{key}\":\""))? + key.len() + 4;
    let mut value = String::new();
    let mut chars = json[start..].chars();
    loop {
        match chars.next()? {
            '"' => return Some(value),
            '\\' => value.push(match chars.next()? {
                'n' => '\n',
                't' => '\t',
                'r' => '\r',
                'b' => '\u{8}',
                'f' => '\u{c}',
                'u' => {
                    let hex: String = chars.by_ref().take(4).collect();
                    char::from_u32(u32::from_str_radix(&hex, 16).ok()?)?
                }
                c => c, // \" \\ \/
            }),
            c => value.push(c),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::ffi::OsString;

    #[test]
    fn relative_values_are_made_absolute_against_the_working_directory() {
        let cwd = Path::new("/home/me/somewhere");
        let abs = OsString::from("/tmp/tgt");
        let rel = OsString::from("reltgt/x");
        let up = OsString::from("../t");
        assert_eq!(
            absolute_target_dir(Some(&abs), cwd),
            Some(PathBuf::from("/tmp/tgt"))
        );
        assert_eq!(
            absolute_target_dir(Some(&rel), cwd),
            Some(PathBuf::from("/home/me/somewhere/reltgt/x"))
        );
        assert_eq!(
            absolute_target_dir(Some(&up), cwd),
            Some(PathBuf::from("/home/me/somewhere/../t"))
        );
        assert_eq!(absolute_target_dir(None, cwd), None);
        assert_eq!(absolute_target_dir(Some(OsStr::new("")), cwd), None);
    }

    #[test]
    fn json_string_field_unescapes() {
        let j = r#"{"packages":[],"target_directory":"/a \"b\"\\c\u00e9/d","version":1}"#;
        assert_eq!(
            json_string_field(j, "target_directory").as_deref(),
            Some("/a \"b\"\\cé/d")
        );
        assert_eq!(json_string_field(j, "workspace_root"), None);
        assert_eq!(
            json_string_field(r#"{"target_directory":"/cut"#, "target_directory"),
            None
        );
    }

    /// Cargo itself, on the firmware's workspace: its own `target/` when unset, the variable
    /// when set — what the firmware's size check reads the ELF from.
    #[test]
    fn cargo_metadata_follows_the_variable() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap();
        let firmware = root.join("firmware");
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
        let cmd = |target: Option<&Path>| {
            let mut c = Command::new(&cargo);
            c.current_dir(&firmware)
                .env_remove("CARGO_TARGET_DIR")
                .env_remove("CARGO_BUILD_TARGET_DIR");
            if let Some(t) = target {
                c.env("CARGO_TARGET_DIR", t);
            }
            c
        };
        assert_eq!(
            target_directory(cmd(None)).unwrap(),
            firmware.join("target")
        );
        let elsewhere = std::env::temp_dir().join("xtask-target-dir-test");
        assert_eq!(target_directory(cmd(Some(&elsewhere))).unwrap(), elsewhere);
        // a relative value, as the xtask passes it on: made absolute first
        let cwd = std::env::temp_dir();
        let rel = absolute_target_dir(Some(OsStr::new("reltgt")), &cwd).unwrap();
        assert_eq!(
            target_directory(cmd(Some(&rel))).unwrap(),
            cwd.join("reltgt")
        );
    }
}
