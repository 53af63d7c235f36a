//! The sans-IO SBus master against the minimal responder on a loop bus (no tokio): services,
//! both handshake modes, process data, groups, the SYNC producer and its windows, scan,
//! timeouts, retries, late and mismatching answers, foreign frames.

// Test code: helpers outside `#[test]` fns (not exempted by clippy.toml) panic by design.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

mod common;

use std::time::Duration;

use common::{Bus, LATENCY, Responder};
use drive_core::Instant;
use drive_core::can::{CanFrame, Frame};
use drive_profile::sew::{ParamChannel, ReturnCode, Service};
use proptest::prelude::*;
use sbus_can::Address;
use sbus_can::master::{
    Answer, Handshake, MasterConfig, MasterError, MasterEvent, RequestError, SbusMaster, ScanEntry,
    SyncProducer,
};
use sbus_can::telegram::{ProcessData, Telegram};

fn a(n: u8) -> Address {
    Address::new(n).unwrap()
}

fn bus(drives: &[u8]) -> Bus {
    Bus::new(
        SbusMaster::new(MasterConfig::default()),
        drives.iter().map(|&d| Responder::new(d)).collect(),
    )
}

fn done(ev: Option<MasterEvent>) -> Result<Answer, MasterError> {
    match ev {
        Some(MasterEvent::Done(r)) => r,
        other => panic!("expected Done, got {other:?}"),
    }
}

fn param_ok(ev: Option<MasterEvent>) -> ParamChannel {
    match done(ev) {
        Ok(Answer::Param(ch)) => ch,
        other => panic!("expected a parameter answer, got {other:?}"),
    }
}

/// Manual ch. 5.3: read of index 8318 at SBus address 1 → 1 000 000 (1000.000 1/min); the
/// request on 523 and the answer on 524.
#[test]
fn manual_read_8318_at_address_1() {
    let mut b = bus(&[1]);
    let t = b.now;
    b.master
        .param(a(1), ParamChannel::read(8318), Handshake::Async, t)
        .unwrap();
    let ch = param_ok(b.run(Duration::from_millis(100)));
    assert_eq!(ch.data, 1_000_000);
    let frames: Vec<String> = b.log.iter().map(|(_, _, f)| f.to_string()).collect();
    assert_eq!(frames, ["20B#3100207E00000000", "20C#3100207E000F4240"]);
    assert_eq!(b.master.stats().transactions, 1);
    assert_eq!(b.master.stats().rejected.total(), 0);
}

#[test]
fn every_service_in_both_handshake_modes() {
    let services = [
        (Service::Read, 8470, 0, 1000),
        (Service::Write, 8470, 1500, 0),
        (Service::WriteVolatile, 8470, 1200, 0),
        (Service::ReadMinimum, 8470, 0, 0),
        (Service::ReadMaximum, 8470, 0, 3_000_000),
        (Service::ReadDefault, 8470, 0, 1000),
        (Service::ReadScale, 8470, 0, 0x0BFD),
        (Service::ReadAttribute, 8470, 0, 0x2080_0013),
    ];
    for hs in [Handshake::Async, Handshake::Sync] {
        let mut b = bus(&[7]);
        for (service, index, data, expected) in services {
            let t = b.now;
            let req = ParamChannel::request(service, index, data);
            b.master.param(a(7), req, hs, t).unwrap();
            let ch = param_ok(b.run(Duration::from_millis(100)));
            assert_eq!(ch.data, expected, "{service} {hs:?}");
            assert_eq!(ch.management.service(), Some(service));
            assert_eq!(ch.management.handshake(), hs == Handshake::Sync);
            // The request carried bit 6 as asked.
            let (_, req_frame) = *b
                .sent()
                .iter()
                .rev()
                .find(|(_, f)| f.raw_id() == 8 * 7 + 515)
                .unwrap();
            assert_eq!(
                req_frame.data()[0],
                0x30 | service.code() | if hs == Handshake::Sync { 0x40 } else { 0 }
            );
        }
        // The writes landed: 1200 after the volatile write.
        let t = b.now;
        b.master
            .param(a(7), ParamChannel::read(8470), hs, t)
            .unwrap();
        assert_eq!(param_ok(b.run(Duration::from_millis(100))).data, 1200);
    }
}

