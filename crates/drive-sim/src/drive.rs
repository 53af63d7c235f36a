//! [`SimDrive`]: parameter store, state machine, ramp and fault injection together.

use std::time::Duration;

use crate::error::SimError;
use crate::inject::{FaultInjector, Response};
use crate::ramp::{Ramp, RampConfig, RampMode};
use crate::state::{Command, DriveState, DriveStateMachine, FaultReaction};
use crate::store::{OperatingCondition, ParamStore, Persistence};
use drive_core::Instant;

/// Where the actual speed is mirrored into the parameter store on every update.
#[derive(Debug, Clone, Copy)]
pub struct SpeedMapping {
    /// Bus index of the actual-speed parameter (SEW: 8318).
    pub index: u16,
    /// Its sub-index (0 for parameters without one).
    pub sub: u16,
    /// Speed in 1/min → raw value (SEW 8318: `(rpm * 1000.0).round() as i64`).
    pub to_raw: fn(f64) -> i64,
}

/// A family front-end's per-tick hook: runs at the end of [`SimDrive::tick`], after the ramp
/// and the speed mapping, with full access to the drive (e.g. to build a status word into a
/// parameter, or to take ramp times from P130/P131).
pub type TickHook = Box<dyn FnMut(&mut SimDrive, Instant) + Send>;

/// One simulated drive.
///
/// Every method that takes `now` first advances the ramp to `now` under the current state, then
/// acts, so a command given at time *t* takes effect exactly at *t*. Reads do not take a time:
/// call [`SimDrive::tick`] first for fresh actual values.
pub struct SimDrive {
    store: ParamStore,
    machine: DriveStateMachine,
    ramp: Ramp,
    injector: FaultInjector,
    speed_actual: Option<SpeedMapping>,
    hook: Option<TickHook>,
}

impl core::fmt::Debug for SimDrive {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("SimDrive")
            .field("state", &self.machine.state())
            .field("fault_reaction", &self.machine.fault_reaction())
            .field("ramp", &self.ramp)
            .field("injector", &self.injector)
            .field("speed_actual", &self.speed_actual)
            .field("hook", &self.hook.is_some())
            .field("store", &self.store)
            .finish()
    }
}

impl SimDrive {
    /// A drive at standstill under controller inhibit, with default ramps, coasting fault
    /// reaction and no injected faults.
    pub fn new(store: ParamStore) -> SimDrive {
        let mut drive = SimDrive {
            store,
            machine: DriveStateMachine::new(),
            ramp: Ramp::default(),
            injector: FaultInjector::default(),
            speed_actual: None,
            hook: None,
        };
        drive.sync();
        drive
    }

    // ----- parameters -----

    /// The parameter store.
    pub fn store(&self) -> &ParamStore {
        &self.store
    }

    /// The parameter store, mutably (e.g. for [`ParamStore::set_internal`]).
    pub fn store_mut(&mut self) -> &mut ParamStore {
        &mut self.store
    }

    /// Read a parameter's current value ([`ParamStore::read`]).
    pub fn read(&self, index: u16, sub: u16) -> Result<i64, SimError> {
        self.store.read(index, sub)
    }

    /// Write a parameter as a bus master would, checked against the drive's state at `now`
    /// ([`ParamStore::write`]).
    pub fn write(
        &mut self,
        index: u16,
        sub: u16,
        raw: i64,
        persistence: Persistence,
        now: Instant,
    ) -> Result<(), SimError> {
        self.advance(now);
        self.store.write(index, sub, raw, persistence, now)
    }

    /// Mirror the actual speed into a parameter from now on (`None` stops it).
    ///
    /// Fails with [`SimError::UnknownIndex`] / [`SimError::UnknownSubIndex`] if the store lacks
    /// that cell.
    pub fn set_speed_actual_mapping(
        &mut self,
        mapping: Option<SpeedMapping>,
    ) -> Result<(), SimError> {
        if let Some(m) = mapping {
            self.store.meta(m.index, m.sub)?;
        }
        self.speed_actual = mapping;
        self.sync();
        Ok(())
    }

    /// The configured actual-speed mapping.
    pub fn speed_actual_mapping(&self) -> Option<SpeedMapping> {
        self.speed_actual
    }

    /// Install (or remove) the per-tick hook.
    pub fn set_tick_hook(&mut self, hook: Option<TickHook>) {
        self.hook = hook;
    }

    // ----- state machine -----

    /// The current state.
    pub fn state(&self) -> DriveState {
        self.machine.state()
    }

    /// The configured fault reaction.
    pub fn fault_reaction(&self) -> FaultReaction {
        self.machine.fault_reaction()
    }

    /// Configure the fault reaction.
    pub fn set_fault_reaction(&mut self, reaction: FaultReaction) {
        self.machine.set_fault_reaction(reaction);
    }

    /// Apply a command at `now` (see [`crate::state`] for the transitions).
    pub fn command(&mut self, command: Command, now: Instant) -> Result<DriveState, SimError> {
        self.advance(now);
        let result = self.machine.apply(command);
        self.sync();
        result
    }

    /// [`Command::Enable`].
    pub fn enable(&mut self, now: Instant) -> Result<DriveState, SimError> {
        self.command(Command::Enable, now)
    }

    /// [`Command::Inhibit`].
    pub fn inhibit(&mut self, now: Instant) -> Result<DriveState, SimError> {
        self.command(Command::Inhibit, now)
    }

