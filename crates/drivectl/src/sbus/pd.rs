//! `drivectl sbus pd` and `drivectl sbus sync`: process data (three words, ch. 5.1) and the
//! SYNC producer.

use std::time::Duration;

use clap::Args;
use drive_client::control::sew::{
    IntervalError, PdStop, SbusTo, sbus_pd, sbus_preflight, sbus_stop, sync_interval, sync_producer,
};
use drive_core::rt::CanIo;
use drive_profile::sew::{self, ControlWord1, StatusWord1};
use sbus_can::driver::SbusDriver;
use sbus_can::ids::Address;
use serde_json::json;

use crate::error::{CliError, Result};
use crate::tool::again::Again;
use crate::tool::client::parse_int;
use crate::tool::front::Cli;
use crate::tool::interrupt::Interrupt;
use crate::tool::motor::{Motion, MotorGuard, Stopped};
use crate::tool::output::trim_float;

/// Arguments of `drivectl sbus pd`.
#[derive(Debug, Args)]
pub struct PdArgs {
    /// The three process output words PO1,PO2,PO3 (SBus always carries three), e.g.
    /// 0x0006,5000,0; each −32768…65535.
    #[arg(
        long,
        value_delimiter = ',',
        required = true,
        allow_hyphen_values = true
    )]
    out: Vec<String>,
    /// Number of exchanges; 0 runs until Ctrl-C.
    #[arg(long, default_value_t = 1)]
    count: u32,
    /// Milliseconds between exchanges, 1–60000 (with --sync: rounded up to whole 5 ms
    /// cycles). By default half the drive's SBus timeout P815 (read first), at most 100 ms, and
    /// with --sync one 5 ms cycle; an interval at or above P815 is refused (the drive would
    /// trip with F47 SBus timeout between two exchanges).
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..=60_000))]
    interval: Option<u64>,
    /// Synchronous process data: the PO sync telegram (8a+5), taken by the drive at the next
    /// SYNC, which drivectl sends; the PI comes in the first millisecond after it.
    #[arg(long, conflicts_with = "group")]
    sync: bool,
    /// Send the words to every drive of this SBus group (P814) as group process data (8g+6):
    /// no drive answers.
    #[arg(long, value_parser = clap::value_parser!(u8).range(0..=63))]
    group: Option<u8>,
    /// Leave the drive as the last exchange left it. Without it, `pd` ends (after --count, on
    /// Ctrl-C, SIGTERM, SIGHUP or SIGQUIT, on an error or a closed output pipe) by sending the
    /// control word slot the --stop command.
    #[arg(long)]
    keep_running: bool,
    /// How `pd` stops the drive at its end: `ramp` (control word 0x0002) or `inhibit`
    /// (0x0001: controller inhibit, the motor coasts).
    #[arg(long, default_value = "ramp", value_parser = ["ramp", "inhibit"])]
    stop: String,
}

impl PdArgs {
    /// The three words, checked: each −32768…65535 (a negative word is its two's complement).
    pub fn check(&self) -> Result<[u16; 3]> {
        if self.out.len() != 3 {
            return Err(CliError::usage(format!(
                "--out gave {} word(s): SBus process data are always three words (PO1,PO2,PO3)",
                self.out.len()
            )));
        }
        let mut words = [0u16; 3];
        for (w, text) in words.iter_mut().zip(&self.out) {
            let v = parse_int(text)
                .filter(|v| (-32768..=65535).contains(v))
                .ok_or_else(|| {
                    CliError::usage(format!(
                        "--out `{text}` is not a 16-bit word (−32768…65535, or 0x0000…0xFFFF)"
                    ))
                })?;
            *w = v as u16;
        }
        Ok(words)
    }
}

/// Arguments of `drivectl sbus sync`.
#[derive(Debug, Args)]
pub struct SyncArgs {
    /// Milliseconds between two SYNC telegrams, 1–60000 (SBus's cycle is 5 ms).
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u64).range(1..=60_000))]
    period: u64,
    /// Number of SYNC telegrams; 0 sends until Ctrl-C.
    #[arg(long, default_value_t = 0)]
    count: u32,
}

