//! The page's control of a drive over process data (`page_control = true`): one page drives
//! a drive at a time, holding a lease; while it does, the family's control and setpoint words
//! replace the config's `out` in the drive's cycles. A command is answered after the cycle
//! that sent it. Once the lease has no receiver (the page closed, reloaded, lost its
//! connection) or was not heard of for
//! [`LEASE_SILENCE`](crate::model::LEASE_SILENCE), the next cycle sends the family's stop, the
//! action log says that a lost page stopped it, and the cycles after it send the config's
//! `out` again.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::SystemTime;

use drive_client::ClientError;
use drive_profile::Family;
use serde_json::{Value, json};
use tokio::sync::{oneshot, watch};

use super::super::bus::BusAccess;
use super::super::config::Bus;
use super::super::model::{Answer, Ask, ControlOp, DriveIx, LEASE_SILENCE, PageCommand};
use crate::ui::auth::{self, Who};

/// The reply of an ask.
type Reply = oneshot::Sender<Result<Answer, ClientError>>;

/// Lease numbers, unique in the process.
static LEASES: AtomicU64 = AtomicU64::new(1);

/// A drive a page drives.
#[derive(Debug)]
pub struct Driven {
    who: Who,
    lease_no: u64,
    lease: Arc<watch::Sender<Value>>,
    family: Family,
    /// The command in effect (`None`: nothing sent yet, the config's `out` goes on).
    pub(crate) command: Option<PageCommand>,
    /// A command waiting for its cycle, and whom to answer after it.
    pending: Option<(PageCommand, Reply)>,
    /// The last cycle's output and input words.
    sent: Vec<u16>,
    inputs: Vec<u16>,
    /// The lease ended: the stop goes out at the next cycle.
    lost: bool,
    /// When the page last said it is there.
    heard: tokio::time::Instant,
    /// Done: the task forgets the drive after this cycle.
    pub released: bool,
}

/// `drive NAME on bus NAME`.
fn words_of(bus: &Bus, drive: DriveIx) -> String {
    let d = bus.drives.get(drive).map_or("?", |d| d.name.as_str());
    format!("drive {d} on bus {}", bus.name)
}

/// The setpoint's unit on the page.
pub fn unit(family: Family) -> &'static str {
    match family {
        Family::Nord => "%",
        _ => "1/min",
    }
}

/// The family's setpoint word for `text` (a speed in 1/min for a MOVIDRIVE, 0.2 1/min per
/// digit, −6553.6 … 6553.4; a percentage for NORD's SW1, −200 … 199.99 %), or why it is none,
/// before anything is sent.
pub fn setpoint_word(family: Family, text: &str) -> Result<u16, String> {
    match family {
        Family::Nord => drive_client::control::nord::setpoint_word(text, false)
            .map(|s| s.word)
            .map_err(|e| match e {
                drive_client::control::nord::SetpointError::NotExact { nearest } => format!(
                    "setpoint {text} %: {e}; the nearest is {:.4} %",
                    drive_profile::nord::percent_from_word(nearest)
                ),
                _ => format!("setpoint {text} %: {e}"),
            }),
        Family::Movidrive => {
            let rpm = drive_client::text::parse_decimal(text)
                .filter(|x| x.is_finite())
                .ok_or_else(|| format!("setpoint `{text}` is not a speed in 1/min"))?;
            let per = drive_profile::sew::SPEED_RPM_PER_DIGIT;
            let steps = (rpm / per).round();
            if steps > f64::from(i16::MAX) || steps < f64::from(i16::MIN) {
                return Err(format!(
                    "setpoint {text} 1/min is past what the speed setpoint word holds \
                     (−6553.6 … 6553.4 1/min at 0.2 1/min per digit)"
                ));
            }
            if (steps * per - rpm).abs() > 1e-6 {
                return Err(format!(
                    "setpoint {text} 1/min is finer than the word's steps of 0.2 1/min; the \
                     nearest is {:.1} 1/min",
                    steps * per
                ));
            }
            Ok(steps as i16 as u16)
        }
        _ => Err(no_control(family)),
    }
}

/// Why a family's drives cannot be driven from the page.
pub fn no_control(family: Family) -> String {
    format!(
        "{family} drives have no process data in the gateway: the page cannot enable or stop them"
    )
}

