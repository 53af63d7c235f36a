//! Plain data types of a MOVILINK telegram, one file per part.
//!
//! * [`address`]: the address byte ([`Address`]),
//! * [`pdu`]: the PDU type byte ([`PduType`]),
//! * [`param`]: the 8-byte parameter channel ([`ParamChannel`], [`Management`], [`Service`]),
//! * [`telegram`]: the whole telegram ([`Telegram`], [`Direction`]).

pub mod address;
pub mod param;
pub mod pdu;
pub mod telegram;

pub use address::{Address, AddressKind};
pub use param::{AttributeInfo, DataLength, Management, ParamChannel, ScaleInfo, Service};
pub use pdu::PduType;
pub use telegram::{Direction, MAX_TELEGRAM_LEN, MIN_TELEGRAM_LEN, SD1, SD2, Telegram};
