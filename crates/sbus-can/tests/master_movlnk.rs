//! The MOVLNK command (manual ch. 5.3): parsing from IPOS variables, the telegrams it sends,
//! the answers back into ReadPar/PI/Result, the manual's example and its inconsistencies
//! (errata SB-E41 … SB-E43).

// Test code: helpers outside `#[test]` fns (not exempted by clippy.toml) panic by design.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

mod common;

use std::time::Duration;

use common::Responder;
use drive_core::Instant;
use drive_core::can::CanEndpoint;
use drive_profile::sew::{self, ReturnCode, StatusWord1, UnitStatus, index};
use sbus_can::movlnk::{
    BusType, Format, MlData, MovlnkCommand, MovlnkDone, MovlnkError, MovlnkMaster, MovlnkService,
    Target,
};
use sbus_can::telegram::ProcessData;
use sbus_can::{Address, master::MasterConfig};

/// Run `m` against `drive` (zero latency) until the command is done; every frame on the bus.
fn run(m: &mut MovlnkMaster, drive: &mut Responder) -> (MovlnkDone, Vec<String>) {
    let mut now = Instant::ZERO;
    let mut log = Vec::new();
    for _ in 0..1000 {
        m.handle_timeout(now);
        if let Some(d) = m.poll_done() {
            return (d, log);
        }
        while let Some(f) = m.poll_transmit(now) {
            log.push(f.to_string());
            drive.handle_frame(&f, now);
        }
        while let Some(f) = drive.poll_transmit(now) {
            log.push(f.to_string());
            m.handle_frame(&f, now);
        }
        if let Some(d) = m.poll_done() {
            return (d, log);
        }
        now = m.poll_timeout().unwrap_or(now).later(now);
    }
    panic!("the command did not finish: {log:?}");
}

/// The manual's command: BusType 5, Address 1, Format 4, Service 1, Index 8318, DPointer H20.
const MANUAL: [i32; 7] = [5, 1, 4, 1, 8318, 20, 0];

/// Manual ch. 5.3, the example as a test vector: PO 6/5000/15000 → ReadPar 1 000 000,
/// PI 7/5011/0, Result 0.
#[test]
fn manual_example_5_3() {
    let cmd = MovlnkCommand::from_vars(MANUAL).unwrap();
    assert_eq!(
        cmd,
        MovlnkCommand {
            bus_type: BusType::SBus,
            target: Target::Single(Address::new(1).unwrap()),
            format: Format::Param3Pd,
            service: MovlnkService::Read,
            index: 8318,
            dpointer: 20,
        }
    );
    assert_eq!(cmd.to_vars(0), MANUAL);
    let data = MlData::from_vars([0, 0, 6, 5000, 15000, 0, 0, 0]);
    let mut drive = Responder::new(1);
    drive.pi = Some(ProcessData([7, 5011, 0]));
    let mut m = MovlnkMaster::new(MasterConfig::default());
    m.execute(cmd, data, Instant::ZERO).unwrap();
    let (done, log) = run(&mut m, &mut drive);
    assert_eq!(done.result, 0);
    assert_eq!(done.error, None);
    assert_eq!(
        done.data.to_vars(),
        [0, 1_000_000, 6, 5000, 15000, 7, 5011, 0]
    );
    // Parameter request 8a + 515, response 8a + 516, PO 8a + 3, PI 8a + 4.
    assert_eq!(
        log,
        [
            "20B#3100207E00000000",
            "20C#3100207E000F4240",
            "00B#000613883A98",
            "00C#000713930000",
        ]
    );
    // PO2 5000 = 1000 1/min at 0.2 1/min per digit; PO3 15000 = 3000 1/min.
    assert_eq!((5000 / 5, 15000 / 5), (1000, 3000));
}

/// SB-E41: the table sets PO3 = 15000 "programmed to maximum speed", the program listing
/// `Mld.PO3 = 0; // reserved` and the watch window 0. With the factory setting P872 = 0
/// "no function" (ch. 5.1 table: KEINE FUNKTION) PO3 carries nothing: the listing's 0 is the
/// consistent value; 15000 needs P872 = 5 "maximum speed" first. The executor sends whatever
/// the variable holds, so the frames differ only in the last word.
#[test]
fn po3_table_vs_listing_sb_e41() {
    let p872 = sew::by_number(872).unwrap();
    assert_eq!(p872.default, Some(0));
    let names: Vec<(i64, &str)> = p872.values.iter().map(|v| (v.value, v.en)).collect();
    assert!(names.contains(&(0, "no function")));
    assert!(names.contains(&(5, "maximum speed")));
    let cmd = MovlnkCommand::from_vars(MANUAL).unwrap();
    let table = MlData::from_vars([0, 0, 6, 5000, 15000, 0, 0, 0]);
    let listing = MlData::from_vars([0, 0, 6, 5000, 0, 0, 0, 0]);
    assert_eq!(
        cmd.process_output(&table).unwrap(),
        Some(ProcessData([6, 5000, 15000]))
    );
    assert_eq!(
        cmd.process_output(&listing).unwrap(),
        Some(ProcessData([6, 5000, 0]))
    );
}

