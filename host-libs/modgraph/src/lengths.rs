//! The length of every function of a crate's non-test code, to keep them short enough to
//! read: `cargo run -p pam-modgraph --bin longest-functions -- N DIR...` prints the N
//! longest under the source folders given.
//!
//! A function runs from its `fn` line to the line of its closing brace, both counted. The
//! braces are matched outside string and character literals and comments; a nested function
//! is counted within its parent and on its own. Test code is left out as in the module graph:
//! a file from its first `#[cfg(test)]` on, and files named `tests.rs` or under `tests/`.

use std::path::{Path, PathBuf};

/// A function and its length.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FnLength {
    pub file: PathBuf,
    /// 1-based line of its `fn`.
    pub line: usize,
    pub name: String,
    pub lines: usize,
}

/// Every function with a body in the non-test code under `src`, longest first.
pub fn function_lengths(src: &Path) -> Vec<FnLength> {
    let mut files = Vec::new();
    crate::rust_files(src, &mut files);
    let mut out: Vec<FnLength> = files
        .iter()
        .filter_map(|f| Some((f, std::fs::read_to_string(f).ok()?)))
        .flat_map(|(f, text)| {
            let code = text.split("#[cfg(test)]").next().unwrap_or("");
            lengths_in(code)
                .into_iter()
                .map(move |(line, name, lines)| FnLength {
                    file: f.clone(),
                    line,
                    name,
                    lines,
                })
        })
        .collect();
    out.sort_by(|a, b| b.lines.cmp(&a.lines).then(a.file.cmp(&b.file)));
    out
}

/// The name of the function a line declares, if it does.
fn declared_fn(line: &str) -> Option<String> {
    let mut rest = line.trim_start();
    if let Some(r) = rest.strip_prefix("pub") {
        rest = r.trim_start();
        if rest.starts_with('(') {
            rest = rest[rest.find(')')? + 1..].trim_start();
        }
    }
    for q in ["const ", "async ", "unsafe ", "extern \"C\" "] {
        if let Some(r) = rest.strip_prefix(q) {
            rest = r.trim_start();
        }
    }
    let name: String = rest
        .strip_prefix("fn ")?
        .chars()
        .take_while(|c| c.is_alphanumeric() || *c == '_')
        .collect();
    (!name.is_empty()).then_some(name)
}

/// The code of `text` with string and character literals and comments blanked (line breaks
/// kept), so that braces can be counted.
fn blank_literals(text: &str) -> String {
    let c: Vec<char> = text.chars().collect();
    let mut out = String::with_capacity(text.len());
    let mut i = 0;
    let blank = |out: &mut String, s: &[char]| {
        out.extend(s.iter().map(|&ch| if ch == '\n' { '\n' } else { ' ' }))
    };
    while i < c.len() {
        let start = i;
        if c[i] == '/' && c.get(i + 1) == Some(&'/') {
            while i < c.len() && c[i] != '\n' {
                i += 1;
            }
        } else if c[i] == '/' && c.get(i + 1) == Some(&'*') {
            i += 2;
            while i < c.len() && !(c[i] == '*' && c.get(i + 1) == Some(&'/')) {
                i += 1;
            }
            i = (i + 2).min(c.len());
        } else if c[i] == 'r' && matches!(c.get(i + 1), Some('"' | '#')) {
            // a raw string: r"…" or r#"…"#
            let hashes = c[i + 1..].iter().take_while(|&&h| h == '#').count();
            if c.get(i + 1 + hashes) != Some(&'"') {
                out.push(c[i]);
                i += 1;
                continue;
            }
            i += 2 + hashes;
            while i < c.len()
                && !(c[i] == '"'
                    && c[i + 1..]
                        .iter()
                        .take(hashes)
                        .filter(|&&h| h == '#')
                        .count()
                        == hashes)
            {
                i += 1;
            }
            i = (i + 1 + hashes).min(c.len());
        } else if c[i] == '"' {
            i += 1;
            while i < c.len() && c[i] != '"' {
                i += if c[i] == '\\' { 2 } else { 1 };
            }
            i = (i + 1).min(c.len());
        } else if c[i] == '\'' && (c.get(i + 1) == Some(&'\\') || c.get(i + 2) == Some(&'\'')) {
            // a character literal ('x', '\n', '\''); a lifetime has no closing quote
            i += 2;
            while i < c.len() && c[i] != '\'' {
                i += 1;
            }
            i = (i + 1).min(c.len());
        } else {
            out.push(c[i]);
            i += 1;
            continue;
        }
        blank(&mut out, &c[start..i.min(c.len())]);
    }
    out
}

/// (line, name, length) of each function with a body in `code`.
fn lengths_in(code: &str) -> Vec<(usize, String, usize)> {
    let code = blank_literals(code);
    let lines: Vec<&str> = code.lines().collect();
    let mut out = Vec::new();
    for (start, line) in lines.iter().enumerate() {
        let Some(name) = declared_fn(line) else {
            continue;
        };
        // the body opens at the first `{` outside the signature's parentheses; a `;` first
        // is a declaration without a body
        let (mut depth, mut parens, mut opened) = (0i64, 0i64, false);
        'lines: for (k, l) in lines.iter().enumerate().skip(start) {
            let from = if k == start {
                l.find("fn ").unwrap_or(0)
            } else {
                0
            };
            for ch in l[from..].chars() {
                match ch {
                    '(' | '[' if !opened => parens += 1,
                    ')' | ']' if !opened => parens -= 1,
                    ';' if !opened && parens <= 0 => break 'lines,
                    '{' => {
                        opened = true;
                        depth += 1;
                    }
                    '}' if opened => {
                        depth -= 1;
                        if depth == 0 {
                            out.push((start + 1, name.clone(), k - start + 1));
                            break 'lines;
                        }
                    }
                    _ => {}
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_from_the_fn_line_to_its_closing_brace() {
        let code = "pub(crate) fn a(x: Vec<u8>) -> usize {\n    let s = \"}}{\";\n    let c = '}';\n    // }\n    x.len()\n}\nfn decl();\nfn b<'a>(s: &'a str)\n    -> &'a str\n{\n    s\n}\n";
        assert_eq!(
            lengths_in(code),
            vec![(1, "a".to_string(), 6), (8, "b".to_string(), 5)]
        );
    }

    #[test]
    fn raw_strings_and_comments_hide_their_braces() {
        let code = "fn a() {\n    let s = r#\"{ \"{\" \"#;\n    /* { */\n}\n";
        assert_eq!(lengths_in(code), vec![(1, "a".to_string(), 4)]);
    }
}
