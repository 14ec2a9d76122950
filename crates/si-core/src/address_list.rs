//! Station address lists as users type them: `1-247`, `1,2,10-20`, the form of the Modbus
//! scan's `--units`, the USS scan's `--nodes` and a gateway line's `units`.

/// The addresses of `text` (comma-separated `N` or `N-M`, blanks around each allowed), sorted,
/// each once; `None` if a part is not a number or range within `lo ..= hi`, or nothing is
/// given. Each caller names its flag or key and range in its own error.
pub fn parse(text: &str, lo: u8, hi: u8) -> Option<Vec<u8>> {
    let mut list = Vec::new();
    for part in text.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        let (a, b) = part.split_once('-').unwrap_or((part, part));
        let a: u8 = a.trim().parse().ok()?;
        let b: u8 = b.trim().parse().ok()?;
        if a < lo || b > hi || a > b {
            return None;
        }
        list.extend(a..=b);
    }
    list.sort_unstable();
    list.dedup();
    (!list.is_empty()).then_some(list)
}

#[cfg(test)]
mod tests {
    use super::parse;

    #[test]
    fn ranges_and_lists_sorted_once_within_the_bounds() {
        assert_eq!(parse("1-3,2,10", 1, 247), Some(vec![1, 2, 3, 10]));
        assert_eq!(parse(" 5 , 1 - 2 ", 1, 247), Some(vec![1, 2, 5]));
        assert_eq!(parse("0-31", 0, 31).map(|l| l.len()), Some(32));
        for bad in ["0-5", "1-248", "5-1", "x", "", ",", "1-", "300"] {
            assert_eq!(parse(bad, 1, 247), None, "{bad:?}");
        }
    }
}
