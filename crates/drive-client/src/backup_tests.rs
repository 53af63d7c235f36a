//! Tests of the backup file and the backup of a drive.
use super::*;
use crate::testing::{FakeClient, refusal};
use drive_profile::sew::index;

/// P804 "reset statistic data" and P810 "RS-485 address": a command and a link setting of
/// MOVILINK, never restored.
const NOT_RESTORED: &[u16] = &[8596, 8597];
const LINK_SETTINGS: &[u16] = &[8597];

/// Every read answers the index as value, except: P000 "speed" (8318) is absent, P001
/// "user display" (8501) refuses reading.
fn answers(i: u16) -> Result<i64, ClientError> {
    match i {
        8318 => Err(refusal(DeviceErrorKind::Absent, "not implemented")),
        8501 => Err(refusal(DeviceErrorKind::Refused, "access denied")),
        i => Ok(i64::from(i)),
    }
}

fn block_on<F: std::future::Future>(f: F) -> F::Output {
    tokio::runtime::Builder::new_current_thread()
        .build()
        .unwrap()
        .block_on(f)
}

/// The phases a progress saw, with their steps, and how each ended.
#[derive(Default)]
struct Seen(Vec<String>);

impl Progress for Seen {
    fn start(&mut self, phase: Phase, steps: usize) {
        self.0.push(format!("{phase:?} {steps}"));
    }
    fn finish(&mut self) {
        self.0.push("finish".into());
    }
    fn abandon(&mut self) {
        self.0.push("abandon".into());
    }
}

#[test]
fn absent_parameters_are_left_out_and_refused_ones_are_a_gap_that_is_said() {
    let mut c: FakeClient = FakeClient::new(answers);
    c.identity.insert("device_type".into(), 7.into());
    let mut seen = Seen::default();
    let b = block_on(backup(&mut c, &mut seen, &Interrupt::new())).unwrap();
    let rows = rows(Family::Movidrive).len();
    assert_eq!(seen.0, [format!("Reading {rows}"), "finish".into()]);
    assert_eq!((b.absent, b.saved.len() + 2), (1, rows));
    assert!(!b.is_complete());
    let labels: Vec<(String, String)> = b
        .unreadable
        .iter()
        .map(|(t, d)| (t.label(), d.message.clone()))
        .collect();
    assert_eq!(labels, [("P001".to_owned(), "access denied".to_owned())]);
    // The file holds everything else, and names the drive and the format.
    let doc: Value = serde_json::from_str(&b.text().unwrap()).unwrap();
    assert_eq!(
        (
            &doc["format"],
            &doc["version"],
            &doc["family"],
            &doc["device_type"]
        ),
        (
            &json!(FORMAT),
            &json!(VERSION),
            &json!("movidrive"),
            &json!(7)
        )
    );
    let list = doc["parameters"].as_array().unwrap();
    let p130 = list
        .iter()
        .find(|e| e["index"] == index::RAMP_T11_UP_CW)
        .unwrap();
    assert_eq!(
        p130,
        &json!({"index": 8470, "sub": 0, "number": "P130", "name": "Ramp t11 up CW [s]",
                "raw": 8470, "writable": true})
    );
    assert!(
        !list
            .iter()
            .any(|e| e["index"] == 8318 || e["index"] == 8501)
    );
    // What a backup writes, a restore reads: every writable entry, read-only ones aside.
    let file =
        BackupFile::parse(b.text().unwrap().as_bytes(), Family::Movidrive, &[], &[]).unwrap();
    assert_eq!(file.len(), b.saved.len());
    assert!(file.skipped.iter().all(|(_, s)| *s == Skip::ReadOnly));
    assert_eq!(file.identity.get("device_type"), Some(&json!(7)));
}

#[test]
fn a_backup_ends_on_an_interrupt_or_a_failing_link() {
    let stop = Interrupt::new();
    stop.raise(Cause {
        name: "SIGTERM".into(),
        code: 15,
    });
    let mut seen = Seen::default();
    let e = block_on(backup(
        &mut FakeClient::<Interrupt>::new(answers),
        &mut seen,
        &stop,
    ))
    .unwrap_err();
    assert!(
        matches!(&e, BackupError::Interrupted { cause, saved: 0, .. } if cause.code == 15),
        "{e:?}"
    );
    assert_eq!(seen.0.last().map(String::as_str), Some("abandon"));
    let dead = |_| {
        Err(ClientError::link(
            crate::LinkFault::NoAnswer,
            "no answer from drive 1",
        ))
    };
    let e = block_on(backup(
        &mut FakeClient::<Interrupt>::new(dead),
        &mut (),
        &Interrupt::new(),
    ))
    .unwrap_err();
    assert_eq!(e.to_string(), "P000: no answer from drive 1");
}

