//! A simulated MOVIDRIVE executing MOVLNK (manual ch. 5.3) towards other simulated drives, on
//! the virtual CAN bus at 500 kbit/s and tokio's paused clock: the manual's example run as its
//! program does (in a loop), volatile and non-volatile writes, group writes, a missing drive, a
//! refused service, the raw IPOS variables.

// Test code: helpers outside `#[test]` fns (not exempted by clippy.toml) panic by design.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

use std::future::Future;
use std::io;
use std::pin::Pin;
use std::task::{Context, Poll};
use std::time::Duration;

use drive_core::can::{Bitrate, CanFrame};
use drive_core::rt::{CanIo, ReceivedFrame, recv_frame};
use drive_profile::sew::{ReturnCode, StatusWord1, UnitStatus, index};
use drive_transport::can::virtual_bus::{VirtualBus, VirtualNode};
use sbus_can::movlnk::{MlData, MovlnkCommand, MovlnkDone, MovlnkError};
use sbus_can::sim::{MovlnkHandle, SimulatedSbusBus};
use tokio::sync::oneshot;
use tokio::task::JoinHandle;
use tokio::time::Instant as TokioInstant;

/// The manual's command: SBus, address 1, Param + 3PD, read, index 8318 (P000 speed), H20.
const MANUAL: [i32; 7] = [5, 1, 4, 1, 8318, 20, 0];

/// A node whose receive ends (EOF, so that `serve` returns) when `stop` fires: several nodes
/// keep each other's bus alive, so dropping the bus handle does not end them.
struct Stoppable {
    node: VirtualNode,
    stop: oneshot::Receiver<()>,
}

impl CanIo for Stoppable {
    fn poll_recv(&mut self, cx: &mut Context<'_>) -> Poll<io::Result<ReceivedFrame>> {
        if let Poll::Ready(r) = self.node.poll_recv(cx) {
            return Poll::Ready(r);
        }
        match Pin::new(&mut self.stop).poll(cx) {
            Poll::Ready(_) => Poll::Ready(Err(io::ErrorKind::UnexpectedEof.into())),
            Poll::Pending => Poll::Pending,
        }
    }

    fn poll_send(&mut self, cx: &mut Context<'_>, frame: &CanFrame) -> Poll<io::Result<()>> {
        self.node.poll_send(cx, frame)
    }
}

/// A running test bus: simulated drives behind nodes of their own, a sniffer node that sees
/// their frames.
struct TestBus {
    vbus: VirtualBus,
    sniffer: VirtualNode,
    tasks: Vec<(oneshot::Sender<()>, JoinHandle<SimulatedSbusBus>)>,
}

impl TestBus {
    fn new() -> Self {
        let vbus = VirtualBus::new(Bitrate::K500);
        let sniffer = vbus.node();
        Self {
            vbus,
            sniffer,
            tasks: Vec::new(),
        }
    }

    /// Serve `sims` on a node of its own.
    fn serve(&mut self, mut sims: SimulatedSbusBus) {
        let (tx, stop) = oneshot::channel();
        let io = Stoppable {
            node: self.vbus.node(),
            stop,
        };
        let task = tokio::spawn(async move {
            sims.serve(io).await.unwrap();
            sims
        });
        self.tasks.push((tx, task));
    }

    /// The frames on the bus so far (candump spelling).
    async fn frames(&mut self) -> Vec<String> {
        let mut v = Vec::new();
        while self.sniffer.pending_rx() > 0 {
            let f: CanFrame = recv_frame(&mut self.sniffer).await.unwrap().frame;
            v.push(f.to_string());
        }
        v
    }

    /// End the bus; the simulated drives back, in the order served.
    async fn stop(self) -> Vec<SimulatedSbusBus> {
        let Self {
            vbus,
            sniffer,
            tasks,
        } = self;
        drop((vbus, sniffer));
        let mut out = Vec::new();
        for (stop, task) in tasks {
            drop(stop);
            out.push(task.await.unwrap());
        }
        out
    }
}

