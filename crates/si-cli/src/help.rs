//! How the command tree reads in `--help`: the line options under their own heading
//! and only where a command uses them, and one hex rule written beside every byte argument.
//!
//! The line options stay `global` (so `si --port X modbus read` and `si modbus read --port X`
//! both work) and are declared once, in [`crate::conn::Connection`]. This module post-processes
//! the built tree instead of touching every command file: clap copies a global option into a
//! subcommand only where the subcommand has no argument of that id yet, so giving an offline
//! command a hidden copy of each line option keeps it out of that command's help (and its
//! subcommands'), while still accepting it from the scripts that pass it everywhere.

use crate::conn::LINE_OPTIONS;
use crate::hex::HEX_HELP;
use clap::{Arg, Command};

/// The commands that open no line, as paths from the top: every line option is hidden from
/// their help (and their subcommands').
const OFFLINE: &[&[&str]] = &[
    &["frame"],
    &["diag"],
    &["im"],
    &["params"],
    &["completions"],
    // The host side of the DP window runs on windows read from stdin; `dp-coord module`
    // opens the serial line.
    &["dp-coord", "host"],
];

/// The commands that use only some line options, and those they use: the others are hidden.
/// `si sim` takes the simulated line's character format and `--record` for its trace; `si
/// ports` looks at one port (`--port`) and may set its latency timer; both take them from a
/// `--profile` too.
const PARTLY: &[(&str, &[&str])] = &[
    (
        "sim",
        &[
            "profile",
            "baud",
            "data_bits",
            "parity",
            "stop_bits",
            "record",
        ],
    ),
    ("ports", &["profile", "port", "latency_timer"]),
];

/// The tree as the user sees it: line options hidden where unused, the hex rule beside every
/// `HEX` argument.
pub fn arrange(cli: Command) -> Command {
    let line: Vec<Arg> = cli
        .get_arguments()
        .filter(|a| a.get_help_heading() == Some(LINE_OPTIONS))
        .cloned()
        .collect();
    let hide = |sub: Command, keep: &[&str]| {
        line.iter()
            .filter(|a| !keep.contains(&a.get_id().as_str()))
            .fold(sub, |sub, a| sub.arg(a.clone().hide(true)))
    };
    let mut cli = cli;
    for (name, uses) in PARTLY {
        cli = cli.mut_subcommand(name, |sub| hide(sub, uses));
    }
    for path in OFFLINE {
        cli = at_path(cli, path, &|sub| hide(sub, &[]));
    }
    with_hex_rule(cli)
}

/// Apply `f` to the subcommand at `path` below `cmd`.
fn at_path(cmd: Command, path: &[&str], f: &dyn Fn(Command) -> Command) -> Command {
    match path {
        [] => f(cmd),
        [name, rest @ ..] => cmd.mut_subcommand(name, |sub| at_path(sub, rest, f)),
    }
}

/// Append [`HEX_HELP`] to the help of every argument named `HEX`, in this command and below.
fn with_hex_rule(cmd: Command) -> Command {
    cmd.mut_args(|a| {
        let takes_hex = a
            .get_value_names()
            .is_some_and(|names| names.iter().any(|n| n.as_str() == "HEX"));
        if !takes_hex {
            return a;
        }
        let what = a.get_help().map(ToString::to_string).unwrap_or_default();
        a.help(format!("{what}. {HEX_HELP}"))
    })
    .mut_subcommands(with_hex_rule)
}
