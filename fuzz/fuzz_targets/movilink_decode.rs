//! Fuzz the MOVILINK decoder and the character receiver.
//!
//! `cargo fuzz run movilink_decode` (from the `fuzz/` folder).
#![no_main]

use libfuzzer_sys::fuzz_target;
use movilink::timing::Instant;
use movilink::{
    Address, AddressFilter, CharError, Direction, LineTiming, Receiver, RxChar, decode, encode,
};

fuzz_target!(|data: &[u8]| {
    // 1. The decoder: never panics; whatever it accepts re-encodes to the same bytes.
    if let Ok((t, n)) = decode(data) {
        let mut buf = [0u8; movilink::MAX_TELEGRAM_LEN];
        let m = encode(&t, &mut buf).expect("a decoded telegram fits the maximum length");
        assert_eq!(m, n);
        assert_eq!(Some(&buf[..m]), data.get(..n));
    }

    // 2. The receiver: pairs of bytes are (character, gap code); never panics.
    let own = Address::new(1).unwrap_or(Address::BROADCAST);
    let mut rx_slave = Receiver::for_slave(own, Address::NO_GROUP);
    let mut rx_any = Receiver::new(
        Direction::Response,
        AddressFilter::Any,
        LineTiming::MOVILINK,
    );
    let mut t = 0u64;
    for pair in data.chunks(2) {
        let byte = pair.first().copied().unwrap_or(0);
        let code = pair.get(1).copied().unwrap_or(0);
        t += 1146 + u64::from(code & 0x3F) * 200;
        let time = Instant::from_micros(t);
        let c = match code >> 6 {
            0 => RxChar::with_error(byte, time, CharError::Parity),
            1 => RxChar::with_error(byte, time, CharError::Framing),
            _ => RxChar::new(byte, time),
        };
        let _ = rx_slave.handle_char(c);
        let _ = rx_any.handle_char(c);
    }
    let _ = rx_slave.handle_timeout(Instant::from_micros(u64::MAX));
    let _ = rx_any.handle_timeout(Instant::from_micros(u64::MAX));
});
