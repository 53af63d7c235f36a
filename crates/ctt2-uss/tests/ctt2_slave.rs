//! The sans-IO double slave on manual `Instant`s: the answer window, error 5 and the order of
//! answers, the parameter channel's previous answer, replaced orders, AK 0, reads truncated
//! to what was asked and to the object.

#![allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)]

use std::time::Duration;

use ctt2_uss::ctt2::{
    Backend, Channel, Data, DiagnosisCode, DiagnosisObject, DoubleSlave, ErrorCode, IdObject,
    MAX_REQUEST, Request, Response, SlaveConfig,
};
use ctt2_uss::uss::{Ind, Order, PzdIn, PzdOut, Reply};
use drive_core::Instant;
use drive_profile::nord::{Ctt2MessageType, StatusWord, Width};

struct Drive {
    answer: Duration,
    pkw: Duration,
    executed: Vec<(u16, u64)>,
}

impl Backend for Drive {
    fn id_object(&mut self, _now: Instant) -> IdObject {
        IdObject::from_bytes(&[1, 137, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13])
    }

    fn diagnosis(&mut self, _now: Instant) -> DiagnosisObject {
        DiagnosisObject::new(DiagnosisCode::Fault, 9, 50)
    }

    fn process(&mut self, _out: PzdOut, _now: Instant) -> PzdIn {
        PzdIn::new(StatusWord(0x0B37), &[0x2000, 2, 3])
    }

    fn process_data(&mut self, _now: Instant) -> PzdIn {
        PzdIn::new(StatusWord(0x0B31), &[1, 2, 3])
    }

    fn execute(&mut self, order: Order, now: Instant) -> Reply {
        self.executed.push((order.pnu(), now.as_micros() / 1000));
        Reply::Value {
            width: Width::Word,
            array: false,
            value: 7,
        }
    }

    fn pkw_time(&self, _order: &Order) -> Duration {
        self.pkw
    }

    fn answer_time(&self, _request: &Request) -> Duration {
        self.answer
    }
}

fn slave(answer_ms: u64, pkw_ms: u64) -> DoubleSlave<Drive> {
    DoubleSlave::new(
        Drive {
            answer: Duration::from_millis(answer_ms),
            pkw: Duration::from_millis(pkw_ms),
            executed: Vec::new(),
        },
        SlaveConfig::default(),
    )
}

fn t(ms: u64) -> Instant {
    Instant::from_millis(ms)
}

fn bytes(r: &Request) -> Vec<u8> {
    let mut b = [0u8; MAX_REQUEST];
    let n = r.encode(&mut b).unwrap();
    b[..n].to_vec()
}

fn pkw_write(pnu: u16) -> Vec<u8> {
    let order = Order::read(pnu, Ind::ZERO).unwrap();
    bytes(&Request::NordWrite {
        index: Channel::Pkw,
        data: Data::from_pkw(Channel::Pkw, &order.to_pkw()).unwrap(),
    })
}

/// The answer begins `answer_time` after the request; a drive slower than the window gets
/// error 4 exactly when the window ends.
#[test]
fn answer_window() {
    let mut s = slave(120, 0);
    s.handle_request(&[16, 1, 3], t(1000));
    assert!(s.is_busy());
    assert_eq!(s.poll_timeout(), Some(t(1120)));
    assert_eq!(s.poll_answer(t(1119)), None);
    assert_eq!(
        s.poll_answer(t(1120)),
        Some(Response::Ok {
            kind: Ctt2MessageType::StandardRead,
            data: Data::new(&[255, 9, 50]).unwrap()
        })
    );
    assert!(!s.is_busy());

    let mut s = slave(201, 0);
    s.handle_request(&[18, 3, 9], t(0));
    assert_eq!(s.poll_timeout(), Some(t(200)));
    assert_eq!(
        s.poll_answer(t(200)),
        Some(Response::error(Ctt2MessageType::NordRead, ErrorCode::Busy))
    );
    assert_eq!(s.counters().errors[3], 1);
}