/// Drives 5 (the MOVLNK master) and 1 on one node; the handle of drive 5.
fn drives_5_and_1(bus: &mut TestBus) -> MovlnkHandle {
    let sims = SimulatedSbusBus::new(&[5, 1]);
    let h = sims.movlnk_handle(5).unwrap();
    bus.serve(sims);
    h
}

fn command(vars: [i32; 7]) -> MovlnkCommand {
    MovlnkCommand::from_vars(vars).unwrap()
}

/// Manual ch. 5.3 as its program runs it (`while(1) _Movilink(Ml);`), with the listing's PO
/// 6 / 5000 / 0 (SB-E41): drive 5 enables drive 1, which ramps to 1000 1/min. Every run:
/// Result 0, ReadPar = drive 1's P000 speed (0.001 1/min) read before the run's PO, PI1 its
/// status word (enabled), PI2 its speed word (0.2 1/min per digit). At the end the table's
/// ReadPar 1 000 000 and PI2 5000 (the manual's 5011 is a real motor's 1002.2 1/min). PI3 is
/// drive 1's output current with the factory P875 (SB-E50).
#[tokio::test(start_paused = true)]
async fn manual_example_5_3_enables_and_ramps_drive_1() {
    let mut bus = TestBus::new();
    let h = drives_5_and_1(&mut bus);
    let cmd = command(MANUAL);
    let mut data = MlData::from_vars([0, 0, 6, 5000, 0, 0, 0, 0]);
    let started = TokioInstant::now();

    // The first run: the frames of the command, in order, and drive 1 enabled.
    let first = h.execute(cmd, data).await.unwrap();
    assert_eq!((first.result, first.error), (0, None));
    let frames = bus.frames().await;
    assert_eq!(frames.len(), 4, "{frames:?}");
    assert_eq!(frames[0], "20B#3100207E00000000"); // read 8318 from address 1
    assert!(frames[1].starts_with("20C#3100207E"), "{frames:?}"); // its answer
    assert_eq!(frames[2], "00B#000613880000"); // PO 6 / 5000 / 0 on 8 × 1 + 3
    assert!(frames[3].starts_with("00C#"), "{frames:?}"); // PI on 8 × 1 + 4
    assert_eq!(first.data.read_par, 0, "standing before the PO");
    let status = StatusWord1::from_bits(first.data.pi[0] as u16);
    assert_eq!(status.unit_status(), Some(UnitStatus::Enable), "{status}");
    data = first.data;

    let mut last: Option<MovlnkDone> = None;
    let mut runs = 1;
    while data.read_par < 1_000_000 {
        assert!(runs < 20_000, "no 1000 1/min after {runs} runs: {data:?}");
        let done = h.execute(cmd, data).await.unwrap();
        assert_eq!(done.result, 0, "run {runs}: {done:?}");
        // ReadPar (read before the PO) never exceeds the previous run's PI2 (after its PO) by
        // more than the speed gained in one run; the ramp only rises.
        assert!(
            done.data.read_par >= data.read_par,
            "{done:?} after {data:?}"
        );
        assert!(
            done.data.read_par <= data.pi[1] * 200 + 5_000,
            "{done:?} after {data:?}"
        );
        data = done.data;
        last = Some(done);
        runs += 1;
    }
    let last = last.unwrap();
    assert_eq!(last.data.read_par, 1_000_000);
    assert_eq!(last.data.pi[1], 5000);
    // PI3: the factory P875 = output current, not the example's "no function" (SB-E50).
    assert_ne!(last.data.pi[2], 0);
    assert!(
        started.elapsed() > Duration::from_millis(100),
        "a ramp takes time"
    );

    // Drive 1's model agrees with the last PI.
    let sims = bus.stop().await;
    let d1 = sims[0].drive(1).unwrap().movidrive();
    let mut pi = [0u16; 3];
    d1.process_input(&mut pi);
    assert_eq!(pi.map(i32::from), last.data.pi);
    assert!((d1.actual_speed_rpm() - 1000.0).abs() < 0.01);
    // Drive 5 stays a slave at its own address: nothing addressed it.
    assert_eq!(
        sims[0].drive(5).unwrap().movidrive().actual_speed_rpm(),
        0.0
    );
}

