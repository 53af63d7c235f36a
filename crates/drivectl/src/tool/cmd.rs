//! The parameter commands every family has — read, watch, write, info, backup, restore —
//! written once: their arguments (flattened into each family's subcommands, which keep their own
//! descriptions and examples), the checks made before a port is opened ([`precheck`]) and the
//! one executor ([`execute`]) over the [`ParamClient`] a family's [`Drive`] gives.
//!
//! A family says how a parameter is named with its [`Selector`] (`--array`/`--set`,
//! `--dataset`/`--word`/`--long`, or nothing) and how a write is confirmed with its [`Confirm`]
//! (`--yes`, SBus's `--group`); its [`Drive`] makes the client for each command on the open
//! link and says what only it does (`info`, where a write goes).

use std::fmt::Debug;

use clap::Args;
use drive_client::info::Info;
use drive_profile::{Family, Persistence};

use super::backup::{self, BackupArgs, RestoreArgs};
use super::client::{ParamClient, Target, ValueText};
use super::interrupt::Interrupt;
use super::output::physical_text;
use super::write::{self, WriteRequest};
use super::{read, watch};
use crate::error::Result;

/// How a family names a parameter on the command line beyond its number: the options it adds
/// to every parameter command, its help texts, and the checks made against its table before
/// anything is sent.
pub trait Selector: Args + Copy + Debug {
    /// The family's table.
    const FAMILY: Family;
    /// Help of the parameter names of `read` and `watch`.
    const PARAMS: &'static str;
    /// Help of the parameter of `write`.
    const PARAM: &'static str;
    /// Help of the parameter of `info`.
    const INFO_PARAM: &'static str;
    /// Help of `write --volatile`.
    const VOLATILE: &'static str;
    /// The family's other name of `--volatile`, if any.
    const VOLATILE_ALIAS: Option<&'static str> = None;
    /// Help of `write --force`.
    const FORCE: &'static str;

    /// The targets of `read` and `watch`, every name checked against the table.
    fn targets(params: &[String], sel: Self) -> Result<Vec<Target>>;

    /// Check the parameter of `info` against the table.
    fn check_info(param: &str, sel: Self) -> Result<()>;

    /// Resolve and parse a write's value, checked without the drive.
    fn write_value(param: &str, value: &str, sel: Self, how: &ValueText) -> Result<WriteValue>;

    /// The checks of a write made before the link is opened, beyond [`Selector::write_value`].
    fn precheck_write(_value: &WriteValue, _force: bool) -> Result<()> {
        Ok(())
    }
}

/// How a family confirms a write of the drive's link settings (`--yes`, or none).
pub trait Confirm: Args + Debug {
    /// Whether the write of a link setting was confirmed.
    fn yes(&self) -> bool;
}

/// No confirmation: the family has no link setting a write must confirm.
#[derive(Debug, Clone, Copy, Default, Args)]
pub struct NoConfirm {}

impl Confirm for NoConfirm {
    fn yes(&self) -> bool {
        false
    }
}

// Each family's subcommand describes itself (its doc comment wins over these).

/// The arguments of `read`: parameter names and the family's selector.
#[derive(Debug, Clone, Args)]
pub struct ReadArgs<S: Selector> {
    #[arg(required = true, num_args = 1.., help = S::PARAMS)]
    pub params: Vec<String>,
    #[command(flatten)]
    pub sel: S,
}

/// The arguments of `watch`: as `read`, and the poll options.
#[derive(Debug, Clone, Args)]
#[group(id = "WatchCommand")]
pub struct WatchArgs<S: Selector> {
    #[arg(required = true, num_args = 1.., help = S::PARAMS)]
    pub params: Vec<String>,
    #[command(flatten)]
    pub sel: S,
    #[command(flatten)]
    pub watch: watch::WatchArgs,
}

/// The arguments of `write`: the parameter, its value and how it is written.
#[derive(Debug, Clone, Args)]
pub struct WriteArgs<S: Selector, Y: Confirm> {
    #[arg(help = S::PARAM)]
    pub param: String,
    /// Value in the parameter's unit (or raw with --raw).
    #[arg(allow_hyphen_values = true)]
    pub value: String,
    #[command(flatten)]
    pub sel: S,
    #[arg(long, help = S::VOLATILE, visible_alias = S::VOLATILE_ALIAS)]
    pub volatile: bool,
    /// VALUE is the raw bus value.
    #[arg(long)]
    pub raw: bool,
    #[arg(long, help = S::FORCE)]
    pub force: bool,
    /// Accept a physical value the parameter cannot hold exactly (1.25 s where it takes
    /// 0.1 s steps) and write the nearest one it can, saying so; without it such a value is
    /// refused with the nearest one named.
    #[arg(long)]
    pub round: bool,
    #[command(flatten)]
    pub confirm: Y,
}

