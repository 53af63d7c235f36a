//! `cargo xtask`: workspace automation.
//!
//! * `cargo xtask codegen` validates every CSV under `crates/drive-profile/data/` and writes
//!   the Rust tables to `crates/drive-profile/src/generated/`; it also compiles
//!   `crates/sparkplug-b/proto/sparkplug_b.proto` into `crates/sparkplug-b/src/proto.rs`.
//! * `cargo xtask codegen --check` does the same in memory and fails when the committed
//!   output differs (CI runs it; a `#[test]` in this crate runs it too).
//! * `cargo xtask interop [--only mbpoll|libmodbus|pymodbus|master] [--no-install]` runs
//!   third-party Modbus software against drivebus (see [`xtask::interop`]).

use std::process::ExitCode;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    match args.as_slice() {
        ["codegen"] => run(false),
        ["codegen", "--check"] => run(true),
        ["interop", rest @ ..] => xtask::interop::run(&xtask::workspace_root(), rest),
        _ => {
            eprintln!(
                "usage: cargo xtask codegen [--check]\n       {}",
                &xtask::interop::USAGE[7..]
            );
            ExitCode::from(2)
        }
    }
}

fn run(check: bool) -> ExitCode {
    let root = xtask::workspace_root();
    match xtask::codegen(&root, check) {
        Ok(report) => {
            println!("{report}");
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
