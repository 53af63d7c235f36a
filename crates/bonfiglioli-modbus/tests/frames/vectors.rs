//! Every example frame of the manual's ch. 8.1 (RTU) and 8.2 (ASCII) as a test vector, one
//! comment per byte (RTU) or per hex pair (ASCII). Each vector is encoded (it must give the
//! manual's bytes), decoded whole ([`decode_frame`]) and received character by character on
//! its side (drive for requests, master for responses).

use bonfiglioli_modbus::frame::{DiagSubFunction, ExceptionCode, Request, Response, StartAddress};
use bonfiglioli_modbus::framing::Mode;

use crate::{request, response};

/// Ch. 8.1.1, example 1, request: read P372 rated speed in data set 2 from drive 1.
#[test]
fn rtu_8_1_1_example_1_request() {
    let wire = [
        0x01, // address 1
        0x03, // function code 3: read 16-bit parameter
        0x21, 0x74, // start address: data set 2 (high nibble), parameter 372 = 0x174
        0x00, 0x01, // register count 1
        0xCE, 0x2C, // CRC-16 0x2CCE, low byte first
    ];
    request(
        Mode::Rtu,
        &wire,
        1,
        Request::ReadWord {
            start: StartAddress::from_raw(0x2174),
            count: 1,
        },
    );
}

/// Ch. 8.2.1, example 1, request: read P372 rated speed in data set 2 from drive 1.
#[test]
fn ascii_8_2_1_example_1_request() {
    let wire = [
        0x3A, // ':' start of frame
        0x30, 0x31, // "01" address 1
        0x30, 0x33, // "03" function code 3: read 16-bit parameter
        0x32,
        0x31, // "21" start address: data set 2 (high nibble), parameter 372 = 0x174 (high byte)
        0x37,
        0x34, // "74" start address: data set 2 (high nibble), parameter 372 = 0x174 (low byte)
        0x30, 0x30, // "00" register count 1 (high byte)
        0x30, 0x31, // "01" register count 1 (low byte)
        0x36, 0x36, // "66" LRC: -(sum of the bytes) mod 256 = 0x66
        0x0D, 0x0A, // CR LF end of frame
    ];
    request(
        Mode::Ascii,
        &wire,
        1,
        Request::ReadWord {
            start: StartAddress::from_raw(0x2174),
            count: 1,
        },
    );
}

/// Ch. 8.1.1, example 1, response: its answer: 0x056E = 1390 rpm.
#[test]
fn rtu_8_1_1_example_1_response() {
    let wire = [
        0x01, // address 1
        0x03, // function code 3
        0x02, // byte count 2
        0x05, 0x6E, // value 0x056E = 1390
        0x3A, 0xF8, // CRC-16 0xF83A, low byte first
    ];
    response(Mode::Rtu, &wire, 1, Response::ReadWord { value: 1390 });
}

/// Ch. 8.2.1, example 1, response: its answer: 0x056E = 1390 rpm.
#[test]
fn ascii_8_2_1_example_1_response() {
    let wire = [
        0x3A, // ':' start of frame
        0x30, 0x31, // "01" address 1
        0x30, 0x33, // "03" function code 3
        0x30, 0x32, // "02" byte count 2
        0x30, 0x35, // "05" value 0x056E = 1390 (high byte)
        0x36, 0x45, // "6E" value 0x056E = 1390 (low byte)
        0x38, 0x37, // "87" LRC: -(sum of the bytes) mod 256 = 0x87
        0x0D, 0x0A, // CR LF end of frame
    ];
    response(Mode::Ascii, &wire, 1, Response::ReadWord { value: 1390 });
}

/// Ch. 8.1.1, example 2, request: read P372 in data set 0 with register count 2 (not allowed).
#[test]
fn rtu_8_1_1_example_2_request() {
    let wire = [
        0x01, // address 1
        0x03, // function code 3: read 16-bit parameter
        0x01, 0x74, // start address: data set 0, parameter 372
        0x00, 0x02, // register count 2
        0x85, 0xED, // CRC-16 0xED85, low byte first
    ];
    request(
        Mode::Rtu,
        &wire,
        1,
        Request::ReadWord {
            start: StartAddress::from_raw(0x0174),
            count: 2,
        },
    );
}

