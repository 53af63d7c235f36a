//! `drivectl`: browse drive parameter tables, talk to drives, run simulated drives.
//!
//! Human-readable output by default, `--json` for scripts (one JSON object per result).
//! Errors print one line saying what failed and what to try, and exit with a non-zero code.

mod demo;
mod error;
mod params;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// Talk to SEW, NORD and Bonfiglioli frequency inverters over their own buses.
#[derive(Debug, Parser)]
#[command(name = "drivectl", version, about, propagate_version = true)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Browse the parameter tables of a drive family (movidrive, nord, bonfiglioli).
    Params(params::ParamsArgs),
    /// Run the built-in demonstration (tables, state machines, simulated sessions).
    Demo(demo::DemoArgs),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Params(args) => params::run(&args),
        Command::Demo(args) => demo::run(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("drivectl: {e}");
            ExitCode::from(e.exit_code())
        }
    }
}