impl<S: Selector, Y: Confirm> WriteArgs<S, Y> {
    /// How the value is read: `--raw`, `--force`, `--round`.
    pub fn how(&self) -> ValueText {
        ValueText {
            raw: self.raw,
            force: self.force,
            round: self.round,
        }
    }

    /// The value, checked without the drive.
    pub fn value(&self) -> Result<WriteValue> {
        S::write_value(&self.param, &self.value, self.sel, &self.how())
    }
}

/// The arguments of `info`: one parameter with the family's selector.
#[derive(Debug, Clone, Args)]
pub struct InfoArgs<S: Selector> {
    #[arg(help = S::INFO_PARAM)]
    pub param: String,
    #[command(flatten)]
    pub sel: S,
}

/// The value a write sends, checked without the drive.
#[derive(Debug, Clone, Copy)]
pub struct WriteValue {
    /// The parameter with its selector.
    pub target: Target,
    /// The raw value.
    pub raw: i64,
    /// What the user typed, when it was rounded (`--round`).
    pub rounded_from: Option<f64>,
}

/// One of the common commands of a family's subcommand.
#[derive(Debug, Clone, Copy)]
pub enum Common<'a, S: Selector, Y: Confirm> {
    Read(&'a ReadArgs<S>),
    Watch(&'a WatchArgs<S>),
    Write(&'a WriteArgs<S, Y>),
    Info(&'a InfoArgs<S>),
    Backup(&'a BackupArgs),
    Restore(&'a RestoreArgs),
}

/// The [`Common`] command of a family's subcommand enum, whose variants `Read`, `Watch`,
/// `Write`, `Info`, `Backup` and `Restore` hold the common arguments; `None` for its own.
macro_rules! common_of {
    ($cmd:expr, $enum:ident) => {
        match $cmd {
            $enum::Read(a) => Some($crate::tool::cmd::Common::Read(a)),
            $enum::Watch(a) => Some($crate::tool::cmd::Common::Watch(a)),
            $enum::Write(a) => Some($crate::tool::cmd::Common::Write(a)),
            $enum::Info(a) => Some($crate::tool::cmd::Common::Info(a)),
            $enum::Backup(a) => Some($crate::tool::cmd::Common::Backup(a)),
            $enum::Restore(a) => Some($crate::tool::cmd::Common::Restore(a)),
            #[allow(unreachable_patterns)]
            _ => None,
        }
    };
}

/// The examples below a family's `backup --help`, for a drive reached with `$reach`
/// (`drivectl movilink --port /dev/ttyUSB0 --addr 1`).
macro_rules! backup_examples {
    ($reach:literal) => {
        concat!(
            "Examples:\n  ",
            $reach,
            " backup --out drive1.json\n  ",
            $reach,
            " backup --out drive1.json --overwrite"
        )
    };
}

/// The examples below a family's `restore --help` (as [`backup_examples`]).
macro_rules! restore_examples {
    ($reach:literal) => {
        concat!(
            "Examples:\n  ",
            $reach,
            " restore drive1.json --dry-run    what would change\n  ",
            $reach,
            " restore drive1.json"
        )
    };
}

/// What a command can check without the drive is checked before the link is opened: names,
/// selectors, a write's value, a restore's file (`not_restored`: the indices it never writes).
pub fn precheck<S: Selector, Y: Confirm>(
    cmd: Common<'_, S, Y>,
    not_restored: &[u16],
) -> Result<()> {
    match cmd {
        Common::Read(a) => S::targets(&a.params, a.sel).map(drop),
        Common::Watch(a) => S::targets(&a.params, a.sel).map(drop),
        Common::Info(a) => S::check_info(&a.param, a.sel),
        Common::Write(a) => S::precheck_write(&a.value()?, a.force),
        Common::Backup(_) => Ok(()),
        Common::Restore(r) => backup::check_file(&r.file, S::FAMILY, not_restored),
    }
}

/// Where a write goes, as the family's [`Drive::writer`] decides.
#[derive(Debug)]
pub enum Writer<C> {
    /// It was sent where no drive answers (a group, a broadcast) and said so: nothing to read
    /// back.
    Sent,
    /// To the drive behind `client`: the one write path and its read-back.
    To {
        /// The client of the drive.
        client: C,
        /// The write of a link setting is confirmed.
        yes: bool,
        /// A note said after the write (where the value is kept).
        note: Option<String>,
    },
}

/// A family's open link to a drive: the client of each common command and what only the
/// family does.
pub trait Drive {
    /// How a parameter is named.
    type Selector: Selector;
    /// How a write is confirmed.
    type Confirm: Confirm;
    /// The drive's parameter client.
    type Client<'a>: ParamClient
    where
        Self: 'a;

    /// The client of `read` and `watch` of `targets`.
    async fn reader(&mut self, sel: Self::Selector, targets: &[Target])
    -> Result<Self::Client<'_>>;

    /// The client of `backup` and `restore`.
    fn keeper(&mut self) -> Result<Self::Client<'_>>;

    /// Said after a backup, and after a restore however it ended.
    fn kept<'c>(_client: &Self::Client<'c>)
    where
        Self: 'c,
    {
    }

    /// Said before a restore that writes.
    async fn before_restore<'c>(_client: &mut Self::Client<'c>)
    where
        Self: 'c,
    {
    }

    /// Where the write of `request` goes; the family may decide its persistence (a RAM-only
    /// parameter, a drive that keeps nothing in EEPROM) and send it itself where no drive
    /// answers.
    async fn writer(
        &mut self,
        args: &WriteArgs<Self::Selector, Self::Confirm>,
        request: &mut WriteRequest,
        json: bool,
    ) -> Result<Writer<Self::Client<'_>>>;

    /// What `info` shows: the family reads it its own way.
    async fn info(&mut self, args: &InfoArgs<Self::Selector>) -> Result<Info>;
}

/// Run a common command on the drive behind `drive`.
pub async fn execute<D: Drive>(
    drive: &mut D,
    cmd: Common<'_, D::Selector, D::Confirm>,
    json: bool,
) -> Result<()> {
    match cmd {
        Common::Read(a) => {
            let targets = D::Selector::targets(&a.params, a.sel)?;
            let mut c = drive.reader(a.sel, &targets).await?;
            read::read_all(&mut c, &targets, json).await
        }
        Common::Watch(a) => {
            let targets = D::Selector::targets(&a.params, a.sel)?;
            let options = a.watch.options(json)?;
            let mut c = drive.reader(a.sel, &targets).await?;
            watch::watch(
                &mut c,
                &targets,
                options,
                &mut |s| out!("{s}"),
                watch::ctrl_c(),
            )
            .await
            .map(drop)
        }
        Common::Write(a) => write(drive, a, json).await,
        Common::Info(a) => super::info::print(&drive.info(a).await?, json),
        Common::Backup(a) => {
            let mut c = drive.keeper()?;
            let stop = Interrupt::install("the backup file was not written");
            backup::backup(&mut c, &a.out, a.overwrite, json, &stop).await?;
            D::kept(&c);
            Ok(())
        }
        Common::Restore(a) => {
            let mut c = drive.keeper()?;
            if !a.dry_run {
                D::before_restore(&mut c).await;
            }
            let stop = Interrupt::install(
                "the drive may be half restored; run the same restore again to finish it",
            );
            let r = backup::restore(&mut c, &a.file, a.options(), json, &stop).await;
            D::kept(&c);
            r
        }
    }
}

/// `write`: the value checked (a rounded one said), sent where the family says, through the one
/// write path, and the value as read back.
async fn write<D: Drive>(
    drive: &mut D,
    a: &WriteArgs<D::Selector, D::Confirm>,
    json: bool,
) -> Result<()> {
    let v = a.value()?;
    if let (Some(x), Some(p)) = (v.rounded_from, v.target.param) {
        errln!(
            "drivectl: note: {} cannot hold {x} exactly; writing the nearest value it takes, {}",
            p.label(),
            physical_text(p, v.raw)
        );
    }
    let mut request = WriteRequest {
        target: v.target,
        raw: v.raw,
        persistence: if a.volatile {
            Persistence::Volatile
        } else {
            Persistence::NonVolatile
        },
        force: a.force,
    };
    match drive.writer(a, &mut request, json).await? {
        Writer::Sent => Ok(()),
        Writer::To {
            mut client,
            yes,
            note,
        } => {
            let done = write::write_checked(&mut client, &request, yes).await?;
            if let Some(note) = note {
                errln!("drivectl: note: {note}");
            }
            write::print_written(&request.target, &done, json)
        }
    }
}
