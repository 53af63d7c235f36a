//! What `drivectl movilink` and `drivectl sbus` share: a MOVIDRIVE's parameter channel is the
//! same on RS-485 and on CAN, so the client is drive-client's one [`SewClient`] on a
//! [`SewLink`] (MOVILINK's or SBus's), and the common commands run on it the same way
//! ([`SewDrive`]): the names ([`Sew`]), info, a write to a group or broadcast, and the
//! process-data preflight with its warnings on standard error.

use drive_client::info::Info;
use drive_client::sew::{RAW_INDICES, write_service};
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

/// The `pd` arguments that stop the drive, for the hint (`pd --out 0x0002,5000,0`).
pub fn pd_hint(words: &[u16], slots: &[usize], cmd: drive_profile::sew::ControlWord1) -> String {
    let w: Vec<String> = drive_client::control::sew::PdStop::words_for(words, slots, cmd)
        .iter()
        .map(|w| format!("0x{w:04X}"))
        .collect();
    format!("pd --out {}", w.join(","))
}

/// drive-client's process-data preflight with its warnings on standard error (`drivectl
/// movilink pd`, `sbus pd`).
pub async fn pd_preflight<L: SewLink>(
    link: &mut L,
    words: usize,
    stopping: bool,
    timeout: (u16, &str),
) -> drive_client::control::sew::Preflight {
    let pre = drive_client::control::sew::preflight(link, words, stopping, timeout, &Cli).await;
    for w in &pre.warnings {
        errln!("drivectl: warning: {w}");
    }
    pre
}

/// drive-client's interval between process data exchanges, its refusal in the command line's
/// words: `timeout_name` names the drive's timeout, `fault` what it trips with.
pub fn pd_interval(
    asked: Option<u64>,
    timeout: Option<std::time::Duration>,
    default: u64,
    grain: u64,
    timeout_name: &str,
    fault: &str,
) -> Result<std::time::Duration> {
    use drive_client::control::sew::IntervalError;
    drive_client::control::sew::interval(asked, timeout, default, grain).map_err(|e| {
        crate::error::CliError::usage(match e {
            IntervalError::NotShorter {
                asked_ms: ms,
                timeout_ms: t,
                fits_ms: fits,
            } => format!(
                "--interval {ms} ms is not shorter than the drive's {timeout_name} of {t} ms: the \
                 drive would trip with {fault} between two exchanges; use --interval {fits} or \
                 less (or raise the timeout)"
            ),
            e => e.to_string(),
        })
    })
}
