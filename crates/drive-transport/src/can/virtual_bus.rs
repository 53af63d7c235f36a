//! An in-memory CAN bus: any number of nodes, arbitration by identifier, frame times from the
//! bit rate with exact bit stuffing, bounded receive queues and seeded fault injection.
//!
//! [`VirtualBus::new`] makes a bus, [`VirtualBus::node`] attaches a [`VirtualNode`], which is a
//! [`CanIo`]. Every node receives every frame sent by the *other* nodes; its own frames only
//! with [`BusConfig::echo`] (SocketCAN does not deliver a socket's own frames to it by default,
//! and neither does this bus).
//!
//! # Time model (timing on, the default)
//!
//! Time is `drive_core::rt::time`'s clock (tokio's, so tests run on the paused clock, or a
//! `VirtualClock`'s). A frame handed to
//! [`CanIo::poll_send`] is *pending* from that instant. The bus is a single wire:
//!
//! - when it is idle, the pending frames compete; the lowest arbitration key wins: the
//!   identifier's first 11 bits, then a standard frame before an extended one with the same
//!   base identifier (its IDE bit is dominant), then a data frame before a remote frame with the
//!   same identifier (RTR dominant); among frames with the same key (which CAN forbids) the
//!   earlier request wins, then the node attached first;
//! - frames requested at the *same* instant compete with each other, whatever order their tasks
//!   ran in: a transmission that starts at `t` is decided only once the clock has passed `t`;
//! - the winner occupies the bus for [`CanFrame::duration`] (its real length in bits, stuff
//!   bits included, intermission included); the next one starts right after;
//! - every receiver gets it with [`ReceivedFrame::at`] = the end of its last bit, exact to the
//!   nanosecond; [`CanIo::poll_send`] of the sender completes at the same instant.
//!
//! tokio's timers tick in milliseconds: a task waiting for a frame wakes at the first tick at or
//! after the frame's end and then gets every frame that has ended by then, each with its exact
//! time. Measure with the `at` stamps, not with `Instant::now()` after the wake-up.
//!
//! A node that sends again right after its previous frame completed gets its next frame
//! backdated to that frame's end (at most 1 ms, [`TIMER_RESOLUTION`]), as a controller with the
//! next frame already in its transmit buffer would: back-to-back frames from one node are
//! back-to-back on the wire despite the millisecond wake-ups. A sender that knows when its
//! frame is due says so with [`CanIo::poll_send_at`] (the serve loop of simulated drives and
//! the SBus master do): the frame competes from that instant (at most 1 ms back) instead, so
//! an answer starts when its request ended and a periodic frame keeps its period even when
//! the previous one was delayed by arbitration.
//!
//! # Untimed mode (benchmarks)
//!
//! With [`BusConfig::untimed`], a frame is delivered to every receiver the moment it is sent
//! (`at` = now) and the send completes at once: no arbitration delays, no frame times, delays
//! from fault injection ignored. It measures software overhead only.
//!
//! # Receive queues and overruns
//!
//! Each node keeps at most [`BusConfig::rx_capacity`] received frames that it has not read. A
//! frame that arrives at a full queue is discarded and counted ([`NodeStats::overruns`]), like
//! a CAN controller's receive overrun: a slow reader loses the newest frames and can see that it
//! did, the bus never grows without bound.
//!
//! # Faults
//!
//! Per frame, from one-shot faults ([`VirtualNode::inject`]) or at random ([`BusFaults`],
//! seeded with [`drive_core::SplitMix64`]):
//!
//! - **drop**: the frame takes its time on the bus but no receiver gets it (every receiver
//!   missed it); the sender's send completes normally;
//! - **corrupt**: the frame is destroyed on the wire: the receivers' CRC check fails, they send
//!   an error frame, and nobody receives it. The bus is busy for the frame up to the ACK
//!   delimiter, 6 error-flag bits, 8 error-delimiter bits and the 3-bit intermission
//!   ([`CanFrame::bits`] + 7 bits in all). Then, as every CAN controller does by default, the
//!   sender retransmits it: it competes again and receivers see it *later*, once. With
//!   [`BusFaults::one_shot`] (a controller's one-shot mode) it is not retransmitted: the frame
//!   is lost and the sender's [`CanIo::poll_send`] fails;
//! - **delay**: the sender's request reaches the bus that much later (its controller was late),
//!   so other frames may win arbitration before it.
//!
//! # End of the bus
//!
//! A node's [`CanIo::poll_recv`] returns [`io::ErrorKind::UnexpectedEof`] once no other node is
//! attached and no [`VirtualBus`] handle is left that could attach one (and it has read
//! everything it had received). A node that sends then gets [`io::ErrorKind::BrokenPipe`].

