//! Regression tests of wire faults found by the fault-injection campaign
//! (`tests/tests/movilink_faults.rs` of the workspace): each test is named after the fault.

use movilink::timing::Instant;
use movilink::{
    Address, MasterConfig, MasterEvent, MovilinkMaster, ParamChannel, PduType, RejectReason,
    RxChar, RxEvent, Slave, SlaveConfig, SlaveEvent, Telegram, codec,
};

use crate::bus::TestDrive;

const CT: u64 = 1146;
const PAUSE: u64 = 3440;

fn drive1() -> Address {
    Address::new(1).unwrap()
}

fn encoded(t: &Telegram) -> Vec<u8> {
    let mut buf = [0u8; 18];
    let n = codec::encode(t, &mut buf).unwrap();
    buf[..n].to_vec()
}

/// `bytes` with `extra` inserted after position `after`.
fn with_insert(bytes: &[u8], after: usize, extra: u8) -> Vec<u8> {
    let mut v = bytes.to_vec();
    v.insert(after + 1, extra);
    v
}

/// An inserted character equal to the telegram's BCC makes the first `n` characters pass the
/// XOR check (the real BCC is shifted out): before the fix, the receiver accepted that
/// telegram with a wrong value. The character after it (no idle gap) must reject it.
#[test]
fn inserted_character_with_matching_bcc_is_rejected() {
    let resp = Telegram::response(drive1(), PduType::PARAM_0PD_ACYCLIC)
        .with_param(ParamChannel::read(8471).answer(Ok(0x1234_5678)));
    let bytes = encoded(&resp);
    let bcc = *bytes.last().unwrap();
    for after in 2..bytes.len() - 2 {
        let wire = with_insert(&bytes, after, bcc);
        // The first 12 characters alone would pass every check of the codec.
        let (wrong, _) = codec::decode(&wire[..bytes.len()]).unwrap();
        assert_ne!(wrong, resp);
        let mut rx = movilink::Receiver::new(movilink::TelegramFraming::master(drive1()));
        let mut events = Vec::new();
        let mut t = 0;
        for b in &wire {
            t += CT;
            events.extend(rx.handle_char(RxChar::new(*b, Instant::from_micros(t))));
        }
        events.extend(rx.handle_timeout(Instant::from_micros(t + PAUSE)));
        assert_eq!(
            events,
            vec![RxEvent::Rejected(RejectReason::TrailingCharacter {
                byte: bytes[bytes.len() - 1]
            })],
            "insert after {after}"
        );
    }
}

/// A character inserted after the BCC rejects the telegram too (its length is wrong).
#[test]
fn inserted_character_after_bcc_is_rejected() {
    let req = Telegram::request(drive1(), PduType::PD3).with_process_data(&[1, 2, 3]);
    let bytes = encoded(&req);
    let wire = with_insert(&bytes, bytes.len() - 1, 0x00);
    let mut rx = movilink::Receiver::new(movilink::TelegramFraming::slave(
        drive1(),
        Address::NO_GROUP,
    ));
    let mut events = Vec::new();
    let mut t = 0;
    for b in &wire {
        t += CT;
        events.extend(rx.handle_char(RxChar::new(*b, Instant::from_micros(t))));
    }
    events.extend(rx.handle_timeout(Instant::from_micros(t + PAUSE + CT)));
    assert_eq!(
        events,
        vec![RxEvent::Rejected(RejectReason::TrailingCharacter {
            byte: 0x00
        })]
    );
}

/// A dropped character leaves the telegram one character short: rejected by the
/// inter-character gap once the line stays quiet, never accepted.
#[test]
fn dropped_character_is_rejected_by_gap() {
    let req = Telegram::request(drive1(), PduType::PARAM_3PD)
        .with_param(ParamChannel::write(8471, 77))
        .with_process_data(&[1, 2, 3]);
    let bytes = encoded(&req);
    for dropped in 1..bytes.len() {
        let mut rx = movilink::Receiver::new(movilink::TelegramFraming::slave(
            drive1(),
            Address::NO_GROUP,
        ));
        let mut events = Vec::new();
        let mut last = 0;
        for (i, b) in bytes.iter().enumerate() {
            // The dropped character still took its wire time.
            let t = CT * (i as u64 + 1);
            if i != dropped {
                last = t;
                events.extend(rx.handle_char(RxChar::new(*b, Instant::from_micros(t))));
            }
        }
        events.extend(rx.handle_timeout(Instant::from_micros(last + CT + PAUSE)));
        assert_eq!(events.len(), 1, "drop {dropped}: {events:?}");
        assert!(
            matches!(events[0], RxEvent::Rejected(_)),
            "drop {dropped}: {events:?}"
        );
    }
}

