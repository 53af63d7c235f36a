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

/// A USS line: each address gets one telegram without retries ([`nord`]), in the line
/// settings and layout of the driver it starts from.
#[derive(Debug)]
pub struct UssScan<IO> {
    io: Option<IO>,
    config: ctt2_uss::serial::driver::DriverConfig,
    stale: u64,
}

impl<IO: drive_core::rt::CharIo> UssScan<IO> {
    /// The scan of `driver`'s line.
    pub fn new(driver: ctt2_uss::serial::driver::UssDriver<IO>) -> Self {
        Self {
            config: *driver.config(),
            io: Some(driver.into_inner()),
            stale: 0,
        }
    }
}

/// The port of a [`UssScan`] was lost with a failed probe.
#[derive(Debug, Clone, Copy, thiserror::Error)]
#[error("the port was lost in an earlier probe")]
pub struct PortLost;

impl<IO: drive_core::rt::CharIo> Scan for UssScan<IO> {
    type Error = ScanError<PortLost>;

    async fn probe(&mut self, a: u8) -> Result<Option<Found>, Self::Error> {
        use ctt2_uss::serial::driver::{DriverConfig, UssDriver};
        let address = ctt2_uss::serial::UssAddress::new(a).ok_or(ScanError::Address(a))?;
        let config = DriverConfig {
            address,
            retries: 0,
            ..self.config
        };
        let io = self.io.take().ok_or(ScanError::Link(PortLost))?;
        let mut client = ctt2_uss::client::NordClient::new(
            UssDriver::new(io, config),
            ctt2_uss::client::ClientConfig::default(),
        );
        let found = nord(&mut client, self.config.layout.pzd_words()).await;
        self.stale += client.channel().stats().stale;
        self.io = Some(client.into_inner().into_inner());
        Ok(found)
    }

    fn stale_bytes(&self) -> u64 {
        self.stale
    }
}

/// A margin for the answer of a Bonfiglioli drive that is there: USB serial adapters hand
/// received characters over late (FTDI: every 16 ms by default) and the operating system
/// schedules.
pub const BONFIGLIOLI_MARGIN: Duration = Duration::from_millis(20);

/// How long a Bonfiglioli scan waits at each address: the response timeout counts from the
/// request's end to the first character of the answer, which a drive sends 10 ms after a
/// request at the earliest (ch. 6.8); with two character times for that first character and
/// [`BONFIGLIOLI_MARGIN`]. The 500 ms of ch. 6.8 are for a drive under load, not for finding
/// one.
pub fn bonfiglioli_timeout(line: &drive_core::LineSettings) -> Duration {
    bonfiglioli_modbus::slave::ANSWER_DELAY + line.char_time() * 2 + BONFIGLIOLI_MARGIN
}

/// A Bonfiglioli bus: each address gets one diagnostics request within `timeout`; a drive
/// that answers is asked for 30 configuration, 411 status word and its variant.
#[derive(Debug)]
pub struct BonfiglioliScan<'a, IO> {
    /// The bus's master.
    pub driver: &'a mut bonfiglioli_modbus::driver::ModbusDriver<IO>,
    /// How long to wait for the answer at each address ([`bonfiglioli_timeout`]).
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

#[cfg(test)]
mod tests {
    use super::*;
    use bonfiglioli_modbus::framing::Mode;

    #[test]
    fn issue18_scan_waits_the_answer_delay_and_a_margin_not_500_ms() {
        let line = |baud, mode: Mode| mode.line_settings(baud, drive_core::Parity::None);
        // 9600 8N2: 11 bits, 1.146 ms a character: 10 ms + 2.29 ms + 20 ms.
        let t = bonfiglioli_timeout(&line(9600, Mode::Rtu));
        assert_eq!(t.as_micros(), 10_000 + 2_291 + 20_000);
        // 19200: 10 ms + 1.15 ms + 20 ms; 115200: hardly more than the answer delay.
        assert_eq!(
            bonfiglioli_timeout(&line(19200, Mode::Rtu)).as_micros(),
            31_145
        );
        assert!(bonfiglioli_timeout(&line(115_200, Mode::Rtu)) < Duration::from_millis(31));
        // The timeout it replaced: answer delay, 60 characters and 20 ms (99 ms at 9600).
        let old = bonfiglioli_modbus::slave::ANSWER_DELAY
            + line(9600, Mode::Rtu).char_time() * 60
            + Duration::from_millis(20);
        assert!(t * 3 < old, "{t:?} vs {old:?}");
        // Never below what a drive needs before its first character.
        for baud in [2400, 9600, 19200, 57600, 115_200] {
            let l = line(baud, Mode::Ascii);
            assert!(
                bonfiglioli_timeout(&l) > bonfiglioli_modbus::slave::ANSWER_DELAY + l.char_time()
            );
        }
    }

    #[test]
    fn sew_firmware_numbers_read_as_part_and_version() {
        assert_eq!(firmware_text(822_609_711), "822 609 7.11");
        // Not nine digits: the number as it is.
        assert_eq!(firmware_text(1234), "1234");
    }

    #[test]
    fn each_familys_drive_found_keeps_its_keys() {
        let sbus = Found::Sbus {
            device_type: Err(ReturnCode::new(8, 0, 0x0010)),
            firmware: None,
        };
        let v = sbus.json(3);
        assert_eq!(v["address"], 3);
        assert!(v["device_type"].is_null());
        assert!(v["refused"].is_string());
        let nord = Found::Nord {
            status: Some(StatusWord(0x0B70)),
            configuration_level: None,
        };
        let v = nord.json(1);
        assert_eq!(
            (v["status_word"].as_u64(), v["state"].as_str()),
            (Some(0x0B70), Some("B"))
        );
        assert!(v["configuration_level"].is_null());
        let bonfiglioli = Found::Bonfiglioli {
            variant: None,
            configuration: Some(110),
            status_word: None,
        };
        let v = bonfiglioli.json(247);
        assert_eq!(v["configuration"], 110);
        assert!(v.get("firmware").is_some_and(Value::is_null));
    }
}
