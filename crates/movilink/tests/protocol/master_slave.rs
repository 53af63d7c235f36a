//! Master and drive state machines exchanging bytes in memory.

use movilink::timing::Instant;
use movilink::{
    Address, AttributeInfo, MasterConfig, MasterEvent, MovilinkMaster, ParamChannel, PduType,
    RejectReason, ReturnCode, RxChar, ScaleInfo, SendError, Slave, SlaveConfig, SlaveEvent,
    Telegram, encode,
};

use super::bus::{Bus, TestDrive};

fn drive1() -> Address {
    Address::new(1).unwrap()
}

fn bus() -> Bus<TestDrive> {
    bus_with(MasterConfig::default(), SlaveConfig::new(drive1()))
}

fn bus_with(m: MasterConfig, s: SlaveConfig) -> Bus<TestDrive> {
    Bus::new(MovilinkMaster::new(m), Slave::new(s, TestDrive::default()))
}

fn param_request(pdu: PduType, p: ParamChannel) -> Telegram {
    Telegram::request(drive1(), pdu)
        .with_param(p)
        .with_process_data(&[0x0006, 0x2000, 0x0BB8])
}

/// Send and run; return the ParamDone result and all events.
fn exchange(
    bus: &mut Bus<TestDrive>,
    req: Telegram,
) -> (Option<Result<u32, ReturnCode>>, Vec<MasterEvent>) {
    let now = bus.now;
    bus.master.send(req, now).unwrap();
    let events = bus.run_collect();
    let done = events.iter().find_map(|e| match e {
        MasterEvent::ParamDone(r) => Some(*r),
        _ => None,
    });
    (done, events)
}

#[test]
fn acyclic_read_write_and_services() {
    let mut bus = bus();
    let t = PduType::PARAM_0PD_ACYCLIC;
    assert_eq!(
        exchange(&mut bus, param_request(t, ParamChannel::read(8471))).0,
        Some(Ok(2000))
    );
    assert_eq!(
        exchange(&mut bus, param_request(t, ParamChannel::write(8471, 3000))).0,
        Some(Ok(3000))
    );
    assert_eq!(bus.slave.backend().value(8471), Some(3000));
    assert_eq!(
        exchange(
            &mut bus,
            param_request(t, ParamChannel::write_volatile(8471, 4000))
        )
        .0,
        Some(Ok(4000))
    );
    assert_eq!(
        exchange(&mut bus, param_request(t, ParamChannel::read_minimum(8471))).0,
        Some(Ok(0))
    );
    assert_eq!(
        exchange(&mut bus, param_request(t, ParamChannel::read_maximum(8471))).0,
        Some(Ok(2_000_000))
    );
    assert_eq!(
        exchange(&mut bus, param_request(t, ParamChannel::read_default(8471))).0,
        Some(Ok(2000))
    );
    let scale = exchange(&mut bus, param_request(t, ParamChannel::read_scale(8471)))
        .0
        .unwrap()
        .unwrap();
    assert_eq!(
        ScaleInfo::from_data(scale),
        ScaleInfo {
            size_index: 4,
            conversion_index: -3
        }
    );
    let attr = exchange(
        &mut bus,
        param_request(t, ParamChannel::read_attribute(8471)),
    )
    .0
    .unwrap()
    .unwrap();
    assert_eq!(AttributeInfo::from_data(attr).next_index, 8472);
    assert_eq!(bus.requests, 8);
    assert_eq!(bus.responses, 8);
}

#[test]
fn drive_errors_are_return_codes() {
    let mut bus = bus();
    let t = PduType::PARAM_1PD_ACYCLIC;
    assert_eq!(
        exchange(&mut bus, param_request(t, ParamChannel::write(8318, 1))).0,
        Some(Err(ReturnCode::READ_ONLY))
    );
    assert_eq!(
        exchange(&mut bus, param_request(t, ParamChannel::read(9999))).0,
        Some(Err(ReturnCode::ILLEGAL_INDEX))
    );
    assert_eq!(
        exchange(&mut bus, param_request(t, ParamChannel::write(8597, 100))).0,
        Some(Err(ReturnCode::VALUE_TOO_LARGE))
    );
    // Undefined service code 0xF.
    let mut p = ParamChannel::read(8471);
    p.management = movilink::Management::from_raw(0x3F);
    assert_eq!(
        exchange(&mut bus, param_request(t, p)).0,
        Some(Err(ReturnCode::ILLEGAL_SERVICE_CODING))
    );
}

