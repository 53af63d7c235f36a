//! `drivectl movilink …`: talk to a MOVIDRIVE over MOVILINK (RS-485 / RS-232).
//!
//! Every command opens the port with the given settings, runs the async master driver of the
//! `movilink` crate and prints one result per line (`--json`: one JSON object per line).

pub mod backup;
pub mod decode;
pub mod sim;
mod wear;

use crate::error::{CliError, Result};
use crate::params::{label, physical_text, trim_float};
use clap::{Args, Subcommand};
use drive_profile::{Access, ParamMeta, sew};
use drive_transport::serial::{self, LineSettings, Parity, SerialConfig, StopBits};
use movilink::driver::{CharIo, DriverConfig, DriverError, MasterDriver, Stream};
use movilink::guard::WriteGuard;
use movilink::{Address, ParamChannel, PduType, Telegram};
use serde_json::json;
use std::path::PathBuf;
use std::time::Duration;

/// Serial line settings shared by the MOVILINK commands and `drivectl sim movilink`.
#[derive(Debug, Args, Clone)]
pub struct LineArgs {
    /// Baud rate (MOVILINK: 9600).
    #[arg(long, default_value_t = 9600)]
    pub baud: u32,
    /// Parity: even (MOVILINK), odd or none (pseudo-terminals only accept none).
    #[arg(long, default_value = "even")]
    pub parity: Parity,
    /// Stop bits: 1 or 2.
    #[arg(long, default_value = "1")]
    pub stop_bits: StopBits,
}

impl LineArgs {
    /// The line settings (8 data bits).
    pub fn line(&self) -> LineSettings {
        LineSettings::new(self.baud)
            .with_parity(self.parity)
            .with_stop_bits(self.stop_bits)
    }

    /// The serial configuration for `path`.
    pub fn config(&self, path: &str) -> SerialConfig {
        SerialConfig::with_line(path, self.line())
    }
}

/// Arguments of `drivectl movilink`.
#[derive(Debug, Args)]
pub struct MovilinkArgs {
    /// Serial port, e.g. /dev/ttyUSB0 (or the pty printed by `drivectl sim movilink --pty`).
    #[arg(long)]
    port: String,
    #[command(flatten)]
    line: LineArgs,
    /// Drive address: 0–99 single drive, 254 point-to-point.
    #[arg(long, default_value_t = 0)]
    addr: u8,
    /// Response timeout in milliseconds (the manual allows at most 50).
    #[arg(long, default_value_t = 50)]
    timeout: u64,
    /// Retries after a timeout or a corrupt answer.
    #[arg(long, default_value_t = 2)]
    retries: u8,
    /// Longest gap in ms accepted between the characters of an answer. USB serial adapters
    /// hand characters over in bursts (FTDI: every 16 ms); 0 applies the manual's rule
    /// (less than the 3.44 ms start pause). BCC, length and parity checks always apply.
    #[arg(long, default_value_t = 20)]
    char_gap: u64,
    /// One JSON object per result.
    #[arg(long, global = true)]
    json: bool,
    #[command(subcommand)]
    command: MovilinkCommand,
}

