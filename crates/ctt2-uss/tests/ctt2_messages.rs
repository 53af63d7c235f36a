//! CTT2 messages: the manual's examples of sections 4.3.1 to 4.3.5 and 5.1 as vectors (a
//! comment per byte), the length and index rules of 4.3.5, erratum E3 (157, and 177 as an
//! alias), and property tests (round trips, decoders never panic).

#![allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)]

use ctt2_uss::ctt2::message::{code, error_code, ok_code, request_code};
use ctt2_uss::ctt2::{
    Channel, DRIVE_ADDRESS, Data, DecodeError, DiagnosisCode, DiagnosisObject, EncodeError,
    ErrorCode, IdObject, MAX_DATA, ObjectError, Request, Response, StandardIndex,
};
use ctt2_uss::uss::{Ind, Pkw, PzdIn, PzdOut};
use drive_profile::nord::{self, ControlWord, Ctt2MessageType, Ctt2Role, StatusWord};
use proptest::prelude::*;

fn enc_req(r: &Request) -> Vec<u8> {
    let mut b = [0u8; 32];
    let n = r.encode(&mut b).unwrap();
    b[..n].to_vec()
}

fn enc_resp(r: &Response) -> Vec<u8> {
    let mut b = [0u8; 32];
    let n = r.encode(&mut b).unwrap();
    b[..n].to_vec()
}

fn ok(kind: Ctt2MessageType, data: &[u8]) -> Response {
    Response::Ok {
        kind,
        data: Data::new(data).unwrap(),
    }
}

#[test]
fn codes_agree_with_the_generated_table() {
    use Ctt2MessageType::*;
    for kind in [StandardRead, NordRead, NordWrite, NordWriteRead] {
        assert_eq!(
            Some(request_code(kind)),
            nord::ctt2_code(kind, Ctt2Role::Request)
        );
        assert_eq!(
            Some(ok_code(kind)),
            nord::ctt2_code(kind, Ctt2Role::ResponseOk)
        );
        assert_eq!(
            Some(error_code(kind)),
            nord::ctt2_code(kind, Ctt2Role::ResponseError)
        );
    }
    assert_eq!(error_code(NordWriteRead), 157);
    assert_eq!(
        nord::ctt2_message(157).unwrap().printed,
        Some(code::NORD_WRITE_READ_ERROR_PRINTED)
    );
    for (index, max) in [(0, 14), (1, 3)] {
        let i = StandardIndex::from_index(index).unwrap();
        assert_eq!(i.max_len(), max);
        assert_eq!(nord::ctt2_index(index).unwrap().max_len, max);
    }
    for c in [Channel::Pzd, Channel::PkwWithAddress, Channel::Pkw] {
        let row = nord::ctt2_index(c.index()).unwrap();
        assert_eq!(c.max_len(), row.max_len);
        assert_eq!(c.has_address(), row.address);
        for len in 0..=20u8 {
            assert_eq!(
                c.write_len_ok(len),
                row.write_lengths.contains(&len),
                "{c:?} {len}"
            );
        }
    }
    for e in 1..=5 {
        let code = ErrorCode::from_code(e).unwrap();
        assert_eq!(code.code(), e);
        assert_eq!(code.info().unwrap().code, e);
    }
    assert_eq!(ErrorCode::from_code(0), None);
    assert_eq!(ErrorCode::from_code(6), None);
    assert_eq!(
        ErrorCode::Busy.to_string(),
        "CTT2 error 4: busy (request not completed within the time window of 200 ms)"
    );
}

