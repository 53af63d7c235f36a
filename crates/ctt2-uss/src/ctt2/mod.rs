//! CTT2 over AS-Interface (BU 0255 chapters 3 and 4): the messages an AS-i master exchanges
//! with the 2nd slave of a NORDAC LINK's double slave, the objects and channels they carry,
//! the double slave itself (sans-IO), the AS-i side (addresses, BusIO bits, transfer times),
//! and, with feature `tokio`, a master over any AS-i master's command interface.
//!
//! * [`message`]: [`Request`] and [`Response`] with their codes (16/18/19/29, 80/82/83/93,
//!   144/146/147/157 and the misprinted 177), indices, length rules and error codes 1–5.
//! * [`object`]: the [`IdObject`], the [`DiagnosisObject`], and USS PKW/PZD in channel data
//!   with the drive address.
//! * [`slave`]: the [`DoubleSlave`] state machine over a [`Backend`].
//! * [`asi`]: [`AsiAddress`] ("5A"), [`Profile`], BusIO bits, an in-memory [`AsiNetwork`] and
//!   the transfer-time model.
//! * `master` (feature `tokio`): the `Ctt2Link` trait a user implements for an AS-i master and
//!   the `Ctt2Driver` on it, which is a `ParameterChannel` and `ProcessChannel` for the shared
//!   `client::NordClient`.
//! * `link` (feature `sim`): an in-memory AS-i link to a simulated drive.
//!
//! ```
//! use ctt2_uss::ctt2::{Channel, Data, Request, Response};
//! use ctt2_uss::uss::{Ind, Order};
//!
//! // P102 in parameter set 3 := 1000 (10.00 s), the order of example 5.1.3, as a NORD write
//! // on the parameter channel without address.
//! let order = Order::write(0x66, Ind::new(0, 2).unwrap(), drive_profile::nord::Width::Word,
//!                          true, ctt2_uss::uss::Storage::Eeprom, 1000).unwrap();
//! let request = Request::NordWrite {
//!     index: Channel::Pkw,
//!     data: Data::from_pkw(Channel::Pkw, &order.to_pkw()).unwrap(),
//! };
//! let mut buf = [0u8; 16];
//! let n = request.encode(&mut buf).unwrap();
//! assert_eq!(&buf[..n], &[19, 47, 8, 0x70, 0x66, 0x02, 0x00, 0x00, 0x00, 0x03, 0xE8]);
//! assert_eq!(Request::decode(&buf[..n]), Ok(request));
//! assert!(matches!(Response::decode(&[83]), Ok(Response::Ok { .. })));
//! ```

pub mod asi;
#[cfg(feature = "sim")]
pub mod link;
#[cfg(feature = "tokio")]
pub mod master;
pub mod message;
pub mod object;
pub mod slave;

pub use asi::{
    AsiAddress, AsiNetwork, Bank, BusIoIn, BusIoOut, DoubleSlaveAddress, DoubleSlaveId,
    NetworkError, Profile, SlaveAddress,
};
pub use message::{
    Channel, DRIVE_ADDRESS, Data, DecodeError, EncodeError, ErrorCode, MAX_DATA, MAX_REQUEST,
    MAX_RESPONSE, Request, Response, StandardIndex,
};
pub use object::{DiagnosisCode, DiagnosisObject, IdObject, ObjectError};
pub use slave::{ANSWER_WINDOW, Backend, DoubleSlave, SlaveConfig, SlaveCounters};
