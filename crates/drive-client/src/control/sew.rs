//! Process data of a MOVIDRIVE (`pd`), over MOVILINK or SBus: the checks before it (control
//! word slots, warnings, the bus timeout), the interval that keeps the timeout fed, the
//! exchanges, and the stop: the output words with the stop command in every control word slot.

use std::time::Duration;

use drive_core::rt::{CanIo, CharIo};
use drive_profile::sew::{ControlWord1, StatusWord1};
use movilink::driver::MovilinkDriver;
use movilink::{Address, PduType, Telegram};
use sbus_can::driver::SbusDriver;
use sbus_can::telegram::ProcessData;

use super::{ControlError, paced};
use crate::front::FrontEnd;
use crate::interrupt::Interrupt;
use crate::motor::{AtEnd, Motion, Stopped};
use crate::sew::{SewLink, bus_timeout, pd_warnings, with_command};

/// The stop a SEW `pd` session ends with: the output words with the stop command in the low
/// byte of every control word slot, the other words as they were.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PdStop {
    /// The words sent to stop.
    pub words: Vec<u16>,
    /// The command in the control word slots.
    pub cmd: ControlWord1,
    /// The first control word slot (for the message).
    slot: usize,
}

impl PdStop {
    /// The stop of a session sending `words` with control words in `slots`; `None` when no
    /// output word is a control word (nothing can stop the drive over process data).
    pub fn new(words: &[u16], slots: &[usize], cmd: ControlWord1) -> Option<Self> {
        let slot = *slots.first()?;
        Some(Self {
            words: with_command(words, slots, cmd),
            cmd,
            slot,
        })
    }

    /// What was sent: `stop (control word 0x0002)`.
    pub fn sent(&self) -> String {
        format!(
            "{} (control word 0x{:04X})",
            self.cmd.command().name(),
            self.words.get(self.slot).copied().unwrap_or(0)
        )
    }

    /// How the session ends: stopped with `stop`, else left as the last exchange set it, for
    /// `keep_running` (the front end's reason) or because no word is a control word.
    pub fn at_end(stop: Option<&PdStop>, keep_running: Option<&'static str>) -> AtEnd {
        match (keep_running, stop) {
            (Some(why), _) => AtEnd::KeepRunning(why),
            (None, None) => AtEnd::KeepRunning("no process output word is a control word"),
            (None, Some(_)) => AtEnd::Stop,
        }
    }

    /// The words that stop the drive, for a front end's hint: `cmd` in the control word slots,
    /// PO1 (the factory setting's control word) where none is known.
    pub fn words_for(words: &[u16], slots: &[usize], cmd: ControlWord1) -> Vec<u16> {
        let slots = if slots.is_empty() { &[0][..] } else { slots };
        with_command(words, slots, cmd)
    }
}

/// What [`preflight`] found out before process data.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Preflight {
    /// The process output words the drive takes as control words.
    pub slots: Vec<usize>,
    /// The drive's bus timeout (P812 RS-485 / P815 SBus), `None` when it is off (0, or P815's
    /// 650 s) or could not be read.
    pub timeout: Option<Duration>,
    /// What a person should hear first ([`pd_warnings`]).
    pub warnings: Vec<String>,
}

/// Before process data of `words` words: the control word slots, the warnings, and the bus
/// timeout (`timeout`: its index and name) the exchanges must keep fed; `stopping`: the
/// session ends with a stop.
pub async fn preflight<L: SewLink>(
    link: &mut L,
    words: usize,
    stopping: bool,
    timeout: (u16, &str),
    front: &dyn FrontEnd,
) -> Preflight {
    let (slots, warnings) = pd_warnings(link, words, stopping, timeout, front).await;
    Preflight {
        slots,
        timeout: bus_timeout(link, timeout.0).await,
        warnings,
    }
}