/// Ch. 8.2.1, example 2, request: read P372 in data set 0 with register count 2 (not allowed).
#[test]
fn ascii_8_2_1_example_2_request() {
    let wire = [
        0x3A, // ':' start of frame
        0x30, 0x31, // "01" address 1
        0x30, 0x33, // "03" function code 3: read 16-bit parameter
        0x30, 0x31, // "01" start address: data set 0, parameter 372 (high byte)
        0x37, 0x34, // "74" start address: data set 0, parameter 372 (low byte)
        0x30, 0x30, // "00" register count 2 (high byte)
        0x30, 0x32, // "02" register count 2 (low byte)
        0x38, 0x35, // "85" LRC: -(sum of the bytes) mod 256 = 0x85
        0x0D, 0x0A, // CR LF end of frame
    ];
    request(
        Mode::Ascii,
        &wire,
        1,
        Request::ReadWord {
            start: StartAddress::from_raw(0x0174),
            count: 2,
        },
    );
}

/// Ch. 8.1.1, example 2, response: its exception answer 2 (illegal data address).
#[test]
fn rtu_8_1_1_example_2_response() {
    let wire = [
        0x01, // address 1
        0x83, // function code 3 with bit 7: exception
        0x02, // exception code 2: illegal data address
        0xC0, 0xF1, // CRC-16 0xF1C0, low byte first
    ];
    response(
        Mode::Rtu,
        &wire,
        1,
        Response::Exception {
            function: 3,
            code: ExceptionCode::ILLEGAL_DATA_ADDRESS,
        },
    );
}

/// Ch. 8.2.1, example 2, response: its exception answer 2 (illegal data address).
#[test]
fn ascii_8_2_1_example_2_response() {
    let wire = [
        0x3A, // ':' start of frame
        0x30, 0x31, // "01" address 1
        0x38, 0x33, // "83" function code 3 with bit 7: exception
        0x30, 0x32, // "02" exception code 2: illegal data address
        0x37, 0x41, // "7A" LRC: -(sum of the bytes) mod 256 = 0x7A
        0x0D, 0x0A, // CR LF end of frame
    ];
    response(
        Mode::Ascii,
        &wire,
        1,
        Response::Exception {
            function: 3,
            code: ExceptionCode::ILLEGAL_DATA_ADDRESS,
        },
    );
}

/// Ch. 8.1.2, example 1, request: write P376 rated mechanical power = 1.5 kW (15) in data set 4 of drive 3.
#[test]
fn rtu_8_1_2_example_1_request() {
    let wire = [
        0x03, // address 3
        0x06, // function code 6: write 16-bit parameter
        0x41, 0x78, // start address: data set 4, parameter 376 = 0x178
        0x00, 0x0F, // value 15 = 1.5 kW
        0x5C, 0x09, // CRC-16 0x095C, low byte first
    ];
    request(
        Mode::Rtu,
        &wire,
        3,
        Request::WriteWord {
            start: StartAddress::from_raw(0x4178),
            value: 15,
        },
    );
}

/// Ch. 8.2.2, example 1, request: write P376 rated mechanical power = 1.5 kW (15) in data set 4 of drive 3.
#[test]
fn ascii_8_2_2_example_1_request() {
    let wire = [
        0x3A, // ':' start of frame
        0x30, 0x33, // "03" address 3
        0x30, 0x36, // "06" function code 6: write 16-bit parameter
        0x34, 0x31, // "41" start address: data set 4, parameter 376 = 0x178 (high byte)
        0x37, 0x38, // "78" start address: data set 4, parameter 376 = 0x178 (low byte)
        0x30, 0x30, // "00" value 15 = 1.5 kW (high byte)
        0x30, 0x46, // "0F" value 15 = 1.5 kW (low byte)
        0x32, 0x46, // "2F" LRC: -(sum of the bytes) mod 256 = 0x2F
        0x0D, 0x0A, // CR LF end of frame
    ];
    request(
        Mode::Ascii,
        &wire,
        3,
        Request::WriteWord {
            start: StartAddress::from_raw(0x4178),
            value: 15,
        },
    );
}

/// Ch. 8.1.2, example 1, response: its answer, the request echoed.
#[test]
fn rtu_8_1_2_example_1_response() {
    let wire = [
        0x03, // address 3
        0x06, // function code 6
        0x41, 0x78, // start address: data set 4, parameter 376
        0x00, 0x0F, // value 15
        0x5C, 0x09, // CRC-16 0x095C, low byte first
    ];
    response(
        Mode::Rtu,
        &wire,
        3,
        Response::WriteWord {
            start: StartAddress::from_raw(0x4178),
            value: 15,
        },
    );
}

