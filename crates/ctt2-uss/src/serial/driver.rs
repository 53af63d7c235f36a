//! The async USS master (feature `tokio`) on drive-core's runtime layer: the sans-IO
//! [`Master`] over any [`CharIo`] (a serial port from drive-transport, an in-memory link),
//! talking to one drive.
//!
//! [`UssMaster`] implements the client's [`ParameterChannel`] and [`ProcessChannel`], so a
//! [`NordClient`](crate::client::NordClient) runs orders to their plausible answers and the
//! drive's state machine over it. A USS telegram always carries both parts, so:
//!
//! * a parameter telegram ([`ParameterChannel::submit`] and [`ParameterChannel::poll`] alike:
//!   USS asks again by sending the same telegram) carries the process data last sent, so
//!   reading a parameter does not change the drive's control word or setpoints;
//! * a process telegram ([`ProcessChannel::exchange_process`]) carries the PKW order last
//!   sent, so the drive does not take it for a new order (a changed PKW is a new order for
//!   the drive: sending "no order" in between would make it execute a repeated write twice).
//!
//! Before the first process exchange the process data are all zero: control word 0000h has
//! bit 10 ("Steuerdaten gültig") clear, so the drive ignores them.
//!
//! The 3-word PKW carries no PWE1: an answer whose value word is the order's takes the order's
//! PWE1 (a word write's echo, whatever its sign), every other answer has PWE1 = the sign of
//! its value word. Reading a word above 32767 through the 3-word PKW therefore gives a negative
//! number: its meaning depends on the parameter (the table says whether it is signed).

use std::time::Duration;

use drive_core::LineSettings;
pub use drive_core::rt::{CharIo, Clock, Port};
use drive_core::rt::{Failed, Flow, Tally};

use super::framing::UssTiming;
use super::master::{Master, MasterConfig, MasterEvent, RejectReason, SendError};
use super::telegram::{Adr, Layout, MAX_PZD, MAX_TELEGRAM, Telegram, TelegramError, UssAddress};
use crate::client::{ParameterChannel, ProcessChannel};
use crate::uss::pkw::Pkw;
use crate::uss::pzd::{PzdIn, PzdOut};
use drive_profile::nord::StatusWord;

/// Configuration of a [`UssMaster`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DriverConfig {
    /// The drive's address.
    pub address: UssAddress,
    /// The layout of the telegrams (the drive's setting).
    pub layout: Layout,
    /// The line (timing).
    pub line: LineSettings,
    /// The USS times.
    pub timing: UssTiming,
    /// From the end of a telegram to the start of its answer (USS: 20 ms).
    pub response_timeout: Duration,
    /// Retransmissions after a timeout or a rejected answer.
    pub retries: u8,
    /// Real time, or the virtual clock of benchmarks.
    pub clock: Clock,
}

impl DriverConfig {
    /// Drive `address` with `layout` on `line`, the specification's times, real time.
    pub fn new(address: UssAddress, layout: Layout, line: LineSettings) -> DriverConfig {
        DriverConfig {
            address,
            layout,
            line,
            timing: UssTiming::from_line(&line),
            response_timeout: super::master::DEFAULT_RESPONSE_TIMEOUT,
            retries: 2,
            clock: Clock::Real,
        }
    }

    fn master(&self) -> MasterConfig {
        MasterConfig {
            timing: self.timing,
            response_timeout: self.response_timeout,
            retries: self.retries,
            ..MasterConfig::new(self.line)
        }
    }
}

/// Counts of what the driver did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
pub struct DriverStats {
    /// Telegrams started.
    pub transactions: u64,
    /// Retransmissions.
    pub retries: u64,
    /// Telegrams given up without any answer.
    pub timeouts: u64,
    /// Answers not taken.
    pub rejected: u64,
    /// Bytes never taken as an answer because they arrived before the telegram had left the
    /// port (an answer an earlier program left there, a late answer, another master).
    pub stale: u64,
}

