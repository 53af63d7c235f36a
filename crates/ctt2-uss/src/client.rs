//! The parameter and process-data logic both masters share (feature `tokio`): one
//! [`NordClient`] over either transport.
//!
//! A transport implements [`ParameterChannel`] (hand an order to the drive, ask again for its
//! answer) and [`ProcessChannel`] (one process-data exchange). The USS serial master repeats the
//! telegram that carries the order; the CTT2 master writes the order once and then reads the
//! parameter channel back, because the answer to a CTT2 write says nothing about execution.
//! Either way the drive keeps answering the previous order until the new one is done, so the
//! client takes an answer only when [`Order::check`] finds it plausible (AK, PNU and IND fit the
//! order, and a write's answer repeats the value), and asks again until it does or
//! [`ClientConfig::max_polls`] is reached.
//!
//! Two orders in a row on the same parameter and index cannot be told apart by their answers:
//! the second one's first answer could be the first one's (an AK 7 refusal fits every order, a
//! write's echo fits a read; erratum E21). The client therefore sends "no order" (AK 0) and
//! waits for its answer (AK 0) before such an order, and before its first order, because the
//! drive may still answer an order of an earlier session.
//!
//! On top of that: reads and writes of words, double words, array elements and parameter sets,
//! the number of array elements, writes without EEPROM (AK 11–14), and control through the NORD
//! state machine ([`NordClient::drive_to`]).

use core::fmt;
use core::future::Future;

use drive_core::LinkFault;
use drive_profile::nord::{ControlWord, NordStateMachine, State, StatusWord, Width};
use drive_profile::state::StateMachine;

use crate::uss::DriveError;
use crate::uss::pkw::{Ind, IndLayout, Order, Pkw, PkwError, Plausibility, Reply, Storage};
use crate::uss::pzd::{PzdIn, PzdOut};

/// A transport's parameter channel.
pub trait ParameterChannel {
    /// What can go wrong on the transport (timeouts, checks, I/O).
    type Error: std::error::Error + Send + Sync + 'static;

    /// Hand a new order to the drive and return the first parameter-channel answer received
    /// (which may still be the previous order's).
    fn submit(&mut self, order: Pkw) -> impl Future<Output = Result<Pkw, Self::Error>>;

    /// Ask again for the answer to `order`, the order last submitted (USS: send the same
    /// telegram again; CTT2: read the parameter channel).
    fn poll(&mut self, order: Pkw) -> impl Future<Output = Result<Pkw, Self::Error>>;

    /// Bytes the transport discarded so far because they arrived before a telegram had left
    /// the port (an answer an earlier program left there, a late answer); 0 where the
    /// transport has no such bytes.
    fn stale_bytes(&self) -> u64 {
        0
    }

    /// What kind of link failure `error` is; `None` when it is none (a request the transport
    /// cannot carry, nothing sent). A transport that does not say is taken as a failed port.
    fn link_fault(error: &Self::Error) -> Option<LinkFault> {
        let _ = error;
        Some(LinkFault::Port)
    }
}

/// A transport's process-data channel.
pub trait ProcessChannel {
    /// What can go wrong on the transport.
    type Error: std::error::Error + Send + Sync + 'static;

    /// Send control word and setpoints, and return status word and `actuals` actual values
    /// (0–3).
    fn exchange_process(
        &mut self,
        out: PzdOut,
        actuals: u8,
    ) -> impl Future<Output = Result<PzdIn, Self::Error>>;

    /// What kind of link failure `error` is, as [`ParameterChannel::link_fault`].
    fn link_fault(error: &Self::Error) -> Option<LinkFault> {
        let _ = error;
        Some(LinkFault::Port)
    }
}

/// Settings of a [`NordClient`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ClientConfig {
    /// How often the client asks again for a plausible answer before it gives up.
    pub max_polls: u16,
    /// How many control words [`NordClient::drive_to`] sends before it gives up.
    pub max_steps: u16,
}

impl Default for ClientConfig {
    fn default() -> Self {
        Self {
            max_polls: 50,
            max_steps: 200,
        }
    }
}

/// Why a client operation failed.
#[derive(Debug)]
#[non_exhaustive]
pub enum ClientError<E> {
    /// The transport failed (timeout, check, I/O).
    Transport(E),
    /// The drive answered AK 7 with this error number.
    Drive {
        /// The order.
        order: Order,
        /// The error number from PWE2.
        error: DriveError,
    },
    /// No plausible answer after `polls` requests: the drive kept answering another order.
    NoPlausibleAnswer {
        /// The order.
        order: Order,
        /// Requests made.
        polls: u16,
        /// The last answer received.
        last: Pkw,
    },
    /// The order cannot be built (value too wide, PNU or index out of range), or a plausible
    /// answer cannot be decoded.
    Pkw(PkwError),
    /// An answer of the wrong kind (e.g. a count where a value was asked for).
    UnexpectedReply {
        /// The order.
        order: Order,
        /// The answer.
        reply: Reply,
    },
    /// [`NordClient::drive_to`] did not reach the state.
    StateNotReached {
        /// The state wanted.
        target: State,
        /// The state the drive is in.
        current: State,
        /// The last status word.
        status: StatusWord,
    },
}

