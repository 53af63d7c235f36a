//! Every example telegram of the manuals as a test vector, one comment per byte.

use movilink::{
    Address, Direction, ParamChannel, PduType, ReturnCode, ScaleInfo, Service, Telegram, codec,
    decode, encode,
};

fn addr(a: u8) -> Address {
    Address::new(a).unwrap()
}

fn round_trip(t: &Telegram, wire: &[u8]) {
    let mut buf = [0u8; 18];
    let n = encode(t, &mut buf).unwrap();
    assert_eq!(&buf[..n], wire, "encode");
    assert_eq!(decode(wire), Ok((*t, wire.len())), "decode");
}

/// Bild 20 (ch. 4.2): forming the BCC of a cyclic 3PD request.
#[test]
fn bild_20_bcc_of_cyclic_3pd_request() {
    let wire = [
        0x02, // SD1: request
        0x01, // ADR: drive 1
        0x05, // TYP: 3PD cyclic
        0x00, // PD1 high
        0x06, // PD1 low
        0x3A, // PD2 high
        0x98, // PD2 low
        0x01, // PD3 high
        0xF4, // PD3 low
        0x57, // BCC = 02 ^ 01 ^ 05 ^ 00 ^ 06 ^ 3A ^ 98 ^ 01 ^ F4
    ];
    assert_eq!(codec::bcc(&wire[..9]), 0x57);
    let t = Telegram::request(addr(1), PduType::PD3).with_process_data(&[0x0006, 0x3A98, 0x01F4]);
    round_trip(&t, &wire);
}

/// Ch. 4.3 application example "control via 3 process data words", request. The manual calls
/// the type "PDU-Typ 5 (3PD azyklisch)"; 5 is 3PD *cyclic*, acyclic is 0x85 (see ERRATA-NOTES.md).
/// The example itself is acyclic ("keine Timeout-Überwachung"), so the vector uses 0x85. Bild 23
/// is not in the text: the address (1) is ours.
#[test]
fn ch_4_3_application_example_request_is_type_0x85() {
    let wire = [
        0x02, // SD1: request
        0x01, // ADR: drive 1 (Bild 23 not available; assumed)
        0x85, // TYP: 3PD acyclic (the manual's "type 5" is the cyclic variant)
        0x00, // PA1 high: control word 1
        0x06, // PA1 low: 0x0006 = enable
        0x20, // PA2 high: speed [%] setpoint
        0x00, // PA2 low: 0x2000 = 50 %
        0x0B, // PA3 high: ramp
        0xB8, // PA3 low: 0x0BB8 = 3000 ms
        0x13, // BCC
    ];
    let t = Telegram::request(addr(1), PduType::PD3_ACYCLIC)
        .with_process_data(&[0x0006, 0x2000, 0x0BB8]);
    round_trip(&t, &wire);
    // The cyclic variant "TYP = 5" differs only in TYP and BCC.
    let cyclic =
        Telegram::request(addr(1), PduType::PD3).with_process_data(&[0x0006, 0x2000, 0x0BB8]);
    let mut buf = [0u8; 18];
    let n = encode(&cyclic, &mut buf).unwrap();
    assert_eq!(
        &buf[..n],
        &[0x02, 0x01, 0x05, 0x00, 0x06, 0x20, 0x00, 0x0B, 0xB8, 0x93]
    );
}

/// Ch. 4.3 application example, response.
#[test]
fn ch_4_3_application_example_response() {
    let wire = [
        0x1D, // SD2: response
        0x01, // ADR: drive 1
        0x85, // TYP: 3PD acyclic, as the request
        0x02, // PE1 high: status word 1
        0x06, // PE1 low: 0x0206
        0x00, // PE2 high: speed [%] actual value
        0x00, // PE2 low: 0 %
        0x06, // PE3 high: status word 2
        0x06, // PE3 low: 0x0606
        0x9D, // BCC
    ];
    let t = Telegram::response(addr(1), PduType::PD3_ACYCLIC)
        .with_process_data(&[0x0206, 0x0000, 0x0606]);
    round_trip(&t, &wire);
    assert_eq!(t.direction(), Direction::Response);
}

/// Ch. 4.3 "Read Scale" example: P131 ramp t11 down CW, size index 4 (time, s), conversion
/// index -3 (milli); the value 3000 means 3 s. Index 8471 from the parameter list.
#[test]
fn ch_4_3_read_scale_p131() {
    let req = [
        0x02, // SD1
        0x01, // ADR: drive 1
        0x86, // TYP: PARAM + 0PD acyclic
        0x37, // management: data length 11 = 4 bytes, service 0111 = Read Scale
        0x00, // subindex / reserved
        0x21, // index high
        0x17, // index low: 0x2117 = 8471 = P131
        0x00, // data MSB
        0x00, // data
        0x00, // data
        0x00, // data LSB
        0x84, // BCC
    ];
    let t = Telegram::request(addr(1), PduType::PARAM_0PD_ACYCLIC)
        .with_param(ParamChannel::read_scale(8471));
    round_trip(&t, &req);
    let resp = [
        0x1D, // SD2
        0x01, // ADR
        0x86, // TYP
        0x37, // management: Read Scale, status 0
        0x00, // subindex
        0x21, // index high
        0x17, // index low
        0x00, // reserved
        0x00, // reserved
        0x04, // size index 4: time [s]
        0xFD, // conversion index -3: milli
        0x62, // BCC
    ];
    let (t, _) = decode(&resp).unwrap();
    let scale = t.param().unwrap().scale().unwrap();
    assert_eq!(
        scale,
        ScaleInfo {
            size_index: 4,
            conversion_index: -3
        }
    );
    // 3000 × 10^-3 s = 3 s.
    assert_eq!(3000.0 * 10f64.powi(scale.conversion_index.into()), 3.0);
}

