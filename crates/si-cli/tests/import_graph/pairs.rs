//! File pairs that import each other, in any crate of the workspace.
//!
//! What counts as "file A imports file B": A names an item that B defines, through any path
//! the compiler accepts — `crate::b::Item`, `super::Item` (B the parent), `super::b::Item` (B a
//! sibling), `self::b::Item` or `b::Item` (B a child declared in A) — in a `use` line (brace
//! groups expanded) or written out in code. A path through a re-export counts for the file
//! that defines the item, not for the one that re-exports it: `crate::Status` in a module of a
//! crate whose root says `pub use status::Status` imports `status.rs`, not `lib.rs`. Declaring
//! a child (`mod b;`) is not an import: a parent and its `tests.rs` (which says `use super::*`)
//! are fine, but a parent that `use`s its child's items while the child uses items defined in
//! the parent is a mutual import, as are two siblings that use each other's items.
//!
//! `super::` and `self::` inside an inline `mod tests { … }` count from that inline module, so
//! its `use super::*` names the file itself. Comments, string and character literals are
//! ignored; `$crate` in macros is not followed.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// A file of a crate: its module path (`["cmd", "gateway"]`, empty for the root) and its code
/// without comments and literals.
#[derive(Debug, Clone)]
pub struct File {
    /// Where it is, relative to `src/` (for messages).
    pub name: String,
    /// Module path.
    pub module: Vec<String>,
    /// The code without comments, strings and character literals.
    pub code: String,
}

impl File {
    /// A file from its path under `src/` and its text.
    pub fn new(name: &str, text: &str) -> File {
        let mut parts: Vec<String> = name.split('/').map(str::to_owned).collect();
        let last = parts.pop().unwrap_or_default();
        if !matches!(last.as_str(), "mod.rs" | "lib.rs" | "main.rs") {
            parts.push(last.trim_end_matches(".rs").to_owned());
        }
        File {
            name: name.to_owned(),
            module: parts,
            code: strip(text),
        }
    }
}

/// Every `.rs` file under `src`, read.
pub fn read_crate(src: &Path) -> Vec<File> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        for entry in std::fs::read_dir(dir).expect("readable src") {
            let path = entry.expect("entry").path();
            if path.is_dir() {
                walk(&path, out);
            } else if path.extension().is_some_and(|e| e == "rs") {
                out.push(path);
            }
        }
    }
    let mut paths = Vec::new();
    walk(src, &mut paths);
    paths.sort();
    paths
        .iter()
        .map(|p| {
            let name = p.strip_prefix(src).expect("under src").to_string_lossy();
            File::new(&name, &std::fs::read_to_string(p).expect("utf-8"))
        })
        .collect()
}

/// The code without `//` and `/* */` comments, string literals (raw ones too) and character
/// literals, each replaced by a space so positions and line structure stay.
pub fn strip(text: &str) -> String {
    let b: Vec<char> = text.chars().collect();
    let mut out = String::with_capacity(text.len());
    let mut i = 0;
    while i < b.len() {
        let c = b[i];
        let next = b.get(i + 1).copied();
        if c == '/' && next == Some('/') {
            while i < b.len() && b[i] != '\n' {
                i += 1;
            }
        } else if c == '/' && next == Some('*') {
            let mut depth = 0;
            while i < b.len() {
                if b[i] == '/' && b.get(i + 1) == Some(&'*') {
                    depth += 1;
                    i += 2;
                } else if b[i] == '*' && b.get(i + 1) == Some(&'/') {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    i += 1;
                }
            }
            out.push(' ');
        } else if c == 'r'
            && (next == Some('"') || next == Some('#'))
            && !b[..i]
                .last()
                .is_some_and(|p| p.is_alphanumeric() || *p == '_')
        {
            // r"…", r#"…"#
            let mut j = i + 1;
            let mut hashes = 0;
            while b.get(j) == Some(&'#') {
                hashes += 1;
                j += 1;
            }
            if b.get(j) != Some(&'"') {
                out.push(c);
                i += 1;
                continue;
            }
            j += 1;
            loop {
                if j >= b.len() {
                    break;
                }
                if b[j] == '"' && (0..hashes).all(|k| b.get(j + 1 + k) == Some(&'#')) {
                    j += 1 + hashes;
                    break;
                }
                j += 1;
            }
            out.push(' ');
            i = j;
        } else if c == '"' {
            i += 1;
            while i < b.len() && b[i] != '"' {
                if b[i] == '\\' {
                    i += 1;
                }
                i += 1;
            }
            i += 1;
            out.push(' ');
        } else if c == '\'' {
            // 'x', '\n', '\u{…}' are literals; 'a (a lifetime or label) is not.
            if next == Some('\\') {
                let mut j = i + 2;
                while j < b.len() && b[j] != '\'' {
                    j += 1;
                }
                i = j + 1;
                out.push(' ');
            } else if b.get(i + 2) == Some(&'\'') {
                i += 3;
                out.push(' ');
            } else {
                out.push(c);
                i += 1;
            }
        } else {
            out.push(c);
            i += 1;
        }
    }
    out
}

