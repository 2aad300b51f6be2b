//! The crate graph in ARCHITECTURE.md is the one the manifests declare: for every crate of
//! the project, its `pam-*` dependencies and dev-dependencies (optional ones aside: the
//! block names them in a note) as the block lists them, and no crate missing from it.

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};

/// A crate's project dependencies: (normal, dev), without the `pam-` prefix.
type Deps = (BTreeSet<String>, BTreeSet<String>);

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The block after "An arrow reads": `name → a, b [c, d]`, continued on indented lines;
/// parentheses are notes.
fn documented() -> BTreeMap<String, Deps> {
    let text = fs::read_to_string(root().join("ARCHITECTURE.md")).expect("ARCHITECTURE.md");
    let start = text
        .find("An arrow reads")
        .expect("the crate graph's block");
    let block = &text[start..];
    let open = block.find("```\n").expect("the block opens") + 4;
    let close = open + block[open..].find("```").expect("the block closes");
    let mut entries: Vec<(String, String)> = Vec::new();
    for line in block[open..close].lines() {
        if let Some((name, rest)) = line.split_once('→') {
            entries.push((name.trim().to_string(), rest.to_string()));
        } else if let Some(last) = entries.last_mut() {
            last.1.push(' ');
            last.1.push_str(line);
        }
    }
    entries
        .into_iter()
        .map(|(name, rest)| (name, parse_entry(&rest)))
        .collect()
}

fn parse_entry(rest: &str) -> Deps {
    let mut plain = String::new();
    let mut depth = 0;
    for c in rest.chars() {
        match c {
            '(' => depth += 1,
            ')' => depth -= 1,
            _ if depth == 0 => plain.push(c),
            _ => {}
        }
    }
    let (normal, dev) = match plain.split_once('[') {
        Some((n, d)) => (n.to_string(), d.split(']').next().unwrap_or("").to_string()),
        None => (plain, String::new()),
    };
    let names = |s: &str| -> BTreeSet<String> {
        s.split(',')
            .map(str::trim)
            .filter(|n| !n.is_empty())
            .map(String::from)
            .collect()
    };
    (names(&normal), names(&dev))
}

/// Every Cargo.toml of the project but the workspace's own, outside build directories.
fn manifests(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in fs::read_dir(dir).expect("a readable directory").flatten() {
        let path = entry.path();
        let name = entry.file_name();
        let name = name.to_string_lossy();
        if path.is_dir() {
            if !name.starts_with('.') && name != "target" && name != "corpus" {
                manifests(&path, out);
            }
        } else if name == "Cargo.toml" && dir != root().as_path() {
            out.push(path);
        }
    }
}

/// (package name, its project dependencies) from one manifest.
fn declared(manifest: &Path) -> (String, Deps) {
    let text = fs::read_to_string(manifest).expect("a readable manifest");
    let mut name = String::new();
    let (mut normal, mut dev) = (BTreeSet::new(), BTreeSet::new());
    let mut section = String::new();
    for line in text.lines().map(str::trim) {
        if line.starts_with('[') {
            section = line.to_string();
            continue;
        }
        let Some((key, value)) = line.split_once('=') else {
            continue;
        };
        let key = key.trim();
        if section == "[package]" && key == "name" {
            name = value.trim().trim_matches('"').to_string();
        }
        let project = key.starts_with("pam-") || key == "pamctl";
        if !project || value.contains("optional = true") || key == name {
            continue;
        }
        let short = key.trim_start_matches("pam-").to_string();
        match section.as_str() {
            "[dependencies]" => normal.insert(short),
            "[dev-dependencies]" => dev.insert(short),
            _ => false,
        };
    }
    (name, (normal, dev))
}

#[test]
fn the_documented_crate_graph_is_the_manifests_one() {
    let documented = documented();
    let mut found = Vec::new();
    manifests(&root(), &mut found);
    let mut wrong = Vec::new();
    for manifest in &found {
        let (name, deps) = declared(manifest);
        if name == "xtask" {
            continue; // the project's jobs, not a crate of the product
        }
        match documented.get(&name) {
            None => wrong.push(format!(
                "{name} ({}) is not in the block",
                manifest.display()
            )),
            Some(doc) if *doc != deps => wrong.push(format!(
                "{name}: the block says {:?} [{:?}], the manifest {:?} [{:?}]",
                doc.0, doc.1, deps.0, deps.1
            )),
            Some(_) => {}
        }
    }
    assert!(found.len() > 20, "only {} manifests found", found.len());
    assert!(
        wrong.is_empty(),
        "ARCHITECTURE.md's crate graph:\n{}",
        wrong.join("\n")
    );
}
