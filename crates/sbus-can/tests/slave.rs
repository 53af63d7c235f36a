//! The sans-IO SBus slave (`sbus_can::slave`) against a recording backend: the manual's
//! vectors, the timing rules of ch. 5.1/5.2 and what is never answered.

// Test code: helpers outside `#[test]` fns (not exempted by clippy.toml) panic by design.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

use std::time::Duration;

use drive_core::Instant;
use drive_core::can::{CanFrame, ExtendedId, Frame, StandardId};
use drive_profile::sew::{ParamChannel, ReturnCode, Service};
use proptest::prelude::*;
use sbus_can::Address;
use sbus_can::slave::{Backend, Rejection, Slave, SlaveConfig};
use sbus_can::telegram::ProcessData;

/// Records what the slave hands over; answers like the manual's ch. 5.3 example.
#[derive(Debug, Default)]
struct Recorder {
    params: Vec<(ParamChannel, Instant)>,
    po: Vec<(ProcessData, Instant)>,
    gpo: Vec<(ProcessData, Instant)>,
    syncs: Vec<Instant>,
}

impl Backend for Recorder {
    fn param(&mut self, request: &ParamChannel, now: Instant) -> Result<u32, ReturnCode> {
        self.params.push((*request, now));
        match (request.service(), request.index) {
            // P000 speed: 1000.000 1/min (manual ch. 5.3, Mld.ReadPar = 1000000)
            (Some(Service::Read), 8318) => Ok(1_000_000),
            (Some(s), _) if s.is_write() => Ok(0),
            _ => Err(ReturnCode::ILLEGAL_INDEX),
        }
    }

    fn process_data(&mut self, output: ProcessData, now: Instant) -> ProcessData {
        self.po.push((output, now));
        // Manual ch. 5.3: PI1 = 7 (status word 1), PI2 = 5011 (1002.2 1/min), PI3 = 0
        ProcessData([7, 5011, 0])
    }

    fn group_process_data(&mut self, output: ProcessData, now: Instant) {
        self.gpo.push((output, now));
    }

    fn sync(&mut self, now: Instant) {
        self.syncs.push(now);
    }
}

fn ms(v: f64) -> Instant {
    Instant::from_nanos((v * 1e6).round() as u64)
}

fn a(n: u8) -> Address {
    Address::new(n).unwrap()
}

fn slave(address: u8) -> Slave<Recorder> {
    let mut c = SlaveConfig::new(a(address));
    c.group = a(2);
    Slave::new(c, Recorder::default())
}

fn frame(id: u16, data: &[u8]) -> CanFrame {
    CanFrame::standard(id, data).unwrap()
}

fn sync() -> CanFrame {
    frame(0, &[])
}

fn drain(s: &mut Slave<Recorder>, now: Instant) -> Vec<CanFrame> {
    std::iter::from_fn(|| s.poll_transmit(now)).collect()
}

/// Manual ch. 5.3: read of index 8318 at SBus address 1 (request 523, response 524) answered
/// with 1 000 000 = 1000.000 1/min; answered at once (handshake bit 0).
#[test]
fn manual_5_3_read_8318_answered_at_once() {
    let mut s = slave(1);
    // 31h: read, 4 bytes, handshake 0; 00 reserved; 207Eh = 8318; data 0
    s.handle_frame(&frame(523, &[0x31, 0x00, 0x20, 0x7E, 0, 0, 0, 0]), ms(1.0));
    let out = drain(&mut s, ms(1.0));
    // 524: same management, index; data 000F4240h = 1 000 000
    assert_eq!(
        out,
        [frame(
            524,
            &[0x31, 0x00, 0x20, 0x7E, 0x00, 0x0F, 0x42, 0x40]
        )]
    );
    assert_eq!(s.tally().taken(), 1);
}

