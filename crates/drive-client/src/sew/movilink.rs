//! MOVILINK on RS-485 / RS-232 as a [`SewLink`]: the `movilink` driver's acyclic PARAM + 0PD
//! services to one address.

use ::movilink::Address;
use ::movilink::driver::{CharIo, DriverError, MovilinkDriver, ParamServices};
use drive_profile::sew::{ParamChannel, index};

use super::{SewLink, device_error};
use crate::client::ClientError;
use crate::front::{FrontEnd, Setting};
use crate::target::Target;
use crate::text::{canonical_port, physical_text};

/// The settings of the RS-485 link a MOVILINK master talks over: P810 address, P811 group
/// address, P812 RS-485 timeout delay.
pub const LINK_SETTINGS: &[u16] = &[
    index::RS485_ADDRESS,
    index::RS485_GROUP_ADDRESS,
    index::RS485_TIMEOUT,
];

/// What a MOVIDRIVE restore never writes: P802 factory setting, P803 parameter lock, P804 reset
/// statistics data (a command: 1–3 clear the fault memory or a counter), P810/P811 RS-485
/// address and group address (writing them would cut the connection the restore runs on), P840
/// manual reset.
pub const NOT_RESTORED: &[u16] = &[
    index::FACTORY_SETTING,
    index::PARAMETER_LOCK,
    index::RESET_STATISTICS,
    index::RS485_ADDRESS,
    index::RS485_GROUP_ADDRESS,
    index::MANUAL_RESET,
];

/// The MOVILINK driver as the way to one MOVIDRIVE's parameter channel (acyclic PARAM + 0PD
/// services); the client is [`SewClient`](super::SewClient) on it.
#[derive(Debug)]
pub struct MovilinkLink<'a, IO> {
    /// The driver of the line.
    pub driver: &'a mut MovilinkDriver<IO>,
    /// The drive's address (254: point-to-point; a group or broadcast for unanswered writes).
    pub address: Address,
    /// The port's name, for the EEPROM-wear log.
    pub port: String,
}

impl<'a, IO> MovilinkLink<'a, IO> {
    /// The way to the drive at `address` behind `driver` on the port named `port`.
    pub fn new(driver: &'a mut MovilinkDriver<IO>, address: Address, port: &str) -> Self {
        Self {
            driver,
            address,
            port: port.to_owned(),
        }
    }
}

/// The client error of a driver error: a drive's return code is a device error, the rest are
/// link failures.
pub fn client_error(e: DriverError) -> ClientError {
    match e {
        DriverError::Device(code) => device_error(code, e.to_string()),
        DriverError::Link(l) => ClientError::link(l.fault(), l.to_string()),
        other => ClientError::Request(other.to_string()),
    }
}

impl<IO: CharIo> SewLink for MovilinkLink<'_, IO> {
    fn stale_bytes(&self) -> u64 {
        self.driver.stats().stale
    }

    async fn service(&mut self, request: ParamChannel) -> Result<u32, ClientError> {
        // The SEW service on RS-485: an acyclic PARAM + 0PD telegram.
        ParamServices::service(self.driver, self.address, request)
            .await
            .map(|p| p.data)
            .map_err(client_error)
    }

    fn bus_key(&self) -> String {
        canonical_port(&self.port)
    }

    async fn drive_address(&mut self) -> Result<String, ClientError> {
        // Point-to-point (254) reaches whichever drive is connected: its own address (P810)
        // names it. Groups and broadcast are keyed by their address.
        if self.address.get() == 254 {
            let a = self
                .service(ParamChannel::read(index::RS485_ADDRESS))
                .await?;
            Ok(format!("{a}"))
        } else {
            Ok(self.address.get().to_string())
        }
    }

    fn link_settings(&self) -> &'static [u16] {
        LINK_SETTINGS
    }

    fn link_change(&self, target: &Target, raw: i64, front: &dyn FrontEnd) -> String {
        let address = front.name(Setting::Address(raw));
        let around = |before: &str, after: &str| {
            address
                .as_ref()
                .map_or_else(String::new, |w| format!("{before}{w}{after}"))
        };
        match target.index {
            index::RS485_ADDRESS if self.address.get() == 254 => format!(
                "the drive will answer at address {raw}{} and still at 254 (point-to-point)",
                around(" (", ")")
            ),
            index::RS485_ADDRESS => format!(
                "the drive will answer at address {raw}, no longer at {}{}",
                self.address.get(),
                around(" (use ", ")")
            ),
            index::RS485_GROUP_ADDRESS => format!(
                "the drive will take group telegrams to address {raw}{}",
                around(" (", " writes to the group)")
            ),
            index::RS485_TIMEOUT if raw == 0 => "the drive will no longer watch the RS-485 \
                 link for a timeout (0 s): a master that stops leaves it running"
                .to_owned(),
            _ => format!(
                "the drive will stop with an RS-485 timeout when no telegram arrives for {} \
                 (P812)",
                target
                    .param
                    .map_or_else(|| raw.to_string(), |p| physical_text(p, raw))
            ),
        }
    }

    fn follow_link_change(&mut self, target: &Target, raw: i64, front: &dyn FrontEnd) -> String {
        let note = self.link_change(target, raw, front);
        if target.index == index::RS485_ADDRESS
            && self.address.get() != 254
            && let Some(a) = u8::try_from(raw).ok().and_then(Address::new)
        {
            self.address = a;
        }
        note
    }

    fn not_restored(&self) -> &'static [u16] {
        NOT_RESTORED
    }

    fn address_number(&self) -> u8 {
        self.address.get()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ::movilink::driver::{DriverConfig, Stream};
    use drive_profile::Family;

    #[derive(Debug)]
    struct Words;

    impl FrontEnd for Words {
        fn name(&self, setting: Setting) -> Option<String> {
            match setting {
                Setting::Address(a) => Some(format!("--addr {a}")),
                _ => None,
            }
        }
    }

    #[tokio::test]
    async fn a_link_change_names_the_new_address_only_in_a_front_ends_words() {
        let (a, _b) = tokio::io::duplex(64);
        let mut driver = MovilinkDriver::new(Stream(a), DriverConfig::default());
        let p810 = Target::resolve(Family::Movidrive, "P810", super::super::RAW_INDICES).unwrap();
        let p811 = Target::resolve(Family::Movidrive, "P811", super::super::RAW_INDICES).unwrap();
        let one = Address::new(1).unwrap();
        let link = MovilinkLink::new(&mut driver, one, "test");
        assert_eq!(
            link.link_change(&p810, 5, &crate::front::Plain),
            "the drive will answer at address 5, no longer at 1"
        );
        assert_eq!(
            link.link_change(&p810, 5, &Words),
            "the drive will answer at address 5, no longer at 1 (use --addr 5)"
        );
        assert_eq!(
            link.link_change(&p811, 101, &Words),
            "the drive will take group telegrams to address 101 (--addr 101 writes to the group)"
        );
        let p2p = MovilinkLink::new(&mut driver, Address::new(254).unwrap(), "test");
        assert_eq!(
            p2p.link_change(&p810, 5, &Words),
            "the drive will answer at address 5 (--addr 5) and still at 254 (point-to-point)"
        );
    }
}