/// Service 3 (write without storing) changes drive 1's P130 ramp in RAM only; service 2 writes
/// RAM and EEPROM. Drive 5 and drive 1 on two buses on two nodes of the virtual bus.
#[tokio::test(start_paused = true)]
async fn volatile_write_changes_ram_only() {
    let mut bus = TestBus::new();
    let master = SimulatedSbusBus::new(&[5]);
    let h = master.movlnk_handle(5).unwrap();
    bus.serve(master);
    bus.serve(SimulatedSbusBus::new(&[1]));
    let ramp = i32::from(index::RAMP_T11_UP_CW);

    let mut data = MlData {
        write_par: 500,
        ..MlData::default()
    };
    let done = h
        .execute(command([5, 1, 6, 3, ramp, 20, 0]), data)
        .await
        .unwrap();
    assert_eq!((done.result, done.error), (0, None));
    assert_eq!(done.data, data, "a write changes nothing in the block");
    // Write volatile (0x33 = service 3, 4 bytes), then the answer; no process data (format 6).
    assert_eq!(
        bus.frames().await,
        ["20B#33002116000001F4", "20C#3300211600000000"]
    );
    data.write_par = 700;
    let done = h
        .execute(command([5, 1, 6, 2, 8478, 20, 0]), data)
        .await
        .unwrap();
    assert_eq!(done.result, 0);

    let sims = bus.stop().await;
    let store = sims[1].drive(1).unwrap().movidrive().drive().store();
    let ramp = index::RAMP_T11_UP_CW;
    assert_eq!(store.read(ramp, 0).unwrap(), 500);
    assert_ne!(store.read_eeprom(ramp, 0).unwrap(), 500, "not stored");
    assert_eq!(store.nv_writes(ramp, 0).unwrap(), 0);
    assert_eq!(store.read(8478, 0).unwrap(), 700);
    assert_eq!(store.read_eeprom(8478, 0).unwrap(), 700, "stored");
    assert_eq!(store.nv_writes(8478, 0).unwrap(), 1);
}

/// `MI.Address` = 100 + g: a group write (service 3) reaches every drive of group g (P814)
/// beside the executing drive and on other nodes, nobody answers, Result 0. The executing
/// drive, in the same group, does not receive its own telegram (a CAN controller does not);
/// a drive of another group is untouched.
#[tokio::test(start_paused = true)]
async fn group_write_reaches_every_drive_of_the_group() {
    let mut bus = TestBus::new();
    let mut here = SimulatedSbusBus::new(&[5, 1, 7]);
    let mut there = SimulatedSbusBus::new(&[2]);
    let set_group = |bus: &mut SimulatedSbusBus, a: u8| {
        bus.drive_mut(a)
            .unwrap()
            .movidrive_mut()
            .drive_mut()
            .store_mut()
            .set_internal(index::SBUS_GROUP_ADDRESS, 3)
            .unwrap();
    };
    set_group(&mut here, 5);
    set_group(&mut here, 1);
    set_group(&mut there, 2);
    let h = here.movlnk_handle(5).unwrap();
    bus.serve(here);
    bus.serve(there);
    let ramp = i32::from(index::RAMP_T11_UP_CW);
    let data = MlData {
        write_par: 700,
        read_par: 42,
        ..MlData::default()
    };
    let started = TokioInstant::now();
    let done = h
        .execute(command([5, 103, 6, 3, ramp, 20, 0]), data)
        .await
        .unwrap();
    assert_eq!((done.result, done.error), (0, None));
    assert_eq!(done.data, data, "nothing read back");
    assert!(
        started.elapsed() < Duration::from_millis(2),
        "no answer awaited"
    );
    // One group parameter request (8 × 3 + 518 = 542 = 21Eh) and nothing else: no drive answers it.
    tokio::time::sleep(Duration::from_millis(50)).await;
    assert_eq!(bus.frames().await, ["21E#33002116000002BC"]);

    let sims = bus.stop().await;
    let ramp_of = |bus: &SimulatedSbusBus, a: u8| {
        let store = bus.drive(a).unwrap().movidrive().drive().store();
        store.read(index::RAMP_T11_UP_CW, 0).unwrap()
    };
    assert_eq!(ramp_of(&sims[0], 1), 700);
    assert_eq!(ramp_of(&sims[1], 2), 700);
    assert_ne!(ramp_of(&sims[0], 7), 700, "group 0");
    assert_ne!(ramp_of(&sims[0], 5), 700, "its own telegram");
}

