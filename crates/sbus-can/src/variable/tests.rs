use proptest::prelude::*;

use super::*;
use crate::ids::Address;

fn obj(n: u16) -> ObjectNo {
    ObjectNo::new(n).unwrap()
}

const V: Variables = Variables {
    low: 0x1122_3344,
    high: 0x5566_7788,
};

/// The manual's MOTOROLA table (ch. 5.5, "Übertragungsformate"): H20 = DPointer = 11223344h,
/// H21 = DPointer + 1 = 55667788h; bytes 0–3 carry H21, bytes 4–7 H20, MSB first.
#[test]
fn manual_motorola_table() {
    let f = encode(obj(1024), Len::MOTOROLA_8, V);
    assert_eq!(
        f.data(),
        &[
            0x55, 0x66, 0x77, 0x88, // H21 = DPointer + 1 (DataHigh), MSB … LSB
            0x11, 0x22, 0x33, 0x44, // H20 = DPointer (DataLow), MSB … LSB
        ]
    );
    assert_eq!(f.raw_id(), 1024);
    assert_eq!(decode(&f, Len::MOTOROLA_8), Ok(V));
}

/// The manual's INTEL table: bytes 44 33 22 11 88 77 66 55. Its label says bytes 0–3 are
/// "H21 = DPointer" and bytes 4–7 "H20 = DPointer + 1"; the listing under it (20 = 11223344h,
/// 21 = 55667788h) and the bytes show bytes 0–3 are H20 = DPointer (DataLow, LSB first) and
/// bytes 4–7 H21 = DPointer + 1 (erratum SB-E10).
#[test]
fn manual_intel_table_labels_sb_e10() {
    let f = encode(obj(1024), Len::INTEL_8, V);
    assert_eq!(
        f.data(),
        &[
            0x44, 0x33, 0x22, 0x11, // H20 = DPointer (DataLow), LSB … MSB; not "H21"
            0x88, 0x77, 0x66, 0x55, // H21 = DPointer + 1 (DataHigh), LSB … MSB; not "H20"
        ]
    );
    let got = decode(&f, Len::INTEL_8).unwrap();
    assert_eq!(got.low, 0x1122_3344, "bytes 0-3 are DataLow (H20)");
    assert_eq!(got.high, 0x5566_7788, "bytes 4-7 are DataHigh (H21)");
}

/// Lengths below 8 (drivebus's interpretation, `docs/protocols/sbus.md`): `n` bytes carry the
/// `n` low bytes of DataHigh:DataLow, so up to 4 bytes only DataLow is on the wire ("the
/// second variable is used only for a length > 4").
#[test]
fn short_lengths_carry_data_low_first() {
    let m = |n| to_bytes(Len::new(n, Format::Motorola).unwrap(), V);
    let i = |n| to_bytes(Len::new(n, Format::Intel).unwrap(), V);
    // Motorola, MSB first: the n low bytes of 55667788_11223344h.
    assert_eq!(m(0), [0; 8]);
    assert_eq!(m(1), [0x44, 0, 0, 0, 0, 0, 0, 0]);
    assert_eq!(m(2), [0x33, 0x44, 0, 0, 0, 0, 0, 0]);
    assert_eq!(m(4), [0x11, 0x22, 0x33, 0x44, 0, 0, 0, 0]);
    assert_eq!(m(5), [0x88, 0x11, 0x22, 0x33, 0x44, 0, 0, 0]);
    assert_eq!(m(6), [0x77, 0x88, 0x11, 0x22, 0x33, 0x44, 0, 0]);
    // Intel, LSB first.
    assert_eq!(i(0), [0; 8]);
    assert_eq!(i(1), [0x44, 0, 0, 0, 0, 0, 0, 0]);
    assert_eq!(i(2), [0x44, 0x33, 0, 0, 0, 0, 0, 0]);
    assert_eq!(i(4), [0x44, 0x33, 0x22, 0x11, 0, 0, 0, 0]);
    assert_eq!(i(5), [0x44, 0x33, 0x22, 0x11, 0x88, 0, 0, 0]);
    assert_eq!(i(6), [0x44, 0x33, 0x22, 0x11, 0x88, 0x77, 0, 0]);
    // Decoded: bytes not carried are 0 (no sign extension).
    assert_eq!(
        from_bytes(&[0xFF, 0xFE], Format::Motorola),
        Some(Variables {
            low: 0xFFFE,
            high: 0
        })
    );
    assert_eq!(
        from_bytes(&[0x44, 0x33, 0x22, 0x11, 0x88], Format::Intel),
        Some(Variables {
            low: 0x1122_3344,
            high: 0x88
        })
    );
    assert_eq!(from_bytes(&[0; 9], Format::Intel), None);
    // A frame sends exactly len bytes.
    let f = encode(obj(7), Len::new(3, Format::Intel).unwrap(), V);
    assert_eq!(f.data(), &[0x44, 0x33, 0x22]);
}

