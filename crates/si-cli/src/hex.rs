//! The user's hex arguments: one rule for every command that takes bytes.
//!
//! A leaf module: the protocol commands, `si frame` and the module commands all read hex, so it
//! lives below them rather than in one of them.
//!
//! The rule ([`HEX_HELP`]): the bytes may be given as separate words (`01 02 10 03`), as one
//! quoted string (`"01 02 10 03"`, `"01021003"`) or mixed; words are joined with spaces and read
//! by [`si_core::hex::parse`], so `,` `:` `-` also separate and each group may carry `0x` (or the
//! manuals' `16#`, as the numbers of the radix convention do). A group
//! needs an even number of digits (`0203` is two bytes, `2` is an error, not `02`).

use crate::error::CliError;

/// The hex rule in one sentence, for the help of every argument that takes bytes
/// (`#[arg(help = crate::hex::HEX_HELP)]`), so all commands document the same rule.
pub const HEX_HELP: &str = "Hex as separate words (01 02 10 03) or one quoted string \
     (\"01021003\"); , : - also separate, 0x or 16# may lead a group, each group an even \
     number of digits";

/// Parse the user's hex argument (`0x` and the manuals' `16#` may lead a group), turning a
/// mistake into a one-line error.
pub fn parse_hex(text: &str) -> Result<Vec<u8>, CliError> {
    si_core::hex::parse(text).map_err(|e| CliError::new(format!("bad hex {text:?}: {e}")))
}

/// Parse hex given as several command-line words (`01 02 10 03`, or one quoted string), the
/// rule of [`HEX_HELP`]; a mistake there is a usage error (exit 2), like clap's own.
pub fn parse_hex_args(words: &[String]) -> Result<Vec<u8>, CliError> {
    parse_hex(&words.join(" ")).map_err(|e| CliError::usage(e.text()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn words(w: &[&str]) -> Vec<String> {
        w.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn a_bad_hex_argument_is_a_usage_error() {
        let e = parse_hex_args(&words(&["01", "2"])).unwrap_err();
        assert_eq!(e.code(), crate::error::EXIT_USAGE);
        assert!(e.text().contains("bad hex"), "{}", e.text());
    }

    #[test]
    fn separate_words_one_string_and_prefixes_give_the_same_bytes() {
        let want = vec![0x01, 0x02, 0x10, 0x03];
        assert_eq!(
            parse_hex_args(&words(&["01", "02", "10", "03"])).unwrap(),
            want
        );
        assert_eq!(parse_hex_args(&words(&["01 02 10 03"])).unwrap(), want);
        assert_eq!(parse_hex_args(&words(&["01021003"])).unwrap(), want);
        assert_eq!(
            parse_hex_args(&words(&["0x01,0x02", "1003"])).unwrap(),
            want
        );
        assert_eq!(
            parse_hex_args(&words(&["16#01", "16#0210", "03"])).unwrap(),
            want
        );
    }

    #[test]
    fn an_error_after_16_names_the_position_in_what_was_typed() {
        let e = parse_hex_args(&words(&["16#0G"])).unwrap_err();
        assert!(e.text().contains("'G' at position 5"), "{}", e.text());
        // `16#` inside a group is not a prefix.
        assert!(parse_hex_args(&words(&["0116#02"])).is_err());
    }

    #[test]
    fn a_lone_digit_is_an_error_naming_the_input() {
        let e = parse_hex_args(&words(&["01", "2"])).unwrap_err();
        assert!(e.text().contains("\"01 2\""), "{}", e.text());
        assert!(e.text().contains("odd number"), "{}", e.text());
    }
}
