//! What `drivectl movilink` and `drivectl sbus` share: a MOVIDRIVE's parameter channel is the
//! same on RS-485 and on CAN, so the client is drive-client's one [`SewClient`] on a
//! [`SewLink`] (MOVILINK's or SBus's), and the common commands run on it the same way
//! ([`SewDrive`]): the names ([`Sew`]), info, a write to a group or broadcast, and the
//! process-data preflight with its warnings on standard error.

use drive_client::info::Info;
use drive_client::sew::{RAW_INDICES, bus_timeout, pd_warnings, with_command, write_service};
use drive_profile::Family;
use drive_profile::sew::ParamChannel;
use serde_json::{Map, Value, json};

pub use drive_client::sew::{SewClient, SewLink};

use crate::error::Result;
use crate::tool::client::{Target, ValueText};
use crate::tool::cmd::{self, Confirm, Drive, InfoArgs, WriteArgs, WriteValue, Writer};
use crate::tool::front::Cli;
use crate::tool::write::WriteRequest;

/// The client of the drive behind `link`, its messages in the command line's words.
pub fn client<L: SewLink>(link: L) -> SewClient<L> {
    SewClient::new(link).with_front_end(&Cli)
}

/// Resolve a MOVIDRIVE parameter: `P813`, `813`, `8600`, `0x2198`; indices outside the table
/// are allowed (raw access).
pub fn resolve(key: &str) -> Result<Target> {
    Ok(Target::resolve(Family::Movidrive, key, RAW_INDICES)?)
}

/// A MOVIDRIVE parameter is its index or menu number alone.
#[derive(Debug, Clone, Copy, Default, clap::Args)]
pub struct Sew {}

impl cmd::Selector for Sew {
    const FAMILY: Family = Family::Movidrive;
    const PARAMS: &'static str = "Indices (8318, 0x207E) or menu numbers (P000)";
    const PARAM: &'static str = "Index or menu number";
    const INFO_PARAM: &'static str = "Index or menu number";
    const VOLATILE: &'static str =
        "Write to RAM only (the service for frequent writes; lost at power-off)";
    const FORCE: &'static str = "Skip the access/range/value-list/EEPROM-wear checks of the \
        table and convert a physical value outside the table's range (a value that does not \
        fit the parameter's 32 bits is never sent)";

    fn targets(params: &[String], _: Self) -> Result<Vec<Target>> {
        params.iter().map(|p| resolve(p)).collect()
    }

    fn check_info(param: &str, _: Self) -> Result<()> {
        resolve(param).map(drop)
    }

    fn write_value(param: &str, value: &str, _: Self, how: &ValueText) -> Result<WriteValue> {
        let target = resolve(param)?;
        let parsed = target.value_from_text(value, how)?;
        Ok(WriteValue {
            target,
            raw: parsed.raw,
            rounded_from: parsed.rounded_from,
        })
    }
}

/// A SEW bus with a drive on it (MOVILINK's line, SBus's CAN): the way to the drive, and the
/// writes no drive answers.
pub trait SewBus {
    /// The way to one drive.
    type Link<'a>: SewLink
    where
        Self: 'a;
    /// How a write is confirmed (and, on SBus, sent to a group).
    type Confirm: Confirm;

    /// The way to the drive of `--addr`.
    fn link(&mut self) -> Result<Self::Link<'_>>;

    /// Send the write of `request` where no drive answers, when `args` ask for it (a group, a
    /// broadcast); `true` when it was sent.
    async fn unanswered(
        &mut self,
        args: &WriteArgs<Sew, Self::Confirm>,
        request: &WriteRequest,
        json: bool,
    ) -> Result<bool>;
}

/// The common commands on a SEW bus.
#[derive(Debug)]
pub struct SewDrive<B>(pub B);

impl<B: SewBus> Drive for SewDrive<B> {
    type Selector = Sew;
    type Confirm = B::Confirm;
    type Client<'a>
        = SewClient<B::Link<'a>>
    where
        Self: 'a;

    async fn reader(&mut self, _: Sew, _: &[Target]) -> Result<Self::Client<'_>> {
        Ok(client(self.0.link()?))
    }