impl<E: fmt::Display> fmt::Display for ClientError<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ClientError::Transport(e) => write!(f, "{e}"),
            ClientError::Drive { order, error } => write!(
                f,
                "the drive refused AK {} for P{}: {error}",
                order.ak(),
                order.pnu()
            ),
            ClientError::NoPlausibleAnswer { order, polls, last } => write!(
                f,
                "no answer to AK {} for P{} after {polls} requests (the drive kept answering \
                 AK {}, P{}, IND {:#06x})",
                order.ak(),
                order.pnu(),
                last.pke.ak(),
                last.pke.pnu(),
                last.ind.0
            ),
            ClientError::Pkw(e) => write!(f, "{e}"),
            ClientError::UnexpectedReply { order, reply } => {
                write!(
                    f,
                    "unexpected answer {reply:?} to AK {} for P{}",
                    order.ak(),
                    order.pnu()
                )
            }
            ClientError::StateNotReached {
                target,
                current,
                status,
            } => write!(
                f,
                "the drive did not reach {target:?}: it is in {current:?} (status word {:#06x})",
                status.0
            ),
        }
    }
}

impl<E: std::error::Error + 'static> std::error::Error for ClientError<E> {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            ClientError::Transport(e) => Some(e),
            ClientError::Pkw(e) => Some(e),
            _ => None,
        }
    }
}

impl<E> From<PkwError> for ClientError<E> {
    fn from(e: PkwError) -> Self {
        ClientError::Pkw(e)
    }
}

/// Which value of a parameter: array element (0-based) and parameter set (0-based).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Address {
    /// The parameter number.
    pub pnu: u16,
    /// The array element (0 = [-01]); `None` for a parameter that is no array (AK 1/2/3/13/14
    /// instead of 6/7/8/11/12).
    pub element: Option<u8>,
    /// The parameter set, 0 = set 1.
    pub set: u8,
}

impl Address {
    /// Parameter `pnu`, no array element, parameter set 1.
    pub const fn new(pnu: u16) -> Address {
        Address {
            pnu,
            element: None,
            set: 0,
        }
    }

    /// The IND word, laid out as the table says the parameter needs ([`IndLayout::of_pnu`]:
    /// element in bits 10–15 and set in bits 8–9 for a parameter with parameter sets, else the
    /// element as the sub-index in bits 8–15).
    pub fn ind(&self) -> Result<Ind, PkwError> {
        let element = self.element.unwrap_or(0);
        Ind::address(IndLayout::of_pnu(self.pnu), element, self.set).ok_or(PkwError::BadIndex {
            element,
            set: self.set,
        })
    }
}

/// The shared master logic over one transport (see the [module docs](self)).
#[derive(Debug)]
pub struct NordClient<C> {
    channel: C,
    config: ClientConfig,
    last_order: Option<Pkw>,
    last_control: u16,
    polls: u64,
}

impl<C> NordClient<C> {
    /// A client over `channel`.
    pub fn new(channel: C, config: ClientConfig) -> Self {
        Self {
            channel,
            config,
            last_order: None,
            last_control: 0,
            polls: 0,
        }
    }

    /// The transport.
    pub fn channel(&self) -> &C {
        &self.channel
    }

    /// The transport, mutable.
    pub fn channel_mut(&mut self) -> &mut C {
        &mut self.channel
    }

    /// The transport back.
    pub fn into_inner(self) -> C {
        self.channel
    }

    /// Requests made again because an answer was not (yet) plausible, since the start.
    pub fn repeated_requests(&self) -> u64 {
        self.polls
    }

    /// The control word sent last (0 before the first).
    pub fn last_control(&self) -> u16 {
        self.last_control
    }
}

impl<C: ParameterChannel> NordClient<C> {
    /// Run one order to its plausible answer.
    pub async fn order(&mut self, order: Order) -> Result<Reply, ClientError<C::Error>> {
        let pkw = order.to_pkw();
        let separate = match self.last_order {
            // What the drive answers now is unknown: maybe an earlier session's order on the
            // same PNU and IND.
            None => true,
            Some(last) => {
                last.pke.ak() != 0 && last.pke.pnu() == pkw.pke.pnu() && last.ind == pkw.ind
            }
        };
        if separate && order.ak() != 0 {
            // The previous answer (an AK 7 fits every order, a write's echo fits a read) could
            // pass the check for this order, so make the drive answer "no order" in between
            // (erratum E21).
            Box::pin(self.order(Order::none())).await?;
        }
        self.last_order = Some(pkw);
        let mut answer = self
            .channel
            .submit(pkw)
            .await
            .map_err(ClientError::Transport)?;
        let mut polls = 1u16;
        loop {
            match order.check(&answer) {
                Plausibility::Answer(Reply::Error(error)) => {
                    return Err(ClientError::Drive { order, error });
                }
                Plausibility::Answer(reply) => return Ok(reply),
                Plausibility::Invalid(e) => return Err(ClientError::Pkw(e)),
                Plausibility::Other => {}
            }
            if polls > self.config.max_polls {
                return Err(ClientError::NoPlausibleAnswer {
                    order,
                    polls,
                    last: answer,
                });
            }
            polls += 1;
            self.polls += 1;
            answer = self
                .channel
                .poll(pkw)
                .await
                .map_err(ClientError::Transport)?;
        }
    }

