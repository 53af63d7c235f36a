//! `drivectl`: browse drive parameter tables, talk to drives, run simulated drives.
//!
//! Human-readable output by default, `--json` for scripts (one JSON object per result).
//! Errors print one line saying what failed and what to try, and exit with a non-zero code.

// Command output goes through `outln!`/`out!` (a closed pipe is an error, not a panic) and
// messages through `errln!`.
#![deny(clippy::print_stdout, clippy::print_stderr)]

#[macro_use]
mod tool;
mod bonfiglioli;
mod completions;
mod decode;
mod demo;
mod error;
mod examples;
mod gateway;
mod movilink;
mod nord;
mod params;
mod ports;
mod sbus;
mod sew;
mod ui;

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};
use std::process::ExitCode;

// The doc comment is the first line of `--help` and the man page's NAME line (`drivectl -
// Talk to …`); the package's description (`drivectl: the drivebus command-line tool`) would
// say the name twice there.
/// Talk to SEW, NORD and Bonfiglioli frequency inverters over their own buses.
#[derive(Debug, Parser)]
#[command(
    name = "drivectl",
    version,
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
    /// Talk to a Bonfiglioli ACTIVE / ACTIVE Cube over Modbus RTU or ASCII.
    Bonfiglioli(bonfiglioli::BonfiglioliArgs),
    /// Talk to a SEW MOVIDRIVE over SBus (MOVILINK over CAN): identifiers, ID plans, and (with
    /// --iface) the drive.
    Sbus(sbus::SbusArgs),
    /// Put every drive of a plant on an MQTT broker: polls, statuses, guarded writes, metrics.
    Gateway(gateway::GatewayArgs),
    /// The drives on one bus in the browser: a page on 127.0.0.1 with their live values.
    Ui(ui::UiArgs),
    /// Talk to a NORD NORDAC LINK over USS (RS-485).
    Uss(nord::uss::UssArgs),
    /// Talk to a NORD NORDAC LINK over CTT2 through an AS-i master (simulated: --sim).
    Ctt2(nord::ctt2::Ctt2Args),
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
    /// Simulated Bonfiglioli ACT/ACU drive(s) answering Modbus RTU or ASCII.
    Bonfiglioli(bonfiglioli::sim::SimArgs),
    /// Simulated NORD NORDAC LINK drive(s) answering USS.
    Uss(nord::sim::SimArgs),
    /// Simulated MOVIDRIVE(s) on SBus (CAN): behind a simulated slcan adapter on a pty, or on
    /// a CAN interface.
    Sbus(sbus::sim::SimArgs),
}

