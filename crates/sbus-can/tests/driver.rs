//! The async SBus master (`SbusDriver`) over an in-test `CanIo` (tokio channels) against the
//! minimal responder, on tokio's paused clock: every service, sync mode, the SYNC producer's
//! period, exact timeouts, fault injection (lost, corrupted, duplicated and delayed answers:
//! never a wrong value), foreign frames, a closed interface and a cancelled call.

// Test code: helpers outside `#[test]` fns (not exempted by clippy.toml) panic by design.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

mod common;

use std::io;
use std::sync::{Arc, Mutex};
use std::task::{Context, Poll};
use std::time::Duration;

use common::Responder;
use common::responder::UNIT_TYPE;
use drive_core::can::{CanEndpoint, CanFrame};
use drive_core::rt::{CanIo, ReceivedFrame};
use drive_core::{Instant, SplitMix64};
use drive_profile::sew::{AttributeInfo, ParamChannel, ReturnCode, ScaleInfo};
use sbus_can::Address;
use sbus_can::driver::{DriverError, LinkError, ParamServices, SbusDriver, ScanHit};
use sbus_can::master::{Handshake, MasterConfig};
use sbus_can::telegram::ProcessData;
use tokio::sync::mpsc::{UnboundedReceiver, UnboundedSender, unbounded_channel};
use tokio::time::Instant as TokioInstant;

/// The master's end of the in-test bus.
struct ChanIo {
    tx: UnboundedSender<CanFrame>,
    rx: UnboundedReceiver<ReceivedFrame>,
}

impl CanIo for ChanIo {
    fn poll_recv(&mut self, cx: &mut Context<'_>) -> Poll<io::Result<ReceivedFrame>> {
        match self.rx.poll_recv(cx) {
            Poll::Ready(Some(f)) => Poll::Ready(Ok(f)),
            Poll::Ready(None) => Poll::Ready(Err(io::ErrorKind::UnexpectedEof.into())),
            Poll::Pending => Poll::Pending,
        }
    }

    fn poll_send(&mut self, _cx: &mut Context<'_>, frame: &CanFrame) -> Poll<io::Result<()>> {
        Poll::Ready(
            self.tx
                .send(*frame)
                .map_err(|_| io::ErrorKind::BrokenPipe.into()),
        )
    }
}

type Fault = Box<dyn FnMut(&CanFrame) -> Vec<(CanFrame, Duration)> + Send>;
type Log = Arc<Mutex<Vec<(Duration, String)>>>;

/// Drives on the other end: every master frame goes to each (and into the log with its time
/// since `t0`); their answers pass `fault` and arrive at once (or after the fault's delay).
fn spawn_drives(drives: Vec<Responder>, fault: Option<Fault>) -> (ChanIo, Log) {
    let (mtx, mut drx) = unbounded_channel::<CanFrame>();
    let (dtx, mrx) = unbounded_channel::<ReceivedFrame>();
    let log: Log = Arc::default();
    let t0 = TokioInstant::now();
    let l = log.clone();
    tokio::spawn(async move {
        let mut drives = drives;
        let mut fault = fault;
        while let Some(f) = drx.recv().await {
            l.lock()
                .unwrap()
                .push((TokioInstant::now() - t0, f.to_string()));
            for d in drives.iter_mut() {
                d.handle_frame(&f, Instant::ZERO);
                while let Some(out) = d.poll_transmit(Instant::ZERO) {
                    let outs = match fault.as_mut() {
                        Some(fault) => fault(&out),
                        None => vec![(out, Duration::ZERO)],
                    };
                    for (g, delay) in outs {
                        let tx = dtx.clone();
                        let l = l.clone();
                        tokio::spawn(async move {
                            tokio::time::sleep(delay).await;
                            l.lock()
                                .unwrap()
                                .push((TokioInstant::now() - t0, g.to_string()));
                            let _ = tx.send(ReceivedFrame {
                                frame: g,
                                at: TokioInstant::now(),
                            });
                        });
                    }
                }
            }
        }
    });
    (ChanIo { tx: mtx, rx: mrx }, log)
}

fn a(n: u8) -> Address {
    Address::new(n).unwrap()
}

fn master(io: ChanIo, config: MasterConfig) -> SbusDriver<ChanIo> {
    SbusDriver::new(io, config)
}

