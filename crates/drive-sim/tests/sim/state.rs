//! State machine transitions.

use drive_sim::{Command, DriveState, DriveStateMachine, FaultReaction, SimError};

const COMMANDS: [Command; 5] = [
    Command::Enable,
    Command::Stop,
    Command::QuickStop,
    Command::Inhibit,
    Command::FaultReset,
];

fn machine_in(state: DriveState) -> DriveStateMachine {
    let mut m = DriveStateMachine::new();
    match state {
        DriveState::Inhibited => {}
        DriveState::Ready => {
            m.apply(Command::Stop).unwrap();
        }
        DriveState::Enabled => {
            m.apply(Command::Enable).unwrap();
        }
        DriveState::QuickStop => {
            m.apply(Command::Enable).unwrap();
            m.apply(Command::QuickStop).unwrap();
        }
        DriveState::Fault(code) => {
            m.raise_fault(code);
        }
    }
    assert_eq!(m.state(), state);
    m
}

#[test]
fn transition_table() {
    use DriveState::*;
    let f = Fault(7);
    let faulted = Err(SimError::Faulted { code: 7 });
    // rows: from; columns: enable, stop, quick_stop, inhibit, fault_reset
    let table: [(DriveState, [Result<DriveState, SimError>; 5]); 5] = [
        (
            Inhibited,
            [
                Ok(Enabled),
                Ok(Ready),
                Ok(Inhibited),
                Ok(Inhibited),
                Ok(Inhibited),
            ],
        ),
        (
            Ready,
            [
                Ok(Enabled),
                Ok(Ready),
                Ok(QuickStop),
                Ok(Inhibited),
                Ok(Ready),
            ],
        ),
        (
            Enabled,
            [
                Ok(Enabled),
                Ok(Ready),
                Ok(QuickStop),
                Ok(Inhibited),
                Ok(Enabled),
            ],
        ),
        (
            QuickStop,
            [
                Ok(Enabled),
                Ok(Ready),
                Ok(QuickStop),
                Ok(Inhibited),
                Ok(QuickStop),
            ],
        ),
        (f, [faulted, faulted, faulted, Ok(f), Ok(Inhibited)]),
    ];
    for (from, expected) in table {
        for (cmd, want) in COMMANDS.iter().zip(expected) {
            let mut m = machine_in(from);
            let got = m.apply(*cmd);
            assert_eq!(got, want, "{from:?} --{cmd:?}-->");
            let after = want.unwrap_or(from);
            assert_eq!(m.state(), after, "{from:?} --{cmd:?}--> state");
        }
    }
}

#[test]
fn faults_keep_the_first_code_until_reset() {
    let mut m = machine_in(DriveState::Enabled);
    assert_eq!(m.raise_fault(4), DriveState::Fault(4));
    assert_eq!(m.raise_fault(9), DriveState::Fault(4));
    assert_eq!(m.state().fault_code(), Some(4));
    assert_eq!(m.apply(Command::FaultReset), Ok(DriveState::Inhibited));
    assert_eq!(m.raise_fault(9), DriveState::Fault(9));
}

#[test]
fn output_stage_and_defaults() {
    assert!(!DriveState::Inhibited.output_stage_on());
    assert!(DriveState::Ready.output_stage_on());
    assert!(DriveState::Enabled.output_stage_on());
    assert!(DriveState::QuickStop.output_stage_on());
    assert!(!DriveState::Fault(1).output_stage_on());
    assert_eq!(DriveState::Enabled.fault_code(), None);
    let mut m = DriveStateMachine::default();
    assert_eq!(m.state(), DriveState::Inhibited);
    assert_eq!(m.fault_reaction(), FaultReaction::Coast);
    m.set_fault_reaction(FaultReaction::QuickStop);
    assert_eq!(m.fault_reaction(), FaultReaction::QuickStop);
    m.apply(Command::Enable).unwrap();
    m.restart();
    assert_eq!(m.state(), DriveState::Inhibited);
}
