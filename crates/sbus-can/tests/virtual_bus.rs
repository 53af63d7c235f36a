//! SBus end to end on the virtual CAN bus of `drive-transport`, as a user runs it: the async
//! master (`SbusDriver`) on one node, three simulated MOVIDRIVEs (`SimulatedSbusBus`, drives 1,
//! 2, 3) on another, an observer node recording every frame with the end of its last bit, all
//! on tokio's paused clock at 500 kbit/s unless a test says otherwise.
//!
//! * fault injection: seeded campaigns of reads, writes and process data with frames dropped,
//!   destroyed (and retransmitted by the controller) or delayed on either node; every value
//!   the master reports is the drive model's, every failure a typed `DriverError`; late
//!   answers are never taken for a later request;
//! * timing through the bus, exact to the nanosecond from the frames' `at` stamps: async and
//!   sync-mode parameter answers, PO/PI and PO sync/PI, the P815 timeout (F47), the 1 ms
//!   master-slave group telegrams;
//! * bus load: a variable-telegram node with cyclic objects, the bus time measured from the
//!   frames' real lengths against the worst-case model of `sbus_can::busload`.

// Test code: helpers outside `#[test]` fns (not exempted by clippy.toml) panic by design.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

use std::future::Future;
use std::io;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::task::{Context, Poll};
use std::time::Duration;

use drive_core::SplitMix64;
use drive_core::can::{Bitrate, CanFrame, Frame};
use drive_core::rt::{CanIo, ReceivedFrame, recv_frame};
use drive_profile::sew::{ParamChannel, index};
use drive_sim::movidrive::FAULT_SBUS_TIMEOUT;
use drive_transport::can::virtual_bus::{BusConfig, BusFault, BusFaults, VirtualBus, VirtualNode};
use sbus_can::Address;
use sbus_can::driver::{DriverError, LinkError, ParamServices, SbusDriver};
use sbus_can::master::{Handshake, MasterConfig};
use sbus_can::sim::{SimulatedSbusBus, SimulatedSbusDrive};
use sbus_can::telegram::ProcessData;
use sbus_can::variable::{
    CyclicTiming, Format, Len, NodeConfig, ObjectNo, SetupResult, VariableNode, Variables,
};
use tokio::task::JoinHandle;
use tokio::time::Instant as TokioInstant;

type Log = Arc<Mutex<Vec<ReceivedFrame>>>;

fn a(n: u8) -> Address {
    Address::new(n).unwrap()
}

/// A node that records every frame the others send, with its `at` stamp.
fn observe(bus: &VirtualBus) -> (Log, JoinHandle<()>) {
    let log: Log = Arc::default();
    let mut node = bus.node();
    let l = log.clone();
    let task = tokio::spawn(async move {
        while let Ok(f) = recv_frame(&mut node).await {
            l.lock().unwrap().push(f);
        }
    });
    (log, task)
}

/// The master, the simulated drives (served in their own task) and the observer on one bus.
struct Rig {
    bus: VirtualBus,
    master: SbusDriver<VirtualNode>,
    sim: JoinHandle<(SimulatedSbusBus, io::Result<()>)>,
    log: Log,
    observer: JoinHandle<()>,
}

impl Rig {
    fn new(config: BusConfig, mut drives: SimulatedSbusBus, master: MasterConfig) -> Rig {
        let bus = VirtualBus::with_config(config);
        let (log, observer) = observe(&bus);
        let node = bus.node();
        let sim = tokio::spawn(async move {
            let r = drives.serve(node).await;
            (drives, r)
        });
        let master = SbusDriver::new(bus.node(), master);
        Rig {
            bus,
            master,
            sim,
            log,
            observer,
        }
    }

    /// The frames on identifier `id` that ended by now (the observer catches up first).
    async fn frames(&self, id: u32) -> Vec<ReceivedFrame> {
        tokio::time::sleep(Duration::from_millis(1)).await;
        self.log
            .lock()
            .unwrap()
            .iter()
            .filter(|f| f.frame.raw_id() == id)
            .copied()
            .collect()
    }

    /// Ends the bus; the drives back (their serve ended without error).
    async fn finish(self) -> SimulatedSbusBus {
        let Rig {
            bus,
            master,
            sim,
            observer,
            ..
        } = self;
        drop(master);
        observer.abort();
        let _ = observer.await;
        drop(bus);
        let (drives, r) = sim.await.unwrap();
        r.unwrap();
        drives
    }
}

fn k500() -> BusConfig {
    BusConfig::new(Bitrate::K500)
}

