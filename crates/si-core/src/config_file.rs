//! The one way the si programs read a file the user hands them whole: the settings file of
//! `--profile`, the `--config` of `gateway`, `modbus serve` and `rk512 serve`, a module's
//! parameter file, a window trace.
//!
//! - **Bounded**: at most [`MAX_FILE_BYTES`] are read; a longer file (or `/dev/zero`, a FIFO
//!   that never ends) is refused with its path and the cap after reading one byte past it, so
//!   memory stays bounded whatever the path names.
//! - **Placed errors**: a TOML error names the file, the line and the key
//!   (`gw.toml:3: [[line]] baud: invalid type: …`): toml gives the byte span, the line is
//!   counted from it and the key is the one written on that line, under the table header above
//!   it.
//! - **Short errors**: a bad value quoted in a message is cut to [`EXCERPT_CHARS`] characters
//!   and "…", so a 50 MB string yields a message of one line, not 50 MB.
//!
//! A leaf module: it imports nothing of the crate.
use serde::de::DeserializeOwned;
use std::io::Read;
use std::ops::Range;
use std::path::Path;

/// The largest file read: 4 MiB. The biggest real file (a gateway of 32 lines with their unit
/// maps, a module's parameters) is a few KiB; the cap only stops a wrong path from filling the
/// memory.
pub const MAX_FILE_BYTES: usize = 4 << 20;

/// The most characters of a value quoted in an error message: one line's worth.
pub const EXCERPT_CHARS: usize = 80;

/// A file that could not be read or whose text was refused: one line naming the file (and,
/// for a TOML error, the line and key), for the user as it is.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{text}")]
pub struct FileError {
    text: String,
}

impl FileError {
    /// An error of this text (already naming the file).
    pub fn new(text: impl Into<String>) -> Self {
        FileError { text: text.into() }
    }

    /// The line the user reads.
    pub fn text(&self) -> &str {
        &self.text
    }
}

/// The whole text of `path`, read through the cap ([`MAX_FILE_BYTES`]). Errors name the file:
/// not readable, longer than the cap, not UTF-8.
pub fn read(path: &Path) -> Result<String, FileError> {
    let name = path.display();
    let cannot = |e: std::io::Error| FileError::new(format!("cannot read {name}: {e}"));
    let file = std::fs::File::open(path).map_err(cannot)?;
    let mut bytes = Vec::new();
    file.take(MAX_FILE_BYTES as u64 + 1)
        .read_to_end(&mut bytes)
        .map_err(cannot)?;
    if bytes.len() > MAX_FILE_BYTES {
        return Err(FileError::new(format!(
            "cannot read {name}: longer than {} MiB, the most a file given to si may hold",
            MAX_FILE_BYTES >> 20
        )));
    }
    String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let line = line_of(&String::from_utf8_lossy(&e.as_bytes()[..at]), at);
        FileError::new(format!("{name}:{line}: not UTF-8 text (byte {at})"))
    })
}

/// [`read`], then parse the text as TOML into `T`; a parse error names the file, line and key
/// ([`placed`]).
pub fn read_toml<T: DeserializeOwned>(path: &Path) -> Result<T, FileError> {
    let text = read(path)?;
    parse_toml(path, &text)
}

/// Parse `text`, the contents of `path`, as TOML into `T`; a parse error names the file, line
/// and key ([`placed`]).
pub fn parse_toml<T: DeserializeOwned>(path: &Path, text: &str) -> Result<T, FileError> {
    toml::from_str(text).map_err(|e| {
        let span = e.span().unwrap_or(0..0);
        placed(path, text, span, None, e.message())
    })
}

/// An error at byte `span` of `text` (the contents of `path`): `FILE:LINE: KEY: WHY`, the key
/// given or else the one written on that line under its table header (left out when `why`
/// already names it, as toml's "unknown field `buad`" and si-core's "memory.inputs = …" do), quoted values in `why` cut short
/// ([`clip`]).
pub fn placed(
    path: &Path,
    text: &str,
    span: Range<usize>,
    key: Option<&str>,
    why: impl std::fmt::Display,
) -> FileError {
    let line = line_of(text, span.start);
    let why = clip(&why.to_string());
    let key = key.map(str::to_owned).or_else(|| key_at(text, span.start));
    let named = |k: &str| {
        let bare = k.rsplit([' ', '.']).next().unwrap_or(k);
        why.starts_with(&format!("{k} =")) || why.contains(&format!("`{bare}`"))
    };
    let text = match key {
        Some(k) if !named(&k) => format!("{}:{line}: {k}: {why}", path.display()),
        _ => format!("{}:{line}: {why}", path.display()),
    };
    FileError::new(text)
}

