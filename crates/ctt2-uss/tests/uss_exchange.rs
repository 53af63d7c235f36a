//! The sans-IO USS master and slave on an in-memory line with exact wire times: answers,
//! rejections (address, layout, BCC, changed mirror), broadcast and mirror telegrams, special
//! telegrams, the plausibility repeat against a slow slave, the response timeout and retries
//! to the nanosecond, the slave's response delay, and what the master refuses to send.

// A failing fixture is a failing test: panicking is the report.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

#[path = "uss_common/bus.rs"]
mod bus;

use std::time::Duration;

use bus::{Bus, Store};
use ctt2_uss::serial::master::{MasterConfig, MasterEvent, RejectReason, SendError, UssMaster};
use ctt2_uss::serial::slave::{Slave, SlaveConfig, SlaveEvent};
use ctt2_uss::serial::telegram::{
    Adr, FrameError, Layout, MAX_TELEGRAM, Telegram, UssAddress, bcc,
};
use ctt2_uss::uss::pkw::{Ind, Order, Pkw, Plausibility, Reply, Storage};
use drive_core::{Endpoint, Instant, LineSettings};
use drive_profile::nord::Width;

fn addr(a: u8) -> UssAddress {
    UssAddress::new(a).unwrap()
}

const L: Layout = Layout::PKW4_PZD2;

fn line() -> LineSettings {
    LineSettings::new(19200)
}

fn bus_of(addresses: &[u8]) -> Bus<Store> {
    let slaves = addresses
        .iter()
        .map(|&a| Slave::new(SlaveConfig::new(addr(a), L, line()), Store::default()))
        .collect();
    Bus::new(UssMaster::new(MasterConfig::new(line())), slaves)
}

fn telegram(adr: Adr, pkw: Pkw) -> Telegram {
    Telegram::new(adr, L, pkw, &[0x047E, 0x1234]).unwrap()
}

fn read(pnu: u16) -> Pkw {
    Order::read(pnu, Ind::ZERO).unwrap().to_pkw()
}

/// Send `t` and collect the master's events until it is idle.
fn exchange(bus: &mut Bus<Store>, t: Telegram) -> Vec<MasterEvent> {
    let now = bus.now;
    bus.master.send(t, now).unwrap();
    let mut events = Vec::new();
    assert!(bus.run(|e| events.push(e)), "the line settled");
    events
}

fn answer(events: &[MasterEvent]) -> Telegram {
    match events.last() {
        Some(MasterEvent::Response(t)) => *t,
        other => panic!("no answer: {other:?} in {events:?}"),
    }
}

#[test]
fn a_read_is_answered_with_the_value_and_the_process_data() {
    let mut bus = bus_of(&[7]);
    let a = answer(&exchange(&mut bus, telegram(Adr::new(addr(7)), read(102))));
    assert_eq!(a.adr(), Adr::new(addr(7)));
    let pkw = a.pkw().unwrap();
    assert_eq!((pkw.pke.ak(), pkw.pke.pnu(), pkw.pwe2), (1, 102, 306));
    // The test drive answers the control word inverted and the setpoint unchanged.
    assert_eq!(a.pzd(), &[!0x047E, 0x1234]);
    assert_eq!(bus.slaves[0].backend().executed, 1);
}

#[test]
fn a_slow_slave_answers_the_previous_order_until_the_new_one_is_done() {
    let mut bus = bus_of(&[7]);
    bus.slaves[0].backend_mut().processing = Duration::from_millis(30);
    let first = Order::read(102, Ind::ZERO).unwrap();
    // Until 30 ms have passed the drive answers "no order" (its answer before any order).
    let mut polls = 0;
    let reply = loop {
        polls += 1;
        let a = answer(&exchange(
            &mut bus,
            telegram(Adr::new(addr(7)), first.to_pkw()),
        ));
        match first.check(&a.pkw().unwrap()) {
            Plausibility::Answer(r) => break r,
            Plausibility::Other => assert!(polls < 100),
            Plausibility::Invalid(e) => panic!("{e}"),
        }
    };
    assert_eq!(
        reply,
        Reply::Value {
            width: Width::Word,
            array: false,
            value: 306
        }
    );
    // 16-character telegrams both ways at 19200 baud, 1.146 ms delays: about 21.5 ms per
    // exchange, so the second or third telegram brings the answer.
    assert!((2..=3).contains(&polls), "{polls}");
    // The next order: the drive keeps answering P102 until P105 is done.
    let second = Order::write(105, Ind::ZERO, Width::Word, false, Storage::Eeprom, 600).unwrap();
    let a = answer(&exchange(
        &mut bus,
        telegram(Adr::new(addr(7)), second.to_pkw()),
    ));
    assert_eq!(second.check(&a.pkw().unwrap()), Plausibility::Other);
    assert_eq!(a.pkw().unwrap().pke.pnu(), 102, "still the previous answer");
    assert!(bus.slaves[0].is_processing());
    // The drive finishes it on its own time even without a telegram.
    let later = bus.now + Duration::from_millis(40);
    bus.slaves[0].handle_timeout(later);
    bus.now = later;
    assert!(!bus.slaves[0].is_processing());
    let a = answer(&exchange(
        &mut bus,
        telegram(Adr::new(addr(7)), second.to_pkw()),
    ));
    assert!(matches!(
        second.check(&a.pkw().unwrap()),
        Plausibility::Answer(_)
    ));
    // Orders executed: P102 once (however often it was repeated), P105 once.
    assert_eq!(bus.slaves[0].backend().executed, 2);
    let mut done = 0;
    while let Some(e) = bus.slaves[0].poll_event() {
        if matches!(e, SlaveEvent::OrderDone(_)) {
            done += 1;
        }
    }
    assert!(done >= 1);
}

