//! `control` of a Bonfiglioli ACT/ACU: 412 = 1 (the control word drives the state machine) in
//! RAM, the reference frequency 484 (RAM), then control words 410 toward the action's state,
//! polling 411 until it is reached; the stop of an interrupted enable is "disable operation".

use std::time::Duration;

use bonfiglioli_modbus::driver::{CharIo, ModbusDriver};
use bonfiglioli_modbus::frame::{Address, DataSet};
use bonfiglioli_modbus::slave::Width;
use drive_profile::bonfiglioli::state::command;
use drive_profile::bonfiglioli::{
    ActStateMachine, AcuPositioningStateMachine, AcuStateMachine, State, Variant,
};
use drive_profile::state::StateMachine;

use super::{Action, CONTROL_PERIOD, ControlError, STOP_WAIT, pause};
use crate::bonfiglioli::{BonfiglioliClient, client_error, param, raw_of, table_width, target};
use crate::client::{ClientError, DeviceError, ParamClient};
use crate::front::FrontEnd;
use crate::motor::{Motion, Stopped};

/// What `control` is asked to do.
#[derive(Debug, Clone, Copy)]
pub struct Control {
    /// The drive.
    pub address: Address,
    /// The action.
    pub action: Action,
    /// The reference frequency 484 to write first, raw (0.01 Hz).
    pub freq: Option<i64>,
    /// ACT or ACU: their state tables differ.
    pub variant: Variant,
    /// Whose words a client's messages use.
    pub front: &'static dyn FrontEnd,
}

/// What `control` tells its front end while it runs.
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub enum Event {
    /// 412 local/remote was this; set to 1 (state machine) in RAM, all four data sets.
    RemoteSet(u32),
    /// Configuration 30 cannot be read: going on as without positioning control.
    NoConfiguration(DeviceError),
    /// `reset` found no fault (the drive shows this state).
    NoFault(State),
}

/// What `control` reached: the last status word and control word.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reached {
    /// 411 status word.
    pub word: u16,
    /// The last control word written.
    pub last: Option<u16>,
    /// `enable`: 241 actual frequency in Hz once enabled (read as part of the enabling, so an
    /// interrupt during it still stops the motor).
    pub actual: Option<f64>,
}

impl Control {
    /// The state the action drives toward.
    pub fn target(&self) -> State {
        match self.action {
            Action::Enable => State::OperationEnabled,
            Action::Stop => State::SwitchedOn,
            Action::QuickStop => State::QuickStopActive,
            Action::Disable | Action::Reset => State::SwitchOnDisabled,
        }
    }

    /// Whether the drive with status word `word` has done what the action asks.
    pub fn done(&self, word: u16) -> bool {
        let state = self.variant.state(word);
        self.action == Action::Reset && state != State::Fault || state == self.target()
    }

    fn error(
        &self,
        number: u16,
        width: Width,
        e: bonfiglioli_modbus::driver::DriverError,
    ) -> ControlError {
        match target(number, 0) {
            Ok(t) => ControlError::on(&t, client_error(width, e, self.front)),
            Err(e) => ControlError::Client(e),
        }
    }
}

async fn read_word<IO: CharIo>(m: &mut ModbusDriver<IO>, a: &Control) -> Result<u16, ControlError> {
    m.read(a.address, param::STATUS_WORD, DataSet::ALL, Width::Word)
        .await
        .map(|v| v as u16)
        .map_err(|e| a.error(param::STATUS_WORD, Width::Word, e))
}

async fn write_cw<IO: CharIo>(
    m: &mut ModbusDriver<IO>,
    a: &Control,
    cw: u16,
) -> Result<(), ControlError> {
    m.write(
        a.address,
        param::CONTROL_WORD,
        DataSet::ALL,
        Width::Word,
        u32::from(cw),
    )
    .await
    .map_err(|e| a.error(param::CONTROL_WORD, Width::Word, e))
}

/// 241 actual frequency in Hz, if the drive answers it.
pub async fn actual_frequency<IO: CharIo>(m: &mut ModbusDriver<IO>, addr: Address) -> Option<f64> {
    let t = target(241, 0).ok()?;
    let width = table_width(&t, None)?;
    let data = m.read(addr, 241, DataSet::ALL, width).await.ok()?;
    Some(t.param?.to_physical(raw_of(&t, width, data)))
}

