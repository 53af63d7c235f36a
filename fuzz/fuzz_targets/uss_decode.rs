//! Fuzz the USS serial telegram codec, the character receiver with USS framing (both sides)
//! and the USS master and slave state machines fed with the same characters.
//!
//! Input: byte 0 picks the layout (`b % 3` → 0, 3 or 4 PKW words; `(b >> 2) % 17` PZD words);
//! the rest is read twice: (1) as one telegram for `Telegram::decode` (never panics; what it
//! accepts re-encodes to the same bytes), (2) as pairs (character, code) for the receivers,
//! where `code >> 6` is the UART status (0 parity error, 1 framing error, 2 or 3 none) and
//! `code & 0x3F` the idle time before the character in quarter character times (19200 8E1).
//! A telegram built from the bytes also makes an encode → decode round trip.
//!
//! `cargo fuzz run uss_decode` (from the `fuzz/` folder), or `scripts/fuzz`.
#![no_main]

use ctt2_uss::serial::framing::{Side, UssFraming, UssReceiver};
use ctt2_uss::serial::master::{UssMaster, MasterConfig};
use ctt2_uss::serial::slave::{Backend, Slave, SlaveConfig};
use ctt2_uss::serial::telegram::{Adr, Layout, MAX_TELEGRAM, Telegram, UssAddress};
use ctt2_uss::uss::pkw::{Order, Pkw, Reply};
use drive_core::{CharError, Endpoint, Instant, LineSettings, RxChar};
use libfuzzer_sys::fuzz_target;

/// A drive that answers every order through the typed order and answer codecs.
struct Echo;

impl Backend for Echo {
    fn execute(&mut self, order: &Pkw, _now: Instant) -> Pkw {
        let reply = match Order::from_pkw(order) {
            Ok(o) => match o.kind() {
                ctt2_uss::uss::OrderKind::Count => Reply::Count(3),
                _ => Reply::None,
            },
            Err(_) => Reply::Error(ctt2_uss::uss::DriveError(201)),
        };
        reply.to_pkw(order.pke.pnu(), order.ind)
    }

    fn process(&mut self, request: &[u16], answer: &mut [u16], _now: Instant) {
        for (a, r) in answer.iter_mut().zip(request) {
            *a = !*r;
        }
    }
}

impl drive_core::Timers for Echo {}

fuzz_target!(|data: &[u8]| {
    let Some((&pick, rest)) = data.split_first() else {
        return;
    };
    let Ok(layout) = Layout::new([0, 3, 4][usize::from(pick % 3)], (pick >> 2) % 17) else {
        return;
    };

    // 1. The decoder: never panics; whatever it accepts re-encodes to the same bytes.
    if let Ok(t) = Telegram::decode(rest, layout) {
        let mut buf = [0u8; MAX_TELEGRAM];
        let n = t.encode(&mut buf).expect("a decoded telegram fits the maximum length");
        assert_eq!(&buf[..n], rest);
        assert_eq!(t.layout(), layout);
    }
    let _ = Telegram::announced_len(rest);

    // 2. A telegram made of the bytes: encode → decode gives it back.
    let word = |i: usize| {
        u16::from_be_bytes([
            rest.get(2 * i).copied().unwrap_or(0),
            rest.get(2 * i + 1).copied().unwrap_or(0),
        ])
    };
    let mut pkw = Pkw::from_words([word(0), word(1), word(2), word(3)]);
    if layout.pkw_words() == 3 {
        pkw.pwe1 = if pkw.pwe2 & 0x8000 != 0 { 0xFFFF } else { 0 };
    }
    let pzd: Vec<u16> = (0..usize::from(layout.pzd_words())).map(|i| word(4 + i)).collect();
    let t = Telegram::new(Adr(rest.first().copied().unwrap_or(0)), layout, pkw, &pzd)
        .expect("a consistent telegram");
    let mut buf = [0u8; MAX_TELEGRAM];
    let n = t.encode(&mut buf).expect("fits");
    assert_eq!(Telegram::decode(&buf[..n], layout), Ok(t));

    // 3. Receivers and state machines: never panic, whatever arrives and whenever.
    let line = LineSettings::new(19200);
    let own = UssAddress::new(1).unwrap_or_default();
    let mut rx_slave = UssReceiver::new(UssFraming::new(Side::Slave(own), layout, &line));
    let mut rx_master = UssReceiver::new(UssFraming::new(Side::Master, layout, &line));
    let mut master = UssMaster::new(MasterConfig::new(line));
    let mut slave = Slave::new(SlaveConfig::new(own, layout, line), Echo);
    let request = Telegram::new(Adr::new(own), layout, Pkw::default(), &pzd).expect("request");
    let _ = master.send(request, Instant::ZERO);
    let _ = master.poll_transmit(Instant::ZERO, &mut buf);
    let ct = line.char_time().as_nanos() as u64;
    let mut t = 0u64;
    for pair in rest.chunks(2) {
        let byte = pair.first().copied().unwrap_or(0);
        let code = pair.get(1).copied().unwrap_or(0);
        t += ct + u64::from(code & 0x3F) * ct / 4;
        let time = Instant::from_nanos(t);
        let c = match code >> 6 {
            0 => RxChar::with_error(byte, time, CharError::Parity),
            1 => RxChar::with_error(byte, time, CharError::Framing),
            _ => RxChar::new(byte, time),
        };
        for rx in [&mut rx_slave, &mut rx_master] {
            let _ = rx.handle_char(c);
            if let Some(at) = rx.poll_timeout().filter(|at| *at <= time) {
                let _ = rx.handle_timeout(at);
            }
        }
        master.handle_char(c);
        slave.handle_char(c);
        if let Some(at) = master.poll_timeout().filter(|at| *at <= time) {
            master.handle_timeout(at);
        }
        if let Some(at) = slave.poll_timeout().filter(|at| *at <= time) {
            slave.handle_timeout(at);
        }
        let _ = master.poll_transmit(time, &mut buf);
        let _ = slave.poll_transmit(time, &mut buf);
        while master.poll_event().is_some() {}
        while slave.poll_event().is_some() {}
    }
    let end = Instant::from_nanos(t + 100_000_000);
    master.handle_timeout(end);
    slave.handle_timeout(end);
});