    fn keeper(&mut self) -> Result<Self::Client<'_>> {
        Ok(client(self.0.link()?))
    }

    async fn writer(
        &mut self,
        args: &WriteArgs<Sew, B::Confirm>,
        request: &mut WriteRequest,
        json: bool,
    ) -> Result<Writer<Self::Client<'_>>> {
        if self.0.unanswered(args, request, json).await? {
            return Ok(Writer::Sent);
        }
        Ok(Writer::To {
            client: client(self.0.link()?),
            yes: args.confirm.yes(),
            note: None,
        })
    }

    async fn info(&mut self, args: &InfoArgs<Sew>) -> Result<Info> {
        let mut link = self.0.link()?;
        Ok(drive_client::info::sew(&mut link, resolve(&args.param)?).await?)
    }
}

/// Where an unanswered write goes, for the output: the text (`group 2`, `broadcast`) and the
/// JSON key and number (`"group": 2`, `"address": 255`).
#[derive(Debug, Clone)]
pub struct Unanswered {
    /// For a person.
    pub text: String,
    /// The JSON key.
    pub key: &'static str,
    /// The number under it.
    pub number: u8,
}

/// A write that every drive addressed executes and none answers (a group, a broadcast): the
/// same checks and wear log as an answered write, then `send` puts it on the bus; there is
/// nothing to read back. The drives of a group share the wear-log entry of the group.
pub async fn write_unanswered<L, F>(
    link: L,
    request: &WriteRequest,
    yes: bool,
    json: bool,
    to: Unanswered,
    send: F,
) -> Result<()>
where
    L: SewLink,
    F: AsyncFnOnce(&mut L, ParamChannel) -> Result<()>,
{
    let t = request.target;
    let channel = write_service(t.index, request.raw, request.persistence);
    let put = async |c: &mut SewClient<L>| send(&mut c.link, channel).await;
    crate::tool::write::unanswered(&mut client(link), request, yes, put).await?;
    if json {
        let mut m = Map::new();
        m.insert("index".into(), t.index.into());
        m.insert(
            "number".into(),
            json!(t.param.map(|p| p.label().to_string())),
        );
        m.insert("name_de".into(), json!(t.param.map(|p| p.name_de())));
        m.insert("name_en".into(), json!(t.param.map(|p| p.name_en())));
        m.insert("raw".into(), request.raw.into());
        m.insert(to.key.into(), to.number.into());
        m.insert("answered".into(), false.into());
        outln!("{}", Value::Object(m))?;
    } else {
        outln!(
            "sent index {} = raw {} to {} (never answered by design)",
            t.index,
            request.raw,
            to.text
        )?;
    }
    Ok(())
}

/// The stop a SEW `pd` session ends with (`movilink pd`, `sbus pd`): the output words with the
/// stop command in the low byte of every control word slot, the other words as they were.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PdStop {
    /// The words sent to stop.
    pub words: Vec<u16>,
    /// The command in the control word slots.
    pub cmd: drive_profile::sew::ControlWord1,
    /// The first control word slot (for the message).
    slot: usize,
}

impl PdStop {
    /// The stop of a session sending `words` with control words in `slots`; `None` when no
    /// output word is a control word (nothing can stop the drive over process data).
    pub fn new(
        words: &[u16],
        slots: &[usize],
        cmd: drive_profile::sew::ControlWord1,
    ) -> Option<Self> {
        let slot = *slots.first()?;
        Some(Self {
            words: with_command(words, slots, cmd),
            cmd,
            slot,
        })
    }

    /// What was sent, for the guard's message: `stop (control word 0x0002)`.
    pub fn sent(&self) -> String {
        format!(
            "{} (control word 0x{:04X})",
            self.cmd.command().name(),
            self.words.get(self.slot).copied().unwrap_or(0)
        )
    }

    /// How the session ends ([`crate::tool::motor::AtEnd`]): stopped with `stop`, else left as
    /// the last exchange set it, with the reason.
    pub fn at_end(stop: Option<&PdStop>, keep_running: bool) -> crate::tool::motor::AtEnd {
        use crate::tool::motor::AtEnd;
        match (keep_running, stop) {
            (true, _) => AtEnd::KeepRunning("--keep-running"),
            (false, None) => AtEnd::KeepRunning("no process output word is a control word"),
            (false, Some(_)) => AtEnd::Stop,
        }
    }