#[test]
fn len_words() {
    let mut valid = 0;
    for word in (0..0x1000u32).chain([0x1_0008, 0x8000_0108, u32::MAX]) {
        match Len::from_word(word) {
            Ok(l) => {
                valid += 1;
                assert_eq!(l.to_word(), word);
                assert!(word & 0xF <= 8 && word & !0x10F == 0);
            }
            Err(e) => assert_eq!(e.word, word),
        }
    }
    assert_eq!(valid, 18);
    assert_eq!(
        Len::from_word(0x109).unwrap_err().to_string(),
        "Len word 109h is none of 0h…8h (MOTOROLA) and 100h…108h (INTEL)"
    );
    assert!(Len::new(9, Format::Motorola).is_none());
}

#[test]
fn decode_refusals() {
    let len = Len::MOTOROLA_8;
    let short = CanFrame::standard(1024, &[1, 2, 3, 4]).unwrap();
    assert_eq!(
        decode(&short, len),
        Err(VariableError::Length {
            id: 1024,
            expected: 8,
            got: 4
        })
    );
    let remote = CanFrame::remote_frame(StandardId::new(5).unwrap(), 8).unwrap();
    assert_eq!(decode(&remote, len), Err(VariableError::Remote { id: 5 }));
    let ext =
        CanFrame::data_frame(drive_core::can::ExtendedId::new(0x1234).unwrap(), &[0; 8]).unwrap();
    assert_eq!(
        decode(&ext, len),
        Err(VariableError::ExtendedId { id: 0x1234 })
    );
}

#[test]
fn cyclic_timing_limits() {
    for ok in [
        (1, 0),
        (9, 65534),
        (10, 0),
        (10, 65530),
        (65530, 10),
        (120, 0),
        (50, 120),
    ] {
        assert!(CyclicTiming::new(ok.0, ok.1).is_ok(), "{ok:?}");
    }
    for cycle in [0, 11, 15, 65531, 65540, 70000] {
        assert_eq!(
            CyclicTiming::new(cycle, 0),
            Err(SetupError::WrongCycleTime { cycle_ms: cycle })
        );
    }
    for (cycle, offset) in [(9, 65535), (10, 65540), (10, 5), (100, 1)] {
        let e = CyclicTiming::new(cycle, offset).unwrap_err();
        assert_eq!(
            e,
            SetupError::WrongOffset {
                offset_ms: offset,
                cycle_ms: cycle
            }
        );
        assert_eq!(e.result(), Some(SetupResult::WrongCycleTime));
    }
    assert_eq!(CyclicTiming::new(9, 0).unwrap().class(), CycleClass::Fast);
    assert_eq!(CyclicTiming::new(10, 0).unwrap().class(), CycleClass::Slow);
}

#[test]
fn result_and_return_codes() {
    for code in -10..=110 {
        match SetupResult::from_code(code) {
            Some(r) => assert_eq!(r.to_code(), code),
            None => assert!(!(-3..=100).contains(&code)),
        }
    }
    for code in -1..=4 {
        match AcyclicStatus::from_code(code) {
            Some(s) => assert_eq!(s.to_code(), code),
            None => assert!(code == -1 || code == 4),
        }
    }
}

fn timing(cycle: u32, offset: u32) -> CyclicTiming {
    CyclicTiming::new(cycle, offset).unwrap()
}