#[derive(Debug, Subcommand)]
enum DecodeCommand {
    /// A MOVILINK capture: hex bytes, e.g. `02 01 85 00 06 20 00 0B B8 13`.
    ///
    /// Bytes are pairs of hex digits, with or without `0x`, separated by spaces, commas or
    /// colons, or run together (`020185`); an odd number of digits or a non-hex token is an
    /// error naming it. Several telegrams back to back are split by their start character
    /// (SD1 02 request, SD2 1D response) and PDU type; bytes that start no telegram are reported
    /// with their offset and skipped.
    ///
    /// Examples:
    ///   drivectl decode movilink 02 01 86 31 00 20 6D 00 00 00 00 F9
    ///   drivectl decode movilink --file capture.txt --json
    ///   drivectl decode movilink - < capture.txt
    #[command(verbatim_doc_comment)]
    Movilink {
        #[command(flatten)]
        input: decode::CaptureArgs,
        /// One JSON object per telegram (`"type": "telegram"`) or skipped run of bytes
        /// (`"type": "skipped"`), the shape every decoder shares
        /// (docs/decode-json.md).
        #[arg(long)]
        json: bool,
    },
    /// A NORD CTT2 capture (AS-i): hex bytes, e.g. `13 2F 08 70 66 02 00 00 00 03 E8`.
    ///
    /// Bytes as for `decode movilink`. Requests (16, 18, 19, 29) and answers (80, 82, 83, 93,
    /// 144, 146, 147, 157) are split by their codes and lengths; an answer's data are read as
    /// the request before it asked (ID or diagnosis object, PZD or PKW channel). The PKW and
    /// PZD data are explained with the NORD table (P102 in parameter set 3 = 10.00 s).
    #[command(
        verbatim_doc_comment,
        after_help = "Examples:\n  drivectl decode ctt2 13 2F 08 70 66 02 00 00 00 03 E8 53 12 2F 08 52 40 66 02 00 00 00 03 E8\n  \
                      drivectl decode ctt2 1D 03 05 05 01 04 7F 20 00 5D 01 0B 37 20 00 --json\n  \
                      drivectl decode ctt2 --file capture.txt"
    )]
    Ctt2 {
        #[command(flatten)]
        input: decode::CaptureArgs,
        /// One JSON object per message or skipped run of bytes, the shape every decoder shares
        /// (docs/decode-json.md).
        #[arg(long)]
        json: bool,
    },
    /// A NORD USS capture (RS-485): hex bytes, e.g. `02 0E 01 70 66 02 00 … 88`.
    ///
    /// Bytes as for `decode movilink`. Telegrams are split at STX (02h) by their LGE and the
    /// BCC is checked. A telegram does not say who sent it: they alternate, the first is the
    /// master's (--start drive turns that round; a broadcast gets no answer). The net data are
    /// --pkw PKW words and the rest PZD words.
    #[command(
        verbatim_doc_comment,
        after_help = "Examples:\n  drivectl decode uss 02 0E 01 70 66 02 00 00 00 03 E8 04 7E 00 00 88\n  \
                      drivectl decode uss 02 0E 01 40 66 02 00 00 00 03 E8 0B 31 00 00 F8 --start drive --json\n  \
                      drivectl decode uss --pkw 3 --pzd 2 --file capture.txt"
    )]
    Uss {
        #[command(flatten)]
        input: decode::CaptureArgs,
        /// PKW words of the telegrams: 0, 3 or 4.
        #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u8).range(0..=4))]
        pkw: u8,
        /// PZD words of the telegrams (checked against LGE); default: the rest of the net data.
        #[arg(long, value_parser = clap::value_parser!(u8).range(0..=16))]
        pzd: Option<u8>,
        /// Who sent the first telegram: master or drive (they alternate).
        #[arg(long, default_value = "master", value_parser = ["master", "drive"])]
        start: String,
        /// One JSON object per telegram or skipped run of bytes, the shape every decoder shares
        /// (docs/decode-json.md).
        #[arg(long)]
        json: bool,
    },
    /// An SBus frame (CAN identifier and data bytes), e.g. `--id 523 31 00 20 7E 00 00 00 00`,
    /// or a candump log (`--log FILE`: lines `(seconds.micros) iface ID#DATA`).
    ///
    /// Data bytes as for `decode movilink`, at most 8. The identifier names the telegram
    /// (manual ch. 5.1: 8 × address + 3 … + 518); the sync identifier is --sync-id (P817); any
    /// other identifier is a variable telegram (shown as two 32-bit variables in MOTOROLA and
    /// INTEL byte order) or another protocol.
    #[command(
        verbatim_doc_comment,
        after_help = "Examples:\n  drivectl decode sbus --id 523 31 00 20 7E 00 00 00 00\n  \
                      drivectl decode sbus --id 0x10B 00 06 13 88 00 00 --json\n  \
                      drivectl decode sbus --id 1024 55 66 77 88 11 22 33 44\n  \
                      candump -l can0; drivectl decode sbus --log candump-2026-11-26_101010.log"
    )]
    Sbus {
        /// The CAN identifier: decimal, 0x… or …h; 0–2047 (or 29 bits with --extended).
        #[arg(
            long,
            allow_hyphen_values = true,
            required_unless_present = "log",
            conflicts_with = "log"
        )]
        id: Option<String>,
        /// A candump log file (`-`: standard input); a UTF-8 BOM and CR LF line ends are
        /// allowed.
        #[arg(long, value_name = "FILE", conflicts_with_all = ["hex", "extended"])]
        log: Option<String>,
        /// The identifier is an extended (29-bit) one (SBus uses none).
        #[arg(long)]
        extended: bool,
        /// The data bytes (0–8).
        #[arg(num_args = 0..)]
        hex: Vec<String>,
        /// The sync identifier (P817), 0–2047.
        #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u16).range(0..=2047))]
        sync_id: u16,
        /// One JSON object per frame (or unreadable log line), the shape every decoder shares
        /// (docs/decode-json.md).
        #[arg(long)]
        json: bool,
    },
    /// A Bonfiglioli Modbus RTU capture: hex bytes, e.g. `01 03 21 74 00 01 CE 2C`.
    ///
    /// Bytes as for `decode movilink`. RTU has no start character: a stream is split where a
    /// CRC-16 closes a frame; a run without a valid CRC is explained with the CRC it should
    /// have. A read answer is scaled by the parameter of the read request before it.
    #[command(
        verbatim_doc_comment,
        after_help = "Examples:\n  drivectl decode modbus-rtu 01 03 21 74 00 01 CE 2C 01 03 02 05 6E 3A F8\n  \
                      drivectl decode modbus-rtu --file capture.txt --json\n  \
                      drivectl decode modbus-rtu - < capture.txt"
    )]
    ModbusRtu {
        #[command(flatten)]
        input: decode::CaptureArgs,
        /// One JSON object per frame or skipped run of bytes, the shape every decoder shares
        /// (docs/decode-json.md).
        #[arg(long)]
        json: bool,
    },
    /// A Bonfiglioli Modbus ASCII capture: the frames as text (`:010321740001 66`) or their
    /// characters as hex bytes (`3A 30 31 …`).
    ///
    /// Frames run from `:` to CR LF (a line end counts as CR LF); the LRC is checked and the
    /// expected one named when it is wrong.
    #[command(
        verbatim_doc_comment,
        after_help = "Examples:\n  drivectl decode modbus-ascii :01032174000166 :010302056E87\n  \
                      drivectl decode modbus-ascii --file capture.txt --json"
    )]
    ModbusAscii {
        /// The frames; `-` reads a capture from standard input (as --file).
        #[arg(required_unless_present = "file", conflicts_with = "file", num_args = 1..)]
        text: Vec<String>,
        /// Read the capture from a file, one frame per line.
        #[arg(long, value_name = "PATH")]
        file: Option<String>,
        /// One JSON object per frame or skipped run of bytes, the shape every decoder shares
        /// (docs/decode-json.md).
        #[arg(long)]
        json: bool,
    },
}