/// Section 4.3.1: reading the ID object, its answer, and the negative answer "busy".
#[test]
fn manual_4_3_1_id_object() {
    let request = [
        16, // code: standard read
        0,  // index: ID object
        14, // length
    ];
    let r = Request::decode(&request).unwrap();
    assert_eq!(
        r,
        Request::StandardRead {
            index: StandardIndex::Id,
            len: 14
        }
    );
    assert_eq!(enc_req(&r), request);

    // The answer: 80, manufacturer ID 1, 137, … (the rest is not printed; these are the
    // simulated drive's bytes).
    let answer = [
        80,   // code: standard read OK
        1,    // manufacturer ID, high byte
        137,  // manufacturer ID, low byte
        0x02, // device ID, high byte
        0x80, // device ID, low byte
        0x07, // I/O configuration
        0x01, // AS-i mode
        0x10, // AS-i firmware
        0x01, // drive firmware version
        0x00, // drive firmware revision
        0x00, // power, high byte
        0x37, // power, low byte
        0x01, // voltage range
        0x00, // configuration level, high byte
        0x01, // configuration level, low byte
    ];
    let a = Response::decode(&answer).unwrap();
    let Response::Ok { kind, data } = a else {
        panic!("{a:?}")
    };
    assert_eq!(kind, Ctt2MessageType::StandardRead);
    let id = IdObject::decode(data.as_slice()).unwrap();
    assert_eq!(id.manufacturer_id, Some(0x0189)); // 1 × 256 + 137
    assert_eq!(id.device_id, Some(0x0280));
    assert_eq!(id.io_config, Some(7));
    assert_eq!(id.power, Some(0x37));
    assert_eq!(id.configuration_level, Some(1));
    assert!(id.is_complete());
    assert_eq!(id.to_bytes().unwrap(), answer[1..]);
    assert_eq!(id.to_data().as_slice(), &answer[1..]);
    assert_eq!(enc_resp(&a), answer);

    // A shorter read returns only the first bytes: 3 bytes = manufacturer ID and half of the
    // device ID, which stays unknown.
    let short = IdObject::decode(&answer[1..4]).unwrap();
    assert_eq!(short.manufacturer_id, Some(0x0189));
    assert_eq!(short.device_id, None);
    assert_eq!(short.io_config, None);
    assert_eq!(short.to_data().as_slice(), &answer[1..3]);
    assert_eq!(
        IdObject::decode(&[0; 15]),
        Err(ObjectError::TooLong { max: 14, got: 15 })
    );

    let busy = [
        144, // code: standard read not OK
        4,   // error code: busy
    ];
    let a = Response::decode(&busy).unwrap();
    assert_eq!(
        a,
        Response::error(Ctt2MessageType::StandardRead, ErrorCode::Busy)
    );
    assert_eq!(enc_resp(&a), busy);
}

/// Section 4.3.1: reading the diagnosis object and its answer (no fault, fault 0, 45 °C).
#[test]
fn manual_4_3_1_diagnosis_object() {
    let request = [
        16, // code: standard read
        1,  // index: diagnosis object
        3,  // length
    ];
    let r = Request::decode(&request).unwrap();
    assert_eq!(
        r,
        Request::StandardRead {
            index: StandardIndex::Diagnosis,
            len: 3
        }
    );
    assert_eq!(enc_req(&r), request);
    let answer = [
        80, // code: standard read OK
        0,  // diagnosis code: no fault
        0,  // fault number of the drive
        45, // microcontroller temperature
    ];
    let Response::Ok { data, .. } = Response::decode(&answer).unwrap() else {
        panic!()
    };
    let d = DiagnosisObject::decode(data.as_slice()).unwrap();
    assert_eq!(d, DiagnosisObject::new(DiagnosisCode::NoFault, 0, 45));
    assert_eq!(d.to_data().as_slice(), &answer[1..]);
    assert_eq!(
        d.to_string(),
        "no fault, fault number 0, microcontroller at 45 °C"
    );
    assert_eq!(DiagnosisCode::from_byte(255), DiagnosisCode::Fault);
    assert_eq!(DiagnosisCode::from_byte(7), DiagnosisCode::Other(7));
    assert_eq!(
        DiagnosisObject::decode(&[255]).unwrap().fault,
        None,
        "a 1-byte read has only the code"
    );
    assert_eq!(
        DiagnosisObject::decode(&[0, 0, 45, 0]),
        Err(ObjectError::TooLong { max: 3, got: 4 }),
        "the diagnosis object has 3 bytes"
    );
}