#[tokio::test(start_paused = true)]
async fn every_service() {
    let mut group_member = Responder::new(2);
    group_member.group = a(9);
    let (io, log) = spawn_drives(vec![Responder::new(1), group_member], None);
    let mut m = master(io, MasterConfig::default());
    assert_eq!(m.read(a(1), 8318).await.unwrap(), 1_000_000);
    m.write(a(1), 8470, 1500).await.unwrap();
    m.write_volatile(a(1), 8470, 1400).await.unwrap();
    assert_eq!(m.read(a(1), 8470).await.unwrap(), 1400);
    assert_eq!(m.read_minimum(a(1), 8470).await.unwrap(), 0);
    assert_eq!(m.read_maximum(a(1), 8470).await.unwrap(), 3_000_000);
    assert_eq!(m.read_default(a(1), 8470).await.unwrap(), 1000);
    assert_eq!(
        m.read_scale(a(1), 8470).await.unwrap(),
        ScaleInfo {
            size_index: 11,
            conversion_index: -3
        }
    );
    assert_eq!(
        m.read_attribute(a(1), 8470).await.unwrap(),
        AttributeInfo {
            next_index: 0x2080,
            attributes: 0x0013
        }
    );
    let ch = m
        .param_with(a(1), ParamChannel::read(8318), Handshake::Sync)
        .await
        .unwrap();
    assert!(ch.management.handshake());
    assert_eq!(
        m.process_data(a(1), ProcessData([6, 5000, 0]))
            .await
            .unwrap(),
        ProcessData([0x0407, 5000, 0])
    );
    assert_eq!(
        m.process_data_sync(a(1), ProcessData([6, 3000, 0]))
            .await
            .unwrap(),
        ProcessData([0x0407, 3000, 0])
    );
    m.group_write(a(9), ParamChannel::write_volatile(8470, 900))
        .await
        .unwrap();
    m.group_process_data(a(9), ProcessData([6, 700, 0]))
        .await
        .unwrap();
    assert_eq!(m.read(a(2), 8470).await.unwrap(), 900);
    m.sync().await.unwrap();
    assert!(matches!(
        m.group_write(a(9), ParamChannel::read(8470)).await,
        Err(DriverError::Request(_))
    ));
    let refused = m.write(a(1), 8318, 5).await.unwrap_err();
    assert!(matches!(
        refused,
        DriverError::Device {
            code: ReturnCode::READ_ONLY,
            ..
        }
    ));
    assert_eq!(
        refused.to_string(),
        "the drive at SBus address 1 refused the service: read access only (error class 8, error code 0, additional code 0x0012)"
    );
    let s = m.stats();
    assert_eq!(
        (s.transactions, s.retries, s.timeouts, s.drive_errors),
        (17, 0, 0, 1)
    );
    assert_eq!(s.rejected.total(), 0);
    assert_eq!(
        log.lock().unwrap().last().unwrap().1,
        "20C#B200207E08000012"
    );
}

/// The scan reports who answered and what, in one timeout.
#[tokio::test(start_paused = true)]
async fn scan_reports_who_answered() {
    let mut refusing = Responder::new(40);
    refusing.values[1] = (1, 0);
    let (io, _log) = spawn_drives(vec![Responder::new(5), refusing, Responder::new(0)], None);
    let mut m = master(io, MasterConfig::default());
    let t0 = TokioInstant::now();
    let hits = m.scan(a(0), a(63)).await.unwrap();
    assert_eq!(
        hits,
        [
            ScanHit {
                address: a(0),
                unit_type: Ok(UNIT_TYPE)
            },
            ScanHit {
                address: a(5),
                unit_type: Ok(UNIT_TYPE)
            },
            ScanHit {
                address: a(40),
                unit_type: Err(ReturnCode::ILLEGAL_INDEX)
            },
        ]
    );
    assert_eq!(t0.elapsed(), Duration::from_millis(20));
    assert_eq!(m.stats().transactions, 64);
}