/// Sync mode: the answer comes only after the SYNC the master produces 1 ms after the request,
/// on the sync identifier P817 and without data.
#[test]
fn sync_mode_answer_follows_the_masters_sync() {
    let mut b = Bus::new(
        SbusMaster::new(MasterConfig {
            sync_id: 1000,
            ..MasterConfig::default()
        }),
        vec![Responder {
            sync_id: 1000,
            ..Responder::new(3)
        }],
    );
    b.master
        .param(
            a(3),
            ParamChannel::read(8318),
            Handshake::Sync,
            Instant::ZERO,
        )
        .unwrap();
    assert_eq!(param_ok(b.run(Duration::from_millis(100))).data, 1_000_000);
    let log: Vec<(u64, String)> = b
        .log
        .iter()
        .map(|(t, _, f)| (t.as_micros(), f.to_string()))
        .collect();
    assert_eq!(
        log,
        [
            (250, "21B#7100207E00000000".to_string()),
            (1250, "3E8#".to_string()),
            (1500, "21C#7100207E000F4240".to_string()),
        ]
    );
    // The producer stops once nothing waits for a SYNC.
    assert_eq!(b.master.poll_timeout(), None);
}

/// With another node as SYNC producer and none on the bus, a sync-mode request cannot hang:
/// each attempt ends one period + the lead + the timeout after it, and the give-up names the
/// address, the attempts and the timeout.
#[test]
fn sync_mode_without_sync_gives_up_in_bounded_time() {
    let config = MasterConfig {
        sync_producer: SyncProducer::External,
        retries: 1,
        response_timeout: Duration::from_millis(10),
        late_guard: Duration::from_millis(10),
        ..MasterConfig::default()
    };
    let mut b = Bus::new(SbusMaster::new(config), vec![Responder::new(3)]);
    b.master
        .param(
            a(3),
            ParamChannel::read(8318),
            Handshake::Sync,
            Instant::ZERO,
        )
        .unwrap();
    let err = done(b.run(Duration::from_secs(10))).unwrap_err();
    assert_eq!(
        err,
        MasterError::Timeout {
            address: a(3),
            attempts: 2,
            response_timeout: Duration::from_millis(10)
        }
    );
    assert_eq!(b.now, Instant::from_millis(2 * (5 + 1 + 10)));
    assert_eq!(
        err.to_string(),
        "no answer from SBus address 3 after 2 attempts of 10 ms each"
    );
    // Held answers were never released: no SYNC went out.
    assert!(b.log.iter().all(|(_, _, f)| f.raw_id() != 0));
    // An external SYNC releases the answer; the attempt then ends SYNC + timeout at the latest.
    b.master
        .param(a(3), ParamChannel::read(8318), Handshake::Sync, b.now)
        .unwrap();
    // (The request goes out after the 10 ms late guard, the SYNC 2 ms later.)
    let at = b.now.saturating_add(Duration::from_millis(12));
    b.inject(CanFrame::standard(0, &[]).unwrap(), at);
    assert_eq!(param_ok(b.run(Duration::from_millis(100))).data, 1_000_000);
    assert_eq!(b.master.stats().syncs_seen, 1);
}

#[test]
fn drive_refusal_is_a_typed_return_code() {
    let mut b = bus(&[5]);
    b.master
        .param(
            a(5),
            ParamChannel::write(8318, 1),
            Handshake::Async,
            Instant::ZERO,
        )
        .unwrap();
    assert_eq!(
        done(b.run(Duration::from_millis(100))),
        Err(MasterError::Drive {
            address: a(5),
            code: ReturnCode::READ_ONLY
        })
    );
    let t = b.now;
    b.master
        .param(a(5), ParamChannel::read(9999), Handshake::Async, t)
        .unwrap();
    assert_eq!(
        done(b.run(Duration::from_millis(100))),
        Err(MasterError::Drive {
            address: a(5),
            code: ReturnCode::ILLEGAL_INDEX
        })
    );
    assert_eq!(b.master.stats().drive_errors, 2);
}

