//! The module graph of a crate read from its sources, and a check that it has no circle.
//!
//! A crate whose modules form layers can be read bottom up and split along them; a circle
//! (a module that, through others, depends on itself) hides which concern owns which code.
//! Each host crate runs [`assert_no_cycles`] from a test.
//!
//! How the graph is read:
//! - a node is a module file (`src/a/b.rs` or `src/a/b/mod.rs` is `a::b`; `lib.rs` is the root);
//! - every path `crate::…` or `super::…` in the file's non-test code is an edge to the deepest
//!   module that path names (so `crate::a::b::f` points at `a::b` when `a/b.rs` exists, at `a`
//!   otherwise): `use` lines and paths written inline both count;
//! - an edge from a module to one of its ancestors does not count: a parent declares its
//!   children, and a child may use what the parent defines;
//! - test code does not count: a file from its first `#[cfg(test)]` on, and files named
//!   `tests.rs` or under `tests/`.
//!
//! Re-exports do not hide a dependency: `use super::*` and `pub use x::*` are refused (a file
//! says what it uses and where it comes from), and a path that goes through a parent's
//! re-export to a sibling's item counts as an edge to the parent only, so such a path is a
//! blind spot the glob ban and explicit imports keep small.

mod lengths;

pub use lengths::{function_lengths, FnLength};

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};

/// A module's path below the crate root, segments joined by `::` (`""` for the root).
pub type ModulePath = String;

/// The modules of a crate and which ones each uses.
#[derive(Debug, Default)]
pub struct Graph {
    /// module → the modules it uses (ancestors left out)
    pub edges: BTreeMap<ModulePath, BTreeSet<ModulePath>>,
    /// `use super::*` or a glob `pub use` outside tests: (file, line number, line)
    pub globs: Vec<(PathBuf, usize, String)>,
}

fn module_of(src: &Path, file: &Path) -> ModulePath {
    let rel = file.strip_prefix(src).unwrap_or(file);
    let mut parts: Vec<String> = rel
        .iter()
        .map(|p| p.to_string_lossy().trim_end_matches(".rs").to_string())
        .collect();
    if matches!(
        parts.last().map(String::as_str),
        Some("mod" | "lib" | "main")
    ) {
        parts.pop();
    }
    parts.join("::")
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = fs::read_dir(dir) else {
        return;
    };
    let mut entries: Vec<PathBuf> = entries.filter_map(|e| e.ok().map(|e| e.path())).collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            if p.file_name().is_some_and(|n| n == "tests" || n == "bin") {
                continue;
            }
            rust_files(&p, out);
        } else if p.extension().is_some_and(|e| e == "rs")
            && p.file_name().is_some_and(|n| n != "tests.rs")
        {
            out.push(p);
        }
    }
}

/// The non-test part of a source, line comments removed: an item under `#[cfg(test)]` (a
/// `mod tests;` line or a braced block) is left out.
fn non_test(text: &str) -> Vec<(usize, String)> {
    let mut lines = Vec::new();
    let mut skipping = false;
    let mut depth = 0i64;
    let mut opened = false;
    for (i, line) in text.lines().enumerate() {
        let t = line.trim_start();
        if t.starts_with("//") {
            continue;
        }
        let code = match line.find("//") {
            Some(at) if !line[..at].contains('"') => &line[..at],
            _ => line,
        };
        if t.starts_with("#[cfg(test)]") {
            skipping = true;
            depth = 0;
            opened = false;
            continue;
        }
        if skipping {
            for c in code.chars() {
                match c {
                    '{' => {
                        depth += 1;
                        opened = true;
                    }
                    '}' => depth -= 1,
                    _ => {}
                }
            }
            let ends = if opened {
                depth <= 0
            } else {
                code.trim_end().ends_with(';')
            };
            if ends {
                skipping = false;
            }
            continue;
        }
        lines.push((i + 1, code.to_string()));
    }
    lines
}

/// Every `crate::a::b…` / `super::…` path in a line, as its segments (`{…}` groups expanded
/// one level: `crate::a::{b, c::d}` gives `crate::a::b` and `crate::a::c::d`).
fn paths_in(line: &str) -> Vec<Vec<String>> {
    let mut out = Vec::new();
    let bytes = line.as_bytes();
    let is_ident = |c: u8| c.is_ascii_alphanumeric() || c == b'_';
    let mut i = 0;
    while i < bytes.len() {
        let starts = line.is_char_boundary(i)
            && (line[i..].starts_with("crate::") || line[i..].starts_with("super::"))
            && (i == 0 || !is_ident(bytes[i - 1]));
        if !starts {
            i += 1;
            continue;
        }
        let mut segs = Vec::new();
        let mut j = i;
        loop {
            let s = j;
            while j < bytes.len() && is_ident(bytes[j]) {
                j += 1;
            }
            if s == j {
                break;
            }
            segs.push(line[s..j].to_string());
            if line[j..].starts_with("::") {
                j += 2;
                if line[j..].starts_with('{') {
                    let close = line[j..].find('}').map_or(line.len(), |c| j + c);
                    for part in line[j + 1..close].split(',') {
                        let mut full = segs.clone();
                        full.extend(
                            part.trim()
                                .split("::")
                                .map(|p| p.split_whitespace().next().unwrap_or("").to_string())
                                .filter(|p| !p.is_empty()),
                        );
                        out.push(full);
                    }
                    segs.clear();
                    j = close;
                    break;
                }
            } else {
                break;
            }
        }
        if !segs.is_empty() {
            out.push(segs);
        }
        i = j.max(i + 1);
    }
    out
}

