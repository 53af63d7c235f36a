//! `drivectl demo`: the main job on an embedded default.
//!
//! It walks through what drivebus knows without any hardware: the parameter tables of every
//! family with their scaling, the DRIVECOM-style state machines driven by control words, a
//! MOVILINK session, an SBus session (on a virtual CAN bus, on a virtual clock), a Bonfiglioli
//! Modbus session (RTU and ASCII) and a NORD CTT2 session (through a simulated AS-i master, on
//! a virtual clock) against simulated drives.

use crate::error::CliError;
use crate::error::Result;
use crate::params::{all, lookup};
use crate::tool::output::trim_float;
use clap::Args;
use drive_profile::Family;
use drive_profile::bonfiglioli::{self, ActStateMachine};
use drive_profile::nord::{self, NordStateMachine};
use drive_profile::state::StateMachine;

/// Examples below `drivectl demo --help`.
mod on_ctt2;
mod on_modbus;
mod on_movilink;
mod on_sbus;

use self::on_ctt2::nord_session;
use self::on_modbus::bonfiglioli_session;
use self::on_movilink::movilink_session;
use self::on_sbus::sbus_session;

const AFTER_HELP: &str = "\
Examples:
  drivectl demo                  tables, state machines, simulated MOVILINK, SBus, Modbus and CTT2 sessions
  drivectl demo | less           page through it";

/// Arguments of `drivectl demo`: none; it runs without hardware, on simulated drives.
#[derive(Debug, Args)]
#[command(after_help = AFTER_HELP)]
pub struct DemoArgs {}

/// Run the demonstration.
pub fn run(_args: &DemoArgs) -> Result<()> {
    outln!("drivebus demo: everything below runs without hardware.\n")?;
    tables()?;
    nord_walk()?;
    bonfiglioli_walk()?;
    let rt = crate::tool::line::runtime()?;
    rt.block_on(movilink_session())?;
    // The CAN frame times run on a virtual clock too: exact and deterministic.
    crate::tool::line::run_virtual(sbus_session())??;
    rt.block_on(bonfiglioli_session())?;
    // The AS-i transfer times run on a virtual clock: counted exactly, not waited.
    crate::tool::line::run_virtual(nord_session())??;
    Ok(())
}

fn tables() -> Result<()> {
    outln!("== Parameter tables generated from the manuals")?;
    for family in Family::ALL {
        outln!(
            "  {:<12} {:>4} parameters",
            family.name(),
            all(family).len()
        )?;
    }
    outln!()?;
    let samples = [
        (Family::Movidrive, "8318", 1_000_000),
        (Family::Movidrive, "P813", 5),
        (Family::Nord, "P102", 1000),
        (Family::Bonfiglioli, "1376", 1),
    ];
    for (family, key, raw) in samples {
        let p = lookup(family, key)?;
        outln!(
            "  {:<12} {:<8} {:<28} index {:>5}: raw {raw} = {} {}",
            family.name(),
            p.label(),
            p.name_en(),
            p.bus_index(),
            trim_float(p.to_physical(raw), p.decimals()),
            p.unit()
        )?;
    }
    outln!()?;
    Ok(())
}

/// How many control words a walk may take before the demo calls it stuck.
const MAX_STEPS: usize = 8;

/// NORD: drive the state machine from switch-on disabled to operation enabled and back, with a
/// drive that follows the manual's transition table.
fn nord_walk() -> Result<()> {
    use nord::State;
    outln!("== NORD state machine (control word → status word)")?;
    let status_of = |s: State| nord::state_info(s).map_or(0, |i| i.value);
    let mut state = State::SwitchOnDisabled;
    let mut last = 0u16;
    for target in [State::OperationEnabled, State::SwitchOnDisabled] {
        outln!("  target: {}", target.name_en())?;
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
            outln!(
                "    status 0x{status:04X} {:<24} send 0x{word:04X} → {}",
                decoded.name_en(),
                next.name_en()
            )?;
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
    outln!()?;
    Ok(())
}

/// Bonfiglioli ACT: the same walk, using the shortcut transition 4 from switch-on disabled.
fn bonfiglioli_walk() -> Result<()> {
    use bonfiglioli::State;
    outln!("== Bonfiglioli ACT state machine (control word 410 → status word 411)")?;
    let status_of = |s: State| {
        bonfiglioli::state::ACT_PATTERNS
            .iter()
            .find(|p| p.state == s)
            .map_or(0, |p| p.value)
    };
    let mut state = State::SwitchOnDisabled;
    for target in [State::OperationEnabled, State::SwitchOnDisabled] {
        outln!("  target: {target}")?;
        for _ in 0..MAX_STEPS {
            let status = status_of(state);
            let decoded = ActStateMachine::decode(status);
            let Some(word) = ActStateMachine::control_toward(decoded, target) else {
                break;
            };
            let next = bonfiglioli::act_transitions()
                .find(|t| t.from == decoded && t.word == word)
                .map_or(decoded, |t| t.to);
            outln!(
                "    status 0x{status:04X} {:<24} send 0x{word:04X} → {next}",
                decoded.name_en()
            )?;
            state = next;
        }
        if state != target {
            return Err(CliError::failed(format!("ACT walk stuck in {state}")));
        }
    }
    outln!()?;
    Ok(())
}
