//! The book (`book/src`) and the README: every relative link and `#anchor` resolves, every
//! chapter is in the contents, the generated reference files are what `orch` prints, and every
//! shell example runs.
//!
//! Shell examples are fenced code blocks:
//!
//! - ```` ```console ````: each `$ COMMAND` line (a trailing `\` continues it) is run with bash in
//!   the chapter's scratch directory, standard error joined to standard output. The lines after it,
//!   up to the next `$`, are the output it must print. `[..]` in a line matches any text; a line
//!   `...` matches any number of lines. A line `? N` right after the command is its exit code
//!   (0 otherwise).
//! - ```` ```sh ````: the block is one bash script (`set -euo pipefail`) run in the chapter's
//!   scratch directory; it must exit 0. Its output is not shown, so not compared.
//! - ```` ```sh,norun ```` or ```` ```console,norun ````: not run (real hardware, `sudo`, minutes
//!   of CPU). The paragraph just before it must say why, with the words "not run by the tests",
//!   or the chapter's opening (before its first `##` section) must, for all of its blocks.
//!
//! Each chapter gets one scratch directory, shared by its blocks in order, so a block may use a
//! file an earlier one wrote. It holds `examples/` (a link to the repository's). `orch` is the
//! binary under test, first on `PATH`.
//!
//! `ORCH_BOOK_UPDATE=1 cargo test -p orch --test book` rewrites the generated files: the
//! reference's robot.toml files and the piano roll.

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Component, Path, PathBuf};
use std::process::Command;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn book_src() -> PathBuf {
    root().join("book/src")
}

/// Every `.md` file under `dir`, sorted.
fn markdown_files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in fs::read_dir(&d).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else if path.extension().is_some_and(|e| e == "md") {
                out.push(path);
            }
        }
    }
    out.sort();
    out
}

/// A fenced code block: its info string, its lines, the line it starts on (1-based) and the
/// paragraph of text just before it.
struct Block {
    info: String,
    lines: Vec<String>,
    line: usize,
    before: String,
}

/// The text outside code blocks (code lines blanked, so line numbers stay) and the blocks.
fn parse(text: &str) -> (Vec<String>, Vec<Block>) {
    let mut prose = Vec::new();
    let mut blocks = Vec::new();
    let mut current: Option<Block> = None;
    let mut paragraph: Vec<String> = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let trimmed = line.trim_start();
        match current.as_mut() {
            Some(block) => {
                if trimmed.starts_with("```") {
                    blocks.push(current.take().unwrap());
                } else {
                    block.lines.push(line.to_string());
                }
                prose.push(String::new());
            }
            None => {
                if let Some(info) = trimmed.strip_prefix("```") {
                    current = Some(Block {
                        info: info.trim().to_string(),
                        lines: Vec::new(),
                        line: i + 1,
                        before: paragraph.join(" "),
                    });
                    prose.push(String::new());
                } else {
                    // The last paragraph stays until the next one starts.
                    if !line.trim().is_empty() {
                        if prose.last().is_none_or(|l: &String| l.trim().is_empty()) {
                            paragraph.clear();
                        }
                        paragraph.push(line.to_string());
                    }
                    prose.push(line.to_string());
                }
            }
        }
    }
    assert!(current.is_none(), "a code block is not closed");
    (prose, blocks)
}

/// mdBook's id for a heading (mdbook 0.4's `id_from_content` on the rendered heading).
fn heading_id(heading: &str) -> String {
    let mut text = String::new();
    // A link in a heading renders as its text.
    let mut rest = heading;
    while let Some(open) = rest.find('[') {
        text.push_str(&rest[..open]);
        let after = &rest[open + 1..];
        match (after.find("]("), after.find(')')) {
            (Some(close), Some(end)) if close < end => {
                text.push_str(&after[..close]);
                rest = &after[end + 1..];
            }
            _ => {
                text.push('[');
                rest = after;
            }
        }
    }
    text.push_str(rest);
    text.chars()
        .filter(|c| *c != '`' && *c != '*')
        .collect::<String>()
        .trim()
        .chars()
        .filter_map(|c| {
            if c.is_alphanumeric() || c == '_' || c == '-' {
                Some(c.to_ascii_lowercase())
            } else if c.is_whitespace() {
                Some('-')
            } else {
                None
            }
        })
        .collect()
}

