//! The async USS driver (feature `tokio`): drive-core's one runtime driver
//! ([`drive_core::rt::Driver`]) running the sans-IO [`UssMaster`] over any [`CharIo`] (a serial
//! port from drive-transport, an in-memory link), talking to one drive.
//!
//! [`UssDriver`] implements the client's [`ParameterChannel`] and [`ProcessChannel`], so a
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
//! On a line whose adapter's echo is not taken out (`drive_core::rt::echo`), an answer that
//! repeats its telegram (a read's answer can: the same AK, the value and the process data as
//! sent; a mirror telegram's always does) cannot be told from the telegram's echo: it is taken
//! only once the line is known not to echo. Until then the driver asks for the parameter as an
//! array element (AK 6, whose answer has another AK) to find out; on a line that echoes every
//! call fails with [`LinkError::Echo`].
//!
//! The 3-word PKW carries no PWE1: an answer whose value word is the order's takes the order's
//! PWE1 (a word write's echo, whatever its sign), every other answer has PWE1 = the sign of
//! its value word. Reading a word above 32767 through the 3-word PKW therefore gives a negative
//! number: its meaning depends on the parameter (the table says whether it is signed).

use drive_core::LinkFault;
use std::time::Duration;

use drive_core::LineSettings;
use drive_core::rt::echo::{self, EchoCheck};
pub use drive_core::rt::{CharIo, Clock, DriverStats, Port};
use drive_core::rt::{Driver, Failed, Flow, Tally};

use super::framing::UssTiming;
use super::master::{MasterConfig, RejectReason, SendError, UssMaster};
use super::telegram::{Adr, Layout, MAX_PZD, Telegram, TelegramError, UssAddress};
use crate::client::{ParameterChannel, ProcessChannel};
use crate::uss::pkw::{Pke, Pkw, ak};
use crate::uss::pzd::{PzdIn, PzdOut};
use drive_profile::nord::StatusWord;

/// Configuration of a [`UssDriver`].
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

/// Why a driver call failed: the line ([`DriverError::Link`]) or the request itself
/// ([`DriverError::Request`]). A USS drive refuses an order inside its PKW answer (AK 7 with
/// an error number), which the driver returns like any answer; the client layer
/// ([`NordClient`](crate::client::NordClient)) makes it its `ClientError::Device`.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DriverError {
    /// No answer, answers that kept failing the checks, or the port.
    #[error(transparent)]
    Link(#[from] LinkError),
    /// The telegram cannot be made or sent; nothing was sent.
    #[error(transparent)]
    Request(#[from] RequestError),
}

/// How the line failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum LinkError {
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
    Corrupt {
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
    /// The port failed or was closed.
    #[error("port i/o failed: {0}; check that the port still exists and no other program uses it")]
    Io(#[from] std::io::Error),
    /// What came back was the telegram itself: the adapter echoes what it sends (a two-wire
    /// RS-485 converter whose receiver stays on) and its echo is not taken out, so no answer on
    /// the line can be told from the telegram's echo.
    #[error(
        "what came back for USS address {address} is the telegram itself: the adapter echoes what it sends and its echo is not taken out, so no answer can be told from the echo{}",
        if *sent { "; whether the drive received it is unknown" } else { "; nothing was sent" }
    )]
    Echo {
        /// The drive's address.
        address: u8,
        /// The telegram was sent.
        sent: bool,
    },
}

impl LinkError {
    /// What kind of link failure this is.
    pub fn fault(&self) -> LinkFault {
        match self {
            LinkError::Timeout { .. } => LinkFault::NoAnswer,
            LinkError::Corrupt { .. } => LinkFault::Garbled,
            LinkError::Io(_) => LinkFault::Port,
            LinkError::Echo { .. } => LinkFault::Echo,
        }
    }
}

/// Why a telegram cannot be made or sent.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum RequestError {
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
}

impl From<TelegramError> for DriverError {
    fn from(e: TelegramError) -> Self {
        DriverError::Request(e.into())
    }
}

impl From<SendError> for DriverError {
    fn from(e: SendError) -> Self {
        DriverError::Request(e.into())
    }
}

/// The async USS driver for one drive; see the [module docs](self).
#[derive(Debug)]
pub struct UssDriver<IO> {
    driver: Driver<Port<IO>, UssMaster>,
    config: DriverConfig,
    stats: DriverStats,
    /// The PKW order last sent (repeated by process telegrams).
    pkw: Pkw,
    /// The process data last sent (repeated by parameter telegrams).
    pzd: [u16; MAX_PZD],
}