use std::collections::VecDeque;
use std::io;
use std::pin::Pin;
use std::sync::{Arc, Mutex, MutexGuard};
use std::task::{Context, Poll, Waker};
use std::time::Duration;

use drive_core::SplitMix64;
use drive_core::can::{Bitrate, CanFrame, Frame, Id};
use drive_core::rt::time::{self as rt_time, Instant, Sleep};
use drive_core::rt::{CanIo, ReceivedFrame, TIMER_RESOLUTION};

/// Bits a destroyed frame adds to its own length: error flag (6), error delimiter (8) and
/// intermission (3), minus the end of frame and intermission (10) it did not get to send.
const ERROR_FRAME_EXTRA_BITS: u32 = 6 + 8 + 3 - 10;

/// Random faults per frame; probabilities in `0.0..=1.0`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BusFaults {
    /// Seed of the deterministic generator.
    pub seed: u64,
    /// Probability that no receiver gets a frame.
    pub drop: f64,
    /// Probability that one transmission of a frame is destroyed (drawn per attempt).
    pub corrupt: f64,
    /// Probability that a frame's request reaches the bus [`BusFaults::delay_by`] late.
    pub delay: f64,
    /// How late a delayed request is.
    pub delay_by: Duration,
    /// One-shot mode: a destroyed frame is not retransmitted (lost, and the send fails).
    pub one_shot: bool,
}

impl BusFaults {
    /// No faults.
    pub const fn none() -> Self {
        BusFaults {
            seed: 0xCA11_5EED_0000_0001,
            drop: 0.0,
            corrupt: 0.0,
            delay: 0.0,
            delay_by: Duration::from_millis(1),
            one_shot: false,
        }
    }

    fn is_active(&self) -> bool {
        self.drop > 0.0 || self.corrupt > 0.0 || self.delay > 0.0
    }
}

impl Default for BusFaults {
    fn default() -> Self {
        Self::none()
    }
}

/// A one-shot fault for the next frame a node sends ([`VirtualNode::inject`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum BusFault {
    /// No receiver gets the frame.
    Drop,
    /// The frame's first transmission is destroyed (retransmitted unless one-shot mode).
    Corrupt,
    /// The frame's request reaches the bus this much later.
    Delay(Duration),
}

/// Configuration of a [`VirtualBus`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BusConfig {
    /// The bit rate: frame times.
    pub bitrate: Bitrate,
    /// Model frame times and arbitration (`true`) or deliver at once (benchmarks).
    pub timing: bool,
    /// Whether a node also receives its own frames.
    pub echo: bool,
    /// Unread frames a node keeps before further ones are overruns.
    pub rx_capacity: usize,
    /// Random faults.
    pub faults: BusFaults,
}

impl BusConfig {
    /// Timing on at `bitrate`, no echo, 256 frames per receive queue, no faults.
    pub const fn new(bitrate: Bitrate) -> Self {
        BusConfig {
            bitrate,
            timing: true,
            echo: false,
            rx_capacity: 256,
            faults: BusFaults::none(),
        }
    }