#[derive(Debug, Subcommand)]
enum MovilinkCommand {
    /// Read a parameter: value with unit and scaling, and the raw value.
    Read {
        /// Index (8318, 0x207E) or menu number (P000).
        param: String,
    },
    /// Write a parameter (checked against the table first).
    Write {
        /// Index or menu number.
        param: String,
        /// Value in the parameter's unit (or raw with --raw).
        #[arg(allow_hyphen_values = true)]
        value: String,
        /// VALUE is the raw bus value.
        #[arg(long)]
        raw: bool,
        /// Write to RAM only (the service for frequent writes; lost at power-off).
        #[arg(long)]
        volatile: bool,
        /// Skip the access/range/EEPROM-wear checks of the table.
        #[arg(long)]
        force: bool,
    },
    /// Minimum, maximum, default, scale and attributes of a parameter.
    Info {
        /// Index or menu number.
        param: String,
    },
    /// Find responding drives with their device type (8301) and firmware (8300).
    Scan {
        /// First address.
        #[arg(long, default_value_t = 0)]
        from: u8,
        /// Last address.
        #[arg(long, default_value_t = 99)]
        to: u8,
    },
    /// Exchange process data and decode the status.
    Pd {
        /// PDU type, e.g. 0x85 (3PD acyclic) or 0x05 (3PD cyclic).
        #[arg(long = "type", default_value = "0x85")]
        pdu_type: String,
        /// Output words, e.g. 0x0006,5000,0.
        #[arg(
            long,
            value_delimiter = ',',
            required = true,
            allow_hyphen_values = true
        )]
        out: Vec<String>,
        /// Number of exchanges.
        #[arg(long, default_value_t = 1)]
        count: u32,
        /// Milliseconds between exchanges.
        #[arg(long, default_value_t = 100)]
        interval: u64,
    },
    /// Save all readable parameters to a JSON file.
    Backup {
        /// Output file.
        #[arg(long)]
        out: PathBuf,
    },
    /// Write a backup file back to the drive and verify every value.
    Restore {
        /// Backup file written by `backup`.
        file: PathBuf,
        /// Write even values the table check refuses.
        #[arg(long)]
        force: bool,
    },
}

/// Parse an integer given as decimal, `0x` hex or negative decimal.
pub fn parse_int(s: &str) -> Option<i64> {
    let t = s.trim();
    let (neg, body) = t.strip_prefix('-').map_or((false, t), |b| (true, b));
    let v = match body.strip_prefix("0x").or_else(|| body.strip_prefix("0X")) {
        Some(h) => i64::from_str_radix(h, 16).ok()?,
        None => body.parse::<i64>().ok()?,
    };
    Some(if neg { -v } else { v })
}

/// A parameter as named on the command line: the table row if known, and the index.
#[derive(Debug, Clone, Copy)]
pub struct Target {
    /// Bus index.
    pub index: u16,
    /// The table row, when the index is in the MOVIDRIVE table.
    pub param: Option<&'static sew::Param>,
}

/// Resolve `P813`, `813`, `8600`, `0x2198`; indices outside the table are allowed (raw access).
pub fn resolve(key: &str) -> Result<Target> {
    if let Some(p) = sew::lookup(key) {
        return Ok(Target {
            index: p.bus_index(),
            param: Some(p),
        });
    }
    let t = key.trim();
    let numeric = t.strip_prefix(['P', 'p']).is_none();
    match parse_int(t) {
        Some(v) if numeric && (1000..=0xFFFF).contains(&v) => Ok(Target {
            index: v as u16,
            param: None,
        }),
        _ => Err(CliError::usage(format!(
            "no MOVIDRIVE parameter `{key}`; give a menu number (P813) or an index (8600); \
             `drivectl params movidrive --search NAME` finds it"
        ))),
    }
}

fn address(a: u8) -> Result<Address> {
    Address::new(a)
        .filter(|a| a.expects_response())
        .ok_or_else(|| {
            CliError::usage(format!(
                "address {a} cannot be asked for an answer; use 0–99 or 254 (point-to-point)"
            ))
        })
}

/// An address for a write: a single drive, 254, a group (101–199) or broadcast (255).
fn any_address(a: u8) -> Result<Address> {
    match Address::new(a) {
        Some(addr) if a != 100 && a != 253 => Ok(addr),
        _ => Err(CliError::usage(format!(
            "address {a} cannot be written to; use 0–99, 254, a group 101–199 or 255 (broadcast)"
        ))),
    }
}

/// Turn a driver error into a one-line CLI error.
pub fn driver_error(e: DriverError) -> CliError {
    CliError::failed(e.to_string())
}

/// A tokio runtime for one command.
pub fn runtime() -> Result<tokio::runtime::Runtime> {
    tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .map_err(|e| CliError::failed(format!("cannot start the async runtime: {e}")))
}

