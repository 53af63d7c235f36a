//! The simulated MOVIDRIVE on SBus (feature `sim`) served by `drive_core::rt::can_serve` on an
//! in-test CAN interface (tokio channels), on tokio's paused clock: the 1 ms answers, the sync
//! answers, the SBus timeout F47 (P815/P836), identifiers following P813/P817, master-slave.

// Test code: helpers outside `#[test]` fns (not exempted by clippy.toml) panic by design.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

use std::io;
use std::task::{Context, Poll};
use std::time::Duration;

use drive_core::Instant;
use drive_core::can::{CanFrame, Frame};
use drive_core::rt::{CanIo, ReceivedFrame};
use drive_profile::sew::{ParamChannel, index};
use drive_sim::movidrive::{FAULT_SBUS_TIMEOUT, MasterSlave, MasterSlaveError};
use sbus_can::sim::{SimulatedSbusBus, SimulatedSbusDrive};
use sbus_can::slave::Rejection;
use tokio::sync::mpsc::{UnboundedReceiver, UnboundedSender, unbounded_channel};
use tokio::time::{Instant as TokioInstant, sleep, timeout};

/// The simulators' end of the in-test CAN interface.
struct ChannelCan {
    rx: UnboundedReceiver<CanFrame>,
    tx: UnboundedSender<(CanFrame, TokioInstant)>,
}

impl CanIo for ChannelCan {
    fn poll_recv(&mut self, cx: &mut Context<'_>) -> Poll<io::Result<ReceivedFrame>> {
        self.rx.poll_recv(cx).map(|f| match f {
            Some(frame) => Ok(ReceivedFrame {
                frame,
                at: TokioInstant::now(),
            }),
            None => Err(io::ErrorKind::UnexpectedEof.into()),
        })
    }

    fn poll_send(&mut self, _cx: &mut Context<'_>, frame: &CanFrame) -> Poll<io::Result<()>> {
        Poll::Ready(
            self.tx
                .send((*frame, TokioInstant::now()))
                .map_err(|_| io::ErrorKind::BrokenPipe.into()),
        )
    }
}

/// The test's end: a PLC on the bus.
struct Plc {
    tx: UnboundedSender<CanFrame>,
    rx: UnboundedReceiver<(CanFrame, TokioInstant)>,
}

fn pair() -> (Plc, ChannelCan) {
    let (to_sim, from_plc) = unbounded_channel();
    let (to_plc, from_sim) = unbounded_channel();
    (
        Plc {
            tx: to_sim,
            rx: from_sim,
        },
        ChannelCan {
            rx: from_plc,
            tx: to_plc,
        },
    )
}

impl Plc {
    /// Send `id#data` now; its time.
    fn send(&self, id: u16, data: &[u8]) -> TokioInstant {
        self.tx.send(CanFrame::standard(id, data).unwrap()).unwrap();
        TokioInstant::now()
    }

    /// The next frame on identifier `id` (others skipped), within 20 ms.
    async fn expect(&mut self, id: u32) -> (CanFrame, TokioInstant) {
        timeout(Duration::from_millis(20), async {
            loop {
                let (f, at) = self.rx.recv().await.expect("simulator gone");
                if f.raw_id() == id {
                    return (f, at);
                }
            }
        })
        .await
        .unwrap_or_else(|_| panic!("no frame on {id} within 20 ms"))
    }

    /// Frames on `id` received so far, without waiting.
    fn drain(&mut self, id: u32) -> Vec<(CanFrame, TokioInstant)> {
        std::iter::from_fn(|| self.rx.try_recv().ok())
            .filter(|(f, _)| f.raw_id() == id)
            .collect()
    }

    /// A parameter service at address `a` with handshake bit 0; the answer's data.
    async fn param(
        &mut self,
        a: u16,
        req: ParamChannel,
    ) -> Result<u32, drive_profile::sew::ReturnCode> {
        self.send(8 * a + 515, &req.to_bytes());
        let (f, _) = self.expect(u32::from(8 * a + 516)).await;
        let ch = ParamChannel::from_bytes(f.data().try_into().unwrap());
        assert!(req.is_answered_by(&ch));
        ch.result()
    }
}

fn po(words: [u16; 3]) -> [u8; 6] {
    sbus_can::telegram::ProcessData(words).to_bytes()
}