/// Ch. 8.2.2, example 1, response: its answer, the request echoed.
#[test]
fn ascii_8_2_2_example_1_response() {
    let wire = [
        0x3A, // ':' start of frame
        0x30, 0x33, // "03" address 3
        0x30, 0x36, // "06" function code 6
        0x34, 0x31, // "41" start address: data set 4, parameter 376 (high byte)
        0x37, 0x38, // "78" start address: data set 4, parameter 376 (low byte)
        0x30, 0x30, // "00" value 15 (high byte)
        0x30, 0x46, // "0F" value 15 (low byte)
        0x32, 0x46, // "2F" LRC: -(sum of the bytes) mod 256 = 0x2F
        0x0D, 0x0A, // CR LF end of frame
    ];
    response(
        Mode::Ascii,
        &wire,
        3,
        Response::WriteWord {
            start: StartAddress::from_raw(0x4178),
            value: 15,
        },
    );
}

/// Ch. 8.1.2, example 2, request: write the invalid value 0 to P376 in data set 2 of drive 3.
#[test]
fn rtu_8_1_2_example_2_request() {
    let wire = [
        0x03, // address 3
        0x06, // function code 6: write 16-bit parameter
        0x21, 0x78, // start address: data set 2, parameter 376
        0x00, 0x00, // value 0 (below the minimum)
        0x02, 0x0D, // CRC-16 0x0D02, low byte first
    ];
    request(
        Mode::Rtu,
        &wire,
        3,
        Request::WriteWord {
            start: StartAddress::from_raw(0x2178),
            value: 0,
        },
    );
}

/// Ch. 8.2.2, example 2, request: write the invalid value 0 to P376 in data set 2 of drive 3.
#[test]
fn ascii_8_2_2_example_2_request() {
    let wire = [
        0x3A, // ':' start of frame
        0x30, 0x33, // "03" address 3
        0x30, 0x36, // "06" function code 6: write 16-bit parameter
        0x32, 0x31, // "21" start address: data set 2, parameter 376 (high byte)
        0x37, 0x38, // "78" start address: data set 2, parameter 376 (low byte)
        0x30, 0x30, // "00" value 0 (below the minimum) (high byte)
        0x30, 0x30, // "00" value 0 (below the minimum) (low byte)
        0x35, 0x45, // "5E" LRC: -(sum of the bytes) mod 256 = 0x5E
        0x0D, 0x0A, // CR LF end of frame
    ];
    request(
        Mode::Ascii,
        &wire,
        3,
        Request::WriteWord {
            start: StartAddress::from_raw(0x2178),
            value: 0,
        },
    );
}

/// Ch. 8.1.2, example 2, response: its exception answer 4 (slave device failure).
#[test]
fn rtu_8_1_2_example_2_response() {
    let wire = [
        0x03, // address 3
        0x86, // function code 6 with bit 7: exception
        0x04, // exception code 4: slave device failure
        0xE2, 0x63, // CRC-16 0x63E2, low byte first
    ];
    response(
        Mode::Rtu,
        &wire,
        3,
        Response::Exception {
            function: 6,
            code: ExceptionCode::SLAVE_DEVICE_FAILURE,
        },
    );
}

/// Ch. 8.2.2, example 2, response: its exception answer 4 (slave device failure).
#[test]
fn ascii_8_2_2_example_2_response() {
    let wire = [
        0x3A, // ':' start of frame
        0x30, 0x33, // "03" address 3
        0x38, 0x36, // "86" function code 6 with bit 7: exception
        0x30, 0x34, // "04" exception code 4: slave device failure
        0x37, 0x33, // "73" LRC: -(sum of the bytes) mod 256 = 0x73
        0x0D, 0x0A, // CR LF end of frame
    ];
    response(
        Mode::Ascii,
        &wire,
        3,
        Response::Exception {
            function: 6,
            code: ExceptionCode::SLAVE_DEVICE_FAILURE,
        },
    );
}

/// Ch. 8.1.3, example 1, request: read P481 fixed frequency 2 in data set 0 from drive 1.
#[test]
fn rtu_8_1_3_example_1_request() {
    let wire = [
        0x01, // address 1
        0x64, // function code 100: read 32-bit parameter
        0x01, 0xE1, // start address: data set 0, parameter 481 = 0x1E1
        0x81, 0xDF, // CRC-16 0xDF81, low byte first
    ];
    request(
        Mode::Rtu,
        &wire,
        1,
        Request::ReadLong {
            start: StartAddress::from_raw(0x01E1),
        },
    );
}

