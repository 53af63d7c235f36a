//! One request through the runtime driver until it completes.

use std::time::Duration;

use drive_core::rt::{Failed, Flow, Tally};

use super::{CharIo, DriverError, LinkError, MovilinkDriver, RequestError};
use crate::error::ReturnCode;
use crate::frame::Telegram;
use crate::master::MasterEvent;

/// What one request produced.
#[derive(Debug, Default)]
pub(super) struct Outcome {
    pub(super) response: Option<Telegram>,
    pub(super) param: Option<Result<u32, ReturnCode>>,
}

impl<IO: CharIo> MovilinkDriver<IO> {
    /// Run one request through the sans-IO master (response timeout `timeout`, `retries`)
    /// until it completes: a request nobody answers once it is sent, an answered one when the
    /// master is idle with every event of it read (a response, then a parameter service's
    /// result). What it met is counted, and the wire times of its last answered exchange kept.
    pub(super) async fn transact(
        &mut self,
        request: Telegram,
        timeout: Duration,
        retries: u8,
    ) -> Result<Outcome, DriverError> {
        let address = request.address().get();
        let now = self.driver.prepare();
        let master = self.driver.master_mut();
        master.set_response_timeout(timeout);
        master.set_retries(retries);
        if master.send(request, now).is_err() {
            return Err(RequestError::NotARequest.into());
        }
        self.stats.transactions += 1;
        let mut out = Outcome::default();
        let mut tally = Tally::default();
        let device_errors = &mut self.stats.device_errors;
        let r = self
            .driver
            .run(&mut tally, |m| {
                let event = m.poll_event()?;
                let last = m.is_idle() && !m.has_events();
                Some(match event {
                    MasterEvent::Response { telegram } => {
                        out.response = Some(telegram);
                        if telegram.param().is_some_and(|p| p.management.is_error()) {
                            *device_errors += 1;
                        }
                        if last {
                            Flow::Answered(())
                        } else {
                            Flow::Answer
                        }
                    }
                    MasterEvent::ParamDone(result) => {
                        out.param = Some(result);
                        if last { Flow::Done(()) } else { Flow::Other }
                    }
                    MasterEvent::Sent { .. } => Flow::Done(()),
                    MasterEvent::Rejected(reason) => Flow::Rejected(reason),
                    MasterEvent::Timeout { attempts } => Flow::GaveUp { attempts },
                    MasterEvent::ParamNotExecuted { .. } => Flow::Failed(()),
                })
            })
            .await;
        self.stats.count(&tally, &r);
        if let Some(timing) = tally.timing {
            self.last_timing = Some(timing);
        }
        match r {
            Ok(()) => Ok(out),
            Err(Failed::NoAnswer { attempts }) => {
                Err(LinkError::Timeout { address, attempts }.into())
            }
            Err(Failed::Corrupt { reason, attempts }) => Err(LinkError::Corrupt {
                address,
                reason,
                attempts,
            }
            .into()),
            Err(Failed::Ended(())) => Err(LinkError::NotExecuted { address }.into()),
            // The telegram on the wire is broken or the port gone (the link let what did get
            // out leave the line): the master holds the bus for two start pauses.
            Err(Failed::Io(e)) => Err(LinkError::Io(e).into()),
        }
    }
}