/// Manual ch. 5.3: PO 6 / 5000 / 15000 to address 1 (identifier 11) answered on 12 with the
/// drive's PI (7 / 5011 / 0), within the response delay.
#[test]
fn async_po_answered_with_pi_after_the_response_delay() {
    let mut s = slave(1);
    let mut c = *s.config();
    c.response_delay = Duration::from_micros(300);
    s.set_config(c);
    s.handle_frame(&frame(11, &[0x00, 0x06, 0x13, 0x88, 0x3A, 0x98]), ms(10.0));
    assert_eq!(s.backend().po, [(ProcessData([6, 5000, 15000]), ms(10.0))]);
    assert_eq!(s.poll_timeout(), Some(ms(10.3)));
    assert!(drain(&mut s, ms(10.299)).is_empty());
    assert_eq!(
        drain(&mut s, ms(10.3)),
        [frame(12, &[0x00, 0x07, 0x13, 0x93, 0, 0])]
    );
    assert_eq!(s.poll_timeout(), None);
    // A delay past the manual's 1 ms is clamped to it.
    c.response_delay = Duration::from_millis(7);
    s.set_config(c);
    s.handle_frame(&frame(11, &[0; 6]), ms(20.0));
    assert_eq!(s.poll_timeout(), Some(ms(21.0)));
}

/// Bild 32 (WRITE-SYNC): the service runs when the request arrives, process data go on being
/// answered, the response leaves only after the next SYNC, in its first millisecond.
#[test]
fn write_sync_executes_at_once_and_answers_after_the_sync() {
    let mut s = slave(1);
    // SYNC at 0 ms, the write-sync request (72h: write volatile + handshake) at 2 ms
    s.handle_frame(&sync(), ms(0.0));
    let req = ParamChannel::write_volatile(8470, 1500).with_handshake(true);
    s.handle_frame(&frame(523, &req.to_bytes()), ms(2.0));
    assert_eq!(s.backend().params, [(req, ms(2.0))]);
    // PO still answered at once meanwhile
    s.handle_frame(&frame(11, &[0, 6, 0, 0, 0, 0]), ms(3.0));
    assert_eq!(
        drain(&mut s, ms(3.0))
            .iter()
            .map(CanFrame::raw_id)
            .collect::<Vec<_>>(),
        [12]
    );
    assert!(drain(&mut s, ms(4.9)).is_empty());
    assert_eq!(s.poll_timeout(), None);
    s.handle_frame(&sync(), ms(5.0));
    let out = drain(&mut s, ms(5.0));
    assert_eq!(out, [frame(524, &req.answer(Ok(0)).to_bytes())]);
    assert_eq!(out[0].data()[0], 0x73, "handshake bit echoed");
    // Exactly once.
    s.handle_frame(&sync(), ms(10.0));
    assert!(drain(&mut s, ms(10.0)).is_empty());
}

/// The PO sync window: "frühestens 500 ms nach der 2. Millisekunde und spätestens 500 ms vor
/// der 1. Millisekunde" is in µs (a 5 ms cycle has no 500 ms): 2.5 … 4.5 ms after the SYNC
/// (erratum SB-E30). Outside it, and before any SYNC, the PO sync is dropped and counted.
#[test]
fn po_sync_window_is_2_5_to_4_5_ms_after_sync_sb_e30() {
    let po = |s: &mut Slave<Recorder>, w: u16, t: f64| {
        s.handle_frame(&frame(13, &ProcessData([w, 0, 0]).to_bytes()), ms(t));
    };
    let mut s = slave(1);
    po(&mut s, 1, 1.0); // no SYNC yet
    assert_eq!(s.tally().rejected(Rejection::OutsideSyncWindow), 1);
    s.handle_frame(&sync(), ms(5.0));
    for (t, taken) in [(7.499, false), (7.5, true), (9.5, true), (9.501, false)] {
        let before = s.tally().rejected(Rejection::OutsideSyncWindow);
        po(&mut s, 2, t);
        assert_eq!(
            s.tally().rejected(Rejection::OutsideSyncWindow) == before,
            taken,
            "at {t} ms"
        );
    }
    // Taken at the SYNC, answered then; a later PO sync replaced the earlier one.
    assert!(s.backend().po.is_empty());
    assert!(drain(&mut s, ms(9.9)).is_empty());
    s.handle_frame(&sync(), ms(10.0));
    assert_eq!(s.backend().po, [(ProcessData([2, 0, 0]), ms(10.0))]);
    assert_eq!(
        drain(&mut s, ms(10.0)),
        [frame(12, &[0, 7, 0x13, 0x93, 0, 0])]
    );
    // With the window off, any time after a SYNC is taken.
    let mut c = *s.config();
    c.po_sync_window = None;
    s.set_config(c);
    po(&mut s, 3, 10.1);
    assert_eq!(s.tally().rejected(Rejection::OutsideSyncWindow), 3);
}

