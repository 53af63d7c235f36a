//! The CTT2 driver (feature `tokio`): requests to the double slave over a [`Ctt2Link`], the
//! one thing a user implements for the command interface of an AS-i master (one request in,
//! one answer out).
//!
//! [`Ctt2Driver`] reads the ID and diagnosis objects, writes and reads process data, and is a
//! [`ParameterChannel`] and a [`ProcessChannel`], so [`NordClient`](crate::client::NordClient)
//! runs on it:
//!
//! * `submit` writes the order to the parameter channel (NORD write, index 47 by default or 4
//!   with address, [`DriverConfig::pkw_channel`]) and then reads the channel back (NORD read),
//!   because the answer to the write says nothing about the order (section 4.3.3); `poll` reads
//!   the channel again. The client's plausibility check does the rest: the drive returns the
//!   previous answer until the new order is done.
//! * `exchange_process` is one NORD write/read on the PZD channel.
//!
//! A negative CTT2 answer is a [`DriverError::Device`], with the error code. Errors **4**
//! (busy: not done within 200 ms) and **5** (previous request not yet answered) say that the
//! request was not carried out and that it may succeed later, so the driver repeats the request
//! after [`DriverConfig::retry_pause`] (one answer window by default: long enough for a
//! previous request to finish) up to [`DriverConfig::retries`] times, then reports the error.
//! Errors 1–3 are repeated never: the same request would fail again.

use core::future::Future;
use core::time::Duration;
use drive_core::LinkFault;

use drive_profile::nord::Ctt2MessageType;

use super::message::{
    Channel, Data, DecodeError, EncodeError, ErrorCode, MAX_REQUEST, MAX_RESPONSE, Request,
    Response, StandardIndex,
};
use super::object::{DIAGNOSIS_OBJECT_LEN, DiagnosisObject, ID_OBJECT_LEN, IdObject, ObjectError};
use super::slave::ANSWER_WINDOW;
use crate::client::{ParameterChannel, ProcessChannel};
use crate::uss::pkw::{PKW_LEN, Pkw};
use crate::uss::pzd::{PzdIn, PzdOut};

/// One CTT2 exchange through an AS-i master: implement it on your AS-i master's API (for
/// example a gateway's "CTT2 command" call or a PLC function block).
pub trait Ctt2Link {
    /// What can go wrong on the link (I/O, the AS-i master's own errors, a timeout).
    type Error: std::error::Error + Send + Sync + 'static;

    /// Send `request` (a whole CTT2 request, code first) to the 2nd slave and write its whole
    /// answer (code first) into `answer` ([`MAX_RESPONSE`] bytes are always enough); return the
    /// answer's length.
    fn transact(
        &mut self,
        request: &[u8],
        answer: &mut [u8],
    ) -> impl Future<Output = Result<usize, Self::Error>>;
}

/// Settings of a [`Ctt2Driver`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DriverConfig {
    /// The parameter channel: [`Channel::Pkw`] (index 47, without address, the default) or
    /// [`Channel::PkwWithAddress`] (index 4).
    pub pkw_channel: Channel,
    /// How often a request answered with error 4 or 5 is repeated.
    pub retries: u8,
    /// The pause before such a repetition.
    pub retry_pause: Duration,
}

impl Default for DriverConfig {
    fn default() -> Self {
        Self {
            pkw_channel: Channel::Pkw,
            retries: 3,
            retry_pause: ANSWER_WINDOW,
        }
    }
}

/// Why a CTT2 exchange failed: the double slave refused ([`DriverError::Device`]), the link
/// or the answer failed ([`DriverError::Link`]), or the request cannot be made
/// ([`DriverError::Request`]).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DriverError<E: std::error::Error + 'static> {
    /// The double slave answered "not OK" (after `attempts` tries for errors 4 and 5).
    #[error(
        "the double slave refused the {request:?} request with {error} (after {attempts} attempts)"
    )]
    Device {
        /// The request's type.
        request: Ctt2MessageType,
        /// The error code.
        error: ErrorCode,
        /// Requests sent.
        attempts: u8,
    },
    /// The link failed, or its answer is not one.
    #[error(transparent)]
    Link(LinkError<E>),
    /// The request cannot be made; nothing was sent.
    #[error(transparent)]
    Request(RequestError),
}