/// A command to an address nobody has: Result −1 (timeout), ReadPar and PI untouched, in
/// bounded time: one 50 ms attempt for the parameter request, the 50 ms late guard, one 50 ms
/// attempt for the PO.
#[tokio::test(start_paused = true)]
async fn nobody_at_the_address_times_out_in_bounded_time() {
    let mut bus = TestBus::new();
    let h = drives_5_and_1(&mut bus);
    let data = MlData::from_vars([0, 11, 6, 5000, 0, 22, 33, 44]);
    let started = TokioInstant::now();
    let done = h
        .execute(command([5, 9, 4, 1, 8318, 20, 0]), data)
        .await
        .unwrap();
    let took = started.elapsed();
    assert_eq!(done.result, MovlnkError::RESULT_TIMEOUT);
    assert_eq!(done.result, -1);
    assert_eq!(done.error, Some(MovlnkError::Timeout));
    assert_eq!(done.data, data);
    assert!(
        (Duration::from_millis(150)..=Duration::from_millis(153)).contains(&took),
        "{took:?}"
    );
    // The request (8 × 9 + 515) and the PO (8 × 9 + 3), once each.
    assert_eq!(
        bus.frames().await,
        ["24B#3100207E00000000", "04B#000613880000"]
    );
    // The drive takes the next command at once.
    let done = h
        .execute(command([5, 1, 6, 1, 8318, 20, 0]), data)
        .await
        .unwrap();
    assert_eq!(done.result, 0);
    bus.stop().await;
}

/// A refused service: a write to P000 speed (read-only) gets the drive's return code as
/// `MI.Result` (its 32 bits); the PO exchange of the format still runs and updates PI.
#[tokio::test(start_paused = true)]
async fn refused_service_gives_the_return_code() {
    let mut bus = TestBus::new();
    let h = drives_5_and_1(&mut bus);
    let data = MlData::from_vars([1, 0, 0, 0, 0, 0, 0, 0]);
    let done = h
        .execute(command([5, 1, 4, 2, 8318, 20, 0]), data)
        .await
        .unwrap();
    assert_eq!(done.error, Some(MovlnkError::Drive(ReturnCode::READ_ONLY)));
    assert_eq!(done.result, ReturnCode::READ_ONLY.to_data() as i32);
    assert!(done.result > 0);
    assert_ne!(done.data.pi[0], 0, "PI1 = drive 1's status word");
    let done = h
        .execute(command([5, 1, 6, 1, 9999, 20, 0]), data)
        .await
        .unwrap();
    assert_eq!(done.result, ReturnCode::ILLEGAL_INDEX.to_data() as i32);
    assert_eq!(done.result, 0x0800_0010, "the module docs' example");
    bus.stop().await;
}

/// The raw IPOS variables: `MI.Result` written back; a command structure that does not parse
/// (reserved bus type 3) or one for RS-485 is not sent.
#[tokio::test(start_paused = true)]
async fn ipos_variables() {
    let mut bus = TestBus::new();
    let h = drives_5_and_1(&mut bus);
    let (mi, mld) = h
        .execute_vars(MANUAL, [0, 0, 6, 5000, 0, 0, 0, 0])
        .await
        .unwrap();
    assert_eq!(mi, MANUAL, "Result 0");
    assert_eq!(mld[..5], [0, 0, 6, 5000, 0]);
    assert_ne!(mld[5], 0, "PI1");
    assert_eq!(bus.frames().await.len(), 4);

    let (mi, _) = h
        .execute_vars([3, 1, 4, 1, 8318, 20, 0], mld)
        .await
        .unwrap();
    assert_eq!(mi[6], MovlnkError::RESULT_BAD_COMMAND);
    let (mi, back) = h
        .execute_vars([1, 1, 4, 1, 8318, 20, 0], mld)
        .await
        .unwrap();
    assert_eq!(mi[6], MovlnkError::RESULT_NOT_SBUS);
    assert_eq!(back, mld);
    let (mi, _) = h
        .execute_vars([5, 1, 4, 1, 8318, 20, 0], [0, 0, 6, 70_000, 0, 0, 0, 0])
        .await
        .unwrap();
    assert_eq!(mi[6], MovlnkError::RESULT_PO_RANGE);
    assert!(bus.frames().await.is_empty(), "nothing sent");
    bus.stop().await;
}