/// The ids of a file's headings, with mdBook's `-1`, `-2` for repeats.
fn anchors(path: &Path) -> BTreeSet<String> {
    let (prose, _) = parse(&fs::read_to_string(path).unwrap());
    let mut seen: BTreeMap<String, usize> = BTreeMap::new();
    let mut ids = BTreeSet::new();
    for line in prose {
        let Some(heading) = line.strip_prefix('#') else {
            continue;
        };
        let heading = heading.trim_start_matches('#');
        if !heading.starts_with(' ') {
            continue;
        }
        let id = heading_id(heading);
        let n = seen.entry(id.clone()).or_insert(0);
        ids.insert(if *n == 0 {
            id.clone()
        } else {
            format!("{id}-{n}")
        });
        *n += 1;
    }
    ids
}

/// The targets of the inline links `[text](target)` of a line, outside inline code.
fn links(line: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut in_code = false;
    let chars: Vec<char> = line.chars().collect();
    let mut i = 0;
    while i < chars.len() {
        match chars[i] {
            '`' => in_code = !in_code,
            ']' if !in_code && chars.get(i + 1) == Some(&'(') => {
                let start = i + 2;
                let mut depth = 1;
                let mut j = start;
                while j < chars.len() {
                    match chars[j] {
                        '(' => depth += 1,
                        ')' => {
                            depth -= 1;
                            if depth == 0 {
                                break;
                            }
                        }
                        _ => {}
                    }
                    j += 1;
                }
                let target: String = chars[start..j.min(chars.len())].iter().collect();
                out.push(target.split_whitespace().next().unwrap_or("").to_string());
                i = j;
            }
            _ => {}
        }
        i += 1;
    }
    out
}

/// A path with `.` and `..` taken out, without touching the file system.
fn clean(path: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for c in path.components() {
        match c {
            Component::ParentDir => {
                out.pop();
            }
            Component::CurDir => {}
            other => out.push(other),
        }
    }
    out
}

/// Every relative link of `file` resolves, and so does its `#anchor`. Links from the book must
/// stay inside the book (mdBook publishes `book/src` alone).
fn check_links(file: &Path, problems: &mut Vec<String>) {
    let (prose, _) = parse(&fs::read_to_string(file).unwrap());
    let in_book = file.starts_with(book_src());
    for (n, line) in prose.iter().enumerate() {
        for target in links(line) {
            if target.contains("://") || target.starts_with("mailto:") {
                continue;
            }
            let at = format!("{}:{}", file.display(), n + 1);
            let (path, anchor) = match target.split_once('#') {
                Some((p, a)) => (p, Some(a)),
                None => (target.as_str(), None),
            };
            let dest = if path.is_empty() {
                file.to_path_buf()
            } else {
                clean(&file.parent().unwrap().join(path))
            };
            if in_book && !dest.starts_with(book_src()) {
                problems.push(format!("{at}: {target} leaves the book"));
                continue;
            }
            if !dest.exists() {
                problems.push(format!("{at}: {target}: no such file"));
                continue;
            }
            if let Some(anchor) = anchor {
                if dest.extension().is_some_and(|e| e == "md") && !anchors(&dest).contains(anchor) {
                    problems.push(format!("{at}: {target}: no such heading"));
                }
            }
        }
    }
}

#[test]
fn every_link_and_anchor_resolves() {
    let mut problems = Vec::new();
    let mut files = markdown_files(&book_src());
    files.push(root().join("README.md"));
    files.push(root().join("CHANGELOG.md"));
    for file in &files {
        check_links(file, &mut problems);
    }
    assert!(
        problems.is_empty(),
        "broken links:\n{}",
        problems.join("\n")
    );
}

#[test]
fn every_chapter_is_in_the_contents() {
    let summary = book_src().join("SUMMARY.md");
    let text = fs::read_to_string(&summary).unwrap();
    let listed: BTreeSet<PathBuf> = text
        .lines()
        .flat_map(links)
        .map(|t| clean(&book_src().join(t)))
        .collect();
    let missing: Vec<String> = markdown_files(&book_src())
        .into_iter()
        .filter(|f| *f != summary && !listed.contains(f))
        .map(|f| f.display().to_string())
        .collect();
    assert!(missing.is_empty(), "not in SUMMARY.md: {missing:?}");
}

fn orch() -> Command {
    Command::new(env!("CARGO_BIN_EXE_orch"))
}