/// The 1-based line of byte `offset` in `text`.
pub fn line_of(text: &str, offset: usize) -> usize {
    let end = floor_char_boundary(text, offset);
    text[..end].matches('\n').count() + 1
}

/// Where the dotted key `table.key` (`memory.inputs`) is written in `text`: the span of its
/// line under the header `[table]` (or at the top for a key without a table); `None` if it is
/// not written there, as for a default.
pub fn key_span(text: &str, dotted: &str) -> Option<Range<usize>> {
    let (table, key) = match dotted.rsplit_once('.') {
        Some((t, k)) => (Some(format!("[{t}]")), k),
        None => (None, dotted),
    };
    let mut in_table = table.is_none();
    let mut offset = 0;
    for line in text.split_inclusive('\n') {
        let trimmed = line.trim();
        if trimmed.starts_with('[') {
            in_table = table.as_deref() == trimmed.split('#').next().map(str::trim);
        } else if in_table && trimmed.split('=').next().map(str::trim) == Some(key) {
            return Some(offset..offset + line.len());
        }
        offset += line.len();
    }
    None
}

/// The key written on the line of byte `offset` (the text before its `=`), after the table
/// header above it if there is one: `[profile.plc1] baud`, `[[line]] units`, `listen`.
fn key_at(text: &str, offset: usize) -> Option<String> {
    let start = floor_char_boundary(text, offset);
    let line_start = text[..start].rfind('\n').map_or(0, |i| i + 1);
    let line = text[line_start..].lines().next().unwrap_or("");
    let (key, _) = line.split_once('=')?;
    let key = clip(key.trim());
    let header = text[..line_start]
        .lines()
        .rev()
        .map(str::trim)
        .find(|l| l.starts_with('['));
    Some(match header {
        Some(h) => format!("{} {key}", clip(h.split('#').next().unwrap_or(h).trim())),
        None => key,
    })
}

/// `text` with every quoted part (between `"` or `` ` ``) longer than [`EXCERPT_CHARS`] cut to
/// that many characters and "…", and the whole kept to its first line and at most four
/// excerpts' worth.
pub fn clip(text: &str) -> String {
    let first_line = text.lines().next().unwrap_or("");
    let mut out = String::new();
    let mut quote: Option<(char, usize)> = None;
    for c in first_line.chars() {
        match quote {
            Some((q, n)) if c != q => {
                if n < EXCERPT_CHARS {
                    out.push(c);
                } else if n == EXCERPT_CHARS {
                    out.push('…');
                }
                quote = Some((q, n + 1));
                continue;
            }
            Some(_) => quote = None,
            None if c == '"' || c == '`' => quote = Some((c, 0)),
            None => {}
        }
        out.push(c);
    }
    let most = 4 * EXCERPT_CHARS;
    if out.chars().count() > most {
        out = out.chars().take(most).collect::<String>() + "…";
    }
    out
}

/// Refuse a table that sets two keys that exclude each other: `FILE:LINE: KEY: … not
/// together with …`, placed at the second one. Each key comes with its span, if set.
pub fn refuse_together(
    path: &Path,
    text: &str,
    table: &str,
    first: (&str, Option<Range<usize>>),
    second: (&str, Option<Range<usize>>),
) -> Result<(), FileError> {
    match (first.1, second.1) {
        (Some(_), Some(span)) => Err(placed(
            path,
            text,
            span,
            Some(&format!("{table} {}", second.0)),
            format!(
                "{} and {} exclude each other (a line is one or the other): keep one",
                first.0, second.0
            ),
        )),
        _ => Ok(()),
    }
}

/// The largest char boundary at or below `offset` (clamped to the text).
fn floor_char_boundary(text: &str, offset: usize) -> usize {
    let mut end = offset.min(text.len());
    while !text.is_char_boundary(end) {
        end -= 1;
    }
    end
}
