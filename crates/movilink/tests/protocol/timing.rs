//! Timing with explicit times: start pause, restart after abort, broadcast spacing, response
//! timeout, the backend's own deadlines (the drive's P812 monitor), response delay of the drive.

use core::time::Duration;

use movilink::timing::{BROADCAST_SPACING, CHAR_TIME, Instant, RESTART_PAUSE, START_PAUSE};
use movilink::{
    Address, MasterConfig, MasterEvent, MovilinkMaster, ParamChannel, PduType, RxChar, Slave,
    SlaveConfig, Telegram, TxGate, encode,
};

use super::bus::TestDrive;

/// Characters fed by hand arrive 1146 µs apart (a little slower than the 1145.833 µs of the
/// line, as a real UART's rounding might make them).
const CT: u64 = 1146;

fn us(t: u64) -> Instant {
    Instant::from_micros(t)
}

/// The end of `n` characters sent back to back from `start` (exact character time).
fn after_chars(start: Instant, n: u32) -> Instant {
    start + CHAR_TIME * n
}

fn drive1() -> Address {
    Address::new(1).unwrap()
}

#[test]
fn gate_start_pause_restart_and_broadcast_spacing() {
    let mut g = TxGate::new(START_PAUSE);
    assert!(g.may_start(Instant::ZERO));
    g.on_activity(us(10_000));
    assert_eq!(g.earliest_start(), us(13_440));
    // Activity in the past does not move it back.
    g.on_activity(us(9_000));
    assert_eq!(g.earliest_start(), us(13_440));
    g.on_aborted(us(20_000), RESTART_PAUSE);
    assert_eq!(g.earliest_start(), us(20_000) + RESTART_PAUSE);
    assert_eq!(g.earliest_start(), us(26_880));
    g.on_request_sent(us(30_000), drive1().expects_response(), BROADCAST_SPACING);
    assert_eq!(g.earliest_start(), us(33_440));
    g.on_request_sent(
        us(40_000),
        Address::BROADCAST.expects_response(),
        BROADCAST_SPACING,
    );
    assert_eq!(g.earliest_start(), us(40_000) + BROADCAST_SPACING);
    let group = Address::group(120).unwrap();
    g.on_request_sent(us(100_000), group.expects_response(), BROADCAST_SPACING);
    assert_eq!(g.earliest_start(), us(125_000));
}

#[test]
fn master_waits_start_pause_after_bus_activity() {
    let mut m = MovilinkMaster::new(MasterConfig::default());
    // Traffic on the bus: a character ended at 5 ms.
    m.handle_char(RxChar::new(0x55, us(5_000)));
    m.send(Telegram::request(drive1(), PduType::PD1_ACYCLIC), us(6_000))
        .unwrap();
    let mut buf = [0u8; 18];
    assert_eq!(m.poll_transmit(us(6_000), &mut buf), None);
    assert_eq!(m.poll_timeout(), Some(us(5_000) + START_PAUSE));
    assert_eq!(m.poll_transmit(us(8_439), &mut buf), None);
    assert_eq!(m.poll_transmit(us(8_440), &mut buf), Some(6));
}

#[test]
fn master_abort_requires_two_start_pauses() {
    let mut m = MovilinkMaster::new(MasterConfig::default());
    m.send(Telegram::request(drive1(), PduType::PD1_ACYCLIC), us(0))
        .unwrap();
    let mut buf = [0u8; 18];
    assert!(m.poll_transmit(us(0), &mut buf).is_some());
    m.abort(us(2_000));
    assert!(m.is_idle());
    m.send(Telegram::request(drive1(), PduType::PD1_ACYCLIC), us(2_000))
        .unwrap();
    assert_eq!(m.poll_transmit(us(2_000 + 6_879), &mut buf), None);
    assert!(m.poll_transmit(us(2_000 + 6_880), &mut buf).is_some());
}

#[test]
fn master_broadcast_spacing() {
    let mut m = MovilinkMaster::new(MasterConfig::default());
    let bc = Telegram::request(Address::BROADCAST, PduType::PD3).with_process_data(&[6, 0x2000, 0]);
    m.send(bc, us(0)).unwrap();
    let mut buf = [0u8; 18];
    assert_eq!(m.poll_transmit(us(0), &mut buf), Some(10));
    assert_eq!(
        m.poll_event(),
        Some(MasterEvent::Sent {
            address: Address::BROADCAST
        })
    );
    assert!(m.is_idle());
    // The BCC ends after 10 characters; the next SD1 may start 25 ms later.
    let end = after_chars(Instant::ZERO, 10);
    m.send(bc, end).unwrap();
    let next = end + BROADCAST_SPACING;
    assert_eq!(m.poll_timeout(), Some(next));
    assert_eq!(
        m.poll_transmit(next.saturating_sub(Duration::from_nanos(1)), &mut buf),
        None
    );
    assert_eq!(m.poll_transmit(next, &mut buf), Some(10));
}