    /// Read a value (AK 1, or AK 6 for an array element). Returns the value and whether it came
    /// as a double word.
    pub async fn read_value(&mut self, at: Address) -> Result<(i32, Width), ClientError<C::Error>> {
        let ind = at.ind()?;
        let order = match at.element {
            Some(_) => Order::read_array(at.pnu, ind)?,
            None => Order::read(at.pnu, ind)?,
        };
        match self.order(order).await? {
            Reply::Value { value, width, .. } => Ok((value, width)),
            reply => Err(ClientError::UnexpectedReply { order, reply }),
        }
    }

    /// Read a value (see [`NordClient::read_value`]).
    pub async fn read(&mut self, at: Address) -> Result<i32, ClientError<C::Error>> {
        Ok(self.read_value(at).await?.0)
    }

    /// Write `value` as a word or double word, to EEPROM (as P560 says) or RAM only.
    pub async fn write(
        &mut self,
        at: Address,
        width: Width,
        storage: Storage,
        value: i64,
    ) -> Result<(), ClientError<C::Error>> {
        let order = Order::write(
            at.pnu,
            at.ind()?,
            width,
            at.element.is_some(),
            storage,
            value,
        )?;
        match self.order(order).await? {
            Reply::Value { .. } => Ok(()),
            reply => Err(ClientError::UnexpectedReply { order, reply }),
        }
    }

    /// The number of array elements of `pnu` (AK 9).
    pub async fn count(&mut self, pnu: u16) -> Result<u16, ClientError<C::Error>> {
        let order = Order::count(pnu, Ind::ZERO)?;
        match self.order(order).await? {
            Reply::Count(n) => Ok(n),
            reply => Err(ClientError::UnexpectedReply { order, reply }),
        }
    }
}

impl<C: ProcessChannel> NordClient<C> {
    /// One process-data exchange: control word, setpoints, and `actuals` actual values back.
    pub async fn process(
        &mut self,
        control: ControlWord,
        setpoints: &[u16],
        actuals: u8,
    ) -> Result<PzdIn, ClientError<C::Error>> {
        let answer = self
            .channel
            .exchange_process(PzdOut::new(control, setpoints), actuals)
            .await
            .map_err(ClientError::Transport)?;
        self.last_control = control.0;
        Ok(answer)
    }

    /// Move the drive to `target` through the state machine of section 4.5.3, sending
    /// `setpoints` with every control word (and as many actual values back, at most three);
    /// `set` selects the parameter set (0-based, bits 14/15; above 3 it is refused before
    /// anything is sent). Returns the last answer once the status word shows `target`. A fault
    /// is reset with a rising edge of bit 7 ([`NordStateMachine::next_control`]).
    pub async fn drive_to(
        &mut self,
        target: State,
        setpoints: &[u16],
        set: u8,
    ) -> Result<PzdIn, ClientError<C::Error>> {
        if set > 3 {
            // Bits 14/15 carry parameter sets 1–4 only.
            return Err(ClientError::Pkw(PkwError::BadIndex { element: 0, set }));
        }
        let with_set = |w: u16| {
            ControlWord(w)
                .with_parameter_set(set + 1)
                .unwrap_or(ControlWord(w))
        };
        // As many actual values back as setpoints go out (at most three).
        let actuals = setpoints.len().min(crate::uss::pzd::MAX_VALUES) as u8;
        // The first exchange only reads the state: keep the drive where it is if we know what
        // was sent, else send "disable voltage" only if the drive is in no state we can hold.
        let mut last = self.last_control;
        let mut answer = self
            .process(with_set(hold_word(last)), setpoints, actuals)
            .await?;
        for _ in 0..self.config.max_steps {
            let current = NordStateMachine::decode(answer.status().0);
            if current == target {
                return Ok(answer);
            }
            let Some(word) = NordStateMachine::next_control(last, current, target) else {
                break;
            };
            last = word;
            answer = self.process(with_set(word), setpoints, actuals).await?;
        }
        let status = answer.status();
        Err(ClientError::StateNotReached {
            target,
            current: NordStateMachine::decode(status.0),
            status,
        })
    }
}

/// The control word that keeps a drive where `last` put it; with nothing sent yet, a word that
/// changes nothing in switch-on disabled (disable voltage, 0400h).
fn hold_word(last: u16) -> u16 {
    if last & ControlWord::CONTROL_DATA_VALID.0 != 0 {
        last & !ControlWord::FAULT_RESET.0
    } else {
        drive_profile::nord::command::DISABLE_VOLTAGE.0
    }
}