/// A setpoint word as the page shows it.
pub fn setpoint_text(family: Family, word: u16) -> String {
    match family {
        Family::Nord => format!("{:.2} %", drive_profile::nord::percent_from_word(word)),
        _ => format!("{:.1} 1/min", drive_profile::sew::speed_from_word(word)),
    }
}

fn command_key(c: Option<PageCommand>) -> Value {
    match c {
        Some(PageCommand::Enable { .. }) => "enable".into(),
        Some(PageCommand::Stop) => "stop".into(),
        None => Value::Null,
    }
}

/// Take a control ask (the drive exists, answers and the bus is not too busy).
pub fn take(ask: Ask, op: ControlOp, bus: &Bus, family: Family, driven: &mut [Option<Driven>]) {
    let drive = ask.drive;
    let refuse = |reply: Reply, m: String| {
        let _ = reply.send(Err(ClientError::Request(m)));
    };
    let Some(slot) = driven.get_mut(drive) else {
        return refuse(
            ask.reply,
            format!("bus {} has no drive number {drive}", bus.name),
        );
    };
    let allowed = bus
        .drives
        .get(drive)
        .and_then(|d| d.process_data.as_ref())
        .is_some_and(|pd| pd.page_control);
    if !allowed {
        return refuse(
            ask.reply,
            format!(
                "{} is not controlled from the page: its config needs [bus.drive.process_data] \
                 with page_control = true",
                words_of(bus, drive)
            ),
        );
    }
    match op {
        ControlOp::Take { who, lease } => {
            if let Some(d) = slot.as_ref() {
                let m = if d.lost || d.lease.is_closed() {
                    format!(
                        "{} is being stopped after the page that drove it went away; try again \
                         in a moment",
                        words_of(bus, drive)
                    )
                } else {
                    format!(
                        "{} is driven from another page by {}; it must stop driving it first",
                        words_of(bus, drive),
                        d.who.user
                    )
                };
                return refuse(ask.reply, m);
            }
            let lease_no = LEASES.fetch_add(1, Ordering::Relaxed);
            *slot = Some(Driven {
                who,
                lease_no,
                lease,
                family,
                command: None,
                pending: None,
                sent: Vec::new(),
                inputs: Vec::new(),
                lost: false,
                heard: tokio::time::Instant::now(),
                released: false,
            });
            let _ = ask.reply.send(Ok(Answer::Lease(lease_no)));
        }
        ControlOp::Alive { lease } => match slot.as_mut() {
            Some(d) if d.lease_no == lease && !d.lost && !d.lease.is_closed() => {
                d.heard = tokio::time::Instant::now();
                let _ = ask.reply.send(Ok(Answer::Done));
            }
            _ => refuse(
                ask.reply,
                format!("this page does not drive {}", words_of(bus, drive)),
            ),
        },
        ControlOp::Command { lease, command } => match slot.as_mut() {
            Some(d) if d.lease_no == lease && !d.lost && !d.lease.is_closed() => {
                d.heard = tokio::time::Instant::now();
                if let Some((_, old)) = d.pending.replace((command, ask.reply)) {
                    refuse(
                        old,
                        "a newer command replaced this one before its cycle".to_owned(),
                    );
                }
            }
            Some(d) => refuse(
                ask.reply,
                format!(
                    "this page does not drive {}: {} does",
                    words_of(bus, drive),
                    d.who.user
                ),
            ),
            None => refuse(
                ask.reply,
                format!(
                    "this page does not drive {} (its lease ended): take it again",
                    words_of(bus, drive)
                ),
            ),
        },
    }
}