/// Ch. 4.3 "Lesen eines Parameters" / "Schreiben eines Parameters" and an error answer with
/// the structured return code (ch. 6.2: class 8, code 0, additional 0x0015 "value too large").
#[test]
fn ch_4_3_read_write_and_error_answer() {
    let read = [
        0x02, 0x01, 0x86, //        SD1, ADR 1, TYP PARAM+0PD acyclic
        0x31, //                    management: 4 bytes, Read
        0x00, 0x21, 0x17, //        subindex, index 0x2117
        0x00, 0x00, 0x00, 0x00, //  data (ignored for reads)
        0x82, //                    BCC
    ];
    round_trip(
        &Telegram::request(addr(1), PduType::PARAM_0PD_ACYCLIC)
            .with_param(ParamChannel::read(8471)),
        &read,
    );
    let answer = [
        0x1D, 0x01, 0x86, //        SD2, ADR 1, TYP
        0x31, //                    management echoed, status 0
        0x00, 0x21, 0x17, //        subindex, index
        0x00, 0x00, 0x0B, 0xB8, //  data: 3000
        0x2E, //                    BCC
    ];
    assert_eq!(
        decode(&answer).unwrap().0.param().unwrap().result(),
        Ok(3000)
    );
    let write = [
        0x02, 0x01, 0x86, //        SD1, ADR 1, TYP
        0x32, //                    management: 4 bytes, Write
        0x00, 0x21, 0x17, //        subindex, index
        0x00, 0x00, 0x0B, 0xB8, //  data 3000, MSB first
        0x32, //                    BCC
    ];
    round_trip(
        &Telegram::request(addr(1), PduType::PARAM_0PD_ACYCLIC)
            .with_param(ParamChannel::write(8471, 3000)),
        &write,
    );
    let error = [
        0x1D, 0x01, 0x86, //        SD2, ADR 1, TYP
        0xB2, //                    management: status bit 7 set, Write
        0x00, 0x21, 0x17, //        subindex, index
        0x08, //                    error class 8: other
        0x00, //                    error code 0
        0x00, 0x15, //              additional code 0x0015: value too large
        0x03, //                    BCC
    ];
    let p = decode(&error).unwrap().0.param().unwrap();
    assert!(p.management.is_error());
    assert_eq!(p.service(), Some(Service::Write));
    assert_eq!(p.result(), Err(ReturnCode::VALUE_TOO_LARGE));
    assert_eq!(
        p.result().unwrap_err().meaning().map(|m| m.en),
        Some("value for parameter too large")
    );
}

/// Ch. 5.2/6.2 special cases of the return codes.
#[test]
fn ch_5_2_and_6_2_special_return_codes() {
    assert_eq!(
        ReturnCode::from_data(0x0505_0000),
        ReturnCode::ILLEGAL_SERVICE_CODING
    );
    assert_eq!(
        ReturnCode::from_data(0x0602_0000),
        ReturnCode::INTERNAL_COMMUNICATION_ERROR
    );
    let table: [(u16, ReturnCode); 17] = [
        (0x10, ReturnCode::ILLEGAL_INDEX),
        (0x11, ReturnCode::NOT_IMPLEMENTED),
        (0x12, ReturnCode::READ_ONLY),
        (0x13, ReturnCode::PARAMETER_LOCK),
        (0x14, ReturnCode::FACTORY_SETTING_ACTIVE),
        (0x15, ReturnCode::VALUE_TOO_LARGE),
        (0x16, ReturnCode::VALUE_TOO_SMALL),
        (0x17, ReturnCode::OPTION_CARD_MISSING),
        (0x18, ReturnCode::SYSTEM_SOFTWARE_ERROR),
        (0x19, ReturnCode::ONLY_VIA_RS485_PROCESS_INTERFACE),
        (0x1A, ReturnCode::ONLY_VIA_RS485_DIAGNOSTIC_INTERFACE),
        (0x1B, ReturnCode::ACCESS_PROTECTED),
        (0x1C, ReturnCode::CONTROLLER_INHIBIT_REQUIRED),
        (0x1D, ReturnCode::INVALID_VALUE),
        (0x1E, ReturnCode::FACTORY_SETTING_ACTIVATED),
        (0x1F, ReturnCode::NOT_STORED_IN_EEPROM),
        (0x20, ReturnCode::OUTPUT_STAGE_ENABLED),
    ];
    for (code, rc) in table {
        assert_eq!(ReturnCode::from_data(0x0800_0000 | u32::from(code)), rc);
    }
}

/// PARAM + 3PD (the longest telegram, 18 bytes): read P000 plus the three process data words
/// of the application example.
#[test]
fn param_3pd_acyclic_layout() {
    let wire = [
        0x02, 0x01, 0x84, //        SD1, ADR 1, TYP PARAM+3PD acyclic
        0x31, 0x00, 0x20, 0x7E, //  management Read, subindex, index 0x207E = 8318 (P000)
        0x00, 0x00, 0x00, 0x00, //  data
        0x00, 0x06, //              PA1
        0x20, 0x00, //              PA2
        0x0B, 0xB8, //              PA3
        0x7D, //                    BCC
    ];
    let t = Telegram::request(addr(1), PduType::PARAM_3PD_ACYCLIC)
        .with_param(ParamChannel::read(8318))
        .with_process_data(&[0x0006, 0x2000, 0x0BB8]);
    round_trip(&t, &wire);
}