/// Async parameter read at 500 kbit/s: the answer's last bit comes exactly its own frame time
/// after the request's last bit (response delay 0, the factory setting of the simulator).
#[tokio::test(start_paused = true)]
async fn async_read_answer_is_one_frame_time_after_the_request() {
    let mut rig = Rig::new(
        k500(),
        SimulatedSbusBus::new(&[1, 2, 3]),
        MasterConfig::default(),
    );
    tokio::time::sleep(Duration::from_millis(3)).await;
    assert_eq!(rig.master.read(a(1), 8301).await.unwrap(), 60_001_553);
    let req = rig.frames(8 + 515).await;
    let resp = rig.frames(8 + 516).await;
    assert_eq!((req.len(), resp.len()), (1, 1));
    let gap = resp[0].at - req[0].at;
    assert_eq!(gap, resp[0].frame.duration(Bitrate::K500));
    rig.finish().await;
}

/// Writes `value` to `index` of the model directly (before the bus is served).
fn set(d: &mut SimulatedSbusDrive, index: u16, value: u32) {
    d.movidrive_mut()
        .param(
            &ParamChannel::write_volatile(index, value),
            drive_core::Instant::ZERO,
        )
        .unwrap();
}

/// The frame's last bit minus its first: the end of the frame before it on the wire is at
/// most this.
fn starts(f: &ReceivedFrame) -> TokioInstant {
    f.at - f.frame.duration(Bitrate::K500)
}

/// Sync-mode read: the master's SYNC ([`sbus_can::master::SYNC_LEAD`] after the request), then
/// the answer, which starts the moment the SYNC has ended: inside the cycle's first
/// millisecond.
#[tokio::test(start_paused = true)]
async fn sync_mode_read_leaves_right_after_the_next_sync() {
    let mut rig = Rig::new(
        k500(),
        SimulatedSbusBus::new(&[1, 2, 3]),
        MasterConfig::default(),
    );
    tokio::time::sleep(Duration::from_millis(3)).await;
    let ch = rig
        .master
        .param_with(
            a(2),
            ParamChannel::read(index::SBUS_ADDRESS),
            Handshake::Sync,
        )
        .await
        .unwrap();
    assert_eq!(ch.data, 2);
    let req = rig.frames(16 + 515).await;
    let sync = rig.frames(0).await;
    let resp = rig.frames(16 + 516).await;
    assert_eq!((req.len(), sync.len(), resp.len()), (1, 1, 1));
    assert!(sync[0].at > req[0].at);
    assert_eq!(
        starts(&resp[0]),
        sync[0].at,
        "the answer starts when the SYNC ends"
    );
    assert!(resp[0].at - sync[0].at < Duration::from_millis(1));
    rig.finish().await;
}

/// Async PO (8a + 3) answered by PI (8a + 4) at once: the PI starts when the PO ends (well
/// inside the 1 ms of ch. 5.1); PO sync (8a + 5) sent in the window, taken at the next SYNC,
/// its PI starts when that SYNC ends, and carries the state the PO sync set.
#[tokio::test(start_paused = true)]
async fn process_data_async_and_sync_timing() {
    let mut rig = Rig::new(
        k500(),
        SimulatedSbusBus::new(&[1, 2, 3]),
        MasterConfig::default(),
    );
    tokio::time::sleep(Duration::from_millis(3)).await;
    let pi = rig
        .master
        .process_data(a(3), ProcessData([0, 0, 0]))
        .await
        .unwrap();
    let po = rig.frames(24 + 3).await;
    let pi_frames = rig.frames(24 + 4).await;
    assert_eq!((po.len(), pi_frames.len()), (1, 1));
    assert_eq!(starts(&pi_frames[0]), po[0].at);
    assert!(pi_frames[0].at - po[0].at <= Duration::from_millis(1));
    assert_eq!(pi_frames[0].frame.data(), &pi.to_bytes());
    assert_ne!(pi.0[0] >> 8, 4, "not enabled yet: {:04X}h", pi.0[0]);

    // PO sync: enable. The master's SYNCs run on demand while it waits.
    let pi = rig
        .master
        .process_data_sync(a(3), ProcessData([6, 0, 0]))
        .await
        .unwrap();
    let po_sync = rig.frames(24 + 5).await;
    let syncs = rig.frames(0).await;
    let pi_frames = rig.frames(24 + 4).await;
    assert_eq!((po_sync.len(), pi_frames.len()), (1, 2));
    let before = syncs.iter().rev().find(|s| s.at < po_sync[0].at).unwrap();
    let after = syncs.iter().find(|s| s.at > po_sync[0].at).unwrap();
    // The master opens the window 2.5 ms after the SYNC it sent (its first bit, when it was
    // handed over); the drive sees SYNC end to PO end inside its 2.5–4.5 ms (SB-E30).
    assert_eq!(
        starts(&po_sync[0]) - starts(before),
        Duration::from_micros(2500)
    );
    let seen = po_sync[0].at - before.at;
    assert!(
        seen >= Duration::from_micros(2500) && seen <= Duration::from_micros(4500),
        "PO sync {seen:?} into the cycle"
    );
    // No PO sync before the first SYNC: the master started the cycle for it.
    assert!(syncs[0].at < po_sync[0].at);
    assert_eq!(
        starts(&pi_frames[1]),
        after.at,
        "PI starts when the SYNC ends"
    );
    assert_eq!(pi.0[0] >> 8, 4, "enabled at the SYNC: {:04X}h", pi.0[0]);
    assert_eq!(rig.master.stats().retries, 0, "the first PO sync was taken");
    let drives = rig.finish().await;
    assert_eq!(
        drives.drive(3).unwrap().movidrive().status_word_1(),
        pi.0[0]
    );
}