/// A response that answers another index is counted and never taken; the request is retried
/// and finally given up.
#[test]
fn mismatching_response_is_rejected_not_taken() {
    let mut b = bus(&[2]);
    // The "drive" answers every request with index 8319.
    b.fault = Some(Box::new(|f: &CanFrame| {
        let mut d = f.data_array();
        d[3] = 0x7F;
        vec![(
            CanFrame::standard(f.raw_id() as u16, &d).unwrap(),
            Duration::ZERO,
        )]
    }));
    b.master
        .param(
            a(2),
            ParamChannel::read(8318),
            Handshake::Async,
            Instant::ZERO,
        )
        .unwrap();
    let err = done(b.run(Duration::from_secs(1))).unwrap_err();
    assert!(
        matches!(err, MasterError::Timeout { attempts: 3, .. }),
        "{err:?}"
    );
    let s = b.master.stats();
    assert_eq!((s.rejected.mismatch, s.retries, s.timeouts), (3, 2, 1));
}

/// A late answer to an abandoned request is not taken as the
/// answer to the next, different request, nor to the same one asked again.
#[test]
fn late_answer_to_earlier_request_is_not_taken() {
    let config = MasterConfig {
        retries: 0,
        response_timeout: Duration::from_millis(10),
        late_guard: Duration::from_millis(10),
        ..MasterConfig::default()
    };
    let mut b = Bus::new(SbusMaster::new(config), vec![Responder::new(4)]);
    // Every answer of the drive arrives 15 ms late (after the 10 ms timeout).
    let mut slow = true;
    b.fault = Some(Box::new(move |f: &CanFrame| {
        let delay = if slow {
            Duration::from_millis(15)
        } else {
            Duration::ZERO
        };
        slow = false;
        vec![(*f, delay)]
    }));
    b.master
        .param(
            a(4),
            ParamChannel::read(8318),
            Handshake::Async,
            Instant::ZERO,
        )
        .unwrap();
    assert!(done(b.run(Duration::from_secs(1))).is_err());
    let gave_up = b.now;
    // The next request (another index) waits the late guard: the late answer (8318, due at
    // 15.25 ms) arrives before it went out and is counted as stale (issue 18).
    let t = b.now;
    b.master
        .param(a(4), ParamChannel::read(8319), Handshake::Async, t)
        .unwrap();
    let ch = param_ok(b.run(Duration::from_secs(1)));
    assert_eq!((ch.index, ch.data), (8319, 50_000));
    let sent = b.sent();
    assert!(sent.last().unwrap().0 >= gave_up.saturating_add(Duration::from_millis(10)));
    assert_eq!(b.master.stats().stale, 1);
    assert_eq!(b.master.stats().rejected.unsolicited, 0);

    // Without the guard, a late answer reaching the next request is still refused by index.
    let mut m = SbusMaster::new(MasterConfig {
        late_guard: Duration::ZERO,
        ..MasterConfig::default()
    });
    m.param(
        a(4),
        ParamChannel::read(8319),
        Handshake::Async,
        Instant::ZERO,
    )
    .unwrap();
    m.poll_transmit(Instant::ZERO).unwrap();
    let late = Telegram::ParamResponse {
        address: a(4),
        channel: ParamChannel::read(8318).answer(Ok(1_000_000)),
    };
    m.handle_frame(&late.encode(0), Instant::from_micros(300));
    assert_eq!(m.poll_event(), None);
    assert_eq!(m.stats().rejected.mismatch, 1);
    // Another address's response of the very same service is not it either.
    let other = Telegram::ParamResponse {
        address: a(5),
        channel: ParamChannel::read(8319).answer(Ok(1)),
    };
    m.handle_frame(&other.encode(0), Instant::from_micros(400));
    assert_eq!(m.poll_event(), None);
    assert_eq!(m.stats().rejected.unsolicited, 1);
}