/// Status word 1 of drive `a` through the drive status parameter (P010, 8310), which does not
/// feed the SBus monitor.
async fn status(plc: &mut Plc, a: u16) -> u16 {
    plc.param(a, ParamChannel::read(index::DRIVE_STATUS))
        .await
        .unwrap() as u16
}

/// Asynchronous PO (8a + 3) answered with PI (8a + 4) within 1 ms (ch. 5.1); the manual's
/// ch. 5.3 values: PO 6 / 5000 (enable, 1000 1/min), PI1 = status word 1.
#[tokio::test(start_paused = true)]
async fn async_po_answered_within_1_ms() {
    let (mut plc, io) = pair();
    let mut drive = SimulatedSbusDrive::new(1);
    let sim = tokio::spawn(async move { drive.serve(io).await.map(|()| drive) });
    sleep(Duration::from_millis(3)).await;
    let sent = plc.send(11, &po([6, 5000, 0]));
    let (pi, at) = plc.expect(12).await;
    assert!(at - sent <= Duration::from_millis(1), "{:?}", at - sent);
    assert_eq!(pi.data().len(), 6);
    // Status word 1: output stage on, ready, PO data enabled; high byte 4 = enable.
    assert_eq!(u16::from_be_bytes([pi.data()[0], pi.data()[1]]), 0x0407);
    // Manual ch. 5.3 read of 8318 answers the speed in 0.001 1/min: 1000 1/min after the
    // ramp (P130 2 s per 3000 1/min), PI2 = 5000 (0.2 1/min per digit). PO every 50 ms keep
    // the SBus monitor (P815 = 100 ms) fed.
    let mut pi = CanFrame::standard(0, &[]).unwrap();
    for _ in 0..16 {
        sleep(Duration::from_millis(50)).await;
        let sent = plc.send(11, &po([6, 5000, 0]));
        let (f, at) = plc.expect(12).await;
        assert!(at - sent <= Duration::from_millis(1));
        pi = f;
    }
    assert_eq!(u16::from_be_bytes([pi.data()[2], pi.data()[3]]), 5000);
    assert_eq!(plc.param(1, ParamChannel::read(8318)).await, Ok(1_000_000));
    drop(plc);
    let drive = sim.await.unwrap().unwrap();
    assert_eq!(drive.tally().rejected_total(), 0);
}

/// SYNC every 5 ms; a PO sync inside the window and a write-sync request: PI and the
/// parameter response both leave inside the first millisecond after the next SYNC, not before.
#[tokio::test(start_paused = true)]
async fn sync_answers_inside_the_first_millisecond() {
    let (mut plc, io) = pair();
    let mut drive = SimulatedSbusDrive::new(1);
    let sim = tokio::spawn(async move { drive.serve(io).await.map(|()| drive) });
    sleep(Duration::from_millis(1)).await;
    let sync0 = plc.send(0, &[]);
    sleep(Duration::from_millis(3)).await; // 3 ms into the cycle: inside 2.5 … 4.5 ms
    plc.send(13, &po([6, 1500, 0]));
    let req = ParamChannel::write_volatile(8470, 1500).with_handshake(true);
    plc.send(523, &req.to_bytes());
    sleep(Duration::from_millis(1)).await;
    assert!(
        plc.drain(12).is_empty() && plc.drain(524).is_empty(),
        "answered before SYNC"
    );
    sleep_until(sync0 + Duration::from_millis(5)).await;
    let sync1 = plc.send(0, &[]);
    let (pi, pi_at) = plc.expect(12).await;
    let (resp, resp_at) = plc.expect(524).await;
    for at in [pi_at, resp_at] {
        assert!(
            at >= sync1 && at - sync1 < Duration::from_millis(1),
            "{:?}",
            at - sync1
        );
    }
    assert_eq!(
        pi.data()[1],
        0x07,
        "enabled by the PO sync taken at the SYNC"
    );
    assert_eq!(resp.data(), &req.answer(Ok(0)).to_bytes());
    assert_eq!(plc.param(1, ParamChannel::read(8470)).await, Ok(1500));
    drop(plc);
    sim.await.unwrap().unwrap();
}

async fn sleep_until(t: TokioInstant) {
    tokio::time::sleep_until(t).await;
}