/// Section 4.3.2: reading the process data (ZSW, IW1–IW3) and the answer, with the status
/// word of example 5.1.1 (ready to switch on).
#[test]
fn manual_4_3_2_read_process_data() {
    let request = [
        18, // code: NORD read
        3,  // index: PZD channel
        9,  // length: address + ZSW + IW1..IW3
    ];
    let r = Request::decode(&request).unwrap();
    assert_eq!(
        r,
        Request::NordRead {
            index: Channel::Pzd,
            len: 9
        }
    );
    assert_eq!(enc_req(&r), request);
    let answer = [
        82,   // code: NORD read OK
        1,    // USS address of the drive
        0x0B, // ZSW high byte (bits 8..15)
        0x31, // ZSW low byte (bits 0..7): ready to switch on (5.1.1)
        0x00, // IW1 high byte
        0x00, // IW1 low byte
        0x00, // IW2 high byte
        0x00, // IW2 low byte
        0x00, // IW3 high byte
        0x00, // IW3 low byte
    ];
    let a = Response::decode(&answer).unwrap();
    let Response::Ok { kind, data } = a else {
        panic!()
    };
    assert_eq!(kind, Ctt2MessageType::NordRead);
    let pzd = data.to_pzd_in().unwrap();
    assert_eq!(pzd.status(), StatusWord(0x0B31));
    assert_eq!(pzd.actuals(), &[0, 0, 0]);
    assert_eq!(Data::from_pzd_in(&pzd).as_slice(), &answer[1..]);
    assert_eq!(enc_resp(&a), answer);
}

/// Section 4.3.3 with the order of example 5.1.3 (P102 := 10.00 s in parameter set 3, IND
/// corrected by erratum E4) on the PKW channel without and with address.
#[test]
fn manual_4_3_3_write_parameter_order() {
    let request = [
        19,   // code: NORD write
        47,   // index: PKW channel without address
        8,    // write length
        0x70, // PKE high: AK 7 (change, array word), PNU bits 8..10 = 0
        0x66, // PKE low: PNU 66h = P102
        0x02, // IND high: parameter set 3 (bits 8..9 = 2) (E4: the manual prints 00h 02h)
        0x00, // IND low
        0x00, // PWE1 high
        0x00, // PWE1 low
        0x03, // PWE2 high
        0xE8, // PWE2 low: 3E8h = 1000 = 10.00 s at 0.01 s
    ];
    let r = Request::decode(&request).unwrap();
    let Request::NordWrite { index, data } = r else {
        panic!()
    };
    assert_eq!(index, Channel::Pkw);
    let pkw = data.to_pkw(Channel::Pkw).unwrap();
    assert_eq!(pkw.pke.ak(), 7);
    assert_eq!(pkw.pke.pnu(), 102);
    assert_eq!(pkw.ind, Ind::new(0, 2).unwrap());
    assert_eq!(pkw.pwe2, 1000);
    assert_eq!(enc_req(&r), request);

    // The same order on index 4: the address 1 first, 9 bytes.
    let with_address = Request::NordWrite {
        index: Channel::PkwWithAddress,
        data: Data::from_pkw(Channel::PkwWithAddress, &pkw).unwrap(),
    };
    let bytes = enc_req(&with_address);
    assert_eq!(&bytes[..4], &[19, 4, 9, DRIVE_ADDRESS]);
    assert_eq!(&bytes[4..], &request[3..]);
    assert_eq!(Request::decode(&bytes), Ok(with_address));

    let answer = [83]; // code: NORD write OK (nothing about the order)
    let a = Response::decode(&answer).unwrap();
    assert_eq!(a, ok(Ctt2MessageType::NordWrite, &[]));
    assert_eq!(enc_resp(&a), answer);
    assert_eq!(
        Response::decode(&[83, 0]),
        Err(DecodeError::TooLong {
            code: 83,
            max: 1,
            got: 2
        })
    );
}

