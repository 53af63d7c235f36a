//! `drivectl ctt2 --sim …`: a NORDAC LINK over CTT2 through an AS-i master — here the
//! in-memory AS-i link of `ctt2_uss::ctt2::link` with a simulated drive behind its double slave.
//!
//! The shared NORD commands run on `ctt2_uss::ctt2::master::Ctt2Driver` (a parameter order is
//! a NORD write of the PKW channel and NORD reads of it until the answer fits; process data are
//! one NORD write/read of the PZD channel). What only CTT2 has lives here: the ID and diagnosis
//! objects of the standard read (`id`, `diag`), the AS-i network the transfer time comes from
//! (`--slaves`: 16 × 154 µs × (2 + slaves) per byte, BU 0255 ch. 4.4) and the double slave's
//! address (`--asi-address`).
//!
//! Every run starts a new simulated drive after power-on (the simulation ends with the
//! command). Transfer times are waited in real time, or with `--fast` on a virtual clock that
//! counts them without waiting.
//!
//! A real AS-i master is reached through its own command interface: implement
//! `ctt2_uss::ctt2::master::Ctt2Link` for it (one request in, one answer out).

use clap::{Args, Subcommand};
use ctt2_uss::client::{ClientConfig, NordClient};
use ctt2_uss::ctt2::link::{SimulatedDoubleSlave, SimulatedLink};
use ctt2_uss::ctt2::master::{Ctt2Driver, DriverConfig};
use ctt2_uss::ctt2::{
    AsiAddress, AsiNetwork, Bank, Channel, DoubleSlaveAddress, IdObject, Profile, SlaveAddress,
};
use serde_json::{Map, Value, json};

use super::{NordCommand, Session, execute, precheck};
use crate::error::{CliError, Result};
use crate::tool::line::runtime;
use crate::tool::output::trim_float;

/// Below `drivectl ctt2 --help`.
const CTT2_HELP: &str = "\
Examples:
  drivectl ctt2 --sim id                                   the ID object (14 bytes)
  drivectl ctt2 --sim read P102 --set 3
  drivectl ctt2 --sim --slaves 31 --fast diag             31 AS-i slaves: 81.31 ms per byte, not waited
  drivectl ctt2 --sim --asi-address 5A control enable --setpoint 50

Every run talks to a new simulated drive after power-on, through the in-memory AS-i link with
the transfer-time model of BU 0255 ch. 4.4 (16 × 154 µs × (2 + slaves) per byte). CTT2 has no
response timeout to set: the double slave answers within 200 ms or with error 4 (ch. 4.3.5),
and drivectl repeats a request answered with error 4 or 5 three times. `line` shows what the
link uses. A real AS-i master needs its own link: implement ctt2_uss::ctt2::master::Ctt2Link
for its command interface.";

/// Arguments of `drivectl ctt2`.
#[derive(Debug, Args)]
#[command(after_help = CTT2_HELP)]
pub struct Ctt2Args {
    /// Run against the in-memory AS-i link with a simulated NORDAC LINK behind the double
    /// slave (required: drivectl has no AS-i master of its own).
    #[arg(long, global = true)]
    sim: bool,
    /// AS-i slaves on the network, 2–62 (the double slave counts 2): the CTT2 transfer time
    /// per byte is 16 × 154 µs × (2 + slaves).
    #[arg(long, global = true, default_value_t = 2, value_parser = clap::value_parser!(u8).range(2..=62))]
    slaves: u8,
    /// AS-i address of the double slave's 1st slave, 1A–31A (the 2nd slave is the same number
    /// in bank B). Default 1A, the first extended address: an AS-i slave leaves the factory at
    /// address 0, which exchanges no data until the AS-i master gives it one.
    #[arg(long, global = true, default_value = "1A", value_name = "ADDRESS")]
    asi_address: String,
    /// Count the transfer times on a virtual clock instead of waiting for them.
    #[arg(long, global = true)]
    fast: bool,
    /// The PKW channel: 47 (without the drive address, the default) or 4 (with it).
    #[arg(long, global = true, default_value_t = 47, value_name = "INDEX", value_parser = pkw_index)]
    pkw_index: u8,
    /// One JSON object per result.
    #[arg(long, global = true)]
    json: bool,
    #[command(subcommand)]
    command: Ctt2Command,
}