fn is_ident(c: char) -> bool {
    c.is_alphanumeric() || c == '_'
}

/// Inline modules (`mod name { … }`): their names and the byte span of their bodies.
fn inline_modules(code: &str) -> Vec<(String, usize, usize)> {
    let bytes = code.as_bytes();
    let mut spans = Vec::new();
    let mut open: Vec<(String, usize, usize)> = Vec::new(); // name, start, depth
    let mut depth = 0usize;
    let mut i = 0;
    while i < bytes.len() {
        match bytes[i] {
            b'{' => depth += 1,
            b'}' => {
                if open.last().is_some_and(|(_, _, d)| *d == depth) {
                    let (name, start, _) = open.pop().expect("an open module");
                    spans.push((name, start, i));
                }
                depth = depth.saturating_sub(1);
            }
            b'm' if code[i..].starts_with("mod")
                && (i == 0 || !is_ident(code[..i].chars().last().unwrap_or(' '))) =>
            {
                let rest = &code[i + 3..];
                let trimmed = rest.trim_start();
                if rest.len() > trimmed.len() {
                    let name: String = trimmed.chars().take_while(|c| is_ident(*c)).collect();
                    let after = trimmed[name.len()..].trim_start();
                    if !name.is_empty() && after.starts_with('{') {
                        let brace = code.len() - after.len();
                        open.push((name, brace + 1, depth + 1));
                        depth += 1;
                        i = brace + 1;
                        continue;
                    }
                }
            }
            _ => {}
        }
        i += 1;
    }
    spans
}

/// The child modules a file declares (`mod name;`), which its own paths may start with.
fn declared_children(code: &str) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    let mut rest = code;
    while let Some(i) = rest.find("mod ") {
        let before_ok = rest[..i].chars().last().is_none_or(|c| !is_ident(c));
        let after = &rest[i + 4..];
        let name: String = after
            .trim_start()
            .chars()
            .take_while(|c| is_ident(*c))
            .collect();
        let tail = after.trim_start()[name.len()..].trim_start();
        if before_ok && !name.is_empty() && tail.starts_with(';') {
            out.insert(name);
        }
        rest = after;
    }
    out
}