/// Error 5 is answered at once; the first request keeps its answer, which follows.
#[test]
fn error_5_then_the_first_answer() {
    let mut s = slave(100, 0);
    s.handle_request(&[18, 3, 3], t(0));
    s.handle_request(&[16, 0, 14], t(30));
    s.handle_request(&[16, 0, 14], t(40)); // a third one replaces the second's error 5
    assert_eq!(
        s.poll_answer(t(40)),
        Some(Response::error(
            Ctt2MessageType::StandardRead,
            ErrorCode::PreviousPending
        ))
    );
    assert_eq!(s.poll_answer(t(99)), None);
    assert_eq!(
        s.poll_answer(t(100)),
        Some(Response::Ok {
            kind: Ctt2MessageType::NordRead,
            data: Data::new(&[1, 0x0B, 0x31]).unwrap()
        })
    );
    assert_eq!(s.poll_timeout(), None);
    assert_eq!(s.counters().requests, 3);
    assert_eq!(s.counters().answers, 2);
}

/// Reads: shorter than the object → only that; longer → only the object (section 4.3.5).
#[test]
fn read_lengths() {
    let mut s = slave(0, 0);
    let mut read = |r: &[u8]| {
        s.handle_request(r, t(0));
        match s.poll_answer(t(0)).unwrap() {
            Response::Ok { data, .. } => data.as_slice().to_vec(),
            other => panic!("{other:?}"),
        }
    };
    assert_eq!(read(&[16, 0, 2]), [1, 137]);
    assert_eq!(read(&[16, 0, 255]).len(), 14);
    assert_eq!(read(&[16, 1, 200]), [255, 9, 50]);
    assert_eq!(read(&[18, 3, 0]), Vec::<u8>::new());
    assert_eq!(read(&[18, 3, 4]), [1, 0x0B, 0x31, 0]);
    assert_eq!(read(&[18, 3, 50]).len(), 9);
    assert_eq!(read(&[18, 47, 50]).len(), 8);
    assert_eq!(read(&[18, 4, 50]).len(), 9);
    // Write/read on PZD returns the status after the write.
    assert_eq!(
        read(&[29, 3, 5, 3, 1, 0x04, 0x7F]),
        [1, 0x0B, 0x37, 0x20, 0x00]
    );
}

/// The parameter channel: error 9 before any order, the previous answer while the drive works,
/// a newer order replaces an unfinished one, AK 0 is answered at once.
#[test]
fn parameter_channel() {
    let mut s = slave(0, 100);
    assert_eq!(s.pkw_answer().words(), [0x7000, 0, 0, 9]);
    s.handle_request(&pkw_write(102), t(0));
    assert_eq!(
        s.poll_answer(t(0)),
        Some(Response::Ok {
            kind: Ctt2MessageType::NordWrite,
            data: Data::EMPTY
        })
    );
    assert!(s.is_working());
    assert_eq!(s.poll_timeout(), Some(t(100)));
    s.handle_request(&[18, 47, 8], t(50));
    let Some(Response::Ok { data, .. }) = s.poll_answer(t(50)) else {
        panic!()
    };
    assert_eq!(
        data.to_pkw(Channel::Pkw).unwrap().words(),
        [0x7000, 0, 0, 9]
    );
    // A newer order at 60 ms replaces P102; it is done at 160 ms.
    s.handle_request(&pkw_write(105), t(60));
    let _ = s.poll_answer(t(60));
    s.handle_timeout(t(159));
    assert!(s.is_working());
    s.handle_timeout(t(160));
    assert!(!s.is_working());
    assert_eq!(s.backend().executed, [(105, 160)]);
    assert_eq!(s.pkw_answer().words(), [0x1069, 0, 0, 7]);
    // AK 0 ("no order") is answered at once with AK 0.
    s.handle_request(&[19, 47, 8, 0, 0, 0, 0, 0, 0, 0, 0], t(200));
    let _ = s.poll_answer(t(200));
    assert_eq!(s.pkw_answer().words(), [0, 0, 0, 0]);
    assert_eq!(s.counters().orders, 1);
}