/// Run `pd`; `again` is the command line that reaches the drive again (for the hint that
/// says how to stop it).
pub async fn pd<C: CanIo>(
    m: &mut SbusDriver<C>,
    addr: Address,
    args: &PdArgs,
    json: bool,
    again: &Again,
) -> Result<()> {
    let words = args.check()?;
    let end = match (args.keep_running, args.stop.as_str()) {
        (true, _) => None,
        (false, "inhibit") => Some(ControlWord1::INHIBIT),
        (false, _) => Some(ControlWord1::STOP),
    };
    let group = args
        .group
        .map(|g| Address::new(g).ok_or_else(|| CliError::usage(format!("--group {g}: 0…63"))))
        .transpose()?;
    let to = SbusTo {
        address: addr,
        group,
        sync: args.sync,
    };
    if group.is_some() && end.is_some() {
        errln!(
            "drivectl: note: a group does not answer; the stop at the end goes to PO1, the \
             factory setting's control word (P870)"
        );
    }
    let pre = sbus_preflight(m, to, end.is_some(), &Cli).await;
    for w in &pre.warnings {
        errln!("drivectl: warning: {w}");
    }
    let (slots, timeout) = (pre.slots, pre.timeout);
    let (default, grain) = if args.sync { (5, 5) } else { (100, 1) };
    let mut period = crate::sew::pd_interval(
        args.interval,
        timeout,
        default,
        grain,
        "SBus timeout P815",
        "F47 SBus timeout",
    )?;
    if args.sync {
        period = sync_interval(period, timeout).map_err(|e| match e {
            IntervalError::SyncNotShorter {
                rounded_ms,
                timeout_ms,
            } => CliError::usage(format!(
                "--interval rounds up to {rounded_ms} ms of whole 5 ms SYNC cycles, not shorter \
                 than the drive's SBus timeout P815 of {timeout_ms} ms: the drive would trip with \
                 F47; use a shorter --interval or raise P815"
            )),
            e => CliError::usage(e.to_string()),
        })?;
    }
    let stop = end.and_then(|cmd| PdStop::new(&words, &slots, cmd));
    let mut hint = crate::sew::pd_hint(&words, &slots, end.unwrap_or(ControlWord1::STOP));
    if let Some(g) = group {
        hint.push_str(&format!(" --group {}", g.get()));
    }
    let guard = MotorGuard::install(
        PdStop::at_end(stop.as_ref(), end.is_none().then_some("--keep-running")),
        again.then(&hint),
    );
    let work = async |m: &mut SbusDriver<C>, motion: &Motion<'_>| -> Result<()> {
        sbus_pd(m, to, words, args.count, period, motion, |pi| {
            print_pd(to, words, pi, json)
        })
        .await
    };
    let send_stop = async |m: &mut SbusDriver<C>| -> Result<Stopped> {
        Ok(sbus_stop(m, to, stop.as_ref()).await?)
    };
    guard.run(m, work, send_stop).await
}

fn print_pd(to: SbusTo, words: [u16; 3], pi: Option<[u16; 3]>, json: bool) -> Result<()> {
    let time = crate::tool::watch::timestamp(std::time::SystemTime::now());
    match (pi, to.group) {
        (Some(pi), _) => {
            let status = StatusWord1::from_bits(pi[0]).to_string();
            if json {
                outln!(
                    "{}",
                    json!({"type": "pd", "time": time, "address": to.address.get(),
                           "sync": to.sync, "out": words, "in": pi, "status": status})
                )
            } else {
                outln!(
                    "PI 0x{:04X} 0x{:04X} 0x{:04X}: {status}, speed {} 1/min",
                    pi[0],
                    pi[1],
                    pi[2],
                    trim_float(sew::speed_from_word(pi[1]), 1)
                )
            }
        }
        (None, Some(g)) => {
            if json {
                outln!(
                    "{}",
                    json!({"type": "pd", "time": time, "group": g.get(), "out": words, "in": null})
                )
            } else {
                outln!(
                    "GPO 0x{:04X} 0x{:04X} 0x{:04X} to group {} (never answered by design)",
                    words[0],
                    words[1],
                    words[2],
                    g.get()
                )
            }
        }
        (None, None) => Ok(()),
    }
}

/// Run `sync`: SYNC every `period` ms, `count` times (0: until Ctrl-C).
pub async fn sync<C: CanIo>(
    m: &mut SbusDriver<C>,
    args: &SyncArgs,
    sync_id: u16,
    json: bool,
) -> Result<()> {
    let stop = Interrupt::install("the SYNC telegrams stopped");
    let started = tokio::time::Instant::now();
    let period = Duration::from_millis(args.period);
    let sent = sync_producer(m, period, args.count, stop.inner()).await?;
    let elapsed = started.elapsed();
    if json {
        outln!(
            "{}",
            json!({"type": "sync", "sync_id": sync_id, "sent": sent, "period_ms": args.period,
                   "elapsed_ms": elapsed.as_millis() as u64})
        )
    } else {
        outln!(
            "sent {sent} SYNC telegram(s) on identifier {sync_id} every {} ms ({:.1} s)",
            args.period,
            elapsed.as_secs_f64()
        )
    }
}
