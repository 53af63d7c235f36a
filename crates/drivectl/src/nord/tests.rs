//! The shared NORD commands against a tiny fake transport: what is sent (AK, PNU, IND, PWE)
//! for parameter sets and array elements, the plausibility repeat, refusals, and the state
//! machine walk of `control`.

use std::collections::HashMap;

use ctt2_uss::client::{ClientConfig, NordClient, ParameterChannel, ProcessChannel};
use ctt2_uss::uss::DriveError;
use ctt2_uss::uss::pkw::{Order, OrderKind, Pkw, Reply};
use ctt2_uss::uss::pzd::{PzdIn, PzdOut};
use drive_profile::Persistence;
use drive_profile::nord::{self, ControlWord, State, StatusWord};

use super::*;
use crate::tool::client::{ClientError, DeviceErrorKind};
use drive_client::nord::raw_of;
use serde_json::json;

/// The fake transport's only error: the line is dead.
#[derive(Debug)]
struct Dead;

impl std::fmt::Display for Dead {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("no answer from the fake drive")
    }
}

impl std::error::Error for Dead {}

/// A NORD drive in memory: parameters by (PNU, IND), an order answered only after `delay`
/// further requests (the drive repeats its previous answer meanwhile), and a state machine
/// that follows the manual's transition table.
#[derive(Debug, Default)]
struct Fake {
    values: HashMap<(u16, u16), i32>,
    /// Every parameter channel the master sent (submit and poll).
    sent: Vec<Pkw>,
    answer: Pkw,
    pending: Option<(Pkw, u8)>,
    delay: u8,
    state: Option<State>,
    last_control: u16,
    /// Every control word and setpoint sent with bit 10 set.
    controls: Vec<(u16, Vec<u16>)>,
    /// The line dies after this many process exchanges.
    process_dies_after: Option<usize>,
    exchanges: usize,
}

fn status_of(state: State) -> u16 {
    nord::state_info(state).map_or(0, |i| i.value) | StatusWord::BUS_CONTROL.0
}

impl Fake {
    fn execute(&mut self, pkw: Pkw) -> Pkw {
        let Ok(order) = Order::from_pkw(&pkw) else {
            return Reply::Error(DriveError(201)).to_pkw(pkw.pke.pnu(), pkw.ind);
        };
        let reply = self.reply(&order);
        reply.to_pkw(order.pnu(), order.ind())
    }

    fn reply(&mut self, order: &Order) -> Reply {
        if order.kind() == OrderKind::None {
            return Reply::None;
        }
        let Some(p) = nord::by_index(order.pnu()) else {
            return Reply::Error(DriveError(0));
        };
        let key = (order.pnu(), order.ind().0);
        match order.kind() {
            OrderKind::None => Reply::None,
            OrderKind::Count => Reply::Count(u16::from(p.array_len.unwrap_or(0))),
            OrderKind::Read { array } => Reply::Value {
                width: nord::Width::Word,
                array,
                value: *self.values.get(&key).unwrap_or(&0),
            },
            OrderKind::Write {
                array,
                value,
                width,
                ..
            } => {
                if !p.access.is_writable() {
                    return Reply::Error(DriveError(1));
                }
                if let Some((lo, hi)) = p.raw_range
                    && (i64::from(value) < lo || i64::from(value) > hi)
                {
                    return Reply::Error(DriveError(2));
                }
                self.values.insert(key, value);
                Reply::Value {
                    width,
                    array,
                    value,
                }
            }
        }
    }

    fn answer_now(&mut self) -> Pkw {
        if let Some((pkw, left)) = self.pending {
            if left == 0 {
                self.answer = self.execute(pkw);
                self.pending = None;
            } else {
                self.pending = Some((pkw, left - 1));
            }
        }
        self.answer
    }

    /// AK, PNU and IND of every order sent, without the repeats of one order.
    fn orders(&self) -> Vec<(u8, u16, u16, u16)> {
        let mut v: Vec<(u8, u16, u16, u16)> = self
            .sent
            .iter()
            .map(|p| (p.pke.ak(), p.pke.pnu(), p.ind.0, p.pwe2))
            .collect();
        v.dedup();
        v
    }
}