/// The reference's robot.toml files are what `orch config` prints (one source: the command), and
/// the piano roll shown is what `orch analyze --svg` draws.
#[test]
fn the_generated_reference_is_what_orch_prints() {
    let cases: [(&str, &[&str]); 5] = [
        ("piano.toml", &["config"]),
        ("piano-pca9685.toml", &["config", "--boards", "pca9685"]),
        ("drums.toml", &["config", "--instrument", "drums"]),
        (
            "glockenspiel.toml",
            &["config", "--instrument", "glockenspiel"],
        ),
        ("recorder.toml", &["config", "--instrument", "recorder"]),
    ];
    let dir = book_src().join("reference/generated");
    let update = std::env::var_os("ORCH_BOOK_UPDATE").is_some();
    let mut stale = Vec::new();
    for (file, args) in cases {
        let out = orch().args(args).output().unwrap();
        assert!(out.status.success(), "orch {args:?} failed");
        let printed = String::from_utf8(out.stdout).unwrap();
        let path = dir.join(file);
        if update {
            fs::create_dir_all(&dir).unwrap();
            fs::write(&path, &printed).unwrap();
        } else if fs::read_to_string(&path).ok().as_deref() != Some(printed.as_str()) {
            stale.push(format!(
                "{} is not `orch {}`",
                path.display(),
                args.join(" ")
            ));
        }
    }
    // The picture of the README and of the roll's chapter: Ode to Joy's piano roll at four times
    // its tempo, where a few notes come late and one is dropped.
    let svg = testkit::in_test("roll.svg");
    let out = orch()
        .args([
            "analyze",
            "examples/ode-to-joy.mid",
            "--tempo",
            "4",
            "--svg",
        ])
        .arg(&svg)
        .current_dir(root())
        .output()
        .unwrap();
    assert!(out.status.success(), "orch analyze --svg failed");
    let drawn = fs::read_to_string(&svg).unwrap();
    let _ = fs::remove_file(&svg);
    let picture = book_src().join("ode-to-joy-roll.svg");
    if update {
        fs::write(&picture, &drawn).unwrap();
    } else if fs::read_to_string(&picture).ok().as_deref() != Some(drawn.as_str()) {
        stale.push(format!(
            "{} is not `orch analyze examples/ode-to-joy.mid --tempo 4 --svg FILE`",
            picture.display()
        ));
    }
    assert!(
        stale.is_empty(),
        "{}\n(ORCH_BOOK_UPDATE=1 cargo test -p orch --test book rewrites them)",
        stale.join("\n")
    );
}

/// Does `line` match the pattern line `want` (`[..]` matches any text)?
fn line_matches(want: &str, line: &str) -> bool {
    let parts: Vec<&str> = want.split("[..]").collect();
    if parts.len() == 1 {
        return want == line;
    }
    let mut rest = match line.strip_prefix(parts[0]) {
        Some(r) => r,
        None => return false,
    };
    for (k, part) in parts.iter().enumerate().skip(1) {
        if k == parts.len() - 1 {
            return rest.ends_with(part);
        }
        match rest.find(part) {
            Some(at) => rest = &rest[at + part.len()..],
            None => return false,
        }
    }
    true
}

/// Does the output match the expected lines (`...` matches any number of lines)?
fn output_matches(want: &[String], got: &[&str]) -> bool {
    match want.split_first() {
        None => got.is_empty(),
        Some((first, rest)) if first.trim() == "..." => {
            (0..=got.len()).any(|skip| output_matches(rest, &got[skip..]))
        }
        Some((first, rest)) => {
            !got.is_empty() && line_matches(first, got[0]) && output_matches(rest, &got[1..])
        }
    }
}