/// PO sync again and again, with SYNCs running between the calls (`sync_for`) and without:
/// every one is taken in its window at the first attempt (a master that measured its window from
/// the SYNC it handed out, while the drive measures from the SYNC it received, or that sent a
/// PO sync before any SYNC, lost attempts to the drive's window check).
#[tokio::test(start_paused = true)]
async fn repeated_po_sync_is_always_taken_at_the_first_attempt() {
    let mut rig = Rig::new(
        k500(),
        SimulatedSbusBus::new(&[1, 2]),
        MasterConfig::default(),
    );
    for i in 0..40u16 {
        let speed = 100 * i;
        let pi = rig
            .master
            .process_data_sync(a(1 + (i % 2) as u8), ProcessData([6, speed, 0]))
            .await
            .unwrap();
        assert_eq!(pi.0[0] >> 8, 4, "call {i}: enabled, {:04X}h", pi.0[0]);
        if i % 3 == 0 {
            rig.master
                .sync_for(Duration::from_millis(40))
                .await
                .unwrap();
        } else if i % 3 == 1 {
            tokio::time::sleep(Duration::from_millis(7)).await;
        }
    }
    let stats = rig.master.stats();
    assert_eq!((stats.retries, stats.timeouts), (0, 0), "{stats:?}");
    rig.finish().await;
}

/// P815 (100 ms, factory setting) with P836 emergency stop / fault: drive 1, enabled by process
/// data and then left without any, gets F47 100 ms after the end of its last PO (checked
/// through the bus: status word P010 and fault P080); drive 2 with P815 = 0 keeps running.
#[tokio::test(start_paused = true)]
async fn p815_timeout_f47_through_the_bus() {
    let mut drives = SimulatedSbusBus::new(&[1, 2, 3]);
    set(drives.drive_mut(2).unwrap(), index::SBUS_TIMEOUT, 0);
    let mut rig = Rig::new(k500(), drives, MasterConfig::default());
    tokio::time::sleep(Duration::from_millis(3)).await;
    for d in [1, 2] {
        let pi = rig
            .master
            .process_data(a(d), ProcessData([6, 0, 0]))
            .await
            .unwrap();
        assert_eq!(pi.0[0], 0x0407, "drive {d}");
    }
    let last_po = rig.frames(8 + 3).await[0].at;
    let status = |r: Result<u32, _>| r.unwrap() as u16;
    // tokio wakes on a millisecond tick and the read request takes its frame time: what
    // counts is when the request's last bit reached the drive, from the log.
    let req_id = 8 + 515;
    tokio::time::sleep_until(last_po + Duration::from_millis(98)).await;
    let sw = status(rig.master.read(a(1), index::DRIVE_STATUS).await);
    let req = *rig.frames(req_id).await.last().unwrap();
    assert!(
        req.at - last_po <= Duration::from_millis(100),
        "{:?}",
        req.at - last_po
    );
    assert_eq!(sw, 0x0407, "drive 1 before P815: {sw:04X}h");
    tokio::time::sleep_until(last_po + Duration::from_millis(100)).await;
    let sw = status(rig.master.read(a(1), index::DRIVE_STATUS).await);
    let req = *rig.frames(req_id).await.last().unwrap();
    assert!(
        req.at - last_po > Duration::from_millis(100),
        "{:?}",
        req.at - last_po
    );
    assert_eq!(sw & 0x0020, 0x0020, "fault bit: {sw:04X}h");
    assert_eq!(sw >> 8, FAULT_SBUS_TIMEOUT);
    assert_eq!(
        rig.master.read(a(1), index::FAULT_T0).await.unwrap(),
        u32::from(FAULT_SBUS_TIMEOUT)
    );
    tokio::time::sleep(Duration::from_secs(10)).await;
    let sw = status(rig.master.read(a(2), index::DRIVE_STATUS).await);
    assert_eq!(sw, 0x0407, "drive 2 (P815 = 0) after 10 s: {sw:04X}h");
    let drives = rig.finish().await;
    // The fault came exactly P815 after the PO's last bit (the model's own record).
    let d1 = drives.drive(1).unwrap().movidrive();
    assert_eq!(d1.fault_number(), Some(FAULT_SBUS_TIMEOUT));
    assert_eq!(drives.drive(2).unwrap().movidrive().fault_number(), None);
}