#[test]
fn process_data_in_both_directions() {
    let mut bus = bus();
    let req = Telegram::request(drive1(), PduType::PD3_ACYCLIC)
        .with_process_data(&[0x0006, 0x2000, 0x0BB8]);
    let (done, events) = exchange(&mut bus, req);
    assert_eq!(done, None);
    let [MasterEvent::Response { telegram }] = events.as_slice() else {
        panic!("{events:?}")
    };
    // The ch. 4.3 application example's answer.
    assert_eq!(telegram.process_data(), &[0x0206, 0x0000, 0x0606]);
    assert_eq!(bus.slave.backend().po, [0x0006, 0x2000, 0x0BB8]);
}

#[test]
fn cyclic_handshake_sync_then_toggle() {
    let mut bus = bus();
    let t = PduType::PARAM_3PD;
    // First service: the master does not know the drive's handshake bit, learns it with a
    // "no service" exchange, then sends the read with the bit toggled.
    let (done, events) = exchange(&mut bus, param_request(t, ParamChannel::read(8471)));
    assert_eq!(done, Some(Ok(2000)));
    assert_eq!(bus.requests, 2);
    assert_eq!(
        events
            .iter()
            .filter(|e| matches!(e, MasterEvent::Response { .. }))
            .count(),
        2
    );
    assert_eq!(bus.slave.backend().executed, 1);
    // The next services toggle directly: one exchange each, executed once each.
    for (i, value) in [100u32, 200, 300].into_iter().enumerate() {
        let (done, _) = exchange(
            &mut bus,
            param_request(t, ParamChannel::write_volatile(8471, value)),
        );
        assert_eq!(done, Some(Ok(value)));
        assert_eq!(bus.requests, 3 + i as u32);
        assert_eq!(bus.slave.backend().executed, 2 + i as u32);
    }
    // Process data only (no service): no toggle, nothing executed.
    let (done, _) = exchange(&mut bus, param_request(t, ParamChannel::no_service()));
    assert_eq!(done, None);
    assert_eq!(bus.slave.backend().executed, 4);
}

#[test]
fn slave_executes_cyclic_service_only_on_toggle() {
    let mut s = Slave::new(SlaveConfig::new(drive1()), TestDrive::default());
    let mut t0 = 0u64;
    let mut answers = Vec::new();
    // Handshake sequence as in Bild 22: 0, 0, 1, 1, 0.
    for hs in [false, false, true, true, false] {
        let p = ParamChannel::write_volatile(8471, 1000 + t0 as u32 % 7).with_handshake(hs);
        let req = Telegram::request(drive1(), PduType::PARAM_0PD).with_param(p);
        let mut buf = [0u8; 18];
        let n = encode(&req, &mut buf).unwrap();
        for (i, b) in buf[..n].iter().enumerate() {
            s.handle_char(RxChar::new(
                *b,
                Instant::from_micros(t0 + 1146 * (i as u64 + 1)),
            ));
        }
        t0 += 1146 * n as u64 + 3440;
        s.handle_timeout(Instant::from_micros(t0));
        let n = s.poll_transmit(Instant::from_micros(t0), &mut buf).unwrap();
        let (resp, _) = movilink::decode(&buf[..n]).unwrap();
        answers.push(resp.param().unwrap().management.handshake());
        t0 += 1146 * n as u64 + 3440;
    }
    // Initial state 0: the first two (bit 0) are not executed, 1 executes once, 0 executes once.
    assert_eq!(s.backend().executed, 2);
    assert_eq!(answers, [false, false, true, true, false]);
}

#[test]
fn retry_after_lost_response() {
    let mut bus = bus();
    bus.faults.drop_responses = 1;
    let (done, events) = exchange(
        &mut bus,
        param_request(PduType::PARAM_0PD_ACYCLIC, ParamChannel::read(8471)),
    );
    assert_eq!(done, Some(Ok(2000)));
    assert_eq!(bus.requests, 2);
    assert!(
        !events
            .iter()
            .any(|e| matches!(e, MasterEvent::Timeout { .. }))
    );
}

#[test]
fn retry_after_lost_request() {
    let mut bus = bus();
    bus.faults.drop_requests = 2;
    let (done, _) = exchange(
        &mut bus,
        param_request(PduType::PARAM_0PD_ACYCLIC, ParamChannel::read(8471)),
    );
    assert_eq!(done, Some(Ok(2000)));
    assert_eq!(bus.requests, 3);
}

#[test]
fn retry_after_corrupt_answer() {
    let mut bus = bus();
    bus.faults.corrupt_responses = 1;
    bus.faults.parity_responses = 1;
    let (done, events) = exchange(
        &mut bus,
        param_request(PduType::PARAM_0PD_ACYCLIC, ParamChannel::write(8471, 7)),
    );
    assert_eq!(done, Some(Ok(7)));
    assert_eq!(bus.requests, 3);
    let rejected: Vec<_> = events
        .iter()
        .filter_map(|e| match e {
            MasterEvent::Rejected(r) => Some(*r),
            _ => None,
        })
        .collect();
    assert!(
        matches!(
            rejected.as_slice(),
            [
                RejectReason::BadBcc { .. },
                RejectReason::Char(movilink::CharError::Parity)
            ]
        ),
        "{rejected:?}"
    );
    // Acyclic writes execute on every request: the drive wrote three times.
    assert_eq!(bus.slave.backend().executed, 3);
}

