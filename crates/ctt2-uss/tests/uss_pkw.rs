//! The USS parameter channel as the serial telegrams carry it: what the plausibility check of
//! BU 0255 section 4.6.1.1 can and cannot tell apart (erratum E21), and the 3-word PKW's value
//! word against the orders' and answers' value rules.

// A failing fixture is a failing test: panicking is the report.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

use ctt2_uss::serial::telegram::{Adr, Layout, MAX_TELEGRAM, Telegram, UssAddress};
use ctt2_uss::uss::pkw::{DriveError, Ind, Order, Pkw, Plausibility, Reply, Storage};
use drive_profile::nord::Width;

fn p102() -> (u16, Ind) {
    (102, Ind::ZERO)
}

/// E21: the manual's plausibility check (AK, PNU with IND, PWE) cannot tell the answer to a
/// new order from the previous order's answer when both orders address the same PNU and IND:
/// an AK 7 fits every order, and a word write's echo (AK 1 with the value) is a perfect answer
/// to a read of the same parameter. A master must make the drive answer something else in
/// between (an order for another parameter, or "no order" with PNU 0).
#[test]
fn e21_the_previous_answer_for_the_same_parameter_passes_the_check() {
    let (pnu, ind) = p102();
    let read = Order::read(pnu, ind).unwrap();
    // The drive refused a write of P102 (error 2, limit exceeded) and has not yet done the
    // read: it still answers the write's AK 7, which the check takes as the read's answer.
    let refused = Reply::Error(DriveError(2)).to_pkw(pnu, ind);
    assert_eq!(
        read.check(&refused),
        Plausibility::Answer(Reply::Error(DriveError(2)))
    );
    // After a successful word write of 450 the echo AK 1, P102, 450 is a plausible read answer
    // (here with the right value, as nothing changed it since).
    let echo = Reply::Value {
        width: Width::Word,
        array: false,
        value: 450,
    }
    .to_pkw(pnu, ind);
    assert!(matches!(read.check(&echo), Plausibility::Answer(_)));
    // An answer about another parameter, or "no order", is never taken: that is the separator.
    let none = Reply::None.to_pkw(0, Ind::ZERO);
    assert_eq!(read.check(&none), Plausibility::Other);
    let other = Reply::Value {
        width: Width::Word,
        array: false,
        value: 450,
    }
    .to_pkw(105, ind);
    assert_eq!(read.check(&other), Plausibility::Other);
    // The same AK, PNU and IND but another value is not a write's answer.
    let write = Order::write(pnu, ind, Width::Word, false, Storage::Ram, 451).unwrap();
    assert_eq!(write.check(&echo), Plausibility::Other);
}

/// The 3-word PKW carries one value word: every word order and answer fits, negative words
/// arrive with PWE1 = FFFFh as section 4.6.1.3 asks, double words are refused.
#[test]
fn three_word_pkw_and_word_values() {
    let l = Layout::new(3, 0).unwrap();
    let a = Adr::new(UssAddress::new(1).unwrap());
    let mut buf = [0u8; MAX_TELEGRAM];
    for value in [0i64, 1, 32767, -1, -32768] {
        let order = Order::write(102, Ind::ZERO, Width::Word, false, Storage::Eeprom, value)
            .unwrap()
            .to_pkw();
        let t = Telegram::new(a, l, order, &[]).unwrap();
        let n = t.encode(&mut buf).unwrap();
        let back = Telegram::decode(&buf[..n], l).unwrap().pkw().unwrap();
        assert_eq!(back, order, "{value}");
        assert_eq!(i64::from(back.value32()), value);
        let parsed = Order::from_pkw(&back).unwrap();
        assert_eq!(
            parsed.check(
                &Reply::Value {
                    width: Width::Word,
                    array: false,
                    value: value as i32
                }
                .to_pkw(102, Ind::ZERO)
            ),
            Plausibility::Answer(Reply::Value {
                width: Width::Word,
                array: false,
                value: value as i32
            })
        );
    }
    // An unsigned word above 32767 (PWE1 0000h) travels as its word and comes back with the
    // sign of bit 15: the 3-word form cannot say which was meant.
    let big = Order::write(102, Ind::ZERO, Width::Word, false, Storage::Eeprom, 40_000)
        .unwrap()
        .to_pkw();
    let t = Telegram::new(a, l, big, &[]).unwrap();
    assert_eq!(t.pkw().unwrap().value32(), 40_000 - 65_536);
    let double = Pkw { pwe1: 1, ..big };
    assert!(Telegram::new(a, l, double, &[]).is_err());
}