    /// [`Command::Stop`].
    pub fn stop(&mut self, now: Instant) -> Result<DriveState, SimError> {
        self.command(Command::Stop, now)
    }

    /// [`Command::QuickStop`].
    pub fn quick_stop(&mut self, now: Instant) -> Result<DriveState, SimError> {
        self.command(Command::QuickStop, now)
    }

    /// [`Command::FaultReset`].
    pub fn fault_reset(&mut self, now: Instant) -> Result<DriveState, SimError> {
        self.command(Command::FaultReset, now)
    }

    /// Raise a drive fault at `now`: the state becomes [`DriveState::Fault`] and the motor
    /// stops per the fault reaction.
    pub fn raise_fault(&mut self, code: u16, now: Instant) -> DriveState {
        self.advance(now);
        let state = self.machine.raise_fault(code);
        self.sync();
        state
    }

    /// Restart (power cycle) at `now`: RAM ← EEPROM ([`ParamStore::restart`]), state
    /// [`DriveState::Inhibited`], standstill, setpoint 0. Injected communication faults stay.
    pub fn restart(&mut self, now: Instant) {
        self.store.restart();
        self.machine.restart();
        self.ramp.reset(now);
        self.sync();
    }

    // ----- ramp -----

    /// The ramp configuration.
    pub fn ramp_config(&self) -> &RampConfig {
        self.ramp.config()
    }

    /// Change the ramps at `now` (motion up to `now` used the old ones).
    pub fn set_ramp_config(&mut self, config: RampConfig, now: Instant) {
        self.advance(now);
        self.ramp.set_config(config);
    }

    /// The speed setpoint in 1/min.
    pub fn setpoint(&self) -> f64 {
        self.ramp.setpoint()
    }

    /// Set the speed setpoint in 1/min at `now` (clamped to the speed limit; followed only
    /// while [`DriveState::Enabled`]).
    pub fn set_setpoint(&mut self, rpm: f64, now: Instant) -> Result<(), SimError> {
        self.advance(now);
        self.ramp.set_setpoint(rpm)
    }

    /// The actual speed in 1/min, as of the last update.
    pub fn actual_speed(&self) -> f64 {
        self.ramp.actual()
    }

    /// The speed the ramp is heading for in the current state (the setpoint when enabled, 0
    /// otherwise).
    pub fn effective_target(&self) -> f64 {
        self.ramp.target(self.ramp_mode())
    }

    /// Whether the actual speed is not 0.
    pub fn motor_turning(&self) -> bool {
        self.ramp.actual() != 0.0
    }

    /// Whether the actual speed has reached [`SimDrive::effective_target`].
    pub fn target_reached(&self) -> bool {
        self.ramp.actual() == self.effective_target()
    }

    /// Advance the model to `now`: ramp, operating condition, actual-speed mapping, then the
    /// tick hook.
    pub fn tick(&mut self, now: Instant) {
        self.advance(now);
        if let Some(mut hook) = self.hook.take() {
            hook(self, now);
            // The hook may have installed a replacement; keep that one.
            if self.hook.is_none() {
                self.hook = Some(hook);
            }
        }
    }

    // ----- communication faults -----

    /// The fault injector.
    pub fn injector(&self) -> &FaultInjector {
        &self.injector
    }

    /// The fault injector, mutably.
    pub fn injector_mut(&mut self) -> &mut FaultInjector {
        &mut self.injector
    }

    /// Answer after `delay` from now on ([`FaultInjector::set_response_delay`]).
    pub fn set_response_delay(&mut self, delay: Duration) {
        self.injector.set_response_delay(delay);
    }

    /// Drop answers with probability `p` ([`FaultInjector::set_drop_probability`]).
    pub fn set_drop_probability(&mut self, p: f64) {
        self.injector.set_drop_probability(p);
    }

    /// Drop the next `n` answers ([`FaultInjector::drop_next`]).
    pub fn drop_next(&mut self, n: u32) {
        self.injector.drop_next(n);
    }

    /// Remove every injected communication fault ([`FaultInjector::clear`]).
    pub fn clear_injection(&mut self) {
        self.injector.clear();
    }

    /// Whether and when to answer a request received at `now`
    /// ([`FaultInjector::should_respond`]).
    pub fn should_respond(&mut self, now: Instant) -> Response {
        self.injector.should_respond(now)
    }

    // ----- internals -----

    fn ramp_mode(&self) -> RampMode {
        match self.machine.state() {
            DriveState::Inhibited => RampMode::Coast,
            DriveState::Ready => RampMode::Stop,
            DriveState::Enabled => RampMode::Follow,
            DriveState::QuickStop => RampMode::QuickStop,
            DriveState::Fault(_) => match self.machine.fault_reaction() {
                FaultReaction::Coast => RampMode::Coast,
                FaultReaction::QuickStop => RampMode::QuickStop,
            },
        }
    }

    fn advance(&mut self, now: Instant) {
        let mode = self.ramp_mode();
        self.ramp.advance(now, mode);
        self.sync();
    }

    /// Push state-derived values into the store.
    fn sync(&mut self) {
        let state = self.machine.state();
        self.store.set_condition(OperatingCondition {
            controller_inhibited: state == DriveState::Inhibited,
            in_operation: state.output_stage_on() || self.ramp.actual() != 0.0,
        });
        if let Some(m) = self.speed_actual {
            // Validated when the mapping was set; the store's keys never change.
            let _ = self
                .store
                .set_internal_sub(m.index, m.sub, (m.to_raw)(self.ramp.actual()));
        }
    }
}