/// F47: enabled by PO, then no process data: the fault comes after exactly P815 (100 ms,
/// factory setting) and not before; parameter telegrams do not feed the monitor. P836 factory
/// setting: emergency stop / fault.
#[tokio::test(start_paused = true)]
async fn sbus_timeout_f47_after_exactly_p815() {
    let (mut plc, io) = pair();
    let mut drive = SimulatedSbusDrive::new(4);
    assert_eq!(
        drive.movidrive().sbus_timeout(),
        Some(Duration::from_millis(100))
    );
    let sim = tokio::spawn(async move { drive.serve(io).await.map(|()| drive) });
    sleep(Duration::from_millis(2)).await;
    let last_po = plc.send(8 * 4 + 3, &po([6, 5000, 0]));
    plc.expect(8 * 4 + 4).await;
    sleep_until(last_po + Duration::from_millis(100)).await;
    // Exactly P815 after the last PO: still in time.
    let sw = status(&mut plc, 4).await;
    assert_eq!(sw & 0x0020, 0, "fault before P815: {sw:04X}h");
    assert_eq!(sw >> 8, 4, "enabled");
    sleep_until(last_po + Duration::from_millis(101)).await;
    let sw = status(&mut plc, 4).await;
    assert_eq!(sw & 0x0020, 0x0020, "{sw:04X}h");
    assert_eq!(sw >> 8, FAULT_SBUS_TIMEOUT);
    assert_eq!(
        plc.param(4, ParamChannel::read(index::FAULT_T0)).await,
        Ok(u32::from(FAULT_SBUS_TIMEOUT))
    );
    drop(plc);
    let drive = sim.await.unwrap().unwrap();
    assert_eq!(drive.movidrive().fault_number(), Some(FAULT_SBUS_TIMEOUT));
}

/// P815 = 0 (and 650 s) switch the monitor off: an enabled drive without process data for
/// 10 s never times out.
#[tokio::test(start_paused = true)]
async fn p815_zero_never_times_out() {
    for off in [0u32, 650_000] {
        let (mut plc, io) = pair();
        let mut drive = SimulatedSbusDrive::new(1);
        let sim = tokio::spawn(async move { drive.serve(io).await.map(|()| drive) });
        assert_eq!(
            plc.param(1, ParamChannel::write_volatile(index::SBUS_TIMEOUT, off))
                .await,
            Ok(0)
        );
        plc.send(11, &po([6, 5000, 0]));
        plc.expect(12).await;
        sleep(Duration::from_secs(10)).await;
        let sw = status(&mut plc, 1).await;
        assert_eq!(sw, 0x0407, "P815 = {off}: {sw:04X}h");
        drop(plc);
        let drive = sim.await.unwrap().unwrap();
        assert_eq!(drive.movidrive().sbus_deadline(), None);
    }
}

/// P813 and P817 written over the bus: the answer to the write still comes on the old
/// identifier, then the drive answers only its new ones.
#[tokio::test(start_paused = true)]
async fn identifiers_follow_p813_and_p817() {
    let (mut plc, io) = pair();
    let mut drive = SimulatedSbusDrive::new(1);
    let sim = tokio::spawn(async move { drive.serve(io).await.map(|()| drive) });
    assert_eq!(
        plc.param(1, ParamChannel::write_volatile(index::SBUS_ADDRESS, 33))
            .await,
        Ok(0)
    );
    // P817 holds the identifier × 1000: 5000 = identifier 5.
    assert_eq!(
        plc.param(33, ParamChannel::write_volatile(index::SBUS_SYNC_ID, 5000))
            .await,
        Ok(0)
    );
    plc.send(11, &po([0, 0, 0]));
    sleep(Duration::from_millis(2)).await;
    assert!(plc.drain(12).is_empty());
    // Manual ch. 5.6: address 33 → PO 267, PI 268.
    plc.send(267, &po([0, 0, 0]));
    plc.expect(268).await;
    drop(plc);
    let drive = sim.await.unwrap().unwrap();
    assert_eq!(drive.slave_config().sync_id, 5);
    assert_eq!(drive.tally().rejected(Rejection::OtherAddress), 1);
}

fn write(d: &mut SimulatedSbusDrive, index: u16, value: i32) {
    d.movidrive_mut()
        .param(
            &ParamChannel::write_volatile(index, value as u32),
            Instant::ZERO,
        )
        .unwrap();
}