/// The master does not report the value of a response with an inserted character; it
/// rejects it and retries.
#[test]
fn inserted_character_in_response_is_not_accepted_by_master() {
    let mut m = MovilinkMaster::new(MasterConfig::default());
    let req = Telegram::request(drive1(), PduType::PARAM_0PD_ACYCLIC)
        .with_param(ParamChannel::read(8471));
    m.send(req, Instant::ZERO).unwrap();
    let mut buf = [0u8; 18];
    let n = m.poll_transmit(Instant::ZERO, &mut buf).unwrap();
    let resp = Telegram::response(drive1(), PduType::PARAM_0PD_ACYCLIC)
        .with_param(ParamChannel::read(8471).answer(Ok(2000)));
    let bytes = encoded(&resp);
    let wire = with_insert(&bytes, 6, *bytes.last().unwrap());
    let mut t = CT * n as u64 + PAUSE;
    for b in &wire {
        t += CT;
        m.handle_char(RxChar::new(*b, Instant::from_micros(t)));
    }
    m.handle_timeout(m.poll_timeout().unwrap());
    let mut events = Vec::new();
    while let Some(e) = m.poll_event() {
        events.push(e);
    }
    assert_eq!(
        events,
        vec![MasterEvent::Rejected(RejectReason::TrailingCharacter {
            byte: bytes[bytes.len() - 1]
        })]
    );
    assert!(!m.is_idle(), "the master retries");
}

/// The drive does not execute a write request with an inserted character.
#[test]
fn inserted_character_in_write_request_is_not_executed() {
    let mut s = Slave::new(SlaveConfig::new(drive1()), TestDrive::default());
    let req = Telegram::request(drive1(), PduType::PARAM_0PD_ACYCLIC)
        .with_param(ParamChannel::write(8471, 1000));
    let bytes = encoded(&req);
    let wire = with_insert(&bytes, 8, *bytes.last().unwrap());
    let mut t = PAUSE;
    for b in &wire {
        t += CT;
        s.handle_char(RxChar::new(*b, Instant::from_micros(t)));
    }
    while let Some(due) = s.poll_timeout() {
        s.handle_timeout(due);
    }
    assert_eq!(s.backend().value(8471), Some(2000));
    assert_eq!(s.backend().executed, 0);
    assert_eq!(
        s.poll_transmit(Instant::from_micros(t + PAUSE), &mut [0u8; 18]),
        None
    );
    assert!(matches!(
        s.poll_event(),
        Some(SlaveEvent::Rejected(RejectReason::TrailingCharacter { .. }))
    ));
}

/// Confirming a telegram's end does not delay the response: the drive answers exactly a start
/// pause after the request's BCC, as before.
#[test]
fn end_confirmation_does_not_delay_the_response() {
    let mut s = Slave::new(SlaveConfig::new(drive1()), TestDrive::default());
    let req = Telegram::request(drive1(), PduType::PARAM_3PD)
        .with_param(ParamChannel::read(8471))
        .with_process_data(&[1, 2, 3]);
    let mut t = PAUSE;
    for b in &encoded(&req) {
        t += CT;
        s.handle_char(RxChar::new(*b, Instant::from_micros(t)));
    }
    assert_eq!(s.poll_timeout(), Some(Instant::from_micros(t + PAUSE)));
    s.handle_timeout(Instant::from_micros(t + PAUSE));
    assert_eq!(
        s.poll_transmit(Instant::from_micros(t + PAUSE), &mut [0u8; 18]),
        Some(18)
    );
}

/// Every response of a cyclic service is lost (the master gives up), although the drive
/// executed the service and took over its handshake bit. The master's record of the drive's
/// bit is then stale: the next service carries the bit the drive already holds, and the drive
/// repeats the old answer. Before the fix the master repeated that request until
/// `ParamNotExecuted`; it must toggle the bit again and get the new service executed.
#[test]
fn lost_cyclic_responses_do_not_stall_the_next_service() {
    use crate::bus::Bus;
    let mut bus = Bus::new(
        MovilinkMaster::new(MasterConfig::default()),
        Slave::new(SlaveConfig::new(drive1()), TestDrive::default()),
    );
    let cyclic = |p: ParamChannel| {
        Telegram::request(drive1(), PduType::PARAM_1PD)
            .with_param(p)
            .with_process_data(&[6])
    };
    // Learn the drive's handshake bit.
    let now = bus.now;
    bus.master
        .send(cyclic(ParamChannel::no_service()), now)
        .unwrap();
    bus.run_collect();
    // A write whose three responses are all lost: executed by the drive, timeout for the master.
    bus.faults.drop_responses = 3;
    let now = bus.now;
    bus.master
        .send(cyclic(ParamChannel::write_volatile(8471, 1234)), now)
        .unwrap();
    let events = bus.run_collect();
    assert_eq!(events.last(), Some(&MasterEvent::Timeout { attempts: 3 }));
    assert_eq!(bus.slave.backend().value(8471), Some(1234));
    // The next service is executed and answered.
    let now = bus.now;
    bus.master
        .send(cyclic(ParamChannel::read(8318)), now)
        .unwrap();
    let events = bus.run_collect();
    assert!(
        events.contains(&MasterEvent::ParamDone(Ok(1500))),
        "{events:?}"
    );
    assert!(events.contains(&MasterEvent::Rejected(RejectReason::ParamMismatch)));
}