#[test]
fn lost_answer_is_retried() {
    let mut b = bus(&[9]);
    let mut first = true;
    b.fault = Some(Box::new(move |f: &CanFrame| {
        if std::mem::take(&mut first) {
            vec![]
        } else {
            vec![(*f, Duration::ZERO)]
        }
    }));
    b.master
        .param(
            a(9),
            ParamChannel::read(8318),
            Handshake::Async,
            Instant::ZERO,
        )
        .unwrap();
    assert_eq!(param_ok(b.run(Duration::from_secs(1))).data, 1_000_000);
    // The retry went out exactly one timeout after the first request.
    let sent = b.sent();
    assert_eq!(sent.len(), 2);
    assert_eq!(sent[1].0.nanos_since(sent[0].0), 50_000_000);
    assert_eq!(b.master.stats().retries, 1);
}

#[test]
fn group_services() {
    let mut b = bus(&[1, 2]);
    b.drives[0].group = a(2);
    b.drives[1].group = a(2);
    assert_eq!(
        b.master
            .group_param(a(2), ParamChannel::read(8470), Instant::ZERO),
        Err(RequestError::GroupNeedsWrite { service: 1 })
    );
    assert_eq!(
        RequestError::GroupNeedsWrite { service: 1 }.to_string(),
        "group parameter telegrams carry write services only, not read (code 1); drives never answer them"
    );
    b.master
        .group_param(a(2), ParamChannel::write_volatile(8470, 777), Instant::ZERO)
        .unwrap();
    // Done as soon as handed out: no answer is awaited.
    assert_eq!(done(b.run(Duration::from_millis(1))), Ok(Answer::Sent));
    b.run(Duration::from_millis(1));
    assert_eq!(b.sent()[0].1.to_string(), "216#3300211600000309");
    assert!(b.drives.iter().all(|d| d.values[3] == (8470, 777)));
    // Group process data: 8g + 6.
    let t = b.now;
    b.master
        .group_process_data(a(2), ProcessData([6, 5000, 0]), t)
        .unwrap();
    assert_eq!(done(b.run(Duration::from_millis(1))), Ok(Answer::Sent));
    b.run(Duration::from_millis(1));
    assert_eq!(b.sent().last().unwrap().1.to_string(), "016#000613880000");
    assert!(b.drives.iter().all(|d| d.po == ProcessData([6, 5000, 0])));
}

#[test]
fn process_data_async_and_sync() {
    let mut b = bus(&[1]);
    b.master
        .process_data(a(1), ProcessData([6, 5000, 0]), Instant::ZERO)
        .unwrap();
    assert_eq!(
        done(b.run(Duration::from_millis(10))),
        Ok(Answer::ProcessInput(ProcessData([0x0407, 5000, 0])))
    );
    assert_eq!(b.log[0].2.to_string(), "00B#000613880000");
    assert_eq!(b.log[1].2.raw_id(), 12);
    // Synchronised: 8a + 5, PI after the next SYNC. No cycle runs yet: the master sends a
    // SYNC first (the simulated drive, like a real one, drops a PO sync before any SYNC; found
    // end to end in tests/virtual_bus.rs).
    let t = b.now;
    b.master
        .process_data_sync(a(1), ProcessData([6, 4000, 0]), t)
        .unwrap();
    let ev = done(b.run(Duration::from_millis(10)));
    assert_eq!(ev, Ok(Answer::ProcessInput(ProcessData([0x0407, 4000, 0]))));
    let ids: Vec<u32> = b.log[2..].iter().map(|(_, _, f)| f.raw_id()).collect();
    assert_eq!(ids, [0, 13, 0, 12]);
}

