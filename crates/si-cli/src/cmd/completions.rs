//! `si completions <shell>`: the shell's completion script, generated from the command tree so it
//! never drifts from the options.
//!
//! Install, e.g. bash: `si completions bash > ~/.local/share/bash-completion/completions/si`;
//! zsh: `si completions zsh > ~/.zfunc/_si`; fish:
//! `si completions fish > ~/.config/fish/completions/si.fish`.

use crate::error::CliError;
use clap::Args;
use clap_complete::Shell;

/// `si completions`.
#[derive(Debug, Args)]
pub struct CompletionsArgs {
    /// The shell: bash, elvish, fish, powershell or zsh.
    #[arg(value_enum)]
    shell: Shell,
}

impl CompletionsArgs {
    /// Write the script for the tree `cli` (the arranged `si` command) to stdout.
    pub fn run(&self, mut cli: clap::Command) -> Result<(), CliError> {
        let name = cli.get_name().to_owned();
        let mut script = Vec::new();
        clap_complete::generate(self.shell, &mut cli, name, &mut script);
        crate::output::write_stdout(format_args!("{}", String::from_utf8_lossy(&script)));
        Ok(())
    }
}