/// The limits: 5 objects with 1–9 ms and 10 with 10–65530 ms, as separate pools (15 in all);
/// the sixth fast or eleventh slow object is Result −2.
#[test]
fn object_limits() {
    let mut node = VariableNode::new(NodeConfig::new(Bitrate::M1));
    for n in 0..5 {
        assert!(matches!(
            node.define_cyclic(obj(1100 + n), timing(9, 0), Len::MOTOROLA_8, V),
            Ok(SetupResult::FreeCapacity(_))
        ));
    }
    let e = node
        .define_cyclic(obj(1105), timing(1, 0), Len::MOTOROLA_8, V)
        .unwrap_err();
    assert_eq!(e.result(), Some(SetupResult::TooManyObjects));
    for n in 0..10 {
        assert!(
            node.define_cyclic(obj(1200 + n), timing(1000, 0), Len::MOTOROLA_8, V)
                .is_ok()
        );
    }
    let e = node
        .define_cyclic(obj(1210), timing(10, 0), Len::MOTOROLA_8, V)
        .unwrap_err();
    assert_eq!(
        e,
        SetupError::TooManyObjects {
            class: Some(CycleClass::Slow),
            max: 10
        }
    );
    for n in 0..32 {
        node.define_receive(obj(1300 + n), Len::INTEL_8).unwrap();
    }
    assert_eq!(
        node.define_receive(obj(1332), Len::INTEL_8),
        Err(SetupError::TooManyObjects {
            class: None,
            max: 32
        })
    );
    assert_eq!(
        node.define_receive(obj(1100), Len::INTEL_8),
        Err(SetupError::DuplicateObject { object: obj(1100) })
    );
}

/// The manual's screenshots: an 8-byte object every 100 ms (and every 120 ms) at the factory
/// 500 kbit/s answers Result 99; the bus-load model overloads where the frames cannot fit.
#[test]
fn setup_results_from_the_bus_load_model() {
    let mut node = VariableNode::new(NodeConfig::new(Bitrate::K500));
    assert_eq!(
        node.define_cyclic_raw(1024, 100, 0, 0x8, V),
        Some(SetupResult::FreeCapacity(99))
    );
    assert_eq!(
        node.define_cyclic_raw(1025, 120, 0, 0x108, V),
        Some(SetupResult::FreeCapacity(99))
    );
    // Four 8-byte objects every 1 ms at 500 kbit/s: 4 × 27 % = 108 %: the fourth is −3.
    let mut node = VariableNode::new(NodeConfig::new(Bitrate::K500));
    let codes: Vec<i32> = (0..4)
        .map(|n| {
            node.define_cyclic_raw(1100 + n, 1, 0, 8, V)
                .unwrap()
                .to_code()
        })
        .collect();
    assert_eq!(codes, [73, 46, 19, -3]);
    // The refused object is not set up.
    assert_eq!(node.sent(obj(1103)), None);
    // Wrong times are −1; refusals the manual has no code for are None.
    assert_eq!(
        node.define_cyclic_raw(1200, 15, 0, 8, V),
        Some(SetupResult::WrongCycleTime)
    );
    assert_eq!(
        node.define_cyclic_raw(1200, 20, 5, 8, V),
        Some(SetupResult::WrongCycleTime)
    );
    assert_eq!(node.define_cyclic_raw(2048, 20, 0, 8, V), None);
    assert_eq!(node.define_cyclic_raw(1200, 20, 0, 9, V), None);
    assert_eq!(node.define_cyclic_raw(1100, 20, 0, 8, V), None);
    // Reserved load (a master-slave master's 6-byte group telegram every 1 ms: 23 %) counts.
    let mut cfg = NodeConfig::new(Bitrate::K500);
    cfg.reserved = BusLoad::periodic(6, core::time::Duration::from_millis(1), Bitrate::K500);
    let mut node = VariableNode::new(cfg);
    assert_eq!(
        node.define_cyclic_raw(1024, 100, 0, 8, V),
        Some(SetupResult::FreeCapacity(76))
    );
}

/// Rule 2 of ch. 5.5: the device's own MOVILINK identifiers (and its SYNC identifier) are no
/// variable objects.
#[test]
fn movilink_ids_refused() {
    let mut cfg = NodeConfig::new(Bitrate::K500);
    cfg.slave = Some(SlaveIds {
        address: Address::new(0).unwrap(),
        group: Address::new(0).unwrap(),
        sync_id: 0,
    });
    let mut node = VariableNode::new(cfg);
    for (id, kind) in [
        (515, Some(Kind::ParamRequest)),
        (516, Some(Kind::ParamResponse)),
        (3, Some(Kind::ProcessOutput)),
        (6, Some(Kind::GroupProcessOutput)),
        (0, None),
    ] {
        assert_eq!(
            node.define_receive(obj(id), Len::MOTOROLA_8),
            Err(SetupError::MovilinkId {
                object: obj(id),
                kind
            })
        );
    }
    // 11 is address 1's: free here.
    assert!(node.define_receive(obj(11), Len::MOTOROLA_8).is_ok());
    assert_eq!(
        node.send_acyclic(obj(516), Len::MOTOROLA_8, V, Instant::ZERO)
            .unwrap_err()
            .to_string(),
        "object 516 is this device's MOVILINK parameter response identifier (ch. 5.5 rule 2)"
    );
}