/// Ch. 8.2.3, example 1, request: read P481 fixed frequency 2 in data set 0 from drive 1.
#[test]
fn ascii_8_2_3_example_1_request() {
    let wire = [
        0x3A, // ':' start of frame
        0x30, 0x31, // "01" address 1
        0x36, 0x34, // "64" function code 100: read 32-bit parameter
        0x30, 0x31, // "01" start address: data set 0, parameter 481 = 0x1E1 (high byte)
        0x45, 0x31, // "E1" start address: data set 0, parameter 481 = 0x1E1 (low byte)
        0x42, 0x39, // "B9" LRC: -(sum of the bytes) mod 256 = 0xB9
        0x0D, 0x0A, // CR LF end of frame
    ];
    request(
        Mode::Ascii,
        &wire,
        1,
        Request::ReadLong {
            start: StartAddress::from_raw(0x01E1),
        },
    );
}

/// Ch. 8.1.3, example 1, response: its answer: 0x000003E8 = 1000 = 10.00 Hz.
#[test]
fn rtu_8_1_3_example_1_response() {
    let wire = [
        0x01, // address 1
        0x64, // function code 100
        0x00, 0x00, 0x03, 0xE8, // value 0x000003E8 = 1000 (10.00 Hz), high byte first
        0x70, 0xBC, // CRC-16 0xBC70, low byte first
    ];
    response(Mode::Rtu, &wire, 1, Response::ReadLong { value: 1000 });
}

/// Ch. 8.2.3, example 1, response: its answer: 0x000003E8 = 1000 = 10.00 Hz.
#[test]
fn ascii_8_2_3_example_1_response() {
    let wire = [
        0x3A, // ':' start of frame
        0x30, 0x31, // "01" address 1
        0x36, 0x34, // "64" function code 100
        0x30, 0x30, // "00" value 0x000003E8 = 1000 (10.00 Hz), high byte first (byte 1 of 4)
        0x30, 0x30, // "00" value 0x000003E8 = 1000 (10.00 Hz), high byte first (byte 2 of 4)
        0x30, 0x33, // "03" value 0x000003E8 = 1000 (10.00 Hz), high byte first (byte 3 of 4)
        0x45, 0x38, // "E8" value 0x000003E8 = 1000 (10.00 Hz), high byte first (byte 4 of 4)
        0x42, 0x30, // "B0" LRC: -(sum of the bytes) mod 256 = 0xB0
        0x0D, 0x0A, // CR LF end of frame
    ];
    response(Mode::Ascii, &wire, 1, Response::ReadLong { value: 1000 });
}

/// Ch. 8.1.3, example 2, request: read the unknown parameter 1600 in data set 2 from drive 1.
#[test]
fn rtu_8_1_3_example_2_request() {
    let wire = [
        0x01, // address 1
        0x64, // function code 100: read 32-bit parameter
        0x26, 0x40, // start address: data set 2, parameter 1600 = 0x640
        0x5B, 0x97, // CRC-16 0x975B, low byte first
    ];
    request(
        Mode::Rtu,
        &wire,
        1,
        Request::ReadLong {
            start: StartAddress::from_raw(0x2640),
        },
    );
}

/// Ch. 8.2.3, example 2, request: read the unknown parameter 1600 in data set 2 from drive 1.
#[test]
fn ascii_8_2_3_example_2_request() {
    let wire = [
        0x3A, // ':' start of frame
        0x30, 0x31, // "01" address 1
        0x36, 0x34, // "64" function code 100: read 32-bit parameter
        0x32, 0x36, // "26" start address: data set 2, parameter 1600 = 0x640 (high byte)
        0x34, 0x30, // "40" start address: data set 2, parameter 1600 = 0x640 (low byte)
        0x33, 0x35, // "35" LRC: -(sum of the bytes) mod 256 = 0x35
        0x0D, 0x0A, // CR LF end of frame
    ];
    request(
        Mode::Ascii,
        &wire,
        1,
        Request::ReadLong {
            start: StartAddress::from_raw(0x2640),
        },
    );
}