impl ParameterChannel for Fake {
    type Error = Dead;

    async fn submit(&mut self, order: Pkw) -> std::result::Result<Pkw, Dead> {
        self.sent.push(order);
        self.pending = Some((order, self.delay));
        Ok(self.answer_now())
    }

    async fn poll(&mut self, order: Pkw) -> std::result::Result<Pkw, Dead> {
        self.sent.push(order);
        Ok(self.answer_now())
    }
}

impl ProcessChannel for Fake {
    type Error = Dead;

    async fn exchange_process(
        &mut self,
        out: PzdOut,
        actuals: u8,
    ) -> std::result::Result<PzdIn, Dead> {
        self.exchanges += 1;
        if self.process_dies_after.is_some_and(|n| self.exchanges > n) {
            return Err(Dead);
        }
        let mut state = self.state.unwrap_or(State::SwitchOnDisabled);
        let word = out.control().0;
        if word & ControlWord::CONTROL_DATA_VALID.0 != 0 {
            self.controls.push((word, out.setpoints().to_vec()));
            // The fake's ramp is instant: a stop reaches 0 Hz at once.
            if let Some(t) = nord::transitions()
                .iter()
                .find(|t| t.from == Some(state) && t.triggered_by(self.last_control, word))
            {
                state = t.to;
            }
            if state == State::QuickStopActive {
                state = State::SwitchOnDisabled;
            }
            self.last_control = word;
        }
        self.state = Some(state);
        let iw1 = if state == State::OperationEnabled {
            self.controls
                .last()
                .and_then(|(_, s)| s.first().copied())
                .unwrap_or(0)
        } else {
            0
        };
        let values = [iw1, 0, 0];
        Ok(PzdIn::new(
            StatusWord(status_of(state)),
            values.get(..usize::from(actuals.min(3))).unwrap_or(&[]),
        ))
    }
}

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

#[tokio::test]
async fn a_write_and_its_read_back_send_the_manuals_orders_and_wait_for_a_plausible_answer() {
    // The drive answers an order only after two more requests (it repeats its previous
    // answer meanwhile): the client asks again until AK, PNU and IND fit.
    let mut c = client(Fake {
        delay: 2,
        ..Fake::default()
    });
    let mut pc = NordParamClient::new(&mut c, "fake 1", Map::new());
    let p102 = one("P102", None, Some(3));
    pc.write(&p102, 1000, Persistence::NonVolatile)
        .await
        .unwrap();
    assert_eq!(pc.read(&p102).await.unwrap(), 1000);
    let p543 = one("P543", Some(2), None);
    pc.write(&p543, 3, Persistence::Volatile).await.unwrap();
    assert_eq!(pc.read(&p543).await.unwrap(), 3);
    let p102 = one("P102", None, Some(2));
    pc.write(&p102, 250, Persistence::Volatile).await.unwrap();
    assert!(c.repeated_requests() > 0);
    assert_eq!(
        c.channel().orders(),
        [
            // AK 0 first: the drive may still answer an earlier command's order (E21).
            (0, 0, 0, 0),
            // AK 2 (word, EEPROM as P560 says) P102 = 66h, IND 0200h (set 3), 3E8h.
            (2, 0x66, 0x0200, 0x03E8),
            // AK 0 between two orders on one PNU and IND (E21), then AK 1: read it back.
            (0, 0, 0, 0),
            (1, 0x66, 0x0200, 0),
            // AK 12 (array word, RAM only) P543 = 21Fh, IND 0100h ([-02]).
            (12, 0x21F, 0x0100, 3),
            // AK 6: read the element.
            (0, 0, 0, 0),
            (6, 0x21F, 0x0100, 0),
            // AK 14 (word, RAM only), IND 0100h (set 2): 2.5 s as in 5.1.5.
            (14, 0x66, 0x0100, 0xFA),
        ]
    );
}