/// `a::{b::C, d as e}` → `a::b::C`, `a::d as e`.
pub fn expand(tree: &str) -> Vec<String> {
    let tree = tree.trim();
    let Some(open) = tree.find('{') else {
        return vec![tree.split_whitespace().collect::<Vec<_>>().join(" ")];
    };
    let prefix: String = tree[..open].split_whitespace().collect();
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

/// A path written in a file, with the module it was written in (inline modules included).
#[derive(Debug, Clone)]
struct Written {
    context: Vec<String>,
    segments: Vec<String>,
    /// `use … as alias` or the last segment: the name the path brings in (use lines only).
    binds: Option<String>,
}

/// Every path a file writes that may lead into its own crate: `use` trees (all roots), and in
/// code the paths that start with `crate`, `super`, `self` or a declared child.
fn written_paths(file: &File) -> Vec<Written> {
    let code = &file.code;
    let spans = inline_modules(code);
    let children = declared_children(code);
    let context_at = |pos: usize| {
        let mut c = file.module.clone();
        let mut inner: Vec<&(String, usize, usize)> = spans
            .iter()
            .filter(|(_, s, e)| *s <= pos && pos < *e)
            .collect();
        inner.sort_by_key(|(_, s, _)| *s);
        c.extend(inner.into_iter().map(|(n, _, _)| n.clone()));
        c
    };
    let mut out = Vec::new();
    // `use` lines.
    let mut use_spans = Vec::new();
    let mut from = 0;
    while let Some(i) = code[from..].find("use ") {
        let at = from + i;
        from = at + 4;
        let before = code[..at].trim_end();
        let starts_statement = before.is_empty()
            || before.ends_with([';', '{', '}', ']'])
            || before.ends_with("pub")
            || before.ends_with(')');
        if !starts_statement || code[..at].chars().last().is_some_and(is_ident) {
            continue;
        }
        let end = code[at..].find(';').map_or(code.len(), |e| at + e);
        use_spans.push((at, end));
        for leaf in expand(&code[at + 4..end]) {
            let (path, alias) = match leaf.split_once(" as ") {
                Some((p, a)) => (p.trim().to_owned(), Some(a.trim().to_owned())),
                None => (leaf.trim().to_owned(), None),
            };
            let segments: Vec<String> = path
                .trim_start_matches("::")
                .split("::")
                .map(str::to_owned)
                .collect();
            let binds = alias.or_else(|| segments.last().cloned());
            out.push(Written {
                context: context_at(at),
                segments,
                binds,
            });
        }
        from = end;
    }
    // Paths in code.
    let chars: Vec<(usize, char)> = code.char_indices().collect();
    let mut k = 0;
    while k < chars.len() {
        let (pos, c) = chars[k];
        let prev = if k == 0 { ' ' } else { chars[k - 1].1 };
        if !is_ident(c) || is_ident(prev) || prev == '$' || prev == ':' {
            k += 1;
            continue;
        }
        if use_spans.iter().any(|(s, e)| *s <= pos && pos < *e) {
            k += 1;
            continue;
        }
        let mut end = pos;
        while end < code.len() {
            let rest = &code[end..];
            let ident: usize = rest
                .chars()
                .take_while(|c| is_ident(*c))
                .map(char::len_utf8)
                .sum();
            if ident == 0 {
                break;
            }
            end += ident;
            if code[end..].starts_with("::") && code[end + 2..].starts_with(|c: char| is_ident(c)) {
                end += 2;
            } else {
                break;
            }
        }
        let text = &code[pos..end];
        let segments: Vec<String> = text.split("::").map(str::to_owned).collect();
        let first = segments[0].as_str();
        if segments.len() > 1
            && (matches!(first, "crate" | "super" | "self") || children.contains(first))
        {
            out.push(Written {
                context: context_at(pos),
                segments,
                binds: None,
            });
        }
        while k < chars.len() && chars[k].0 < end {
            k += 1;
        }
    }
    out
}

/// A crate's files, indexed for resolving paths.
pub struct Crate {
    files: Vec<File>,
    by_module: BTreeMap<Vec<String>, usize>,
    uses: Vec<Vec<Written>>,
    children: Vec<BTreeSet<String>>,
}

impl Crate {
    /// Indexes `files`.
    pub fn new(files: Vec<File>) -> Crate {
        let by_module = files
            .iter()
            .enumerate()
            .map(|(i, f)| (f.module.clone(), i))
            .collect();
        let uses = files.iter().map(written_paths).collect();
        let children = files.iter().map(|f| declared_children(&f.code)).collect();
        Crate {
            files,
            by_module,
            uses,
            children,
        }
    }

    /// How many files.
    pub fn len(&self) -> usize {
        self.files.len()
    }

    /// Does file `f` itself define an item called `name`?
    fn defines(&self, f: usize, name: &str) -> bool {
        let code = &self.files[f].code;
        let kinds = [
            "struct", "enum", "fn", "trait", "type", "const", "static", "union", "mod",
        ];
        kinds.iter().any(|kind| {
            let mut rest = code.as_str();
            while let Some(i) = rest.find(kind) {
                let before_ok = rest[..i].chars().last().is_none_or(|c| !is_ident(c));
                let after = &rest[i + kind.len()..];
                let trimmed = after.trim_start();
                if before_ok
                    && after.len() > trimmed.len()
                    && trimmed.starts_with(name)
                    && !trimmed[name.len()..].starts_with(is_ident)
                {
                    return true;
                }
                rest = after;
            }
            false
        }) || code.contains(&format!("macro_rules! {name}"))
    }

    /// The file that defines what `segments` name, written in module `context`; `None` for a
    /// path outside the crate. `depth` bounds the re-exports followed.
    fn resolve(&self, context: &[String], segments: &[String], depth: u32) -> Option<usize> {
        let mut module: Vec<String> = context.to_vec();
        let mut rest = segments;
        let file_of = |m: &[String]| {
            (0..=m.len())
                .rev()
                .find_map(|n| self.by_module.get(&m[..n]).copied())
        };
        match rest.first().map(String::as_str) {
            Some("crate") => {
                module.clear();
                rest = &rest[1..];
            }
            Some("self") => rest = &rest[1..],
            Some("super") => {}
            Some(first) => {
                // A child of the module the path is written in, or something outside.
                let here = file_of(&module)?;
                let mut child = module.clone();
                child.push(first.to_owned());
                if !self.children[here].contains(first) && !self.by_module.contains_key(&child) {
                    return None;
                }
            }
            None => return None,
        }
        while rest.first().is_some_and(|s| s == "super") {
            module.pop();
            rest = &rest[1..];
        }
        // Down the file modules as far as they go.
        while let Some(next) = rest.first() {
            let mut deeper = module.clone();
            deeper.push(next.clone());
            if self.by_module.contains_key(&deeper) {
                module = deeper;
                rest = &rest[1..];
            } else {
                break;
            }
        }
        let target = file_of(&module)?;
        let Some(item) = rest.first() else {
            return Some(target); // the module itself
        };
        if item == "*" || self.defines(target, item) || depth == 0 {
            return Some(target);
        }
        // A re-export: follow it to the file that defines the item.
        let re_export = self.uses[target].iter().find(|w| {
            w.binds.as_deref() == Some(item.as_str()) && w.context == self.files[target].module
        });
        match re_export {
            Some(w) => {
                let mut path = w.segments.clone();
                path.extend(rest[1..].iter().cloned());
                self.resolve(&w.context, &path, depth - 1)
            }
            // A `#[macro_export]` macro sits at the crate root wherever it is written.
            None => Some(
                (0..self.files.len())
                    .find(|&f| self.files[f].code.contains(&format!("macro_rules! {item}")))
                    .unwrap_or(target),
            ),
        }
    }

    /// Which files each file imports (by index; itself excluded).
    pub fn imports(&self) -> Vec<BTreeSet<usize>> {
        (0..self.files.len())
            .map(|f| {
                self.uses[f]
                    .iter()
                    .filter_map(|w| self.resolve(&w.context, &w.segments, 8))
                    .filter(|&t| t != f)
                    .collect()
            })
            .collect()
    }

    /// Every pair of files that import each other, by their names under `src/`, each pair in
    /// name order.
    pub fn mutual_pairs(&self) -> Vec<(String, String)> {
        let imports = self.imports();
        let mut pairs = Vec::new();
        for (a, deps) in imports.iter().enumerate() {
            for &b in deps {
                if a < b && imports[b].contains(&a) {
                    let (x, y) = (&self.files[a].name, &self.files[b].name);
                    pairs.push(if x < y {
                        (x.clone(), y.clone())
                    } else {
                        (y.clone(), x.clone())
                    });
                }
            }
        }
        pairs.sort();
        pairs
    }
}