    /// Untimed (benchmark) mode: frames are delivered when sent.
    pub const fn untimed() -> Self {
        BusConfig {
            timing: false,
            ..BusConfig::new(Bitrate::K500)
        }
    }

    /// The same configuration with these random faults.
    pub const fn with_faults(self, faults: BusFaults) -> Self {
        BusConfig { faults, ..self }
    }
}

/// Counters of one node.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
pub struct NodeStats {
    /// Frames this node sent (completed sends).
    pub sent: u64,
    /// Frames this node received (queued for it).
    pub received: u64,
    /// Frames discarded because this node's receive queue was full.
    pub overruns: u64,
    /// Frames of this node no receiver got (drop faults).
    pub dropped: u64,
    /// Transmissions of this node destroyed on the wire (corrupt faults).
    pub corrupted: u64,
    /// Frames of this node abandoned after a destroyed transmission (one-shot mode).
    pub abandoned: u64,
    /// Frames of this node whose request was delayed.
    pub delayed: u64,
}

/// What happened to a node's frame in flight.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum TxState {
    /// Waiting for the bus (or for arbitration at `requested`).
    Pending,
    /// On the wire, ends at the instant.
    OnWire(Instant),
    /// Destroyed and not retransmitted (one-shot mode); known at the instant.
    Abandoned(Instant),
}

#[derive(Debug, Clone, Copy)]
struct Tx {
    frame: CanFrame,
    requested: Instant,
    drop: bool,
    corrupt_first: bool,
    attempts: u32,
    state: TxState,
}

#[derive(Debug)]
struct NodeState {
    rx: VecDeque<ReceivedFrame>,
    tx: Option<Tx>,
    /// End of the last frame this node completed: backdating of the next request.
    last_end: Option<Instant>,
    one_shot: VecDeque<BusFault>,
    stats: NodeStats,
    rx_waker: Option<Waker>,
    tx_waker: Option<Waker>,
}

impl NodeState {
    fn new() -> Self {
        NodeState {
            rx: VecDeque::new(),
            tx: None,
            last_end: None,
            one_shot: VecDeque::new(),
            stats: NodeStats::default(),
            rx_waker: None,
            tx_waker: None,
        }
    }
}

#[derive(Debug)]
struct BusState {
    config: BusConfig,
    nodes: Vec<Option<NodeState>>,
    handles: usize,
    bus_free: Option<Instant>,
    rng: SplitMix64,
    faults_active: bool,
    frames: u64,
}

/// The arbitration key: lower wins (see the module docs).
fn arbitration_key(frame: &CanFrame) -> u64 {
    let (base, ide, ext) = match frame.id() {
        Id::Standard(s) => (u64::from(s.as_raw()), 0u64, 0u64),
        Id::Extended(e) => {
            let raw = u64::from(e.as_raw());
            (raw >> 18, 1, raw & 0x3FFFF)
        }
    };
    // Standard: id(11) RTR IDE. Extended: id(11) SRR(1) IDE(1) ext(18) RTR. A standard
    // frame's RTR sits where an extended frame's recessive SRR is.
    let rtr = u64::from(frame.is_remote_frame());
    if ide == 0 {
        (base << 21) | (rtr << 20)
    } else {
        (base << 21) | (1 << 20) | (1 << 19) | (ext << 1) | rtr
    }
}

impl BusState {
    fn others_present(&self, me: usize) -> bool {
        self.handles > 0
            || self
                .nodes
                .iter()
                .enumerate()
                .any(|(i, n)| i != me && n.is_some())
    }

