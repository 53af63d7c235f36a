//! Finding the drives on a bus: [`Scan`] probes one address and says what answers there as a
//! [`Found`] (its identity as the family's protocol tells it), the same for every family, so a
//! front end has one scan loop.

use std::time::Duration;

use drive_profile::nord::StatusWord;
use drive_profile::sew::{self, ParamServices as _, ReturnCode, index};
use serde_json::{Map, Value, json};

use crate::meaning::KnownVariant;
use crate::nord::{NordParamClient, table_target};
use crate::{ClientError, ParamClient};

/// What answered at an address, in its family's terms.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum Found {
    /// A MOVIDRIVE over MOVILINK.
    Movilink {
        /// P070 unit type (index 8301).
        device_type: u32,
        /// P071 unit rated current in A, `None` when the drive does not answer it.
        rated_current_a: Option<f64>,
        /// P076 firmware (index 8300), as a number (`822609711`).
        firmware: u32,
    },
    /// A MOVIDRIVE over SBus.
    Sbus {
        /// P070 unit type, or the drive's refusal of it.
        device_type: Result<u32, ReturnCode>,
        /// P076 firmware, `None` when unreadable.
        firmware: Option<u32>,
    },
    /// A NORD drive over USS.
    Nord {
        /// The status word of a process telegram, `None` without PZD (or no answer to it).
        status: Option<StatusWord>,
        /// P744 configuration level, `None` when unreadable.
        configuration_level: Option<i64>,
    },
    /// A Bonfiglioli ACTIVE or ACTIVE Cube over Modbus.
    Bonfiglioli {
        /// The variant and how it was told, `None` when the drive did not tell it.
        variant: Option<KnownVariant>,
        /// 30 configuration, `None` when unreadable.
        configuration: Option<i64>,
        /// 411 status word, `None` when unreadable.
        status_word: Option<i64>,
    },
}

/// Why a scan stopped.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ScanError<E> {
    /// No drive can answer at this address.
    #[error("address {0} cannot be asked for an answer")]
    Address(u8),
    /// The link failed.
    #[error(transparent)]
    Link(E),
}

/// One bus to scan, address by address. The futures are not `Send`, as [`ParamClient`]'s.
#[allow(async_fn_in_trait)]
pub trait Scan {
    /// A failure that ends the scan.
    type Error;

    /// What answers at `address`, `None` when nothing does.
    async fn probe(&mut self, address: u8) -> Result<Option<Found>, Self::Error>;

    /// Bytes discarded as stale while scanning (see [`ParamClient::stale_bytes`]).
    fn stale_bytes(&self) -> u64 {
        0
    }
}

impl Found {
    /// The JSON object of one drive found at `address`, with the keys the family's scan has
    /// always printed.
    pub fn json(&self, address: u8) -> Value {
        let mut m = Map::new();
        m.insert("address".into(), address.into());
        let rest = match self {
            Found::Movilink {
                device_type,
                rated_current_a,
                firmware,
            } => json!({"device_type": device_type,
                "device_type_name": sew::device::designation(*device_type),
                "rated_current_a": rated_current_a, "firmware": firmware}),
            Found::Sbus {
                device_type: Ok(device_type),
                firmware,
            } => json!({"device_type": device_type,
                "device_type_name": sew::device::designation(*device_type),
                "firmware": firmware}),
            Found::Sbus {
                device_type: Err(code),
                ..
            } => json!({"device_type": null, "refused": code.to_string()}),
            Found::Nord {
                status,
                configuration_level,
            } => json!({"status_word": status.map(|s| s.0),
                "state": status.and_then(|s| drive_profile::nord::state_info(s.state()))
                    .map(|i| i.letter.to_string()),
                "state_en": status.map(|s| s.state().name_en()),
                "configuration_level": configuration_level}),
            Found::Bonfiglioli {
                variant,
                configuration,
                status_word,
            } => json!({"variant": variant.map(|k| k.variant.key()),
                "variant_from": variant.map(|k| k.from),
                "configuration": configuration, "status_word": status_word,
                "device_type": null, "firmware": null}),
        };
        if let Value::Object(r) = rest {
            m.extend(r);
        }
        Value::Object(m)
    }
}

/// SEW firmware numbers read like 822609711 = part 822 609, version 7.11.
pub fn firmware_text(v: u32) -> String {
    let s = v.to_string();
    match (s.get(0..3), s.get(3..6), s.get(6..7), s.get(7..9)) {
        (Some(a), Some(b), Some(c), Some(d)) if s.len() == 9 => format!("{a} {b} {c}.{d}"),
        _ => s,
    }
}

/// A MOVILINK line: each address gets one read of P070 within `timeout`, then P076 and P071.
#[derive(Debug)]
pub struct MovilinkScan<'a, IO> {
    /// The line's master.
    pub driver: &'a mut movilink::driver::MovilinkDriver<IO>,
    /// How long to wait for the answer at each address.
    pub timeout: Duration,
}