/// The timeout is exact on the paused clock: three attempts of 20 ms, then an error naming the
/// address, the attempts and the timeout.
#[tokio::test(start_paused = true)]
async fn timeout_is_exact() {
    let (io, log) = spawn_drives(vec![], None);
    let mut m = master(
        io,
        MasterConfig {
            response_timeout: Duration::from_millis(20),
            ..MasterConfig::default()
        },
    );
    let t0 = TokioInstant::now();
    let err = m.read(a(12), 8318).await.unwrap_err();
    assert_eq!(t0.elapsed(), Duration::from_millis(60));
    assert!(matches!(
        err,
        DriverError::Link(LinkError::Timeout {
            attempts: 3,
            response_timeout,
            ..
        }) if response_timeout == Duration::from_millis(20)
    ));
    assert_eq!(
        err.to_string(),
        "no answer from SBus address 12 after 3 attempts of 20 ms each; check the address (P813), the bit rate (P816), wiring and termination, and the sync identifier (P817) for sync-mode services"
    );
    let times: Vec<Duration> = log.lock().unwrap().iter().map(|(t, _)| *t).collect();
    assert_eq!(times, [0, 20, 40].map(Duration::from_millis));
    assert_eq!(m.stats().retries, 2);
    assert_eq!(m.stats().timeouts, 1);
}

/// Sync mode on the paused clock: the request, the driver's SYNC 1 ms later, the answer after
/// it; then no SYNC while nothing waits.
#[tokio::test(start_paused = true)]
async fn sync_mode_read_is_answered_after_the_next_sync() {
    let (io, log) = spawn_drives(vec![Responder::new(3)], None);
    let mut m = master(
        io,
        MasterConfig {
            handshake: Handshake::Sync,
            ..MasterConfig::default()
        },
    );
    let t0 = TokioInstant::now();
    assert_eq!(m.read(a(3), 8318).await.unwrap(), 1_000_000);
    assert_eq!(t0.elapsed(), Duration::from_millis(1));
    tokio::time::sleep(Duration::from_millis(50)).await;
    let log = log.lock().unwrap().clone();
    let expected: Vec<(Duration, String)> = [
        (0, "21B#7100207E00000000"),
        (1, "000#"),
        (1, "21C#7100207E000F4240"),
    ]
    .into_iter()
    .map(|(t, f)| (Duration::from_millis(t), f.to_string()))
    .collect();
    assert_eq!(log, expected);
}

/// `sync_for`: SYNC every 5 ms on P817, exactly.
#[tokio::test(start_paused = true)]
async fn sync_producer_period() {
    let (io, log) = spawn_drives(vec![], None);
    let mut m = master(
        io,
        MasterConfig {
            sync_id: 0x123,
            ..MasterConfig::default()
        },
    );
    m.sync_for(Duration::from_millis(22)).await.unwrap();
    let log = log.lock().unwrap().clone();
    let expected: Vec<(Duration, String)> = (0..5)
        .map(|k| (Duration::from_millis(5 * k), "123#".to_string()))
        .collect();
    assert_eq!(log, expected);
    assert_eq!(m.stats().syncs_sent, 5);
    // Afterwards the producer is off again.
    tokio::time::sleep(Duration::from_millis(20)).await;
    m.read(a(1), 1).await.unwrap_err();
}

/// Fault injection: a lost answer is repeated, an answer with corrupted header bytes
/// (management, index) is rejected and repeated, a duplicate is counted, a delayed answer
/// arrives after the retry: every value returned is right.
#[tokio::test(start_paused = true)]
async fn faults_never_give_a_wrong_value() {
    let mut n = 0u32;
    let fault: Fault = Box::new(move |f| {
        n += 1;
        match n {
            1 => vec![], // lost
            2 => {
                // the index of the answer corrupted
                let mut d = f.data_array();
                d[3] ^= 0x04;
                vec![(
                    CanFrame::standard(f.raw_id() as u16, &d).unwrap(),
                    Duration::ZERO,
                )]
            }
            3 => {
                // the service code corrupted
                let mut d = f.data_array();
                d[0] ^= 0x02;
                vec![(
                    CanFrame::standard(f.raw_id() as u16, &d).unwrap(),
                    Duration::ZERO,
                )]
            }
            5 => vec![(*f, Duration::ZERO), (*f, Duration::from_millis(1))], // duplicated
            7 => vec![(*f, Duration::from_millis(70))],                      // late
            _ => vec![(*f, Duration::ZERO)],
        }
    });
    let (io, _log) = spawn_drives(vec![Responder::new(1)], Some(fault));
    let mut m = master(
        io,
        MasterConfig {
            retries: 3,
            ..MasterConfig::default()
        },
    );
    // 1: lost, 2: corrupted index, 3: corrupted service, 4: the answer.
    assert_eq!(m.read(a(1), 8318).await.unwrap(), 1_000_000);
    assert_eq!(m.stats().retries, 3);
    assert_eq!(m.stats().rejected.mismatch, 2);
    // 5: duplicated, the copy 1 ms later; 6: answered at once.
    assert_eq!(m.read(a(1), 8319).await.unwrap(), 50_000);
    assert_eq!(m.read(a(1), 8470).await.unwrap(), 1000);
    // 7: 70 ms late (timeout 50 ms): the retry's answer (8) comes first. Meanwhile the copy
    // of 5 arrives and is refused (another index).
    assert_eq!(m.read(a(1), 8517).await.unwrap(), 1_500_000);
    assert_eq!(m.stats().rejected.mismatch, 3);
    // 7's late answer arrives while no call runs; the next call hears it before its request
    // goes out: stale, not a rejection.
    tokio::time::sleep(Duration::from_millis(100)).await;
    assert_eq!(m.read(a(1), 8318).await.unwrap(), 1_000_000);
    assert_eq!(m.stats().stale, 1);
    assert_eq!(m.stats().rejected.unsolicited, 0);
}

