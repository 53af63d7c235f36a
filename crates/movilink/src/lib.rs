//! `movilink`: the SEW MOVILINK protocol (RS-485/RS-232, 9600 8E1) for MOVIDRIVE and
//! MOVIMOT drives, sans-IO.
//!
//! Layers, bottom up:
//!
//! * [`frame`]: plain data types: [`Address`], [`PduType`], [`ParamChannel`] (with
//!   [`Management`], [`Service`]) and [`Telegram`];
//! * [`codec`]: [`encode`] / [`decode`] of whole telegrams
//!   (`SD ADR TYP PDU BCC`) into and from byte slices, without allocation;
//! * [`timing`]: the protocol times, computed from the real line settings ([`LineTiming`]);
//!   time is always an argument ([`Instant`], drivebus's one time type), the crate never reads
//!   a clock;
//! * [`receiver`]: MOVILINK's framing description ([`TelegramFraming`]) on the shared character
//!   receiver of `drive-core`, every receive error of the manual as a [`RejectReason`];
//! * [`master`] and [`slave`]: state machines in the quinn-proto style (`send`/`handle_char`/
//!   `handle_timeout` in, `poll_transmit(now, …)`/`poll_timeout`/`poll_event` out); the master
//!   is `drive-core`'s one master ([`drive_core::master::Master`]) with MOVILINK's checks, both are
//!   [`drive_core::Endpoint`]s.
//!
//! The parameter channel, its services and return codes are SEW's, shared with SBus and the
//! simulated drive: they live in [`drive_profile::sew`] and are re-exported here.
//!
//! Device errors (a drive's negative answer, [`ReturnCode`]) are separate from transport errors
//! ([`DecodeError`], [`RejectReason`], [`MasterEvent::Timeout`]).
//!
//! The crate is `no_std` without its default `std` feature, and nothing allocates.
//!
//! Optional layers on top:
//!
//! * `tokio`: `driver`, the async master (`MovilinkDriver`, drive-core's runtime driver) over
//!   any `CharIo` of the runtime layer (the in-memory wire model of `drive-transport`, serial
//!   ports, ptys), with the SEW parameter services of `drive_profile::sew::ParamServices`;
//! * `sim`: `sim`, simulated MOVIDRIVE drives answering on a `CharIo`.
//!
//! ```
//! use movilink::{codec, Address, ParamChannel, PduType, Telegram};
//!
//! // Read P131 "ramp t11 down CW" (index 8471 = 0x2117) from drive 1 with an acyclic PARAM + 0PD telegram.
//! let req = Telegram::request(Address::new(1).unwrap(), PduType::PARAM_0PD_ACYCLIC)
//!     .with_param(ParamChannel::read(8471));
//! let mut buf = [0u8; movilink::MAX_TELEGRAM_LEN];
//! let n = codec::encode(&req, &mut buf).unwrap();
//! assert_eq!(&buf[..n], &[0x02, 0x01, 0x86, 0x31, 0x00, 0x21, 0x17, 0, 0, 0, 0, 0x82]);
//!
//! // The drive's answer: value 3000 (3 s).
//! let answer = [0x1D, 0x01, 0x86, 0x31, 0x00, 0x21, 0x17, 0x00, 0x00, 0x0B, 0xB8, 0x2E];
//! let (resp, _) = codec::decode(&answer).unwrap();
//! assert_eq!(resp.param().unwrap().result(), Ok(3000));
//! ```
#![cfg_attr(not(feature = "std"), no_std)]
#![warn(missing_docs)]

pub mod codec;
#[cfg(feature = "tokio")]
pub mod driver;
pub mod error;
pub mod frame;
pub mod master;
pub mod receiver;
#[cfg(feature = "sim")]
pub mod sim;
pub mod slave;
pub mod timing;

pub use codec::{decode, encode};
pub use error::{CharError, DecodeError, EncodeError, ErrorClass, RejectReason, ReturnCode};
pub use frame::{
    Address, AddressKind, AttributeInfo, DataLength, Direction, MAX_TELEGRAM_LEN, MIN_TELEGRAM_LEN,
    Management, ParamChannel, PduType, SD1, SD2, ScaleInfo, Service, Telegram,
};
pub use master::{MasterConfig, MasterEvent, MovilinkMaster, SendError};
pub use receiver::{AddressFilter, Receiver, RxChar, RxEvent, TelegramFraming};
pub use slave::{Backend, RequestContext, Slave, SlaveConfig, SlaveEvent};
pub use timing::{Instant, LineTiming, TxGate};