/// Ch. 5.2 special case: a wrong coding of the management byte is answered with class 5,
/// code 5, additional code 0, without the drive: an undefined service code, a write with a
/// data length other than 4 bytes, the status bit in a request.
#[test]
fn wrong_management_byte_is_class_5_code_5() {
    for (m, answer) in [(0x39u8, 0xB9u8), (0x02, 0x82), (0x22, 0xA2), (0xB1, 0xB1)] {
        let mut s = slave(7);
        s.handle_frame(
            &frame(8 * 7 + 515, &[m, 0, 0x20, 0x7E, 0, 0, 0, 0]),
            ms(0.0),
        );
        // 0x0505_0000: class 5 (service), code 5 (illegal value), additional 0
        assert_eq!(
            drain(&mut s, ms(0.0)),
            [frame(8 * 7 + 516, &[answer, 0, 0x20, 0x7E, 5, 5, 0, 0])],
            "management {m:02X}h"
        );
        assert!(s.backend().params.is_empty());
    }
    // A read with another data length is no wrong coding (reads carry no data).
    let mut s = slave(7);
    s.handle_frame(
        &frame(8 * 7 + 515, &[0x01, 0, 0x20, 0x7E, 0, 0, 0, 0]),
        ms(0.0),
    );
    assert_eq!(
        drain(&mut s, ms(0.0))[0].data(),
        &[0x01, 0, 0x20, 0x7E, 0, 0x0F, 0x42, 0x40]
    );
    // "No service" is echoed without the drive.
    s.handle_frame(&frame(8 * 7 + 515, &[0x30, 0, 0, 0, 0, 0, 0, 0]), ms(1.0));
    assert_eq!(
        drain(&mut s, ms(1.0))[0].data(),
        &[0x30, 0, 0, 0, 0, 0, 0, 0]
    );
    assert_eq!(s.backend().params.len(), 1);
}

/// Group telegrams (group 2: GPO 22, group parameter request 534) are taken and never
/// answered; a group parameter request with a read is ignored.
#[test]
fn group_telegrams_are_never_answered() {
    let mut s = slave(1);
    s.handle_frame(&frame(22, &[0, 6, 0x13, 0x88, 0, 0]), ms(0.0));
    let write = ParamChannel::write_volatile(8470, 1000);
    s.handle_frame(&frame(534, &write.to_bytes()), ms(1.0));
    s.handle_frame(&frame(534, &ParamChannel::read(8318).to_bytes()), ms(2.0));
    assert!(drain(&mut s, ms(10.0)).is_empty());
    assert_eq!(s.poll_timeout(), None);
    assert_eq!(s.backend().gpo, [(ProcessData([6, 5000, 0]), ms(0.0))]);
    assert_eq!(s.backend().params, [(write, ms(1.0))]);
    assert_eq!(s.tally().rejected(Rejection::GroupNotWrite), 1);
    // Another group: not taken.
    s.handle_frame(&frame(30, &[0; 6]), ms(3.0));
    assert_eq!(s.tally().rejected(Rejection::OtherAddress), 1);
    // A master-slave master takes no group telegrams (ch. 5.4).
    let mut c = *s.config();
    c.group_telegrams = false;
    s.set_config(c);
    s.handle_frame(&frame(22, &[0; 6]), ms(4.0));
    s.handle_frame(&frame(534, &write.to_bytes()), ms(5.0));
    assert_eq!(s.tally().rejected(Rejection::GroupToMaster), 2);
    assert_eq!(s.backend().gpo.len(), 1);
}

