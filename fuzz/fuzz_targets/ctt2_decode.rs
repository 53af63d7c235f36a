//! Fuzz the CTT2 decoders (requests, answers, the ID and diagnosis objects, PKW/PZD channel
//! data) and the sans-IO double slave fed with the same bytes.
//!
//! Whatever a decoder accepts re-encodes to the same bytes; a request it refuses has a
//! negative answer of two bytes. Seeds (`fuzz/seeds/ctt2_decode/`): the manual's examples of
//! sections 4.3.1 to 4.3.5 and 5.1 as CTT2 messages, and the misprinted answer code 177.
//!
//! `cargo fuzz run ctt2_decode` (from the `fuzz/` folder), or `scripts/fuzz`.
#![no_main]

use core::time::Duration;

use ctt2_uss::ctt2::{
    Backend, Channel, Data, DiagnosisCode, DiagnosisObject, DoubleSlave, IdObject, MAX_RESPONSE,
    Request, Response, SlaveConfig,
};
use ctt2_uss::uss::{Order, PzdIn, PzdOut, Reply};
use drive_core::Instant;
use drive_profile::nord::{StatusWord, Width};
use libfuzzer_sys::fuzz_target;

/// A drive that answers after a delay the input chooses.
struct Echo(u8);

impl Backend for Echo {
    fn id_object(&mut self, _now: Instant) -> IdObject {
        IdObject::from_bytes(&[1, 137, 0, 0, 7, 0, 0, 0, 0, 0, 0, 0, 0, 0])
    }

    fn diagnosis(&mut self, _now: Instant) -> DiagnosisObject {
        DiagnosisObject::new(DiagnosisCode::NoFault, 0, 45)
    }

    fn process(&mut self, out: PzdOut, _now: Instant) -> PzdIn {
        PzdIn::new(StatusWord(out.control().0), out.setpoints())
    }

    fn process_data(&mut self, _now: Instant) -> PzdIn {
        PzdIn::new(StatusWord(0x0B70), &[0, 0, 0])
    }

    fn execute(&mut self, order: Order, _now: Instant) -> Reply {
        Reply::Value {
            width: Width::Word,
            array: false,
            value: i32::from(order.pnu()),
        }
    }

    fn pkw_time(&self, _order: &Order) -> Duration {
        Duration::from_millis(u64::from(self.0))
    }

    fn answer_time(&self, _request: &Request) -> Duration {
        Duration::from_millis(u64::from(self.0) * 2)
    }
}

fuzz_target!(|data: &[u8]| {
    let mut buf = [0u8; 64];
    match Request::decode(data) {
        Ok(r) => {
            let n = r.encode(&mut buf).expect("a decoded request encodes");
            assert_eq!(&buf[..n], data);
        }
        Err(e) => {
            let n = e.answer().encode(&mut buf).expect("a negative answer encodes");
            assert_eq!(n, 2);
        }
    }
    if let Ok(r) = Response::decode(data) {
        let n = r.encode(&mut buf).expect("a decoded answer encodes");
        assert_eq!(&buf[..n], data);
    }
    let _ = IdObject::decode(data);
    let _ = DiagnosisObject::decode(data);
    if let Some(d) = Data::new(data) {
        let _ = d.to_pzd_in();
        let _ = d.to_pzd_out();
        let _ = d.to_pkw(Channel::Pkw);
        let _ = d.to_pkw(Channel::PkwWithAddress);
    }

    // The double slave: the input split at 0xFF bytes into requests, 30 ms apart.
    let mut slave = DoubleSlave::new(Echo(data.first().copied().unwrap_or(0)), SlaveConfig::default());
    let mut t = Instant::ZERO;
    for request in data.split(|b| *b == 0xFF) {
        t = t.saturating_add(Duration::from_millis(30));
        slave.handle_request(request, t);
        while let Some(a) = slave.poll_answer(t) {
            let mut out = [0u8; MAX_RESPONSE];
            let n = a.encode(&mut out).expect("the slave's answers encode");
            assert_eq!(Response::decode(&out[..n]), Ok(a));
        }
    }
    while let Some(due) = slave.poll_timeout() {
        let _ = slave.poll_answer(due);
    }
});