/// SB-E30: the PO-sync window of ch. 5.1 is 2.5 ms … 4.5 ms after a SYNC (the manual prints
/// "500 ms" for 500 µs; 500 ms does not fit in a 5 ms cycle). With the producer running, the
/// PO-sync telegram waits for the window and goes out inside it.
#[test]
fn po_sync_window_is_in_microseconds_sb_e30() {
    let mut b = Bus::new(
        SbusMaster::new(MasterConfig {
            sync_producer: SyncProducer::Always,
            ..MasterConfig::default()
        }),
        vec![Responder::new(1)],
    );
    // Let the producer run 5.2 ms (SYNCs at 0 and 5 ms), then ask: the window opens at 7.5 ms.
    b.run(Duration::from_micros(5200));
    let t = b.now;
    b.master
        .process_data_sync(a(1), ProcessData([6, 5000, 0]), t)
        .unwrap();
    assert_eq!(
        done(b.run(Duration::from_millis(20))),
        Ok(Answer::ProcessInput(ProcessData([0x0407, 5000, 0])))
    );
    let sent: Vec<(u64, u32)> = b
        .sent()
        .iter()
        .map(|(t, f)| (t.as_micros(), f.raw_id()))
        .collect();
    assert_eq!(sent, [(0, 0), (5000, 0), (7500, 13), (10_000, 0)]);
    // The PI came in the first millisecond after the SYNC at 10 ms.
    let (pi_at, _, _) = b.log.iter().find(|(_, _, f)| f.raw_id() == 12).unwrap();
    assert!(pi_at.as_micros() > 10_000 && pi_at.as_micros() <= 11_000);
    // Asked inside the window (3.4 ms into the cycle), it goes out at once.
    b.run(Duration::from_micros(13_400) - b.now.as_duration());
    let t = b.now;
    assert_eq!(t.as_micros(), 13_400);
    b.master
        .process_data_sync(a(1), ProcessData([6, 1, 0]), t)
        .unwrap();
    done(b.run(Duration::from_millis(20))).unwrap();
    assert!(
        b.sent()
            .iter()
            .any(|(t, f)| t.as_micros() == 13_400 && f.raw_id() == 13)
    );
}

#[test]
fn sync_producer_period_and_identifier() {
    let mut b = Bus::new(
        SbusMaster::new(MasterConfig {
            sync_producer: SyncProducer::Always,
            sync_id: 0x7FF,
            ..MasterConfig::default()
        }),
        vec![],
    );
    b.run(Duration::from_micros(20_300));
    let sent: Vec<(u64, String)> = b
        .sent()
        .iter()
        .map(|(t, f)| (t.as_micros(), f.to_string()))
        .collect();
    let expected: Vec<(u64, String)> = (0..5).map(|k| (k * 5000, "7FF#".to_string())).collect();
    assert_eq!(sent, expected);
    assert_eq!(b.master.stats().syncs_sent, 5);
    // Polled 12 ms late: one SYNC now, the grid stays (next at 35 ms), two cycles skipped.
    let mut m = SbusMaster::new(MasterConfig {
        sync_producer: SyncProducer::Always,
        ..MasterConfig::default()
    });
    assert!(m.poll_transmit(Instant::ZERO).is_some());
    assert!(m.poll_transmit(Instant::from_millis(17)).is_some());
    assert_eq!(m.poll_timeout(), Some(Instant::from_millis(20)));
    assert_eq!(m.stats().syncs_skipped, 2);
    // The one-off SYNC request.
    let mut m = SbusMaster::new(MasterConfig::default());
    m.sync(Instant::ZERO).unwrap();
    assert_eq!(m.poll_transmit(Instant::ZERO).unwrap().to_string(), "000#");
    assert_eq!(m.poll_event(), Some(MasterEvent::Done(Ok(Answer::Sent))));
}

#[test]
fn scan_finds_every_drive_in_one_round() {
    let mut b = bus(&[3, 17, 63]);
    b.drives[1].values[1] = (8302, 0); // no P070 at 17: it refuses with "illegal index"
    b.master
        .scan(a(0), a(63), Duration::from_millis(20), Instant::ZERO)
        .unwrap();
    assert_eq!(b.run(Duration::from_secs(1)), Some(MasterEvent::ScanDone));
    let r = b.master.scan_results();
    assert_eq!(r[3], ScanEntry::UnitType(common::responder::UNIT_TYPE));
    assert_eq!(r[17], ScanEntry::Refused(ReturnCode::ILLEGAL_INDEX));
    assert_eq!(r[63], ScanEntry::UnitType(common::responder::UNIT_TYPE));
    assert_eq!(r.iter().filter(|e| **e == ScanEntry::Silent).count(), 61);
    // 64 requests, all in one go; done one timeout after the last.
    assert_eq!(b.sent().len(), 64);
    assert_eq!(b.now, Instant::from_millis(20));
    // A range.
    let t = b.now;
    b.master
        .scan(a(10), a(20), Duration::from_millis(5), t)
        .unwrap();
    assert_eq!(b.run(Duration::from_secs(1)), Some(MasterEvent::ScanDone));
    let r = b.master.scan_results();
    assert_eq!(r[3], ScanEntry::NotScanned);
    assert_eq!(r[17], ScanEntry::Refused(ReturnCode::ILLEGAL_INDEX));
    assert_eq!(
        b.master.scan(a(5), a(4), Duration::ZERO, t),
        Err(RequestError::EmptyRange)
    );
}