#[derive(Debug, Subcommand)]
enum Ctt2Command {
    #[command(flatten)]
    Nord(NordCommand),
    /// Read the ID object (standard read, index 0): manufacturer and device ID, I/O
    /// configuration, AS-i mode and firmware, the drive's firmware, power, voltage range and
    /// configuration level. `--len` reads only the first bytes (the manual: read only what is
    /// needed).
    #[command(
        after_help = "Examples:\n  drivectl ctt2 --sim id\n  drivectl ctt2 --sim id --len 4 --json     manufacturer and device ID only"
    )]
    Id {
        /// Bytes to read, 1–14.
        #[arg(long, default_value_t = 14, value_parser = clap::value_parser!(u8).range(1..=14))]
        len: u8,
    },
    /// Show what the AS-i link uses: the simulated double slave and its addresses and
    /// profiles, the AS-i network's size, the AS-i cycle and CTT2 byte time it models (BU 0255
    /// 4.4), the answer window and repetitions, and the channels.
    #[command(
        after_help = "Examples:\n  drivectl ctt2 --sim line\n  drivectl ctt2 --sim --slaves 31 --asi-address 5A line --json"
    )]
    Line,
    /// Read the diagnosis object (standard read, index 1): fault or not, the drive's fault
    /// number and the microcontroller temperature.
    #[command(
        after_help = "Examples:\n  drivectl ctt2 --sim diag\n  drivectl ctt2 --sim --slaves 31 diag --json"
    )]
    Diag,
}

/// The examples of the commands `uss` and `ctt2` share are written for `drivectl uss --port
/// /dev/ttyUSB0 --addr 1`; below `drivectl ctt2 <command> --help` they read `drivectl ctt2
/// --sim`.
pub fn with_help(cmd: clap::Command) -> clap::Command {
    // `mut_subcommands` keeps the order of the commands in `--help`.
    cmd.mut_subcommands(|c| {
        if c.get_name() != "ctt2" {
            return c;
        }
        c.mut_subcommands(|sub| match sub.get_after_help().map(ToString::to_string) {
            Some(h) => sub.after_help(h.replace(USS_PREFIX, "drivectl ctt2 --sim")),
            None => sub,
        })
    })
}

/// How the shared examples call `drivectl uss`.
const USS_PREFIX: &str = "drivectl uss --port /dev/ttyUSB0 --addr 1";

/// `--pkw-index`: 47 or 4.
fn pkw_index(s: &str) -> std::result::Result<u8, String> {
    match s.trim() {
        "47" => Ok(47),
        "4" => Ok(4),
        _ => Err("the PKW channel is index 47 (without address) or 4 (with address)".to_owned()),
    }
}

/// The double slave's address of `--asi-address` (bank A; its 2nd slave in bank B).
fn double_slave_address(text: &str) -> Result<DoubleSlaveAddress> {
    let bad = || {
        CliError::usage(format!(
            "--asi-address {text}: give the 1st slave's extended address, 1A…31A (the 2nd slave \
             takes the same number in bank B)"
        ))
    };
    let first: AsiAddress = text.trim().parse().map_err(|_| bad())?;
    if first.bank() != Bank::A {
        return Err(bad());
    }
    let second = AsiAddress::new(first.number(), Bank::B).ok_or_else(bad)?;
    DoubleSlaveAddress::new(first, second).ok_or_else(bad)
}