    /// Decides every transmission that starts before `now` (see the module docs).
    fn settle(&mut self, now: Instant) {
        loop {
            let Some(first_request) = self
                .nodes
                .iter()
                .flatten()
                .filter_map(|n| n.tx.filter(|t| t.state == TxState::Pending))
                .map(|t| t.requested)
                .min()
            else {
                return;
            };
            let start = self
                .bus_free
                .map_or(first_request, |f| f.max(first_request));
            if start >= now {
                return;
            }
            let mut winner: Option<(u64, Instant, usize)> = None;
            for (i, node) in self.nodes.iter().enumerate() {
                let Some(tx) = node.as_ref().and_then(|n| n.tx) else {
                    continue;
                };
                if tx.state != TxState::Pending || tx.requested > start {
                    continue;
                }
                let key = (arbitration_key(&tx.frame), tx.requested, i);
                if winner.is_none_or(|w| key < w) {
                    winner = Some(key);
                }
            }
            let Some((_, _, index)) = winner else {
                return;
            };
            self.transmit(index, start);
        }
    }

    /// Puts node `index`'s pending frame on the wire at `start`.
    fn transmit(&mut self, index: usize, start: Instant) {
        let bitrate = self.config.bitrate;
        let corrupt_random = self.faults_active && self.rng.chance(self.config.faults.corrupt);
        let one_shot = self.config.faults.one_shot;
        let Some(Some(node)) = self.nodes.get_mut(index) else {
            return;
        };
        let Some(tx) = node.tx.as_mut() else {
            return;
        };
        let corrupt = corrupt_random || (tx.corrupt_first && tx.attempts == 0);
        tx.attempts = tx.attempts.saturating_add(1);
        if corrupt {
            let end = start + bitrate.bits_duration(tx.frame.bits() + ERROR_FRAME_EXTRA_BITS);
            node.stats.corrupted += 1;
            self.bus_free = Some(end);
            if one_shot {
                tx.state = TxState::Abandoned(end);
                node.stats.abandoned += 1;
            } else {
                // Automatic retransmission: it competes again when the bus is idle.
                tx.requested = end;
            }
            self.wake_all();
            return;
        }
        let end = start + tx.frame.duration(bitrate);
        tx.state = TxState::OnWire(end);
        let frame = tx.frame;
        let dropped = tx.drop;
        self.bus_free = Some(end);
        self.deliver(index, frame, end, dropped);
    }

    /// Queues `frame` (ended at `at`) for every receiver of sender `from`.
    fn deliver(&mut self, from: usize, frame: CanFrame, at: Instant, dropped: bool) {
        self.frames += 1;
        if dropped {
            if let Some(Some(sender)) = self.nodes.get_mut(from) {
                sender.stats.dropped += 1;
            }
        } else {
            let echo = self.config.echo;
            let capacity = self.config.rx_capacity;
            for (i, node) in self.nodes.iter_mut().enumerate() {
                let Some(node) = node else { continue };
                if i == from && !echo {
                    continue;
                }
                if node.rx.len() >= capacity {
                    node.stats.overruns += 1;
                } else {
                    node.rx.push_back(ReceivedFrame { frame, at });
                    node.stats.received += 1;
                }
            }
        }
        self.wake_all();
    }

    fn wake_all(&mut self) {
        for node in self.nodes.iter_mut().flatten() {
            if let Some(w) = node.rx_waker.take() {
                w.wake();
            }
            if let Some(w) = node.tx_waker.take() {
                w.wake();
            }
        }
    }

    /// When the next transmission can be decided (a start not yet passed).
    fn next_decision(&self) -> Option<Instant> {
        let first = self
            .nodes
            .iter()
            .flatten()
            .filter_map(|n| n.tx.filter(|t| t.state == TxState::Pending))
            .map(|t| t.requested)
            .min()?;
        Some(self.bus_free.map_or(first, |f| f.max(first)))
    }
}

fn lock(state: &Mutex<BusState>) -> MutexGuard<'_, BusState> {
    // A panic elsewhere while holding the lock leaves plain queues behind; keep going.
    state
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// An in-memory CAN bus (see the module docs). Cloning gives another handle to the same bus;
/// the bus ends for its nodes when every handle and every other node is gone.
#[derive(Debug)]
pub struct VirtualBus {
    state: Arc<Mutex<BusState>>,
}

