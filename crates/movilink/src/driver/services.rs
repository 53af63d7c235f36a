//! The services of the master: any parameter channel service, process data exchanges,
//! unanswered telegrams and probing; and the one call the SEW parameter services
//! ([`ParamServices`]: read, write, …) need.

use std::time::Duration;

use super::transact::Outcome;
use super::{
    CharIo, DriverError, LinkError, MovilinkDriver, ParamServices, RequestError, UNIT_TYPE_INDEX,
};
use crate::error::ReturnCode;
use crate::frame::{Address, ParamChannel, PduType, Telegram};

/// The SEW parameter services on RS-485: each one in an acyclic PARAM + 0PD telegram.
impl<IO: CharIo> ParamServices for MovilinkDriver<IO> {
    type Address = Address;
    type Error = DriverError;

    async fn service(
        &mut self,
        address: Address,
        request: ParamChannel,
    ) -> Result<ParamChannel, DriverError> {
        self.param(address, PduType::PARAM_0PD_ACYCLIC, request)
            .await
    }

    fn return_code(error: &DriverError) -> Option<ReturnCode> {
        match error {
            DriverError::Device(code) => Some(*code),
            _ => None,
        }
    }
}

impl<IO: CharIo> MovilinkDriver<IO> {
    /// One parameter-channel service on `address` in a telegram of type `pdu` (normally
    /// [`PduType::PARAM_0PD_ACYCLIC`]); returns the answer's parameter channel. Cyclic types
    /// toggle the handshake bit (the sans-IO master learns the drive's bit first if needed).
    /// Types with process data repeat the process output words last sent to `address` with
    /// [`MovilinkDriver::exchange`] (zeros before).
    pub async fn param(
        &mut self,
        address: Address,
        pdu: PduType,
        request: ParamChannel,
    ) -> Result<ParamChannel, DriverError> {
        if !pdu.has_param() {
            return Err(RequestError::NoParamChannel.into());
        }
        if !address.expects_response() {
            return Err(RequestError::Unanswered.into());
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
            .ok_or(LinkError::NoParamChannel.into())
    }

    /// Process data exchange with any PDU type (with or without parameter channel); returns
    /// the response telegram. A negative parameter answer is not an error here: read it with
    /// `response.param().map(|p| p.result())`. The process output words are remembered for
    /// [`MovilinkDriver::param`].
    pub async fn exchange(&mut self, request: Telegram) -> Result<Telegram, DriverError> {
        if request.direction() != crate::Direction::Request {
            return Err(RequestError::NotARequest.into());
        }
        if !request.address().expects_response() {
            return Err(RequestError::Unanswered.into());
        }
        self.remember_po(&request);
        let out = self
            .transact(request, self.config.response_timeout, self.config.retries)
            .await?;
        out.response.ok_or(LinkError::NoResponse.into())
    }

    /// A group (100–199) or broadcast (255) telegram: sent, never answered. Returns when the
    /// telegram has left the port; the next telegram waits the 25 ms broadcast spacing.
    pub async fn send_unanswered(&mut self, request: Telegram) -> Result<(), DriverError> {
        if request.direction() != crate::Direction::Request {
            return Err(RequestError::NotARequest.into());
        }
        if request.address().expects_response() {
            return Err(RequestError::Answered.into());
        }
        self.remember_po(&request);
        self.transact(request, self.config.response_timeout, 0)
            .await
            .map(drop)
    }

    /// Probe `address` with one read of P070 "unit type" (index 8301), one attempt, response
    /// timeout `timeout`: `Ok(Some(unit type))` if a drive answers, `Ok(None)` if nothing
    /// does. A negative answer ([`DriverError::Device`]) or garbled answers
    /// ([`LinkError::Corrupt`]) also mean that something is there.
    pub async fn probe(
        &mut self,
        address: Address,
        timeout: Duration,
    ) -> Result<Option<u32>, DriverError> {
        if !address.expects_response() {
            return Err(RequestError::NotProbeable.into());
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
            Ok(_) => Err(LinkError::NoParamChannel.into()),
            Err(DriverError::Link(LinkError::Timeout { .. })) => Ok(None),
            Err(e) => Err(e),
        }
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
