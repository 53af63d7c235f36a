//! The Modbus frame of the Bonfiglioli manual (ch. 6): slave address, function code and data,
//! as plain types. The PDU codec (function code + data) is in [`pdu`](crate::pdu); RTU and
//! ASCII add the address and their check ([`rtu`](crate::rtu), [`ascii`](crate::ascii)).

mod address;
mod pdu_types;

pub use address::{Address, DataSet, StartAddress};
pub use pdu_types::{DiagSubFunction, ExceptionCode, FunctionCode, Request, Response};
