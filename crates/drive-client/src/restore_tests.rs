//! Tests of the restore engine over a scripted drive.
use super::*;
use crate::backup::{FORMAT, VERSION};
use crate::testing::FakeClient;
use crate::wear::MemoryWearLog;
use serde_json::json;

type Fake = FakeClient<Interrupt>;

/// Every read answers the index as value (writes do not change it).
fn index_as_value(i: u16) -> Result<i64, ClientError> {
    Ok(i64::from(i))
}

/// A backup file with P130…P133 (8470…8473) set to 1000 (P133 to the value the drive holds),
/// saved from device type 7 and the identity fields `identity`.
fn file(identity: Value) -> BackupFile {
    let mut doc = json!({
        "format": FORMAT, "version": VERSION, "family": "movidrive",
        "device_type": 7, "firmware": 822_609_711,
        "parameters": [
            {"index": 8470, "raw": 1000}, {"index": 8471, "raw": 1000},
            {"index": 8472, "raw": 1000}, {"index": 8473, "raw": 8473},
        ],
    });
    for (k, v) in identity.as_object().unwrap() {
        doc[k] = v.clone();
    }
    BackupFile::parse(
        doc.to_string().as_bytes(),
        drive_profile::Family::Movidrive,
        &[],
        &[],
    )
    .unwrap()
}

fn drive(device_type: u64) -> Fake {
    let mut c = Fake::new(index_as_value);
    c.identity.insert("device_type".into(), device_type.into());
    c.identity.insert("firmware".into(), 822_609_711.into());
    c
}

fn block_on<F: std::future::Future>(f: F) -> F::Output {
    tokio::runtime::Builder::new_current_thread()
        .build()
        .unwrap()
        .block_on(f)
}

/// What a front end was told: phases, steps and notices, in order.
#[derive(Default)]
struct Seen(Vec<String>);

impl Progress for Seen {
    fn start(&mut self, phase: Phase, steps: usize) {
        self.0.push(format!("{phase:?} {steps}"));
    }
    fn step(&mut self, target: &Target) {
        self.0.push(target.label());
    }
    fn finish(&mut self) {
        self.0.push("finish".into());
    }
    fn abandon(&mut self) {
        self.0.push("abandon".into());
    }
    fn notice(&mut self, notice: &Notice) {
        self.0.push(format!("{notice:?}"));
    }
}

const FORCED: Options = Options {
    force: true,
    any_device: false,
    confirm_link_settings: false,
};

/// Plan, apply and verify as a front end does.
fn restore(
    c: &mut Fake,
    file: &BackupFile,
    opts: Options,
    stop: &Interrupt,
    seen: &mut Seen,
) -> Result<(Plan, Applied, Vec<Mismatch>), RestoreError> {
    let log = MemoryWearLog::default();
    block_on(async {
        let plan = plan(c, file, &opts, &log, seen, stop).await?;
        let applied = apply(c, &plan, &log, seen, stop).await?;
        let mismatches = verify(c, &plan, seen, stop).await?;
        Ok((plan, applied, mismatches))
    })
}

fn labels(changes: &[Change]) -> Vec<String> {
    changes.iter().map(|c| c.target.label()).collect()
}

#[test]
fn a_restore_writes_what_differs_and_verifies_every_value_compared() {
    let mut c = drive(7);
    let mut seen = Seen::default();
    let (plan, applied, mismatches) = restore(
        &mut c,
        &file(json!({})),
        FORCED,
        &Interrupt::new(),
        &mut seen,
    )
    .unwrap();
    assert_eq!((plan.in_file, plan.entries, plan.unchanged()), (4, 4, 1));
    let changes: Vec<(String, i64, i64)> = plan
        .changes
        .iter()
        .map(|c| (c.target.label(), c.from, c.to))
        .collect();
    assert_eq!(
        changes,
        [
            ("P130".to_owned(), 8470, 1000),
            ("P131".to_owned(), 8471, 1000),
            ("P132".to_owned(), 8472, 1000)
        ]
    );
    assert_eq!(labels(&applied.written), ["P130", "P131", "P132"]);
    assert_eq!(
        c.written,
        [
            (8470, 1000, Persistence::NonVolatile),
            (8471, 1000, Persistence::NonVolatile),
            (8472, 1000, Persistence::NonVolatile)
        ]
    );
    // This drive ignores writes: each value read back is its old one.
    let back: Vec<(String, i64, i64)> = mismatches
        .iter()
        .map(|m| (m.target.label(), m.expected, m.back))
        .collect();
    assert_eq!(
        back,
        [
            ("P130".to_owned(), 1000, 8470),
            ("P131".to_owned(), 1000, 8471),
            ("P132".to_owned(), 1000, 8472)
        ]
    );
    let phases: Vec<&str> = seen
        .0
        .iter()
        .map(String::as_str)
        .filter(|s| s.contains(' ') || *s == "finish")
        .collect();
    assert_eq!(
        phases,
        [
            "Reading 4",
            "finish",
            "Writing 3",
            "finish",
            "Verifying 4",
            "finish"
        ]
    );
}

