//! Cyclic mode: a session that sends a cyclic telegram to one drive every period, so the
//! drive's RS-485 timeout (P812) stays fed, and runs parameter services inside that stream.

use std::time::Duration;

use tokio::time::Instant as TokioInstant;

use super::{CharIo, DriverError, MovilinkDriver, RequestError};
use crate::frame::{Address, ParamChannel, PduType, Telegram};

/// A cyclic session with one drive, borrowed from a [`MovilinkDriver`].
///
/// Every call of [`CyclicSession::cycle`] or [`CyclicSession::param`] first waits for the next
/// period boundary, then exchanges one telegram of the session's cyclic PDU type carrying the
/// current process output words. The caller keeps calling (e.g. in a loop) for as long as the
/// drive should stay enabled; when the calls stop, the drive's RS-485 timeout fires after P812
/// and it reacts as P833 says. The schedule is fixed-rate: a late cycle does not cause a burst
/// of catch-up telegrams, the next one is simply one period after the late one.
#[derive(Debug)]
pub struct CyclicSession<'a, IO> {
    driver: &'a mut MovilinkDriver<IO>,
    address: Address,
    pdu: PduType,
    period: Duration,
    next: Option<TokioInstant>,
    output: [u16; 3],
}

impl<IO: CharIo> MovilinkDriver<IO> {
    /// Start a cyclic session with `address` using the cyclic `pdu` type (0x00–0x06), one
    /// telegram every `period`. The process output words start as the ones last sent to the
    /// drive (zeros before any); set them with [`CyclicSession::set_output`].
    pub fn cyclic(
        &mut self,
        address: Address,
        pdu: PduType,
        period: Duration,
    ) -> Result<CyclicSession<'_, IO>, DriverError> {
        if !pdu.is_cyclic() {
            return Err(RequestError::NotCyclic.into());
        }
        if !address.expects_response() {
            return Err(RequestError::NotSingle.into());
        }
        if period.is_zero() {
            return Err(RequestError::ZeroPeriod.into());
        }
        let output = self.po_of(address);
        Ok(CyclicSession {
            driver: self,
            address,
            pdu,
            period,
            next: None,
            output,
        })
    }
}

impl<IO: CharIo> CyclicSession<'_, IO> {
    /// The drive this session talks to.
    pub fn address(&self) -> Address {
        self.address
    }

    /// The cyclic PDU type of the session.
    pub fn pdu_type(&self) -> PduType {
        self.pdu
    }

    /// The period between telegrams.
    pub fn period(&self) -> Duration {
        self.period
    }

    /// Set the process output words sent from the next cycle on (extra words are ignored,
    /// missing ones keep their value).
    pub fn set_output(&mut self, words: &[u16]) {
        for (dst, src) in self.output.iter_mut().zip(words) {
            *dst = *src;
        }
    }

    /// The process output words the session sends.
    pub fn output(&self) -> &[u16] {
        self.output.get(..self.pdu.pd_words()).unwrap_or(&[])
    }

    /// Wait for the next period boundary and claim it.
    async fn wait_turn(&mut self) {
        if let Some(at) = self.next {
            tokio::time::sleep_until(at).await;
        }
        let now = TokioInstant::now();
        let base = self.next.map_or(now, |at| at.max(now));
        self.next = Some(base + self.period);
    }

    /// One cycle: wait for the period boundary, send the process output words (and, with a
    /// PARAM type, an empty parameter channel), return the drive's response.
    pub async fn cycle(&mut self) -> Result<Telegram, DriverError> {
        self.wait_turn().await;
        let mut request =
            Telegram::request(self.address, self.pdu).with_process_data(self.output());
        if self.pdu.has_param() {
            request = request.with_param(ParamChannel::no_service());
        }
        self.driver.exchange(request).await
    }

    /// A parameter service inside the cyclic stream (PARAM types only): the handshake bit is
    /// toggled and the service completes when the drive echoes it. The process output words
    /// keep being sent meanwhile, so the drive's timeout stays fed.
    pub async fn param(&mut self, request: ParamChannel) -> Result<ParamChannel, DriverError> {
        if !self.pdu.has_param() {
            return Err(RequestError::NoParamInCycle.into());
        }
        self.wait_turn().await;
        let words = self.output;
        self.driver.set_po(self.address, &words);
        self.driver.param(self.address, self.pdu, request).await
    }
}
