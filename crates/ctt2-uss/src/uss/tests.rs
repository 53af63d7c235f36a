//! The manual's parameter-channel examples (BU 0255 sections 4.6.1.2 and 5.1) as vectors, and
//! the plausibility check.

#![allow(clippy::unwrap_used, clippy::indexing_slicing)]

use drive_profile::nord::{ControlWord, StatusWord, Width};

use super::DriveError;
use super::pkw::{
    Ind, IndLayout, Order, OrderKind, Pke, Pkw, PkwError, Plausibility, Reply, Storage,
};
use super::pzd::{PzdError, PzdIn, PzdOut, position_from_words, position_to_words};

/// 5.1.3 "Parameter ändern": P102 = 10 s in parameter set 3, with IND corrected as erratum E4
/// says (the manual prints the IND bytes swapped).
#[test]
fn manual_5_1_3_order_and_answer() {
    let order_bytes = [
        0x70, 0x66, // PKE: AK 7 (change value, array, word), PNU 66h = P102
        0x02, 0x00, // IND: bits 8–9 = 2 → parameter set 3 (E4: printed 00h 02h)
        0x00, 0x00, // PWE1: high word 0 (positive word value)
        0x03, 0xE8, // PWE2: 3E8h = 1000 = 10.00 s at 0.01 s
    ];
    let pkw = Pkw::decode(&order_bytes).unwrap();
    assert_eq!(pkw.pke.ak(), 7);
    assert_eq!(pkw.pke.pnu(), 102);
    assert_eq!(pkw.ind.set(), 2);
    let order = Order::from_pkw(&pkw).unwrap();
    assert_eq!(
        order.kind(),
        OrderKind::Write {
            width: Width::Word,
            array: true,
            storage: Storage::Eeprom,
            value: 1000
        }
    );
    // The same order built from its meaning gives the same bytes.
    let built = Order::write(
        102,
        Ind::new(0, 2).unwrap(),
        Width::Word,
        true,
        Storage::Eeprom,
        1000,
    )
    .unwrap();
    assert_eq!(built.to_pkw().to_bytes(), order_bytes);

    let answer = [
        0x40, 0x66, // PKE: AK 4 (value transferred, array, word), PNU 102
        0x02, 0x00, // IND as in the order
        0x00, 0x00, 0x03, 0xE8, // the value written
    ];
    let answer = Pkw::decode(&answer).unwrap();
    assert_eq!(
        order.check(&answer),
        Plausibility::Answer(Reply::Value {
            width: Width::Word,
            array: true,
            value: 1000
        })
    );
}

/// 5.1.4: read P701 element [-01] (E5: the bytes are 12h BDh).
#[test]
fn manual_5_1_4_read_p701() {
    let order = Order::read(701, Ind::ZERO).unwrap();
    assert_eq!(
        order.to_pkw().to_bytes(),
        [
            0x12, 0xBD, // PKE 12BDh: AK 1, PNU 2BDh = 701
            0x00, 0x00, // IND 0
            0x00, 0x00, 0x00, 0x00 // PWE unused in a read
        ]
    );
}

/// 5.1.5: write P102 = 2.5 s with "index 1" = parameter set 2 (E6).
#[test]
fn manual_5_1_5_write_p102() {
    let bytes = [
        0x20, 0x66, // PKE 2066h: AK 2 (change value, word), PNU 102
        0x01, 0x00, // IND 0100h: parameter set 2
        0x00, 0x00, 0x00, 0xFA, // 250 = 2.50 s
    ];
    let order = Order::from_pkw(&Pkw::decode(&bytes).unwrap()).unwrap();
    assert_eq!(order.ak(), 2);
    assert_eq!(order.ind().set(), 1);
    assert_eq!(
        order.kind(),
        OrderKind::Write {
            width: Width::Word,
            array: false,
            storage: Storage::Eeprom,
            value: 250
        }
    );
}

/// 4.6.1.2: the two IND examples (E9: raw array fields 5 and 21, sets 2 and 4).
#[test]
fn manual_4_6_1_2_ind_examples() {
    assert_eq!(Ind::new(5, 1).unwrap().0, 0x1500);
    assert_eq!(Ind::new(21, 3).unwrap().0, 0x5700);
    assert_eq!(Ind(0x5700).element(), 21);
    assert_eq!(Ind(0x5700).set(), 3);
    assert_eq!(Ind::subindex(0x57).sub(), 0x57);
    assert_eq!(Ind::new(64, 0), None);
    assert_eq!(Ind::new(0, 4), None);
}