/// A stalled host is not a silent bus: the simulated drives' task is not run for 150 ms while
/// the master's PO of the 50th millisecond waits in another task on its way to the bus (the
/// simulated slcan adapter reads the pty in a task of its own). When the drives' loop wakes,
/// the P815 deadline has passed and the PO, stamped after the stall, is not there yet. The
/// stall is taken out of the drives' time: the PO is heard in time and the drive does not
/// trip F47; a bus that then stays silent still trips it. Failed (F47 at once) before
/// `serve_can` took a stall out of the drives' time.
#[tokio::test(start_paused = true)]
async fn a_stalled_host_does_not_trip_p815_while_a_po_waits_on_its_way() {
    let drives = SimulatedSbusBus::new(&[1]);
    let mut rig = Rig::new(k500(), drives, MasterConfig::default());
    tokio::time::sleep(Duration::from_millis(3)).await;
    let pi = rig
        .master
        .process_data(a(1), ProcessData([6, 0, 0]))
        .await
        .unwrap();
    assert_eq!(pi.0[0], 0x0407);
    // The relay: an adapter task that puts a frame on the bus when it is run.
    let (tx, rx) = tokio::sync::oneshot::channel::<CanFrame>();
    let mut adapter = rig.bus.node();
    let relay = tokio::spawn(async move {
        let frame = rx.await.unwrap();
        drive_core::rt::send_frame(&mut adapter, &frame)
            .await
            .unwrap();
        adapter
    });
    tokio::time::sleep(Duration::from_millis(50)).await;
    let po = CanFrame::standard(8 + 3, &[0x00, 0x06, 0, 0, 0, 0]).unwrap();
    tx.send(po).unwrap();
    // The stall: 150 ms pass with no task run; the drives' deadline (100 ms after the first
    // PO) is met late, the relayed PO reaches the bus only after that.
    tokio::time::advance(Duration::from_millis(150)).await;
    drop(relay.await.unwrap());
    tokio::time::sleep(Duration::from_millis(30)).await;
    let sw = rig.master.read(a(1), index::DRIVE_STATUS).await.unwrap() as u16;
    assert_eq!(
        sw, 0x0407,
        "no F47 after a stall with a PO on its way: {sw:04X}h"
    );
    // A bus that really goes silent still trips, at P815 plus the grace at most.
    tokio::time::sleep(Duration::from_millis(100)).await;
    let sw = rig.master.read(a(1), index::DRIVE_STATUS).await.unwrap() as u16;
    assert_eq!(
        sw >> 8,
        FAULT_SBUS_TIMEOUT,
        "F47 after 130 ms of silence: {sw:04X}h"
    );
    let drives = rig.finish().await;
    assert_eq!(
        drives.drive(1).unwrap().movidrive().fault_number(),
        Some(FAULT_SBUS_TIMEOUT)
    );
}

/// P750 "slave setpoint", P751 "scaling slave setpoint" (×1000), P100 = 8 MASTER-SBus.
const P750: u16 = 8592;
const P751: u16 = 8593;

/// Ch. 5.4 master-slave on the bus: drive 1 the master (P750 = speed via SBus, group 5), 2 and
/// 3 its slaves; the group telegram (8 × 5 + 6 = 46) leaves every 1 ms, measured from the
/// frames' `at` stamps, and the slaves follow the master's speed × P751.
#[tokio::test(start_paused = true)]
async fn master_slave_group_telegram_every_millisecond_on_the_bus() {
    let mut drives = SimulatedSbusBus::new(&[1, 2, 3]);
    for d in drives.drives_mut() {
        set(d, index::SBUS_GROUP_ADDRESS, 5);
        set(d, index::SBUS_TIMEOUT, 0);
    }
    let master = drives.drive_mut(1).unwrap();
    set(master, P750, 2);
    set(master, P751, 500);
    for d in [2, 3] {
        set(drives.drive_mut(d).unwrap(), index::SETPOINT_SOURCE, 8);
    }
    let mut rig = Rig::new(k500(), drives, MasterConfig::default());
    rig.master
        .process_data(a(1), ProcessData([6, 7500, 0]))
        .await
        .unwrap();
    tokio::time::sleep(Duration::from_millis(2100)).await;
    let group = rig.frames(46).await;
    assert!(
        group.len() >= 2099,
        "{} group telegrams in 2.1 s",
        group.len()
    );
    // The first one competes with the PI answer to the enabling PO (PI, identifier 12, wins
    // arbitration and delays it by a frame); the grid stays: from the second one on, exactly
    // 1 ms apart while the bus carries nothing else.
    assert!(group[1].at - group[0].at < Duration::from_millis(1));
    for w in group[1..].windows(2) {
        assert_eq!(
            starts(&w[1]) - starts(&w[0]),
            Duration::from_millis(1),
            "{} → {}",
            w[0].frame,
            w[1].frame
        );
    }
    let speed = |r: Result<u32, _>| f64::from(r.unwrap() as i32) / 1000.0;
    for (d, want) in [(1, 1500.0), (2, 750.0), (3, 750.0)] {
        let got = speed(rig.master.read(a(d), index::SPEED).await);
        assert!((got - want).abs() < 0.2, "drive {d}: {got} 1/min");
    }
    rig.finish().await;
}

