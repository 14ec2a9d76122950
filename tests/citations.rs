//! Citations a reader of the published crates can follow.
//!
//! Comments cite the manuals by the tags of `SOURCES.md` and the manual's own section, table or
//! figure ("[Modbus/USS] §3.3.5, Table 3-11"). This test fails when a Rust file under `crates/`,
//! `src/`, `examples/`, `benches/` or `tests/`
//!
//! - names one of the project's private working notes (the extractions the manuals were read
//!   through): their section numbers are not the manuals', and a reader has no copy of them;
//! - cites a tracker issue by number in a comment: the reason belongs in the sentence;
//! - uses a tag in a comment that `SOURCES.md` does not define.
//!
//! Directories that are not there (the published root package has no `crates/`) are skipped.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// The working notes' base names; with ".md" appended they must not appear in any Rust file.
const NOTES: [&str; 8] = [
    "et200s-si-3964r-ascii",
    "et200s-si-modbus-uss",
    "et200s-si-2005-window-protocol",
    "cp341-3964r-rk512-ascii",
    "cp341-event-classes",
    "public-facts",
    "uss-parameter-pages",
    "s7-200-ppi-dp",
];

/// Top-level directories whose Rust files are checked.
const DIRS: [&str; 5] = ["crates", "src", "examples", "benches", "tests"];

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries {
        let path = entry.expect("directory entry").path();
        let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
        if path.is_dir() {
            if name != "target" && !name.starts_with('.') {
                rust_files(&path, out);
            }
        } else if name.ends_with(".rs") {
            out.push(path);
        }
    }
}

fn all_rust_files() -> Vec<PathBuf> {
    let mut files = Vec::new();
    for dir in DIRS {
        rust_files(&root().join(dir), &mut files);
    }
    assert!(!files.is_empty(), "no Rust files found under {:?}", root());
    files
}

/// The comment text of a line (after `//`, `///` or `//!`), if the line has one.
fn comment(line: &str) -> Option<&str> {
    // `//` inside a string literal ("http://…") is not a comment: take the first `//` with an
    // even number of quotes before it.
    let at = line
        .match_indices("//")
        .map(|(at, _)| at)
        .find(|&at| line[..at].matches('"').count().is_multiple_of(2))?;
    Some(line[at..].trim_start_matches('/').trim_start_matches('!'))
}

/// A tracker number in prose: the word issue (or its plural), spaces or `#`, then a digit.
fn cites_issue_number(text: &str) -> bool {
    let lower = text.to_ascii_lowercase();
    let bytes = lower.as_bytes();
    let mut from = 0;
    while let Some(found) = lower[from..].find("issue") {
        let start = from + found;
        let before_ok = start == 0 || !bytes[start - 1].is_ascii_alphanumeric();
        let mut i = start + "issue".len();
        if bytes.get(i) == Some(&b's') {
            i += 1;
        }
        while matches!(bytes.get(i), Some(b' ') | Some(b'#')) {
            i += 1;
        }
        if before_ok && i > start + 5 && bytes.get(i).is_some_and(u8::is_ascii_digit) {
            return true;
        }
        from = start + 1;
    }
    false
}

/// Bracketed words that look like a source tag: an upper-case start, a space, slash or hyphen
/// inside (so never an intra-doc link), no comma (not a code array), and not a Markdown link.
fn tags_in(text: &str) -> Vec<String> {
    let mut tags = Vec::new();
    let mut rest = text;
    while let Some(open) = rest.find('[') {
        let after = &rest[open + 1..];
        let Some(close) = after.find(']') else { break };
        let inner = &after[..close];
        let next = after[close + 1..].chars().next();
        let looks_like_tag = inner.chars().next().is_some_and(|c| c.is_ascii_uppercase())
            && inner.contains([' ', '/', '-'])
            && !inner.contains([',', '`', '[', '(', ':'])
            && !matches!(next, Some('(') | Some('[') | Some(':'));
        if looks_like_tag {
            tags.push(inner.to_owned());
        }
        rest = &after[close + 1..];
    }
    tags
}

/// The tags `SOURCES.md` defines: the first cell of its table rows, "| `[TAG]` | …".
fn defined_tags() -> BTreeSet<String> {
    let sources = std::fs::read_to_string(root().join("SOURCES.md")).expect("SOURCES.md");
    sources
        .lines()
        .filter_map(|line| line.strip_prefix("| `[")?.split_once("]` |"))
        .map(|(tag, _)| tag.to_owned())
        .collect()
}

#[test]
fn no_rust_file_names_a_working_note() {
    let mut found = Vec::new();
    for file in all_rust_files() {
        let text = std::fs::read_to_string(&file).expect("readable file");
        for (n, line) in text.lines().enumerate() {
            for note in NOTES {
                if line.contains(&format!("{note}.md")) {
                    found.push(format!("{}:{}: {note}.md", file.display(), n + 1));
                }
            }
        }
    }
    assert!(
        found.is_empty(),
        "cite the manual by its SOURCES.md tag and section instead:\n{}",
        found.join("\n")
    );
}

#[test]
fn no_comment_cites_an_issue_number() {
    let mut found = Vec::new();
    for file in all_rust_files() {
        let text = std::fs::read_to_string(&file).expect("readable file");
        for (n, line) in text.lines().enumerate() {
            if comment(line).is_some_and(cites_issue_number) {
                found.push(format!("{}:{}: {}", file.display(), n + 1, line.trim()));
            }
        }
    }
    assert!(
        found.is_empty(),
        "say why in the comment, not which issue asked for it:\n{}",
        found.join("\n")
    );
}

#[test]
fn every_tag_a_comment_uses_is_defined_in_sources_md() {
    let defined = defined_tags();
    assert!(
        defined.contains("Modbus/USS") && defined.contains("ET200S SI"),
        "SOURCES.md lost its tag table: {defined:?}"
    );
    let mut unknown = Vec::new();
    for file in all_rust_files() {
        let text = std::fs::read_to_string(&file).expect("readable file");
        let mut in_code_block = false;
        for (n, line) in text.lines().enumerate() {
            let Some(comment) = comment(line) else {
                in_code_block = false;
                continue;
            };
            if comment.trim_start().starts_with("```") {
                in_code_block = !in_code_block;
                continue;
            }
            if in_code_block {
                continue;
            }
            for tag in tags_in(comment) {
                if !defined.contains(&tag) {
                    unknown.push(format!("{}:{}: [{tag}]", file.display(), n + 1));
                }
            }
        }
    }
    assert!(
        unknown.is_empty(),
        "tags not defined in SOURCES.md:\n{}",
        unknown.join("\n")
    );
}

#[test]
fn the_checks_can_fail() {
    assert!(cites_issue_number("as asked in issue 17"));
    assert!(cites_issue_number("Issue 21's patterns"));
    assert!(cites_issue_number("issues 16 and 17"));
    assert!(cites_issue_number("see issue #9"));
    assert!(!cites_issue_number("no issue here, 17 bytes"));
    assert!(!cites_issue_number("tissue 5"));
    assert_eq!(
        tags_in("([Modbus/USS] §3.3.5, [CP 341 Diag] row 0601 [M,T])"),
        ["Modbus/USS", "CP 341 Diag"]
    );
    assert!(tags_in("[`Config`], [Host], [a link](http://x), [NAK, DLE]").is_empty());
    assert_eq!(
        comment("let url = \"http://x\"; // [CP 341] §2.2.3"),
        Some(" [CP 341] §2.2.3")
    );
}
