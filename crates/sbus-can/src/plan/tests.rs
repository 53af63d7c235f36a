use super::*;

fn a(n: u8) -> Address {
    Address::new(n).unwrap()
}

fn ids(address: u8, group: u8) -> SlaveIds {
    SlaveIds {
        address: a(address),
        group: a(group),
        sync_id: 0,
    }
}

/// The manual's example (ch. 5.5, Bild 35 and the table under it): device 1 is slave at
/// address 0 and group 0 and master of address 1 and group 2; device 2 is slave at address 1
/// and group 2.
fn manual_example() -> Plan {
    let mut d1 = Device::slave("device 1", ids(0, 0));
    d1.master_of = vec![Target::Address(a(1)), Target::Group(a(2))];
    let d2 = Device::slave("device 2", ids(1, 2));
    Plan {
        bitrate: Bitrate::K500,
        devices: vec![d1, d2],
    }
}

fn obj(id: u16, kind: ObjectKind) -> Object {
    Object { id, len: 8, kind }
}

const CYCLIC_100: ObjectKind = ObjectKind::Cyclic {
    cycle_ms: 100,
    offset_ms: 0,
};

/// The table "Belegung der Identifier": every identifier of both devices with its direction.
#[test]
fn manual_id_table() {
    use Direction::{Receive as R, Transmit as T};
    let plan = manual_example();
    let got = |i: usize| -> Vec<(u16, Direction)> {
        plan.devices[i]
            .movilink_uses()
            .iter()
            .filter(|u| u.kind.is_some()) // the table has no SYNC row
            .map(|u| (u.id, u.direction))
            .collect()
    };
    assert_eq!(
        got(0),
        [
            (515, R),
            (516, T),
            (3, R),
            (4, T),
            (5, R),
            (518, R),
            (6, R),
            (523, T),
            (524, R),
            (11, T),
            (12, R),
            (13, T),
            (534, T),
            (22, T),
        ]
    );
    assert_eq!(
        got(1),
        [
            (523, R),
            (524, T),
            (11, R),
            (12, T),
            (13, R),
            (534, R),
            (22, R),
        ]
    );
    assert!(plan.check().is_empty(), "{:?}", plan.check());
}

/// The printed table "Folgende Variablen-Objekte dürfen im Beispiel nicht verwendet werden"
/// against the two rules (erratum SB-E12):
///
/// * device 1: the print adds 531, 532, 19, 29, 21, which no rule gives: 531/532/19/21 are
///   the parameter request/response, PO and PO sync of *address* 2, but device 1 is master of
///   *group* 2 (534, 22 only); 29 is no identifier of address 2 at all (8 × 3 + 5);
/// * device 2: its receive column lacks 22, the group PO it receives itself (rule 2);
/// * both: the SYNC identifier (P817 = 0) every drive listens to is missing.
#[test]
fn manual_forbidden_table_sb_e12() {
    let plan = manual_example();
    let printed_1: [u16; 19] = [
        515, 516, 3, 4, 5, 518, 6, 523, 524, 11, 12, 13, 534, 22, 531, 532, 19, 29, 21,
    ];
    let printed_2_tx: [u16; 9] = [523, 524, 11, 12, 13, 534, 22, 516, 4];
    let printed_2_rx: [u16; 6] = [523, 524, 11, 12, 13, 534];

    let f1 = plan.forbidden(0).unwrap();
    let f2 = plan.forbidden(1).unwrap();
    // Device 1: the print without its five extras, plus SYNC 0, in the print's order.
    let want_1 = [515, 516, 3, 4, 5, 518, 6, 523, 524, 11, 12, 13, 534, 22, 0];
    assert_eq!(f1.transmit, want_1);
    assert_eq!(f1.receive, want_1);
    let extras: Vec<u16> = printed_1
        .iter()
        .copied()
        .filter(|id| !f1.transmit.contains(id))
        .collect();
    assert_eq!(extras, [531, 532, 19, 29, 21]);
    // Device 2: the transmit column is right (plus SYNC 0); the receive column lacks 22.
    assert_eq!(f2.transmit, [523, 524, 11, 12, 13, 534, 22, 0, 516, 4]);
    assert_eq!(
        f2.transmit
            .iter()
            .filter(|id| **id != 0)
            .copied()
            .collect::<Vec<_>>(),
        printed_2_tx
    );
    assert_eq!(f2.receive, [523, 524, 11, 12, 13, 534, 22, 0]);
    assert!(!printed_2_rx.contains(&22));

    // Were device 1 also master of address 2, the extras would be 531, 532, 19, 20, 21:
    // 20 (PI of address 2), not 29.
    let mut with_2 = manual_example();
    with_2.devices[0].master_of.push(Target::Address(a(2)));
    let f = with_2.forbidden(0).unwrap();
    assert_eq!(&f.transmit[14..19], [531, 532, 19, 20, 21]);
    assert!(!f.transmit.contains(&29));

    // Rule 2 is what the check applies: device 2 receiving 22 as a variable is refused.
    let mut p = manual_example();
    p.devices[1].objects.push(obj(22, ObjectKind::Receive));
    assert_eq!(
        p.check(),
        [Violation::OwnMovilinkId {
            device: "device 2".into(),
            id: 22,
            object: ObjectKind::Receive,
            movilink: Some(Kind::GroupProcessOutput),
        }]
    );
    assert_eq!(plan.forbidden(2), None);
}

