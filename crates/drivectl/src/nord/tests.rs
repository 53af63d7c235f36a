//! The NORD commands' selectors, values and setpoints in the command line's words, and
//! `control` and `status` against the fake drive of `drive_client::testing::nord`.

use ctt2_uss::client::{ClientConfig, NordClient};
use drive_client::testing::nord::Fake;
use drive_profile::nord::State;

use super::*;

fn client(fake: Fake) -> NordClient<Fake> {
    NordClient::new(fake, ClientConfig::default())
}

fn one(key: &str, array: Option<u8>, set: Option<u8>) -> Target {
    let v = resolve(key, Sub { array, set }, false).unwrap();
    assert_eq!(v.len(), 1);
    v[0]
}

fn err(key: &str, array: Option<u8>, set: Option<u8>) -> String {
    resolve(key, Sub { array, set }, false)
        .unwrap_err()
        .to_string()
}

#[test]
fn sets_and_elements_are_the_ind_word_and_read_as_the_manual_counts() {
    // 5.1.3: P102 in parameter set 3 is IND 0200h (erratum E4).
    let t = one("P102", None, Some(3));
    assert_eq!(
        (t.index, t.sub, t.label()),
        (102, 0x0200, "P102 set 3".to_owned())
    );
    // No --set: set 1.
    assert_eq!(one("102", None, None).sub, 0x0000);
    // P543 has no parameter sets: element [-02] is sub-index 1 in IND bits 8-15 (4.6.1.2).
    let t = one("P543", Some(2), None);
    assert_eq!((t.sub, t.label()), (0x0100, "P543 [-02]".to_owned()));
    // 0x66 typed as a PNU is P102 of the table.
    assert!(one("0x66", None, None).param.is_some());
    // Read and watch take every element of an array.
    let all = resolve_all(&["P700".into()], Sub::default()).unwrap();
    let labels: Vec<String> = all.iter().map(Target::label).collect();
    assert_eq!(labels, ["P700 [-01]", "P700 [-02]", "P700 [-03]"]);
}

#[test]
fn array_and_set_options_are_checked_against_the_table_before_anything_is_sent() {
    let e = err("P102", Some(1), None);
    assert!(e.contains("is no array: it takes no --array"), "{e}");
    let e = err("P560", None, Some(2));
    assert!(
        e.contains("has no parameter sets: it takes no --set"),
        "{e}"
    );
    let e = err("P543", Some(4), None);
    assert!(e.contains("[-01]…[-03]: --array 4 is none of them"), "{e}");
    let e = err("P543", None, None);
    assert!(
        e.contains("is an array of 3 elements: add --array 1…3"),
        "{e}"
    );
    // Outside the table nothing is known: the options make the IND word.
    let raw = one("900", Some(2), Some(3));
    assert_eq!((raw.param.is_none(), raw.sub), (true, 0x0600));
    assert_eq!(raw.label(), "index 900 IND 0x0600");
}

#[test]
fn values_are_physical_strict_and_16_bit() {
    let how = ValueText::default();
    let set3 = Sub {
        array: None,
        set: Some(3),
    };
    // 5.1.3: 10 s = 3E8h; 5.1.5: 2.5 s = FAh; 4.6.1.3: 99.99 s = 9999.
    assert_eq!(write_value("P102", "10", set3, &how).unwrap().raw, 1000);
    assert_eq!(write_value("P102", "2,5", set3, &how).unwrap().raw, 250);
    assert_eq!(write_value("P102", "99.99", set3, &how).unwrap().raw, 9999);
    let raw = ValueText { raw: true, ..how };
    for bad in ["70000", "1099511627776", "--5", "1e3", "0x"] {
        assert!(write_value("P102", bad, set3, &raw).is_err(), "{bad}");
    }
    // Outside the table too: a NORD parameter is a word.
    let e = write_value("900", "70000", Sub::default(), &raw)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("16-bit word") && e.contains("nothing was sent"),
        "{e}"
    );
    assert_eq!(
        write_value("900", "-1", Sub::default(), &raw).unwrap().raw,
        -1
    );
    // Not even --force sends 700 s (raw 70000 does not fit a word).
    let forced = ValueText { force: true, ..how };
    assert!(write_value("P102", "700", set3, &forced).is_err());
    assert!(write_value("P102", "700", set3, &how).is_err());
    assert_eq!(setpoint_word("50", false).unwrap().word, 0x2000);
    assert_eq!(setpoint_word("-100", false).unwrap().word, 0xC000);
    assert!(setpoint_word("fifty", false).is_err());
}