/// 4.6.1.2: a parameter without parameter sets takes bits 8–15 as its sub-index; one with
/// parameter sets has the set in bits 8–9 and the element in bits 10–15.
#[test]
fn ind_layout_follows_the_table() {
    assert_eq!(IndLayout::of_pnu(102), IndLayout::ParameterSets); // P102 per parameter set
    assert_eq!(IndLayout::of_pnu(543), IndLayout::Subindex); // P543 [-01]..[-03], no sets
    assert_eq!(IndLayout::of_pnu(2000), IndLayout::Subindex); // not in the table
    // P543 [-02]: sub-index 1 in bits 8–15.
    assert_eq!(Ind::address(IndLayout::Subindex, 1, 0), Some(Ind(0x0100)));
    assert_eq!(Ind(0x0100).split(IndLayout::Subindex, true), (1, 0));
    assert_eq!(Ind(0x0100).split(IndLayout::Subindex, false), (0, 0));
    assert_eq!(Ind::address(IndLayout::Subindex, 1, 1), None);
    assert_eq!(Ind::address(IndLayout::Subindex, 255, 0), Some(Ind(0xFF00)));
    // P102 set 3, and element [-06] of set 2 (the manual's first IND example).
    assert_eq!(
        Ind::address(IndLayout::ParameterSets, 0, 2),
        Some(Ind(0x0200))
    );
    assert_eq!(Ind(0x1500).split(IndLayout::ParameterSets, true), (5, 1));
    assert_eq!(Ind(0x1500).split(IndLayout::ParameterSets, false), (0, 1));
    assert_eq!(Ind::address(IndLayout::ParameterSets, 64, 0), None);
}

#[test]
fn pke_fields() {
    let p = Pke(0x7866);
    assert_eq!((p.ak(), p.spm(), p.pnu()), (7, true, 0x66));
    assert_eq!(Pke::new(16, 0), None);
    assert_eq!(Pke::new(1, 2048), None);
    assert_eq!(Pke::new(15, 2047), Some(Pke(0xF7FF))); // SPM (bit 11) stays 0
}

/// 4.6.1.3: negative words have FFFFh in PWE1; values past a word are refused, never cut.
#[test]
fn word_values_and_widths() {
    let o = Order::write(102, Ind::ZERO, Width::Word, false, Storage::Ram, -2).unwrap();
    assert_eq!(o.ak(), 14);
    assert_eq!((o.to_pkw().pwe1, o.to_pkw().pwe2), (0xFFFF, 0xFFFE));
    assert_eq!(
        Order::write(102, Ind::ZERO, Width::Word, false, Storage::Eeprom, 65536),
        Err(PkwError::WordOverflow(65536))
    );
    assert_eq!(
        Order::write(102, Ind::ZERO, Width::Word, false, Storage::Eeprom, -32769),
        Err(PkwError::WordOverflow(-32769))
    );
    assert_eq!(
        Order::write(
            102,
            Ind::ZERO,
            Width::DoubleWord,
            false,
            Storage::Eeprom,
            1 << 40
        ),
        Err(PkwError::WordOverflow(1 << 40))
    );
    let d = Order::write(
        2,
        Ind::ZERO,
        Width::DoubleWord,
        true,
        Storage::Ram,
        -100_000,
    )
    .unwrap();
    assert_eq!(d.ak(), 11);
    assert_eq!(d.to_pkw().value32(), -100_000);
    assert_eq!(Order::read(2048, Ind::ZERO), Err(PkwError::BadPnu(2048)));
}

/// Every order ID: reserved ones are refused, the others map to their AK.
#[test]
fn order_ids() {
    for ak in 0..16u8 {
        let pkw = Pkw {
            pke: Pke::new(ak, 1).unwrap(),
            ..Pkw::default()
        };
        let r = Order::from_pkw(&pkw);
        if [4, 5, 10, 15].contains(&ak) {
            assert_eq!(r, Err(PkwError::ReservedOrder(ak)), "AK {ak}");
        } else {
            assert_eq!(r.unwrap().ak(), ak);
        }
    }
    let storage = |w, a, s| Order::write(1, Ind::ZERO, w, a, s, 1).unwrap().ak();
    assert_eq!(storage(Width::Word, false, Storage::Eeprom), 2);
    assert_eq!(storage(Width::DoubleWord, false, Storage::Eeprom), 3);
    assert_eq!(storage(Width::Word, true, Storage::Eeprom), 7);
    assert_eq!(storage(Width::DoubleWord, true, Storage::Eeprom), 8);
    assert_eq!(storage(Width::DoubleWord, true, Storage::Ram), 11);
    assert_eq!(storage(Width::Word, true, Storage::Ram), 12);
    assert_eq!(storage(Width::DoubleWord, false, Storage::Ram), 13);
    assert_eq!(storage(Width::Word, false, Storage::Ram), 14);
}