#[test]
fn broadcast_is_executed_by_all_and_answered_by_none() {
    let mut bus = bus_of(&[1, 2, 3]);
    bus.log = Some(Vec::new());
    let write = Order::write(102, Ind::ZERO, Width::Word, false, Storage::Ram, 999)
        .unwrap()
        .to_pkw();
    let events = exchange(&mut bus, telegram(Adr::broadcast(), write));
    assert_eq!(events, vec![MasterEvent::Sent]);
    // The master is done once it is sent; the drives take it once the start delay of silence
    // after it confirmed its end.
    bus.now += line().char_times(2, 1);
    for s in &mut bus.slaves {
        s.handle_timeout(bus.now);
    }
    for s in &bus.slaves {
        assert_eq!(s.backend().value(102, 0), 999);
        assert_eq!(s.backend().processed, 1);
    }
    // Only the broadcast was on the line.
    assert_eq!(bus.log.as_ref().unwrap().len(), 1);
    // The next telegram may follow after the start delay.
    let a = answer(&exchange(&mut bus, telegram(Adr::new(addr(2)), read(102))));
    assert_eq!(a.pkw().unwrap().pwe2, 999);
    let log = bus.log.as_ref().unwrap();
    assert_eq!(
        log[1].0.saturating_duration_since(log[0].1),
        line().char_times(2, 1)
    );
    // A broadcast carries no order or a write order; it cannot be a mirror.
    let now = bus.now;
    assert_eq!(
        bus.master.send(telegram(Adr::broadcast(), read(102)), now),
        Err(SendError::BroadcastOrder(1))
    );
    assert_eq!(
        bus.master.send(
            telegram(Adr(Adr::BROADCAST | Adr::MIRROR), Pkw::default()),
            now
        ),
        Err(SendError::BroadcastMirror)
    );
    assert_eq!(
        bus.master.send(telegram(Adr(0x81), Pkw::default()), now),
        Err(SendError::Special)
    );
    assert!(
        exchange(&mut bus, telegram(Adr::broadcast(), Pkw::default())) == vec![MasterEvent::Sent]
    );
}

#[test]
fn a_mirror_telegram_comes_back_unchanged_and_is_not_executed() {
    let mut bus = bus_of(&[4, 5]);
    let t = telegram(Adr::mirror(addr(5)), read(102));
    let a = answer(&exchange(&mut bus, t));
    assert_eq!(a, t);
    assert_eq!(bus.slaves[1].backend().executed, 0);
    assert_eq!(bus.slaves[1].backend().processed, 0);
    // A mirror answer that comes back changed is refused.
    bus.tamper = Some(|b, n| {
        b[13] ^= 0x01;
        b[n - 1] ^= 0x01;
        Some(n)
    });
    let events = exchange(&mut bus, t);
    assert!(events.contains(&MasterEvent::Rejected(RejectReason::MirrorChanged)));
    assert_eq!(events.last(), Some(&MasterEvent::Timeout { attempts: 3 }));
}

/// Re-compute the BCC of a telegram of `n` bytes.
fn fix_bcc(b: &mut [u8; MAX_TELEGRAM], n: usize) {
    b[n - 1] = bcc(&b[..n - 1]);
}

