//! `drivectl completions <shell>` and `drivectl man [COMMAND]...`: shell completion scripts and
//! man pages, both generated from the clap definitions, so they never drift from `--help`.

use crate::error::{CliError, Result};
use clap::{Args, Command};
use clap_complete::Shell;

/// Examples below `drivectl completions --help`.
const COMPLETIONS_AFTER_HELP: &str = "\
Examples:
  drivectl completions bash > ~/.local/share/bash-completion/completions/drivectl
  drivectl completions zsh > ~/.zfunc/_drivectl        (with fpath+=~/.zfunc in ~/.zshrc)
  drivectl completions fish > ~/.config/fish/completions/drivectl.fish
  drivectl completions powershell >> $PROFILE";

/// Examples below `drivectl man --help`.
const MAN_AFTER_HELP: &str = "\
Examples:
  drivectl man | man -l -                      read drivectl(1)
  drivectl man movilink read | man -l -        the page of one command, drivectl-movilink-read(1)
  drivectl man params > drivectl-params.1      install a page
  drivectl man --list                          every command path that has a page";

/// Arguments of `drivectl completions`.
#[derive(Debug, Args)]
#[command(after_help = COMPLETIONS_AFTER_HELP)]
pub struct CompletionsArgs {
    /// The shell to write the completion script for.
    #[arg(value_enum)]
    shell: Shell,
}

/// Arguments of `drivectl man`.
#[derive(Debug, Args)]
#[command(after_help = MAN_AFTER_HELP)]
pub struct ManArgs {
    /// The command whose page to write (e.g. `movilink read`); none: drivectl(1) itself.
    command: Vec<String>,
    /// Print every command path that has a page, one a line (`drivectl`, `drivectl movilink`,
    /// `drivectl movilink read`, …), instead of a page.
    #[arg(long, conflicts_with = "command")]
    list: bool,
}

/// Write the completion script for `args.shell` to standard output.
pub fn completions(args: &CompletionsArgs, mut cmd: Command) -> Result<()> {
    let name = cmd.get_name().to_owned();
    let mut buf = Vec::new();
    clap_complete::generate(args.shell, &mut cmd, name, &mut buf);
    out!("{}", String::from_utf8_lossy(&buf))?;
    Ok(())
}

/// Write the man page (roff) of `drivectl` or one of its commands to standard output.
pub fn man(args: &ManArgs, cmd: Command) -> Result<()> {
    let mut cmd = cmd;
    cmd.build();
    if args.list {
        let mut paths = Vec::new();
        command_paths(&cmd, &mut Vec::new(), &mut paths);
        for path in &paths {
            outln!("{path}")?;
        }
        return Ok(());
    }
    let mut page = cmd;
    let mut path = vec![page.get_name().to_owned()];
    for word in &args.command {
        let sub = page
            .find_subcommand(word)
            .filter(|s| s.get_name() != "help")
            .cloned()
            .ok_or_else(|| {
                let known: Vec<&str> = page
                    .get_subcommands()
                    .map(Command::get_name)
                    .filter(|n| *n != "help")
                    .collect();
                if known.is_empty() {
                    CliError::usage(format!("`{}` has no subcommands", path.join(" ")))
                } else {
                    CliError::usage(format!(
                        "`{}` has no command `{word}`; use one of: {}",
                        path.join(" "),
                        known.join(", ")
                    ))
                }
            })?;
        path.push(sub.get_name().to_owned());
        page = sub;
    }
    // Built, a subcommand's display name is the whole command path (drivectl-movilink-read,
    // as git's pages are named) and its usage starts with `drivectl movilink read`.
    let mut buf = Vec::new();
    clap_mangen::Man::new(page)
        .section("1")
        .source(format!("drivectl {}", env!("CARGO_PKG_VERSION")))
        .manual("drivebus")
        .render(&mut buf)
        .map_err(|e| CliError::failed(format!("cannot render the man page: {e}")))?;
    out!("{}", String::from_utf8_lossy(&buf))?;
    Ok(())
}

/// Every command path under `cmd` (itself first, then depth first), without `help`.
fn command_paths(cmd: &Command, prefix: &mut Vec<String>, paths: &mut Vec<String>) {
    prefix.push(cmd.get_name().to_owned());
    paths.push(prefix.join(" "));
    for sub in cmd.get_subcommands().filter(|s| s.get_name() != "help") {
        command_paths(sub, prefix, paths);
    }
    prefix.pop();
}
