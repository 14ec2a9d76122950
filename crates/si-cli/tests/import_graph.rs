//! One import direction inside si-cli (issue 17): no module imports, directly or through others,
//! a module that imports it back.
//!
//! The test reads every file under `src/`, takes each `crate::…` path (in `use` lines, brace
//! groups expanded, and written out in code), resolves it to the longest module path that
//! exists, and looks for a circle in the graph of modules. The crate root (`main.rs`) and every
//! `mod.rs` declare their children, so they count as depending on each of them: a child that
//! imports from its parent closes a circle. Leaf modules (`error`, `output`, `hex`, `preset`,
//! `scenario`, `conn`, `config_file`) take what several commands share.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Module path (`cmd::monitor`, `` for the root) → the modules it depends on.
type Graph = BTreeMap<String, BTreeSet<String>>;

fn module_of(src: &Path, file: &Path) -> String {
    let rel = file.strip_prefix(src).expect("under src");
    let mut parts: Vec<String> = rel
        .iter()
        .map(|p| p.to_string_lossy().into_owned())
        .collect();
    let last = parts.pop().expect("a file name");
    if last != "mod.rs" && last != "main.rs" {
        parts.push(last.trim_end_matches(".rs").to_owned());
    }
    parts.join("::")
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).expect("readable src") {
        let path = entry.expect("entry").path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The code without `//` comments (doc comments name modules without importing them).
fn code(text: &str) -> String {
    text.lines()
        .map(|l| match l.find("//") {
            Some(i) => &l[..i],
            None => l,
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// `a::{b::C, d}` → `a::b::C`, `a::d`.
fn expand(tree: &str) -> Vec<String> {
    let tree = tree.trim();
    let Some(open) = tree.find('{') else {
        return vec![tree.to_owned()];
    };
    let prefix = &tree[..open];
    let inner = &tree[open + 1..tree.rfind('}').unwrap_or(tree.len())];
    let mut parts = Vec::new();
    let (mut depth, mut start) = (0, 0);
    for (i, ch) in inner.char_indices() {
        match ch {
            '{' => depth += 1,
            '}' => depth -= 1,
            ',' if depth == 0 => {
                parts.push(&inner[start..i]);
                start = i + 1;
            }
            _ => {}
        }
    }
    parts.push(&inner[start..]);
    parts
        .into_iter()
        .filter(|p| !p.trim().is_empty())
        .flat_map(expand)
        .map(|p| format!("{prefix}{p}"))
        .collect()
}

/// Every `crate::…` path the code names, without the `crate::`.
fn crate_paths(code: &str) -> Vec<String> {
    let mut paths = Vec::new();
    let mut rest = code;
    while let Some(i) = rest.find("crate::") {
        let after = &rest[i + "crate::".len()..];
        let end = if rest[..i].trim_end().ends_with("use") {
            after.find(';').unwrap_or(after.len())
        } else {
            after
                .find(|c: char| !(c.is_alphanumeric() || c == '_' || c == ':'))
                .unwrap_or(after.len())
        };
        paths.extend(expand(&after[..end]));
        rest = &after[end..];
    }
    paths
        .into_iter()
        .map(|p| p.split(" as ").next().unwrap_or("").trim().to_owned())
        .collect()
}

/// The longest module that `path` starts with (the root if none).
fn resolve(path: &str, modules: &BTreeSet<String>) -> String {
    let segments: Vec<&str> = path.split("::").collect();
    (1..=segments.len())
        .rev()
        .map(|n| segments[..n].join("::"))
        .find(|m| modules.contains(m))
        .unwrap_or_default()
}

fn graph(files: &[(String, String)]) -> Graph {
    let modules: BTreeSet<String> = files.iter().map(|(m, _)| m.clone()).collect();
    let mut g = Graph::new();
    for (module, text) in files {
        let deps = g.entry(module.clone()).or_default();
        for path in crate_paths(&code(text)) {
            let target = resolve(&path, &modules);
            if &target != module {
                deps.insert(target);
            }
        }
        // A parent declares its children.
        for child in &modules {
            let parent = child.rsplit_once("::").map_or("", |(p, _)| p);
            if parent == module && !child.is_empty() {
                deps.insert(child.clone());
            }
        }
    }
    g
}

/// A circle of modules, if there is one.
fn circle(g: &Graph) -> Option<Vec<String>> {
    fn visit(
        m: &str,
        g: &Graph,
        stack: &mut Vec<String>,
        done: &mut BTreeSet<String>,
    ) -> Option<Vec<String>> {
        if let Some(i) = stack.iter().position(|s| s == m) {
            let mut c = stack[i..].to_vec();
            c.push(m.to_owned());
            return Some(c);
        }
        if done.contains(m) {
            return None;
        }
        stack.push(m.to_owned());
        for d in g.get(m).into_iter().flatten() {
            if let Some(c) = visit(d, g, stack, done) {
                return Some(c);
            }
        }
        stack.pop();
        done.insert(m.to_owned());
        None
    }
    let mut done = BTreeSet::new();
    g.keys()
        .find_map(|m| visit(m, g, &mut Vec::new(), &mut done))
}

#[test]
fn si_cli_has_no_import_circle() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut paths = Vec::new();
    rust_files(&src, &mut paths);
    let files: Vec<(String, String)> = paths
        .iter()
        .map(|p| {
            (
                module_of(&src, p),
                std::fs::read_to_string(p).expect("utf-8"),
            )
        })
        .collect();
    assert!(files.len() > 10, "found the sources: {}", files.len());
    let g = graph(&files);
    // The leaves import no command.
    for leaf in ["error", "output", "hex"] {
        let deps = &g[leaf];
        assert!(
            deps.iter().all(|d| d == "error"),
            "{leaf} is a leaf, imports {deps:?}"
        );
    }
    let named = |c: Vec<String>| {
        c.iter()
            .map(|m| if m.is_empty() { "crate" } else { m })
            .collect::<Vec<_>>()
            .join(" → ")
    };
    assert_eq!(circle(&g).map(named), None);
}

#[test]
fn the_check_finds_a_planted_circle() {
    let files = |frame: &str| {
        vec![
            (String::new(), String::new()),
            ("cmd".to_owned(), String::new()),
            ("error".to_owned(), String::new()),
            (
                "cmd::frame".to_owned(),
                "use crate::cmd::{modbus::DecodeArgs, uss};\n".to_owned(),
            ),
            ("cmd::modbus".to_owned(), frame.to_owned()),
            ("cmd::uss".to_owned(), String::new()),
        ]
    };
    // modbus parses hex through frame, which lists modbus: a circle.
    let g = graph(&files("let b = crate::cmd::frame::parse_hex(x)?;\n"));
    assert_eq!(
        circle(&g),
        Some(vec![
            "cmd::frame".to_owned(),
            "cmd::modbus".to_owned(),
            "cmd::frame".to_owned()
        ])
    );
    // Importing the root's items closes a circle through the root's declarations.
    let g = graph(&files("use crate::{CliError, error};\n"));
    assert!(circle(&g).is_some());
    // A doc comment naming the module is not an import.
    let g = graph(&files("/// see [`crate::cmd::frame`]\nuse crate::error;\n"));
    assert_eq!(circle(&g), None);
}