    /// The `pd` arguments that stop the drive, for the hint (`pd --out 0x0002,5000,0`): the
    /// stop command `cmd` in the control word slots, PO1 (the factory setting's control word)
    /// where none is known.
    pub fn hint(words: &[u16], slots: &[usize], cmd: drive_profile::sew::ControlWord1) -> String {
        let slots = if slots.is_empty() { &[0][..] } else { slots };
        let w: Vec<String> = with_command(words, slots, cmd)
            .iter()
            .map(|w| format!("0x{w:04X}"))
            .collect();
        format!("pd --out {}", w.join(","))
    }
}

/// What [`pd_preflight`] found out before process data.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Preflight {
    /// The process output words the drive takes as control words.
    pub slots: Vec<usize>,
    /// The drive's bus timeout (P812 RS-485 / P815 SBus), `None` when it is off (0, or P815's
    /// 650 s) or could not be read.
    pub timeout: Option<std::time::Duration>,
}

/// drive-client's [`pd_warnings`] with the warnings on standard error (`drivectl movilink pd`,
/// `sbus pd`), and the bus timeout the exchanges must keep fed.
pub async fn pd_preflight<L: SewLink>(
    link: &mut L,
    words: usize,
    stopping: bool,
    timeout: (u16, &str),
) -> Preflight {
    let (slots, warnings) = pd_warnings(link, words, stopping, timeout, &Cli).await;
    for w in warnings {
        errln!("drivectl: warning: {w}");
    }
    Preflight {
        slots,
        timeout: bus_timeout(link, timeout.0).await,
    }
}

/// The interval between process data exchanges: the one asked for, or by default one that
/// keeps the drive's bus timeout fed (half of it, whole `grain`s, at most `default`). An
/// interval at or above the timeout is refused: the drive would trip (`fault`, e.g. F47 SBus
/// timeout) between two exchanges.
pub fn pd_interval(
    asked: Option<u64>,
    timeout: Option<std::time::Duration>,
    default: u64,
    grain: u64,
    timeout_name: &str,
    fault: &str,
) -> Result<std::time::Duration> {
    let timeout_ms = timeout.map(|t| u64::try_from(t.as_millis()).unwrap_or(u64::MAX));
    let ms = match (asked, timeout_ms) {
        (Some(ms), Some(t)) if ms >= t => {
            let fits = (t / 2 / grain * grain).max(grain.min(t.saturating_sub(1)).max(1));
            return Err(crate::error::CliError::usage(format!(
                "--interval {ms} ms is not shorter than the drive's {timeout_name} of {t} ms: the \
                 drive would trip with {fault} between two exchanges; use --interval {fits} or \
                 less (or raise the timeout)"
            )));
        }
        (Some(ms), _) => ms,
        (None, Some(t)) => (t / 2 / grain * grain).clamp(grain, default.max(grain)),
        (None, None) => default,
    };
    Ok(std::time::Duration::from_millis(ms))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tool::motor::AtEnd;
    use drive_profile::sew::ControlWord1;

    #[test]
    fn the_pd_stop_goes_into_the_control_word_slots_only() {
        // PO1 control word 1 (enable), PO2 speed, PO3 another control word with its high byte.
        let words = [0x0006, 5000, 0x1206];
        let stop = PdStop::new(&words, &[0, 2], ControlWord1::STOP).unwrap();
        assert_eq!(stop.words, [0x0002, 5000, 0x1202]);
        assert_eq!(stop.sent(), "stop (control word 0x0002)");
        assert_eq!(PdStop::at_end(Some(&stop), false), AtEnd::Stop);
        // No control word: nothing stops it; --keep-running wins anyway.
        assert_eq!(PdStop::new(&words, &[], ControlWord1::STOP), None);
        assert!(matches!(
            PdStop::at_end(None, false),
            AtEnd::KeepRunning(r) if r.contains("control word")
        ));
        assert_eq!(
            PdStop::at_end(Some(&stop), true),
            AtEnd::KeepRunning("--keep-running")
        );
        // The hint: the factory setting's PO1 where no slot is known.
        assert_eq!(
            PdStop::hint(&words, &[], ControlWord1::INHIBIT),
            "pd --out 0x0001,0x1388,0x1206"
        );
    }
}
