//! The services of the master: parameter channel services, process data exchanges,
//! unanswered telegrams and probing.

use std::time::Duration;

use super::transact::Outcome;
use super::{CharIo, DriverError, MasterDriver, UNIT_TYPE_INDEX};
use crate::frame::{Address, AttributeInfo, ParamChannel, PduType, ScaleInfo, Telegram};

impl<IO: CharIo> MasterDriver<IO> {
    /// One parameter-channel service on `address` in a telegram of type `pdu` (normally
    /// [`PduType::PARAM_0PD_ACYCLIC`]); returns the answer's parameter channel. Cyclic types
    /// toggle the handshake bit (the sans-IO master learns the drive's bit first if needed).
    /// Types with process data repeat the process output words last sent to `address` with
    /// [`MasterDriver::exchange`] (zeros before).
    pub async fn param(
        &mut self,
        address: Address,
        pdu: PduType,
        request: ParamChannel,
    ) -> Result<ParamChannel, DriverError> {
        if !pdu.has_param() {
            return Err(DriverError::InvalidRequest(
                "the pdu type has no parameter channel; use one of the PARAM types",
            ));
        }
        if !address.expects_response() {
            return Err(DriverError::InvalidRequest(
                "group and broadcast addresses get no answer; use send_unanswered",
            ));
        }
        let po = self.po_of(address);
        let telegram = Telegram::request(address, pdu)
            .with_param(request)
            .with_process_data(&po);
        let out = self
            .transact(telegram, self.config.response_timeout, self.config.retries)
            .await?;
        if let Some(Err(rc)) = out.param {
            return Err(DriverError::Device(rc));
        }
        out.response
            .and_then(|t| t.param())
            .ok_or(DriverError::InvalidRequest(
                "the answer carried no parameter channel",
            ))
    }

    /// Read the value of `index` (acyclic PARAM + 0PD).
    pub async fn read(&mut self, address: Address, index: u16) -> Result<u32, DriverError> {
        self.service(address, ParamChannel::read(index)).await
    }

    /// Write `value` to `index`, non-volatile (EEPROM). Not for cyclic writes: EEPROMs wear
    /// out; see [`drive_profile::guard::WriteGuard`] and [`MasterDriver::write_volatile`].
    pub async fn write(
        &mut self,
        address: Address,
        index: u16,
        value: u32,
    ) -> Result<(), DriverError> {
        self.service(address, ParamChannel::write(index, value))
            .await
            .map(drop)
    }

    /// Write `value` to `index`, volatile (RAM, lost at power-off).
    pub async fn write_volatile(
        &mut self,
        address: Address,
        index: u16,
        value: u32,
    ) -> Result<(), DriverError> {
        self.service(address, ParamChannel::write_volatile(index, value))
            .await
            .map(drop)
    }

    /// Read the smallest settable value of `index`.
    pub async fn read_minimum(&mut self, address: Address, index: u16) -> Result<u32, DriverError> {
        self.service(address, ParamChannel::read_minimum(index))
            .await
    }

    /// Read the largest settable value of `index`.
    pub async fn read_maximum(&mut self, address: Address, index: u16) -> Result<u32, DriverError> {
        self.service(address, ParamChannel::read_maximum(index))
            .await
    }

    /// Read the default (factory setting) of `index`.
    pub async fn read_default(&mut self, address: Address, index: u16) -> Result<u32, DriverError> {
        self.service(address, ParamChannel::read_default(index))
            .await
    }

    /// Read the size and conversion index of `index`.
    pub async fn read_scale(
        &mut self,
        address: Address,
        index: u16,
    ) -> Result<ScaleInfo, DriverError> {
        self.service(address, ParamChannel::read_scale(index))
            .await
            .map(ScaleInfo::from_data)
    }

    /// Read the access attributes of `index` and the next available index.
    pub async fn read_attribute(
        &mut self,
        address: Address,
        index: u16,
    ) -> Result<AttributeInfo, DriverError> {
        self.service(address, ParamChannel::read_attribute(index))
            .await
            .map(AttributeInfo::from_data)
    }

