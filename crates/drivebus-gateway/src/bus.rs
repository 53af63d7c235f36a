//! A bus as the gateway drives it: [`BusAccess`] is what each protocol gives (its drives'
//! parameter clients, process data, fault status and the wire time of its transactions), and
//! [`BusContext`] is what the gateway gives a bus task.

use std::sync::Arc;
use std::time::Duration;

use tokio::sync::mpsc;

use super::config::Bus;
use super::metrics::Metrics;
use super::model::{Ask, BusSlot, PageCommand, SetRequest, Update};
use drive_client::{ClientError, ParamClient};

/// The kinds of transaction a bus task runs, for wire time and metrics.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Op {
    /// One parameter read.
    Read,
    /// One parameter write (without the read-back, which is a [`Op::Read`]).
    Write,
    /// One process-data exchange of `n` output words.
    ProcessData(u8),
}

impl Op {
    /// The metrics label.
    pub fn label(self) -> &'static str {
        match self {
            Op::Read => "read",
            Op::Write => "write",
            Op::ProcessData(_) => "process_data",
        }
    }
}

/// What the bus's link counted since the last [`BusAccess::take_tally`].
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct LinkTally {
    /// Attempts repeated after a failed one.
    pub retries: u64,
    /// Received frames refused, by reason (`checksum`, `framing`, `wrong_address`, …).
    pub rejected: Vec<(&'static str, u64)>,
}

/// One bus's way to its drives: what a protocol gives the gateway. One value owns the bus
/// (its port and master); the gateway runs one transaction at a time on it.
pub trait BusAccess {
    /// The tool layer's client of one drive (read, guarded write, identify).
    type Client<'a>: ParamClient
    where
        Self: 'a;

    /// The drive at `address` as a [`ParamClient`].
    fn client(&mut self, address: u8) -> Self::Client<'_>;

    /// The client the page's requests use: any parameter of the table, also one whose access
    /// width the manual does not give and the config does not say (a Bonfiglioli client finds
    /// it by trying, as `drivectl … backup` does). The polls' client otherwise.
    fn page_client(&mut self, address: u8) -> Self::Client<'_> {
        self.client(address)
    }

    /// Exchange process data with the drive at `address`: send `out`, return its input
    /// words.
    async fn process_data(&mut self, address: u8, out: &[u16]) -> Result<Vec<u16>, ClientError>;

    /// Stop the drive the gateway controls over process data, as `drivectl pd` does at its
    /// end: one exchange of `out` with the control word set to "stop on the ramp" (SEW: the
    /// low byte of every PO word P870–P872 make a control word, read from the drive first,
    /// `0x02`; NORD: STW `0x047E`). Its input words, or `Ok(Err(why))` when nothing was sent
    /// (no PO word is a control word; no process data on this protocol).
    async fn stop_process_data(
        &mut self,
        address: u8,
        out: &[u16],
    ) -> Result<Result<Vec<u16>, String>, ClientError>;

    /// What a person should know before the gateway exchanges process data `out` every
    /// `period` with the drive at `address` (a few parameter reads): the drive ignores process
    /// output, no output word is a control word, its bus timeout is off (it would keep running
    /// if the gateway went quiet), or the period is at or above that timeout (the drive would
    /// trip between two cycles). Empty where all is well or the family has nothing to check.
    /// It also learns where the drive's input words carry its status (see
    /// [`BusAccess::fault_in_inputs`]).
    async fn process_data_warnings(
        &mut self,
        _address: u8,
        _out: &[u16],
        _period: Duration,
    ) -> Result<Vec<String>, ClientError> {
        Ok(Vec::new())
    }

    /// What a person should know about a drive that watches its link for requests (Bonfiglioli
    /// 413 watchdog: no valid request for that long trips F2010) when the gateway's requests
    /// to it may be `gap` apart (its shortest period, the status reads included): a watchdog
    /// at or below the gap trips the drive between two. Empty where all is well or the family
    /// has no such watchdog.
    async fn watchdog_warnings(
        &mut self,
        _address: u8,
        _gap: Duration,
    ) -> Result<Vec<String>, ClientError> {
        Ok(Vec::new())
    }

    /// The drive's fault as its process input words `inputs` show it: `Some(None)` no fault,
    /// `Some(Some(text))` the fault (as [`BusAccess::fault`] names it), `None` where the inputs
    /// carry no status word (then only the status reads tell).
    fn fault_in_inputs(&self, _address: u8, _inputs: &[u16]) -> Option<Option<String>> {
        None
    }

    /// The process output words that carry the page's `command` to the drive at `address` in
    /// place of the config's `out` (SEW: the command in every control word slot and the speed
    /// setpoint in the speed slot, as P870–P872 describe them, read once; NORD: STW toward
    /// "operation enabled" step by step from the status word in `inputs`, the last exchange's
    /// input words, after `sent`, its output words; SW1 the setpoint). `Ok(Err(why))` when the
    /// drive cannot be driven so (no control word, no setpoint word, no process data).
    async fn control_words(
        &mut self,
        _address: u8,
        _out: &[u16],
        _command: PageCommand,
        _sent: &[u16],
        _inputs: &[u16],
    ) -> Result<Result<Vec<u16>, String>, ClientError> {
        Ok(Err(
            "the gateway has no process data control for this bus".to_owned()
        ))
    }

    /// The drive's state as its process input words show it, in words for a person (`None`
    /// where they carry no status word).
    fn state_in_inputs(&self, _address: u8, _inputs: &[u16]) -> Option<String> {
        None
    }

    /// The drive's fault, decoded (`None`: no fault). One transaction.
    async fn fault(&mut self, address: u8) -> Result<Option<String>, ClientError>;

    /// The time one transaction of `op` occupies the wire: request, the drive's answer and
    /// the pauses the protocol requires, at the bus's line settings (no timeouts, no retries).
    fn wire_time(&self, op: Op) -> Duration;

    /// What the link counted since the last call.
    fn take_tally(&mut self) -> LinkTally;
}

