//! `drivectl demo`: the main job on an embedded default.
//!
//! It walks through what drivebus knows without any hardware: the parameter tables of every
//! family with their scaling, and the DRIVECOM-style state machines driven by control words.

use crate::error::CliError;
use crate::error::Result;
use crate::params::{all, label, lookup, trim_float};
use clap::Args;
use drive_profile::Family;
use drive_profile::bonfiglioli::{self, ActStateMachine};
use drive_profile::nord::{self, NordStateMachine};
use drive_profile::state::StateMachine;

/// Arguments of `drivectl demo`.
#[derive(Debug, Args)]
pub struct DemoArgs {}

/// Run the demonstration.
pub fn run(_args: &DemoArgs) -> Result<()> {
    println!("drivebus demo: everything below runs without hardware.\n");
    tables()?;
    nord_walk()?;
    bonfiglioli_walk()?;
    Ok(())
}

fn tables() -> Result<()> {
    println!("== Parameter tables generated from the manuals");
    for family in Family::ALL {
        println!(
            "  {:<12} {:>4} parameters",
            family.name(),
            all(family).len()
        );
    }
    println!();
    let samples = [
        (Family::Movidrive, "8318", 1_000_000),
        (Family::Movidrive, "P813", 5),
        (Family::Nord, "P102", 1000),
        (Family::Bonfiglioli, "1376", 1),
    ];
    for (family, key, raw) in samples {
        let p = lookup(family, key)?;
        println!(
            "  {:<12} {:<8} {:<28} index {:>5}: raw {raw} = {} {}",
            family.name(),
            label(p),
            p.name_en(),
            p.bus_index(),
            trim_float(p.to_physical(raw), p.decimals()),
            p.unit()
        );
    }
    println!();
    Ok(())
}

/// How many control words a walk may take before the demo calls it stuck.
const MAX_STEPS: usize = 8;

/// NORD: drive the state machine from switch-on disabled to operation enabled and back, with a
/// drive that follows the manual's transition table.
fn nord_walk() -> Result<()> {
    use nord::State;
    println!("== NORD state machine (control word → status word)");
    let status_of = |s: State| s.info().map_or(0, |i| i.value);
    let mut state = State::SwitchOnDisabled;
    let mut last = 0u16;
    for target in [State::OperationEnabled, State::SwitchOnDisabled] {
        println!("  target: {}", target.name_en());
        for _ in 0..MAX_STEPS {
            let status = status_of(state);
            let decoded = NordStateMachine::decode(status);
            let Some(word) = NordStateMachine::next_control(last, decoded, target) else {
                break;
            };
            let next = nord::transitions()
                .iter()
                .find(|t| t.from.is_none_or(|f| f == decoded) && t.triggered_by(last, word))
                .map_or(decoded, |t| t.to);
            println!(
                "    status 0x{status:04X} {:<24} send 0x{word:04X} → {}",
                decoded.name_en(),
                next.name_en()
            );
            last = word;
            state = next;
        }
        if state != target {
            return Err(CliError::failed(format!(
                "NORD walk stuck in {}",
                state.name_en()
            )));
        }
    }
    println!();
    Ok(())
}

/// Bonfiglioli ACT: the same walk, using the shortcut transition 4 from switch-on disabled.
fn bonfiglioli_walk() -> Result<()> {
    use bonfiglioli::State;
    println!("== Bonfiglioli ACT state machine (control word 410 → status word 411)");
    let status_of = |s: State| {
        bonfiglioli::state::ACT_PATTERNS
            .iter()
            .find(|p| p.state == s)
            .map_or(0, |p| p.value)
    };
    let mut state = State::SwitchOnDisabled;
    for target in [State::OperationEnabled, State::SwitchOnDisabled] {
        println!("  target: {target}");
        for _ in 0..MAX_STEPS {
            let status = status_of(state);
            let decoded = ActStateMachine::decode(status);
            let Some(word) = ActStateMachine::control_toward(decoded, target) else {
                break;
            };
            let next = bonfiglioli::act_transitions()
                .find(|t| t.from == decoded && t.word == word)
                .map_or(decoded, |t| t.to);
            println!(
                "    status 0x{status:04X} {:<24} send 0x{word:04X} → {next}",
                decoded.name_en()
            );
            state = next;
        }
        if state != target {
            return Err(CliError::failed(format!("ACT walk stuck in {state}")));
        }
    }
    println!();
    Ok(())
}