// ---------------------------------------------------------------------------------------------
// Fault injection
// ---------------------------------------------------------------------------------------------

/// The drives' node, served only while a step runs: `poll_recv` ends the serve (as the end of
/// the bus would) once the step's master call is done, so that the test can look at the drive
/// models between steps. Nothing is lost: frames that arrive meanwhile wait in the node's
/// queue with their `at` stamps, and the drives' time goes on across serves.
struct Pausable<'a> {
    node: &'a mut VirtualNode,
    stop: &'a AtomicBool,
}

impl CanIo for Pausable<'_> {
    fn poll_recv(&mut self, cx: &mut Context<'_>) -> Poll<io::Result<ReceivedFrame>> {
        if self.stop.load(Ordering::Relaxed) {
            return Poll::Ready(Err(io::ErrorKind::UnexpectedEof.into()));
        }
        self.node.poll_recv(cx)
    }

    fn poll_send(&mut self, cx: &mut Context<'_>, frame: &CanFrame) -> Poll<io::Result<()>> {
        self.node.poll_send(cx, frame)
    }

    fn poll_send_at(
        &mut self,
        cx: &mut Context<'_>,
        frame: &CanFrame,
        start: TokioInstant,
    ) -> Poll<io::Result<()>> {
        self.node.poll_send_at(cx, frame, start)
    }
}

/// Runs the master call `op` while the drives are served; returns once both are done (the
/// drives finish a frame they are sending, e.g. a delayed answer).
async fn step<T>(
    drives: &mut SimulatedSbusBus,
    node: &mut VirtualNode,
    op: impl Future<Output = T>,
) -> T {
    let stop = AtomicBool::new(false);
    let (r, served) = tokio::join!(
        async {
            let r = op.await;
            stop.store(true, Ordering::Relaxed);
            tokio::task::yield_now().await;
            r
        },
        drives.serve(Pausable { node, stop: &stop })
    );
    served.unwrap();
    r
}

/// Parameters the campaign writes (RW ramps, steps of 10 up to 1 s) and reads.
const RAMPS: [u16; 5] = [
    index::RAMP_T11_UP_CW,
    index::RAMP_T11_DOWN_CW,
    index::RAMP_T11_UP_CCW,
    index::RAMP_T11_DOWN_CCW,
    index::RAMP_T12,
];

/// A valid ramp value no other drive can hold: 10 × (4j + address) ms.
fn ramp_value(rng: &mut SplitMix64, address: u8) -> u32 {
    10 * (4 * (rng.next_u64() % 25) as u32 + u32::from(address))
}

/// The model's value of `index` in drive `d` now.
fn model(drives: &mut SimulatedSbusBus, d: u8, index: u16) -> u32 {
    drives
        .drive_mut(d)
        .unwrap()
        .movidrive_mut()
        .param(&ParamChannel::read(index), drive_core::Instant::ZERO)
        .unwrap()
}

/// The model's process input words of drive `d` now.
fn model_pi(drives: &SimulatedSbusBus, d: u8) -> [u16; 3] {
    let mut pi = [0; 3];
    drives.drive(d).unwrap().movidrive().process_input(&mut pi);
    pi
}

/// Counts of one campaign.
#[derive(Debug, Default, Clone, Copy)]
struct Counts {
    operations: u64,
    reads: u64,
    writes: u64,
    exchanges: u64,
    timeouts: u64,
    retries: u64,
    dropped: u64,
    corrupted: u64,
    delayed: u64,
    unsolicited: u64,
    mismatched: u64,
}

/// Every error must be a timeout naming the drive and all attempts.
fn check_timeout(e: &DriverError, d: u8, attempts: u16) {
    match e {
        DriverError::Link(LinkError::Timeout {
            address,
            attempts: n,
            ..
        }) if address.get() == d && *n == attempts => {
            let text = e.to_string();
            assert!(
                text.contains(&format!("address {d} after {attempts} attempts")),
                "{text}"
            );
        }
        other => panic!("drive {d}: {other:?}"),
    }
}

/// The PO each drive gets: drive 1 enabled, 2 and 3 not; with their PI mapped differently
/// (P874/P875) no drive's PI can pass for another's.
const PO: [[u16; 3]; 3] = [[6, 0, 0], [0, 0, 0], [0, 0, 0]];