/// Resolve a path written in module `from` to the deepest known module it names.
fn resolve(from: &str, segs: &[String], modules: &BTreeSet<ModulePath>) -> Option<ModulePath> {
    let mut base: Vec<&str> = if from.is_empty() {
        Vec::new()
    } else {
        from.split("::").collect()
    };
    let mut rest = segs;
    match rest.first().map(String::as_str) {
        Some("crate") => {
            base.clear();
            rest = &rest[1..];
        }
        Some("super") => {
            while rest.first().map(String::as_str) == Some("super") {
                base.pop()?;
                rest = &rest[1..];
            }
        }
        _ => return None,
    }
    let mut best = base.join("::");
    let mut cur = base.iter().map(|s| s.to_string()).collect::<Vec<_>>();
    for s in rest {
        if s == "self" {
            continue;
        }
        cur.push(s.clone());
        let name = cur.join("::");
        if modules.contains(&name) {
            best = name;
        } else {
            break;
        }
    }
    Some(best)
}

fn is_ancestor(a: &str, of: &str) -> bool {
    a.is_empty() || of.starts_with(&format!("{a}::"))
}

impl Graph {
    /// Read the module graph of the crate whose sources are under `src`.
    pub fn read(src: &Path) -> Graph {
        let mut files = Vec::new();
        rust_files(src, &mut files);
        let modules: BTreeSet<ModulePath> = files.iter().map(|f| module_of(src, f)).collect();
        let mut g = Graph::default();
        for f in &files {
            let me = module_of(src, f);
            let text = fs::read_to_string(f).unwrap_or_default();
            let deps = g.edges.entry(me.clone()).or_default();
            for (n, line) in non_test(&text) {
                let t = line.trim();
                if t.starts_with("use super::*")
                    || (t.starts_with("pub") && t.contains(" use ") && t.ends_with("::*;"))
                {
                    g.globs.push((f.clone(), n, t.to_string()));
                }
                for p in paths_in(&line) {
                    if let Some(to) = resolve(&me, &p, &modules) {
                        if to != me && !is_ancestor(&to, &me) {
                            deps.insert(to);
                        }
                    }
                }
            }
        }
        g
    }

    /// The circles of the graph, each as the modules along it (first repeated at the end).
    pub fn cycles(&self) -> Vec<Vec<ModulePath>> {
        // Tarjan's strongly connected components; each component of more than one module
        // is reported with one circle through it.
        let nodes: Vec<&ModulePath> = self.edges.keys().collect();
        let idx: BTreeMap<&str, usize> = nodes
            .iter()
            .enumerate()
            .map(|(i, n)| (n.as_str(), i))
            .collect();
        let adj: Vec<Vec<usize>> = nodes
            .iter()
            .map(|n| {
                self.edges[*n]
                    .iter()
                    .filter_map(|d| idx.get(d.as_str()).copied())
                    .collect()
            })
            .collect();
        let mut comps = Vec::new();
        let mut index = vec![usize::MAX; nodes.len()];
        let mut low = vec![0; nodes.len()];
        let mut on = vec![false; nodes.len()];
        let mut stack = Vec::new();
        let mut counter = 0;
        fn visit(
            v: usize,
            adj: &[Vec<usize>],
            st: &mut (Vec<usize>, Vec<usize>, Vec<bool>, Vec<usize>, usize),
            comps: &mut Vec<Vec<usize>>,
        ) {
            st.0[v] = st.4;
            st.1[v] = st.4;
            st.4 += 1;
            st.3.push(v);
            st.2[v] = true;
            for &w in &adj[v] {
                if st.0[w] == usize::MAX {
                    visit(w, adj, st, comps);
                    st.1[v] = st.1[v].min(st.1[w]);
                } else if st.2[w] {
                    st.1[v] = st.1[v].min(st.0[w]);
                }
            }
            if st.1[v] == st.0[v] {
                let mut comp = Vec::new();
                while let Some(w) = st.3.pop() {
                    st.2[w] = false;
                    comp.push(w);
                    if w == v {
                        break;
                    }
                }
                if comp.len() > 1 {
                    comps.push(comp);
                }
            }
        }
        let mut st = (
            std::mem::take(&mut index),
            std::mem::take(&mut low),
            std::mem::take(&mut on),
            std::mem::take(&mut stack),
            counter,
        );
        for v in 0..nodes.len() {
            if st.0[v] == usize::MAX {
                visit(v, &adj, &mut st, &mut comps);
            }
        }
        counter = st.4;
        let _ = counter;
        comps
            .into_iter()
            .map(|comp| {
                // one circle through the component: a shortest path back to its first node
                let inside: BTreeSet<usize> = comp.iter().copied().collect();
                let start = *comp.iter().min().unwrap_or(&comp[0]);
                let mut prev = vec![usize::MAX; nodes.len()];
                let mut queue = std::collections::VecDeque::from([start]);
                let mut found = None;
                while let Some(v) = queue.pop_front() {
                    for &w in &adj[v] {
                        if !inside.contains(&w) {
                            continue;
                        }
                        if w == start {
                            found = Some(v);
                            break;
                        }
                        if prev[w] == usize::MAX {
                            prev[w] = v;
                            queue.push_back(w);
                        }
                    }
                    if found.is_some() {
                        break;
                    }
                }
                let mut path = vec![start];
                let mut v = found.unwrap_or(start);
                while v != start {
                    path.push(v);
                    v = prev[v];
                }
                path.push(start);
                path.reverse();
                path.into_iter().map(|i| display(nodes[i])).collect()
            })
            .collect()
    }
}

