//! What every `drivectl sim <protocol>` shares: the options of a serial simulator
//! ([`SerialSim`]: where to serve, the drives' addresses, in each protocol's words from its
//! [`SimFamily`]), checking the addresses and the pty's parity before anything is opened, and
//! serving a simulated bus on a serial port or on a new pseudo-terminal whose path is printed
//! as the first line of standard output.

use std::io;
use std::marker::PhantomData;
use std::ops::RangeInclusive;
use std::time::Duration;

use clap::Args;
use drive_core::rt::{Bus, CharIo, Station, Stream};
use drive_core::{LineSettings, Parity};
use drive_transport::pty::PtyPair;

use super::line::open_settings;
use crate::error::{CliError, Result};

/// How a protocol's serial simulator names its drives' addresses and its master.
pub trait SimFamily {
    /// The addresses a drive can have.
    const ADDRESSES: RangeInclusive<u8>;
    /// The address of the one drive simulated when none is given.
    const DEFAULT_ADDRESS: &'static str;
    /// The help of `--addr`.
    const ADDRESS_HELP: &'static str;
    /// What the address is (`P810`, `parameter 1376`), for a refused one.
    const ADDRESS_PARAM: &'static str;
    /// Said after the refused parity on a pty when it is the default (` (the default)`).
    const DEFAULT_PARITY_NOTE: &'static str;
    /// The master's command (`drivectl movilink`).
    const MASTER: &'static str;
}

/// The options every serial `drivectl sim …` starts with: a serial port or a new pty, and the
/// drives' addresses.
#[derive(Debug, Args)]
pub struct SerialSim<F: SimFamily> {
    /// Serve on this serial port.
    #[arg(long, conflicts_with = "pty", required_unless_present = "pty")]
    pub port: Option<String>,
    /// Serve on a new pseudo-terminal and print its path; needs `--parity none` (a pty carries
    /// no parity), on the master too.
    #[arg(long)]
    pub pty: bool,
    #[arg(long = "addr", default_value = F::DEFAULT_ADDRESS, help = F::ADDRESS_HELP)]
    pub addrs: Vec<u8>,
    #[arg(skip)]
    family: PhantomData<F>,
}

impl<F: SimFamily> SerialSim<F> {
    /// Check before anything is opened: every address valid and given once; on a pty no
    /// parity (`parity` is the line's).
    pub fn check(&self, parity: Parity) -> Result<()> {
        self.check_addresses()?;
        self.check_pty_parity(parity)
    }

    /// Every address valid and given once.
    pub fn check_addresses(&self) -> Result<()> {
        check_addresses(&self.addrs, F::ADDRESSES, F::ADDRESS_PARAM)
    }

    /// On a pty no parity.
    pub fn check_pty_parity(&self, parity: Parity) -> Result<()> {
        check_pty_parity(self.pty, parity, F::DEFAULT_PARITY_NOTE, F::MASTER)
    }

    /// The addresses, for the message on standard error: `1, 7`.
    pub fn address_list(&self) -> String {
        address_list(&self.addrs)
    }

    /// Serve `bus` on the port or a new pty with `settings` until interrupted (see [`serve`]).
    pub fn run<B: SimBus>(&self, bus: &mut B, settings: LineSettings, what: &str) -> Result<()> {
        super::line::runtime()?.block_on(serve(bus, self.port.as_deref(), settings, what))
    }
}

/// A simulated bus a protocol crate provides (`movilink::sim::SimulatedBus`,
/// `bonfiglioli_modbus::sim::SimulatedBus`, …: the runtime layer's [`Bus`] of its simulated
/// drives): it serves requests on a line until it closes.
pub trait SimBus {
    /// Serve on `io` until it closes (`Ok`) or fails.
    fn serve_on<IO: CharIo>(&mut self, io: IO) -> impl Future<Output = io::Result<()>>;
}

impl<S: Station> SimBus for Bus<S> {
    fn serve_on<IO: CharIo>(&mut self, io: IO) -> impl Future<Output = io::Result<()>> {
        self.serve(io)
    }
}

/// Each of `addrs` in `valid` and given once; `param` names the address parameter (`P810`,
/// `parameter 1376`).
pub fn check_addresses(addrs: &[u8], valid: RangeInclusive<u8>, param: &str) -> Result<()> {
    if let Some(bad) = addrs.iter().find(|a| !valid.contains(a)) {
        return Err(CliError::usage(format!(
            "--addr {bad}: a drive address is {}…{} ({param})",
            valid.start(),
            valid.end()
        )));
    }
    for (i, a) in addrs.iter().enumerate() {
        if addrs.get(..i).is_some_and(|before| before.contains(a)) {
            return Err(CliError::usage(format!(
                "--addr {a} is given twice; each simulated drive needs its own address ({param})"
            )));
        }
    }
    Ok(())
}

/// `addrs` for a message: `1, 7`.
pub fn address_list(addrs: &[u8]) -> String {
    addrs
        .iter()
        .map(u8::to_string)
        .collect::<Vec<_>>()
        .join(", ")
}