#[tokio::test]
async fn refusals_are_typed_with_their_pwe2_meaning() {
    let mut c = client(Fake::default());
    let mut pc = NordParamClient::new(&mut c, "fake 1", Map::new());
    let p700 = one("P700", Some(1), None);
    match pc.write(&p700, 5, Persistence::NonVolatile).await {
        Err(ClientError::Device(d)) => {
            assert_eq!(d.kind, DeviceErrorKind::Refused);
            // The message is the drive's; the caller names the parameter (once).
            assert!(
                !d.message.contains("P700")
                    && d.message
                        .contains("error 1: parameter value cannot be changed")
                    && d.message.contains("read-only"),
                "{}",
                d.message
            );
        }
        other => panic!("{other:?}"),
    }
    let e = p700
        .error(
            pc.write(&p700, 5, Persistence::NonVolatile)
                .await
                .unwrap_err(),
        )
        .to_string();
    assert!(e.starts_with("P700 [-01]: the drive refused AK 7"), "{e}");
    let raw = one("900", None, None);
    match pc.read(&raw).await {
        Err(ClientError::Device(d)) => assert_eq!(d.kind, DeviceErrorKind::Absent),
        other => panic!("{other:?}"),
    }
}

#[test]
fn words_of_unsigned_parameters_are_unsigned() {
    let p102 = one("P102", None, None);
    assert_eq!(raw_of(&p102, -1, nord::Width::Word), 65535);
    let raw = one("900", None, None);
    assert_eq!(raw_of(&raw, -1, nord::Width::Word), -1);
}

#[test]
fn issue18_read_json_names_the_set_and_the_array_element_in_the_selector() {
    let v = crate::tool::output::value_json(&one("P102", None, Some(3)), 1000);
    assert_eq!(
        (
            &v["index"],
            &v["label"],
            &v["selector"],
            &v["raw"],
            &v["value"]
        ),
        (
            &json!(102),
            &json!("P102 set 3"),
            &json!({"set": 3, "ind": "0x0200"}),
            &json!(1000),
            &json!(10.0)
        )
    );
    let v = crate::tool::output::value_json(&one("P700", Some(2), None), 0);
    assert_eq!(v["selector"], json!({"array": 2, "ind": "0x0100"}));
    assert_eq!(v["label"], "P700 [-02]");
    assert_eq!(v["name_en"], "present warning");
    assert_eq!(v["meaning"], "no warning");
    // A parameter with neither: no selector.
    let v = crate::tool::output::value_json(&one("P560", None, None), 1);
    assert_eq!(v["selector"], serde_json::Value::Null);
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

#[test]
fn backup_rows_cover_every_element_and_set_with_p560_last() {
    let subs = crate::tool::client::nord_subs(102);
    assert_eq!(subs, [0x0000, 0x0100, 0x0200, 0x0300]);
    assert_eq!(
        crate::tool::client::nord_subs(543),
        [0x0000, 0x0100, 0x0200]
    );
    assert_eq!(crate::tool::client::nord_subs(560), [0]);
}

#[tokio::test]
async fn e21_a_read_after_a_refused_write_of_the_same_parameter_is_not_taken_for_refused() {
    // A slow drive (two requests per order): the write of 400 s is refused (AK 7, error 2),
    // and the drive keeps sending that answer until the read is done. AK 7 fits every order
    // and PNU and IND are the same, so without "no order" in between the read would report
    // the write's refusal (erratum E21).
    let mut c = client(Fake {
        delay: 2,
        ..Fake::default()
    });
    c.channel_mut().values.insert((102, 0x0200), 1000);
    let mut pc = NordParamClient::new(&mut c, "fake 1", Map::new());
    let p102 = one("P102", None, Some(3));
    assert!(matches!(
        pc.write(&p102, 40_000, Persistence::Volatile).await,
        Err(ClientError::Device(_))
    ));
    assert_eq!(pc.read(&p102).await.unwrap(), 1000);
    // The same in a new command (a new client on the same line): the drive still answers the
    // refused write.
    let mut pc = NordParamClient::new(&mut c, "fake 1", Map::new());
    assert_eq!(pc.read(&p102).await.unwrap(), 1000);
}