/// Cyclic objects go out at start + offset + k × cycle; a late poll sends once and skips the
/// cycles it missed.
#[test]
fn cyclic_schedule() {
    let mut node = VariableNode::new(NodeConfig::new(Bitrate::K500));
    node.define_cyclic(obj(1025), timing(50, 120), Len::MOTOROLA_8, V)
        .unwrap();
    node.define_cyclic(
        obj(1030),
        timing(3, 1),
        Len::new(2, Format::Intel).unwrap(),
        V,
    )
    .unwrap();
    assert_eq!(node.poll_timeout(), None, "nothing before start");
    assert_eq!(node.poll_transmit(Instant::from_secs(1)), None);
    let t0 = Instant::from_millis(1000);
    node.start(t0);
    let ms = |m: u64| t0.add_nanos(m * 1_000_000);
    let mut sends = Vec::new();
    let mut now = t0;
    while now <= ms(230) {
        while let Some(f) = node.poll_transmit(now) {
            sends.push((now.nanos_since(t0) / 1_000_000, f.raw_id()));
        }
        now = node.poll_timeout().unwrap();
    }
    let slow: Vec<u64> = sends.iter().filter(|s| s.1 == 1025).map(|s| s.0).collect();
    assert_eq!(slow, [120, 170, 220]);
    let fast: Vec<u64> = sends.iter().filter(|s| s.1 == 1030).map(|s| s.0).collect();
    assert_eq!(fast.len(), 77); // 1, 4, …, 229
    assert!(fast.iter().enumerate().all(|(k, t)| *t == 1 + 3 * k as u64));
    // At equal times the lower identifier goes first: none here coincide, so check order.
    assert!(sends.windows(2).all(|w| w[0].0 <= w[1].0));
    // A late poll (at 400 ms; due 270, 320, 370) sends once, then the grid goes on at 420.
    let mut node2 = VariableNode::new(NodeConfig::new(Bitrate::K500));
    node2
        .define_cyclic(obj(1025), timing(50, 120), Len::MOTOROLA_8, V)
        .unwrap();
    node2.start(t0);
    assert!(node2.poll_transmit(ms(400)).is_some());
    assert!(node2.poll_transmit(ms(400)).is_none());
    assert_eq!(node2.poll_timeout(), Some(ms(420)));
    assert_eq!(node2.sent(obj(1025)), Some(1));
    // Changed data go out in the next telegram.
    assert!(node2.set_data(obj(1025), Variables { low: 1, high: 2 }));
    let f = node2.poll_transmit(ms(420)).unwrap();
    assert_eq!(f.data(), &[0, 0, 0, 2, 0, 0, 0, 1]);
    node2.stop();
    assert_eq!(node2.poll_timeout(), None);
}