/// Ch. 8.1.3, example 2, response: its exception answer 4 (slave device failure).
#[test]
fn rtu_8_1_3_example_2_response() {
    let wire = [
        0x01, // address 1
        0xE4, // function code 100 with bit 7: exception
        0x04, // exception code 4: slave device failure
        0x6A, 0xC3, // CRC-16 0xC36A, low byte first
    ];
    response(
        Mode::Rtu,
        &wire,
        1,
        Response::Exception {
            function: 100,
            code: ExceptionCode::SLAVE_DEVICE_FAILURE,
        },
    );
}

/// Ch. 8.2.3, example 2, response: its exception answer 4 (slave device failure). The manual's
/// `ASC` row of this frame is wrong (erratum E4, `docs/errata-bonfiglioli.md`); this is its
/// `Hex` row, which agrees with the text and the RTU example; see
/// `errata::e4_ascii_row_of_8_2_3_example_2_is_exception_2`.
#[test]
fn ascii_8_2_3_example_2_response() {
    let wire = [
        0x3A, // ':' start of frame
        0x30, 0x31, // "01" address 1
        0x45, 0x34, // "E4" function code 100 with bit 7: exception
        0x30, 0x34, // "04" exception code 4: slave device failure
        0x31, 0x37, // "17" LRC: -(sum of the bytes) mod 256 = 0x17
        0x0D, 0x0A, // CR LF end of frame
    ];
    response(
        Mode::Ascii,
        &wire,
        1,
        Response::Exception {
            function: 100,
            code: ExceptionCode::SLAVE_DEVICE_FAILURE,
        },
    );
}

/// Ch. 8.1.4, example 1, request: write P375 rated frequency = 10.00 Hz (1000) in data set 2 of drive 1.
#[test]
fn rtu_8_1_4_example_1_request() {
    let wire = [
        0x01, // address 1
        0x65, // function code 101: write 32-bit parameter
        0x21, 0x77, // start address: data set 2, parameter 375 = 0x177
        0x00, 0x00, 0x03, 0xE8, // value 1000 = 10.00 Hz, high byte first
        0x46, 0xC5, // CRC-16 0xC546, low byte first
    ];
    request(
        Mode::Rtu,
        &wire,
        1,
        Request::WriteLong {
            start: StartAddress::from_raw(0x2177),
            value: 1000,
        },
    );
}

/// Ch. 8.2.4, example 1, request: write P375 rated frequency = 10.00 Hz (1000) in data set 2 of drive 1.
#[test]
fn ascii_8_2_4_example_1_request() {
    let wire = [
        0x3A, // ':' start of frame
        0x30, 0x31, // "01" address 1
        0x36, 0x35, // "65" function code 101: write 32-bit parameter
        0x32, 0x31, // "21" start address: data set 2, parameter 375 = 0x177 (high byte)
        0x37, 0x37, // "77" start address: data set 2, parameter 375 = 0x177 (low byte)
        0x30, 0x30, // "00" value 1000 = 10.00 Hz, high byte first (byte 1 of 4)
        0x30, 0x30, // "00" value 1000 = 10.00 Hz, high byte first (byte 2 of 4)
        0x30, 0x33, // "03" value 1000 = 10.00 Hz, high byte first (byte 3 of 4)
        0x45, 0x38, // "E8" value 1000 = 10.00 Hz, high byte first (byte 4 of 4)
        0x31, 0x37, // "17" LRC: -(sum of the bytes) mod 256 = 0x17
        0x0D, 0x0A, // CR LF end of frame
    ];
    request(
        Mode::Ascii,
        &wire,
        1,
        Request::WriteLong {
            start: StartAddress::from_raw(0x2177),
            value: 1000,
        },
    );
}

/// Ch. 8.1.4, example 1, response: its answer, the request echoed.
#[test]
fn rtu_8_1_4_example_1_response() {
    let wire = [
        0x01, // address 1
        0x65, // function code 101
        0x21, 0x77, // start address: data set 2, parameter 375
        0x00, 0x00, 0x03, 0xE8, // value 1000
        0x46, 0xC5, // CRC-16 0xC546, low byte first
    ];
    response(
        Mode::Rtu,
        &wire,
        1,
        Response::WriteLong {
            start: StartAddress::from_raw(0x2177),
            value: 1000,
        },
    );
}

