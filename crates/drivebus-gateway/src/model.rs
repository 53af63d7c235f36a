//! What flows between the gateway's tasks: bus tasks report [`Update`]s to the MQTT task, the
//! MQTT task hands [`SetRequest`]s to a bus task and gets a [`SetOutcome`] back.
//!
//! Drives and points are named by their indices in the [`Plant`]
//! (`bus`, `drive`, `point`), so nothing is allocated per value on the way.

use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, SystemTime};

use tokio::sync::{mpsc, oneshot};

use crate::config::Plant;

/// Index of a bus in the plant.
pub type BusIx = usize;
/// Index of a drive in its bus.
pub type DriveIx = usize;
/// Index of a point (parameter) in its drive.
pub type PointIx = usize;

/// A bus task's index in the plant, which a reload may change while the task runs on (a bus
/// whose settings did not change keeps running when another before it is removed). The task
/// reads it each time it reports; the gateway changes it in the same step that sends the
/// [`Update::Reconfigured`] after which the new index holds.
#[derive(Debug, Clone, Default)]
pub struct BusSlot(Arc<AtomicUsize>);

impl BusSlot {
    /// A slot holding `ix`.
    pub fn new(ix: BusIx) -> BusSlot {
        BusSlot(Arc::new(AtomicUsize::new(ix)))
    }

    /// The bus's index now.
    pub fn get(&self) -> BusIx {
        self.0.load(Ordering::Relaxed)
    }

    /// Move the bus to index `ix` (the gateway, at a reload).
    pub fn set(&self, ix: BusIx) {
        self.0.store(ix, Ordering::Relaxed);
    }
}

/// A reloaded config taking effect ([`Update::Reconfigured`]): every update before it names
/// the old plant's buses, every update after it the new plant's.
#[derive(Debug)]
pub struct Reconfig {
    /// The config's generation: 1 at the start, one more at each reload that took effect.
    pub generation: u64,
    /// The new plant.
    pub plant: Arc<Plant>,
    /// For each bus of the old plant, its index in the new one where it keeps running (its
    /// settings did not change: its drives, points and their indices are the same); `None`
    /// for a bus removed or restarted with new settings.
    pub kept: Vec<Option<BusIx>>,
    /// The writes' way to each bus task of the new plant.
    pub sets: Vec<mpsc::Sender<SetRequest>>,
    /// The page's way to each bus task of the new plant.
    pub asks: Vec<mpsc::Sender<Ask>>,
    /// The JSON topics' broker connection changed (its settings or files): the publisher
    /// stops the old one and starts this one. Taken once.
    pub json: std::sync::Mutex<Option<crate::mqtt::Mqtt>>,
    /// The same for the Sparkplug connection.
    pub sparkplug: std::sync::Mutex<Option<crate::sparkplug::Sparkplug>>,
}

impl Reconfig {
    /// Where bus `old` of the old plant is in the new one (`None`: not running on).
    pub fn kept(&self, old: BusIx) -> Option<BusIx> {
        self.kept.get(old).copied().flatten()
    }
}

/// The running config as the gateway's status topic tells it: which file, which generation,
/// since when, and how the last reload went.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ConfigStatus {
    /// The file it was read from (`None`: given by a program, not read from a file).
    pub file: Option<String>,
    /// 1 at the start, one more at each reload that took effect.
    pub generation: u64,
    /// When the running config took effect (ms since the Unix epoch).
    pub loaded: u64,
    /// The last reload asked for: when (ms) and, when it did not take effect, why.
    pub last_reload: Option<(u64, Option<String>)>,
}

/// A drive's state as the gateway sees it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum DriveStatus {
    /// Answering.
    Online,
    /// Did not answer (after the bus's retries); polled again after a back-off.
    Timeout,
    /// Answering, in fault: the decoded fault text.
    Fault(String),
}

impl DriveStatus {
    /// The `state` field of the status topic.
    pub fn state(&self) -> &'static str {
        match self {
            DriveStatus::Online => "online",
            DriveStatus::Timeout => "timeout",
            DriveStatus::Fault(_) => "fault",
        }
    }
}

