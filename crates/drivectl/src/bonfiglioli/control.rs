//! `control`: the state machine driven through the control word 410 (412 = 1), the reference
//! frequency 484 written first.

use super::*;

/// A reference frequency in Hz as 484's raw value (2 decimals, ±999.99 Hz).
pub fn freq_raw(text: &str) -> Result<i64> {
    let t = resolve("484", 0)?;
    let v = t.value_from_text(text, &ValueText::default())?;
    Ok(v.raw)
}

pub struct ControlSession<'a> {
    pub addr: Address,
    pub action: &'a str,
    pub freq: Option<i64>,
    pub variant: Variant,
    pub json: bool,
    /// The command line that reaches the drive again (for the hint that says how to stop it).
    pub again: Again,
}

/// How long the stop of an interrupted `control enable` waits for the drive to leave
/// "operation enabled".
pub const STOP_WAIT: Duration = Duration::from_secs(5);

/// What `control` reached: the last status word and control word.
pub struct Reached {
    word: u16,
    last: Option<u16>,
    /// `enable`: 241 actual frequency in Hz once enabled (read as part of the enabling, so an
    /// interrupt during it still stops the motor).
    actual: Option<f64>,
}

/// The state `action` drives toward.
pub fn target_of_action(action: &str) -> Result<State> {
    match action {
        "enable" => Ok(State::OperationEnabled),
        "stop" => Ok(State::SwitchedOn),
        "quick-stop" => Ok(State::QuickStopActive),
        "disable" | "reset" => Ok(State::SwitchOnDisabled),
        other => Err(CliError::usage(format!("unknown control action `{other}`"))),
    }
}