/// Ch. 8.2.4, example 1, response: its answer, the request echoed.
#[test]
fn ascii_8_2_4_example_1_response() {
    let wire = [
        0x3A, // ':' start of frame
        0x30, 0x31, // "01" address 1
        0x36, 0x35, // "65" function code 101
        0x32, 0x31, // "21" start address: data set 2, parameter 375 (high byte)
        0x37, 0x37, // "77" start address: data set 2, parameter 375 (low byte)
        0x30, 0x30, // "00" value 1000 (byte 1 of 4)
        0x30, 0x30, // "00" value 1000 (byte 2 of 4)
        0x30, 0x33, // "03" value 1000 (byte 3 of 4)
        0x45, 0x38, // "E8" value 1000 (byte 4 of 4)
        0x31, 0x37, // "17" LRC: -(sum of the bytes) mod 256 = 0x17
        0x0D, 0x0A, // CR LF end of frame
    ];
    response(
        Mode::Ascii,
        &wire,
        1,
        Response::WriteLong {
            start: StartAddress::from_raw(0x2177),
            value: 1000,
        },
    );
}

/// Ch. 8.1.4, example 2, request: write the invalid value 9.00 Hz (900) to P375 in data set 2 of drive 1.
#[test]
fn rtu_8_1_4_example_2_request() {
    let wire = [
        0x01, // address 1
        0x65, // function code 101: write 32-bit parameter
        0x21, 0x77, // start address: data set 2, parameter 375
        0x00, 0x00, 0x03, 0x84, // value 900 = 9.00 Hz (below the minimum)
        0x46, 0xE8, // CRC-16 0xE846, low byte first
    ];
    request(
        Mode::Rtu,
        &wire,
        1,
        Request::WriteLong {
            start: StartAddress::from_raw(0x2177),
            value: 900,
        },
    );
}

/// Ch. 8.2.4, example 2, request: write the invalid value 9.00 Hz (900) to P375 in data set 2 of drive 1.
#[test]
fn ascii_8_2_4_example_2_request() {
    let wire = [
        0x3A, // ':' start of frame
        0x30, 0x31, // "01" address 1
        0x36, 0x35, // "65" function code 101: write 32-bit parameter
        0x32, 0x31, // "21" start address: data set 2, parameter 375 (high byte)
        0x37, 0x37, // "77" start address: data set 2, parameter 375 (low byte)
        0x30, 0x30, // "00" value 900 = 9.00 Hz (below the minimum) (byte 1 of 4)
        0x30, 0x30, // "00" value 900 = 9.00 Hz (below the minimum) (byte 2 of 4)
        0x30, 0x33, // "03" value 900 = 9.00 Hz (below the minimum) (byte 3 of 4)
        0x38, 0x34, // "84" value 900 = 9.00 Hz (below the minimum) (byte 4 of 4)
        0x37, 0x42, // "7B" LRC: -(sum of the bytes) mod 256 = 0x7B
        0x0D, 0x0A, // CR LF end of frame
    ];
    request(
        Mode::Ascii,
        &wire,
        1,
        Request::WriteLong {
            start: StartAddress::from_raw(0x2177),
            value: 900,
        },
    );
}

/// Ch. 8.1.4, example 2, response: its exception answer 4 (slave device failure).
#[test]
fn rtu_8_1_4_example_2_response() {
    let wire = [
        0x01, // address 1
        0xE5, // function code 101 with bit 7: exception
        0x04, // exception code 4: slave device failure
        0x6B, 0x53, // CRC-16 0x536B, low byte first
    ];
    response(
        Mode::Rtu,
        &wire,
        1,
        Response::Exception {
            function: 101,
            code: ExceptionCode::SLAVE_DEVICE_FAILURE,
        },
    );
}

/// Ch. 8.2.4, example 2, response: its exception answer 4 (slave device failure).
#[test]
fn ascii_8_2_4_example_2_response() {
    let wire = [
        0x3A, // ':' start of frame
        0x30, 0x31, // "01" address 1
        0x45, 0x35, // "E5" function code 101 with bit 7: exception
        0x30, 0x34, // "04" exception code 4: slave device failure
        0x31, 0x36, // "16" LRC: -(sum of the bytes) mod 256 = 0x16
        0x0D, 0x0A, // CR LF end of frame
    ];
    response(
        Mode::Ascii,
        &wire,
        1,
        Response::Exception {
            function: 101,
            code: ExceptionCode::SLAVE_DEVICE_FAILURE,
        },
    );
}

/// Ch. 8.1.5, example 1a, request: clear all diagnostic counters of drive 1.
#[test]
fn rtu_8_1_5_example_1a_request() {
    let wire = [
        0x01, // address 1
        0x08, // function code 8: diagnostics
        0x00, 0x0A, // sub-function 0x0A: clear counters
        0x00, 0x00, // data 0
        0xC0, 0x09, // CRC-16 0x09C0, low byte first
    ];
    request(
        Mode::Rtu,
        &wire,
        1,
        Request::Diagnostics {
            sub: DiagSubFunction::CLEAR_COUNTERS,
            data: 0,
        },
    );
}