/// The simulated network: the double slave at `address` and `slaves − 2` other extended slaves
/// at the lowest free addresses.
fn network(address: DoubleSlaveAddress, slaves: u8) -> Result<SimulatedLink> {
    let failed = |e: ctt2_uss::ctt2::NetworkError| CliError::usage(format!("AS-i network: {e}"));
    let mut net = AsiNetwork::new();
    let id = net.add_double_slave(address).map_err(failed)?;
    let mut others = slaves.saturating_sub(2);
    'fill: for n in 1..=31 {
        if n == address.first.number() {
            continue;
        }
        for bank in [Bank::A, Bank::B] {
            if others == 0 {
                break 'fill;
            }
            let a = AsiAddress::new(n, bank).ok_or_else(|| CliError::failed("AS-i address"))?;
            net.add_slave(SlaveAddress::Extended(a)).map_err(failed)?;
            others -= 1;
        }
    }
    if others > 0 {
        return Err(CliError::usage(format!(
            "--slaves {slaves}: the AS-i network holds at most 62 slaves"
        )));
    }
    Ok(SimulatedLink::on_network(
        SimulatedDoubleSlave::default(),
        net,
        id,
    ))
}

/// The command line that reaches the same simulation again (for notes).
fn again(args: &Ctt2Args) -> String {
    let mut s = "drivectl ctt2 --sim".to_owned();
    if args.slaves != 2 {
        s.push_str(&format!(" --slaves {}", args.slaves));
    }
    if args.asi_address.trim() != "1A" {
        s.push_str(&format!(" --asi-address {}", args.asi_address.trim()));
    }
    s
}

/// Run `drivectl ctt2`.
pub fn run(args: &Ctt2Args) -> Result<()> {
    if !args.sim {
        return Err(CliError::usage(
            "drivectl reaches CTT2 only through its simulated AS-i link: add --sim; a real AS-i \
             master needs its own ctt2_uss::ctt2::master::Ctt2Link",
        ));
    }
    let address = double_slave_address(&args.asi_address)?;
    if let Ctt2Command::Nord(cmd) = &args.command {
        precheck(cmd)?;
    }
    let session = async {
        // On the session's clock: its figures do not depend on the real time before it.
        let link = network(address, args.slaves)?;
        let byte_time = link.byte_time();
        let config = DriverConfig {
            pkw_channel: if args.pkw_index == 4 {
                Channel::PkwWithAddress
            } else {
                Channel::Pkw
            },
            ..DriverConfig::default()
        };
        let mut master = Ctt2Driver::new(link, config);
        let started = drive_core::rt::time::now();
        let r = match &args.command {
            Ctt2Command::Nord(cmd) => {
                let identity = if matches!(
                    cmd,
                    NordCommand::Backup { .. } | NordCommand::Restore { .. }
                ) {
                    let id = master
                        .read_id_object()
                        .await
                        .map_err(|e| CliError::failed(e.to_string()))?;
                    identity(&address, &id)
                } else {
                    let mut m = Map::new();
                    m.insert("asi_address".into(), address.first.to_string().into());
                    m
                };
                let session = Session {
                    json: args.json,
                    key: format!("ctt2-sim {}", address.first),
                    again: again(args),
                    identity,
                    simulated: true,
                    actuals: 3,
                };
                let mut client = NordClient::new(master, ClientConfig::default());
                let r = execute(&mut client, &session, cmd).await;
                master = client.into_inner();
                r
            }
            Ctt2Command::Line => line(&master, args, &address),
            Ctt2Command::Id { len } => match master.read_id(*len).await {
                Ok(id) => print_id(&id, *len, args.json),
                Err(e) => Err(CliError::failed(e.to_string())),
            },
            Ctt2Command::Diag => match master.read_diagnosis().await {
                Ok(d) => {
                    if args.json {
                        outln!(
                            "{}",
                            json!({"code": d.code.map(|c| c.byte()), "fault": d.code.map(|c| c.byte() != 0),
                                   "fault_number": d.fault, "temperature_c": d.temperature,
                                   "text": d.to_string()})
                        )
                    } else {
                        outln!("diagnosis object: {d}")
                    }
                }
                Err(e) => Err(CliError::failed(e.to_string())),
            },
        };
        let counters = *master.counters();
        if !args.json && r.is_ok() && counters.requests > 0 {
            errln!(
                "drivectl: note: {} CTT2 request(s) ({} repeated after error 4/5) on {} AS-i \
                 slave(s), {} ms per byte: {} ms{}",
                counters.requests,
                counters.retries,
                args.slaves,
                trim_float(byte_time.as_secs_f64() * 1e3, 3),
                trim_float(
                    drive_core::rt::time::now()
                        .saturating_duration_since(started)
                        .as_secs_f64()
                        * 1e3,
                    1
                ),
                if args.fast { " (virtual time)" } else { "" }
            );
        }
        r
    };
    if args.fast {
        crate::tool::line::run_virtual(session)?
    } else {
        runtime()?.block_on(session)
    }
}