/// An answer that arrived while no call ran (late, after its request was given up)
/// waits in the interface's queue. It is older than the next request and is refused, even for
/// the same service and index (here it carries a stale value, 111): the driver hears what
/// waits before it sends (issue 18), and a frame read only after the request went out is
/// judged by its receive time. Before the receive time was compared, it was taken.
#[tokio::test(start_paused = true)]
async fn queued_late_answer_is_older_than_the_request() {
    let mut first = true;
    let fault: Fault = Box::new(move |f| {
        if std::mem::take(&mut first) {
            let mut d = f.data_array();
            d[4..8].copy_from_slice(&111u32.to_be_bytes());
            vec![(
                CanFrame::standard(f.raw_id() as u16, &d).unwrap(),
                Duration::from_millis(70),
            )]
        } else {
            vec![(*f, Duration::ZERO)]
        }
    });
    let (io, _log) = spawn_drives(vec![Responder::new(1)], Some(fault));
    let mut m = master(
        io,
        MasterConfig {
            retries: 0,
            ..MasterConfig::default()
        },
    );
    assert!(matches!(
        m.read(a(1), 8318).await,
        Err(DriverError::Link(LinkError::Timeout { .. }))
    ));
    tokio::time::sleep(Duration::from_millis(100)).await;
    assert_eq!(m.read(a(1), 8318).await.unwrap(), 1_000_000);
    assert_eq!(m.stats().stale, 1);
    assert_eq!(m.stats().rejected.unsolicited, 0);
}

/// An interface that stamps a frame when it is read, as the slcan port does (it parses the
/// adapter's line then).
struct StampedWhenRead(ChanIo);

impl CanIo for StampedWhenRead {
    fn poll_recv(&mut self, cx: &mut Context<'_>) -> Poll<io::Result<ReceivedFrame>> {
        self.0.poll_recv(cx).map_ok(|r| ReceivedFrame {
            frame: r.frame,
            at: TokioInstant::now(),
        })
    }

    fn poll_send(&mut self, cx: &mut Context<'_>, frame: &CanFrame) -> Poll<io::Result<()>> {
        self.0.poll_send(cx, frame)
    }
}

/// Issue 18: the late answer (a stale value, 111) waits in an interface that stamps frames
/// when they are read. Read only after the next request went out, it would look younger than
/// that request and pass every check (same drive, service and index); the driver hears what
/// waits before it sends, so it is counted as stale and the drive's answer is taken. It failed
/// before: the read returned 111.
#[tokio::test(start_paused = true)]
async fn issue18_an_answer_waiting_in_an_interface_timed_when_read_is_stale() {
    let mut first = true;
    let fault: Fault = Box::new(move |f| {
        if std::mem::take(&mut first) {
            let mut d = f.data_array();
            d[4..8].copy_from_slice(&111u32.to_be_bytes());
            vec![(
                CanFrame::standard(f.raw_id() as u16, &d).unwrap(),
                Duration::from_millis(70),
            )]
        } else {
            vec![(*f, Duration::ZERO)]
        }
    });
    let (io, _log) = spawn_drives(vec![Responder::new(1)], Some(fault));
    let mut m = SbusDriver::new(
        StampedWhenRead(io),
        MasterConfig {
            retries: 0,
            ..MasterConfig::default()
        },
    );
    assert!(matches!(
        m.read(a(1), 8318).await,
        Err(DriverError::Link(LinkError::Timeout { .. }))
    ));
    tokio::time::sleep(Duration::from_millis(100)).await;
    assert_eq!(m.read(a(1), 8318).await.unwrap(), 1_000_000);
    assert_eq!((m.stats().stale, m.stats().rejected.total()), (1, 0));
}