#[test]
fn foreign_and_malformed_frames_are_counted() {
    let mut m = SbusMaster::new(MasterConfig::default());
    m.param(
        a(1),
        ParamChannel::read(8318),
        Handshake::Async,
        Instant::ZERO,
    )
    .unwrap();
    m.poll_transmit(Instant::ZERO).unwrap();
    let t = Instant::from_micros(100);
    // A variable telegram, another master's request, PO of another master, a short response.
    m.handle_frame(&CanFrame::standard(1025, &[1, 2, 3, 4]).unwrap(), t);
    m.handle_frame(
        &Telegram::ParamRequest {
            address: a(2),
            channel: ParamChannel::read(1),
        }
        .encode(0),
        t,
    );
    m.handle_frame(&CanFrame::standard(11, &[0; 6]).unwrap(), t);
    m.handle_frame(
        &CanFrame::standard(524, &[0x31, 0, 0x20, 0x7E, 0, 0]).unwrap(),
        t,
    );
    assert_eq!(m.poll_event(), None);
    let r = m.stats().rejected;
    assert_eq!(
        (r.foreign, r.malformed, r.unsolicited, r.mismatch),
        (3, 1, 0, 0)
    );
    assert_eq!(
        m.param(a(1), ParamChannel::read(1), Handshake::Async, t),
        Err(RequestError::Busy)
    );
}

proptest! {
    /// Whatever arrives while a read waits, the master never panics and completes the read
    /// only with a response of its address, service and index.
    #[test]
    fn random_frames_never_give_a_wrong_answer(
        frames in proptest::collection::vec((0u16..2048, proptest::collection::vec(any::<u8>(), 0..=8), 0u64..200_000), 0..40),
        hs in any::<bool>(),
    ) {
        let mut m = SbusMaster::new(MasterConfig::default());
        let hs = if hs { Handshake::Sync } else { Handshake::Async };
        m.param(a(1), ParamChannel::read(8318), hs, Instant::ZERO).unwrap();
        let mut now = Instant::ZERO;
        let _ = m.poll_transmit(now);
        for (id, data, dt) in frames {
            now = now.add_nanos(dt * 1000);
            m.handle_timeout(now);
            let _ = m.poll_transmit(now);
            m.handle_frame(&CanFrame::standard(id, &data).unwrap(), now);
            while let Some(ev) = m.poll_event() {
                if let MasterEvent::Done(Ok(Answer::Param(ch))) = ev {
                    prop_assert_eq!(id, 524);
                    prop_assert_eq!(ch.index, 8318);
                    prop_assert_eq!(ch.management.service_code(), 1);
                    prop_assert_eq!(&data[..4], &[data[0], 0, 0x20, 0x7E][..]);
                }
            }
        }
    }
}

#[test]
fn latency_constant_is_what_the_loop_uses() {
    // The loop bus delivers every frame LATENCY after it was sent (the times above rely on it).
    let mut b = bus(&[1]);
    b.master
        .process_data(a(1), ProcessData::default(), Instant::ZERO)
        .unwrap();
    done(b.run(Duration::from_millis(5))).unwrap();
    assert_eq!(b.log[0].0, Instant::ZERO.saturating_add(LATENCY));
    assert_eq!(b.log[1].0, Instant::ZERO.saturating_add(LATENCY * 2));
}