/// P750 slave setpoint, P751 scaling (set in the master), P100 = 8 MASTER-SBus (the slaves).
const P750: u16 = 8592;
const P751: u16 = 8593;

/// Ch. 5.4: drive 1 is the master (P750 = speed (SBus), group 5), drives 2 and 3 are slaves
/// of group 5 (P100 = MASTER-SBus). A PLC ramps the master to 1500 1/min; its group telegram
/// every 1 ms carries its speed × P751 (0.5), and both slaves follow at 750 1/min. The master
/// takes no group telegrams itself.
#[tokio::test(start_paused = true)]
async fn master_ramps_and_two_slaves_follow() {
    let (mut plc, io) = pair();
    let mut bus = SimulatedSbusBus::new(&[1, 2, 3]);
    for d in bus.drives_mut() {
        write(d, index::SBUS_GROUP_ADDRESS, 5);
        write(d, index::SBUS_TIMEOUT, 0);
    }
    let master = bus.drive_mut(1).unwrap();
    write(master, P750, 2);
    write(master, P751, 500);
    for a in [2, 3] {
        write(bus.drive_mut(a).unwrap(), index::SETPOINT_SOURCE, 8);
    }
    let sim = tokio::spawn(async move { bus.serve(io).await.map(|()| bus) });
    plc.send(11, &po([6, 7500, 0])); // master: enable, 1500 1/min
    // Group telegrams (8 × 5 + 6 = 46) every millisecond.
    let (_, t1) = plc.expect(46).await;
    let (_, t2) = plc.expect(46).await;
    assert_eq!(t2 - t1, Duration::from_millis(1));
    // Mid-ramp (500 ms, master at 750 1/min): the slaves follow within one telegram.
    sleep(Duration::from_millis(500)).await;
    let speed = |r: Result<u32, _>| f64::from(r.unwrap() as i32) / 1000.0;
    let m = speed(plc.param(1, ParamChannel::read(8318)).await);
    let s2 = speed(plc.param(2, ParamChannel::read(8318)).await);
    assert!((m - 750.0).abs() < 2.0, "master {m}");
    assert!((s2 - m / 2.0).abs() < 1.0, "slave {s2} master {m}");
    sleep(Duration::from_millis(1500)).await;
    for (a, want) in [(1, 1500.0), (2, 750.0), (3, 750.0)] {
        let got = speed(plc.param(a, ParamChannel::read(8318)).await);
        assert!((got - want).abs() < 0.2, "drive {a}: {got} 1/min");
    }
    // A PLC's group telegram to group 5 moves the slaves, never the master.
    plc.send(46, &po([0, 0, 0]));
    sleep(Duration::from_millis(2)).await;
    drop(plc);
    let bus = sim.await.unwrap().unwrap();
    assert_eq!(
        bus.drive(1).unwrap().master_slave(),
        Ok(MasterSlave::Master)
    );
    assert_eq!(bus.drive(2).unwrap().master_slave(), Ok(MasterSlave::Slave));
    assert_eq!(
        bus.drive(1)
            .unwrap()
            .tally()
            .rejected(Rejection::GroupToMaster),
        1
    );
}

/// Ch. 5.4: master-slave operation only at 500 and 1000 kbit/s; at 125 and 250 kbit/s the
/// simulated master refuses, with the reason, and sends nothing.
#[tokio::test(start_paused = true)]
async fn master_refuses_125_and_250_kbit() {
    for (p816, kbit) in [(0, 125_000), (1, 250_000)] {
        let (mut plc, io) = pair();
        let mut drive = SimulatedSbusDrive::new(1);
        write(&mut drive, index::SBUS_TIMEOUT, 0);
        write(&mut drive, index::SBUS_BAUD_RATE, p816);
        write(&mut drive, P750, 2);
        let sim = tokio::spawn(async move { drive.serve(io).await.map(|()| drive) });
        plc.send(11, &po([6, 7500, 0]));
        sleep(Duration::from_millis(10)).await;
        assert!(plc.drain(6).is_empty());
        drop(plc);
        let drive = sim.await.unwrap().unwrap();
        match drive.master_slave() {
            Err(e @ MasterSlaveError::BitrateNotAllowed { bitrate }) => {
                assert_eq!(bitrate.bits_per_second(), kbit);
                assert!(e.to_string().contains("500 or 1000 kbit/s"), "{e}");
            }
            other => panic!("{other:?}"),
        }
    }
}