/// A seeded campaign: answers dropped, duplicated, delayed beyond the timeout or with a
/// corrupted index, over reads of alternating indices: every value returned is the value of
/// the index asked.
#[tokio::test(start_paused = true)]
async fn fault_campaign_no_wrong_value() {
    let mut rng = SplitMix64::new(10);
    let fault: Fault = Box::new(move |f| {
        let r = rng.next_u64() % 10;
        match r {
            0 => vec![],
            1 => vec![(*f, Duration::ZERO), (*f, Duration::from_millis(3))],
            2 => vec![(*f, Duration::from_millis(60 + rng.next_u64() % 80))],
            3 => {
                let mut d = f.data_array();
                d[2] ^= 1 << (rng.next_u64() % 8);
                vec![(
                    CanFrame::standard(f.raw_id() as u16, &d).unwrap(),
                    Duration::ZERO,
                )]
            }
            _ => vec![(*f, Duration::from_millis(rng.next_u64() % 3))],
        }
    });
    let (io, _log) = spawn_drives(vec![Responder::new(8)], Some(fault));
    let mut m = master(io, MasterConfig::default());
    let expected = [
        (8318u16, 1_000_000u32),
        (8301, UNIT_TYPE),
        (8319, 50_000),
        (8470, 1000),
    ];
    let (mut ok, mut failed) = (0, 0);
    for i in 0..300 {
        let (index, value) = expected[i % expected.len()];
        match m.read(a(8), index).await {
            Ok(v) => {
                assert_eq!(v, value, "read {i} of {index}");
                ok += 1;
            }
            Err(DriverError::Link(LinkError::Timeout { .. })) => failed += 1,
            Err(e) => panic!("{e}"),
        }
    }
    let s = m.stats();
    assert!(ok > 250, "{ok} ok, {failed} failed, {s:?}");
    assert!(s.retries > 30 && s.rejected.total() > 30, "{s:?}");
}

/// Frames of other nodes (variable telegrams, another master's requests) are ignored and
/// counted; the answer is still found.
#[tokio::test(start_paused = true)]
async fn foreign_frames_are_ignored_and_counted() {
    let fault: Fault = Box::new(|f| {
        vec![
            (
                CanFrame::standard(1025, &[0x11, 0x22, 0x33, 0x44]).unwrap(),
                Duration::ZERO,
            ),
            (
                CanFrame::standard(8 * 30 + 515, &[0x31, 0, 0x20, 0x7E, 0, 0, 0, 0]).unwrap(),
                Duration::ZERO,
            ),
            (*f, Duration::ZERO),
        ]
    });
    let (io, _log) = spawn_drives(vec![Responder::new(1)], Some(fault));
    let mut m = master(io, MasterConfig::default());
    assert_eq!(m.read(a(1), 8318).await.unwrap(), 1_000_000);
    assert_eq!(m.stats().rejected.foreign, 2);
}

#[tokio::test(start_paused = true)]
async fn closed_interface_and_cancelled_call() {
    let (io, _log) = spawn_drives(
        vec![Responder::new(1)],
        Some(Box::new(|f| vec![(*f, Duration::from_millis(30))])),
    );
    let mut m = master(io, MasterConfig::default());
    // Cancelled after 10 ms: the next call drops the abandoned request; its late answer
    // (at 30 ms, while the next request waits for the late guard) is counted as stale, not
    // taken as the answer to the next read of another index.
    assert!(
        tokio::time::timeout(Duration::from_millis(10), m.read(a(1), 8318))
            .await
            .is_err()
    );
    assert_eq!(m.read(a(1), 8319).await.unwrap(), 50_000);
    assert_eq!(m.stats().stale, 1);
    // The other end goes away: Closed.
    let (io, _) = spawn_drives(vec![], None);
    let ChanIo { tx, rx } = io;
    drop(rx);
    let (_dtx, mrx) = unbounded_channel::<ReceivedFrame>();
    drop(_dtx);
    let mut m = master(ChanIo { tx, rx: mrx }, MasterConfig::default());
    let err = m.read(a(1), 8318).await.unwrap_err();
    assert!(
        matches!(err, DriverError::Link(LinkError::Closed)),
        "{err:?}"
    );
    assert_eq!(err.to_string(), "the CAN interface was closed");
}