/// A bus's figures since the gateway started (published on the bus status topic and as
/// metrics).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BusFigures {
    /// Share of the elapsed time the wire was busy with the gateway's transactions (0–1),
    /// from the wire time of every transaction.
    pub utilisation: f64,
    /// Share the configured polls ask for (0–1; above 1 the polls are stretched).
    pub demand: f64,
    /// Transactions done (answered or not).
    pub transactions: u64,
    /// Transactions without an answer after all attempts.
    pub timeouts: u64,
    /// Repeated attempts.
    pub retries: u64,
    /// Polls that started later than one period after they were due.
    pub late_polls: u64,
}

/// What a bus task reports.
#[derive(Debug, Clone)]
pub enum Update {
    /// A parameter's value was read.
    Value {
        /// Bus.
        bus: BusIx,
        /// Drive.
        drive: DriveIx,
        /// Point.
        point: PointIx,
        /// Raw value from the drive.
        raw: i64,
        /// When it was read.
        at: SystemTime,
    },
    /// Process input words were exchanged.
    ProcessData {
        /// Bus.
        bus: BusIx,
        /// Drive.
        drive: DriveIx,
        /// Input words, as many as configured out words (USS: as the telegram has).
        words: Vec<u16>,
        /// When.
        at: SystemTime,
    },
    /// A drive's status changed.
    Status {
        /// Bus.
        bus: BusIx,
        /// Drive.
        drive: DriveIx,
        /// New status.
        status: DriveStatus,
        /// When.
        at: SystemTime,
    },
    /// A bus's figures (every few seconds).
    Figures {
        /// Bus.
        bus: BusIx,
        /// The figures.
        figures: BusFigures,
    },
    /// A reloaded config takes effect: the updates after this one name the new plant's
    /// buses, drives and points.
    Reconfigured(Arc<Reconfig>),
}

/// A write asked for on `…/set`, checked against the config (writable) but not yet against
/// the drive's table (the bus task runs the write guard).
#[derive(Debug)]
pub struct SetRequest {
    /// Drive.
    pub drive: DriveIx,
    /// Point.
    pub point: PointIx,
    /// The value as sent.
    pub value: SetValue,
    /// When the gateway received it (the bus task refuses it once older than
    /// `max_set_age`).
    pub received: tokio::time::Instant,
    /// How long it may wait for the bus.
    pub max_age: Duration,
    /// The answer.
    pub reply: oneshot::Sender<SetOutcome>,
}

/// The value of a `set`.
#[derive(Debug, Clone, PartialEq)]
pub enum SetValue {
    /// `{"value": …}`: in the parameter's unit (number or value-list text).
    Value(serde_json::Value),
    /// `{"raw": …}`: the raw bus value.
    Raw(i64),
}

/// The answer to a [`SetRequest`].
#[derive(Debug, Clone, PartialEq)]
pub enum SetOutcome {
    /// Written; the value read back.
    Written {
        /// Raw value read back after the write.
        raw: i64,
        /// The drive holds another value than the one sent (it rounded or limited it): the raw
        /// value sent, and what that means for a person (`Written::differs` of the write path).
        differs: Option<(i64, String)>,
    },
    /// Refused before anything was sent (guard, not writable, stale, drive offline).
    Refused {
        /// Machine-readable reason: `not_writable`, `range`, `access`, `value_list`,
        /// `width`, `wear`, `stale`, `retained`, `offline`, `expired`, `bad_request`.
        reason: &'static str,
        /// For a person.
        message: String,
    },
    /// The drive refused it (its answer, decoded).
    DeviceRefused {
        /// The drive's answer.
        message: String,
    },
    /// The bus failed during the write: whether it was written is unknown.
    LinkFailed {
        /// What failed.
        message: String,
    },
}

impl SetOutcome {
    /// The outcome as the set metrics count it: `written`, the refusal's reason,
    /// `device_refused` or `link_failed`.
    pub fn label(&self) -> &'static str {
        match self {
            SetOutcome::Written { .. } => "written",
            SetOutcome::Refused { reason, .. } => reason,
            SetOutcome::DeviceRefused { .. } => "device_refused",
            SetOutcome::LinkFailed { .. } => "link_failed",
        }
    }
}

/// A transaction the page asks a bus task to run for one of its drives (a read on demand, a
/// guarded write's steps, a backup's reads): taken between the polls as a write is, with its
/// own wire time, and refused like a write when the drive is offline or the bus too busy
/// ([`AskOp`]).
#[derive(Debug)]
pub struct Ask {
    /// Drive.
    pub drive: DriveIx,
    /// What to do.
    pub op: AskOp,
    /// When it was asked (refused once older than `max_age` before it ran).
    pub received: tokio::time::Instant,
    /// How long it may wait for the bus.
    pub max_age: Duration,
    /// The answer.
    pub reply: oneshot::Sender<Result<Answer, drive_client::ClientError>>,
}