impl VirtualBus {
    /// A bus at `bitrate` with timing on, no echo and no faults.
    pub fn new(bitrate: Bitrate) -> Self {
        Self::with_config(BusConfig::new(bitrate))
    }

    /// A bus with `config`.
    pub fn with_config(config: BusConfig) -> Self {
        VirtualBus {
            state: Arc::new(Mutex::new(BusState {
                config,
                nodes: Vec::new(),
                handles: 1,
                bus_free: None,
                rng: SplitMix64::new(config.faults.seed),
                faults_active: config.faults.is_active(),
                frames: 0,
            })),
        }
    }

    /// Attaches a new node.
    pub fn node(&self) -> VirtualNode {
        let mut state = lock(&self.state);
        let index = match state.nodes.iter().position(Option::is_none) {
            Some(free) => free,
            None => {
                state.nodes.push(None);
                state.nodes.len() - 1
            }
        };
        if let Some(slot) = state.nodes.get_mut(index) {
            *slot = Some(NodeState::new());
        }
        VirtualNode {
            state: self.state.clone(),
            index,
            rx_sleep: None,
            tx_sleep: None,
        }
    }

    /// The configuration.
    pub fn config(&self) -> BusConfig {
        lock(&self.state).config
    }

    /// Replaces the random faults (the random stream continues).
    pub fn set_faults(&self, faults: BusFaults) {
        let mut state = lock(&self.state);
        state.config.faults = faults;
        state.faults_active = faults.is_active();
    }

    /// Frames that went over the bus so far (dropped ones included, destroyed ones not).
    pub fn frames(&self) -> u64 {
        lock(&self.state).frames
    }

    /// Nodes attached now.
    pub fn node_count(&self) -> usize {
        lock(&self.state).nodes.iter().flatten().count()
    }
}

impl Clone for VirtualBus {
    fn clone(&self) -> Self {
        lock(&self.state).handles += 1;
        VirtualBus {
            state: self.state.clone(),
        }
    }
}

impl Drop for VirtualBus {
    fn drop(&mut self) {
        let mut state = lock(&self.state);
        state.handles = state.handles.saturating_sub(1);
        state.wake_all();
    }
}

/// One node of a [`VirtualBus`]: a [`CanIo`]. Dropping it detaches it (a frame it had in
/// flight that has not started is withdrawn).
#[derive(Debug)]
pub struct VirtualNode {
    state: Arc<Mutex<BusState>>,
    index: usize,
    rx_sleep: Option<Sleep>,
    tx_sleep: Option<Sleep>,
}

impl VirtualNode {
    fn with_node<T>(&self, f: impl FnOnce(&mut NodeState) -> T) -> Option<T> {
        let mut state = lock(&self.state);
        state
            .nodes
            .get_mut(self.index)
            .and_then(Option::as_mut)
            .map(f)
    }

    /// Queues a one-shot fault for the frames this node sends next (the first fault for the
    /// next frame, the second for the one after). A frame with a one-shot fault gets no random
    /// fault of the same kind.
    pub fn inject(&self, fault: BusFault) {
        self.with_node(|n| n.one_shot.push_back(fault));
    }

    /// This node's counters.
    pub fn stats(&self) -> NodeStats {
        self.with_node(|n| n.stats).unwrap_or_default()
    }

    /// Frames received and not yet read.
    pub fn pending_rx(&self) -> usize {
        self.with_node(|n| n.rx.len()).unwrap_or(0)
    }