impl<IO: movilink::driver::CharIo> Scan for MovilinkScan<'_, IO> {
    type Error = ScanError<movilink::driver::DriverError>;

    async fn probe(&mut self, a: u8) -> Result<Option<Found>, Self::Error> {
        let addr = movilink::Address::new(a)
            .filter(|a| a.expects_response())
            .ok_or(ScanError::Address(a))?;
        let m = &mut *self.driver;
        let Some(device_type) = m.probe(addr, self.timeout).await.map_err(ScanError::Link)? else {
            return Ok(None);
        };
        let firmware = m
            .read(addr, index::FIRMWARE)
            .await
            .map_err(ScanError::Link)?;
        // A unit without P071 still shows up.
        let rated_current_a = match m.read(addr, index::RATED_CURRENT).await {
            Ok(raw) => sew::by_index(index::RATED_CURRENT)
                .map(|p| drive_profile::ParamMeta::to_physical(p, i64::from(raw))),
            Err(_) => None,
        };
        Ok(Some(Found::Movilink {
            device_type,
            rated_current_a,
            firmware,
        }))
    }
}

/// An SBus: every address of `from..=to` is asked for P070 at once (on the first probe); each
/// one that answers is then asked for its firmware.
#[derive(Debug)]
pub struct SbusScan<'a, C> {
    driver: &'a mut sbus_can::driver::SbusDriver<C>,
    range: (u8, u8),
    hits: Option<Vec<sbus_can::driver::ScanHit>>,
}

impl<'a, C> SbusScan<'a, C> {
    /// The scan of `from..=to` on `driver`'s bus.
    pub fn new(driver: &'a mut sbus_can::driver::SbusDriver<C>, from: u8, to: u8) -> Self {
        Self {
            driver,
            range: (from, to),
            hits: None,
        }
    }
}

impl<C: drive_core::rt::CanIo> Scan for SbusScan<'_, C> {
    type Error = ScanError<sbus_can::driver::DriverError>;

    async fn probe(&mut self, a: u8) -> Result<Option<Found>, Self::Error> {
        let address = |a: u8| sbus_can::ids::Address::new(a).ok_or(ScanError::Address(a));
        let hits = match &mut self.hits {
            Some(h) => h,
            None => {
                let (from, to) = (address(self.range.0)?, address(self.range.1)?);
                let found = self.driver.scan(from, to).await.map_err(ScanError::Link)?;
                self.hits.insert(found)
            }
        };
        let Some(hit) = hits.iter().find(|h| h.address.get() == a).cloned() else {
            return Ok(None);
        };
        let firmware = self.driver.read(hit.address, index::FIRMWARE).await.ok();
        Ok(Some(Found::Sbus {
            device_type: hit.unit_type,
            firmware,
        }))
    }
}

/// What answers to the NORD `client` (addressed to one drive): with `pzd` process words a
/// process telegram without bit 10 (the drive answers, and ignores it), then P744; without PZD
/// the parameter read alone is the probe. A refusal of P744 is an answer too.
pub async fn nord<C>(client: &mut ctt2_uss::client::NordClient<C>, pzd: u8) -> Option<Found>
where
    C: ctt2_uss::client::ParameterChannel + ctt2_uss::client::ProcessChannel,
{
    let actuals = pzd.saturating_sub(1).min(3);
    let answer = if pzd > 0 {
        client
            .process(drive_profile::nord::ControlWord(0), &[], actuals)
            .await
            .ok()
    } else {
        None
    };
    let mut level = None;
    let mut answered = answer.is_some();
    if answered || pzd == 0 {
        let mut pc = NordParamClient::new(client, "", Map::new());
        if let Ok(t744) = table_target(crate::nord::param::CONFIGURATION_LEVEL) {
            match pc.read(&t744).await {
                Ok(v) => {
                    level = Some(v);
                    answered = true;
                }
                Err(ClientError::Device(_)) => answered = true,
                Err(_) => {}
            }
        }
    }
    answered.then(|| Found::Nord {
        status: answer.map(|a| a.status()),
        configuration_level: level,
    })
}

/// A Bonfiglioli bus: each address gets one diagnostics request within `timeout`; a drive
/// that answers is asked for 30 configuration, 411 status word and its variant.
#[derive(Debug)]
pub struct BonfiglioliScan<'a, IO> {
    /// The bus's master.
    pub driver: &'a mut bonfiglioli_modbus::driver::ModbusDriver<IO>,
    /// How long to wait for the answer at each address.
    pub timeout: Duration,
}

impl<IO: bonfiglioli_modbus::driver::CharIo> Scan for BonfiglioliScan<'_, IO> {
    type Error = ScanError<bonfiglioli_modbus::driver::DriverError>;

    async fn probe(&mut self, a: u8) -> Result<Option<Found>, Self::Error> {
        use crate::bonfiglioli::{BonfiglioliClient, param, target};
        let addr = bonfiglioli_modbus::frame::Address::new(a)
            .filter(|a| !a.is_broadcast())
            .ok_or(ScanError::Address(a))?;
        if !self
            .driver
            .probe(addr, self.timeout)
            .await
            .map_err(ScanError::Link)?
        {
            return Ok(None);
        }
        let mut c = BonfiglioliClient::new(self.driver, addr, "", None).probing();
        let mut read = async |n: u16| match target(n, 0) {
            Ok(t) => c.read(&t).await.ok(),
            Err(_) => None,
        };
        let configuration = read(param::CONFIGURATION).await;
        let status_word = read(param::STATUS_WORD).await;
        // A drive that answers but refuses what tells the variant shows none.
        let variant = c.find_variant().await.ok().and_then(|f| f.variant);
        Ok(Some(Found::Bonfiglioli {
            variant,
            configuration,
            status_word,
        }))
    }
}