/// Ch. 8.2.5, example 1a, request: clear all diagnostic counters of drive 1.
#[test]
fn ascii_8_2_5_example_1a_request() {
    let wire = [
        0x3A, // ':' start of frame
        0x30, 0x31, // "01" address 1
        0x30, 0x38, // "08" function code 8: diagnostics
        0x30, 0x30, // "00" sub-function 0x0A: clear counters (high byte)
        0x30, 0x41, // "0A" sub-function 0x0A: clear counters (low byte)
        0x30, 0x30, // "00" data 0 (high byte)
        0x30, 0x30, // "00" data 0 (low byte)
        0x45, 0x44, // "ED" LRC: -(sum of the bytes) mod 256 = 0xED
        0x0D, 0x0A, // CR LF end of frame
    ];
    request(
        Mode::Ascii,
        &wire,
        1,
        Request::Diagnostics {
            sub: DiagSubFunction::CLEAR_COUNTERS,
            data: 0,
        },
    );
}

/// Ch. 8.1.5, example 1a, response: its answer, the request echoed.
#[test]
fn rtu_8_1_5_example_1a_response() {
    let wire = [
        0x01, // address 1
        0x08, // function code 8
        0x00, 0x0A, // sub-function 0x0A
        0x00, 0x00, // data 0
        0xC0, 0x09, // CRC-16 0x09C0, low byte first
    ];
    response(
        Mode::Rtu,
        &wire,
        1,
        Response::Diagnostics {
            sub: DiagSubFunction::CLEAR_COUNTERS,
            data: 0,
        },
    );
}

/// Ch. 8.2.5, example 1a, response: its answer, the request echoed.
#[test]
fn ascii_8_2_5_example_1a_response() {
    let wire = [
        0x3A, // ':' start of frame
        0x30, 0x31, // "01" address 1
        0x30, 0x38, // "08" function code 8
        0x30, 0x30, // "00" sub-function 0x0A (high byte)
        0x30, 0x41, // "0A" sub-function 0x0A (low byte)
        0x30, 0x30, // "00" data 0 (high byte)
        0x30, 0x30, // "00" data 0 (low byte)
        0x45, 0x44, // "ED" LRC: -(sum of the bytes) mod 256 = 0xED
        0x0D, 0x0A, // CR LF end of frame
    ];
    response(
        Mode::Ascii,
        &wire,
        1,
        Response::Diagnostics {
            sub: DiagSubFunction::CLEAR_COUNTERS,
            data: 0,
        },
    );
}

/// Ch. 8.1.5, example 1b, request: read counter 4, slave messages (0x0E), of drive 1.
#[test]
fn rtu_8_1_5_example_1b_request() {
    let wire = [
        0x01, // address 1
        0x08, // function code 8: diagnostics
        0x00, 0x0E, // sub-function 0x0E: slave messages
        0x00, 0x00, // data 0
        0x81, 0xC8, // CRC-16 0xC881, low byte first
    ];
    request(
        Mode::Rtu,
        &wire,
        1,
        Request::Diagnostics {
            sub: DiagSubFunction::SLAVE_MESSAGES,
            data: 0,
        },
    );
}

/// Ch. 8.2.5, example 1b, request: read counter 4, slave messages (0x0E), of drive 1.
#[test]
fn ascii_8_2_5_example_1b_request() {
    let wire = [
        0x3A, // ':' start of frame
        0x30, 0x31, // "01" address 1
        0x30, 0x38, // "08" function code 8: diagnostics
        0x30, 0x30, // "00" sub-function 0x0E: slave messages (high byte)
        0x30, 0x45, // "0E" sub-function 0x0E: slave messages (low byte)
        0x30, 0x30, // "00" data 0 (high byte)
        0x30, 0x30, // "00" data 0 (low byte)
        0x45, 0x39, // "E9" LRC: -(sum of the bytes) mod 256 = 0xE9
        0x0D, 0x0A, // CR LF end of frame
    ];
    request(
        Mode::Ascii,
        &wire,
        1,
        Request::Diagnostics {
            sub: DiagSubFunction::SLAVE_MESSAGES,
            data: 0,
        },
    );
}