fn bash(script: &str, dir: &Path) -> std::process::Output {
    let bin = Path::new(env!("CARGO_BIN_EXE_orch")).parent().unwrap();
    let path = format!(
        "{}:{}",
        bin.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    Command::new("bash")
        .arg("-c")
        .arg(script)
        .current_dir(dir)
        .env("PATH", path)
        .env("COLUMNS", "100")
        .env_remove("ORCH_BENCH_MIDI")
        .output()
        .unwrap()
}

/// One console block: each `$` command, its exit code and output.
fn run_console(block: &Block, dir: &Path, at: &str, problems: &mut Vec<String>) {
    let mut commands: Vec<(String, i32, Vec<String>)> = Vec::new();
    let mut lines = block.lines.iter().peekable();
    while let Some(line) = lines.next() {
        let Some(command) = line.strip_prefix("$ ") else {
            match commands.last_mut() {
                Some(c) => c.2.push(line.clone()),
                None => problems.push(format!("{at}: output before any `$` command")),
            }
            continue;
        };
        let mut command = command.to_string();
        while command.ends_with('\\') {
            command.pop();
            command.push_str(lines.next().map(String::as_str).unwrap_or(""));
        }
        let mut code = 0;
        if let Some(status) = lines.peek().and_then(|l| l.strip_prefix("? ")) {
            code = status.trim().parse().expect("`? N`: N an exit code");
            lines.next();
        }
        commands.push((command, code, Vec::new()));
    }
    for (command, code, want) in commands {
        let out = bash(&format!("{command} 2>&1"), dir);
        let text = String::from_utf8_lossy(&out.stdout);
        let got: Vec<&str> = text.lines().collect();
        if out.status.code() != Some(code) {
            problems.push(format!(
                "{at}: `{command}` exited {:?}, the book says {code}:\n{text}",
                out.status.code()
            ));
        } else if !output_matches(&want, &got) {
            problems.push(format!(
                "{at}: `{command}` printed:\n{text}\nthe book shows:\n{}",
                want.join("\n")
            ));
        }
    }
}

#[test]
fn every_shell_example_runs() {
    let scratch = testkit::Scratch::new("book");
    let mut problems = Vec::new();
    let mut ran = 0;
    for file in markdown_files(&book_src()) {
        let text = fs::read_to_string(&file).unwrap();
        let (_, blocks) = parse(&text);
        // A reason in the chapter's opening (before its first section) covers all its blocks.
        let opening = text.split("\n## ").next().unwrap_or("").to_lowercase();
        let name = file.strip_prefix(book_src()).unwrap().display().to_string();
        let dir = scratch.join(name.replace('/', "_"));
        fs::create_dir_all(&dir).unwrap();
        let link = dir.join("examples");
        if !link.exists() {
            std::os::unix::fs::symlink(root().join("examples"), &link).unwrap();
        }
        for block in blocks {
            let at = format!("{name}:{}", block.line);
            let mut words = block.info.split([',', ' ']).filter(|w| !w.is_empty());
            let lang = words.next().unwrap_or("");
            let attrs: Vec<&str> = words.collect();
            if !matches!(lang, "sh" | "console" | "bash" | "shell") {
                continue;
            }
            if attrs.contains(&"norun") {
                if !block.before.to_lowercase().contains("not run by the tests")
                    && !opening.contains("not run by the tests")
                {
                    problems.push(format!(
                        "{at}: a block not run must say why just before it (\"not run by the tests: …\")"
                    ));
                }
                continue;
            }
            let started = std::time::Instant::now();
            match lang {
                "console" => run_console(&block, &dir, &at, &mut problems),
                "sh" => {
                    let script = format!("set -euo pipefail\n{}", block.lines.join("\n"));
                    let out = bash(&script, &dir);
                    if !out.status.success() {
                        problems.push(format!(
                            "{at}: the block failed ({:?}):\n{}{}",
                            out.status.code(),
                            String::from_utf8_lossy(&out.stdout),
                            String::from_utf8_lossy(&out.stderr)
                        ));
                    }
                }
                other => problems.push(format!("{at}: write ```sh or ```console, not ```{other}")),
            }
            eprintln!("{at}: {:.1} s", started.elapsed().as_secs_f64());
            ran += 1;
        }
    }
    assert!(ran > 0, "no example ran");
    assert!(
        problems.is_empty(),
        "{} example(s) failed:\n\n{}",
        problems.len(),
        problems.join("\n\n")
    );
}

#[test]
fn the_matcher_matches() {
    let want: Vec<String> = ["a [..] c", "...", "end"].map(String::from).to_vec();
    assert!(output_matches(&want, &["a b c", "x", "y", "end"]));
    assert!(output_matches(&want, &["a  c", "end"]));
    assert!(!output_matches(&want, &["a b d", "end"]));
    assert!(!output_matches(&want, &["a b c", "end", "more"]));
    assert_eq!(
        heading_id("Outputs: `orch play --out`"),
        "outputs-orch-play---out"
    );
    assert_eq!(heading_id("The web page"), "the-web-page");
}