/// One seeded campaign of `ops` operations with random drops, destroyed frames (retransmitted
/// by the controller) and delayed requests on both nodes.
async fn campaign(seed: u64, ops: u64, delay_by: Duration) -> Counts {
    let faults = BusFaults {
        seed,
        drop: 0.12,
        corrupt: 0.05,
        delay: 0.05,
        delay_by,
        one_shot: false,
    };
    let bus = VirtualBus::with_config(k500());
    let mut drives = SimulatedSbusBus::new(&[1, 2, 3]);
    let mut rng = SplitMix64::new(seed ^ 0x5EED);
    for d in 1..=3u8 {
        let drive = drives.drive_mut(d).unwrap();
        set(drive, index::SBUS_TIMEOUT, 0);
        set(drive, index::SBUS_GROUP_ADDRESS, 10 + u32::from(d));
        for i in RAMPS {
            let v = ramp_value(&mut rng, d);
            set(drive, i, v);
        }
    }
    // P875 PI3 = status word 1 in drive 2, P874 PI2 = status word 1 in drive 3.
    set(drives.drive_mut(2).unwrap(), index::PI1_DESCRIPTION + 2, 6);
    set(drives.drive_mut(3).unwrap(), index::PI1_DESCRIPTION + 1, 6);
    let mut node = bus.node();
    let mut master = SbusDriver::new(bus.node(), MasterConfig::default());
    // Warm-up without faults: each drive in its state; their PIs differ.
    for d in 1..=3u8 {
        let po = ProcessData(PO[usize::from(d - 1)]);
        step(&mut drives, &mut node, master.process_data(a(d), po))
            .await
            .unwrap();
    }
    tokio::time::sleep(Duration::from_millis(5)).await;
    let pis: Vec<[u16; 3]> = (1..=3).map(|d| model_pi(&drives, d)).collect();
    assert!(
        pis[0] != pis[1] && pis[1] != pis[2] && pis[0] != pis[2],
        "{pis:04X?}"
    );
    bus.set_faults(faults);

    let attempts = u16::from(master.config().retries) + 1;
    let mut c = Counts::default();
    for _ in 0..ops {
        c.operations += 1;
        let d = 1 + (rng.next_u64() % 3) as u8;
        match rng.next_u64() % 10 {
            // Reads of parameters the test knows: the drive's address, group, a ramp; one in
            // three in sync mode.
            0..=3 => {
                c.reads += 1;
                let i = match rng.next_u64() % 4 {
                    0 => index::SBUS_ADDRESS,
                    1 => index::SBUS_GROUP_ADDRESS,
                    _ => RAMPS[(rng.next_u64() % 5) as usize],
                };
                let hs = if rng.next_u64().is_multiple_of(3) {
                    Handshake::Sync
                } else {
                    Handshake::Async
                };
                let r = step(
                    &mut drives,
                    &mut node,
                    master.param_with(a(d), ParamChannel::read(i), hs),
                )
                .await;
                match r {
                    Ok(ch) => assert_eq!(ch.data, model(&mut drives, d, i), "drive {d} index {i}"),
                    Err(e) => {
                        check_timeout(&e, d, attempts);
                        c.timeouts += 1;
                    }
                }
            }
            // A random valid value, then a read of it.
            4..=6 => {
                c.writes += 1;
                let i = RAMPS[(rng.next_u64() % 5) as usize];
                let v = ramp_value(&mut rng, d);
                let before = model(&mut drives, d, i);
                let w = step(&mut drives, &mut node, master.write_volatile(a(d), i, v)).await;
                let now = model(&mut drives, d, i);
                match w {
                    Ok(()) => assert_eq!(now, v, "drive {d} index {i}: write taken"),
                    Err(e) => {
                        // Lost answers: the drive may have executed it, or not.
                        check_timeout(&e, d, attempts);
                        assert!(now == v || now == before, "drive {d} index {i}: {now}");
                        c.timeouts += 1;
                    }
                }
                let r = step(&mut drives, &mut node, master.read(a(d), i)).await;
                c.reads += 1;
                match r {
                    Ok(got) => assert_eq!(got, model(&mut drives, d, i), "drive {d} index {i}"),
                    Err(e) => {
                        check_timeout(&e, d, attempts);
                        c.timeouts += 1;
                    }
                }
            }
            // Process data: the PI is this drive's, now.
            _ => {
                c.exchanges += 1;
                let po = ProcessData(PO[usize::from(d - 1)]);
                let r = step(&mut drives, &mut node, master.process_data(a(d), po)).await;
                match r {
                    Ok(pi) => assert_eq!(pi.0, model_pi(&drives, d), "drive {d}"),
                    Err(e) => {
                        check_timeout(&e, d, attempts);
                        c.timeouts += 1;
                    }
                }
            }
        }
    }
    let stats = master.stats();
    assert_eq!(stats.timeouts, c.timeouts);
    assert_eq!(stats.drive_errors, 0);
    c.retries = stats.retries;
    c.unsolicited = stats.rejected.unsolicited;
    c.mismatched = stats.rejected.mismatch;
    let nodes = [node.stats(), master.get_ref().stats()];
    c.dropped = nodes.iter().map(|n| n.dropped).sum();
    c.corrupted = nodes.iter().map(|n| n.corrupted).sum();
    c.delayed = nodes.iter().map(|n| n.delayed).sum();
    c
}

