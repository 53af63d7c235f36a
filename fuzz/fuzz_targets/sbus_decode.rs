//! Fuzz the SBus decoders: `Telegram::decode` with any sync identifier, the variable-telegram
//! decoder with any `Len` word, a `VariableNode` fed the frame, and the ID plan checker's
//! per-device functions on a plan built from the same bytes. Whatever decodes re-encodes to
//! the same frame.
//!
//! Input layout (missing bytes read as 0): byte 0 flags (bit 0 extended identifier, bit 1
//! remote frame), bytes 1–4 the identifier (big-endian, cut to 11 or 29 bits), bytes 5–6 the
//! sync identifier (any 16 bits), bytes 7–10 the `Len` word (big-endian), byte 11 the data
//! length (low 4 bits, at most 8), then the data bytes; everything from byte 12 on also
//! describes plan devices, 8 bytes each. See `fuzz/seeds/README.md`.
//!
//! `cargo fuzz run sbus_decode` (from the worktree root or `fuzz/`), or `scripts/fuzz`.
#![no_main]

use drive_core::Instant;
use drive_core::can::{Bitrate, CanEndpoint, CanFrame, ExtendedId, Frame, StandardId};
use libfuzzer_sys::fuzz_target;
use sbus_can::ids::{Address, SlaveIds};
use sbus_can::plan::{Device, Object, ObjectKind, Plan, Target};
use sbus_can::telegram::Telegram;
use sbus_can::variable::{self, CyclicTiming, Len, NodeConfig, ObjectNo, VariableNode, Variables};

fn byte(data: &[u8], i: usize) -> u8 {
    data.get(i).copied().unwrap_or(0)
}

fn be32(data: &[u8], i: usize) -> u32 {
    u32::from_be_bytes([
        byte(data, i),
        byte(data, i + 1),
        byte(data, i + 2),
        byte(data, i + 3),
    ])
}

fn be16(data: &[u8], i: usize) -> u16 {
    u16::from_be_bytes([byte(data, i), byte(data, i + 1)])
}

fuzz_target!(|data: &[u8]| {
    let flags = byte(data, 0);
    let raw_id = be32(data, 1);
    let sync_id = be16(data, 5);
    let len_word = be32(data, 7);
    let n = usize::from(byte(data, 11) & 0xF).min(8);
    let payload: Vec<u8> = (0..n).map(|i| byte(data, 12 + i)).collect();
    let extended = flags & 1 != 0;
    let remote = flags & 2 != 0;
    let frame = if extended {
        let id = ExtendedId::new(raw_id & 0x1FFF_FFFF).unwrap();
        if remote {
            CanFrame::remote_frame(id, n as u8)
        } else {
            CanFrame::data_frame(id, &payload)
        }
    } else {
        let id = StandardId::new((raw_id & 0x7FF) as u16).unwrap();
        if remote {
            CanFrame::remote_frame(id, n as u8)
        } else {
            CanFrame::data_frame(id, &payload)
        }
    }
    .unwrap();

    // 1. The MOVILINK telegram decoder with any sync identifier.
    if let Ok(t) = Telegram::decode(&frame, sync_id) {
        let again = t.encode(sync_id);
        assert_eq!(again.raw_id(), frame.raw_id());
        if t == Telegram::Sync {
            // SYNC is accepted with any data and sent with none.
            assert!(again.data().is_empty());
        } else {
            assert_eq!(again, frame);
        }
        assert_eq!(Telegram::decode(&again, sync_id), Ok(t));
        let _ = t.to_string();
    }

    // 2. The variable decoder with any Len word.
    let len = Len::from_word(len_word);
    if let Ok(len) = len {
        assert_eq!(len.to_word(), len_word);
        if let Ok(v) = variable::decode(&frame, len) {
            let object = ObjectNo::new(frame.standard_id().unwrap()).unwrap();
            assert_eq!(variable::encode(object, len, v), frame);
        }
    }
    if !remote {
        for format in [variable::Format::Motorola, variable::Format::Intel] {
            let v = variable::from_bytes(frame.data(), format).unwrap();
            let l = Len::new(n as u8, format).unwrap();
            assert_eq!(variable::to_bytes(l, v).get(..n), Some(frame.data()));
        }
    }

    // 3. A node with a receive object on the identifier and a cyclic object from the bytes.
    let mut node = VariableNode::new(NodeConfig::new(Bitrate::K125));
    let len = len.unwrap_or(Len::MOTOROLA_8);
    if let Some(object) = ObjectNo::new((raw_id & 0x7FF) as u16) {
        let _ = node.define_receive(object, len);
    }
    if let (Some(object), Ok(timing)) = (
        ObjectNo::new(sync_id & 0x7FF),
        CyclicTiming::new(u32::from(be16(data, 3)), u32::from(be16(data, 1))),
    ) {
        let _ = node.define_cyclic(object, timing, len, Variables::from_u64(u64::from(raw_id)));
    }
    let _ = node.send_acyclic(
        ObjectNo::new(be16(data, 9) & 0x7FF).unwrap(),
        len,
        Variables::default(),
        Instant::from_nanos(u64::from(raw_id)),
    );
    node.start(Instant::ZERO);
    node.handle_frame(&frame, Instant::from_millis(1));
    let mut now = Instant::ZERO;
    for _ in 0..8 {
        while node.poll_transmit(now).is_some() {}
        node.handle_timeout(now);
        match node.poll_timeout() {
            Some(t) if t > now => now = t,
            _ => break,
        }
    }

    // 4. The plan checker on devices built from the rest: address, group, sync id (2), target,
    //    object id (2), object kind/len.
    let mut devices = Vec::new();
    for (i, c) in data.get(12..).unwrap_or(&[]).chunks(8).take(8).enumerate() {
        let b = |k: usize| c.get(k).copied().unwrap_or(0);
        let addr = Address::new(b(0) & 0x3F).unwrap();
        let group = Address::new(b(1) & 0x3F).unwrap();
        let mut d = if b(0) & 0x80 != 0 {
            Device {
                name: format!("node {i}"),
                ..Device::default()
            }
        } else {
            Device::slave(
                format!("node {i}"),
                SlaveIds {
                    address: addr,
                    group,
                    sync_id: u16::from_be_bytes([b(2), b(3)]) & 0x7FF,
                },
            )
        };
        let t = Address::new(b(4) & 0x3F).unwrap();
        match b(4) >> 6 {
            0 => {}
            1 => d.master_of.push(Target::Address(t)),
            2 => d.master_of.push(Target::Group(t)),
            _ => d.sends_sync = Some(u16::from_be_bytes([b(2), b(3)])),
        }
        let kind = match b(7) & 3 {
            0 => ObjectKind::Receive,
            1 => ObjectKind::Acyclic,
            _ => ObjectKind::Cyclic {
                cycle_ms: u32::from(b(7) >> 2),
                offset_ms: u32::from(b(1)),
            },
        };
        d.objects.push(Object {
            id: u16::from_be_bytes([b(5), b(6)]),
            len: u32::from(b(7) >> 2),
            kind,
        });
        let _ = d.movilink_uses();
        let _ = d.check_objects();
        devices.push(d);
    }
    let plan = Plan {
        bitrate: Bitrate::K250,
        devices,
    };
    for v in plan.check() {
        let _ = v.to_string();
    }
    for i in 0..=plan.devices.len() {
        let _ = plan.forbidden(i);
    }
});