/// 4.6.1.1 "Plausibilitätsprüfung": the previous order's answer is not taken.
#[test]
fn plausibility() {
    let read = Order::read(105, Ind::ZERO).unwrap();
    // The previous answer: P102's value.
    let previous = Reply::Value {
        width: Width::Word,
        array: false,
        value: 250,
    }
    .to_pkw(102, Ind::ZERO);
    assert_eq!(read.check(&previous), Plausibility::Other);
    // Same PNU, other IND (parameter set): not this order.
    let other_set = Reply::Value {
        width: Width::Word,
        array: false,
        value: 500,
    }
    .to_pkw(105, Ind::new(0, 1).unwrap());
    assert_eq!(read.check(&other_set), Plausibility::Other);
    // An array answer (AK 4) to AK 1 is no positive answer of AK 1.
    let array = Reply::Value {
        width: Width::Word,
        array: true,
        value: 500,
    }
    .to_pkw(105, Ind::ZERO);
    assert_eq!(read.check(&array), Plausibility::Other);
    // AK 7 with the order's PNU and IND: the drive refused it.
    let refused = Reply::Error(DriveError(0)).to_pkw(105, Ind::ZERO);
    assert_eq!(
        read.check(&refused),
        Plausibility::Answer(Reply::Error(DriveError(0)))
    );
    assert_eq!(
        DriveError(2).to_string(),
        "error 2: lower or upper value limit exceeded"
    );
    // A double-word answer to AK 1 is fine (AK 1 → 1 or 2).
    let double = Reply::Value {
        width: Width::DoubleWord,
        array: false,
        value: 70_000,
    }
    .to_pkw(105, Ind::ZERO);
    assert_eq!(
        read.check(&double),
        Plausibility::Answer(Reply::Value {
            width: Width::DoubleWord,
            array: false,
            value: 70_000
        })
    );
    // A write's answer must repeat the value written.
    let write = Order::write(102, Ind::ZERO, Width::Word, false, Storage::Eeprom, 300).unwrap();
    let stale = Reply::Value {
        width: Width::Word,
        array: false,
        value: 250,
    }
    .to_pkw(102, Ind::ZERO);
    assert_eq!(write.check(&stale), Plausibility::Other);
    // A word answer with garbage in PWE1 is invalid, not a value.
    let mut bad = stale;
    bad.pke = Pke::new(1, 105).unwrap();
    bad.pwe1 = 0x1234;
    assert_eq!(
        read.check(&bad),
        Plausibility::Invalid(PkwError::BadWordHigh { pwe1: 0x1234 })
    );
    // Response IDs 3 and 8–15 are not defined.
    for ak in [3u8, 8, 9, 15] {
        let p = Pkw {
            pke: Pke::new(ak, 1).unwrap(),
            ..Pkw::default()
        };
        assert_eq!(Reply::from_pkw(&p), Err(PkwError::UnknownResponse(ak)));
    }
}

/// Answers round-trip through their raw form.
#[test]
fn reply_round_trip() {
    let ind = Ind::new(3, 2).unwrap();
    for reply in [
        Reply::None,
        Reply::Value {
            width: Width::Word,
            array: false,
            value: -5,
        },
        Reply::Value {
            width: Width::Word,
            array: true,
            value: 65535,
        },
        Reply::Value {
            width: Width::DoubleWord,
            array: true,
            value: i32::MIN,
        },
        Reply::Count(12),
        Reply::Error(DriveError(201)),
    ] {
        assert_eq!(Reply::from_pkw(&reply.to_pkw(480, ind)), Ok(reply));
    }
}

/// 5.1.1/5.1.2 process data: STW 047Eh → ZSW 0B31h; STW 047Fh + SW1 2000h → ZSW 0B37h.
#[test]
fn manual_5_1_process_data() {
    let out = PzdOut::new(ControlWord(0x047F), &[0x2000]);
    let mut buf = [0u8; 8];
    let n = out.encode(&mut buf).unwrap();
    assert_eq!(&buf[..n], [0x04, 0x7F, 0x20, 0x00]); // STW high, low; SW1 high, low
    let answer = PzdIn::decode(&[0x0B, 0x37, 0x20, 0x00]).unwrap(); // ZSW, IW1
    assert_eq!(answer.status(), StatusWord(0x0B37));
    assert_eq!(answer.actuals(), [0x2000]);
    assert_eq!(
        PzdIn::decode(&[0x0B, 0x31]).unwrap().actuals(),
        [] as [u16; 0]
    );
    assert_eq!(PzdOut::decode(&[1, 2, 3]), Err(PzdError::BadLength(3)));
    assert_eq!(PzdOut::decode(&[0; 10]), Err(PzdError::BadLength(10)));
    assert_eq!(PzdOut::decode(&[]), Err(PzdError::BadLength(0)));
    assert_eq!(
        out.encode(&mut [0u8; 3]),
        Err(PzdError::BufferTooSmall { needed: 4, got: 3 })
    );
}

/// 4.5.4: a 32-bit position across two words.
#[test]
fn positions() {
    for p in [0, 1, -1, 5_000_000, -5_000_000, i32::MAX, i32::MIN] {
        let (low, high) = position_to_words(p);
        assert_eq!(position_from_words(low, high), p);
    }
    assert_eq!(position_to_words(-1), (0xFFFF, 0xFFFF));
    assert_eq!(position_to_words(0x0001_0002), (2, 1));
}