#[test]
fn issue7_a_restore_cut_short_by_the_link_says_what_was_and_was_not_written() {
    let mut c = drive(7);
    c.link_dies_after = Some(1);
    let mut seen = Seen::default();
    let e = restore(
        &mut c,
        &file(json!({})),
        FORCED,
        &Interrupt::new(),
        &mut seen,
    )
    .unwrap_err();
    let RestoreError::Halted(h) = e else {
        panic!("{e:?}")
    };
    assert_eq!(labels(&h.applied.written), ["P130"]);
    assert_eq!(labels(&h.not_written), ["P131", "P132"]);
    assert_eq!(h.uncertain().map(Target::label).as_deref(), Some("P131"));
    assert!(
        matches!(&h.why, Halt::Link { error: ClientError::Link(m), .. } if m.message == "no answer from drive 1" && m.fault == crate::LinkFault::NoAnswer)
    );
    assert_eq!(seen.0.last().map(String::as_str), Some("abandon"));
}

#[test]
fn issue7_an_interrupt_during_a_restore_finishes_the_write_in_flight() {
    let stop = Interrupt::new();
    let mut c = drive(7);
    c.interrupt_after = Some((2, stop.clone()));
    let e = restore(
        &mut c,
        &file(json!({})),
        FORCED,
        &stop,
        &mut Seen::default(),
    )
    .unwrap_err();
    let RestoreError::Halted(h) = e else {
        panic!("{e:?}")
    };
    assert_eq!(c.written.len(), 2);
    assert_eq!(labels(&h.applied.written), ["P130", "P131"]);
    assert_eq!(labels(&h.not_written), ["P132"]);
    assert!(h.uncertain().is_none());
    assert!(matches!(&h.why, Halt::Interrupted(cause) if cause.code == 2));
    // Asked before the first read: nothing is read or written.
    let mut c = drive(7);
    let e = restore(
        &mut c,
        &file(json!({})),
        FORCED,
        &stop,
        &mut Seen::default(),
    )
    .unwrap_err();
    assert!(
        matches!(
            e,
            RestoreError::Interrupted {
                phase: Phase::Reading,
                ..
            }
        ),
        "{e:?}"
    );
    assert!(c.written.is_empty());
}

#[test]
fn issue18_every_identity_field_both_sides_know_must_match_but_the_address() {
    let saved = file(json!({"variant": "act", "address": 1}));
    // Another variant and device type: refused, both named.
    let mut c = drive(8);
    c.identity.insert("variant".into(), "acu".into());
    c.identity.insert("address".into(), 2.into());
    let e = restore(
        &mut c,
        &saved,
        FORCED,
        &Interrupt::new(),
        &mut Seen::default(),
    )
    .unwrap_err();
    let RestoreError::OtherDevice(differ) = e else {
        panic!("{e:?}")
    };
    let keys: Vec<&str> = differ.iter().map(|d| d.key.as_str()).collect();
    assert_eq!(keys, ["device_type", "variant"]);
    assert!(c.written.is_empty());
    // With any_device: said, and restored.
    let mut seen = Seen::default();
    let any = Options {
        any_device: true,
        ..FORCED
    };
    restore(&mut c, &saved, any, &Interrupt::new(), &mut seen).unwrap();
    assert!(
        seen.0.first().is_some_and(|n| n.starts_with("OtherDevice")),
        "{:?}",
        seen.0
    );
    assert_eq!(c.written.len(), 3);
    // The same variant at another address: restored (a backup clones a drive); a drive that
    // does not say its variant (null): not compared; another firmware: said.
    let mut c = drive(7);
    c.identity.insert("variant".into(), Value::Null);
    c.identity.insert("address".into(), 2.into());
    c.identity.insert("firmware".into(), 1.into());
    let mut seen = Seen::default();
    restore(&mut c, &saved, FORCED, &Interrupt::new(), &mut seen).unwrap();
    assert_eq!(c.written.len(), 3);
    assert!(
        seen.0
            .first()
            .is_some_and(|n| n.starts_with("OtherFirmware")),
        "{:?}",
        seen.0
    );
}

