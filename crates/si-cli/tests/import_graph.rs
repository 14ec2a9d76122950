//! One import direction inside si-cli: no module imports, directly or through others,
//! a module that imports it back.
//!
//! The test reads every file under `src/`, takes each `crate::…` path (in `use` lines, brace
//! groups expanded, and written out in code), resolves it to the longest module path that
//! exists, and looks for a circle in the graph of modules. The crate root (`main.rs`) and every
//! `mod.rs` declare their children, so they count as depending on each of them: a child that
//! imports from its parent closes a circle. Leaf modules (`error`, `output`, `hex`, `preset`,
//! `scenario`, `conn`, `config_file`) take what several commands share.

#[path = "import_graph/pairs.rs"]
mod pairs;

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
        paths.extend(pairs::expand(&after[..end]));
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
        for path in crate_paths(&pairs::strip(text)) {
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

/// Every crate under `crates/`: its name and its `src/`.
fn workspace_crates() -> Vec<(String, PathBuf)> {
    let crates = Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("crates/");
    let mut out: Vec<(String, PathBuf)> = std::fs::read_dir(crates)
        .expect("readable crates/")
        .map(|e| e.expect("entry").path())
        .filter(|p| p.join("src").is_dir())
        .map(|p| {
            let name = p
                .file_name()
                .expect("a name")
                .to_string_lossy()
                .into_owned();
            (name, p.join("src"))
        })
        .collect();
    out.sort();
    out
}

/// Pairs that import each other in files other helpers are rewriting; each goes once its
/// rewrite is merged (the test fails on a pair listed here that no longer exists, so the list
/// cannot go stale).
const KNOWN_PAIRS: &[(&str, &str, &str)] = &[
    // Helper "handles" rewrites job.rs (the outcome path), helper "v24" fb.rs: the job layer
    // names S_SEND/S_RCV for its docs and tests while the FBs run over the job layer.
    ("si-core", "fb.rs", "job.rs"),
    // Helper "handles" owns the ports: the Linux RS-485 control type and the termios mode.
    ("si-core", "port/linux.rs", "port/stream.rs"),
    // Helper "modbus": the slave's store and the request execution call each other.
    ("si-modbus", "serve.rs", "slave.rs"),
    // The gateway's line kinds' configs and the reopening: untangled in si-gateway next.
    ("si-gateway", "config.rs", "rk512_config.rs"),
    ("si-gateway", "config.rs", "uss_config.rs"),
    ("si-gateway", "line.rs", "reopen.rs"),
];

#[test]
fn no_file_pair_in_any_crate_imports_each_other() {
    let mut found = Vec::new();
    let mut files = 0;
    for (name, src) in workspace_crates() {
        let krate = pairs::Crate::new(pairs::read_crate(&src));
        files += krate.len();
        for (a, b) in krate.mutual_pairs() {
            found.push((name.clone(), a, b));
        }
    }
    assert!(files > 100, "found the sources: {files}");
    for (krate, a, b) in &found {
        eprintln!("{krate}: {a} <-> {b}");
    }
    let known: Vec<(String, String, String)> = KNOWN_PAIRS
        .iter()
        .map(|(k, a, b)| (k.to_string(), a.to_string(), b.to_string()))
        .collect();
    let new: Vec<_> = found.iter().filter(|p| !known.contains(p)).collect();
    let gone: Vec<_> = known.iter().filter(|p| !found.contains(p)).collect();
    assert!(new.is_empty(), "files that import each other: {new:?}");
    assert!(
        gone.is_empty(),
        "known pairs that no longer import each other, remove them from KNOWN_PAIRS: {gone:?}"
    );
}

/// A crate of `(file under src/, text)` for the planted cases.
fn planted(files: &[(&str, &str)]) -> Vec<(String, String)> {
    pairs::Crate::new(
        files
            .iter()
            .map(|(name, text)| pairs::File::new(name, text))
            .collect(),
    )
    .mutual_pairs()
}

#[test]
fn the_check_finds_planted_pairs_and_nothing_else() {
    let pair = |a: &str, b: &str| vec![(a.to_owned(), b.to_owned())];
    let root = "pub mod link;\npub mod frame;\npub use frame::Frame;\npub struct Config;\n";
    // A child that uses an item its parent defines, while the parent uses the child's.
    assert_eq!(
        planted(&[
            (
                "lib.rs",
                "mod link;\nmod frame;\npub struct Config;\nuse link::Link;\n"
            ),
            ("link.rs", "use super::Config;\npub struct Link;\n"),
            ("frame.rs", ""),
        ]),
        pair("lib.rs", "link.rs")
    );
    // The same written as `crate::Config` in code, and the parent naming `link::Link` in code.
    assert_eq!(
        planted(&[
            (
                "lib.rs",
                "mod link;\npub struct Config;\nfn f() { link::Link::new(); }\n"
            ),
            ("link.rs", "fn g(c: crate::Config) {}\n"),
        ]),
        pair("lib.rs", "link.rs")
    );
    // Two siblings through `super::`, one of them in a `use` brace group.
    assert_eq!(
        planted(&[
            ("lib.rs", root),
            ("link.rs", "use super::{frame::Frame, Config};\n"),
            (
                "frame.rs",
                "pub struct Frame;\nfn f() { super::link::Link::new(); }\n"
            ),
        ]),
        pair("frame.rs", "link.rs")
    );
    // A re-export is followed to the file that defines the item: `crate::Frame` imports
    // frame.rs, not lib.rs, which only re-exports it; `crate::Config` imports lib.rs, which
    // imports no item of link.rs.
    assert_eq!(
        planted(&[
            ("lib.rs", root),
            ("link.rs", "use crate::{Config, Frame};\npub struct Link;\n"),
            ("frame.rs", "pub struct Frame;\n"),
        ]),
        vec![]
    );
    // A parent declaring `mod tests;` imports nothing of it; `use super::*` in an inline test
    // module names its own file; comments, strings and `$crate` are no imports; a macro
    // exported at the root is imported from the file it is written in.
    assert_eq!(
        planted(&[
            (
                "lib.rs",
                "#[cfg(test)]\nmod tests;\nmod link;\npub struct Config;\n\
                 // link::Link\nconst S: &str = \"link::Link\";\n",
            ),
            ("tests.rs", "use super::*;\n"),
            (
                "link.rs",
                "pub struct Link;\nmacro_rules! m { () => { $crate::Config } }\n\
                 crate::codes! {}\n#[cfg(test)]\nmod tests {\n    use super::*;\n}\n",
            ),
            (
                "codes.rs",
                "#[macro_export]\nmacro_rules! codes { () => {} }\n"
            ),
        ]),
        vec![]
    );
}