#[test]
fn wrong_answers_are_rejected_and_the_telegram_sent_again() {
    let t = telegram(Adr::new(addr(7)), read(102));
    let cases: [(bus::Tamper, RejectReason); 4] = [
        // Another address.
        (
            |b, n| {
                b[2] = 8;
                fix_bcc(b, n);
                Some(n)
            },
            RejectReason::WrongAddress {
                expected: Adr(7),
                got: Adr(8),
            },
        ),
        // The mirror bit set in an answer to a normal telegram.
        (
            |b, n| {
                b[2] |= Adr::MIRROR;
                fix_bcc(b, n);
                Some(n)
            },
            RejectReason::WrongAddress {
                expected: Adr(7),
                got: Adr(0x47),
            },
        ),
        // A wrong BCC.
        (
            |b, n| {
                b[n - 1] ^= 0xFF;
                Some(n)
            },
            RejectReason::Bcc {
                expected: 0,
                got: 0,
            },
        ),
        // Another layout: a telegram with 4 PZD words (LGE 18) instead of 2 (LGE 14).
        (
            |b, n| {
                let t = Telegram::decode(&b[..n], Layout::PKW4_PZD2).unwrap();
                let wide =
                    Telegram::new(t.adr(), Layout::PKW4_PZD4, t.pkw().unwrap(), &[1, 2, 3, 4])
                        .unwrap();
                Some(wide.encode(b).unwrap())
            },
            RejectReason::WrongLayout {
                expected: 14,
                got: 18,
            },
        ),
    ];
    for (tamper, reason) in cases {
        let mut bus = bus_of(&[7]);
        bus.tamper = Some(tamper);
        let events = exchange(&mut bus, t);
        let rejected: Vec<_> = events
            .iter()
            .filter_map(|e| match e {
                MasterEvent::Rejected(r) => Some(*r),
                _ => None,
            })
            .collect();
        assert_eq!(rejected.len(), 3, "{events:?}");
        match (rejected[0], reason) {
            (RejectReason::Bcc { .. }, RejectReason::Bcc { .. }) => {}
            (got, want) => assert_eq!(got, want),
        }
        assert_eq!(events.last(), Some(&MasterEvent::Timeout { attempts: 3 }));
        // The drive executed the read once: the repeated telegram is the same order.
        assert_eq!(bus.slaves[0].backend().executed, 1);
    }
}

#[test]
fn response_timeout_and_retries_to_the_nanosecond() {
    // Nobody at address 9.
    let mut bus = bus_of(&[1]);
    bus.log = Some(Vec::new());
    let events = exchange(&mut bus, telegram(Adr::new(addr(9)), read(102)));
    assert_eq!(events, vec![MasterEvent::Timeout { attempts: 3 }]);
    let log = bus.log.take().unwrap();
    assert_eq!(log.len(), 3);
    let ct = line().char_time();
    let len = ct * 16;
    for w in log.windows(2) {
        // The next attempt starts when the answer's first character could have been complete:
        // the telegram's end + 20 ms + one character time.
        assert_eq!(
            w[1].0.saturating_duration_since(w[0].1),
            Duration::from_millis(20) + ct
        );
        assert_eq!(w[0].1.saturating_duration_since(w[0].0), len);
    }
    // The give-up comes at the same point after the third attempt.
    assert_eq!(
        bus.now.saturating_duration_since(log[2].1),
        Duration::from_millis(20) + ct
    );
}

#[test]
fn the_slave_answers_after_its_response_delay() {
    let ct = line().char_time();
    for (delay, expected) in [
        (Duration::ZERO, line().char_times(2, 1)), // never sooner than the start delay
        (line().char_times(2, 1), line().char_times(2, 1)),
        (Duration::from_millis(5), Duration::from_millis(5)),
    ] {
        let mut config = SlaveConfig::new(addr(3), L, line());
        config.response_delay = delay;
        let mut bus = Bus::new(
            UssMaster::new(MasterConfig::new(line())),
            vec![Slave::new(config, Store::default())],
        );
        bus.log = Some(Vec::new());
        let _ = answer(&exchange(&mut bus, telegram(Adr::new(addr(3)), read(1))));
        let log = bus.log.unwrap();
        assert_eq!(
            log[1].0.saturating_duration_since(log[0].1),
            expected,
            "{delay:?}"
        );
        assert_eq!(log[1].1.saturating_duration_since(log[1].0), ct * 16);
    }
}

#[test]
fn special_telegrams_and_other_addresses_are_ignored() {
    let line = line();
    let ct = line.char_time().as_nanos() as u64;
    let mut slave = Slave::new(SlaveConfig::new(addr(3), L, line), Store::default());
    let feed = |slave: &mut Slave<Store>, t: Telegram, start: u64| {
        let mut buf = [0u8; MAX_TELEGRAM];
        let n = t.encode(&mut buf).unwrap();
        for (i, b) in buf[..n].iter().enumerate() {
            slave.handle_char(drive_core::RxChar::new(
                *b,
                Instant::from_nanos(start + ct * (i as u64 + 1)),
            ));
        }
        slave.handle_timeout(Instant::from_nanos(start + ct * 40));
    };
    feed(&mut slave, telegram(Adr(0x83), read(102)), 0);
    assert!(matches!(slave.poll_event(), Some(SlaveEvent::Ignored(_))));
    feed(&mut slave, telegram(Adr::new(addr(4)), read(102)), ct * 100);
    assert_eq!(slave.poll_event(), None, "other addresses are no event");
    assert_eq!(
        slave.poll_transmit(Instant::from_secs(1), &mut [0; 64]),
        None
    );
    assert_eq!(slave.backend().executed, 0);
}