#[test]
fn rule_1_one_transmitter_per_id() {
    // Device 2 sends variables on 516, device 1's parameter response.
    let mut p = manual_example();
    p.devices[1].objects.push(obj(516, CYCLIC_100));
    let v = p.check();
    assert_eq!(
        v,
        [Violation::SharedTransmitId {
            id: 516,
            transmitters: vec![
                IdUser {
                    device: "device 1".into(),
                    usage: Usage::Movilink(Some(Kind::ParamResponse)),
                },
                IdUser {
                    device: "device 2".into(),
                    usage: Usage::Variable(CYCLIC_100),
                },
            ],
        }]
    );
    assert_eq!(
        v[0].to_string(),
        "identifier 516 is sent by more than one node (ch. 5.5 rule 1): \"device 1\" (MOVILINK parameter response), \"device 2\" (cyclic transmit object)"
    );
    // Two devices' variable objects on one identifier; a receiver of it is fine.
    let mut p = manual_example();
    p.devices[0].objects.push(obj(1024, CYCLIC_100));
    p.devices[1].objects.push(obj(1024, ObjectKind::Acyclic));
    p.devices[1].objects.push(obj(1025, ObjectKind::Receive));
    p.devices[0].objects.push(obj(1025, ObjectKind::Acyclic));
    let v = p.check();
    assert_eq!(v.len(), 1);
    assert!(matches!(
        &v[0],
        Violation::SharedTransmitId { id: 1024, .. }
    ));
    // Another device's variable transmit ids are forbidden for transmit, not for receive.
    let f = p.forbidden(1).unwrap();
    assert!(f.transmit.contains(&1025) && !f.receive.contains(&1025));
    // Two masters of one address (MOVLNK is single-master).
    let mut p = manual_example();
    let mut plc = Device {
        name: "PLC".into(),
        ..Device::default()
    };
    plc.master_of.push(Target::Address(a(1)));
    p.devices.push(plc);
    let shared: Vec<u16> = p
        .check()
        .iter()
        .map(|v| match v {
            Violation::SharedTransmitId { id, .. } => *id,
            other => panic!("{other}"),
        })
        .collect();
    assert_eq!(shared, [11, 13, 523]);
}

#[test]
fn rule_2_and_received_as_movilink_sb_e13() {
    let mut p = manual_example();
    // Device 1 receives 12 (its own PI from address 1) as a variable: rule 2.
    p.devices[0].objects.push(obj(12, ObjectKind::Receive));
    // Device 2 sends variables on 3: device 1 would take them as its process output data,
    // and no master sends 3 (so rule 1 does not catch it).
    p.devices[1].objects.push(obj(3, ObjectKind::Acyclic));
    let v = p.check();
    assert_eq!(
        v,
        [
            Violation::OwnMovilinkId {
                device: "device 1".into(),
                id: 12,
                object: ObjectKind::Receive,
                movilink: Some(Kind::ProcessInput),
            },
            Violation::ReceivedAsMovilink {
                device: "device 2".into(),
                id: 3,
                receiver: "device 1".into(),
                kind: Some(Kind::ProcessOutput),
            },
        ]
    );
    assert_eq!(
        v[1].to_string(),
        "\"device 2\": transmit object 3 is \"device 1\"'s MOVILINK process output data (PO) identifier: \"device 1\" would take the variables as that telegram"
    );
    // Variables on the SYNC identifier: every drive takes them as SYNC.
    let mut p = manual_example();
    p.devices[0].objects.push(obj(0, CYCLIC_100));
    let v = p.check();
    assert!(v.contains(&Violation::OwnMovilinkId {
        device: "device 1".into(),
        id: 0,
        object: CYCLIC_100,
        movilink: None,
    }));
    assert!(v.contains(&Violation::ReceivedAsMovilink {
        device: "device 1".into(),
        id: 0,
        receiver: "device 2".into(),
        kind: None,
    }));
}

