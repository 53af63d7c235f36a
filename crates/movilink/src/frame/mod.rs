//! Plain data types of a MOVILINK telegram, one file per part.
//!
//! * [`address`]: the address byte ([`Address`]),
//! * [`pdu`]: the PDU type byte ([`PduType`]),
//! * the 8-byte parameter channel ([`ParamChannel`], [`Management`], [`Service`]): SEW's, shared
//!   with SBus, from [`drive_profile::sew`],
//! * [`telegram`]: the whole telegram ([`Telegram`], [`Direction`]).

pub mod address;
pub mod pdu;
pub mod telegram;

pub use address::{Address, AddressKind};
pub use drive_profile::sew::{
    AttributeInfo, DataLength, Management, ParamChannel, ScaleInfo, Service,
};
pub use pdu::PduType;
pub use telegram::{Direction, MAX_TELEGRAM_LEN, MIN_TELEGRAM_LEN, SD1, SD2, Telegram};