/// `control`: 412 = 1 (state machine) in RAM, the reference frequency 484 (RAM), then control
/// words 410 toward the action's state, polling 411 until it is reached. `enable` runs under
/// the motor guard ([`MotorGuard`]): an interrupt, a closed pipe or a failure while enabling
/// sends "disable operation" (0x0007, transition 5: the drive stops as P392 says, by default
/// on its ramp); once enabled, the motor keeps running on purpose and the note says how to
/// stop it.
pub async fn control<IO: CharIo>(m: &mut MasterDriver<IO>, s: &ControlSession<'_>) -> Result<()> {
    let addr = s.addr;
    let target = target_of_action(s.action)?;
    let stop_command = s.again.then("control stop");
    let enabling = s.action == "enable";
    let guard = enabling.then(|| MotorGuard::install(AtEnd::Run, stop_command.clone()));
    let work = async |m: &mut MasterDriver<IO>, motion: &Motion<'_>| -> Result<Reached> {
        control_steps(m, s, target, motion).await
    };
    let reached = match &guard {
        Some(g) => {
            let stop = async |m: &mut MasterDriver<IO>| -> Result<Stopped> {
                let cw = bonfiglioli::state::command::DISABLE_OPERATION;
                write_cw(m, addr, cw).await?;
                // Transition 5 follows P392: by default the drive stops on its ramp first and
                // only then shows "switched on". Wait a few seconds for it (a second signal
                // ends the wait at once).
                let deadline = tokio::time::Instant::now() + STOP_WAIT;
                let mut word = read_word(m, addr, param::STATUS_WORD).await?;
                while s.variant.state(word) == State::OperationEnabled
                    && tokio::time::Instant::now() < deadline
                {
                    tokio::time::sleep(Duration::from_millis(50)).await;
                    word = read_word(m, addr, param::STATUS_WORD).await?;
                }
                let state = s.variant.state(word);
                Ok(Stopped {
                    sent: format!("disable operation (410 = 0x{cw:04X})"),
                    reports: if state == State::OperationEnabled {
                        format!(
                            "411 = 0x{word:04X} still operation enabled after {} s: it stops as \
                             P392 says (by default on its ramp)",
                            STOP_WAIT.as_secs()
                        )
                    } else {
                        format!("411 = 0x{word:04X} {}", state.name_en())
                    },
                })
            };
            g.run(m, work, stop).await?
        }
        None => {
            // Not a command that moves the motor: an interrupt ends the waiting, and the
            // drive is left in whatever state it reached.
            let interrupt =
                Interrupt::install("the drive may not have reached the state asked for");
            let armed = std::cell::Cell::new(false);
            control_steps(m, s, target, &Motion::new(interrupt.inner(), &armed)).await?
        }
    };
    let word = reached.word;
    let state = s.variant.state(word);
    let done = s.action == "reset" && state != State::Fault || state == target;
    // Said before the output, so that a closed standard output cannot swallow it.
    let actual = reached.actual;
    if done && enabling {
        let f = actual;
        if let Some(g) = &guard {
            g.left_running(&format!(
                "the motor is enabled (411 = 0x{word:04X} {}){}",
                state.name_en(),
                f.as_ref().map_or_else(String::new, |hz| format!(
                    ", actual frequency 241 = {hz:.2} Hz"
                ))
            ));
        }
    }
    let freq = s.freq.map(|raw| {
        // 484 is write-only on the ACU: never read back. The drive's answer repeated the value
        // (the master checks the echo), and the actual frequency shows the drive follows it.
        json!({"raw": raw, "hz": raw as f64 / 100.0, "confirmed_by": "echo"})
    });
    if s.json {
        outln!(
            "{}",
            json!({"address": addr.get(), "action": s.action, "status_word": word,
                   "state": state.name_en(), "reached": done,
                   "control_word": reached.last, "freq_raw": s.freq,
                   "reference": freq, "actual_frequency_hz": actual})
        )?;
    } else {
        if let Some(raw) = s.freq {
            outln!(
                "reference frequency 484 = {:.2} Hz written to RAM, confirmed by the drive's echo \
                 of the write (484 is write-only on the ACTIVE Cube and is never read back){}",
                raw as f64 / 100.0,
                actual.map_or_else(String::new, |hz| format!(
                    "; actual frequency 241 = {hz:.2} Hz"
                ))
            )?;
        }
        outln!(
            "status word 411: 0x{word:04X} = {} ({})",
            state.name_en(),
            bits_text(word, s.variant)
        )?;
    }
    if !done {
        return Err(CliError::failed(format!(
            "the drive did not reach {} (it shows {}); check the hardware enable (ACT: S1IND, \
             ACU: STOA/STOB), 412 local/remote and the current fault (`{}`)",
            target.name_en(),
            state.name_en(),
            s.again.then("status")
        )));
    }
    Ok(())
}

/// 241 actual frequency in Hz, if the drive answers it.
pub async fn actual_frequency<IO: CharIo>(m: &mut MasterDriver<IO>, addr: Address) -> Option<f64> {
    let t = resolve("241", 0).ok()?;
    let width = table_width(&t, None)?;
    let data = m.read(addr, 241, DataSet::ALL, width).await.ok()?;
    let p = t.param?;
    Some(p.to_physical(raw_of(&t, width, data)))
}