#[test]
fn sync_id_and_addresses() {
    let mut p = manual_example();
    p.devices[1].slave = Some(SlaveIds {
        address: a(1),
        group: a(2),
        sync_id: 13,
    });
    let v = p.check();
    assert_eq!(
        v,
        [
            Violation::SyncIdCollision {
                device: "device 2".into(),
                sync_id: 13,
                user: "device 1".into(),
                kind: Kind::ProcessOutputSync,
            },
            Violation::SyncIdCollision {
                device: "device 2".into(),
                sync_id: 13,
                user: "device 2".into(),
                kind: Kind::ProcessOutputSync,
            },
        ]
    );
    // Two drives at address 0: also their PI and response collide (rule 1).
    let mut p = manual_example();
    p.devices.push(Device::slave("device 3", ids(0, 5)));
    let v = p.check();
    assert_eq!(
        v[0],
        Violation::DuplicateAddress {
            address: a(0),
            devices: vec!["device 1".into(), "device 3".into()],
        }
    );
    assert_eq!(
        v[0].to_string(),
        "SBus address (P813) 0 is set on more than one device: \"device 1\", \"device 3\""
    );
    assert!(
        v[1..]
            .iter()
            .all(|v| matches!(v, Violation::SharedTransmitId { id: 4 | 516, .. }))
    );
    assert_eq!(v.len(), 3);
}

#[test]
fn object_limits_and_validity() {
    let mut p = manual_example();
    let d = &mut p.devices[1];
    for n in 0..6 {
        d.objects.push(obj(
            1100 + n,
            ObjectKind::Cyclic {
                cycle_ms: 5,
                offset_ms: 0,
            },
        ));
    }
    for n in 0..11 {
        d.objects.push(obj(
            1200 + n,
            ObjectKind::Cyclic {
                cycle_ms: 1000,
                offset_ms: 0,
            },
        ));
    }
    for n in 0..33 {
        d.objects.push(obj(1300 + n, ObjectKind::Receive));
    }
    d.objects.push(obj(2048, ObjectKind::Receive));
    d.objects.push(Object {
        id: 1400,
        len: 0x9,
        kind: ObjectKind::Acyclic,
    });
    d.objects.push(obj(
        1401,
        ObjectKind::Cyclic {
            cycle_ms: 15,
            offset_ms: 0,
        },
    ));
    d.objects.push(obj(1300, ObjectKind::Acyclic));
    let v = p.check();
    let names: Vec<String> = v.iter().map(ToString::to_string).collect();
    assert_eq!(
        names,
        [
            "\"device 2\": object number 2048 is no 11-bit identifier (0–2047)",
            "\"device 2\": object 1400: Len word 9h is none of 0h…8h (MOTOROLA) and 100h…108h (INTEL)",
            "\"device 2\": object 1401: wrong cycle time 15 ms: 1–9 ms, or 10–65530 ms in steps of 10 ms",
            "\"device 2\": object number 1300 is set up more than once",
            "\"device 2\": 6 cyclic transmit objects with cycle 1–9 ms, at most 5",
            "\"device 2\": 11 cyclic transmit objects with cycle 10–65530 ms, at most 10",
            "\"device 2\": 33 receive objects, at most 32",
        ]
    );
}

#[test]
fn bus_overload() {
    // Four 8-byte objects every 1 ms at 500 kbit/s on two devices: 108 %.
    let fast = ObjectKind::Cyclic {
        cycle_ms: 1,
        offset_ms: 0,
    };
    let mut p = manual_example();
    for n in 0..2 {
        p.devices[0].objects.push(obj(1100 + n, fast));
        p.devices[1].objects.push(obj(1200 + n, fast));
    }
    let v = p.check();
    assert_eq!(v.len(), 1);
    assert_eq!(
        v[0].to_string(),
        "the cyclic variable objects load the bus 108.00 % at 500 kbit/s: more than it carries"
    );
    // At 1000 kbit/s they fit.
    p.bitrate = Bitrate::M1;
    assert!(p.check().is_empty());
}