/// An interval between exchanges the drive's bus timeout would not survive.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum IntervalError {
    /// The interval asked for is not shorter than the timeout.
    #[error(
        "an interval of {asked_ms} ms is not shorter than the drive's bus timeout of \
         {timeout_ms} ms: the drive would trip between two exchanges ({fits_ms} ms fits)"
    )]
    NotShorter {
        /// The interval asked for.
        asked_ms: u64,
        /// The drive's bus timeout.
        timeout_ms: u64,
        /// An interval that fits.
        fits_ms: u64,
    },
    /// Rounded up to whole SYNC cycles, the interval is not shorter than the timeout.
    #[error(
        "the interval rounds up to {rounded_ms} ms of whole 5 ms SYNC cycles, not shorter \
         than the drive's bus timeout of {timeout_ms} ms"
    )]
    SyncNotShorter {
        /// The interval in whole SYNC cycles.
        rounded_ms: u64,
        /// The drive's bus timeout.
        timeout_ms: u64,
    },
}

fn millis(d: Duration) -> u64 {
    u64::try_from(d.as_millis()).unwrap_or(u64::MAX)
}

/// The interval between exchanges: the one asked for (ms), or by default one that keeps the
/// drive's bus timeout fed (half of it, whole `grain`s, at most `default`). An interval at or
/// above the timeout is refused: the drive would trip between two exchanges.
pub fn interval(
    asked: Option<u64>,
    timeout: Option<Duration>,
    default: u64,
    grain: u64,
) -> Result<Duration, IntervalError> {
    let timeout_ms = timeout.map(millis);
    let ms = match (asked, timeout_ms) {
        (Some(ms), Some(t)) if ms >= t => {
            let fits = (t / 2 / grain * grain).max(grain.min(t.saturating_sub(1)).max(1));
            return Err(IntervalError::NotShorter {
                asked_ms: ms,
                timeout_ms: t,
                fits_ms: fits,
            });
        }
        (Some(ms), _) => ms,
        (None, Some(t)) => (t / 2 / grain * grain).clamp(grain, default.max(grain)),
        (None, None) => default,
    };
    Ok(Duration::from_millis(ms))
}

/// SBus's SYNC cycle.
pub const SYNC_CYCLE_MS: u64 = 5;

/// `period` rounded up to whole SYNC cycles, refused when that reaches the bus timeout.
pub fn sync_interval(
    period: Duration,
    timeout: Option<Duration>,
) -> Result<Duration, IntervalError> {
    let rounded = millis(period).div_ceil(SYNC_CYCLE_MS).max(1) * SYNC_CYCLE_MS;
    match timeout.map(millis) {
        Some(t) if rounded >= t => Err(IntervalError::SyncNotShorter {
            rounded_ms: rounded,
            timeout_ms: t,
        }),
        _ => Ok(Duration::from_millis(rounded)),
    }
}

/// A `pd` session: the words, how many exchanges (0: until interrupted), how far apart.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Pd {
    /// The process output words.
    pub words: Vec<u16>,
    /// Exchanges; 0 runs until interrupted.
    pub count: u32,
    /// Time between two exchanges.
    pub period: Duration,
}

fn movilink_error(e: movilink::driver::DriverError) -> ControlError {
    ControlError::Client(crate::sew::movilink::client_error(e))
}

fn sbus_error(e: sbus_can::driver::DriverError) -> ControlError {
    ControlError::Client(crate::sew::sbus::client_error(e))
}

/// `pd` over MOVILINK with the drive at `addr`: a cyclic PDU type runs as a cyclic session (one
/// telegram every period, which keeps P812 fed), an acyclic one as single exchanges a period
/// apart; `each` hears every answer's process input words.
pub async fn movilink_pd<IO: CharIo, E: From<ControlError>>(
    m: &mut MovilinkDriver<IO>,
    addr: Address,
    pdu: PduType,
    pd: &Pd,
    motion: &Motion<'_>,
    mut each: impl FnMut(&[u16]) -> Result<(), E>,
) -> Result<(), E> {
    if pdu.is_cyclic() {
        let mut session = m
            .cyclic(addr, pdu, pd.period)
            .map_err(|e| E::from(movilink_error(e)))?;
        session.set_output(&pd.words);
        let mut done = 0u32;
        while pd.count == 0 || done < pd.count {
            if motion.interrupt().requested() {
                break;
            }
            done = done.saturating_add(1);
            motion.armed();
            let response = session.cycle().await.map_err(movilink_error)?;
            each(response.process_data())?;
        }
        Ok(())
    } else {
        paced(motion, pd.count, pd.period, async || {
            let request = Telegram::request(addr, pdu).with_process_data(&pd.words);
            let response = m.exchange(request).await.map_err(movilink_error)?;
            each(response.process_data())
        })
        .await
    }
}