    /// Registers `frame` as this node's frame in flight; `start`: the instant its sender
    /// scheduled it ([`CanIo::poll_send_at`]).
    fn request(
        state: &mut BusState,
        index: usize,
        frame: &CanFrame,
        now: Instant,
        start: Option<Instant>,
    ) {
        let faults = state.config.faults;
        let active = state.faults_active;
        let mut drop = false;
        let mut corrupt_first = false;
        let mut delay = Duration::ZERO;
        let one_shot = state
            .nodes
            .get_mut(index)
            .and_then(Option::as_mut)
            .and_then(|n| n.one_shot.pop_front());
        match one_shot {
            Some(BusFault::Drop) => drop = true,
            Some(BusFault::Corrupt) => corrupt_first = true,
            Some(BusFault::Delay(d)) => delay = d,
            None => {
                if active {
                    drop = state.rng.chance(faults.drop);
                    if state.rng.chance(faults.delay) {
                        delay = faults.delay_by;
                    }
                }
            }
        }
        let Some(Some(node)) = state.nodes.get_mut(index) else {
            return;
        };
        // Backdate a request right after this node's own completed frame (module docs).
        let limit = now.checked_sub(TIMER_RESOLUTION).unwrap_or(now);
        let requested = match start {
            // Where the sender scheduled it, at most the timer resolution back.
            Some(start) => start.clamp(limit, now),
            None => node
                .last_end
                .filter(|end| *end >= limit && *end <= now)
                .unwrap_or(now),
        } + delay;
        if !delay.is_zero() {
            node.stats.delayed += 1;
        }
        node.tx = Some(Tx {
            frame: *frame,
            requested,
            drop,
            corrupt_first,
            attempts: 0,
            state: TxState::Pending,
        });
    }

    fn poll_send_untimed(
        state: &mut BusState,
        index: usize,
        frame: &CanFrame,
    ) -> Poll<io::Result<()>> {
        let mut drop = false;
        let mut corrupt = false;
        let one_shot = state
            .nodes
            .get_mut(index)
            .and_then(Option::as_mut)
            .and_then(|n| n.one_shot.pop_front());
        match one_shot {
            Some(BusFault::Drop) => drop = true,
            Some(BusFault::Corrupt) => corrupt = true,
            Some(BusFault::Delay(_)) => {}
            None => {
                if state.faults_active {
                    let faults = state.config.faults;
                    drop = state.rng.chance(faults.drop);
                    corrupt = state.rng.chance(faults.corrupt);
                }
            }
        }
        if corrupt {
            let one_shot = state.config.faults.one_shot;
            if let Some(Some(node)) = state.nodes.get_mut(index) {
                node.stats.corrupted += 1;
                if one_shot {
                    node.stats.abandoned += 1;
                }
            }
            if one_shot {
                return Poll::Ready(Err(destroyed_error()));
            }
        }
        let now = rt_time::now();
        state.deliver(index, *frame, now, drop);
        if let Some(Some(node)) = state.nodes.get_mut(index) {
            node.stats.sent += 1;
        }
        Poll::Ready(Ok(()))
    }
}

fn destroyed_error() -> io::Error {
    io::Error::other(
        "the frame was destroyed on the virtual bus and not retransmitted (one-shot mode)",
    )
}

fn eof() -> io::Error {
    io::Error::new(
        io::ErrorKind::UnexpectedEof,
        "the virtual CAN bus has ended: no other node is attached",
    )
}

/// One nanosecond after `t`: a decision at `t` is taken once the clock has passed it.
fn just_after(t: Instant) -> Instant {
    t + Duration::from_nanos(1)
}

impl CanIo for VirtualNode {
    fn poll_recv(&mut self, cx: &mut Context<'_>) -> Poll<io::Result<ReceivedFrame>> {
        loop {
            let mut state = lock(&self.state);
            let now = rt_time::now();
            if state.config.timing {
                state.settle(now);
            }
            let others = state.others_present(self.index);
            let next_decision = state.next_decision();
            let Some(Some(node)) = state.nodes.get_mut(self.index) else {
                return Poll::Ready(Err(eof()));
            };
            let deadline = match node.rx.front().copied() {
                Some(front) if front.at <= now => {
                    node.rx.pop_front();
                    return Poll::Ready(Ok(front));
                }
                Some(front) => Some(front.at),
                None => {
                    if !others && next_decision.is_none() {
                        return Poll::Ready(Err(eof()));
                    }
                    node.rx_waker = Some(cx.waker().clone());
                    next_decision.map(just_after)
                }
            };
            drop(state);
            match deadline {
                Some(deadline) => {
                    if poll_sleep(&mut self.rx_sleep, deadline, cx).is_pending() {
                        return Poll::Pending;
                    }
                }
                None => return Poll::Pending,
            }
        }
    }

