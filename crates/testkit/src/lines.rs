//! No function longer than a screen: a simple scanner that the crates' `function_length`
//! tests share. A line that starts a `fn` (after its visibility and qualifiers) opens a
//! function; its length runs from that line to the line where the brace depth falls back to
//! where it was. Strings, characters and comments are skipped well enough for this project's
//! style (no braces in raw strings across lines).

use std::path::{Path, PathBuf};

/// The longest a function may be, in lines (its signature and closing brace included).
pub const LIMIT: usize = 150;

/// Panics, naming each, if a function in the `.rs` files under `dir` (at least 10 of them, so
/// that a wrong folder cannot pass) is longer than [`LIMIT`]: a crate's `function_length` test.
pub fn assert_short(dir: &Path) {
    let long = over_limit(dir, 10);
    assert!(long.is_empty(), "over {LIMIT} lines:\n{}", long.join("\n"));
}

/// Every function over [`LIMIT`] lines in the `.rs` files under `dir`, as
/// `FILE:LINE fn NAME: N lines`; panics if `dir` holds fewer than `at_least` files (so that a
/// wrong folder cannot pass).
pub fn over_limit(dir: &Path, at_least: usize) -> Vec<String> {
    let files = sources(dir);
    assert!(
        files.len() >= at_least,
        "{}: {} sources",
        dir.display(),
        files.len()
    );
    let mut long = Vec::new();
    for file in files {
        let text = std::fs::read_to_string(&file).expect("a source file");
        for (name, line, len) in too_long(&text, LIMIT) {
            long.push(format!("{}:{line} fn {name}: {len} lines", file.display()));
        }
    }
    long
}

/// Every `.rs` file under `dir`.
pub fn sources(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir(dir).expect("the source directory") {
        let path = entry.expect("an entry").path();
        if path.is_dir() {
            out.extend(sources(&path));
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
    out.sort();
    out
}

/// The braces of `line` that count: outside strings, characters and `//` comments.
fn braces(line: &str) -> impl Iterator<Item = i64> + '_ {
    let mut in_str = false;
    let mut prev = ' ';
    let mut chars = line.chars().peekable();
    let mut out = Vec::new();
    while let Some(c) = chars.next() {
        match c {
            '"' if prev != '\\' => in_str = !in_str,
            '/' if !in_str && chars.peek() == Some(&'/') => break,
            '\'' if !in_str => {
                // A character literal ('{', '\'') is skipped; a lifetime is not one.
                let rest: String = chars.clone().take(3).collect();
                if rest.chars().nth(1) == Some('\'') {
                    chars.nth(1);
                } else if rest.starts_with('\\') && rest.chars().nth(2) == Some('\'') {
                    chars.nth(2);
                }
            }
            '{' if !in_str => out.push(1),
            '}' if !in_str => out.push(-1),
            _ => {}
        }
        prev = if prev == '\\' && c == '\\' { ' ' } else { c };
    }
    out.into_iter()
}

/// Whether `line` starts a function.
fn starts_fn(line: &str) -> Option<String> {
    let mut words = line.split_whitespace();
    loop {
        let w = words.next()?;
        if w.starts_with("pub") || ["const", "async", "unsafe", "extern", "default"].contains(&w) {
            continue;
        }
        if w != "fn" {
            return None;
        }
        let name = words.next()?;
        return Some(name.split(['(', '<']).next().unwrap_or(name).to_string());
    }
}

/// Every function of `text` longer than `limit` lines: its name, first line and length.
pub fn too_long(text: &str, limit: usize) -> Vec<(String, usize, usize)> {
    let mut open: Vec<(String, usize, i64)> = Vec::new();
    let mut depth = 0i64;
    let mut found = Vec::new();
    for (n, line) in text.lines().enumerate() {
        if let Some(name) = starts_fn(line) {
            open.push((name, n, depth));
        }
        for b in braces(line) {
            depth += b;
            if b < 0 && open.last().is_some_and(|f| f.2 == depth) {
                let (name, start, _) = open.pop().expect("an open function");
                let len = n - start + 1;
                if len > limit {
                    found.push((name, start + 1, len));
                }
            }
        }
        // A declaration with no body (a trait's method) ends at its semicolon.
        if line.trim_end().ends_with(';') && open.last().is_some_and(|f| f.2 == depth) {
            open.pop();
        }
    }
    found
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_scanner_measures_a_function() {
        let body = "    let x = '{';\n    let s = \"}}\"; // }\n".repeat(3);
        let text = format!(
            "impl A {{\n    pub(crate) fn f(&self) -> u8 {{\n{body}    }}\n\n    fn g();\n}}\n"
        );
        assert_eq!(too_long(&text, 7), vec![("f".to_string(), 2, 8)]);
        assert!(too_long(&text, 8).is_empty());
    }
}