/// Why a driver call failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DriverError {
    /// Nothing answered in time, in every attempt.
    #[error(
        "no answer from USS address {address} after {attempts} attempts at {line} with {} PKW + {} PZD words; check the address, that the drive's baud rate and parity are {line} too, its telegram layout (PKW and PZD words), wiring and termination",
        layout.pkw_words(),
        layout.pzd_words()
    )]
    Timeout {
        /// The drive's address.
        address: u8,
        /// Transmissions made.
        attempts: u32,
        /// The line as the master uses it (baud rate, data bits, parity, stop bits).
        line: LineSettings,
        /// The telegram layout the master uses.
        layout: Layout,
    },
    /// Answers arrived but kept failing the checks.
    #[error(
        "answers from USS address {address} kept failing the checks ({reason}) in {attempts} attempts at {line} with {} PKW + {} PZD words; check that the drive's baud rate, parity and telegram layout are the same, termination and for a second master",
        layout.pkw_words(),
        layout.pzd_words()
    )]
    Rejected {
        /// The drive's address.
        address: u8,
        /// The last check that failed.
        reason: RejectReason,
        /// Transmissions made.
        attempts: u32,
        /// The line as the master uses it.
        line: LineSettings,
        /// The telegram layout the master uses.
        layout: Layout,
    },
    /// The layout has no PKW part: no parameter orders.
    #[error("the telegram layout has no PKW part: parameters cannot be read or written")]
    NoParameterChannel,
    /// The process data asked for do not fit the layout's PZD words.
    #[error("{words} process-data words do not fit the layout's {layout} PZD words")]
    PzdDoesNotFit {
        /// Words needed.
        words: usize,
        /// The layout's.
        layout: u8,
    },
    /// The telegram cannot be built (a double word through the 3-word PKW).
    #[error("{0}")]
    Telegram(#[from] TelegramError),
    /// The telegram cannot be sent this way.
    #[error("{0}")]
    Send(#[from] SendError),
    /// The port failed or was closed.
    #[error("port i/o failed: {0}; check that the port still exists and no other program uses it")]
    Io(#[from] std::io::Error),
}

/// The async USS master for one drive; see the [module docs](self).
#[derive(Debug)]
pub struct UssMaster<IO> {
    master: Master,
    port: Port<IO>,
    config: DriverConfig,
    stats: DriverStats,
    /// The PKW order last sent (repeated by process telegrams).
    pkw: Pkw,
    /// The process data last sent (repeated by parameter telegrams).
    pzd: [u16; MAX_PZD],
}

impl<IO: CharIo> UssMaster<IO> {
    /// A driver on `io` with `config`.
    pub fn new(io: IO, config: DriverConfig) -> UssMaster<IO> {
        UssMaster {
            master: Master::new(config.master()),
            port: Port::new(io, config.clock, config.line.char_time()),
            config,
            stats: DriverStats::default(),
            pkw: Pkw::default(),
            pzd: [0; MAX_PZD],
        }
    }

    /// The configuration.
    pub fn config(&self) -> &DriverConfig {
        &self.config
    }

    /// What the driver did so far.
    pub fn stats(&self) -> DriverStats {
        self.stats
    }

    /// The process data sent with every telegram now.
    pub fn process_data(&self) -> &[u16] {
        self.pzd
            .get(..usize::from(self.config.layout.pzd_words()))
            .unwrap_or(&[])
    }

    /// The port, for inspection or fault injection.
    pub fn port_mut(&mut self) -> &mut IO {
        self.port.get_mut()
    }

    /// The port back.
    pub fn into_inner(self) -> IO {
        self.port.into_inner()
    }

    /// The telegram to the drive with `pkw` and the process data last set.
    fn telegram(&self, adr: Adr, pkw: Pkw) -> Result<Telegram, DriverError> {
        Ok(Telegram::new(
            adr,
            self.config.layout,
            pkw,
            self.process_data(),
        )?)
    }

    /// One telegram through the master: the answer (None for a broadcast once sent) or why
    /// none came.
    pub async fn transact(&mut self, telegram: Telegram) -> Result<Option<Telegram>, DriverError> {
        let now = self.port.now();
        if !self.master.is_idle() {
            // A previous call was cancelled mid-telegram.
            self.master.abort(now);
        }
        while self.master.poll_event().is_some() {}
        self.master.send(telegram, now)?;
        self.stats.transactions += 1;
        let mut buf = [0u8; MAX_TELEGRAM];
        let address = telegram.adr().address().get();
        let (line, layout) = (self.config.line, self.config.layout);
        let mut tally = Tally::default();
        let r = self
            .port
            .transact(
                &mut self.master,
                &mut buf,
                &mut tally,
                |m| {
                    m.poll_event().map(|event| match event {
                        MasterEvent::Response(t) => Flow::Done(Some(t)),
                        MasterEvent::Sent => Flow::Done(None),
                        MasterEvent::Rejected(reason) => Flow::Rejected(reason),
                        MasterEvent::Timeout { attempts } => Flow::GaveUp { attempts },
                    })
                },
                |m, now| m.abort(now),
            )
            .await;
        self.stats.retries += u64::from(tally.retries());
        self.stats.rejected += u64::from(tally.rejected);
        self.stats.stale += u64::from(tally.stale);
        r.map_err(|failed| match failed {
            Failed::NoAnswer {
                attempts,
                last_reject: Some(reason),
            } => DriverError::Rejected {
                address,
                reason,
                attempts,
                line,
                layout,
            },
            Failed::NoAnswer {
                attempts,
                last_reject: None,
            } => {
                self.stats.timeouts += 1;
                DriverError::Timeout {
                    address,
                    attempts,
                    line,
                    layout,
                }
            }
            Failed::Io(e) => DriverError::Io(e),
        })
    }

    /// One telegram with `pkw` and the current process data to the drive; its answer.
    async fn exchange(&mut self, pkw: Pkw) -> Result<Telegram, DriverError> {
        let telegram = self.telegram(Adr::new(self.config.address), pkw)?;
        self.pkw = pkw;
        match self.transact(telegram).await? {
            Some(answer) => Ok(answer),
            // Only a broadcast is unanswered, and this telegram is none.
            None => Err(DriverError::Timeout {
                address: self.config.address.get(),
                attempts: 0,
                line: self.config.line,
                layout: self.config.layout,
            }),
        }
    }

    /// The PKW answer of `answer` to `order` (3-word PKW: PWE1 as the module docs say).
    fn answer_pkw(&self, order: Pkw, answer: &Telegram) -> Result<Pkw, DriverError> {
        let mut pkw = answer.pkw().ok_or(DriverError::NoParameterChannel)?;
        if self.config.layout.pkw_words() == 3
            && pkw.pwe2 == order.pwe2
            && (order.pwe1 == 0 || order.pwe1 == 0xFFFF)
        {
            pkw.pwe1 = order.pwe1;
        }
        Ok(pkw)
    }

    /// Send a mirror telegram with the current PKW order and process data and check that it
    /// comes back unchanged (a line test: the drive executes nothing).
    pub async fn mirror(&mut self) -> Result<Telegram, DriverError> {
        let telegram = self.telegram(Adr::mirror(self.config.address), self.pkw)?;
        match self.transact(telegram).await? {
            Some(t) => Ok(t),
            None => Err(DriverError::Timeout {
                address: self.config.address.get(),
                attempts: 0,
                line: self.config.line,
                layout: self.config.layout,
            }),
        }
    }

    /// Broadcast `pkw` (no order, or a write order) and the current process data to every
    /// drive on the line; returns once it is sent (nobody answers).
    pub async fn broadcast(&mut self, pkw: Pkw) -> Result<(), DriverError> {
        let telegram = self.telegram(Adr::broadcast(), pkw)?;
        self.transact(telegram).await.map(|_| ())
    }

    /// Set the process data sent from now on: control word and setpoints, the rest of the
    /// layout's PZD words zero.
    pub fn set_process_data(&mut self, out: &PzdOut) -> Result<(), DriverError> {
        let words = 1 + out.setpoints().len();
        let layout = self.config.layout.pzd_words();
        if words > usize::from(layout) {
            return Err(DriverError::PzdDoesNotFit { words, layout });
        }
        self.pzd = [0; MAX_PZD];
        let given = core::iter::once(out.control().0).chain(out.setpoints().iter().copied());
        for (slot, w) in self.pzd.iter_mut().zip(given) {
            *slot = w;
        }
        Ok(())
    }
}

impl<IO: CharIo> ParameterChannel for UssMaster<IO> {
    type Error = DriverError;

    async fn submit(&mut self, order: Pkw) -> Result<Pkw, DriverError> {
        if self.config.layout.pkw_words() == 0 {
            return Err(DriverError::NoParameterChannel);
        }
        let answer = self.exchange(order).await?;
        self.answer_pkw(order, &answer)
    }

    async fn poll(&mut self, order: Pkw) -> Result<Pkw, DriverError> {
        // USS asks again by sending the same telegram.
        self.submit(order).await
    }

    fn stale_bytes(&self) -> u64 {
        self.stats.stale
    }
}

impl<IO: CharIo> ProcessChannel for UssMaster<IO> {
    type Error = DriverError;

    async fn exchange_process(&mut self, out: PzdOut, actuals: u8) -> Result<PzdIn, DriverError> {
        let needed = 1 + usize::from(actuals);
        let layout = self.config.layout.pzd_words();
        if needed > usize::from(layout) {
            return Err(DriverError::PzdDoesNotFit {
                words: needed,
                layout,
            });
        }
        self.set_process_data(&out)?;
        let answer = self.exchange(self.pkw).await?;
        let words = answer.pzd();
        let status = words.first().copied().unwrap_or(0);
        let values = words.get(1..needed).unwrap_or(&[]);
        Ok(PzdIn::new(StatusWord(status), values))
    }
}