    fn poll_send(&mut self, cx: &mut Context<'_>, frame: &CanFrame) -> Poll<io::Result<()>> {
        self.poll_send_from(cx, frame, None)
    }

    /// The frame competes for the bus from `start` (at most [`TIMER_RESOLUTION`] back)
    /// instead of the instant of the call or the end of this node's previous frame: an
    /// answer starts when its request ended, a periodic frame keeps its period.
    fn poll_send_at(
        &mut self,
        cx: &mut Context<'_>,
        frame: &CanFrame,
        start: Instant,
    ) -> Poll<io::Result<()>> {
        self.poll_send_from(cx, frame, Some(start))
    }
}

impl VirtualNode {
    fn poll_send_from(
        &mut self,
        cx: &mut Context<'_>,
        frame: &CanFrame,
        start: Option<Instant>,
    ) -> Poll<io::Result<()>> {
        loop {
            let mut state = lock(&self.state);
            let index = self.index;
            if !state.others_present(index) {
                return Poll::Ready(Err(io::Error::new(
                    io::ErrorKind::BrokenPipe,
                    "the virtual CAN bus has ended: no other node is attached",
                )));
            }
            if !state.config.timing {
                return Self::poll_send_untimed(&mut state, index, frame);
            }
            let now = rt_time::now();
            let has_tx = state
                .nodes
                .get(index)
                .and_then(Option::as_ref)
                .is_some_and(|n| n.tx.is_some());
            if !has_tx {
                Self::request(&mut state, index, frame, now, start);
            }
            state.settle(now);
            let next_decision = state.next_decision();
            let Some(Some(node)) = state.nodes.get_mut(index) else {
                return Poll::Ready(Err(eof()));
            };
            let Some(tx) = node.tx else {
                continue;
            };
            let deadline = match tx.state {
                TxState::OnWire(end) | TxState::Abandoned(end) if end <= now => {
                    node.tx = None;
                    if let TxState::Abandoned(_) = tx.state {
                        return Poll::Ready(Err(destroyed_error()));
                    }
                    node.last_end = Some(end);
                    node.stats.sent += 1;
                    if tx.frame == *frame {
                        return Poll::Ready(Ok(()));
                    }
                    // A different frame than the one in flight (the earlier send was
                    // abandoned by its caller but had reached the bus): now send this one.
                    continue;
                }
                TxState::OnWire(end) | TxState::Abandoned(end) => end,
                TxState::Pending => {
                    node.tx_waker = Some(cx.waker().clone());
                    next_decision.map_or(just_after(now), just_after)
                }
            };
            drop(state);
            if poll_sleep(&mut self.tx_sleep, deadline, cx).is_pending() {
                return Poll::Pending;
            }
        }
    }
}

impl Drop for VirtualNode {
    fn drop(&mut self) {
        let mut state = lock(&self.state);
        if let Some(slot) = state.nodes.get_mut(self.index) {
            *slot = None;
        }
        state.wake_all();
    }
}

/// Polls a reusable timer set to `deadline` (on the runtime layer's clock: tokio's or a
/// virtual clock's).
fn poll_sleep(sleep: &mut Option<Sleep>, deadline: Instant, cx: &mut Context<'_>) -> Poll<()> {
    let timer = match sleep {
        Some(timer) => {
            if timer.deadline() != deadline {
                Pin::new(&mut *timer).reset(deadline);
            }
            timer
        }
        None => sleep.insert(rt_time::sleep_until(deadline)),
    };
    Pin::new(timer).poll(cx)
}