/// What the gateway asks of a running bus task ([`BusContext::shutdown`]).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub enum Stop {
    /// Keep running.
    #[default]
    Run,
    /// The gateway stops: the task finishes its transaction, sends every drive it controls
    /// over process data its stop, and returns.
    Gateway,
    /// A reloaded config removes the bus or runs it with other settings: the task finishes its
    /// transaction and returns. The drives at the addresses in `continued` are controlled over
    /// process data on the same line by the new config, whose task sends their next cycle: they
    /// keep their last words until then. Every other drive it controls gets its stop.
    Retire {
        /// Addresses whose process data the new config carries on.
        continued: Vec<u8>,
    },
}

/// What a bus task gets from the gateway.
#[derive(Debug)]
pub struct BusContext {
    /// Leaves [`Stop::Run`] when the gateway stops or a reload retires the bus: the task stops
    /// the drives it controls over process data (as [`Stop`] says) and returns.
    pub shutdown: tokio::sync::watch::Receiver<Stop>,
    /// The bus's index in the plant (a reload may move it).
    pub ix: BusSlot,
    /// Its configuration.
    pub bus: Bus,
    /// Where it reports values, statuses and figures.
    pub updates: mpsc::Sender<Update>,
    /// Writes for its drives.
    pub sets: mpsc::Receiver<SetRequest>,
    /// The page's requests for its drives ([`BusContext::no_asks`] without a page).
    pub asks: mpsc::Receiver<Ask>,
    /// The metrics registry.
    pub metrics: Arc<Metrics>,
    /// Changes when the gateway asks every bus for its drives' statuses again (a reload that
    /// started a new publisher or page, which has seen none of them: a status is reported only
    /// when it changes).
    pub announce: tokio::sync::watch::Receiver<u64>,
}

impl BusContext {
    /// A receiver of asks that never brings one (a bus without the page).
    pub fn no_asks() -> mpsc::Receiver<Ask> {
        mpsc::channel(1).1
    }

    /// An announce request that never comes.
    pub fn no_announce() -> tokio::sync::watch::Receiver<u64> {
        tokio::sync::watch::channel(0).1
    }
}