/// Run `drivectl movilink`.
pub fn run(args: &MovilinkArgs) -> Result<()> {
    let rt = runtime()?;
    rt.block_on(async {
        let port = serial::open(&args.line.config(&args.port))
            .map_err(|e| CliError::failed(e.to_string()))?;
        let config = DriverConfig {
            line: args.line.line(),
            response_timeout: Duration::from_millis(args.timeout),
            retries: args.retries,
            max_char_gap: (args.char_gap > 0).then(|| Duration::from_millis(args.char_gap)),
            ..DriverConfig::default()
        };
        let mut master = MasterDriver::new(Stream(port), config);
        execute(&mut master, args).await
    })
}

async fn execute<IO: CharIo>(m: &mut MasterDriver<IO>, args: &MovilinkArgs) -> Result<()> {
    let json = args.json;
    match &args.command {
        MovilinkCommand::Read { param } => {
            let t = resolve(param)?;
            let raw = m
                .read(address(args.addr)?, t.index)
                .await
                .map_err(driver_error)?;
            print_value(t, raw, json);
            Ok(())
        }
        MovilinkCommand::Write {
            param,
            value,
            raw,
            volatile,
            force,
        } => {
            let t = resolve(param)?;
            let raw_value = to_raw(t, value, *raw)?;
            let addr = any_address(args.addr)?;
            if !force {
                let mut guard = WriteGuard::new();
                wear::prime(&mut guard, &args.port, addr.get(), t.index);
                guard
                    .check(t.index, raw_value, *volatile, std::time::Instant::now())
                    .map_err(|e| CliError::usage(format!("{e}")))?;
            }
            let word = raw_value as i32 as u32;
            if !addr.expects_response() {
                // Group (101–199) or broadcast (255): every drive addressed executes the
                // write, none answers, so there is nothing to read back.
                let channel = if *volatile {
                    ParamChannel::write_volatile(t.index, word)
                } else {
                    ParamChannel::write(t.index, word)
                };
                let request =
                    Telegram::request(addr, PduType::PARAM_0PD_ACYCLIC).with_param(channel);
                m.send_unanswered(request).await.map_err(driver_error)?;
                // Keep the line idle for the broadcast spacing before this process lets go of
                // the port, so the next telegram (perhaps from the next drivectl run) cannot
                // follow sooner than the 25 ms the drives need.
                tokio::time::sleep(movilink::timing::BROADCAST_SPACING).await;
                if !volatile {
                    wear::record(&args.port, addr.get(), t.index);
                }
                if json {
                    println!(
                        "{}",
                        json!({"index": t.index, "raw": raw_value, "address": addr.get(), "answered": false})
                    );
                } else {
                    println!(
                        "sent index {} = raw {raw_value} to {} {} (never answered by design)",
                        t.index,
                        if addr.is_broadcast() {
                            "broadcast"
                        } else {
                            "group"
                        },
                        addr.get()
                    );
                }
                return Ok(());
            }
            if *volatile {
                m.write_volatile(addr, t.index, word).await
            } else {
                m.write(addr, t.index, word).await
            }
            .map_err(driver_error)?;
            if !volatile {
                wear::record(&args.port, addr.get(), t.index);
            }
            let back = m.read(addr, t.index).await.map_err(driver_error)?;
            print_value(t, back, json);
            Ok(())
        }
        MovilinkCommand::Info { param } => {
            info(m, address(args.addr)?, resolve(param)?, json).await
        }
        MovilinkCommand::Scan { from, to } => scan(m, *from, *to, args.timeout, json).await,
        MovilinkCommand::Pd {
            pdu_type,
            out,
            count,
            interval,
        } => {
            pd(
                m,
                address(args.addr)?,
                pdu_type,
                out,
                *count,
                *interval,
                json,
            )
            .await
        }
        MovilinkCommand::Backup { out } => backup::backup(m, address(args.addr)?, out, json).await,
        MovilinkCommand::Restore { file, force } => {
            backup::restore(m, address(args.addr)?, file, *force, json).await
        }
    }
}