/// Decision: one answer in flight. A new request while a synchronised answer waits for its
/// SYNC drops that answer; only the new request is answered.
#[test]
fn new_request_supersedes_a_waiting_sync_answer() {
    let mut s = slave(1);
    s.handle_frame(&sync(), ms(0.0));
    let first = ParamChannel::read(8318).with_handshake(true);
    s.handle_frame(&frame(523, &first.to_bytes()), ms(1.0));
    let second = ParamChannel::read(8318);
    s.handle_frame(&frame(523, &second.to_bytes()), ms(2.0));
    assert_eq!(
        drain(&mut s, ms(2.0)),
        [frame(524, &second.answer(Ok(1_000_000)).to_bytes())]
    );
    s.handle_frame(&sync(), ms(5.0));
    assert!(drain(&mut s, ms(5.0)).is_empty());
    assert_eq!(s.tally().rejected(Rejection::Superseded), 1);
}

/// Frames not for the drive are ignored and counted by reason, never answered.
#[test]
fn foreign_frames_are_counted_by_reason() {
    let mut s = slave(1);
    let cases: [(CanFrame, Rejection); 7] = [
        (frame(8 * 5 + 3, &[0; 6]), Rejection::OtherAddress),
        (frame(12, &[0; 6]), Rejection::FromDrive),
        (frame(524, &[0; 8]), Rejection::FromDrive),
        (frame(1024 + 11, &[0; 6]), Rejection::NotSbus),
        (frame(11, &[0; 5]), Rejection::Length),
        (
            CanFrame::remote_frame(StandardId::new(11).unwrap(), 6).unwrap(),
            Rejection::Remote,
        ),
        (
            CanFrame::data_frame(ExtendedId::new(11).unwrap(), &[0; 6]).unwrap(),
            Rejection::ExtendedId,
        ),
    ];
    for (i, (f, reason)) in cases.iter().enumerate() {
        s.handle_frame(f, ms(i as f64));
        assert!(s.tally().rejected(*reason) >= 1, "{f}");
    }
    assert_eq!(s.tally().rejected_total(), 7);
    assert_eq!(s.tally().taken(), 0);
    assert!(drain(&mut s, ms(100.0)).is_empty());
}

/// P813/P817 written: the slave follows its new identifiers.
#[test]
fn identifiers_follow_the_configuration() {
    let mut s = slave(1);
    let mut c = *s.config();
    c.address = a(33);
    c.sync_id = 1;
    s.set_config(c);
    s.handle_frame(&frame(11, &[0; 6]), ms(0.0));
    assert_eq!(s.tally().rejected(Rejection::OtherAddress), 1);
    s.handle_frame(&frame(267, &[0; 6]), ms(1.0));
    assert_eq!(drain(&mut s, ms(1.0))[0].raw_id(), 268);
    s.handle_frame(&frame(1, &[]), ms(2.0));
    assert_eq!(s.backend().syncs, [ms(2.0)]);
    s.handle_frame(&sync(), ms(3.0)); // identifier 0 is no longer SYNC
    assert_eq!(s.backend().syncs.len(), 1);
}

proptest! {
    /// Whatever arrives: no panic, and the drive only ever sends its own PI and parameter
    /// response.
    #[test]
    fn any_frame_is_safe(frames in proptest::collection::vec((0u16..2048, proptest::collection::vec(any::<u8>(), 0..=8), 0u64..10_000), 0..40)) {
        let mut s = slave(5);
        let mut t = 0;
        for (id, data, dt) in frames {
            t += dt;
            s.handle_frame(&frame(id, &data), Instant::from_micros(t));
            s.handle_timeout(Instant::from_micros(t));
            while let Some(f) = s.poll_transmit(Instant::from_micros(t + 1000)) {
                prop_assert!(f.raw_id() == 8 * 5 + 4 || f.raw_id() == 8 * 5 + 516, "{}", f);
            }
        }
    }
}