/// Section 4.3.4: write STW and SW1–SW3, read ZSW, IW1 and IW2 in one message.
#[test]
fn manual_4_3_4_write_read_process_data() {
    let request = [
        29,   // code: NORD write/read
        3,    // index: PZD channel
        7,    // read length: address + ZSW + IW1 + IW2 (erratum E11: read length first)
        9,    // write length: address + STW + SW1..SW3
        1,    // drive address
        0x04, // STW high byte
        0x7F, // STW low byte: enable operation (5.1.2)
        0x20, // SW1 high byte
        0x00, // SW1 low byte: 2000h = 50 %
        0x00, // SW2 high byte
        0x00, // SW2 low byte
        0x00, // SW3 high byte
        0x00, // SW3 low byte
    ];
    let r = Request::decode(&request).unwrap();
    let Request::NordWriteRead {
        index,
        read_len,
        data,
    } = r
    else {
        panic!()
    };
    assert_eq!((index, read_len), (Channel::Pzd, 7));
    let out = data.to_pzd_out().unwrap();
    assert_eq!(out.control(), ControlWord(0x047F));
    assert_eq!(out.setpoints(), &[0x2000, 0, 0]);
    assert_eq!(Data::from_pzd_out(&out).as_slice(), &request[4..]);
    assert_eq!(enc_req(&r), request);

    let answer = [
        93,   // code: NORD write/read OK
        1,    // drive address
        0x0B, // ZSW high byte
        0x37, // ZSW low byte: operation enabled, setpoint reached (5.1.2)
        0x20, // IW1 high byte
        0x00, // IW1 low byte: 50 %
        0x00, // IW2 high byte
        0x00, // IW2 low byte
    ];
    let a = Response::decode(&answer).unwrap();
    let Response::Ok { kind, data } = a else {
        panic!()
    };
    assert_eq!(kind, Ctt2MessageType::NordWriteRead);
    let pzd = data.to_pzd_in().unwrap();
    assert_eq!(pzd.status(), StatusWord(0x0B37));
    assert_eq!(pzd.actuals(), &[0x2000, 0]);
    assert_eq!(enc_resp(&a), answer);
}

/// Erratum E3: the negative write/read answer is 157; the manual's 177 is decoded as an alias
/// with `code_177` set, and written back as 177.
#[test]
fn e3_negative_write_read_answer_157_and_177() {
    let right = [
        157, // code: NORD write/read not OK (29 + 80h)
        2,   // error code: invalid length
    ];
    let a = Response::decode(&right).unwrap();
    assert_eq!(
        a,
        Response::Error {
            kind: Ctt2MessageType::NordWriteRead,
            error: ErrorCode::InvalidLength,
            code_177: false
        }
    );
    assert_eq!(enc_resp(&a), right);
    let printed = [
        177, // code as printed in section 4.3.4 (E3)
        2,   // error code: invalid length
    ];
    let a = Response::decode(&printed).unwrap();
    assert_eq!(
        a,
        Response::Error {
            kind: Ctt2MessageType::NordWriteRead,
            error: ErrorCode::InvalidLength,
            code_177: true
        }
    );
    assert_eq!(a.kind(), Ctt2MessageType::NordWriteRead);
    assert_eq!(enc_resp(&a), printed);
    // 177 exists only for the write/read answer.
    let bad = Response::Error {
        kind: Ctt2MessageType::NordRead,
        error: ErrorCode::Busy,
        code_177: true,
    };
    assert_eq!(
        bad.encode(&mut [0; 4]),
        Err(EncodeError::Code177NotWriteRead)
    );
}