/// Acyclic objects: Sending when asked, Sent when handed to the transport, Failed on a
/// reported failure or a stop; a second send while one waits is refused.
#[test]
fn acyclic_return_codes() {
    let mut node = VariableNode::new(NodeConfig::new(Bitrate::K500));
    let o = obj(1500);
    assert_eq!(node.acyclic_status(o), None);
    let now = Instant::from_millis(5);
    node.send_acyclic(o, Len::INTEL_8, V, now).unwrap();
    assert_eq!(node.acyclic_status(o), Some(AcyclicStatus::Sending));
    assert_eq!(node.poll_timeout(), Some(now));
    assert_eq!(
        node.send_acyclic(o, Len::INTEL_8, V, now),
        Err(SetupError::Busy { object: o })
    );
    let f = node.poll_transmit(now).unwrap();
    assert_eq!(f.to_string(), "5DC#4433221188776655");
    assert_eq!(node.acyclic_status(o).map(AcyclicStatus::to_code), Some(2));
    assert_eq!(node.poll_transmit(now), None);
    assert_eq!(node.poll_timeout(), None);
    // Again, then the transport fails.
    node.send_acyclic(o, Len::INTEL_8, V, now).unwrap();
    assert!(node.transmit_failed(o));
    assert_eq!(node.acyclic_status(o), Some(AcyclicStatus::Failed));
    assert_eq!(node.poll_transmit(now), None);
    // A stop fails a waiting telegram.
    node.send_acyclic(o, Len::INTEL_8, V, now).unwrap();
    node.stop();
    assert_eq!(node.acyclic_status(o).map(AcyclicStatus::to_code), Some(3));
    // Eight objects at most.
    for n in 1..8 {
        node.send_acyclic(obj(1500 + n), Len::INTEL_8, V, now)
            .unwrap();
    }
    assert!(matches!(
        node.send_acyclic(obj(1600), Len::INTEL_8, V, now),
        Err(SetupError::TooManyObjects {
            class: None,
            max: 8
        })
    ));
    // An acyclic object number is taken for cyclic and receive objects too.
    assert_eq!(
        node.define_receive(o, Len::INTEL_8),
        Err(SetupError::DuplicateObject { object: o })
    );
}

#[test]
fn receive_objects() {
    let mut node = VariableNode::new(NodeConfig::new(Bitrate::K500));
    let o = obj(1024);
    node.define_receive(o, Len::new(4, Format::Motorola).unwrap())
        .unwrap();
    let f4 = CanFrame::standard(1024, &[0x11, 0x22, 0x33, 0x44]).unwrap();
    node.handle_frame(&f4, Instant::ZERO);
    assert_eq!(node.received(o).unwrap().count, 0, "not started: ignored");
    node.start(Instant::ZERO);
    node.handle_frame(&f4, Instant::from_millis(1));
    let got = node.received(o).unwrap();
    assert_eq!((got.vars.low, got.count), (0x1122_3344, 1));
    assert_eq!(got.at, Some(Instant::from_millis(1)));
    // A wrong length is refused and counted, the value kept.
    let f8 = CanFrame::standard(1024, &[9; 8]).unwrap();
    node.handle_frame(&f8, Instant::from_millis(2));
    let got = node.received(o).unwrap();
    assert_eq!((got.vars.low, got.count, got.refused), (0x1122_3344, 1, 1));
    // Other identifiers, remote and extended frames change nothing.
    node.handle_frame(
        &CanFrame::standard(1025, &[1, 2, 3, 4]).unwrap(),
        Instant::ZERO,
    );
    node.handle_frame(
        &CanFrame::remote_frame(StandardId::new(1024).unwrap(), 4).unwrap(),
        Instant::ZERO,
    );
    assert_eq!(node.received(o).unwrap().refused, 2);
    assert_eq!(node.received(obj(1025)), None);
}

/// A receive object of up to 4 bytes writes DataLow only; DataHigh keeps its value.
#[test]
fn short_receive_keeps_data_high() {
    let mut node = VariableNode::new(NodeConfig::new(Bitrate::K500));
    node.define_receive(obj(100), Len::new(6, Format::Intel).unwrap())
        .unwrap();
    node.define_receive(obj(101), Len::new(2, Format::Intel).unwrap())
        .unwrap();
    node.start(Instant::ZERO);
    node.handle_frame(
        &CanFrame::standard(100, &[1, 0, 0, 0, 2, 0]).unwrap(),
        Instant::ZERO,
    );
    assert_eq!(
        node.received(obj(100)).unwrap().vars,
        Variables { low: 1, high: 2 }
    );
    node.handle_frame(
        &CanFrame::standard(101, &[0x34, 0x12]).unwrap(),
        Instant::ZERO,
    );
    assert_eq!(
        node.received(obj(101)).unwrap().vars,
        Variables {
            low: 0x1234,
            high: 0
        }
    );
}