fn display(m: &str) -> String {
    if m.is_empty() {
        "crate".into()
    } else {
        m.to_string()
    }
}

/// Panic with every circle between the modules of the crate under `src`, if there is any.
pub fn assert_no_cycles(src: impl AsRef<Path>) {
    let msg: String = Graph::read(src.as_ref())
        .cycles()
        .iter()
        .map(|c| format!("import circle: {}\n", c.join(" → ")))
        .collect();
    assert!(msg.is_empty(), "{msg}");
}

/// Panic with every glob import (`use super::*`, `pub use x::*`) outside the tests of the
/// crate under `src`, if there is any.
pub fn assert_explicit_imports(src: impl AsRef<Path>) {
    let msg: String = Graph::read(src.as_ref())
        .globs
        .iter()
        .map(|(f, n, l)| {
            format!(
                "glob import (name what the file uses): {}:{n}: {l}\n",
                f.display()
            )
        })
        .collect();
    assert!(msg.is_empty(), "{msg}");
}

#[cfg(test)]
mod tests {
    use super::*;
    use tempfile::TempDir;

    fn write(dir: &Path, files: &[(&str, &str)]) {
        for (p, t) in files {
            let p = dir.join(p);
            fs::create_dir_all(p.parent().unwrap()).unwrap();
            fs::write(p, t).unwrap();
        }
    }

    /// A fresh directory; keep the guard for the whole test: it is removed when the test
    /// ends, pass or fail.
    fn tmp(name: &str) -> TempDir {
        tempfile::Builder::new()
            .prefix(&format!("pam-modgraph-{name}-"))
            .tempdir()
            .unwrap()
    }

    #[test]
    fn finds_a_circle_through_siblings_and_inline_paths() {
        let dir = tmp("circle");
        let d = dir.path();
        write(
            d,
            &[
                ("lib.rs", "mod a;\nmod b;\n"),
                ("a/mod.rs", "mod x;\nmod y;\n"),
                ("a/x.rs", "use super::y::f;\n"),
                ("a/y.rs", "fn g() { crate::b::h(); }\n"),
                ("b.rs", "use crate::a::{x::k, self};\n"),
            ],
        );
        let cycles = Graph::read(d).cycles();
        assert_eq!(cycles.len(), 1, "{cycles:?}");
        assert_eq!(cycles[0].first(), cycles[0].last());
        assert_eq!(cycles[0].len(), 4, "{cycles:?}");
    }

    #[test]
    fn a_child_may_use_its_parent_and_tests_do_not_count() {
        let dir = tmp("layers");
        let d = dir.path();
        write(
            d,
            &[
                ("lib.rs", "mod a;\nmod b;\nmod c;\npub use a::Thing;\n"),
                ("c.rs", "pub fn k() {}\n"),
                ("a/mod.rs", "mod x;\npub struct Thing;\npub use x::f;\n"),
                ("a/x.rs", "use super::Thing;\nuse crate::b::g;\n"),
                ("b.rs", "#[cfg(test)]\nmod t;\npub fn g() {}\n#[cfg(test)]\nmod tests {\n use crate::a::x::f;\n}\nfn h() { crate::c::k() }\n"),
            ],
        );
        let g = Graph::read(d);
        assert!(g.cycles().is_empty(), "{:?}", g.cycles());
        assert!(g.globs.is_empty());
        assert!(g.edges["a::x"].contains("b"));
        let b: Vec<&str> = g.edges["b"].iter().map(String::as_str).collect();
        assert_eq!(
            b,
            ["c"],
            "code after a test item counts, the test item does not"
        );
    }

    #[test]
    fn refuses_glob_imports() {
        let dir = tmp("globs");
        let d = dir.path();
        write(
            d,
            &[
                ("lib.rs", "mod a;\npub use a::*;\n"),
                ("a.rs", "use super::*;\n"),
            ],
        );
        assert_eq!(Graph::read(d).globs.len(), 2);
    }
}