/// Issue 18: a setpoint SW1 cannot hold was sent as the nearest word without a word (100.0001 %
/// as 4000h); it is refused naming the nearest step, or rounded with `--round`. A value is held
/// when the nearest step reads as typed (10 % is 0666h = 9.9976 %: "10" at the precision
/// typed). The bounds are the word's, BU 0255 4.5.4: −32768…32767 (8000h…7FFFh), 4000h = 100 %.
#[test]
fn issue18_a_setpoint_the_word_cannot_hold_is_refused_with_the_nearest() {
    let e = setpoint_word("100.0001", false).unwrap_err().to_string();
    assert!(e.contains("cannot hold 100.0001 %"), "{e}");
    assert!(e.contains("100 % (0x4000)") && e.contains("--round"), "{e}");
    let r = setpoint_word("100.0001", true).unwrap();
    assert_eq!((r.word, r.rounded_from), (0x4000, Some(100.0001)));
    // The nearest step as named is taken when typed back.
    let e = setpoint_word("100.005", false).unwrap_err().to_string();
    assert!(e.contains("100.0061 % (0x4001)"), "{e}");
    assert_eq!(setpoint_word("100.0061", false).unwrap().word, 0x4001);
    // Held at the precision typed: 10 % (1638.4 steps) is 0666h, 33.3 % is 1550h.
    for (text, word) in [
        ("10", 0x0666),
        ("33.3", 0x1550),
        ("-25", 0xF000),
        ("12,5", 0x0800),
    ] {
        let s = setpoint_word(text, false).unwrap();
        assert_eq!((s.word, s.rounded_from), (word, None), "{text}");
    }
    assert_eq!(setpoint_word("0.006103515625", false).unwrap().word, 1);
    assert_eq!(setpoint_word("-0", false).unwrap().word, 0);
    assert_eq!(setpoint_word("-200", false).unwrap().word, 0x8000);
    assert_eq!(setpoint_word("199.9939", false).unwrap().word, 0x7FFF);
    // Within half a step of an end it is the end's step (rounding, not cutting).
    assert_eq!(setpoint_word("-200.0001", true).unwrap().word, 0x8000);
    assert!(setpoint_word("-200.0001", false).is_err());
    // Past the word's ends: refused even with --round (nothing is cut to fit), naming the end.
    for (text, end) in [
        ("200", "199.9939 % (0x7FFF)"),
        ("-200.01", "-200 % (0x8000)"),
    ] {
        for round in [false, true] {
            let e = setpoint_word(text, round).unwrap_err().to_string();
            assert!(e.contains(end), "{text}: {e}");
            assert!(e.contains("4.5.4"), "{text}: {e}");
        }
    }
    let e = setpoint_word(&"9".repeat(400), true)
        .unwrap_err()
        .to_string();
    assert!(e.contains("0x7FFF"), "{e}");
}

fn session() -> Session {
    Session {
        key: "fake 1".into(),
        again: "drivectl uss --port /dev/fake --addr 1".into(),
        actuals: 3,
        ..Session::default()
    }
}

fn control_session(action: &str, setpoint: Option<u16>) -> ControlSession<'_> {
    ControlSession {
        action,
        setpoint,
        set: 1,
        wait: Duration::from_secs(2),
    }
}

#[tokio::test]
async fn a_fault_is_reset_with_a_rising_edge_and_enable_refuses_a_faulted_drive() {
    let mut c = client(Fake {
        state: Some(State::Fault),
        ..Fake::default()
    });
    let e = control(&mut c, &session(), &control_session("enable", None))
        .await
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("shows a fault") && e.contains("control reset"),
        "{e}"
    );
    assert!(c.channel().controls.is_empty(), "nothing sent");
    control(&mut c, &session(), &control_session("reset", None))
        .await
        .unwrap();
    assert_eq!(c.channel().state, Some(State::SwitchOnDisabled));
    assert_eq!(c.channel().controls.last().map(|c| c.0), Some(0x0480));
}

#[tokio::test]
async fn a_link_failure_while_enabling_says_the_drive_may_be_running() {
    // The link dies before anything is sent: nothing to stop, nothing said about a motor.
    let mut c = client(Fake {
        process_dies_after: Some(0),
        ..Fake::default()
    });
    let e = control(&mut c, &session(), &control_session("enable", Some(0x2000)))
        .await
        .unwrap_err()
        .to_string();
    assert!(e.contains("no answer from the fake drive"), "{e}");
    assert!(!e.contains("may still be running"), "{e}");
    // The answer to enable operation (047Fh, the 4th exchange) is lost: the shutdown is tried
    // and not answered either; the drive may run, and the message says how to stop it.
    let mut c = client(Fake {
        process_dies_after: Some(3),
        ..Fake::default()
    });
    let e = control(&mut c, &session(), &control_session("enable", Some(0x2000)))
        .await
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("no answer from the fake drive")
            && e.contains("the stop sent after the failure was not answered")
            && e.contains("may still be running")
            && e.contains("drivectl uss --port /dev/fake --addr 1 control stop"),
        "{e}"
    );
}

#[tokio::test]
async fn status_reads_the_state_and_never_sends_a_valid_control_word() {
    let mut c = client(Fake {
        state: Some(State::ReadyToSwitchOn),
        ..Fake::default()
    });
    status(&mut c, &session()).await.unwrap();
    assert!(c.channel().controls.is_empty());
    assert_eq!(c.channel().state, Some(State::ReadyToSwitchOn));
}
