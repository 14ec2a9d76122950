//! The binary prints, parses flags and opens ports; protocol and port knowledge lives in the
//! libraries. This keeps it so: the non-test code of si-cli outside the gateway (every
//! `src/**/*.rs` except `cmd/gateway.rs` and `cmd/gateway/`, each file counted up to its first
//! `#[cfg(test)]`) stays below 9,000 lines.

use std::path::{Path, PathBuf};

/// The bound: at or above it, logic that belongs in a library has crept back into the binary.
const LIMIT: usize = 9_000;

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

/// Lines of `text` before its first `#[cfg(test)]` (all of them without one).
fn non_test_lines(text: &str) -> usize {
    text.lines()
        .take_while(|l| !l.contains("#[cfg(test)]"))
        .count()
}

/// Whether `file` (relative to `src`) is the gateway's.
fn gateway(rel: &Path) -> bool {
    rel == Path::new("cmd/gateway.rs") || rel.starts_with("cmd/gateway")
}

#[test]
fn non_test_code_outside_the_gateway_stays_below_9000_lines() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let mut counted: Vec<(usize, PathBuf)> = files
        .into_iter()
        .filter_map(|f| {
            let rel = f.strip_prefix(&src).expect("under src").to_path_buf();
            if gateway(&rel) {
                return None;
            }
            let text = std::fs::read_to_string(&f).expect("readable");
            Some((non_test_lines(&text), rel))
        })
        .collect();
    let total: usize = counted.iter().map(|(n, _)| n).sum();
    counted.sort();
    let largest: Vec<String> = counted
        .iter()
        .rev()
        .take(5)
        .map(|(n, f)| format!("{} ({n})", f.display()))
        .collect();
    assert!(
        total < LIMIT,
        "si-cli's non-test code outside the gateway is {total} lines (limit {LIMIT}); largest: {}",
        largest.join(", ")
    );
}

#[test]
fn the_count_stops_at_the_first_test_module_and_leaves_the_gateway_out() {
    let text = "fn a() {}\n// two\n#[cfg(test)]\nmod tests {\n    #[test]\n    fn t() {}\n}\n";
    assert_eq!(non_test_lines(text), 2);
    assert_eq!(non_test_lines("fn a() {}\n"), 1);
    assert!(gateway(Path::new("cmd/gateway.rs")));
    assert!(gateway(Path::new("cmd/gateway/router.rs")));
    assert!(!gateway(Path::new("cmd/modbus.rs")));
    assert!(!gateway(Path::new("cmd/gateway_like.rs")));
}