fn parse(doc: &Value) -> Result<BackupFile, FileError> {
    BackupFile::parse(
        doc.to_string().as_bytes(),
        Family::Movidrive,
        NOT_RESTORED,
        LINK_SETTINGS,
    )
}

#[test]
fn commands_and_link_settings_in_a_file_are_kept_aside() {
    let doc = json!({
        "format": FORMAT, "version": VERSION, "family": "movidrive",
        "parameters": [
            {"index": 8470, "raw": 1200},
            // P804 = 1 would clear the fault memory; P810 would move the drive.
            {"index": 8596, "raw": 1},
            {"index": 8597, "raw": 7},
        ],
    });
    let file = parse(&doc).unwrap();
    let indices: Vec<u16> = file.entries.iter().map(|e| e.target.index).collect();
    assert_eq!(indices, [8470]);
    let skipped: Vec<(String, Skip)> = file
        .skipped
        .iter()
        .map(|(t, s)| (t.label(), s.clone()))
        .collect();
    assert_eq!(
        skipped,
        [
            ("P804".to_owned(), Skip::Command),
            ("P810".to_owned(), Skip::LinkSetting)
        ]
    );
    assert_eq!(file.len(), 3);
    // Bonfiglioli: a RAM-only value in a client's `not_restored` is one.
    let ram = json!({"format": FORMAT, "version": VERSION, "family": "bonfiglioli",
                     "parameters": [{"index": 410, "sub": 0, "raw": 1}]});
    let b =
        BackupFile::parse(ram.to_string().as_bytes(), Family::Bonfiglioli, &[410], &[]).unwrap();
    assert_eq!(b.skipped.first().map(|(_, s)| s), Some(&Skip::RamOnly));
}

#[test]
fn every_problem_of_a_file_is_typed() {
    let with = |list: Value| json!({"format": FORMAT, "version": VERSION, "family": "movidrive", "parameters": list});
    let entry = |entry, problem| Err(FileError::Entry { entry, problem });
    let twice = with(json!([
        {"index": 8470, "raw": 1200}, {"index": 8471, "raw": 1}, {"index": 8470, "raw": 1300},
    ]));
    assert_eq!(
        parse(&twice).map(|_| ()),
        entry(
            3,
            EntryError::Twice {
                label: "P130".into(),
                first: 1,
                second: 3
            }
        )
    );
    let e = parse(&twice).unwrap_err().to_string();
    assert_eq!(e, "entry 3: P130 appears twice (entries 1 and 3)");
    assert_eq!(
        parse(&with(json!([{"index": 70000, "raw": 1}]))).map(|_| ()),
        entry(1, EntryError::Index)
    );
    assert_eq!(
        parse(&with(json!([{"index": 8470, "sub": -1, "raw": 1}]))).map(|_| ()),
        entry(1, EntryError::Sub)
    );
    assert_eq!(
        parse(&with(json!([{"index": 8470, "raw": 1.5}]))).map(|_| ()),
        entry(1, EntryError::Raw)
    );
    assert_eq!(
        parse(&with(json!([{"index": 1, "raw": 1}]))).map(|_| ()),
        entry(
            1,
            EntryError::NotInTable {
                index: 1,
                family: Family::Movidrive
            }
        )
    );
    assert!(matches!(
        parse(&with(
            json!([{"index": 8470, "raw": 1_099_511_627_776_i64}])
        )),
        Err(FileError::Entry {
            entry: 1,
            problem: EntryError::Width(_)
        })
    ));
    assert_eq!(parse(&with(json!([]))).map(|_| ()), Err(FileError::Empty));
    assert_eq!(parse(&with(json!({}))).map(|_| ()), Err(FileError::NoList));
    let mut other = with(json!([]));
    other["family"] = "nord".into();
    assert_eq!(
        parse(&other).map(|_| ()),
        Err(FileError::OtherFamily {
            saved: "nord".into(),
            family: Family::Movidrive
        })
    );
    other.as_object_mut().unwrap().remove("family");
    assert_eq!(
        parse(&other).map(|_| ()),
        Err(FileError::NoFamily {
            family: Family::Movidrive
        })
    );
    other["version"] = 2.into();
    assert_eq!(parse(&other).map(|_| ()), Err(FileError::Format));
    let parse_bytes = |b: &[u8]| BackupFile::parse(b, Family::Movidrive, &[], &[]).map(|_| ());
    assert_eq!(parse_bytes(b"{\"a\xff"), Err(FileError::NotUtf8 { at: 3 }));
    assert!(matches!(parse_bytes(b"{"), Err(FileError::Json(_))));
    assert!(matches!(parse_bytes(b"[1]"), Err(FileError::Format)));
}