/// On a pty no parity: a pseudo-terminal carries none, and the master refuses parity on one
/// too. `default_note` tells when the refused parity is the default; `master` is the master's
/// command (`drivectl movilink`).
pub fn check_pty_parity(pty: bool, parity: Parity, default_note: &str, master: &str) -> Result<()> {
    if !pty || parity == Parity::None {
        return Ok(());
    }
    let default = if parity == Parity::Even {
        default_note
    } else {
        ""
    };
    Err(CliError::usage(format!(
        "--pty does not support parity {parity}{default}: pseudo-terminals accept only no \
         parity; add --parity none here and on the master ({master} --port PTY --parity none), \
         or serve a real port with --port"
    )))
}

/// A new pseudo-terminal for a simulator: its slave side kept open by this process, so the
/// simulator never sees a hang-up between two clients (each drivectl run opens and closes the
/// pty), and its path printed as the first line of standard output. Keep the returned file as
/// long as the pty is served.
pub fn sim_pty() -> Result<(PtyPair, std::path::PathBuf, std::fs::File)> {
    let pair = PtyPair::open().map_err(|e| CliError::failed(e.to_string()))?;
    let path = pair.slave_path().to_path_buf();
    let keep = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .open(&path)
        .map_err(|e| CliError::failed(format!("cannot open {}: {e}", path.display())))?;
    outln!("{}", path.display())?;
    Ok((pair, path, keep))
}

/// Serve `bus` on the serial port `port` with `settings`, or (`None`) on a new pseudo-terminal
/// whose path is printed first, until interrupted. `what` says what is simulated, for the
/// message on standard error.
pub async fn serve<B: SimBus>(
    bus: &mut B,
    port: Option<&str>,
    settings: LineSettings,
    what: &str,
) -> Result<()> {
    if let Some(path) = port {
        let port = open_settings(path, settings)?;
        errln!("{what} on {path}; Ctrl-C stops");
        return bus
            .serve_on(Stream(port))
            .await
            .map_err(|e| CliError::failed(format!("serving {path}: {e}")));
    }
    let (mut pair, path, _keep) = sim_pty()?;
    errln!("{what} on {}; Ctrl-C stops", path.display());
    loop {
        if let Err(e) = bus.serve_on(Stream(pair.master())).await {
            return Err(CliError::failed(format!("serving {}: {e}", path.display())));
        }
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Debug)]
    struct Toy;

    impl SimFamily for Toy {
        const ADDRESSES: RangeInclusive<u8> = 1..=9;
        const DEFAULT_ADDRESS: &'static str = "4";
        const ADDRESS_HELP: &'static str = "Toy address(es) 1…9";
        const ADDRESS_PARAM: &'static str = "T1";
        const DEFAULT_PARITY_NOTE: &'static str = " (the toy's default)";
        const MASTER: &'static str = "drivectl toy";
    }

    #[derive(Debug, Parser)]
    struct Cli {
        #[command(flatten)]
        sim: SerialSim<Toy>,
    }

    #[test]
    fn serial_sim_options_take_the_familys_words() {
        let cli = Cli::try_parse_from(["toy", "--pty"]).unwrap();
        assert_eq!((cli.sim.pty, cli.sim.addrs.as_slice()), (true, &[4][..]));
        assert_eq!(cli.sim.port, None);
        let cli =
            Cli::try_parse_from(["toy", "--port", "/dev/x", "--addr", "2", "--addr", "7"]).unwrap();
        assert_eq!(cli.sim.address_list(), "2, 7");
        cli.sim.check(Parity::Even).unwrap();
        assert!(
            Cli::try_parse_from(["toy"]).is_err(),
            "--port or --pty is required"
        );
        assert!(Cli::try_parse_from(["toy", "--pty", "--port", "/dev/x"]).is_err());
        let cli = Cli::try_parse_from(["toy", "--pty", "--addr", "10"]).unwrap();
        let e = cli.sim.check(Parity::None).unwrap_err().to_string();
        assert_eq!(e, "--addr 10: a drive address is 1…9 (T1)");
        let cli = Cli::try_parse_from(["toy", "--pty"]).unwrap();
        let e = cli.sim.check(Parity::Even).unwrap_err().to_string();
        assert!(
            e.contains("parity even (the toy's default)") && e.contains("drivectl toy --port"),
            "{e}"
        );
        let help = <Cli as clap::CommandFactory>::command()
            .render_help()
            .to_string();
        assert!(help.contains("Toy address(es) 1…9 [default: 4]"), "{help}");
    }

    #[test]
    fn addresses_and_pty_parity_are_checked_with_the_protocols_words() {
        check_addresses(&[1, 5], 0..=99, "P810").unwrap();
        let e = check_addresses(&[1, 100], 0..=99, "P810")
            .unwrap_err()
            .to_string();
        assert_eq!(e, "--addr 100: a drive address is 0…99 (P810)");
        let e = check_addresses(&[3, 1, 3], 1..=247, "parameter 1376")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("--addr 3 is given twice"), "{e}");
        check_pty_parity(true, Parity::None, "", "drivectl movilink").unwrap();
        check_pty_parity(false, Parity::Even, "", "drivectl movilink").unwrap();
        let e = check_pty_parity(true, Parity::Even, " (the default)", "drivectl bonfiglioli")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("parity even (the default)")
                && e.contains("drivectl bonfiglioli --port PTY"),
            "{e}"
        );
    }
}
