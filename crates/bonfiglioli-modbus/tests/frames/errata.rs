//! The manual's errata that concern framing (`docs/errata-bonfiglioli.md`).

use bonfiglioli_modbus::ascii;
use bonfiglioli_modbus::frame::{Address, ExceptionCode, Response};
use bonfiglioli_modbus::framing::{Mode, decode_frame};
use bonfiglioli_modbus::pdu::MAX_PDU;

/// E4: ch. 8.2.3, example 2, error response. The `ASC` row reads `: 0 1 E 4 0 2 1 9 CR LF`,
/// the `Hex` row `3A 30 31 45 34 30 34 31 37 0D 0A`. The two differ in the exception code and
/// the LRC; each is consistent in itself, but the text ("0x04 = FEHLER SLAVE GERÄT") and the
/// RTU example of ch. 8.1.3 (`01 E4 04 6A C3`) say exception 4, so the `Hex` row is right.
#[test]
fn e4_ascii_row_of_8_2_3_example_2_is_exception_2() {
    let mut pdu = [0u8; MAX_PDU];
    // The ASC row as printed decodes (its LRC fits its digits) but to exception 2.
    let asc_row = b":01E40219\r\n";
    assert_eq!(ascii::lrc(&[0x01, 0xE4, 0x02]), 0x19);
    let (a, n) = decode_frame(Mode::Ascii, asc_row, &mut pdu).unwrap();
    assert_eq!(a, Address::new(1).unwrap());
    assert_eq!(
        Response::decode(&pdu[..n]),
        Ok(Response::Exception {
            function: 100,
            code: ExceptionCode::ILLEGAL_DATA_ADDRESS
        })
    );
    // The Hex row: exception 4, LRC 0x17 = -(0x01 + 0xE4 + 0x04) mod 256.
    let hex_row = [
        0x3A, 0x30, 0x31, 0x45, 0x34, 0x30, 0x34, 0x31, 0x37, 0x0D, 0x0A,
    ];
    assert_eq!(ascii::lrc(&[0x01, 0xE4, 0x04]), 0x17);
    let (_, n) = decode_frame(Mode::Ascii, &hex_row, &mut pdu).unwrap();
    assert_eq!(
        Response::decode(&pdu[..n]),
        Ok(Response::Exception {
            function: 100,
            code: ExceptionCode::SLAVE_DEVICE_FAILURE
        })
    );
    // The same answer in RTU (ch. 8.1.3, example 2): exception 4.
    let (_, n) = decode_frame(Mode::Rtu, &[0x01, 0xE4, 0x04, 0x6A, 0xC3], &mut pdu).unwrap();
    assert_eq!(pdu[..n], [0xE4, 0x04]);
    // A mixture of the two rows (the ASC row's code with the Hex row's LRC) is refused.
    assert!(decode_frame(Mode::Ascii, b":01E40217\r\n", &mut pdu).is_err());
}

/// E9: ch. 6.7.1.4, the C# example comments `CRC >>= 1; // schieben links` ("shift left"); the
/// code and the procedure shift *right* (towards the LSB). A left shift gives another value.
#[test]
fn e9_the_crc_shifts_right() {
    fn crc(bytes: &[u8], right: bool) -> u16 {
        let mut reg = 0xFFFFu16;
        for b in bytes {
            reg ^= u16::from(*b);
            for _ in 0..8 {
                let lsb = reg & 1 == 1;
                reg = if right { reg >> 1 } else { reg << 1 };
                if lsb {
                    reg ^= 0xA001;
                }
            }
        }
        reg
    }
    assert_eq!(crc(&[0x02, 0x07], true), 0x1241);
    assert_eq!(bonfiglioli_modbus::rtu::crc(&[0x02, 0x07]), 0x1241);
    assert_ne!(crc(&[0x02, 0x07], false), 0x1241);
}