/// The drive's status word 1, decoded, from process input words.
fn status_of(pi: &[u16]) -> String {
    pi.first()
        .map(|s| StatusWord1::from_bits(*s).to_string())
        .unwrap_or_default()
}

/// Send `stop` over MOVILINK in the session's PDU type.
pub async fn movilink_stop<IO: CharIo>(
    m: &mut MovilinkDriver<IO>,
    addr: Address,
    pdu: PduType,
    stop: Option<&PdStop>,
) -> Result<Stopped, ControlError> {
    let stop = stop.ok_or(ControlError::NoStopWord)?;
    let request = Telegram::request(addr, pdu).with_process_data(&stop.words);
    let response = m.exchange(request).await.map_err(movilink_error)?;
    Ok(Stopped {
        sent: stop.sent(),
        reports: status_of(response.process_data()),
    })
}

/// Where SBus process data go.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SbusTo {
    /// The drive.
    pub address: sbus_can::ids::Address,
    /// Every drive of this group instead (no drive answers).
    pub group: Option<sbus_can::ids::Address>,
    /// Synchronous process data, taken at the next SYNC.
    pub sync: bool,
}

/// [`preflight`] over SBus for `to`. A group has no answers to read the control word slots
/// or P815 from: the factory setting (PO1 = control word 1) is assumed, without a timeout.
pub async fn sbus_preflight<C: CanIo>(
    m: &mut SbusDriver<C>,
    to: SbusTo,
    stopping: bool,
    front: &dyn FrontEnd,
) -> Preflight {
    if to.group.is_some() {
        return Preflight {
            slots: vec![0],
            timeout: None,
            warnings: Vec::new(),
        };
    }
    let mut link = crate::sew::sbus::SbusLink {
        master: m,
        address: to.address,
        handshake: sbus_can::master::Handshake::Async,
        iface: String::new(),
    };
    let timeout = (drive_profile::sew::index::SBUS_TIMEOUT, "SBus timeout P815");
    preflight(&mut link, 3, stopping, timeout, front).await
}

/// One SBus exchange of `words`: the drive's process input words, `None` from a group.
pub async fn sbus_exchange<C: CanIo>(
    m: &mut SbusDriver<C>,
    to: SbusTo,
    words: [u16; 3],
) -> Result<Option<[u16; 3]>, ControlError> {
    let po = ProcessData(words);
    let pi = match to.group {
        Some(g) => m.group_process_data(g, po).await.map(|()| None),
        None if to.sync => m.process_data_sync(to.address, po).await.map(Some),
        None => m.process_data(to.address, po).await.map(Some),
    };
    Ok(pi.map_err(sbus_error)?.map(|p| p.0))
}

/// `pd` over SBus: `count` exchanges `period` apart; `each` hears every answer (`None` from a
/// group).
pub async fn sbus_pd<C: CanIo, E: From<ControlError>>(
    m: &mut SbusDriver<C>,
    to: SbusTo,
    words: [u16; 3],
    count: u32,
    period: Duration,
    motion: &Motion<'_>,
    mut each: impl FnMut(Option<[u16; 3]>) -> Result<(), E>,
) -> Result<(), E> {
    paced(motion, count, period, async || {
        each(sbus_exchange(m, to, words).await?)
    })
    .await
}