/// How the link or its answer failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum LinkError<E: std::error::Error + 'static> {
    /// The link failed.
    #[error("AS-i link: {0}")]
    Transport(#[source] E),
    /// The answer cannot be decoded.
    #[error("undecodable answer: {0}")]
    Decode(#[source] DecodeError),
    /// An answer to another message type.
    #[error("answer {answer:?} to a {request:?} request")]
    UnexpectedAnswer {
        /// The request's type.
        request: Ctt2MessageType,
        /// The answer received.
        answer: Response,
    },
    /// The answer's data are not the object or channel asked for.
    #[error("answer data: {0}")]
    Object(#[source] ObjectError),
}

impl<E: std::error::Error + 'static> LinkError<E> {
    /// What kind of link failure this is.
    pub fn fault(&self) -> LinkFault {
        match self {
            LinkError::Transport(_) => LinkFault::Port,
            LinkError::Decode(_) | LinkError::Object(_) => LinkFault::Garbled,
            LinkError::UnexpectedAnswer { .. } => LinkFault::Unexpected,
        }
    }
}

/// Why a request cannot be made.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum RequestError {
    /// The request cannot be encoded.
    #[error("request cannot be encoded: {0}")]
    Encode(#[source] EncodeError),
    /// The order does not fit the channel's data.
    #[error("answer data: {0}")]
    Object(#[source] ObjectError),
}

impl<E: std::error::Error + 'static> DriverError<E> {
    fn link(e: LinkError<E>) -> Self {
        DriverError::Link(e)
    }

    fn object(e: ObjectError) -> Self {
        DriverError::Link(LinkError::Object(e))
    }
}

/// Counters of a [`Ctt2Driver`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct DriverCounters {
    /// Requests sent (repetitions included).
    pub requests: u64,
    /// Repetitions after error 4 or 5.
    pub retries: u64,
}

/// A CTT2 driver over a [`Ctt2Link`] (see the [module docs](self)).
#[derive(Debug)]
pub struct Ctt2Driver<L> {
    link: L,
    config: DriverConfig,
    counters: DriverCounters,
}

impl<L> Ctt2Driver<L> {
    /// A driver over `link`.
    pub fn new(link: L, config: DriverConfig) -> Self {
        Self {
            link,
            config,
            counters: DriverCounters::default(),
        }
    }

    /// The link.
    pub fn link(&self) -> &L {
        &self.link
    }

    /// The link, mutable.
    pub fn link_mut(&mut self) -> &mut L {
        &mut self.link
    }

    /// The link back.
    pub fn into_inner(self) -> L {
        self.link
    }

    /// The settings.
    pub fn config(&self) -> &DriverConfig {
        &self.config
    }

    /// The counters.
    pub fn counters(&self) -> &DriverCounters {
        &self.counters
    }
}

impl<L: Ctt2Link> Ctt2Driver<L> {
    /// Send `request` and return the data of its positive answer, repeating after error 4 or 5.
    pub async fn request(&mut self, request: &Request) -> Result<Data, DriverError<L::Error>> {
        let mut buf = [0u8; MAX_REQUEST];
        let n = request
            .encode(&mut buf)
            .map_err(|e| DriverError::Request(RequestError::Encode(e)))?;
        let bytes = buf.get(..n).unwrap_or(&[]);
        let mut attempts = 0u8;
        loop {
            attempts = attempts.saturating_add(1);
            self.counters.requests += 1;
            let mut answer = [0u8; MAX_RESPONSE + 1];
            let len = self
                .link
                .transact(bytes, &mut answer)
                .await
                .map_err(|e| DriverError::link(LinkError::Transport(e)))?;
            let answer = Response::decode(answer.get(..len).unwrap_or(&answer))
                .map_err(|e| DriverError::link(LinkError::Decode(e)))?;
            if answer.kind() != request.kind() {
                return Err(DriverError::link(LinkError::UnexpectedAnswer {
                    request: request.kind(),
                    answer,
                }));
            }
            match answer {
                Response::Ok { data, .. } => return Ok(data),
                Response::Error { error, .. } => {
                    let transient = matches!(error, ErrorCode::Busy | ErrorCode::PreviousPending);
                    if !transient || attempts > self.config.retries {
                        return Err(DriverError::Device {
                            request: request.kind(),
                            error,
                            attempts,
                        });
                    }
                    self.counters.retries += 1;
                    drive_core::rt::time::sleep(self.config.retry_pause).await;
                }
            }
        }
    }

    /// Read the first `len` bytes of the ID object (14: all of it).
    pub async fn read_id(&mut self, len: u8) -> Result<IdObject, DriverError<L::Error>> {
        let data = self
            .request(&Request::StandardRead {
                index: StandardIndex::Id,
                len,
            })
            .await?;
        IdObject::decode(data.as_slice()).map_err(DriverError::object)
    }