#[test]
fn a_file_as_notepad_saves_it_and_a_legacy_movilink_file_are_read() {
    let doc = json!({"format": FORMAT, "version": VERSION, "family": "movidrive",
                     "device_type": 7, "parameters": [{"index": 8470, "raw": 1000}]});
    let text =
        format!("\u{feff}{}", serde_json::to_string_pretty(&doc).unwrap()).replace('\n', "\r\n");
    let file = BackupFile::parse(text.as_bytes(), Family::Movidrive, &[], &[]).unwrap();
    assert_eq!(file.entries.first().map(|e| e.raw), Some(1000));
    assert_eq!(file.identity.get("device_type"), Some(&json!(7)));
    // The first MOVILINK backups had no family and sign-extended every 32-bit value: P130
    // takes no negative values, so −1 stands for 0xFFFFFFFF, which does not fit it.
    let legacy = json!({"format": LEGACY_MOVILINK, "version": VERSION,
                        "parameters": [{"index": 8470, "raw": 1000}]});
    let file = parse(&legacy).unwrap();
    assert_eq!(file.entries.len(), 1);
    assert_eq!(
        legacy_raw(-1_294_967_296, (0, u32::MAX.into())),
        3_000_000_000
    );
    assert_eq!(legacy_raw(-5, (-10, 10)), -5);
    // Only MOVIDRIVE reads it.
    let nord = BackupFile::parse(legacy.to_string().as_bytes(), Family::Nord, &[], &[]);
    assert!(matches!(nord, Err(FileError::Format)), "{nord:?}");
}

#[test]
fn rows_hold_every_data_set_and_nord_p560_last() {
    let bonf = rows(Family::Bonfiglioli);
    let p372: Vec<u16> = bonf
        .iter()
        .filter(|t| t.index == 372)
        .map(|t| t.sub)
        .collect();
    assert_eq!(p372, [1, 2, 3, 4]);
    let nord = rows(Family::Nord);
    assert_eq!(nord.last().map(|t| t.index), Some(NORD_SAVE_TO_EEPROM));
}

#[test]
fn the_file_text_is_the_drivebus_backup_v1_layout_byte_for_byte() {
    // What drivectl has written since version 1: the identification, the format's fields and
    // one object per value, keys in order, pretty-printed with two spaces, no final newline.
    let row = |index| {
        rows(Family::Movidrive)
            .into_iter()
            .find(|t| t.index == index)
    };
    let (Some(speed), Some(ramp)) = (row(8318), row(index::RAMP_T11_UP_CW)) else {
        panic!("P000 and P130 are in the MOVIDRIVE table");
    };
    let mut identity = Map::new();
    identity.insert("device_type".into(), 7.into());
    identity.insert("address".into(), 1.into());
    let b = Backup {
        family: Family::Movidrive,
        identity,
        saved: vec![
            Entry {
                target: speed,
                raw: -1500,
            },
            Entry {
                target: ramp,
                raw: 2000,
            },
        ],
        absent: 0,
        unreadable: Vec::new(),
    };
    let expected = r#"{
  "address": 1,
  "device_type": 7,
  "family": "movidrive",
  "format": "drivebus-backup",
  "parameters": [
    {
      "index": 8318,
      "name": "Speed [1/min]",
      "number": "P000",
      "raw": -1500,
      "sub": 0,
      "writable": false
    },
    {
      "index": 8470,
      "name": "Ramp t11 up CW [s]",
      "number": "P130",
      "raw": 2000,
      "sub": 0,
      "writable": true
    }
  ],
  "version": 1
}"#;
    assert_eq!(b.text().unwrap(), expected);
    // And it reads back as the values it holds (the read-only one kept aside).
    let file = BackupFile::parse(expected.as_bytes(), Family::Movidrive, &[], &[]).unwrap();
    let entries: Vec<(u16, i64)> = file
        .entries
        .iter()
        .map(|e| (e.target.index, e.raw))
        .collect();
    assert_eq!(entries, [(8470, 2000)]);
    assert_eq!(file.skipped.len(), 1);
}

#[test]
fn the_backup_summary_counts_what_was_saved_and_names_each_gap() {
    let mut c: FakeClient = FakeClient::new(answers);
    let done = block_on(backup(&mut c, &mut (), &Interrupt::new())).unwrap();
    let v = done.summary_json("b.json");
    assert_eq!(
        (&v["type"], &v["file"]),
        (&json!("backup"), &json!("b.json"))
    );
    assert_eq!(v["parameters"], done.saved.len());
    assert_eq!(v["skipped"], 1);
    assert_eq!(v["unreadable"][0]["label"], "P001");
    assert_eq!(v["unreadable"][0]["error"], "access denied");
    assert_eq!(
        done.gaps_text().as_deref(),
        Some(
            "the backup is incomplete: the drive refused to read 1 parameter(s): P001 (access denied)"
        )
    );
}