/// The manual's examples as they run (Bild 36, 37 MOTOROLA; 39, 40 INTEL): device 1 sends
/// object 1024 every 100 ms and receives 1025; device 2 sends 1025 every 120 ms (MOTOROLA) or
/// 100 ms (INTEL), offset 0, and receives 1024. The text under them says object numbers 1 and
/// 2 and, for MOTOROLA telegram 2, "every 50 ms with an offset of 120 ms" (erratum SB-E11);
/// the screenshots, with their Result 99 and received values, are the vectors.
#[test]
fn manual_screenshots_exchange_sb_e11() {
    for (len, cycle2, rx1, rx2) in [
        // Bild 36/37: what each side's watch window shows as received.
        (
            Len::MOTOROLA_8,
            120,
            Variables {
                low: 0x4433_2211,
                high: 0x8877_6655,
            },
            V,
        ),
        // Bild 39/40.
        (
            Len::INTEL_8,
            100,
            Variables {
                low: 0x4433_2211,
                high: 0x8877_6655,
            },
            V,
        ),
    ] {
        let mut d1 = VariableNode::new(NodeConfig::new(Bitrate::K500));
        let mut d2 = VariableNode::new(NodeConfig::new(Bitrate::K500));
        // lTrDataLow/High of device 1 and device 2.
        assert_eq!(
            d1.define_cyclic(obj(1024), timing(100, 0), len, V),
            Ok(SetupResult::FreeCapacity(99))
        );
        d1.define_receive(obj(1025), len).unwrap();
        assert_eq!(
            d2.define_cyclic(obj(1025), timing(cycle2, 0), len, rx1),
            Ok(SetupResult::FreeCapacity(99))
        );
        d2.define_receive(obj(1024), len).unwrap();
        d1.start(Instant::ZERO);
        d2.start(Instant::ZERO);
        let mut now = Instant::ZERO;
        let end = Instant::from_millis(600);
        while now <= end {
            while let Some(f) = d1.poll_transmit(now) {
                d2.handle_frame(&f, now);
            }
            while let Some(f) = d2.poll_transmit(now) {
                d1.handle_frame(&f, now);
            }
            now = drive_core::time::earliest(d1.poll_timeout(), d2.poll_timeout()).unwrap();
        }
        assert_eq!(d1.received(obj(1025)).unwrap().vars, rx1);
        assert_eq!(d2.received(obj(1024)).unwrap().vars, rx2);
        assert_eq!(d1.sent(obj(1024)), Some(7)); // 0, 100, …, 600
        assert_eq!(d2.sent(obj(1025)), Some(if cycle2 == 120 { 6 } else { 7 }));
        // The text's numbers are not the programs': objects 1 and 2 are other identifiers,
        // and its "50 ms, offset 120 ms" would first send at 120 ms, not at 0.
        assert_eq!(d1.received(obj(2)), None);
        let text = CyclicTiming::new(50, 120).unwrap();
        assert_ne!(
            (text.cycle_ms(), text.offset_ms()),
            (cycle2, 0),
            "the screenshot's cycle and offset"
        );
    }
}

proptest! {
    /// Any variables in any length and format come back as their carried bytes.
    #[test]
    fn round_trip(low: u32, high: u32, n in 0u8..=8, intel: bool, id in 0u16..=2047) {
        let format = if intel { Format::Intel } else { Format::Motorola };
        let len = Len::new(n, format).unwrap();
        let v = Variables { low, high };
        let f = encode(obj(id), len, v);
        prop_assert_eq!(f.len(), usize::from(n));
        let mask = if n == 8 { u64::MAX } else { (1u64 << (8 * n)) - 1 };
        prop_assert_eq!(decode(&f, len), Ok(Variables::from_u64(v.to_u64() & mask)));
        prop_assert_eq!(from_bytes(f.data(), format), Ok::<_, ()>(Variables::from_u64(v.to_u64() & mask)).ok());
    }

    /// Any frame into a started node with receive objects never panics and never stores a
    /// frame of the wrong length.
    #[test]
    fn node_takes_any_frame(id in 0u16..=2047, data in proptest::collection::vec(any::<u8>(), 0..=8), word in any::<u32>()) {
        let mut node = VariableNode::new(NodeConfig::new(Bitrate::K125));
        let len = Len::from_word(word).unwrap_or(Len::MOTOROLA_8);
        node.define_receive(obj(id), len).unwrap();
        node.start(Instant::ZERO);
        let f = CanFrame::standard(id, &data).unwrap();
        node.handle_frame(&f, Instant::ZERO);
        let got = node.received(obj(id)).unwrap();
        prop_assert_eq!(got.count == 1, data.len() == len.bytes());
        prop_assert_eq!(got.refused == 1, data.len() != len.bytes());
    }
}