/// Send `stop` over SBus the way the session sent its words.
pub async fn sbus_stop<C: CanIo>(
    m: &mut SbusDriver<C>,
    to: SbusTo,
    stop: Option<&PdStop>,
) -> Result<Stopped, ControlError> {
    let stop = stop.ok_or(ControlError::NoStopWord)?;
    let mut w = [0u16; 3];
    for (x, y) in w.iter_mut().zip(&stop.words) {
        *x = *y;
    }
    let pi = sbus_exchange(m, to, w).await?;
    Ok(Stopped {
        sent: stop.sent(),
        reports: pi.map_or_else(
            || "no answer by design (group)".to_owned(),
            |p| status_of(&p),
        ),
    })
}

/// The SYNC producer: a SYNC telegram every `period`, `count` times (0: until `interrupt`); how
/// many were sent. A tick missed is skipped, not caught up.
pub async fn sync_producer<C: CanIo>(
    m: &mut SbusDriver<C>,
    period: Duration,
    count: u32,
    interrupt: &Interrupt,
) -> Result<u32, ControlError> {
    let mut ticker = drive_core::rt::time::interval(period);
    ticker.set_missed_tick_behavior(drive_core::rt::time::MissedTickBehavior::Skip);
    let mut sent = 0u32;
    while count == 0 || sent < count {
        tokio::select! {
            _ = ticker.tick() => {}
            () = interrupt.wait() => {}
        }
        if interrupt.requested() {
            break;
        }
        m.sync().await.map_err(sbus_error)?;
        sent = sent.saturating_add(1);
    }
    Ok(sent)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_pd_stop_goes_into_the_control_word_slots_only() {
        // PO1 control word 1 (enable), PO2 speed, PO3 another control word with its high byte.
        let words = [0x0006, 5000, 0x1206];
        let stop = PdStop::new(&words, &[0, 2], ControlWord1::STOP).unwrap();
        assert_eq!(stop.words, [0x0002, 5000, 0x1202]);
        assert_eq!(stop.sent(), "stop (control word 0x0002)");
        assert_eq!(PdStop::at_end(Some(&stop), None), AtEnd::Stop);
        // No control word: nothing stops it; keeping it running wins anyway.
        assert_eq!(PdStop::new(&words, &[], ControlWord1::STOP), None);
        assert!(matches!(
            PdStop::at_end(None, None),
            AtEnd::KeepRunning(r) if r.contains("control word")
        ));
        assert_eq!(
            PdStop::at_end(Some(&stop), Some("asked")),
            AtEnd::KeepRunning("asked")
        );
        // The factory setting's PO1 where no slot is known.
        assert_eq!(
            PdStop::words_for(&words, &[], ControlWord1::INHIBIT),
            [0x0001, 5000, 0x1206]
        );
    }

    #[test]
    fn the_interval_keeps_the_bus_timeout_fed() {
        let ms = Duration::from_millis;
        // Default: half the timeout, at most the default; none known: the default.
        assert_eq!(interval(None, Some(ms(100)), 100, 1), Ok(ms(50)));
        assert_eq!(interval(None, Some(ms(1000)), 100, 1), Ok(ms(100)));
        assert_eq!(interval(None, None, 100, 1), Ok(ms(100)));
        // Whole SYNC cycles, at least one.
        assert_eq!(interval(None, Some(ms(8)), 5, 5), Ok(ms(5)));
        // At or above the timeout: refused, naming one that fits.
        assert_eq!(
            interval(Some(100), Some(ms(100)), 100, 1),
            Err(IntervalError::NotShorter {
                asked_ms: 100,
                timeout_ms: 100,
                fits_ms: 50
            })
        );
        assert_eq!(interval(Some(60_000), None, 100, 1), Ok(ms(60_000)));
        assert_eq!(sync_interval(ms(7), Some(ms(100))), Ok(ms(10)));
        assert_eq!(
            sync_interval(ms(98), Some(ms(100))),
            Err(IntervalError::SyncNotShorter {
                rounded_ms: 100,
                timeout_ms: 100
            })
        );
    }
}