/// A second command while one runs is refused (Busy, Result −2) without disturbing the first;
/// a handle whose bus is gone says so.
#[tokio::test(start_paused = true)]
async fn one_command_at_a_time_and_gone() {
    let mut bus = TestBus::new();
    let h = drives_5_and_1(&mut bus);
    let slow = command([5, 9, 6, 1, 8318, 20, 0]); // nobody: 50 ms
    let (a, b) = tokio::join!(
        h.execute(slow, MlData::default()),
        h.execute(command(MANUAL), MlData::default())
    );
    assert_eq!(a.unwrap().result, MovlnkError::RESULT_TIMEOUT);
    let b = b.unwrap();
    assert_eq!(b.error, Some(MovlnkError::Busy));
    assert_eq!(b.result, MovlnkError::RESULT_BAD_COMMAND);
    drop(bus.stop().await);
    assert!(h.execute(slow, MlData::default()).await.is_err());
}

/// SB-E50: ch. 5.1 gives P875 (PI3 description) the factory setting "KEINE FUNKTION" and the
/// ch. 5.3 example reads PI3 = 0 "auf Keine Funktion programmiert"; the parameter list gives
/// P875 default 2 = output current. The simulated drive follows the parameter list: PI3 is the
/// output current until P875 is set to 0, and then the example's 0.
#[tokio::test(start_paused = true)]
async fn pi3_is_the_output_current_unless_p875_is_0_sb_e50() {
    let p875 = drive_profile::sew::by_number(875).unwrap();
    assert_eq!(p875.index, 8309);
    assert_eq!(p875.default, Some(2), "2 = output current");
    let mut bus = TestBus::new();
    let h = drives_5_and_1(&mut bus);
    let cmd = command(MANUAL);
    let mut data = MlData::from_vars([0, 0, 6, 5000, 0, 0, 0, 0]);
    data = h.execute(cmd, data).await.unwrap().data;
    assert_ne!(data.pi[2], 0, "the output current of the enabled drive");
    // P875 = 0 (no function), written by the MOVLNK drive itself (service 3, format 6).
    let set = h
        .execute(command([5, 1, 6, 3, 8309, 20, 0]), MlData::default())
        .await
        .unwrap();
    assert_eq!(set.result, 0);
    let done = h.execute(cmd, data).await.unwrap();
    assert_eq!(done.result, 0);
    assert_eq!(done.data.pi[2], 0, "the example's PI3 = 0");
    bus.stop().await;
}

/// Regression (found with the group test above): P814 set through `movidrive_mut` before any
/// frame was applied only *after* the first frame, so a group telegram arriving first was
/// ignored by a drive of that group. The setting now counts for that frame.
#[test]
fn p814_set_before_the_first_frame_counts_for_it() {
    use drive_core::Instant;
    use drive_core::can::CanEndpoint;
    use drive_profile::sew::ParamChannel;
    use sbus_can::sim::SimulatedSbusDrive;
    use sbus_can::{Address, Telegram};

    let mut d = SimulatedSbusDrive::new(1);
    d.movidrive_mut()
        .drive_mut()
        .store_mut()
        .set_internal(index::SBUS_GROUP_ADDRESS, 3)
        .unwrap();
    let frame = Telegram::GroupParamRequest {
        group: Address::new(3).unwrap(),
        channel: ParamChannel::write_volatile(index::RAMP_T11_UP_CW, 700),
    }
    .encode(0);
    d.handle_frame(&frame, Instant::from_millis(1));
    let store = d.movidrive().drive().store();
    assert_eq!(store.read(index::RAMP_T11_UP_CW, 0).unwrap(), 700);
    assert_eq!(
        d.poll_transmit(Instant::from_millis(1)),
        None,
        "never answered"
    );
}
