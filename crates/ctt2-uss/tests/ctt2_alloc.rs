//! CTT2 encode, decode and the sans-IO double slave do not allocate: a counting global
//! allocator sees no allocation while they run (it counts the test thread's allocations only).

#![allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)]

use drive_core::alloc_count::CountingAllocator;
use std::time::Duration;

use ctt2_uss::ctt2::{
    Backend, Channel, Data, DiagnosisCode, DiagnosisObject, DoubleSlave, IdObject, MAX_REQUEST,
    MAX_RESPONSE, Request, Response, SlaveConfig, StandardIndex,
};
use ctt2_uss::uss::{Ind, Order, PzdIn, PzdOut, Reply, Storage};
use drive_core::Instant;
use drive_profile::nord::{ControlWord, StatusWord, Width};

#[global_allocator]
static GLOBAL: CountingAllocator = CountingAllocator;

/// A drive that answers at once and echoes what it is told.
struct Echo {
    control: u16,
}

impl Backend for Echo {
    fn id_object(&mut self, _now: Instant) -> IdObject {
        IdObject::from_bytes(&[1, 137, 0, 0, 7, 0, 0, 0, 0, 0, 0, 0, 0, 0])
    }

    fn diagnosis(&mut self, _now: Instant) -> DiagnosisObject {
        DiagnosisObject::new(DiagnosisCode::NoFault, 0, 45)
    }

    fn process(&mut self, out: PzdOut, _now: Instant) -> PzdIn {
        self.control = out.control().0;
        PzdIn::new(StatusWord(0x0B31), &[1, 2, 3])
    }

    fn process_data(&mut self, _now: Instant) -> PzdIn {
        PzdIn::new(StatusWord(0x0B31), &[1, 2, 3])
    }

    fn execute(&mut self, order: Order, _now: Instant) -> Reply {
        Reply::Value {
            width: Width::Word,
            array: true,
            value: i32::from(order.pnu()),
        }
    }

    fn pkw_time(&self, _order: &Order) -> Duration {
        Duration::from_millis(30)
    }
}

#[test]
fn nothing_allocates() {
    let order = Order::write(
        0x66,
        Ind::new(0, 2).unwrap(),
        Width::Word,
        true,
        Storage::Eeprom,
        1000,
    )
    .unwrap();
    let mut slave = DoubleSlave::new(Echo { control: 0 }, SlaveConfig::default());
    let before = CountingAllocator::count();

    let requests = [
        Request::StandardRead {
            index: StandardIndex::Id,
            len: 14,
        },
        Request::StandardRead {
            index: StandardIndex::Diagnosis,
            len: 3,
        },
        Request::NordWrite {
            index: Channel::Pkw,
            data: Data::from_pkw(Channel::Pkw, &order.to_pkw()).unwrap(),
        },
        Request::NordRead {
            index: Channel::PkwWithAddress,
            len: 9,
        },
        Request::NordWriteRead {
            index: Channel::Pzd,
            read_len: 9,
            data: Data::from_pzd_out(&PzdOut::new(ControlWord(0x047F), &[0x2000])),
        },
    ];
    let mut t = 0u64;
    let mut answers = 0;
    for _ in 0..3 {
        for r in &requests {
            let mut req = [0u8; MAX_REQUEST];
            let n = r.encode(&mut req).unwrap();
            assert_eq!(Request::decode(&req[..n]).unwrap(), *r);
            t += 20_000_000;
            slave.handle_request(&req[..n], Instant::from_nanos(t));
            // A second request too early: error 5.
            slave.handle_request(&req[..n], Instant::from_nanos(t));
            while let Some(due) = slave.poll_timeout() {
                if let Some(a) = slave.poll_answer(due) {
                    let mut buf = [0u8; MAX_RESPONSE];
                    let m = a.encode(&mut buf).unwrap();
                    let back = Response::decode(&buf[..m]).unwrap();
                    assert_eq!(back, a);
                    if let Response::Ok { data, .. } = back {
                        let _ = IdObject::decode(data.as_slice());
                        let _ = data.to_pzd_in();
                        let _ = data.to_pkw(Channel::PkwWithAddress);
                    }
                    answers += 1;
                }
                t = t.max(due.as_nanos());
            }
        }
    }
    let _ = Request::decode(&[17, 0, 3]).unwrap_err().answer();
    let _ = Response::decode(&[177, 2]).unwrap();

    let after = CountingAllocator::count();
    assert_eq!(
        answers, 30,
        "every request answered (5 × 3, each with an error 5)"
    );
    assert_eq!(slave.backend().control, 0x047F);
    assert_eq!(slave.pkw_answer().words(), [0x4066, 0x0200, 0, 0x66]);
    assert_eq!(
        after - before,
        0,
        "allocations during CTT2 encode/decode/slave"
    );
}