#[test]
fn issue18_a_link_setting_is_restored_only_when_confirmed() {
    // P131 (8471) is a setting of the link.
    let mut c = drive(7);
    c.link_settings = &[8471];
    let mut seen = Seen::default();
    let (plan, _, _) = restore(
        &mut c,
        &file(json!({})),
        FORCED,
        &Interrupt::new(),
        &mut seen,
    )
    .unwrap();
    let indices: Vec<u16> = c.written.iter().map(|w| w.0).collect();
    assert_eq!(indices, [8470, 8472]);
    assert!(matches!(
        plan.skipped.as_slice(),
        [(t, Skip::Unconfirmed(_))] if t.index == 8471
    ));
    let mut c = drive(7);
    c.link_settings = &[8471];
    let yes = Options {
        confirm_link_settings: true,
        ..FORCED
    };
    let mut seen = Seen::default();
    restore(&mut c, &file(json!({})), yes, &Interrupt::new(), &mut seen).unwrap();
    let indices: Vec<u16> = c.written.iter().map(|w| w.0).collect();
    assert_eq!(indices, [8470, 8471, 8472]);
    // The client followed the change and said so.
    assert!(
        seen.0.iter().any(|n| n.starts_with("LinkFollowed")),
        "{:?}",
        seen.0
    );
}

#[test]
fn every_refusal_is_found_before_the_first_write() {
    // Two values outside P130's and P131's range (in their width).
    let mut doc = json!({"format": FORMAT, "version": VERSION, "family": "movidrive",
                         "parameters": [{"index": 8470, "raw": 2_000_001},
                                        {"index": 8471, "raw": 2_000_001},
                                        {"index": 8472, "raw": 1000}]});
    let file = |doc: &Value| {
        BackupFile::parse(
            doc.to_string().as_bytes(),
            drive_profile::Family::Movidrive,
            &[],
            &[],
        )
        .unwrap()
    };
    let opts = Options::default();
    let log = MemoryWearLog::default();
    let mut c = drive(7);
    let stop = Interrupt::new();
    let plan = block_on(super::plan(
        &mut c,
        &file(&doc),
        &opts,
        &log,
        &mut (),
        &stop,
    ))
    .unwrap();
    assert_eq!(plan.changes.len(), 3);
    assert_eq!(plan.refusals.len(), 2, "{:?}", plan.refusals);
    assert!(
        plan.refusals
            .iter()
            .all(|r| matches!(r, WriteError::Guard { .. }))
    );
    let e = block_on(apply(&mut c, &plan, &log, &mut (), &stop)).unwrap_err();
    assert!(matches!(e, RestoreError::Refused { count: 2 }), "{e:?}");
    assert!(c.written.is_empty());
    // Within the range: no refusal, written, and entered in the wear log.
    doc["parameters"] = json!([{"index": 8470, "raw": 1000}, {"index": 8471, "raw": 1000}]);
    let mut c = drive(7);
    let plan = block_on(super::plan(
        &mut c,
        &file(&doc),
        &opts,
        &log,
        &mut (),
        &stop,
    ))
    .unwrap();
    assert!(plan.refusals.is_empty(), "{:?}", plan.refusals);
    let applied = block_on(apply(&mut c, &plan, &log, &mut (), &stop)).unwrap();
    assert_eq!(labels(&applied.written), ["P130", "P131"]);
    // The same restore again at once is refused as too frequent, for both.
    let again = block_on(super::plan(
        &mut c,
        &file(&doc),
        &opts,
        &log,
        &mut (),
        &stop,
    ))
    .unwrap();
    assert!(
        again
            .refusals
            .iter()
            .all(|r| matches!(r, WriteError::Guard { error, .. } if matches!(error, drive_profile::guard::GuardError::TooFrequent { .. }))),
        "{:?}",
        again.refusals
    );
    assert_eq!(again.refusals.len(), 2);
    // A write the drive refused is listed with the plan's skips.
    let refused = [(
        plan.changes[0].target,
        DeviceError {
            kind: DeviceErrorKind::Refused,
            code: crate::DeviceCode::None,
            message: "controller inhibit needed".into(),
        },
    )];
    let all = plan.skipped_after(&refused);
    assert!(matches!(all.as_slice(), [(_, Skip::Refused(d))] if d.message.contains("inhibit")));
}

