//! SBus (MOVILINK over CAN) as a [`SewLink`]: the `sbus-can` master's parameter services to one
//! address, in either handshake mode.

use drive_core::rt::CanIo;
use drive_profile::sew::ParamChannel;
use drive_profile::sew::index::{
    self, SBUS_ADDRESS, SBUS_BAUD_RATE, SBUS_GROUP_ADDRESS, SBUS_SYNC_ID, SBUS_TIMEOUT,
};
use sbus_can::driver::{DriverError, SbusDriver};
use sbus_can::ids::Address;
use sbus_can::master::Handshake;

use super::{SewLink, device_error};
use crate::client::ClientError;
use crate::front::{FrontEnd, Setting};
use crate::target::Target;
use crate::text::physical_text;

/// The drive's settings of the SBus link: writing one changes how the drive is reached.
pub const LINK_SETTINGS: &[u16] = &[
    SBUS_ADDRESS,
    SBUS_GROUP_ADDRESS,
    SBUS_TIMEOUT,
    SBUS_BAUD_RATE,
    SBUS_SYNC_ID,
];

/// What a restore over SBus never writes: the commands of the MOVILINK list (P802 factory
/// setting, P803 parameter lock, P804 reset statistics, P840 manual reset) and the SBus
/// settings that would cut the connection the restore runs on (P813 address, P816 bit rate,
/// P817 sync identifier).
pub const NOT_RESTORED: &[u16] = &[
    index::FACTORY_SETTING,
    index::PARAMETER_LOCK,
    index::RESET_STATISTICS,
    index::MANUAL_RESET,
    SBUS_ADDRESS,
    SBUS_BAUD_RATE,
    SBUS_SYNC_ID,
];

/// One drive behind an SBus master.
#[derive(Debug)]
pub struct SbusLink<'a, C> {
    /// The master.
    pub master: &'a mut SbusDriver<C>,
    /// The drive's SBus address.
    pub address: Address,
    /// The handshake mode of the parameter services.
    pub handshake: Handshake,
    /// The interface's name, for the EEPROM-wear log.
    pub iface: String,
}

/// The client error of a driver error: a drive's return code is a device error, the rest are
/// link failures.
pub fn client_error(e: DriverError) -> ClientError {
    match e {
        DriverError::Device { code, .. } => device_error(code, e.to_string()),
        DriverError::Link(l) => ClientError::link(l.fault(), l.to_string()),
        other => ClientError::Request(other.to_string()),
    }
}

impl<C: CanIo> SewLink for SbusLink<'_, C> {
    async fn service(&mut self, request: ParamChannel) -> Result<u32, ClientError> {
        self.master
            .param_with(self.address, request, self.handshake)
            .await
            .map(|p| p.data)
            .map_err(client_error)
    }

    fn bus_key(&self) -> String {
        self.iface.clone()
    }

    async fn drive_address(&mut self) -> Result<String, ClientError> {
        Ok(self.address.get().to_string())
    }

    fn link_settings(&self) -> &'static [u16] {
        LINK_SETTINGS
    }

    fn not_restored(&self) -> &'static [u16] {
        NOT_RESTORED
    }

    fn link_change(&self, target: &Target, raw: i64, front: &dyn FrontEnd) -> String {
        let shown = target
            .param
            .map_or_else(|| raw.to_string(), |p| physical_text(p, raw));
        match target.index {
            SBUS_ADDRESS => format!(
                "the drive will answer at SBus address {raw}, no longer at {}{}",
                self.address.get(),
                front
                    .name(Setting::Address(raw))
                    .map_or_else(String::new, |w| format!(" (use {w})"))
            ),
            SBUS_GROUP_ADDRESS => {
                format!("the drive will take group telegrams to group {raw} (8g+6 and 8g+518)")
            }
            SBUS_TIMEOUT if raw == 0 => "the drive will no longer watch the SBus for a timeout \
                 (0 s): a master that stops leaves it running"
                .to_owned(),
            SBUS_TIMEOUT => format!(
                "the drive will stop with an SBus timeout (F47, reaction P836) when no process \
                 data arrive for {shown} (P815)"
            ),
            SBUS_BAUD_RATE => format!(
                "the drive will talk at another bit rate ({shown}): nothing on this bus reaches \
                 it until the bus runs at that rate too"
            ),
            SBUS_SYNC_ID => format!(
                "the drive will take SYNC on another identifier ({shown}{})",
                front
                    .name(Setting::SyncId)
                    .map_or_else(String::new, |w| format!("; {w} must follow"))
            ),
            _ => format!(
                "writing {raw} to {} changes how the drive is reached",
                target.label()
            ),
        }
    }

    fn follow_link_change(&mut self, target: &Target, raw: i64, front: &dyn FrontEnd) -> String {
        let note = self.link_change(target, raw, front);
        if target.index == SBUS_ADDRESS
            && let Some(a) = u8::try_from(raw).ok().and_then(Address::new)
        {
            self.address = a;
        }
        note
    }

    fn address_number(&self) -> u8 {
        self.address.get()
    }
}