#[test]
fn cyclic_retry_does_not_execute_twice() {
    let mut bus = bus();
    // Learn the handshake first.
    exchange(
        &mut bus,
        param_request(PduType::PARAM_1PD, ParamChannel::no_service()),
    );
    bus.faults.corrupt_responses = 2;
    let (done, _) = exchange(
        &mut bus,
        param_request(PduType::PARAM_1PD, ParamChannel::write(8471, 9)),
    );
    assert_eq!(done, Some(Ok(9)));
    assert_eq!(bus.requests, 4);
    // Same handshake bit on the retries: the drive executed once and echoed its answer.
    assert_eq!(bus.slave.backend().executed, 1);
}

#[test]
fn gives_up_after_retries() {
    let mut bus = bus_with(
        MasterConfig {
            retries: 2,
            ..MasterConfig::default()
        },
        SlaveConfig::new(drive1()),
    );
    bus.faults.drop_responses = 10;
    let (done, events) = exchange(
        &mut bus,
        param_request(PduType::PARAM_0PD_ACYCLIC, ParamChannel::read(8471)),
    );
    assert_eq!(done, None);
    assert_eq!(events, vec![MasterEvent::Timeout { attempts: 3 }]);
    assert_eq!(bus.requests, 3);
    // 3 × (12 chars + 50 ms + 1 char) plus the gaps: about 196 ms of simulated time.
    assert!(
        bus.now.as_micros() > 150_000 && bus.now.as_micros() < 250_000,
        "{:?}",
        bus.now
    );
}

#[test]
fn no_answer_for_group_and_broadcast() {
    let group = Address::group(120).unwrap();
    let cfg = SlaveConfig {
        group,
        ..SlaveConfig::new(drive1())
    };
    let mut bus = bus_with(MasterConfig::default(), cfg);
    for a in [group, Address::BROADCAST] {
        let req = Telegram::request(a, PduType::PARAM_3PD_ACYCLIC)
            .with_param(ParamChannel::write_volatile(8471, 1234))
            .with_process_data(&[1, 2, 3]);
        let now = bus.now;
        bus.master.send(req, now).unwrap();
        let events = bus.run_collect();
        assert_eq!(events, vec![MasterEvent::Sent { address: a }]);
        assert_eq!(bus.responses, 0);
        assert_eq!(bus.slave.backend().value(8471), Some(1234));
        assert_eq!(bus.slave.backend().po, [1, 2, 3]);
        let mut answered = None;
        while let Some(e) = bus.slave.poll_event() {
            if let SlaveEvent::Received { answered: a, .. } = e {
                answered = Some(a);
            }
        }
        assert_eq!(answered, Some(false));
    }
    // Another group is not accepted.
    let other = Telegram::request(Address::group(121).unwrap(), PduType::PD1);
    let now = bus.now;
    bus.master.send(other, now).unwrap();
    bus.run_collect();
    let mut rejected = false;
    while let Some(e) = bus.slave.poll_event() {
        rejected |= e == SlaveEvent::Rejected(RejectReason::WrongAddress { address: 121 });
    }
    assert!(rejected);
}

#[test]
fn point_to_point_254() {
    for own_address in [false, true] {
        let cfg = SlaveConfig {
            reply_p2p_with_own_address: own_address,
            ..SlaveConfig::new(Address::new(42).unwrap())
        };
        let mut bus = bus_with(MasterConfig::default(), cfg);
        let req = Telegram::request(Address::POINT_TO_POINT, PduType::PARAM_0PD_ACYCLIC)
            .with_param(ParamChannel::read(8471));
        let (done, events) = exchange(&mut bus, req);
        assert_eq!(done, Some(Ok(2000)));
        let Some(MasterEvent::Response { telegram }) = events.first() else {
            panic!()
        };
        assert_eq!(telegram.address().get(), if own_address { 42 } else { 254 });
    }
}