/// The "lost and corrupted frames, late answers: no wrong value": four seeds of 300
/// operations each, delays shorter and longer than the 50 ms timeout.
#[tokio::test(start_paused = true)]
async fn fault_campaign_never_reports_a_wrong_value() {
    let mut total = Counts::default();
    for (seed, delay_ms) in [(1u64, 5u64), (2, 30), (3, 70), (4, 120)] {
        let c = campaign(seed, 300, Duration::from_millis(delay_ms)).await;
        println!("seed {seed}, delay {delay_ms} ms: {c:?}");
        assert!(c.timeouts > 0 && c.retries > 0, "seed {seed}: {c:?}");
        assert!(
            c.dropped > 0 && c.corrupted > 0 && c.delayed > 0,
            "seed {seed}: {c:?}"
        );
        total.operations += c.operations;
        total.reads += c.reads;
        total.writes += c.writes;
        total.exchanges += c.exchanges;
        total.timeouts += c.timeouts;
        total.retries += c.retries;
        total.dropped += c.dropped;
        total.corrupted += c.corrupted;
        total.delayed += c.delayed;
        total.unsolicited += c.unsolicited;
        total.mismatched += c.mismatched;
    }
    println!("total: {total:?}");
}

/// Late answers on the bus (the drive's answer held back by its controller with one-shot
/// delays): one arriving while the retry of the same request waits answers that request (the
/// same service, index and drive: the right value) and the retry's answer is not taken by the
/// next request; one arriving after the request was given up is never taken for a later
/// request, whether the master waits its late guard or (guard 0) has sent the next request.
#[tokio::test(start_paused = true)]
async fn late_answers_are_never_taken_for_a_later_request() {
    const RAMP: u16 = index::RAMP_T11_UP_CW;
    const OTHER: u16 = index::RAMP_T11_DOWN_CW;
    let bus = VirtualBus::new(Bitrate::K500);
    let mut drives = SimulatedSbusBus::new(&[1, 2, 3]);
    set(drives.drive_mut(1).unwrap(), RAMP, 500);
    set(drives.drive_mut(1).unwrap(), OTHER, 800);
    let mut node = bus.node();
    let mut master = SbusDriver::new(bus.node(), MasterConfig::default());

    // 1. Delayed past the 50 ms timeout: it comes while the retry waits.
    node.inject(BusFault::Delay(Duration::from_millis(70)));
    let t0 = TokioInstant::now();
    let v = step(&mut drives, &mut node, master.read(a(1), RAMP)).await;
    assert_eq!(v.unwrap(), 500);
    assert!(t0.elapsed() >= Duration::from_millis(70));
    assert_eq!(master.stats().retries, 1);
    step(
        &mut drives,
        &mut node,
        master.write_volatile(a(1), RAMP, 600),
    )
    .await
    .unwrap();
    let v = step(&mut drives, &mut node, master.read(a(1), RAMP)).await;
    assert_eq!(v.unwrap(), 600, "not the retry's answer 500");
    let r = master.stats().rejected;
    assert_eq!(r.unsolicited + r.mismatch, 1, "{r:?}");

    // 2. Given up (one attempt), then the late answer (RAMP = 600) during the master's late
    //    guard, before the next request went out: counted as stale, and the next write and
    //    read are the drive's.
    master.set_retries(0);
    node.inject(BusFault::Delay(Duration::from_millis(80)));
    let e = step(&mut drives, &mut node, master.read(a(1), RAMP))
        .await
        .unwrap_err();
    check_timeout(&e, 1, 1);
    step(
        &mut drives,
        &mut node,
        master.write_volatile(a(1), RAMP, 700),
    )
    .await
    .unwrap();
    let v = step(&mut drives, &mut node, master.read(a(1), RAMP)).await;
    assert_eq!(v.unwrap(), 700);
    let after_guard = master.stats().rejected;
    assert_eq!(
        after_guard.unsolicited + after_guard.mismatch + master.stats().stale,
        2,
        "{after_guard:?}"
    );
    assert_eq!(master.stats().stale, 1);

    // 3. No late guard: the next request (another index) is on the bus when the late answer
    //    comes; it is not its answer.
    let mut unguarded = SbusDriver::new(
        master.into_inner(),
        MasterConfig {
            retries: 0,
            late_guard: Duration::ZERO,
            ..MasterConfig::default()
        },
    );
    node.inject(BusFault::Delay(Duration::from_millis(80)));
    let (e, v) = step(&mut drives, &mut node, async {
        let e = unguarded.read(a(1), RAMP).await;
        (e, unguarded.read(a(1), OTHER).await)
    })
    .await;
    check_timeout(&e.unwrap_err(), 1, 1);
    assert_eq!(v.unwrap(), 800, "not the late answer 700 of index {RAMP}");
    assert_eq!(unguarded.stats().rejected.mismatch, 1);
}