#[test]
fn an_answer_is_dropped_when_the_line_is_not_quiet() {
    let line = line();
    let ct = line.char_time().as_nanos() as u64;
    let mut slave = Slave::new(SlaveConfig::new(addr(3), L, line), Store::default());
    let mut buf = [0u8; MAX_TELEGRAM];
    let n = telegram(Adr::new(addr(3)), read(102))
        .encode(&mut buf)
        .unwrap();
    for (i, b) in buf[..n].iter().enumerate() {
        slave.handle_char(drive_core::RxChar::new(
            *b,
            Instant::from_nanos(ct * (i as u64 + 1)),
        ));
    }
    let end = ct * n as u64;
    let due = slave.poll_timeout().unwrap();
    slave.handle_timeout(due);
    assert!(matches!(slave.poll_event(), Some(SlaveEvent::OrderDone(_))));
    assert!(matches!(
        slave.poll_event(),
        Some(SlaveEvent::Executed { .. })
    ));
    // A character on the line before the answer went out: the answer is dropped.
    slave.handle_char(drive_core::RxChar::new(
        0x55,
        Instant::from_nanos(end + ct + ct / 2),
    ));
    assert_eq!(
        slave.poll_transmit(Instant::from_nanos(end + 10 * ct), &mut buf),
        None
    );
}

#[test]
fn a_three_word_slave_refuses_a_double_word_it_cannot_send() {
    #[derive(Debug, Default)]
    struct Wide;
    impl ctt2_uss::serial::slave::Backend for Wide {
        fn execute(&mut self, order: &Pkw, _: Instant) -> Pkw {
            Reply::Value {
                width: Width::DoubleWord,
                array: false,
                value: 70_000,
            }
            .to_pkw(order.pke.pnu(), order.ind)
        }
        fn process(&mut self, _: &[u16], _: &mut [u16], _: Instant) {}
    }

    impl drive_core::Timers for Wide {}
    let l3 = Layout::new(3, 0).unwrap();
    let line = line();
    let mut master = UssMaster::new(MasterConfig::new(line));
    let mut slave = Slave::new(SlaveConfig::new(addr(1), l3, line), Wide);
    let t = Telegram::new(Adr::new(addr(1)), l3, read(102), &[]).unwrap();
    master.send(t, Instant::ZERO).unwrap();
    let ct = line.char_time().as_nanos() as u64;
    let mut buf = [0u8; MAX_TELEGRAM];
    let n = master.poll_transmit(Instant::ZERO, &mut buf).unwrap();
    for (i, b) in buf[..n].iter().enumerate() {
        slave.handle_char(drive_core::RxChar::new(
            *b,
            Instant::from_nanos(ct * (i as u64 + 1)),
        ));
    }
    let at = slave.poll_timeout().unwrap();
    slave.handle_timeout(at);
    let m = slave.poll_transmit(at, &mut buf).unwrap();
    for (i, b) in buf[..m].iter().enumerate() {
        master.handle_char(drive_core::RxChar::new(
            *b,
            at.add_nanos(ct * (i as u64 + 1)),
        ));
    }
    master.handle_timeout(at.add_nanos(ct * 40));
    let Some(MasterEvent::Response(a)) = master.poll_event() else {
        panic!("no answer");
    };
    let pkw = a.pkw().unwrap();
    // AK 7, error 5 "invalid data type": the 3-word PKW cannot carry 70 000.
    assert_eq!((pkw.pke.ak(), pkw.pwe2), (7, 5));
}

#[test]
fn a_broken_request_gets_no_answer() {
    let line = line();
    let ct = line.char_time().as_nanos() as u64;
    let mut slave = Slave::new(SlaveConfig::new(addr(3), L, line), Store::default());
    let mut buf = [0u8; MAX_TELEGRAM];
    let n = telegram(Adr::new(addr(3)), read(102))
        .encode(&mut buf)
        .unwrap();
    buf[6] ^= 0x40; // a data bit: the BCC no longer fits
    for (i, b) in buf[..n].iter().enumerate() {
        slave.handle_char(drive_core::RxChar::new(
            *b,
            Instant::from_nanos(ct * (i as u64 + 1)),
        ));
    }
    slave.handle_timeout(Instant::from_nanos(ct * 40));
    assert!(matches!(
        slave.poll_event(),
        Some(SlaveEvent::Rejected(FrameError::BadBcc { .. }))
    ));
    assert_eq!(slave.poll_transmit(Instant::from_secs(1), &mut buf), None);
    assert_eq!(slave.backend().executed, 0);
}