/// Examples 5.1.1 to 5.1.5 carried in CTT2 messages (the manual shows only the USS part).
#[test]
fn manual_5_1_examples_in_ctt2() {
    // 5.1.1: STW 047Eh, SW1 0 as a PZD write; the answer ZSW 0B31h, IW1 0 as a PZD read.
    let w = Request::NordWrite {
        index: Channel::Pzd,
        data: Data::from_pzd_out(&PzdOut::new(ControlWord(0x047E), &[0])),
    };
    assert_eq!(
        enc_req(&w),
        [
            19,   // NORD write
            3,    // PZD channel
            5,    // length: address + STW + SW1
            1,    // drive address
            0x04, // STW high
            0x7E, // STW low: shut down → ready to switch on
            0x00, // SW1 high
            0x00, // SW1 low
        ]
    );
    let read_answer = [
        82,   // NORD read OK
        1,    // drive address
        0x0B, // ZSW high
        0x31, // ZSW low: ready to switch on
        0x00, // IW1 high
        0x00, // IW1 low
    ];
    let Response::Ok { data, .. } = Response::decode(&read_answer).unwrap() else {
        panic!()
    };
    assert_eq!(
        data.to_pzd_in().unwrap(),
        PzdIn::new(StatusWord(0x0B31), &[0])
    );

    // 5.1.2: STW 047Fh, SW1 2000h; the answer 0B37h, IW1 2000h.
    let w = Request::NordWrite {
        index: Channel::Pzd,
        data: Data::from_pzd_out(&PzdOut::new(ControlWord(0x047F), &[0x2000])),
    };
    assert_eq!(
        enc_req(&w),
        [
            19,   // NORD write
            3,    // PZD channel
            5,    // length
            1,    // drive address
            0x04, // STW high
            0x7F, // STW low: enable operation
            0x20, // SW1 high: 50 %
            0x00, // SW1 low
        ]
    );

    // 5.1.3: the answer once the order is done, read from the PKW channel (IND per E4).
    let answer = [
        82,   // NORD read OK
        0x40, // PKE high: AK 4 (array word value)
        0x66, // PKE low: P102
        0x02, // IND high: parameter set 3
        0x00, // IND low
        0x00, // PWE1 high
        0x00, // PWE1 low
        0x03, // PWE2 high
        0xE8, // PWE2 low: 1000
    ];
    let Response::Ok { data, .. } = Response::decode(&answer).unwrap() else {
        panic!()
    };
    let pkw = data.to_pkw(Channel::Pkw).unwrap();
    assert_eq!(pkw.words(), [0x4066, 0x0200, 0x0000, 0x03E8]);

    // 5.1.4: read P701 [-01] (E5: PKE 12BDh), on index 47.
    let p701 = Pkw::from_words([0x12BD, 0, 0, 0]);
    let r = Request::NordWrite {
        index: Channel::Pkw,
        data: Data::from_pkw(Channel::Pkw, &p701).unwrap(),
    };
    assert_eq!(
        enc_req(&r),
        [
            19,   // NORD write
            47,   // PKW without address
            8,    // length
            0x12, // PKE high: AK 1 (read), PNU bits 8..10 = 2
            0xBD, // PKE low: PNU 2BDh = 701
            0x00, // IND high
            0x00, // IND low
            0x00, // PWE1 high
            0x00, // PWE1 low
            0x00, // PWE2 high
            0x00, // PWE2 low
        ]
    );

    // 5.1.5: P102 := 2.5 s in parameter set 2 (E6), on index 4 with address.
    let p102 = Pkw::from_words([0x2066, 0x0100, 0, 0x00FA]);
    let r = Request::NordWrite {
        index: Channel::PkwWithAddress,
        data: Data::from_pkw(Channel::PkwWithAddress, &p102).unwrap(),
    };
    assert_eq!(
        enc_req(&r),
        [
            19,   // NORD write
            4,    // PKW with address
            9,    // length: address + 8
            1,    // drive address
            0x20, // PKE high: AK 2 (change word)
            0x66, // PKE low: P102
            0x01, // IND high: parameter set 2
            0x00, // IND low
            0x00, // PWE1 high
            0x00, // PWE1 low
            0x00, // PWE2 high
            0xFA, // PWE2 low: 250 = 2.50 s
        ]
    );
}