/// `line`: what the link uses (nothing is sent).
fn line(
    master: &Ctt2Driver<SimulatedLink>,
    args: &Ctt2Args,
    address: &DoubleSlaveAddress,
) -> Result<()> {
    let config = master.config();
    let link = master.link();
    let byte_us = link.byte_time().as_nanos() as f64 / 1000.0;
    // BU 0255 4.4: a CTT2 byte takes 16 AS-i cycles of 154 µs × (2 + slaves).
    let cycle_us = byte_us / 16.0;
    let pkw_index = match config.pkw_channel {
        Channel::PkwWithAddress => 4,
        _ => 47,
    };
    let window_ms = ctt2_uss::ctt2::slave::ANSWER_WINDOW.as_millis() as u64;
    if args.json {
        return outln!(
            "{}",
            json!({
                "link": "simulated", "clock": if args.fast { "virtual" } else { "real" },
                "asi_address": address.first.to_string(),
                "second_slave": address.second.to_string(),
                "profiles": [Profile::FIRST.to_string(), Profile::SECOND.to_string()],
                "busio_in_bits": 5, "busio_out_bits": 6,
                "slaves": link.network().slave_count(),
                "asi_cycle_us": cycle_us, "byte_time_us": byte_us,
                "answer_window_ms": window_ms, "retries": config.retries,
                // The key every family's `line --json` has: how long an answer is waited for.
                "response_timeout_ms": window_ms,
                "retry_pause_ms": config.retry_pause.as_millis() as u64,
                "pkw_index": pkw_index, "pzd_index": 3, "drive_address": 1, "address": 1,
                "pkw_time_ms": ctt2_uss::ctt2::link::SIM_PKW_TIME.as_millis() as u64,
            })
        );
    }
    outln!(
        "simulated AS-i link (in memory, {}): a NORDAC LINK double slave {} ({}, 4 BusIO bits \
         each way) + {} ({}, BusIO 1 in / 2 out, the CTT2 channel) among {} AS-i slave(s)",
        if args.fast {
            "transfer times counted on a virtual clock"
        } else {
            "transfer times waited in real time"
        },
        address.first,
        Profile::FIRST,
        address.second,
        Profile::SECOND,
        link.network().slave_count()
    )?;
    outln!(
        "AS-i cycle {} µs (154 µs × (2 + {} slaves)); a CTT2 byte takes 16 cycles: {} ms \
         (BU 0255 4.4)",
        trim_float(cycle_us, 1),
        link.network().slave_count(),
        trim_float(byte_us / 1000.0, 3)
    )?;
    outln!(
        "answers within the {window_ms} ms window or error 4 (4.3.5); errors 4 and 5 repeated \
         {} times after {} ms; PKW channel index {pkw_index} ({}), PZD channel index 3, drive \
         address 1; the simulated drive works {} ms on a parameter order",
        config.retries,
        config.retry_pause.as_millis(),
        if pkw_index == 4 {
            "with the drive address"
        } else {
            "without the drive address"
        },
        ctt2_uss::ctt2::link::SIM_PKW_TIME.as_millis()
    )
}