/// The steps of `control` toward the action's state, checking the interrupt between
/// exchanges.
pub async fn control<IO: CharIo, E: From<ControlError>>(
    m: &mut ModbusDriver<IO>,
    a: &Control,
    motion: &Motion<'_>,
    mut on: impl FnMut(Event) -> Result<(), E>,
) -> Result<Reached, E> {
    let (addr, toward, stop) = (a.address, a.target(), motion.interrupt());
    let reset = a.action == Action::Reset;
    // 412 = 1: the control word drives the state machine (a data-set parameter: all four).
    let mode = m
        .read(
            addr,
            param::LOCAL_REMOTE,
            DataSet::new(1).unwrap_or(DataSet::ALL),
            Width::Word,
        )
        .await
        .map_err(|e| a.error(param::LOCAL_REMOTE, Width::Word, e))?;
    if mode != 1 {
        m.write(
            addr,
            param::LOCAL_REMOTE,
            DataSet::new(5).unwrap_or(DataSet::ALL),
            Width::Word,
            1,
        )
        .await
        .map_err(|e| a.error(param::LOCAL_REMOTE, Width::Word, e))?;
        on(Event::RemoteSet(mode))?;
    }
    if let Some(raw) = a.freq {
        let data = crate::bonfiglioli::data_of(Width::Long, raw).unwrap_or(0);
        // The reference moves a running motor at once.
        motion.armed();
        m.write(addr, param::FREQUENCY_RAM, DataSet::ALL, Width::Long, data)
            .await
            .map_err(|e| a.error(param::FREQUENCY_RAM, Width::Long, e))?;
    }
    // The ACU with positioning control (configuration 30 = x40) has no shortcut 4' (ch. 10.2).
    let positioning = a.variant == Variant::Acu && {
        let t30 = target(param::CONFIGURATION, 0).map_err(ControlError::Client)?;
        let mut c = BonfiglioliClient::new(m, addr, "", None)
            .with_front_end(a.front)
            .probing();
        match c.read(&t30).await {
            Ok(config) => config % 100 == 40,
            Err(ClientError::Device(d)) => {
                on(Event::NoConfiguration(d))?;
                false
            }
            Err(e) => return Err(ControlError::on(&t30, e).into()),
        }
    };
    let mut last: Option<u16> = None;
    let mut word = read_word(m, a).await?;
    let start_state = a.variant.state(word);
    if reset && start_state != State::Fault {
        on(Event::NoFault(start_state))?;
    }
    // At most a handful of steps: every state reaches every target in four.
    for _ in 0..8 {
        if stop.requested() {
            break;
        }
        let state = a.variant.state(word);
        let next = if reset && state == State::Fault {
            Some(command::FAULT_RESET)
        } else if reset {
            None
        } else if a.variant == Variant::Acu && positioning {
            // No shortcut 4' with positioning control (ch. 10.2).
            AcuPositioningStateMachine::control_toward(state, toward)
        } else if a.variant == Variant::Acu {
            AcuStateMachine::control_toward(state, toward)
        } else {
            ActStateMachine::control_toward(state, toward)
        };
        let Some(cw) = next else { break };
        motion.armed();
        // A fault reset acts on a rising edge of bit 7.
        if cw & 0x80 != 0 && last.is_none_or(|l| l & 0x80 != 0) {
            write_cw(m, a, cw & !0x80).await?;
        }
        write_cw(m, a, cw).await?;
        last = Some(cw);
        // The drive may take a while (a stop ramps down first): poll until the state changes.
        let deadline = drive_core::rt::time::now() + Duration::from_secs(15);
        loop {
            pause(motion, CONTROL_PERIOD).await;
            word = read_word(m, a).await?;
            if a.variant.state(word) != state
                || drive_core::rt::time::now() >= deadline
                || stop.requested()
            {
                break;
            }
        }
        if a.variant.state(word) == state || reset {
            break;
        }
    }
    let actual = if a.action == Action::Enable && a.variant.state(word) == toward {
        actual_frequency(m, addr).await
    } else {
        None
    };
    Ok(Reached { word, last, actual })
}

/// The stop of an interrupted enable: "disable operation" (0x0007, transition 5: the drive
/// stops as P392 says, by default on its ramp, and only then shows "switched on"), waiting at
/// most [`STOP_WAIT`] for it.
pub async fn disable_operation<IO: CharIo>(
    m: &mut ModbusDriver<IO>,
    a: &Control,
) -> Result<Stopped, ControlError> {
    let cw = command::DISABLE_OPERATION;
    write_cw(m, a, cw).await?;
    let deadline = drive_core::rt::time::now() + STOP_WAIT;
    let mut word = read_word(m, a).await?;
    while a.variant.state(word) == State::OperationEnabled && drive_core::rt::time::now() < deadline
    {
        drive_core::rt::time::sleep(CONTROL_PERIOD).await;
        word = read_word(m, a).await?;
    }
    let state = a.variant.state(word);
    Ok(Stopped {
        sent: format!("disable operation (410 = 0x{cw:04X})"),
        reports: if state == State::OperationEnabled {
            format!(
                "411 = 0x{word:04X} still operation enabled after {} s: it stops as P392 says \
                 (by default on its ramp)",
                STOP_WAIT.as_secs()
            )
        } else {
            format!("411 = 0x{word:04X} {}", state.name_en())
        },
    })
}