/// What an [`Ask`] asks for: one [`ParamClient`](drive_client::ParamClient) call on the drive's
/// client.
#[derive(Debug, Clone)]
pub enum AskOp {
    /// What the drive's client knows without asking the drive (no transaction):
    /// [`Answer::Facts`].
    Facts,
    /// What writing `raw` to the link setting `target` would do to the link (no transaction):
    /// [`Answer::Text`].
    LinkChange(drive_client::target::Target, i64),
    /// The drive's key for the EEPROM-wear log: [`Answer::Text`].
    DriveKey,
    /// A read: [`Answer::Raw`].
    Read(drive_client::target::Target),
    /// A write (the guard has passed it): [`Answer::Done`].
    Write(
        drive_client::target::Target,
        i64,
        drive_profile::Persistence,
    ),
    /// The drive's identification for a backup: [`Answer::Identity`].
    Identify,
    /// The page's control of the drive over process data (no transaction of its own: it
    /// changes the words of the drive's next cycles).
    Control(ControlOp),
}

/// What the page asks of a drive it controls over process data ([`AskOp::Control`]); refused
/// as [`ClientError::Request`](drive_client::ClientError::Request) with the reason.
#[derive(Debug, Clone)]
pub enum ControlOp {
    /// Take the drive for `who`: the page drives it for as long as `lease` has a receiver
    /// (the page's open answer, which hears every cycle's state on it). Answered with the
    /// lease's number ([`Answer::Lease`]); refused when another page drives it.
    Take {
        /// The user, for the action log and for a page refused.
        who: crate::ui::auth::Who,
        /// The lease: the bus task sends the drive's state on it each cycle, and stops the
        /// drive at the next cycle once it has no receiver.
        lease: std::sync::Arc<tokio::sync::watch::Sender<serde_json::Value>>,
    },
    /// The page holding lease number `lease` is still there (it says so every second; a
    /// lease not heard of for [`LEASE_SILENCE`] ends as if its page had gone: a connection
    /// lost without a word ends no TCP stream for minutes). Answered at once ([`Answer::Done`]).
    Alive {
        /// The lease's number.
        lease: u64,
    },
    /// Run `command` for the page holding lease number `lease`: answered after the cycle that
    /// sent it ([`Answer::Text`]: what was sent and what the drive answered).
    Command {
        /// The lease's number.
        lease: u64,
        /// What to send.
        command: PageCommand,
    },
}

/// How long a lease may go unheard of ([`ControlOp::Alive`], or a command) before the drive
/// is stopped as if its page had gone.
pub const LEASE_SILENCE: Duration = Duration::from_secs(5);

/// What a page sends a drive it controls, in the family's words.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PageCommand {
    /// Enable at the setpoint (already the family's setpoint word: SEW 0.2 1/min per digit,
    /// NORD SW1 with 4000h = 100 %); a new setpoint while enabled is another `Enable`.
    Enable {
        /// The setpoint word.
        word: u16,
    },
    /// Stop on the ramp (SEW control word "stop", NORD STW shutdown 047Eh).
    Stop,
}

/// What a drive's client knows without a transaction.
#[derive(Debug, Clone, Copy)]
pub struct Facts {
    /// The family.
    pub family: drive_profile::Family,
    /// Its link settings (address, baud rate, timeouts of the bus the gateway talks over).
    pub link_settings: &'static [u16],
    /// What a restore never writes.
    pub not_restored: &'static [u16],
    /// What is known of the drive beyond its table.
    pub device: drive_client::meaning::Device,
}

/// The answer to an [`Ask`].
#[derive(Debug, Clone)]
pub enum Answer {
    /// [`AskOp::Facts`].
    Facts(Facts),
    /// [`AskOp::LinkChange`], [`AskOp::DriveKey`].
    Text(String),
    /// [`AskOp::Read`].
    Raw(i64),
    /// [`AskOp::Write`].
    Done,
    /// [`AskOp::Identify`].
    Identity(serde_json::Map<String, serde_json::Value>),
    /// [`ControlOp::Take`]: the lease's number.
    Lease(u64),
}