/// SB-E42: the listing comments index 8318 as "// Status"; 8318 is P000 speed (the table's
/// "Drehzahl", 0.001 1/min, so 1 000 000 = 1000 1/min); the drive status is P010, 8310.
#[test]
fn index_8318_is_speed_not_status_sb_e42() {
    let p = sew::by_index(8318).unwrap();
    assert_eq!(p.menu_label().as_str(), "P000");
    assert_eq!(p.name_en, "Speed [1/min]");
    // The names callers use find those rows of the table: speed P000, drive status P010.
    let label = |i| sew::by_index(i).unwrap().menu_label();
    assert_eq!(label(index::SPEED).as_str(), "P000");
    assert_eq!(label(index::DRIVE_STATUS).as_str(), "P010");
}

/// SB-E43: the table's PI1 = 7 is no status word of a running drive: bits 0–2 (output stage
/// enabled, ready, PO data enabled) with high byte 0, unit status "24 V operation" (not
/// ready). A drive enabled at 1002 1/min reports unit status 4 or 5 (0407h = 1031). The watch
/// window's 514 = 0202h is consistent with its own other values: ready, PO data *not* enabled,
/// unit status 2 "no enable", so PO1 = 6 is not taken, PI2 = 0 and ReadPar = 0.
#[test]
fn pi1_status_word_table_vs_watch_sb_e43() {
    let table = StatusWord1::from_bits(7);
    assert!(table.contains(StatusWord1::OUTPUT_STAGE_ENABLED));
    assert_eq!(table.unit_status(), Some(UnitStatus::Supply24V));
    let running = StatusWord1::from_bits(0x0407);
    assert_eq!(running.unit_status(), Some(UnitStatus::Enable));
    let watch = StatusWord1::from_bits(514);
    assert_eq!(watch.bits(), 0x0202);
    assert!(!watch.contains(StatusWord1::OUTPUT_STAGE_ENABLED));
    assert!(!watch.contains(StatusWord1::PO_DATA_ENABLED));
    assert_eq!(watch.unit_status(), Some(UnitStatus::NoEnable));
}

#[test]
fn command_checks() {
    let with = |i: usize, v: i32| {
        let mut vars = MANUAL;
        vars[i] = v;
        MovlnkCommand::from_vars(vars)
    };
    for reserved in [0, 3, 4, 6, -1] {
        assert_eq!(with(0, reserved), Err(MovlnkError::BusType(reserved)));
    }
    assert_eq!(with(0, 1).unwrap().bus_type, BusType::S0);
    assert_eq!(with(0, 2).unwrap().bus_type, BusType::S1);
    for bad in [64, 99, 164, -1] {
        assert_eq!(with(1, bad), Err(MovlnkError::Address(bad)));
    }
    assert_eq!(
        with(1, 63).unwrap().target,
        Target::Single(Address::new(63).unwrap())
    );
    // A group: 100 + group address; only writes.
    assert_eq!(with(1, 163), Err(MovlnkError::ReadFromGroup));
    let mut vars = MANUAL;
    vars[1] = 102;
    vars[3] = 3;
    assert_eq!(
        MovlnkCommand::from_vars(vars).unwrap().target,
        Target::Group(Address::new(2).unwrap())
    );
    assert_eq!(with(2, 7), Err(MovlnkError::Format(7)));
    assert_eq!(with(3, 0), Err(MovlnkError::Service(0)));
    assert_eq!(with(4, 65536), Err(MovlnkError::Index(65536)));
    assert_eq!(with(5, 1017), Err(MovlnkError::DPointer(1017)));
    assert_eq!(with(5, 1016).unwrap().dpointer, 1016);
    assert_eq!(
        MovlnkError::BusType(3).to_string(),
        "MI.BusType 3 is not 1 (S0), 2 (S1) or 5 (SBus); 0, 3 and 4 are reserved"
    );
    // PO values are never cut.
    let cmd = MovlnkCommand::from_vars(MANUAL).unwrap();
    let big = MlData::from_vars([0, 0, 6, 70_000, 0, 0, 0, 0]);
    assert_eq!(
        cmd.process_output(&big),
        Err(MovlnkError::ProcessOutput {
            word: 2,
            value: 70_000
        })
    );
    let neg = MlData::from_vars([0, 0, 6, -5000, 0, 0, 0, 0]);
    assert_eq!(
        cmd.process_output(&neg).unwrap(),
        Some(ProcessData([6, 0xEC78, 0]))
    );
    let mut m = MovlnkMaster::new(MasterConfig::default());
    assert_eq!(
        m.execute(cmd, big, Instant::ZERO),
        Err(MovlnkError::ProcessOutput {
            word: 2,
            value: 70_000
        })
    );
    assert!(!m.is_busy());
    assert_eq!(
        m.execute(with(0, 1).unwrap(), MlData::default(), Instant::ZERO),
        Err(MovlnkError::NotSbus(BusType::S0))
    );
}

