//! `bonfiglioli-modbus`: Modbus RTU and ASCII with Bonfiglioli's function codes 100/101 for
//! ACTIVE and ACTIVE Cube drives, sans-IO.
//!
//! * [`frame`]: addresses, the start address (data set | parameter number), requests and
//!   responses with their function codes, exception codes and diagnostic sub-functions;
//! * [`pdu`]: the PDU codec (function code and data);
//! * [`rtu`] and [`ascii`]: the two transmission modes (CRC-16 and binary, LRC and hex text),
//!   their times from the real line settings, whole-frame encode and decode;
//! * [`framing`]: one framing description for both modes and both sides
//!   ([`ModbusFraming`]) on drive-core's character receiver ([`Receiver`]), the
//!   received frames ([`Received`]), whole-frame [`encode_request`], [`encode_response`] and
//!   [`decode_frame`], and [`FrameError`].
//!
//! It builds on [`drive_core`] (time, line timing, the character
//! [`Receiver`](drive_core::Receiver) a framing description plugs into, the
//! [`Endpoint`](drive_core::Endpoint) interface and the transaction skeleton) and on
//! [`drive_profile::bonfiglioli`] (the parameter table, Modbus exceptions, VABus errors,
//! control/status words and state machines).
//!
//! Features: `std` (default), `tokio` (`driver`: the async master `ModbusDriver` on
//! drive-core's runtime layer), `sim` (`sim`: simulated ACT/ACU drives on drive-sim's model).
//! What a program needs is at the root: [`Address`], [`DataSet`], [`Width`], [`Mode`]; with
//! `tokio`, `ModbusDriver`, `DriverConfig` and `DriverError`; with `sim`, `SimulatedDrive`.
//! `examples/bonfiglioli_read_param.rs` reads parameter 372 from a simulated drive in a dozen
//! lines (`cargo run -p bonfiglioli-modbus --example bonfiglioli_read_param`).
//!
//! Like every protocol crate of drivebus it is sans-IO (no I/O, no clock: time is an argument)
//! and `no_std` without its default `std` feature.
//!
//! ```
//! use bonfiglioli_modbus::frame::{DataSet, Request, StartAddress};
//!
//! // Read parameter 372 in data set 2 (the manual's ch. 8.1.1).
//! let start = StartAddress::new(DataSet::new(2).unwrap(), 372).unwrap();
//! let mut pdu = [0u8; 5];
//! let n = Request::ReadWord { start, count: 1 }.encode(&mut pdu).unwrap();
//! assert_eq!(&pdu[..n], [0x03, 0x21, 0x74, 0x00, 0x01]);
//! ```
#![cfg_attr(not(feature = "std"), no_std)]
#![cfg_attr(docsrs, feature(doc_cfg))]
#![warn(missing_docs)]

pub mod ascii;
#[cfg(feature = "tokio")]
#[cfg_attr(docsrs, doc(cfg(feature = "tokio")))]
pub mod driver;
pub mod frame;
pub mod framing;
pub mod master;
pub mod pdu;
pub mod rtu;
#[cfg(feature = "sim")]
#[cfg_attr(docsrs, doc(cfg(feature = "sim")))]
pub mod sim;
pub mod slave;

pub use frame::{Address, DataSet, StartAddress};
pub use slave::Width;

#[cfg(feature = "tokio")]
#[cfg_attr(docsrs, doc(cfg(feature = "tokio")))]
pub use driver::{DriverConfig, DriverError, ModbusDriver};
#[cfg(feature = "sim")]
#[cfg_attr(docsrs, doc(cfg(feature = "sim")))]
pub use sim::SimulatedDrive;

pub use framing::{
    FrameError, MAX_FRAME, ModbusFraming, Mode, Received, Receiver, RxEvent, Side, decode_frame,
    encode_request, encode_response,
};