/// Whether `--json` is among the arguments (before a `--`): then messages and errors on
/// standard error are JSON objects too, including the command line's own errors.
fn json_requested() -> bool {
    std::env::args_os()
        .skip(1)
        .take_while(|a| a != "--")
        .any(|a| a == "--json")
}

/// The command definitions, with the `ctt2` examples of the commands NORD shares.
fn command() -> clap::Command {
    nord::ctt2::with_help(Cli::command())
}

fn main() -> ExitCode {
    let json = json_requested();
    tool::output::json_messages(json);
    let cli = match command()
        .try_get_matches()
        .and_then(|m| Cli::from_arg_matches(&m))
    {
        Ok(cli) => cli,
        Err(e) if json && e.use_stderr() => {
            // A usage error of the command line, as one JSON object (its first line: clap adds
            // usage and a `--help` hint below it).
            let text = e.to_string();
            let first = text.lines().next().unwrap_or_default();
            let message = first.strip_prefix("error: ").unwrap_or(first);
            tool::output::final_error(&error::CliError::usage(message));
            return ExitCode::from(2);
        }
        Err(e) => e.exit(),
    };
    let result = match cli.command {
        Command::Params(args) => params::run(&args),
        Command::Movilink(args) => movilink::run(&args),
        Command::Sim(SimCommand::Movilink(args)) => movilink::sim::run(&args),
        Command::Bonfiglioli(args) => bonfiglioli::run(&args),
        Command::Sim(SimCommand::Bonfiglioli(args)) => bonfiglioli::sim::run(&args),
        Command::Sbus(args) => sbus::run(&args),
        Command::Gateway(args) => gateway::run(&args),
        Command::Ui(args) => ui::run(&args),
        Command::Uss(args) => nord::uss::run(&args),
        Command::Ctt2(args) => nord::ctt2::run(&args),
        Command::Sim(SimCommand::Uss(args)) => nord::sim::run(&args),
        Command::Sim(SimCommand::Sbus(args)) => sbus::sim::run(&args),
        Command::Decode(DecodeCommand::ModbusRtu { input, json }) => {
            bonfiglioli::decode::run(false, &input.hex, input.file.as_deref(), json)
        }
        Command::Decode(DecodeCommand::ModbusAscii { text, file, json }) => {
            bonfiglioli::decode::run(true, &text, file.as_deref(), json)
        }
        Command::Decode(DecodeCommand::Ctt2 { input, json }) => {
            nord::decode::run(None, &input.hex, input.file.as_deref(), json)
        }
        Command::Decode(DecodeCommand::Uss {
            input,
            pkw,
            pzd,
            start,
            json,
        }) => nord::decode::run(
            Some(nord::decode::uss_layout(pkw, pzd, start == "drive")),
            &input.hex,
            input.file.as_deref(),
            json,
        ),
        Command::Decode(DecodeCommand::Sbus {
            log: Some(log),
            sync_id,
            json,
            ..
        }) => sbus::decode::run_log(&log, sync_id, json),
        Command::Decode(DecodeCommand::Sbus {
            id,
            extended,
            hex,
            sync_id,
            json,
            log: None,
        }) => sbus::decode::run_frame(id.as_deref(), extended, &hex, sync_id, json),
        Command::Decode(DecodeCommand::Movilink { input, json }) => {
            movilink::decode::run(&input.hex, input.file.as_deref(), json)
        }
        Command::Demo(args) => demo::run(&args),
        Command::Ports(args) => ports::run(&args),
        Command::Completions(args) => completions::completions(&args, command()),
        Command::Man(args) => completions::man(&args, command()),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if e.is_closed_pipe() => ExitCode::from(e.exit_code()),
        Err(e) => {
            tool::output::final_error(&e);
            ExitCode::from(e.exit_code())
        }
    }
}