/// A backup's identification from the ID object.
fn identity(address: &DoubleSlaveAddress, id: &IdObject) -> Map<String, Value> {
    let mut m = Map::new();
    m.insert("asi_address".into(), address.first.to_string().into());
    m.insert(
        "device_type".into(),
        id.device_id
            .map_or(Value::Null, |d| format!("0x{d:04X}").into()),
    );
    m.insert(
        "firmware".into(),
        match (id.firmware_version, id.firmware_revision) {
            (Some(v), Some(r)) => format!("{v}.{r}").into(),
            _ => Value::Null,
        },
    );
    m
}

/// `id`: every field read, named.
fn print_id(id: &IdObject, len: u8, json: bool) -> Result<()> {
    let hex16 = |v: Option<u16>| v.map(|x| format!("0x{x:04X}"));
    if json {
        return outln!(
            "{}",
            json!({
                "bytes": len,
                "manufacturer_id": id.manufacturer_id, "device_id": id.device_id,
                "io_config": id.io_config, "asi_mode": id.asi_mode,
                "asi_firmware": id.asi_firmware, "firmware_version": id.firmware_version,
                "firmware_revision": id.firmware_revision, "power": id.power,
                "voltage_range": id.voltage_range,
                "configuration_level": id.configuration_level,
                "manufacturer_hex": hex16(id.manufacturer_id), "device_hex": hex16(id.device_id),
            })
        );
    }
    let b = |v: Option<u8>| v.map_or_else(|| "not read".to_owned(), |x| format!("{x} (0x{x:02X})"));
    let w =
        |v: Option<u16>| v.map_or_else(|| "not read".to_owned(), |x| format!("{x} (0x{x:04X})"));
    outln!("ID object ({len} of 14 bytes):")?;
    outln!(
        "  bytes 1-2   manufacturer ID            {}",
        w(id.manufacturer_id)
    )?;
    outln!(
        "  bytes 3-4   device ID                  {}",
        w(id.device_id)
    )?;
    outln!(
        "  byte 5      I/O configuration          {}",
        b(id.io_config)
    )?;
    outln!(
        "  byte 6      AS-i mode                  {}",
        b(id.asi_mode)
    )?;
    outln!(
        "  byte 7      AS-i interface firmware    {}",
        b(id.asi_firmware)
    )?;
    outln!(
        "  byte 8      drive firmware version     {}",
        b(id.firmware_version)
    )?;
    outln!(
        "  byte 9      drive firmware revision    {}",
        b(id.firmware_revision)
    )?;
    outln!("  bytes 10-11 power                      {}", w(id.power))?;
    outln!(
        "  byte 12     voltage range              {}",
        b(id.voltage_range)
    )?;
    outln!(
        "  bytes 13-14 configuration level        {}",
        w(id.configuration_level)
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    /// The time one CTT2 transfer of `bytes` bytes takes on a network of `slaves` slaves.
    fn transfer(slaves: u8, bytes: u32) -> Duration {
        Duration::from_micros(u64::from(drive_profile::nord::ctt2_byte_time_us(slaves))) * bytes
    }

    #[test]
    fn the_double_slave_address_is_bank_a_and_its_twin_in_bank_b() {
        let a = double_slave_address("5A").unwrap();
        assert_eq!(
            (a.first.to_string(), a.second.to_string()),
            ("5A".into(), "5B".into())
        );
        for bad in ["5B", "0A", "32A", "5", "A5", ""] {
            assert!(double_slave_address(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn the_network_has_the_slaves_asked_for_around_the_double_slave() {
        let link = network(double_slave_address("2A").unwrap(), 31).unwrap();
        assert_eq!(link.network().slave_count(), 31);
        // Section 4.4: 31 slaves, 81.31 ms per byte.
        assert_eq!(link.byte_time(), transfer(31, 1));
        assert_eq!(link.byte_time(), Duration::from_micros(81_312));
        assert!(network(double_slave_address("1A").unwrap(), 63).is_err());
        assert_eq!(
            network(double_slave_address("31A").unwrap(), 62)
                .unwrap()
                .network()
                .slave_count(),
            62
        );
    }
}