/// Section 4.3.5: which error each malformed request gets.
#[test]
fn manual_4_3_5_request_errors() {
    let err = |b: &[u8]| Request::decode(b).unwrap_err();
    let answer = |b: &[u8]| enc_resp(&err(b).answer());
    // Error 1: invalid index.
    assert_eq!(
        err(&[16, 2, 3]),
        DecodeError::InvalidIndex { code: 16, index: 2 }
    );
    assert_eq!(answer(&[16, 3, 3]), [144, 1]);
    assert_eq!(answer(&[18, 0, 3]), [146, 1]);
    assert_eq!(answer(&[19, 5, 0]), [147, 1]);
    assert_eq!(answer(&[29, 48, 8, 8]), [157, 1]);
    assert_eq!(
        answer(&[18, 46]),
        [146, 1],
        "index checked before the length"
    );
    // Error 2: invalid length.
    assert_eq!(
        err(&[19, 47, 9, 0, 0, 0, 0, 0, 0, 0, 0, 0]),
        DecodeError::BadWriteLength {
            code: 19,
            index: 47,
            len: 9
        }
    );
    assert_eq!(answer(&[19, 4, 8, 1, 0, 0, 0, 0, 0, 0, 0]), [147, 2]);
    assert_eq!(
        answer(&[19, 3, 4, 1, 4, 0x7E, 0]),
        [147, 2],
        "half a setpoint"
    );
    assert_eq!(answer(&[19, 3, 1, 1]), [147, 2], "address without STW");
    assert_eq!(
        err(&[19, 3, 5, 1, 4, 0x7E]),
        DecodeError::LengthMismatch {
            code: 19,
            declared: 5,
            present: 3
        }
    );
    assert_eq!(answer(&[29, 3, 9, 3, 1, 4, 0x7E, 0]), [157, 2]);
    assert_eq!(answer(&[16, 0]), [144, 2]);
    assert_eq!(answer(&[16, 0, 14, 0]), [144, 2]);
    assert_eq!(answer(&[29, 3, 9]), [157, 2]);
    // Error 3: request not implemented, answered as a standard read.
    assert_eq!(err(&[17, 0, 3]), DecodeError::UnknownCode(17));
    assert_eq!(answer(&[17, 0, 3]), [144, 3]);
    assert_eq!(answer(&[80, 1]), [144, 3], "an answer code as a request");
    assert_eq!(answer(&[]), [144, 3]);
    // Reads of any length are valid (shorter: only that; longer: only the object).
    for len in [0, 1, 14, 200, 255] {
        assert!(Request::decode(&[16, 0, len]).is_ok());
        assert!(Request::decode(&[18, 47, len]).is_ok());
    }
}

#[test]
fn encode_refuses_what_the_drive_would_refuse() {
    let r = Request::NordWrite {
        index: Channel::Pkw,
        data: Data::new(&[0; 9]).unwrap(),
    };
    assert_eq!(
        r.encode(&mut [0; 32]),
        Err(EncodeError::BadWriteLength { index: 47, len: 9 })
    );
    let r = Request::NordRead {
        index: Channel::Pzd,
        len: 9,
    };
    assert_eq!(
        r.encode(&mut [0; 2]),
        Err(EncodeError::BufferTooSmall { needed: 3, got: 2 })
    );
    assert_eq!(
        ok(Ctt2MessageType::NordWrite, &[1]).encode(&mut [0; 4]),
        Err(EncodeError::DataOnWriteAnswer(1))
    );
    assert!(Data::new(&[0; MAX_DATA + 1]).is_none());
    assert_eq!(
        Data::from_pkw(Channel::Pzd, &Pkw::default()),
        Err(ObjectError::WrongChannel(3))
    );
    let d = Data::new(&[2, 0x04, 0x7E]).unwrap();
    assert_eq!(d.to_pzd_out(), Err(ObjectError::BadAddress(2)));
    assert_eq!(Data::EMPTY.to_pzd_in(), Err(ObjectError::MissingAddress));
    assert_eq!(
        Data::new(&[0; 7]).unwrap().to_pkw(Channel::Pkw),
        Err(ObjectError::IncompletePkw(7))
    );
}

fn channel() -> impl Strategy<Value = Channel> {
    prop_oneof![
        Just(Channel::Pzd),
        Just(Channel::PkwWithAddress),
        Just(Channel::Pkw)
    ]
}

fn write_data(c: Channel) -> impl Strategy<Value = Data> {
    let lens: Vec<usize> = match c {
        Channel::Pzd => vec![3, 5, 7, 9],
        Channel::PkwWithAddress => vec![9],
        Channel::Pkw => vec![8],
    };
    proptest::sample::select(lens)
        .prop_flat_map(|n| proptest::collection::vec(any::<u8>(), n))
        .prop_map(|v| Data::new(&v).unwrap())
}

