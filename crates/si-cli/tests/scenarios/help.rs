//! Help that reads well: the line options under their own heading where a command
//! opens a line and hidden where it opens none, one hex rule beside every byte argument, and
//! `si completions`.

use crate::common;

use common::{si, stderr, stdout};

/// `si ARGS --help`, checked to succeed.
fn help(args: &[&str]) -> String {
    let o = si(&[args, &["--help"]].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    stdout(&o)
}

#[test]
fn offline_commands_show_no_line_options() {
    for args in [
        &["frame"][..],
        &["frame", "encode", "modbus"],
        &["frame", "decode", "rk512"],
        &["diag", "decode"],
        &["im", "decode"],
        &["params"],
        &["completions"],
    ] {
        let text = help(args);
        for option in [
            "--baud",
            "--port",
            "--tcp",
            "--parity",
            "--rs485",
            "--profile",
        ] {
            assert!(
                !text.contains(option),
                "si {args:?} --help shows {option}:\n{text}"
            );
        }
        assert!(!text.contains("Line options"), "{text}");
    }
}

#[test]
fn hidden_line_options_are_still_accepted_where_scripts_pass_them() {
    let o = si(&[
        "frame",
        "encode",
        "modbus",
        "01 03 00 00 00 0A",
        "--baud",
        "19200",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stdout(&o).trim(), "01 03 00 00 00 0A C5 CD");
}

#[test]
fn line_commands_show_the_line_options_under_their_own_heading() {
    for args in [
        &["modbus", "read"][..],
        &["3964r", "send"],
        &["uss", "poll"],
        &["monitor"],
    ] {
        let text = help(args);
        let heading = text
            .find("\nLine options:")
            .unwrap_or_else(|| panic!("si {args:?} --help has no Line options heading:\n{text}"));
        let (own, line) = text.split_at(heading);
        // As declared (`--port <PORT>`), not as other options' help may mention them.
        for option in [
            "--port <",
            "--tcp <",
            "--baud <",
            "--parity <",
            "--profile <",
        ] {
            assert!(
                line.contains(option),
                "{option} not under Line options:\n{text}"
            );
            assert!(
                !own.contains(option),
                "{option} among the command's own options:\n{text}"
            );
        }
        // The command's own and the general options stay above the heading.
        assert!(own.contains("--json"), "{text}");
    }
}

#[test]
fn sim_shows_the_character_format_but_no_port() {
    let text = help(&["sim"]);
    for option in ["--baud", "--parity", "--record"] {
        assert!(text.contains(option), "{option} missing:\n{text}");
    }
    for option in ["--port", "--tcp", "--rs485", "--latency-timer"] {
        assert!(!text.contains(option), "{option} shown:\n{text}");
    }
}

#[test]
fn ports_shows_only_the_port_and_its_latency_timer() {
    let text = help(&["ports"]);
    for option in ["--port <", "--latency-timer", "--profile"] {
        assert!(text.contains(option), "{option} missing:\n{text}");
    }
    for option in ["--baud", "--tcp", "--rs485", "--record"] {
        assert!(!text.contains(option), "{option} shown:\n{text}");
    }
}

#[test]
fn every_byte_argument_documents_the_same_hex_rule() {
    for args in [
        &["3964r", "send"][..],
        &["ascii", "send"],
        &["rk512", "send"],
        &["frame", "encode", "3964r"],
        &["frame", "decode", "modbus"],
        &["frame", "decode", "uss"],
        &["diag", "decode"],
        &["dp-coord", "host", "send"],
    ] {
        let text = help(args);
        assert!(
            text.contains("Hex as separate words (01 02 10 03) or one quoted string"),
            "si {args:?} --help lacks the hex rule:\n{text}"
        );
    }
}

#[test]
fn frame_commands_read_words_quoted_groups_and_0x_alike() {
    for args in [
        &["01", "03", "00", "00", "00", "0A", "C5", "CD"][..],
        &["01 03 00 00 00 0A C5 CD"],
        &["0x01,0x03", "0000", "000A", "C5:CD"],
    ] {
        let o = si(&[&["--json", "frame", "decode", "modbus"][..], args].concat());
        assert!(o.status.success(), "{args:?}: {}", stderr(&o));
        assert!(
            stdout(&o).contains("\"unit\":1"),
            "{args:?}: {}",
            stdout(&o)
        );
    }
}

#[test]
fn completions_are_generated_from_the_command_tree() {
    let o = si(&["completions", "bash"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let script = stdout(&o);
    assert!(script.contains("modbus"), "{script}");
    assert!(script.contains("--profile"), "{script}");
    let o = si(&["completions", "zsh"]);
    assert!(
        o.status.success() && stdout(&o).contains("#compdef si"),
        "{}",
        stdout(&o)
    );
    let o = si(&["completions", "tcsh"]);
    assert!(!o.status.success());
}