    /// Process data exchange with any PDU type (with or without parameter channel); returns
    /// the response telegram. A negative parameter answer is not an error here: read it with
    /// `response.param().map(|p| p.result())`. The process output words are remembered for
    /// [`MasterDriver::param`].
    pub async fn exchange(&mut self, request: Telegram) -> Result<Telegram, DriverError> {
        if request.direction() != crate::Direction::Request {
            return Err(DriverError::InvalidRequest("the telegram is not a request"));
        }
        if !request.address().expects_response() {
            return Err(DriverError::InvalidRequest(
                "group and broadcast addresses get no answer; use send_unanswered",
            ));
        }
        self.remember_po(&request);
        let out = self
            .transact(request, self.config.response_timeout, self.config.retries)
            .await?;
        out.response.ok_or(DriverError::InvalidRequest(
            "the exchange completed without a response",
        ))
    }

    /// A group (100–199) or broadcast (255) telegram: sent, never answered. Returns when the
    /// telegram has left the port; the next telegram waits the 25 ms broadcast spacing.
    pub async fn send_unanswered(&mut self, request: Telegram) -> Result<(), DriverError> {
        if request.direction() != crate::Direction::Request {
            return Err(DriverError::InvalidRequest("the telegram is not a request"));
        }
        if request.address().expects_response() {
            return Err(DriverError::InvalidRequest(
                "only group (100-199) and broadcast (255) telegrams go unanswered; use exchange or param",
            ));
        }
        self.remember_po(&request);
        self.transact(request, self.config.response_timeout, 0)
            .await
            .map(drop)
    }

    /// Probe `address` with one read of P070 "unit type" (index 8301), one attempt, response
    /// timeout `timeout`: `Ok(Some(unit type))` if a drive answers, `Ok(None)` if nothing
    /// does. A negative answer ([`DriverError::Device`]) or garbled answers
    /// ([`DriverError::Corrupt`]) also mean that something is there.
    pub async fn probe(
        &mut self,
        address: Address,
        timeout: Duration,
    ) -> Result<Option<u32>, DriverError> {
        if !address.expects_response() {
            return Err(DriverError::InvalidRequest(
                "group and broadcast addresses cannot be probed",
            ));
        }
        let telegram = Telegram::request(address, PduType::PARAM_0PD_ACYCLIC)
            .with_param(ParamChannel::read(UNIT_TYPE_INDEX));
        match self.transact(telegram, timeout, 0).await {
            Ok(Outcome {
                param: Some(Ok(v)), ..
            }) => Ok(Some(v)),
            Ok(Outcome {
                param: Some(Err(rc)),
                ..
            }) => Err(DriverError::Device(rc)),
            Ok(_) => Err(DriverError::InvalidRequest(
                "the answer carried no parameter channel",
            )),
            Err(DriverError::Timeout { .. }) => Ok(None),
            Err(e) => Err(e),
        }
    }

    pub(super) async fn service(
        &mut self,
        address: Address,
        request: ParamChannel,
    ) -> Result<u32, DriverError> {
        let p = self
            .param(address, PduType::PARAM_0PD_ACYCLIC, request)
            .await?;
        Ok(p.data)
    }

    pub(super) fn po_of(&self, address: Address) -> [u16; 3] {
        self.po
            .get(usize::from(address.get()))
            .copied()
            .unwrap_or_default()
    }

    /// Set the process output words remembered for `address` (used by cyclic sessions).
    pub(super) fn set_po(&mut self, address: Address, words: &[u16]) {
        if let Some(slot) = self.po.get_mut(usize::from(address.get())) {
            for (dst, src) in slot.iter_mut().zip(words) {
                *dst = *src;
            }
        }
    }

    pub(super) fn remember_po(&mut self, request: &Telegram) {
        let words = request.process_data();
        if words.is_empty() {
            return;
        }
        if let Some(slot) = self.po.get_mut(usize::from(request.address().get())) {
            for (dst, src) in slot.iter_mut().zip(words) {
                *dst = *src;
            }
        }
    }
}