fn request() -> impl Strategy<Value = Request> {
    prop_oneof![
        (
            prop_oneof![Just(StandardIndex::Id), Just(StandardIndex::Diagnosis)],
            any::<u8>()
        )
            .prop_map(|(index, len)| Request::StandardRead { index, len }),
        (channel(), any::<u8>()).prop_map(|(index, len)| Request::NordRead { index, len }),
        channel().prop_flat_map(
            |c| write_data(c).prop_map(move |data| Request::NordWrite { index: c, data })
        ),
        (channel(), any::<u8>()).prop_flat_map(|(c, read_len)| write_data(c).prop_map(
            move |data| Request::NordWriteRead {
                index: c,
                read_len,
                data
            }
        )),
    ]
}

fn kind() -> impl Strategy<Value = Ctt2MessageType> {
    prop_oneof![
        Just(Ctt2MessageType::StandardRead),
        Just(Ctt2MessageType::NordRead),
        Just(Ctt2MessageType::NordWrite),
        Just(Ctt2MessageType::NordWriteRead)
    ]
}

fn response() -> impl Strategy<Value = Response> {
    prop_oneof![
        (kind(), proptest::collection::vec(any::<u8>(), 0..=MAX_DATA)).prop_map(|(kind, v)| {
            let data = if kind == Ctt2MessageType::NordWrite {
                Data::EMPTY
            } else {
                Data::new(&v).unwrap()
            };
            Response::Ok { kind, data }
        }),
        (kind(), 1u8..=5, any::<bool>()).prop_map(|(kind, e, c177)| Response::Error {
            kind,
            error: ErrorCode::from_code(e).unwrap(),
            code_177: c177 && kind == Ctt2MessageType::NordWriteRead,
        }),
    ]
}

proptest! {
    #[test]
    fn request_round_trip(r in request()) {
        let bytes = enc_req(&r);
        prop_assert_eq!(bytes.len(), r.encoded_len());
        prop_assert_eq!(Request::decode(&bytes), Ok(r));
    }

    #[test]
    fn response_round_trip(r in response()) {
        let bytes = enc_resp(&r);
        prop_assert_eq!(bytes.len(), r.encoded_len());
        prop_assert_eq!(Response::decode(&bytes), Ok(r));
    }

    #[test]
    fn decoders_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..40)) {
        if let Ok(r) = Request::decode(&bytes) {
            prop_assert_eq!(enc_req(&r), bytes.clone());
        } else if let Err(e) = Request::decode(&bytes) {
            // Every failure has an answer of the right form.
            let a = enc_resp(&e.answer());
            prop_assert_eq!(a.len(), 2);
        }
        if let Ok(r) = Response::decode(&bytes) {
            prop_assert_eq!(enc_resp(&r), bytes.clone());
        }
        let _ = IdObject::decode(&bytes);
        let _ = DiagnosisObject::decode(&bytes);
        if let Some(d) = Data::new(&bytes) {
            let _ = d.to_pzd_in();
            let _ = d.to_pzd_out();
            let _ = d.to_pkw(Channel::Pkw);
            let _ = d.to_pkw(Channel::PkwWithAddress);
        }
    }

    #[test]
    fn objects_round_trip(b in proptest::array::uniform14(any::<u8>()), n in 0usize..=14) {
        let id = IdObject::from_bytes(&b);
        prop_assert_eq!(IdObject::decode(&b), Ok(id));
        prop_assert_eq!(id.to_data().as_slice().to_vec(), b.to_vec());
        // A prefix decodes to fields that re-encode to the longest whole-field prefix.
        let part = IdObject::decode(&b[..n]).unwrap();
        let again = part.to_data();
        prop_assert!(again.len() <= n && n - again.len() <= 1);
        prop_assert_eq!(again.as_slice(), &b[..again.len()]);
        let d = DiagnosisObject::decode(&b[..n.min(3)]).unwrap();
        prop_assert_eq!(d.to_data().as_slice().to_vec(), b[..n.min(3)].to_vec());
    }
}