/// A front end that names the confirmation of link settings, as the command line does.
#[derive(Debug)]
struct Yes;

impl crate::front::FrontEnd for Yes {
    fn name(&self, setting: crate::front::Setting) -> Option<String> {
        (setting == crate::front::Setting::ConfirmLinkSettings).then(|| "--yes".to_owned())
    }
}

#[test]
fn every_front_end_reports_the_same_objects_in_its_own_words() {
    // P131 (8471) is an unconfirmed setting of the link; the drive ignores writes.
    let mut c = drive(7);
    c.link_settings = &[8471];
    let (plan, applied, mismatches) = restore(
        &mut c,
        &file(json!({})),
        FORCED,
        &Interrupt::new(),
        &mut Seen::default(),
    )
    .unwrap();
    let change = plan.changes[0].to_json();
    assert_eq!(
        (
            &change["type"],
            &change["label"],
            &change["from_raw"],
            &change["to"]
        ),
        (&json!("change"), &json!("P130"), &json!(8470), &json!(1.0))
    );
    let m = mismatches[0].to_json();
    assert_eq!(
        (&m["type"], &m["expected_raw"], &m["raw"], &m["value"]),
        (&json!("mismatch"), &json!(1000), &json!(8470), &json!(8.47))
    );
    let done = plan.report_json(&applied, &mismatches, "b.json", &crate::front::Plain);
    assert_eq!(
        (
            &done["type"],
            &done["complete"],
            &done["written"],
            &done["mismatches"]
        ),
        (&json!("restore"), &json!(true), &json!(2), &json!(2))
    );
    assert_eq!(
        (&done["entries"], &done["unchanged"]),
        (&json!(4), &json!(1))
    );
    // The skipped link setting: its reason as a code, and the way to write it only where the
    // front end names one.
    let plain = &done["skipped"][0];
    assert_eq!(
        (&plain["label"], &plain["reason"]),
        (&json!("P131"), &json!("needs_yes"))
    );
    assert!(plain.get("hint").is_none());
    assert!(!plain["message"].as_str().unwrap().contains("--yes"));
    let dry = plan.dry_run_json("b.json", &["refused".to_owned()], &Yes);
    assert_eq!(
        (&dry["dry_run"], &dry["changes"]),
        (&json!(true), &json!(2))
    );
    assert_eq!(dry["refused"], json!(["refused"]));
    let cli = &dry["skipped"][0];
    assert_eq!(cli["hint"], "--yes");
    assert!(
        cli["message"]
            .as_str()
            .unwrap()
            .starts_with("settings of the link the restore talks over; add --yes to write them: "),
        "{cli}"
    );
}

#[test]
fn a_half_restore_and_a_restore_that_fell_short_say_what_the_drive_holds() {
    let mut c = drive(7);
    c.link_dies_after = Some(1);
    let e = restore(
        &mut c,
        &file(json!({})),
        FORCED,
        &Interrupt::new(),
        &mut Seen::default(),
    )
    .unwrap_err();
    let RestoreError::Halted(h) = e else {
        panic!("{e:?}")
    };
    assert_eq!(
        h.state_text(),
        "the drive is half restored: 1 of 3 change(s) written (P130), 2 not written (P131, \
         P132); P131 was being written when the link failed and may or may not have arrived; \
         run the same restore again to finish it (values the drive already holds are not \
         written again)"
    );
    // This drive ignores writes: all three differ when read back.
    let mut c = drive(7);
    let (plan, applied, mismatches) = restore(
        &mut c,
        &file(json!({})),
        FORCED,
        &Interrupt::new(),
        &mut Seen::default(),
    )
    .unwrap();
    assert_eq!(
        plan.shortfalls(&applied, &mismatches),
        [
            "verify failed: 3 value(s) differ after restore, 0 write(s) refused by the drive; check \
          controller inhibit and the parameter lock"
        ]
    );
}