/// Ch. 8.1.5, example 1b, response: its answer: 1 message since the counters were cleared.
#[test]
fn rtu_8_1_5_example_1b_response() {
    let wire = [
        0x01, // address 1
        0x08, // function code 8
        0x00, 0x0E, // sub-function 0x0E
        0x00, 0x01, // counter 1
        0x40, 0x08, // CRC-16 0x0840, low byte first
    ];
    response(
        Mode::Rtu,
        &wire,
        1,
        Response::Diagnostics {
            sub: DiagSubFunction::SLAVE_MESSAGES,
            data: 1,
        },
    );
}

/// Ch. 8.2.5, example 1b, response: its answer: 1 message since the counters were cleared.
#[test]
fn ascii_8_2_5_example_1b_response() {
    let wire = [
        0x3A, // ':' start of frame
        0x30, 0x31, // "01" address 1
        0x30, 0x38, // "08" function code 8
        0x30, 0x30, // "00" sub-function 0x0E (high byte)
        0x30, 0x45, // "0E" sub-function 0x0E (low byte)
        0x30, 0x30, // "00" counter 1 (high byte)
        0x30, 0x31, // "01" counter 1 (low byte)
        0x45, 0x38, // "E8" LRC: -(sum of the bytes) mod 256 = 0xE8
        0x0D, 0x0A, // CR LF end of frame
    ];
    response(
        Mode::Ascii,
        &wire,
        1,
        Response::Diagnostics {
            sub: DiagSubFunction::SLAVE_MESSAGES,
            data: 1,
        },
    );
}

/// Ch. 8.1.5, example 2, request: read the unknown counter 8 (sub-function 0x13) of drive 1.
#[test]
fn rtu_8_1_5_example_2_request() {
    let wire = [
        0x01, // address 1
        0x08, // function code 8: diagnostics
        0x00, 0x13, // sub-function 0x13 (unknown)
        0x00, 0x00, // data 0
        0x11, 0xCE, // CRC-16 0xCE11, low byte first
    ];
    request(
        Mode::Rtu,
        &wire,
        1,
        Request::Diagnostics {
            sub: DiagSubFunction(0x13),
            data: 0,
        },
    );
}

/// Ch. 8.2.5, example 2, request: read the unknown counter 8 (sub-function 0x13) of drive 1.
#[test]
fn ascii_8_2_5_example_2_request() {
    let wire = [
        0x3A, // ':' start of frame
        0x30, 0x31, // "01" address 1
        0x30, 0x38, // "08" function code 8: diagnostics
        0x30, 0x30, // "00" sub-function 0x13 (unknown) (high byte)
        0x31, 0x33, // "13" sub-function 0x13 (unknown) (low byte)
        0x30, 0x30, // "00" data 0 (high byte)
        0x30, 0x30, // "00" data 0 (low byte)
        0x45, 0x34, // "E4" LRC: -(sum of the bytes) mod 256 = 0xE4
        0x0D, 0x0A, // CR LF end of frame
    ];
    request(
        Mode::Ascii,
        &wire,
        1,
        Request::Diagnostics {
            sub: DiagSubFunction(0x13),
            data: 0,
        },
    );
}

/// Ch. 8.1.5, example 2, response: its exception answer 1 (illegal function).
#[test]
fn rtu_8_1_5_example_2_response() {
    let wire = [
        0x01, // address 1
        0x88, // function code 8 with bit 7: exception
        0x01, // exception code 1: illegal function
        0x87, 0xC0, // CRC-16 0xC087, low byte first
    ];
    response(
        Mode::Rtu,
        &wire,
        1,
        Response::Exception {
            function: 8,
            code: ExceptionCode::ILLEGAL_FUNCTION,
        },
    );
}

/// Ch. 8.2.5, example 2, response: its exception answer 1 (illegal function).
#[test]
fn ascii_8_2_5_example_2_response() {
    let wire = [
        0x3A, // ':' start of frame
        0x30, 0x31, // "01" address 1
        0x38, 0x38, // "88" function code 8 with bit 7: exception
        0x30, 0x31, // "01" exception code 1: illegal function
        0x37, 0x36, // "76" LRC: -(sum of the bytes) mod 256 = 0x76
        0x0D, 0x0A, // CR LF end of frame
    ];
    response(
        Mode::Ascii,
        &wire,
        1,
        Response::Exception {
            function: 8,
            code: ExceptionCode::ILLEGAL_FUNCTION,
        },
    );
}