/// One cycle of a driven drive: the words of its command (the stop once its lease has
/// ended), the exchange, the answer of a command that waited for it, the state on the lease;
/// the input words.
pub async fn cycle<B: BusAccess>(
    access: &mut B,
    bus: &Bus,
    drive: DriveIx,
    address: u8,
    out: &[u16],
    d: &mut Driven,
) -> Result<Vec<u16>, ClientError> {
    let silent = d.heard.elapsed() > LEASE_SILENCE;
    if !d.lost && (d.lease.is_closed() || silent) {
        d.lost = true;
        if silent {
            tracing::warn!(bus = %bus.name, user = %d.who.user, "the page that drives {} was not heard of for {} s: stopping it", words_of(bus, drive), LEASE_SILENCE.as_secs());
        }
        if let Some((_, reply)) = d.pending.take() {
            let _ = reply.send(Err(ClientError::Request("the page went away".to_owned())));
        }
    }
    let command = if d.lost {
        d.command.map(|_| PageCommand::Stop)
    } else {
        d.pending.as_ref().map(|(c, _)| *c).or(d.command)
    };
    let mut refusal = None;
    let words = match command {
        None => out.to_vec(),
        Some(c) => match access
            .control_words(address, out, c, &d.sent, &d.inputs)
            .await
        {
            Ok(Ok(w)) => w,
            Ok(Err(why)) => {
                refusal = Some(why);
                if d.sent.is_empty() {
                    out.to_vec()
                } else {
                    d.sent.clone()
                }
            }
            Err(e) => {
                if let Some((_, reply)) = d.pending.take() {
                    let _ = reply.send(Err(e.clone()));
                }
                return Err(e);
            }
        },
    };
    let inputs = match access.process_data(address, &words).await {
        Ok(i) => i,
        Err(e) => {
            if let Some((_, reply)) = d.pending.take() {
                let _ = reply.send(Err(e.clone()));
            }
            return Err(e);
        }
    };
    let state = access.state_in_inputs(address, &inputs);
    let what = words_of(bus, drive);
    if let Some((c, reply)) = d.pending.take() {
        let answer = match &refusal {
            Some(why) => Err(ClientError::Request(format!("{why}; nothing was sent"))),
            None => {
                d.command = Some(c);
                Ok(Answer::Text(format!(
                    "sent {} in the process data ({}); the drive answers {}",
                    match c {
                        PageCommand::Enable { word } =>
                            format!("enable at {}", setpoint_text(d.family, word)),
                        PageCommand::Stop => "stop".to_owned(),
                    },
                    hex(&words),
                    state.as_deref().unwrap_or("its input words")
                )))
            }
        };
        let _ = reply.send(answer);
    }
    d.sent = words.clone();
    d.inputs = inputs.clone();
    if d.lost {
        d.released = true;
        match d.command {
            Some(PageCommand::Stop) => auth::action(
                &d.who,
                &format!("release {what}"),
                &format!("stop sent again ({})", hex(&words)),
            ),
            Some(_) if refusal.is_none() => {
                tracing::warn!(bus = %bus.name, drive = %bus.drives.get(drive).map_or("?", |d| d.name.as_str()), user = %d.who.user, "the page that drove the drive went away: stop sent in the process data");
                auth::action(
                    &d.who,
                    &format!("page lost: stop {what}"),
                    &format!("stopped ({})", hex(&words)),
                );
            }
            Some(_) => auth::action(
                &d.who,
                &format!("page lost: stop {what}"),
                &format!("not stopped: {}", refusal.as_deref().unwrap_or("")),
            ),
            None => {}
        }
    } else {
        d.lease.send_replace(json!({
            "type": "state",
            "driving": d.who.user,
            "command": command_key(d.command),
            "setpoint": match d.command {
                Some(PageCommand::Enable { word }) => Value::from(setpoint_text(d.family, word)),
                _ => Value::Null,
            },
            "sent": words,
            "in": inputs,
            "state": state,
            "refused": refusal,
            "ts": crate::mqtt::payload::millis(SystemTime::now()),
        }));
    }
    Ok(inputs)
}

/// At the gateway's stop: the action log says who drove which drive when the gateway stopped
/// it (the stop itself is the one every process-data drive gets).
pub fn at_gateway_stop(bus: &Bus, driven: &[Option<Driven>], why: &str) {
    for (i, d) in driven.iter().enumerate() {
        if let Some(d) = d
            && d.command.is_some()
        {
            auth::action(
                &d.who,
                &format!("{why}: stop {}", words_of(bus, i)),
                "the gateway's stop sends it",
            );
        }
    }
}

fn hex(words: &[u16]) -> String {
    words
        .iter()
        .map(|w| format!("0x{w:04X}"))
        .collect::<Vec<_>>()
        .join(" ")
}