#[test]
fn response_with_other_pdu_type_is_rejected() {
    let cfg = MasterConfig {
        retries: 0,
        ..MasterConfig::default()
    };
    let mut m = MovilinkMaster::new(cfg);
    m.send(
        Telegram::request(drive1(), PduType::PD1_ACYCLIC),
        Instant::ZERO,
    )
    .unwrap();
    let mut buf = [0u8; 18];
    m.poll_transmit(Instant::ZERO, &mut buf).unwrap();
    let wrong = Telegram::response(drive1(), PduType::PD1);
    let n = encode(&wrong, &mut buf).unwrap();
    for (i, b) in buf[..n].iter().enumerate() {
        m.handle_char(RxChar::new(
            *b,
            Instant::from_micros(20_000 + 1146 * i as u64),
        ));
    }
    // The response is judged once the quiet line after it confirmed its end.
    m.handle_timeout(m.poll_timeout().unwrap());
    assert_eq!(
        m.poll_event(),
        Some(MasterEvent::Rejected(RejectReason::PduTypeMismatch {
            expected: 0x81,
            got: 0x01
        }))
    );
    assert_eq!(m.poll_event(), Some(MasterEvent::Timeout { attempts: 1 }));
}

#[test]
fn acyclic_answer_to_other_index_is_rejected() {
    let cfg = MasterConfig {
        retries: 0,
        ..MasterConfig::default()
    };
    let mut m = MovilinkMaster::new(cfg);
    let req = Telegram::request(drive1(), PduType::PARAM_0PD_ACYCLIC)
        .with_param(ParamChannel::read(8471));
    m.send(req, Instant::ZERO).unwrap();
    let mut buf = [0u8; 18];
    m.poll_transmit(Instant::ZERO, &mut buf).unwrap();
    let wrong = Telegram::response(drive1(), PduType::PARAM_0PD_ACYCLIC)
        .with_param(ParamChannel::read(8470).answer(Ok(1)));
    let n = encode(&wrong, &mut buf).unwrap();
    for (i, b) in buf[..n].iter().enumerate() {
        m.handle_char(RxChar::new(
            *b,
            Instant::from_micros(20_000 + 1146 * i as u64),
        ));
    }
    // The response is judged once the quiet line after it confirmed its end.
    m.handle_timeout(m.poll_timeout().unwrap());
    assert_eq!(
        m.poll_event(),
        Some(MasterEvent::Rejected(RejectReason::ParamMismatch))
    );
    assert_eq!(m.poll_event(), Some(MasterEvent::Timeout { attempts: 1 }));
}

#[test]
fn cyclic_service_not_executed_in_time() {
    // A drive that never toggles: answers echo handshake 0 forever.
    let cfg = MasterConfig {
        max_handshake_cycles: 3,
        ..MasterConfig::default()
    };
    let mut m = MovilinkMaster::new(cfg);
    let mut t = 0u64;
    let mut buf = [0u8; 18];
    let stuck =
        Telegram::response(drive1(), PduType::PARAM_0PD).with_param(ParamChannel::no_service());
    let answer = |m: &mut MovilinkMaster, t: &mut u64| {
        let mut out = [0u8; 18];
        let n = encode(&stuck, &mut out).unwrap();
        for b in &out[..n] {
            *t += 1146;
            m.handle_char(RxChar::new(*b, Instant::from_micros(*t)));
        }
        *t += 3440;
        m.handle_timeout(Instant::from_micros(*t));
    };
    m.send(
        Telegram::request(drive1(), PduType::PARAM_0PD).with_param(ParamChannel::read(8471)),
        Instant::ZERO,
    )
    .unwrap();
    let mut transmissions = 0;
    while !m.is_idle() {
        let n = m.poll_transmit(Instant::from_micros(t), &mut buf).unwrap();
        transmissions += 1;
        t += 1146 * n as u64 + 5000;
        answer(&mut m, &mut t);
    }
    // 1 sync exchange + 3 cycles.
    assert_eq!(transmissions, 4);
    let events: Vec<_> = std::iter::from_fn(|| m.poll_event()).collect();
    assert_eq!(
        events.last(),
        Some(&MasterEvent::ParamNotExecuted { cycles: 3 })
    );
}

#[test]
fn send_errors() {
    let mut m = MovilinkMaster::new(MasterConfig::default());
    assert_eq!(
        m.send(Telegram::response(drive1(), PduType::PD1), Instant::ZERO),
        Err(SendError::NotARequest)
    );
    m.send(Telegram::request(drive1(), PduType::PD1), Instant::ZERO)
        .unwrap();
    assert_eq!(
        m.send(Telegram::request(drive1(), PduType::PD1), Instant::ZERO),
        Err(SendError::Busy)
    );
    let job = m.request_mut().expect("a request is in flight");
    job.set_process_data(&[5]);
    let mut small = [0u8; 5];
    assert_eq!(m.poll_transmit(Instant::ZERO, &mut small), None);
}

#[test]
fn many_reads_in_a_row() {
    let mut bus = bus();
    for _ in 0..100 {
        let (done, _) = exchange(
            &mut bus,
            param_request(PduType::PARAM_0PD_ACYCLIC, ParamChannel::read(8318)),
        );
        assert_eq!(done, Some(Ok(1500)));
    }
    assert_eq!(bus.requests, 100);
}