impl<IO: CharIo> UssDriver<IO> {
    /// A driver on `io` with `config`.
    pub fn new(io: IO, config: DriverConfig) -> UssDriver<IO> {
        let port = Port::new(io, config.clock, config.line.char_time());
        UssDriver {
            driver: Driver::new(port, UssMaster::new(config.master())),
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
        self.driver.link_mut().get_mut()
    }

    /// The port back.
    pub fn into_inner(self) -> IO {
        self.driver.into_link().into_inner()
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
    /// none came. On a line whose adapter echoes what it sends while its echo is not taken out,
    /// [`LinkError::Echo`] (see the [module docs](self)).
    pub async fn transact(&mut self, telegram: Telegram) -> Result<Option<Telegram>, DriverError> {
        let broadcast = telegram.adr().is_broadcast();
        let address = self.config.address.get();
        let echo = |sent| DriverError::Link(LinkError::Echo { address, sent });
        if !broadcast && echo::echoes(self.driver.link_mut().get_mut()) {
            return Err(echo(false));
        }
        let r = self.exchange_telegram(telegram).await;
        if broadcast {
            return r;
        }
        let may_repeat = telegram.adr().is_mirror()
            || telegram
                .pkw()
                .is_none_or(|p| matches!(p.pke.ak(), ak::NONE | ak::READ));
        match echo::after_exchange(self.driver.link_mut().get_mut(), may_repeat) {
            EchoCheck::Fine => r,
            EchoCheck::Echoes => Err(echo(true)),
            EchoCheck::Ambiguous => {
                // A telegram whose answer never repeats it tells the echo from an answer: the
                // parameter asked for as an array element (AK 6: answered with AK 4, 5 or 7).
                let Some(order) = telegram.pkw() else {
                    // No parameter channel to ask with: the process data's answer repeated
                    // them, which a drive's status word never does.
                    return Err(echo(true));
                };
                let probe = Pkw {
                    pke: Pke::new(ak::READ_ARRAY, order.pke.pnu()).unwrap_or(order.pke),
                    ind: order.ind,
                    pwe1: 0,
                    pwe2: 0,
                };
                let probe = self.telegram(Adr::new(self.config.address), probe)?;
                let _ = self.exchange_telegram(probe).await;
                match echo::after_exchange(self.driver.link_mut().get_mut(), false) {
                    EchoCheck::Echoes => Err(echo(true)),
                    _ => r,
                }
            }
        }
    }

    /// One telegram through the master, as [`UssDriver::transact`] without the echo rules.
    async fn exchange_telegram(
        &mut self,
        telegram: Telegram,
    ) -> Result<Option<Telegram>, DriverError> {
        let now = self.driver.prepare();
        self.driver.master_mut().send(telegram, now)?;
        self.stats.transactions += 1;
        let mut tally = Tally::default();
        let r = self
            .driver
            .run(&mut tally, |m| m.poll_event().map(Flow::from))
            .await;
        self.stats.count(&tally, &r);
        r.map_err(|failed| {
            let (address, line, layout) = self.context();
            DriverError::Link(match failed {
                Failed::NoAnswer { attempts } => LinkError::Timeout {
                    address,
                    attempts,
                    line,
                    layout,
                },
                Failed::Corrupt { reason, attempts } => LinkError::Corrupt {
                    address,
                    reason,
                    attempts,
                    line,
                    layout,
                },
                Failed::Ended(never) => match never {},
                Failed::Io(e) => LinkError::Io(e),
            })
        })
    }

    /// What a link error names: the drive's address, the line and the layout.
    fn context(&self) -> (u8, LineSettings, Layout) {
        (
            self.config.address.get(),
            self.config.line,
            self.config.layout,
        )
    }

    /// No answer from a telegram that always gets one (only a broadcast is unanswered).
    fn unanswered(&self) -> DriverError {
        let (address, line, layout) = self.context();
        LinkError::Timeout {
            address,
            attempts: 0,
            line,
            layout,
        }
        .into()
    }

    /// One telegram with `pkw` and the current process data to the drive; its answer.
    async fn exchange(&mut self, pkw: Pkw) -> Result<Telegram, DriverError> {
        let telegram = self.telegram(Adr::new(self.config.address), pkw)?;
        self.pkw = pkw;
        match self.transact(telegram).await? {
            Some(answer) => Ok(answer),
            // Only a broadcast is unanswered, and this telegram is none.
            None => Err(self.unanswered()),
        }
    }

    /// The PKW answer of `answer` to `order` (3-word PKW: PWE1 as the module docs say).
    fn answer_pkw(&self, order: Pkw, answer: &Telegram) -> Result<Pkw, DriverError> {
        let mut pkw = answer.pkw().ok_or(RequestError::NoParameterChannel)?;
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
            None => Err(self.unanswered()),
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
            return Err(RequestError::PzdDoesNotFit { words, layout }.into());
        }
        self.pzd = [0; MAX_PZD];
        let given = core::iter::once(out.control().0).chain(out.setpoints().iter().copied());
        for (slot, w) in self.pzd.iter_mut().zip(given) {
            *slot = w;
        }
        Ok(())
    }
}

impl<IO: CharIo> ParameterChannel for UssDriver<IO> {
    type Error = DriverError;

    fn link_fault(error: &DriverError) -> Option<LinkFault> {
        match error {
            DriverError::Link(l) => Some(l.fault()),
            DriverError::Request(_) => None,
        }
    }

    async fn submit(&mut self, order: Pkw) -> Result<Pkw, DriverError> {
        if self.config.layout.pkw_words() == 0 {
            return Err(RequestError::NoParameterChannel.into());
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

impl<IO: CharIo> ProcessChannel for UssDriver<IO> {
    type Error = DriverError;

    fn link_fault(error: &DriverError) -> Option<LinkFault> {
        <Self as ParameterChannel>::link_fault(error)
    }

    async fn exchange_process(&mut self, out: PzdOut, actuals: u8) -> Result<PzdIn, DriverError> {
        let needed = 1 + usize::from(actuals);
        let layout = self.config.layout.pzd_words();
        if needed > usize::from(layout) {
            return Err(RequestError::PzdDoesNotFit {
                words: needed,
                layout,
            }
            .into());
        }
        self.set_process_data(&out)?;
        let answer = self.exchange(self.pkw).await?;
        let words = answer.pzd();
        let status = words.first().copied().unwrap_or(0);
        let values = words.get(1..needed).unwrap_or(&[]);
        Ok(PzdIn::new(StatusWord(status), values))
    }
}
