//! `control`: drive-client's job on the state machine through the control word 410
//! ([`drive_client::control::bonfiglioli`]), its options and its output.

use drive_client::control::Action;
use drive_client::control::bonfiglioli::{self as job, Event, Reached};

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

/// `control` ([`job::control`]). `enable` runs under the motor guard ([`MotorGuard`]): an
/// interrupt, a closed pipe or a failure while enabling sends "disable operation"; once
/// enabled, the motor keeps running on purpose and the note says how to stop it.
pub async fn control<IO: CharIo>(m: &mut MasterDriver<IO>, s: &ControlSession<'_>) -> Result<()> {
    let action = Action::of(s.action)
        .ok_or_else(|| CliError::usage(format!("unknown control action `{}`", s.action)))?;
    let r = job::Control {
        address: s.addr,
        action,
        freq: s.freq,
        variant: s.variant,
        front: &Cli,
    };
    let addr = s.addr;
    let target = r.target();
    let enabling = action == Action::Enable;
    let guard = enabling.then(|| MotorGuard::install(AtEnd::Run, s.again.then("control stop")));
    let on = |e| -> Result<()> {
        match e {
            Event::RemoteSet(mode) => errln!(
                "drivectl: note: 412 local/remote was {mode}; set to 1 (state machine) in RAM \
                 (data set 5: all four data sets, not stored)"
            ),
            Event::NoConfiguration(d) => errln!(
                "drivectl: note: configuration 30 cannot be read ({d}): going on as without \
                 positioning control"
            ),
            Event::NoFault(st) => {
                errln!(
                    "drivectl: note: the drive shows no fault ({})",
                    st.name_en()
                );
            }
            _ => {}
        }
        Ok(())
    };
    let work = async |m: &mut MasterDriver<IO>, motion: &Motion<'_>| -> Result<Reached> {
        job::control(m, &r, motion, on).await
    };
    let reached = match &guard {
        Some(g) => {
            let stop = async |m: &mut MasterDriver<IO>| -> Result<Stopped> {
                Ok(job::disable_operation(m, &r).await?)
            };
            g.run(m, work, stop).await?
        }
        None => {
            // Not a command that moves the motor: an interrupt ends the waiting, and the
            // drive is left in whatever state it reached.
            let interrupt =
                Interrupt::install("the drive may not have reached the state asked for");
            let armed = std::cell::Cell::new(false);
            work(m, &Motion::new(interrupt.inner(), &armed)).await?
        }
    };
    let word = reached.word;
    let state = s.variant.state(word);
    let done = r.done(word);
    // Said before the output, so that a closed standard output cannot swallow it.
    let actual = reached.actual;
    if done && let Some(g) = &guard {
        g.left_running(&format!(
            "the motor is enabled (411 = 0x{word:04X} {}){}",
            state.name_en(),
            actual.map_or_else(String::new, |hz| format!(
                ", actual frequency 241 = {hz:.2} Hz"
            ))
        ));
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