    /// Read the whole ID object.
    pub async fn read_id_object(&mut self) -> Result<IdObject, DriverError<L::Error>> {
        self.read_id(ID_OBJECT_LEN as u8).await
    }

    /// Read the diagnosis object.
    pub async fn read_diagnosis(&mut self) -> Result<DiagnosisObject, DriverError<L::Error>> {
        let data = self
            .request(&Request::StandardRead {
                index: StandardIndex::Diagnosis,
                len: DIAGNOSIS_OBJECT_LEN as u8,
            })
            .await?;
        DiagnosisObject::decode(data.as_slice()).map_err(DriverError::object)
    }

    /// Write control word and setpoints (NORD write on the PZD channel).
    pub async fn write_pzd(&mut self, out: &PzdOut) -> Result<(), DriverError<L::Error>> {
        self.request(&Request::NordWrite {
            index: Channel::Pzd,
            data: Data::from_pzd_out(out),
        })
        .await?;
        Ok(())
    }

    /// Read the status word and `actuals` actual values (0–3; NORD read on the PZD channel).
    pub async fn read_pzd(&mut self, actuals: u8) -> Result<PzdIn, DriverError<L::Error>> {
        let data = self
            .request(&Request::NordRead {
                index: Channel::Pzd,
                len: pzd_len(actuals),
            })
            .await?;
        data.to_pzd_in().map_err(DriverError::object)
    }

    /// Write control word and setpoints and read the status word and `actuals` actual values
    /// in one message (NORD write/read on the PZD channel).
    pub async fn write_read_pzd(
        &mut self,
        out: &PzdOut,
        actuals: u8,
    ) -> Result<PzdIn, DriverError<L::Error>> {
        let data = self
            .request(&Request::NordWriteRead {
                index: Channel::Pzd,
                read_len: pzd_len(actuals),
                data: Data::from_pzd_out(out),
            })
            .await?;
        data.to_pzd_in().map_err(DriverError::object)
    }

    /// Hand a parameter order to the drive (NORD write on the parameter channel). The positive
    /// answer says nothing about the order: read the channel back ([`Ctt2Driver::read_pkw`]).
    pub async fn write_pkw(&mut self, pkw: &Pkw) -> Result<(), DriverError<L::Error>> {
        let index = self.config.pkw_channel;
        let data = Data::from_pkw(index, pkw)
            .map_err(|e| DriverError::Request(RequestError::Object(e)))?;
        self.request(&Request::NordWrite { index, data }).await?;
        Ok(())
    }

    /// Read the parameter channel: the answer to the last order the drive has finished.
    pub async fn read_pkw(&mut self) -> Result<Pkw, DriverError<L::Error>> {
        let index = self.config.pkw_channel;
        let len = PKW_LEN as u8 + u8::from(index.has_address());
        let data = self.request(&Request::NordRead { index, len }).await?;
        data.to_pkw(index).map_err(DriverError::object)
    }
}

/// Bytes of a PZD read with `actuals` actual values: address, ZSW and 2 per value.
fn pzd_len(actuals: u8) -> u8 {
    3 + 2 * actuals.min(3)
}

impl<L: Ctt2Link> ParameterChannel for Ctt2Driver<L> {
    type Error = DriverError<L::Error>;

    fn link_fault(error: &Self::Error) -> Option<LinkFault> {
        match error {
            DriverError::Link(l) => Some(l.fault()),
            // The double slave refused the CTT2 request: the AS-i side, not the drive's PKW.
            DriverError::Device { .. } => Some(LinkFault::Unexpected),
            DriverError::Request(_) => None,
        }
    }

    async fn submit(&mut self, order: Pkw) -> Result<Pkw, Self::Error> {
        self.write_pkw(&order).await?;
        self.read_pkw().await
    }

    async fn poll(&mut self, order: Pkw) -> Result<Pkw, Self::Error> {
        let _ = order;
        self.read_pkw().await
    }
}

impl<L: Ctt2Link> ProcessChannel for Ctt2Driver<L> {
    type Error = DriverError<L::Error>;

    fn link_fault(error: &Self::Error) -> Option<LinkFault> {
        <Self as ParameterChannel>::link_fault(error)
    }

    async fn exchange_process(&mut self, out: PzdOut, actuals: u8) -> Result<PzdIn, Self::Error> {
        self.write_read_pzd(&out, actuals).await
    }
}