#[test]
fn formats_write_group_and_result_codes() {
    // Format 1 (1PD): one PO word, the others 0; only PI1 stored.
    let mut drive = Responder::new(1);
    drive.pi = Some(ProcessData([0x0407, 1234, 99]));
    let mut m = MovlnkMaster::new(MasterConfig::default());
    let cmd = MovlnkCommand::from_vars([5, 1, 1, 1, 0, 20, 0]).unwrap();
    m.execute(
        cmd,
        MlData::from_vars([0, 0, 6, 5000, 7, -1, -1, -1]),
        Instant::ZERO,
    )
    .unwrap();
    let (done, log) = run(&mut m, &mut drive);
    assert_eq!(log[0], "00B#000600000000");
    assert_eq!(done.data.pi, [0x0407, -1, -1]);
    // Format 6 write volatile: WritePar as the data (32-bit two's complement).
    let cmd = MovlnkCommand::from_vars([5, 1, 6, 3, 8470, 20, 0]).unwrap();
    m.execute(
        cmd,
        MlData::from_vars([-2, 0, 0, 0, 0, 0, 0, 0]),
        Instant::ZERO,
    )
    .unwrap();
    let (done, log) = run(&mut m, &mut drive);
    assert_eq!(log[0], "20B#33002116FFFFFFFE");
    assert_eq!(done.result, 0);
    assert_eq!(drive.values[3], (8470, 0xFFFF_FFFE));
    // A refusal: Result = the return code's 32 bits (08000012h read only).
    let cmd = MovlnkCommand::from_vars([5, 1, 6, 2, 8318, 20, 0]).unwrap();
    m.execute(cmd, MlData::default(), Instant::ZERO).unwrap();
    let (done, _) = run(&mut m, &mut drive);
    assert_eq!(done.error, Some(MovlnkError::Drive(ReturnCode::READ_ONLY)));
    assert_eq!(done.result, 0x0800_0012);
    // A group write: 8g + 518 and GPO 8g + 6, unanswered, Result 0.
    drive.group = Address::new(2).unwrap();
    let cmd = MovlnkCommand::from_vars([5, 102, 2, 3, 8470, 20, 0]).unwrap();
    m.execute(
        cmd,
        MlData::from_vars([500, 0, 6, 100, 0, 0, 0, 0]),
        Instant::ZERO,
    )
    .unwrap();
    let (done, log) = run(&mut m, &mut drive);
    assert_eq!(log, ["216#33002116000001F4", "016#000600640000"]);
    assert_eq!(done.result, 0);
    assert_eq!(drive.po, ProcessData([6, 100, 0]));
    // Nobody at address 9: timeout, Result -1; ReadPar and PI untouched.
    let mut m = MovlnkMaster::new(MasterConfig {
        response_timeout: Duration::from_millis(5),
        retries: 0,
        ..MasterConfig::default()
    });
    let cmd = MovlnkCommand::from_vars([5, 9, 4, 1, 8318, 20, 0]).unwrap();
    let before = MlData::from_vars([0, 42, 6, 0, 0, 1, 2, 3]);
    m.execute(cmd, before, Instant::ZERO).unwrap();
    let (done, log) = run(&mut m, &mut drive);
    assert_eq!(done.result, MovlnkError::RESULT_TIMEOUT);
    assert_eq!(done.data, before);
    assert_eq!(log.len(), 2, "{log:?}");
    // A drive code that would read as 0 or negative is not taken for success or a local code.
    assert_eq!(
        MovlnkError::Drive(ReturnCode::new(0, 0, 0)).result_code(),
        MovlnkError::RESULT_UNREADABLE_CODE
    );
    assert_eq!(
        MovlnkError::Drive(ReturnCode::new(0xFF, 0xFF, 0xFFFF)).result_code(),
        MovlnkError::RESULT_UNREADABLE_CODE
    );
}