// ---------------------------------------------------------------------------------------------
// Bus load
// ---------------------------------------------------------------------------------------------

/// Cyclic objects of the bus-load test: (object number, cycle ms, offset ms, bytes, format).
const OBJECTS: [(u16, u32, u32, u8, Format); 6] = [
    (1024, 5, 0, 8, Format::Motorola),
    (1025, 5, 2, 4, Format::Intel),
    (1026, 9, 0, 2, Format::Motorola),
    (1027, 10, 0, 8, Format::Intel),
    (1028, 20, 10, 8, Format::Motorola),
    (1029, 100, 50, 0, Format::Motorola),
];

/// Bits of a standard data frame of `len` bytes without a single stuff bit, intermission
/// included: SOF, 11 identifier bits, RTR, IDE, r0, 4 DLC bits, the data, 15 CRC bits, CRC
/// delimiter, ACK slot and delimiter, 7 EOF bits, 3 intermission bits.
fn unstuffed_bits(len: usize) -> u64 {
    47 + 8 * len as u64
}

/// Measured bus time of one simulated second of a variable-telegram node (six cyclic objects,
/// served by `serve_can` on its own node) at each P816 rate, from the frames' real lengths
/// (`CanFrame::bits`), against the worst-case model of `busload`: measured ≤ modelled, and
/// measured ≥ the same frames without stuff bits (the difference is stuffing only).
#[tokio::test(start_paused = true)]
async fn bus_load_measured_against_the_model() {
    let data = Variables {
        low: 0x1122_3344,
        high: 0x5566_7788,
    };
    for rate in sbus_can::busload::SBUS_BITRATES {
        let bus = VirtualBus::new(rate);
        let (log, observer) = observe(&bus);
        let mut vn = VariableNode::new(NodeConfig::new(rate));
        for (object, cycle, offset, bytes, format) in OBJECTS {
            let r = vn.define_cyclic(
                ObjectNo::new(object).unwrap(),
                CyclicTiming::new(cycle, offset).unwrap(),
                Len::new(bytes, format).unwrap(),
                data,
            );
            assert!(
                matches!(r, Ok(SetupResult::FreeCapacity(_))),
                "{rate:?}: {r:?}"
            );
        }
        let model = vn.load();
        let node = bus.node();
        let t0 = TokioInstant::now();
        vn.start(drive_core::Instant::ZERO);
        let sender = tokio::spawn(async move {
            let mut eps = [vn];
            let mut epoch = t0;
            let _ = drive_core::rt::can_serve::serve_can(&mut eps, &mut epoch, node).await;
        });
        tokio::time::sleep(Duration::from_millis(1001)).await;
        sender.abort();
        let _ = sender.await;
        observer.abort();
        let _ = observer.await;
        let log = log.lock().unwrap().clone();
        let second = t0 + Duration::from_secs(1);
        let frames: Vec<_> = log
            .iter()
            .filter(|f| f.at - f.frame.duration(rate) < second)
            .collect();
        // Due at offset + k × cycle: every one in the second went out, none skipped.
        for (object, cycle, offset, ..) in OBJECTS {
            let n = frames
                .iter()
                .filter(|f| f.frame.raw_id() == u32::from(object))
                .count();
            assert_eq!(
                n as u32,
                (1000 - offset).div_ceil(cycle),
                "object {object} at {rate:?}"
            );
        }
        let bits: u64 = frames.iter().map(|f| u64::from(f.frame.bits())).sum();
        let floor: u64 = frames.iter().map(|f| unstuffed_bits(f.frame.dlc())).sum();
        let bps = u64::from(rate.bits_per_second());
        // Parts per million of the second.
        let measured_ppm = bits * 1_000_000 / bps;
        let floor_ppm = floor * 1_000_000 / bps;
        println!(
            "{:>4} kbit/s: {} frames, {bits} bits on the wire = {:.3} % measured; model {:.3} % \
             (free capacity {:?}); without stuff bits {:.3} %",
            bps / 1000,
            frames.len(),
            measured_ppm as f64 / 1e4,
            model.percent(),
            model.free_capacity(),
            floor_ppm as f64 / 1e4,
        );
        assert!(
            measured_ppm <= model.ppm(),
            "{rate:?}: measured above the model"
        );
        assert!(floor_ppm <= measured_ppm);
    }
}