/// The raw value of `value` for `t` (physical unless `raw`).
fn to_raw(t: Target, value: &str, raw: bool) -> Result<i64> {
    if raw || t.param.is_none() {
        return parse_int(value)
            .ok_or_else(|| CliError::usage(format!("`{value}` is not an integer raw value")));
    }
    let p = t
        .param
        .ok_or_else(|| CliError::usage("unknown parameter"))?;
    if let Some(v) = p
        .values()
        .iter()
        .find(|v| v.de.eq_ignore_ascii_case(value) || v.en.eq_ignore_ascii_case(value))
    {
        return Ok(v.value);
    }
    let x: f64 = value.trim().parse().map_err(|_| {
        CliError::usage(format!(
            "`{value}` is not a number in {}; give the value in the parameter's unit, or --raw",
            if p.unit().is_empty() {
                "the parameter's unit"
            } else {
                p.unit()
            }
        ))
    })?;
    p.from_physical(x).map_err(|e| {
        CliError::usage(format!(
            "{} {}: {e}; --raw --force sends a raw value unchecked",
            label(p),
            p.name_en()
        ))
    })
}

/// Print one read result.
pub fn print_value(t: Target, raw: u32, json: bool) {
    let signed = i64::from(raw as i32);
    match (t.param, json) {
        (Some(p), true) => println!(
            "{}",
            json!({
                "index": t.index, "number": label(p), "name_de": p.name_de(), "name_en": p.name_en(),
                "raw": signed, "value": p.to_physical(signed), "unit": p.unit(),
                "meaning": p.value_name(signed).map(|v| v.en),
            })
        ),
        (Some(p), false) => println!(
            "{} {} (index {}): {} (raw {signed})",
            label(p),
            p.name_en(),
            t.index,
            physical_text(p, signed)
        ),
        (None, true) => println!(
            "{}",
            json!({"index": t.index, "raw": signed, "value": signed, "unit": ""})
        ),
        (None, false) => println!("index {}: raw {signed} (0x{raw:08X})", t.index),
    }
}

async fn info<IO: CharIo>(
    m: &mut MasterDriver<IO>,
    addr: Address,
    t: Target,
    json: bool,
) -> Result<()> {
    let min = m.read_minimum(addr, t.index).await.map_err(driver_error)?;
    let max = m.read_maximum(addr, t.index).await.map_err(driver_error)?;
    let default = m.read_default(addr, t.index).await.map_err(driver_error)?;
    let scale = m.read_scale(addr, t.index).await.map_err(driver_error)?;
    let attr = m
        .read_attribute(addr, t.index)
        .await
        .map_err(driver_error)?;
    let access = Access::from_bits_truncate(attr.attributes as u8);
    let show = |raw: u32| {
        let v = i64::from(raw as i32);
        t.param
            .map_or_else(|| v.to_string(), |p| physical_text(p, v))
    };
    let size_name = sew::size_name(scale.size_index).unwrap_or("unknown quantity");
    if json {
        println!(
            "{}",
            json!({
                "index": t.index,
                "number": t.param.map(|p| label(p)),
                "name_en": t.param.map(|p| p.name_en()),
                "min": min as i32, "max": max as i32, "default": default as i32,
                "size_index": scale.size_index, "conversion_index": scale.conversion_index,
                "quantity": size_name,
                "next_index": attr.next_index, "attributes": attr.attributes, "access": access.to_string(),
            })
        );
    } else {
        let name = t
            .param
            .map_or_else(String::new, |p| format!("{} {} ", label(p), p.name_en()));
        println!("{name}(index {})", t.index);
        println!("  minimum    {}", show(min));
        println!("  maximum    {}", show(max));
        println!("  default    {}", show(default));
        println!(
            "  scale      size index {} ({size_name}), conversion index {}",
            scale.size_index, scale.conversion_index
        );
        println!(
            "  attributes 0x{:04X} ({access}), next index {}",
            attr.attributes, attr.next_index
        );
    }
    Ok(())
}

