//! The Bonfiglioli Modbus fuzz body, the same for RTU and ASCII: whole-frame decoding and
//! drive-core's receiver with `ModbusFraming` on both sides (included by `bonfiglioli_rtu.rs`
//! and `bonfiglioli_ascii.rs`; not a target of its own).

use bonfiglioli_modbus::framing::{MAX_FRAME, ModbusFraming, Mode, Receiver, Side, decode_frame};
use bonfiglioli_modbus::pdu::MAX_PDU;
use bonfiglioli_modbus::{ascii, rtu};
use drive_core::{CharError, Instant, Parity, RxChar};

/// Fuzz `data` in `mode`.
pub fn run(mode: Mode, data: &[u8]) {
    // 1. Whole-frame decoding never panics; what it accepts re-encodes to a frame that
    //    decodes to the same address and PDU (ASCII input may be lower case, so compare
    //    decoded contents, not bytes).
    let mut pdu = [0u8; MAX_PDU];
    if let Ok((a, n)) = decode_frame(mode, data, &mut pdu) {
        let body = pdu.get(..n).unwrap_or(&[]);
        let mut wire = [0u8; MAX_FRAME];
        let m = match mode {
            Mode::Rtu => rtu::encode(a, body, &mut wire),
            Mode::Ascii => ascii::encode(a, body, &mut wire),
        }
        .expect("a decoded frame fits");
        let mut again = [0u8; MAX_PDU];
        assert_eq!(decode_frame(mode, &wire[..m], &mut again), Ok((a, n)));
        assert_eq!(again.get(..n), Some(body));
        if mode == Mode::Rtu {
            assert_eq!(&wire[..m], data);
        }
    }

    // 2. Receivers: pairs of bytes are (character, code); `code >> 6` is the UART status
    //    (0 parity error, 1 framing error, 2 or 3 none), `code & 0x3F` the idle gap before the
    //    character in quarter character times (RTU) or in 20 ms (ASCII).
    let line = mode.line_settings(19200, Parity::Even);
    let ct = line.char_time().as_nanos() as u64;
    let unit = match mode {
        Mode::Rtu => ct / 4,
        Mode::Ascii => 20_000_000,
    };
    let mut slave = Receiver::new(ModbusFraming::new(mode, Side::Slave, &line));
    let mut master = Receiver::new(ModbusFraming::new(mode, Side::Master, &line));
    let mut t = 0u64;
    for pair in data.chunks(2) {
        let byte = pair.first().copied().unwrap_or(0);
        let code = pair.get(1).copied().unwrap_or(0x80);
        t += ct + u64::from(code & 0x3F) * unit;
        let time = Instant::from_nanos(t);
        let c = match code >> 6 {
            0 => RxChar::with_error(byte, time, CharError::Parity),
            1 => RxChar::with_error(byte, time, CharError::Framing),
            _ => RxChar::new(byte, time),
        };
        for rx in [&mut slave, &mut master] {
            let _ = rx.handle_char(c);
            if let Some(at) = rx.poll_timeout().filter(|at| *at <= time) {
                let _ = rx.handle_timeout(at);
            }
        }
    }
    let _ = slave.handle_timeout(Instant::MAX);
    let _ = master.handle_timeout(Instant::MAX);
}