/// The steps of `control` toward `target`, checking the interrupt between exchanges.
pub async fn control_steps<IO: CharIo>(
    m: &mut MasterDriver<IO>,
    s: &ControlSession<'_>,
    target: State,
    motion: &Motion<'_>,
) -> Result<Reached> {
    let addr = s.addr;
    let stop = motion.interrupt();
    let t412 = resolve("412", 0)?;
    // 412 = 1: the control word drives the state machine (a data-set parameter: all four).
    let mode = m
        .read(
            addr,
            param::LOCAL_REMOTE,
            DataSet::new(1).unwrap_or(DataSet::ALL),
            Width::Word,
        )
        .await
        .map_err(|e| t412.error(client_error(Width::Word, e)))?;
    if mode != 1 {
        m.write(
            addr,
            param::LOCAL_REMOTE,
            DataSet::new(5).unwrap_or(DataSet::ALL),
            Width::Word,
            1,
        )
        .await
        .map_err(|e| t412.error(client_error(Width::Word, e)))?;
        errln!(
            "drivectl: note: 412 local/remote was {mode}; set to 1 (state machine) in RAM \
             (data set 5: all four data sets, not stored)"
        );
    }
    if let Some(raw) = s.freq {
        let t = resolve("484", 0)?;
        let data = data_of(Width::Long, raw).unwrap_or(0);
        // The reference moves a running motor at once.
        motion.armed();
        m.write(addr, param::FREQUENCY_RAM, DataSet::ALL, Width::Long, data)
            .await
            .map_err(|e| t.error(client_error(Width::Long, e)))?;
    }
    // The ACU with positioning control (configuration 30 = x40) has no shortcut 4' (ch. 10.2).
    let positioning = s.variant == Variant::Acu && {
        let t30 = resolve(&param::CONFIGURATION.to_string(), 0)?;
        let mut c = client(m, addr, "", None).probing();
        match c.read(&t30).await {
            Ok(config) => config % 100 == 40,
            Err(ClientError::Device(d)) => {
                errln!(
                    "drivectl: note: configuration 30 cannot be read ({d}): going on as without \
                     positioning control"
                );
                false
            }
            Err(e) => return Err(t30.error(e)),
        }
    };
    let mut last: Option<u16> = None;
    let mut word = read_word(m, addr, param::STATUS_WORD).await?;
    let start_state = s.variant.state(word);
    if s.action == "reset" && start_state != State::Fault {
        errln!(
            "drivectl: note: the drive shows no fault ({})",
            start_state.name_en()
        );
    }
    // At most a handful of steps: every state reaches every target in four.
    for _ in 0..8 {
        if stop.requested() {
            break;
        }
        let state = s.variant.state(word);
        let next = if s.action == "reset" && state == State::Fault {
            Some(bonfiglioli::state::command::FAULT_RESET)
        } else if s.action == "reset" {
            None
        } else if s.variant == Variant::Acu && positioning {
            // No shortcut 4' with positioning control (ch. 10.2).
            AcuPositioningStateMachine::control_toward(state, target)
        } else if s.variant == Variant::Acu {
            AcuStateMachine::control_toward(state, target)
        } else {
            ActStateMachine::control_toward(state, target)
        };
        let Some(cw) = next else { break };
        motion.armed();
        // A fault reset acts on a rising edge of bit 7.
        if cw & 0x80 != 0 && last.is_none_or(|l| l & 0x80 != 0) {
            write_cw(m, addr, cw & !0x80).await?;
        }
        write_cw(m, addr, cw).await?;
        last = Some(cw);
        // The drive may take a while (a stop ramps down first): poll until the state changes.
        let deadline = tokio::time::Instant::now() + Duration::from_secs(15);
        loop {
            tokio::select! {
                () = tokio::time::sleep(Duration::from_millis(50)) => {}
                () = stop.wait() => {}
            }
            word = read_word(m, addr, param::STATUS_WORD).await?;
            if s.variant.state(word) != state
                || tokio::time::Instant::now() >= deadline
                || stop.requested()
            {
                break;
            }
        }
        if s.variant.state(word) == state || s.action == "reset" {
            break;
        }
    }
    let actual = if s.action == "enable" && s.variant.state(word) == target {
        actual_frequency(m, addr).await
    } else {
        None
    };
    Ok(Reached { word, last, actual })
}

pub async fn write_cw<IO: CharIo>(m: &mut MasterDriver<IO>, addr: Address, cw: u16) -> Result<()> {
    let t = resolve("410", 0)?;
    m.write(
        addr,
        param::CONTROL_WORD,
        DataSet::ALL,
        Width::Word,
        u32::from(cw),
    )
    .await
    .map_err(|e| t.error(client_error(Width::Word, e)))
}
