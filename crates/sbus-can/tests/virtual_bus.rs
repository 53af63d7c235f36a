//! SBus end to end on the virtual CAN bus of `drive-transport`, as a user runs it: the async
//! master (`SbusMaster`) on one node, three simulated MOVIDRIVEs (`SimulatedSbusBus`, drives 1,
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

use std::io;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use drive_core::can::{Bitrate, Frame};
use drive_core::rt::{ReceivedFrame, recv_frame};
use drive_profile::sew::{ParamChannel, index};
use drive_sim::movidrive::FAULT_SBUS_TIMEOUT;
use drive_transport::can::virtual_bus::{BusConfig, VirtualBus, VirtualNode};
use sbus_can::Address;
use sbus_can::driver::SbusMaster;
use sbus_can::master::{Handshake, MasterConfig};
use sbus_can::sim::{SimulatedSbusBus, SimulatedSbusDrive};
use sbus_can::telegram::ProcessData;
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
    master: SbusMaster<VirtualNode>,
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
        let master = SbusMaster::new(bus.node(), master);
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