async fn scan<IO: CharIo>(
    m: &mut MasterDriver<IO>,
    from: u8,
    to: u8,
    timeout_ms: u64,
    json: bool,
) -> Result<()> {
    if from > to || to > 99 {
        return Err(CliError::usage(
            "scan range must satisfy 0 ≤ --from ≤ --to ≤ 99",
        ));
    }
    let bar = indicatif::ProgressBar::new(u64::from(to - from) + 1);
    bar.set_style(
        indicatif::ProgressStyle::with_template("scanning {pos}/{len} {bar:30} {msg}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let mut found = 0;
    for a in from..=to {
        bar.set_message(format!("address {a}"));
        let addr = address(a)?;
        let probe = m
            .probe(addr, Duration::from_millis(timeout_ms))
            .await
            .map_err(driver_error)?;
        bar.inc(1);
        let Some(device_type) = probe else { continue };
        let firmware = m.read(addr, 8300).await.map_err(driver_error)?;
        found += 1;
        bar.suspend(|| {
            if json {
                println!(
                    "{}",
                    json!({"address": a, "device_type": device_type, "firmware": firmware})
                );
            } else {
                println!(
                    "address {a:>2}: device type {device_type}, firmware {}",
                    firmware_text(firmware)
                );
            }
        });
    }
    bar.finish_and_clear();
    if !json {
        println!("{found} drive(s) answered between {from} and {to}");
    }
    Ok(())
}

/// SEW firmware numbers read like 822609711 = part 822 609, version 7.11.
pub fn firmware_text(v: u32) -> String {
    let s = v.to_string();
    if s.len() == 9 {
        format!("{} {} {}.{}", &s[0..3], &s[3..6], &s[6..7], &s[7..9])
    } else {
        s
    }
}

async fn pd<IO: CharIo>(
    m: &mut MasterDriver<IO>,
    addr: Address,
    pdu_type: &str,
    out: &[String],
    count: u32,
    interval: u64,
    json: bool,
) -> Result<()> {
    let pdu = parse_int(pdu_type)
        .and_then(|v| u8::try_from(v).ok())
        .and_then(PduType::new)
        .ok_or_else(|| {
            CliError::usage(format!(
                "`{pdu_type}` is not a MOVILINK PDU type (0x00–0x06, 0x80–0x86)"
            ))
        })?;
    if pdu.pd_words() == 0 {
        return Err(CliError::usage(
            "this PDU type carries no process data; use 0x81–0x85 or 0x01–0x05",
        ));
    }
    let mut words = Vec::new();
    for w in out {
        let v = parse_int(w)
            .filter(|v| (-32768..=65535).contains(v))
            .ok_or_else(|| CliError::usage(format!("`{w}` is not a 16-bit word")))?;
        words.push(v as u16);
    }
    if words.len() != pdu.pd_words() {
        return Err(CliError::usage(format!(
            "PDU type 0x{:02X} carries {} process data words, --out gave {}",
            pdu.raw(),
            pdu.pd_words(),
            words.len()
        )));
    }
    // Cyclic types run as a cyclic session (one telegram every --interval, which keeps the
    // drive's RS-485 timeout P812 fed); acyclic ones are single exchanges --interval apart.
    let period = Duration::from_millis(interval.max(1));
    if pdu.is_cyclic() {
        let mut session = m.cyclic(addr, pdu, period).map_err(driver_error)?;
        session.set_output(&words);
        for _ in 0..count {
            let response = session.cycle().await.map_err(driver_error)?;
            print_pd(addr, pdu, &words, response.process_data(), json);
        }
    } else {
        for i in 0..count {
            if i > 0 {
                tokio::time::sleep(period).await;
            }
            let request = Telegram::request(addr, pdu).with_process_data(&words);
            let response = m.exchange(request).await.map_err(driver_error)?;
            print_pd(addr, pdu, &words, response.process_data(), json);
        }
    }
    Ok(())
}

fn print_pd(addr: Address, pdu: PduType, out: &[u16], pi: &[u16], json: bool) {
    if json {
        println!(
            "{}",
            json!({"address": addr.get(), "type": pdu.raw(), "out": out, "in": pi,
                   "status": pi.first().map(|s| decode::status_summary(*s))})
        );
    } else {
        let words_text: Vec<String> = pi.iter().map(|w| format!("0x{w:04X}")).collect();
        let status = pi
            .first()
            .map_or_else(String::new, |s| decode::status_summary(*s));
        let speed = pi.get(1).map_or_else(String::new, |w| {
            format!(", speed {} 1/min", trim_float(sew::speed_from_word(*w), 1))
        });
        println!("PI {}: {status}{speed}", words_text.join(" "));
    }
}
