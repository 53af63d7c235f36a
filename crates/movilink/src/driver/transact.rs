//! The transaction loop: one request through the sans-IO master until it completes.

use std::time::Duration;

use tokio::time::Instant as TokioInstant;

use super::{CharIo, DriverError, ExchangeTiming, MasterDriver};
use crate::error::{RejectReason, ReturnCode};
use crate::frame::{MAX_TELEGRAM_LEN, Telegram};
use crate::master::MasterEvent;
use drive_core::rt::Step;

/// What one request produced.
#[derive(Debug, Default)]
pub(super) struct Outcome {
    pub(super) response: Option<Telegram>,
    pub(super) param: Option<Result<u32, ReturnCode>>,
}

impl<IO: CharIo> MasterDriver<IO> {
    /// Run one request through the sans-IO master until it completes; the stale bytes it met
    /// are counted.
    pub(super) async fn transact(
        &mut self,
        request: Telegram,
        timeout: Duration,
        retries: u8,
    ) -> Result<Outcome, DriverError> {
        let stale = self.master.stale_chars();
        let r = self.run(request, timeout, retries).await;
        self.stats.stale += self.master.stale_chars().saturating_sub(stale);
        r
    }

    async fn run(
        &mut self,
        request: Telegram,
        timeout: Duration,
        retries: u8,
    ) -> Result<Outcome, DriverError> {
        let address = request.address().get();
        let now = self.port.now();
        if !self.master.is_idle() {
            // A previous call was cancelled mid-request: its telegram broke off.
            self.master.abort(now);
        }
        while self.master.poll_event().is_some() {}
        self.master.set_response_timeout(timeout);
        self.master.set_retries(retries);
        if self.master.send(request, now).is_err() {
            return Err(DriverError::InvalidRequest("the telegram is not a request"));
        }
        self.stats.transactions += 1;
        let mut out = Outcome::default();
        let mut transmissions: u32 = 0;
        let mut answered = false;
        let mut last_reject: Option<RejectReason> = None;
        let mut request_start = TokioInstant::now();
        let mut buf = [0u8; MAX_TELEGRAM_LEN];
        loop {
            while let Some(event) = self.master.poll_event() {
                match event {
                    MasterEvent::Response { telegram } => {
                        answered = true;
                        out.response = Some(telegram);
                        if let Some(end) = self.port.last_rx_at() {
                            self.last_timing = Some(ExchangeTiming {
                                request_start,
                                response_end: end,
                            });
                        }
                        if telegram.param().is_some_and(|p| p.management.is_error()) {
                            self.stats.device_errors += 1;
                        }
                    }
                    MasterEvent::ParamDone(result) => out.param = Some(result),
                    MasterEvent::Rejected(reason) => {
                        self.stats.rejected += 1;
                        last_reject = Some(reason);
                    }
                    MasterEvent::Timeout { attempts } => {
                        let attempts = u32::from(attempts);
                        return Err(match last_reject {
                            Some(reason) => DriverError::Corrupt {
                                address,
                                reason,
                                attempts,
                            },
                            None => {
                                self.stats.timeouts += 1;
                                DriverError::Timeout { address, attempts }
                            }
                        });
                    }
                    MasterEvent::ParamNotExecuted { .. } => {
                        return Err(DriverError::NotExecuted { address });
                    }
                    _ => {}
                }
            }
            if self.master.is_idle() {
                return Ok(out);
            }
            let before = TokioInstant::now();
            match self.port.step(&mut self.master, &mut buf).await {
                Ok(Step::Sent(_)) => {
                    if transmissions > 0 && !answered {
                        self.stats.retries += 1;
                    }
                    transmissions = transmissions.saturating_add(1);
                    answered = false;
                    last_reject = None;
                    // Where the request was meant to start (after a timer wake-up: the
                    // deadline, where the wire model puts it, not tokio's later tick).
                    request_start = self.port.last_tx_start().unwrap_or(before);
                }
                Ok(Step::Waited) => {}
                Err(e) => {
                    // The telegram on the wire is broken or the port gone (`step` let what
                    // did get out leave the line): the master holds the bus for two start
                    // pauses.
                    self.master.abort(self.port.now());
                    return Err(DriverError::Io(e));
                }
            }
        }
    }
}
