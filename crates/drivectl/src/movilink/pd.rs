//! `drivectl movilink pd`: process data exchanged with one drive (acyclic or cyclic PDU types),
//! the drive stopped at the end unless `--keep-running`.

use clap::Args;
use drive_client::control::sew::{Pd, PdStop, movilink_pd, movilink_stop};
use drive_profile::sew::{self, ControlWord1, StatusWord1, index};
use movilink::driver::{CharIo, MovilinkDriver as MasterDriver};
use movilink::{Address, PduType};
use serde_json::json;

use super::{decode, link};
use crate::error::{CliError, Result};
use crate::tool::again::Again;
use crate::tool::client::parse_int;
use crate::tool::motor::{Motion, MotorGuard, Stopped};
use crate::tool::output::trim_float;

/// Arguments of `drivectl movilink pd`.
#[derive(Debug, Args)]
pub struct PdArgs {
    /// PDU type, e.g. 0x85 (3PD acyclic) or 0x05 (3PD cyclic).
    #[arg(long = "type", default_value = "0x85")]
    pub pdu_type: String,
    /// Output words, e.g. 0x0006,5000,0.
    #[arg(
        long,
        value_delimiter = ',',
        required = true,
        allow_hyphen_values = true
    )]
    pub out: Vec<String>,
    /// Number of exchanges; 0 runs until Ctrl-C.
    #[arg(long, default_value_t = 1)]
    pub count: u32,
    /// Milliseconds between exchanges, 1–60000. By default 100, and for a cyclic PDU type
    /// half the drive's RS-485 timeout P812 when that is shorter; an interval at or above
    /// P812 is refused (the drive would trip between two exchanges).
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..=60_000))]
    pub interval: Option<u64>,
    /// Leave the drive as the last exchange left it. Without it, `pd` ends (after --count
    /// exchanges, on Ctrl-C, SIGTERM, SIGHUP or SIGQUIT, on an error or a closed output
    /// pipe) by sending the control word slot (P870–P872) the --stop command.
    #[arg(long)]
    pub keep_running: bool,
    /// How `pd` stops the drive at its end: `ramp` (control word 0x0002: stop on the
    /// active integrator ramp) or `inhibit` (0x0001: controller inhibit, the output stage
    /// off and the motor coasts).
    #[arg(long, default_value = "ramp", value_parser = ["ramp", "inhibit"])]
    pub stop: String,
}

/// `pd` with the drive at `addr`; `again` reaches it again (for the hint of how to stop it).
pub async fn pd<IO: CharIo>(
    m: &mut MasterDriver<IO>,
    addr: Address,
    args: &PdArgs,
    json: bool,
    again: Again,
) -> Result<()> {
    let end = match (args.keep_running, args.stop.as_str()) {
        (true, _) => None,
        (false, "inhibit") => Some(ControlWord1::INHIBIT),
        (false, _) => Some(ControlWord1::STOP),
    };
    let pdu_type = args.pdu_type.as_str();
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
    for w in &args.out {
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
    let pre = crate::sew::pd_preflight(
        &mut link(m, addr, ""),
        words.len(),
        end.is_some(),
        (index::RS485_TIMEOUT, "RS-485 timeout P812"),
    )
    .await;
    let slots = pre.slots;
    // P812 watches cyclic request telegrams only (manual ch. 4: "zyklisch … Timeout-Zeit").
    let period = crate::sew::pd_interval(
        args.interval,
        pre.timeout.filter(|_| pdu.is_cyclic()),
        100,
        1,
        "RS-485 timeout P812",
        "an RS-485 timeout fault",
    )?;
    // No control word among the outputs: nothing can stop the drive over process data
    // (warned above); the session ends as the last exchange left it.
    let stop = end.and_then(|cmd| PdStop::new(&words, &slots, cmd));
    let hint = crate::sew::pd_hint(&words, &slots, end.unwrap_or(ControlWord1::STOP));
    let guard = MotorGuard::install(
        PdStop::at_end(stop.as_ref(), end.is_none().then_some("--keep-running")),
        again.then(&hint),
    );
    let pd = Pd {
        words,
        count: args.count,
        period,
    };
    let work = async |m: &mut MasterDriver<IO>, motion: &Motion<'_>| -> Result<()> {
        movilink_pd(m, addr, pdu, &pd, motion, |pi| {
            print_pd(addr, pdu, &pd.words, pi, json)
        })
        .await
    };
    let send_stop = async |m: &mut MasterDriver<IO>| -> Result<Stopped> {
        Ok(movilink_stop(m, addr, pdu, stop.as_ref()).await?)
    };
    guard.run(m, work, send_stop).await
}

fn print_pd(addr: Address, pdu: PduType, out: &[u16], pi: &[u16], json: bool) -> Result<()> {
    let status = pi.first().map(|s| StatusWord1::from_bits(*s).to_string());
    if json {
        outln!(
            "{}",
            json!({"type": "pd", "time": crate::tool::watch::timestamp(std::time::SystemTime::now()),
                   "address": addr.get(), "pdu_type": format!("0x{:02X}", pdu.raw()),
                   "pdu_name": decode::pdu_name(pdu), "out": out, "in": pi, "status": status})
        )
    } else {
        let words_text: Vec<String> = pi.iter().map(|w| format!("0x{w:04X}")).collect();
        let speed = pi.get(1).map_or_else(String::new, |w| {
            format!(", speed {} 1/min", trim_float(sew::speed_from_word(*w), 1))
        });
        outln!(
            "PI {}: {}{speed}",
            words_text.join(" "),
            status.unwrap_or_default()
        )
    }
}
