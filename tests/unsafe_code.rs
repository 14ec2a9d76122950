//! `unsafe` stays where it was allowed on purpose.
//!
//! The workspace denies `unsafe_code` (`[workspace.lints.rust]`); `deny` rather than `forbid`
//! only so that one module can allow it: si-core's `port/icount.rs`, the Linux `TIOCGICOUNT`
//! ioctl that no crate in the tree wraps. This test fails when any other Rust file under
//! `crates/`, `src/`, `examples/`, `benches/` or `tests/` allows unsafe code, so a second
//! exception is a decision someone makes here, not a line that slips in. Directories that are
//! not there (the published root package has no `crates/`) are skipped.

use std::path::{Path, PathBuf};

/// The files allowed to allow `unsafe_code`, relative to the workspace root.
const ALLOWED: [&str; 1] = ["crates/si-core/src/port/icount.rs"];

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let path = entry.path();
        if path.is_dir() {
            if path.file_name().is_some_and(|n| n == "target") {
                continue;
            }
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

#[test]
fn only_the_icount_module_allows_unsafe_code() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let mut files = Vec::new();
    for dir in ["crates", "src", "examples", "benches", "tests"] {
        rust_files(&root.join(dir), &mut files);
    }
    // Spelled in two pieces so this file does not match itself.
    let needle = format!("allow({}_code)", "unsafe");
    let offenders: Vec<String> = files
        .iter()
        .filter(|f| {
            std::fs::read_to_string(f).is_ok_and(|text| text.replace(' ', "").contains(&needle))
        })
        .map(|f| {
            f.strip_prefix(&root)
                .unwrap_or(f)
                .to_string_lossy()
                .into_owned()
        })
        .filter(|f| !ALLOWED.contains(&f.as_str()))
        .collect();
    assert!(
        offenders.is_empty(),
        "unsafe code allowed outside {ALLOWED:?}: {offenders:?}"
    );
}
