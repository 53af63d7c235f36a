//! `drivectl`: browse drive parameter tables, talk to drives, run simulated drives.
//!
//! Human-readable output by default, `--json` for scripts (one JSON object per result).
//! Errors print one line saying what failed and what to try, and exit with a non-zero code.

// Command output goes through `outln!`/`out!` (a closed pipe is an error, not a panic) and
// messages through `errln!`.
#![deny(clippy::print_stdout, clippy::print_stderr)]

#[macro_use]
mod tool;
mod completions;
mod demo;
mod error;
mod examples;
mod movilink;
mod params;
mod ports;

use clap::{CommandFactory, Parser, Subcommand};
use std::process::ExitCode;

/// Talk to SEW, NORD and Bonfiglioli frequency inverters over their own buses.
#[derive(Debug, Parser)]
#[command(
    name = "drivectl",
    version,
    about,
    propagate_version = true,
    after_help = examples::ROOT
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Browse the parameter tables of a drive family (movidrive, nord, bonfiglioli).
    Params(params::ParamsArgs),
    /// Talk to a SEW MOVIDRIVE over MOVILINK (RS-485 / RS-232).
    Movilink(movilink::MovilinkArgs),
    /// Run simulated drives on a serial port or a new pseudo-terminal.
    #[command(subcommand, after_help = examples::SIM)]
    Sim(SimCommand),
    /// Explain captured telegrams field by field.
    #[command(subcommand, after_help = examples::DECODE)]
    Decode(DecodeCommand),
    /// Run the built-in demonstration (tables, state machines, simulated sessions).
    Demo(demo::DemoArgs),
    /// List this machine's serial ports (type, USB VID:PID, serial number, maker).
    Ports(ports::PortsArgs),
    /// Print a shell completion script (bash, zsh, fish, powershell, elvish).
    Completions(completions::CompletionsArgs),
    /// Print a man page (roff) generated from the command definitions.
    Man(completions::ManArgs),
}

#[derive(Debug, Subcommand)]
enum SimCommand {
    /// Simulated MOVIDRIVE(s) answering MOVILINK.
    Movilink(movilink::sim::SimArgs),
}

#[derive(Debug, Subcommand)]
enum DecodeCommand {
    /// A MOVILINK capture: hex bytes, e.g. `02 01 85 00 06 20 00 0B B8 13`.
    Movilink {
        /// The bytes (spaces, commas or none between them).
        #[arg(required = true, num_args = 1..)]
        hex: Vec<String>,
        /// One JSON object per telegram.
        #[arg(long)]
        json: bool,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Params(args) => params::run(&args),
        Command::Movilink(args) => movilink::run(&args),
        Command::Sim(SimCommand::Movilink(args)) => movilink::sim::run(&args),
        Command::Decode(DecodeCommand::Movilink { hex, json }) => movilink::decode::run(&hex, json),
        Command::Demo(args) => demo::run(&args),
        Command::Ports(args) => ports::run(&args),
        Command::Completions(args) => completions::completions(&args, Cli::command()),
        Command::Man(args) => completions::man(&args, Cli::command()),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if e.is_closed_pipe() => ExitCode::from(e.exit_code()),
        Err(e) => {
            errln!("drivectl: {e}");
            ExitCode::from(e.exit_code())
        }
    }
}