#[test]
fn master_response_timeout_default_50ms_and_configurable() {
    for (timeout, retries) in [
        (Duration::from_millis(50), 0u8),
        (Duration::from_millis(20), 1),
    ] {
        let cfg = MasterConfig {
            response_timeout: timeout,
            retries,
            ..MasterConfig::default()
        };
        let mut m = MovilinkMaster::new(cfg);
        m.send(Telegram::request(drive1(), PduType::PD1_ACYCLIC), us(0))
            .unwrap();
        let mut buf = [0u8; 18];
        assert_eq!(m.poll_transmit(us(0), &mut buf), Some(6));
        let end = after_chars(Instant::ZERO, 6);
        // Give up when an SD2 starting at the deadline would have been complete.
        let give_up = end + timeout + CHAR_TIME;
        assert_eq!(m.poll_timeout(), Some(give_up));
        m.handle_timeout(give_up.saturating_sub(Duration::from_nanos(1)));
        assert_eq!(m.poll_event(), None);
        m.handle_timeout(give_up);
        if retries == 0 {
            assert_eq!(m.poll_event(), Some(MasterEvent::Timeout { attempts: 1 }));
            assert!(m.is_idle());
        } else {
            // Retransmission.
            assert_eq!(m.poll_transmit(give_up, &mut buf), Some(6));
            let end2 = after_chars(give_up, 6);
            m.handle_timeout(end2 + timeout + CHAR_TIME);
            assert_eq!(m.poll_event(), Some(MasterEvent::Timeout { attempts: 2 }));
        }
    }
}

#[test]
fn late_response_start_is_a_timeout() {
    let cfg = MasterConfig {
        retries: 0,
        ..MasterConfig::default()
    };
    let mut m = MovilinkMaster::new(cfg);
    m.send(Telegram::request(drive1(), PduType::PD1_ACYCLIC), us(0))
        .unwrap();
    let mut buf = [0u8; 18];
    m.poll_transmit(us(0), &mut buf).unwrap();
    let resp = Telegram::response(drive1(), PduType::PD1_ACYCLIC);
    let n = encode(&resp, &mut buf).unwrap();
    // SD2 completes later than deadline + one character: too late.
    let t0 = 6 * CT + 50_000 + 1;
    for (i, b) in buf[..n].iter().enumerate() {
        m.handle_char(RxChar::new(*b, us(t0 + CT * (i as u64 + 1))));
    }
    assert_eq!(m.poll_event(), Some(MasterEvent::Timeout { attempts: 1 }));
    assert_eq!(m.poll_event(), None);
}

#[test]
fn slave_answers_one_start_pause_after_the_request() {
    let mut s = Slave::new(SlaveConfig::new(drive1()), TestDrive::default());
    let req = Telegram::request(drive1(), PduType::PARAM_0PD_ACYCLIC)
        .with_param(ParamChannel::read(8318));
    let mut buf = [0u8; 18];
    let n = encode(&req, &mut buf).unwrap();
    for (i, b) in buf[..n].iter().enumerate() {
        s.handle_char(RxChar::new(*b, us(CT * (i as u64 + 1))));
    }
    let end = CT * n as u64;
    assert_eq!(s.poll_timeout(), Some(us(end + 3_440)));
    s.handle_timeout(us(end + 3_439));
    assert_eq!(s.poll_transmit(us(end + 3_439), &mut buf), None);
    s.handle_timeout(us(end + 3_440));
    assert_eq!(s.poll_transmit(us(end + 3_440), &mut buf), Some(12));
    assert_eq!(&buf[..3], &[0x1D, 0x01, 0x86]);
}

fn send_cyclic(s: &mut Slave<TestDrive>, t0: u64, pdu: PduType) -> u64 {
    let req = Telegram::request(drive1(), pdu).with_process_data(&[6, 0x1000, 0]);
    let mut buf = [0u8; 18];
    let n = encode(&req, &mut buf).unwrap();
    for (i, b) in buf[..n].iter().enumerate() {
        s.handle_char(RxChar::new(*b, us(t0 + CT * (i as u64 + 1))));
    }
    let mut out = [0u8; 18];
    let due = us(t0 + CT * n as u64 + 3_440);
    s.handle_timeout(due);
    let _ = s.poll_transmit(due, &mut out);
    t0 + CT * n as u64
}

#[test]
fn backend_deadlines_wake_the_backend_and_requests_reach_it_with_their_context() {
    // The test drive monitors cyclic requests with a 100 ms timeout of its own (as the
    // simulated MOVIDRIVE monitors P812): the slave only wakes it at its deadline.
    let mut s = Slave::new(SlaveConfig::new(drive1()), TestDrive::default());
    s.backend_mut().monitor = Some(Duration::from_millis(100));
    s.handle_timeout(us(1_000_000));
    // Acyclic requests reach the backend as acyclic: the monitor stays unarmed.
    let end = send_cyclic(&mut s, 1_000_000, PduType::PD3_ACYCLIC);
    assert_eq!(s.backend().last_request.map(|c| c.cyclic), Some(false));
    assert_eq!(s.poll_timeout(), None);
    let end = send_cyclic(&mut s, end + 10_000, PduType::PD3);
    let ctx = s.backend().last_request.unwrap();
    assert!(ctx.cyclic && ctx.answered);
    assert_eq!(ctx.end, us(end));
    assert_eq!(s.poll_timeout(), Some(us(end + 100_000)));
    s.handle_timeout(us(end + 99_999));
    assert_eq!(s.backend().timeouts, 0);
    s.handle_timeout(us(end + 100_000));
    assert_eq!(s.backend().timeouts, 1);
    assert_eq!(s.poll_timeout(), None);
    // A broadcast reaches it too, unanswered.
    let bc = Telegram::request(Address::BROADCAST, PduType::PD3).with_process_data(&[6, 0, 0]);
    let mut buf = [0u8; 18];
    let n = encode(&bc, &mut buf).unwrap();
    let t0 = end + 200_000;
    for (i, b) in buf[..n].iter().enumerate() {
        s.handle_char(RxChar::new(*b, us(t0 + CT * (i as u64 + 1))));
    }
    s.handle_timeout(us(t0 + CT * n as u64 + 3_440));
    let ctx = s.backend().last_request.unwrap();
    assert_eq!((ctx.address, ctx.answered), (Address::BROADCAST, false));
}
