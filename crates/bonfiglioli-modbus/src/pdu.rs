//! The PDU codec: function code and data, without address and check (ch. 6.4). Multi-byte
//! fields are big-endian. Nothing allocates; no input makes a decoder panic.

use crate::frame::{DiagSubFunction, ExceptionCode, FunctionCode, Request, Response, StartAddress};

/// The longest PDU (256-byte RTU frame minus address and CRC).
pub const MAX_PDU: usize = 253;

/// Why a PDU could not be decoded, with the exception a drive answers for it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, thiserror::Error)]
#[non_exhaustive]
pub enum PduError {
    /// No bytes at all.
    #[error("empty PDU")]
    Empty,
    /// A function code the drive does not support.
    #[error("function code {0} is not supported (3, 6, 8, 100, 101)")]
    UnknownFunction(u8),
    /// The length does not fit the function code.
    #[error("function code {function}: {got} bytes, expected {expected}")]
    Length {
        /// The function code (bit 7 set for an exception).
        function: u8,
        /// The length the function code has.
        expected: usize,
        /// The length that arrived.
        got: usize,
    },
    /// A read response whose byte count is not 2 (FC 3).
    #[error("byte count {0}, expected 2 (one 16-bit register)")]
    ByteCount(u8),
}

impl PduError {
    /// The exception a drive answers a request with this error (ch. 6.6).
    pub const fn exception(self) -> ExceptionCode {
        match self {
            PduError::UnknownFunction(_) => ExceptionCode::ILLEGAL_FUNCTION,
            _ => ExceptionCode::ILLEGAL_DATA_VALUE,
        }
    }
}

/// The output buffer is too small.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, thiserror::Error)]
#[error("output buffer too small: {needed} bytes needed")]
pub struct BufferTooSmall {
    /// Bytes needed.
    pub needed: usize,
}

fn be16(b: &[u8], at: usize) -> u16 {
    match (b.get(at), b.get(at + 1)) {
        (Some(&h), Some(&l)) => u16::from_be_bytes([h, l]),
        _ => 0,
    }
}

fn be32(b: &[u8], at: usize) -> u32 {
    (u32::from(be16(b, at)) << 16) | u32::from(be16(b, at + 2))
}

fn put(out: &mut [u8], bytes: &[u8]) -> Result<usize, BufferTooSmall> {
    let dst = out.get_mut(..bytes.len()).ok_or(BufferTooSmall {
        needed: bytes.len(),
    })?;
    dst.copy_from_slice(bytes);
    Ok(bytes.len())
}

fn exact(pdu: &[u8], function: u8, expected: usize) -> Result<(), PduError> {
    if pdu.len() == expected {
        Ok(())
    } else {
        Err(PduError::Length {
            function,
            expected,
            got: pdu.len(),
        })
    }
}

impl Request {
    /// Encode into `out`; the number of bytes written (5 or 7).
    pub fn encode(&self, out: &mut [u8]) -> Result<usize, BufferTooSmall> {
        let fc = self.function().code();
        match *self {
            Request::ReadWord { start, count } => {
                let [a, b] = start.raw().to_be_bytes();
                let [c, d] = count.to_be_bytes();
                put(out, &[fc, a, b, c, d])
            }
            Request::WriteWord { start, value } => {
                let [a, b] = start.raw().to_be_bytes();
                let [c, d] = value.to_be_bytes();
                put(out, &[fc, a, b, c, d])
            }
            Request::ReadLong { start } => {
                let [a, b] = start.raw().to_be_bytes();
                put(out, &[fc, a, b])
            }
            Request::WriteLong { start, value } => {
                let [a, b] = start.raw().to_be_bytes();
                let [c, d, e, f] = value.to_be_bytes();
                put(out, &[fc, a, b, c, d, e, f])
            }
            Request::Diagnostics { sub, data } => {
                let [a, b] = sub.0.to_be_bytes();
                let [c, d] = data.to_be_bytes();
                put(out, &[fc, a, b, c, d])
            }
        }
    }

    /// Decode a request PDU (a drive's view).
    pub fn decode(pdu: &[u8]) -> Result<Request, PduError> {
        let &fc = pdu.first().ok_or(PduError::Empty)?;
        let function = FunctionCode::from_u8(fc).ok_or(PduError::UnknownFunction(fc))?;
        let start = StartAddress::from_raw(be16(pdu, 1));
        Ok(match function {
            FunctionCode::ReadWord => {
                exact(pdu, fc, 5)?;
                Request::ReadWord {
                    start,
                    count: be16(pdu, 3),
                }
            }
            FunctionCode::WriteWord => {
                exact(pdu, fc, 5)?;
                Request::WriteWord {
                    start,
                    value: be16(pdu, 3),
                }
            }
            FunctionCode::ReadLong => {
                exact(pdu, fc, 3)?;
                Request::ReadLong { start }
            }
            FunctionCode::WriteLong => {
                exact(pdu, fc, 7)?;
                Request::WriteLong {
                    start,
                    value: be32(pdu, 3),
                }
            }
            FunctionCode::Diagnostics => {
                exact(pdu, fc, 5)?;
                Request::Diagnostics {
                    sub: DiagSubFunction(be16(pdu, 1)),
                    data: be16(pdu, 3),
                }
            }
        })
    }
}

impl Response {
    /// Encode into `out`; the number of bytes written.
    pub fn encode(&self, out: &mut [u8]) -> Result<usize, BufferTooSmall> {
        match *self {
            Response::ReadWord { value } => {
                let [a, b] = value.to_be_bytes();
                put(out, &[3, 2, a, b])
            }
            Response::WriteWord { start, value } => {
                let [a, b] = start.raw().to_be_bytes();
                let [c, d] = value.to_be_bytes();
                put(out, &[6, a, b, c, d])
            }
            Response::ReadLong { value } => {
                let [a, b, c, d] = value.to_be_bytes();
                put(out, &[100, a, b, c, d])
            }
            Response::WriteLong { start, value } => {
                let [a, b] = start.raw().to_be_bytes();
                let [c, d, e, f] = value.to_be_bytes();
                put(out, &[101, a, b, c, d, e, f])
            }
            Response::Diagnostics { sub, data } => {
                let [a, b] = sub.0.to_be_bytes();
                let [c, d] = data.to_be_bytes();
                put(out, &[8, a, b, c, d])
            }
            Response::Exception { function, code } => put(out, &[function | 0x80, code.0]),
        }
    }

    /// Decode a response PDU (a master's view). A function code with bit 7 set is an
    /// exception response of two bytes, whatever the function.
    pub fn decode(pdu: &[u8]) -> Result<Response, PduError> {
        let &fc = pdu.first().ok_or(PduError::Empty)?;
        if fc & 0x80 != 0 {
            exact(pdu, fc, 2)?;
            return Ok(Response::Exception {
                function: fc & 0x7F,
                code: ExceptionCode(pdu.get(1).copied().unwrap_or(0)),
            });
        }
        let function = FunctionCode::from_u8(fc).ok_or(PduError::UnknownFunction(fc))?;
        Ok(match function {
            FunctionCode::ReadWord => {
                let &count = pdu.get(1).ok_or(PduError::Length {
                    function: fc,
                    expected: 4,
                    got: pdu.len(),
                })?;
                if count != 2 {
                    return Err(PduError::ByteCount(count));
                }
                exact(pdu, fc, 4)?;
                Response::ReadWord {
                    value: be16(pdu, 2),
                }
            }
            FunctionCode::WriteWord => {
                exact(pdu, fc, 5)?;
                Response::WriteWord {
                    start: StartAddress::from_raw(be16(pdu, 1)),
                    value: be16(pdu, 3),
                }
            }
            FunctionCode::ReadLong => {
                exact(pdu, fc, 5)?;
                Response::ReadLong {
                    value: be32(pdu, 1),
                }
            }
            FunctionCode::WriteLong => {
                exact(pdu, fc, 7)?;
                Response::WriteLong {
                    start: StartAddress::from_raw(be16(pdu, 1)),
                    value: be32(pdu, 3),
                }
            }
            FunctionCode::Diagnostics => {
                exact(pdu, fc, 5)?;
                Response::Diagnostics {
                    sub: DiagSubFunction(be16(pdu, 1)),
                    data: be16(pdu, 3),
                }
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn req(bytes: &[u8]) -> Request {
        let r = Request::decode(bytes).unwrap();
        let mut out = [0u8; MAX_PDU];
        let n = r.encode(&mut out).unwrap();
        assert_eq!(&out[..n], bytes);
        r
    }

    fn resp(bytes: &[u8]) -> Response {
        let r = Response::decode(bytes).unwrap();
        let mut out = [0u8; MAX_PDU];
        let n = r.encode(&mut out).unwrap();
        assert_eq!(&out[..n], bytes);
        r
    }

    #[test]
    fn the_manuals_pdus_of_ch_8_1() {
        // 8.1.1: read 372 in data set 2; the answer 0x056E = 1390.
        assert_eq!(
            req(&[0x03, 0x21, 0x74, 0x00, 0x01]),
            Request::ReadWord {
                start: StartAddress::from_raw(0x2174),
                count: 1
            }
        );
        assert_eq!(
            resp(&[0x03, 0x02, 0x05, 0x6E]),
            Response::ReadWord { value: 1390 }
        );
        // Example 2: register count 2, answered with exception 2.
        assert_eq!(
            req(&[0x03, 0x01, 0x74, 0x00, 0x02]),
            Request::ReadWord {
                start: StartAddress::from_raw(0x0174),
                count: 2
            }
        );
        assert_eq!(
            resp(&[0x83, 0x02]),
            Response::Exception {
                function: 3,
                code: ExceptionCode::ILLEGAL_DATA_ADDRESS
            }
        );
        // 8.1.3: read 481 (data set 0), 0x000003E8; unknown 1600 → E4 04.
        assert_eq!(
            req(&[0x64, 0x01, 0xE1]),
            Request::ReadLong {
                start: StartAddress::from_raw(0x01E1)
            }
        );
        assert_eq!(
            resp(&[0x64, 0x00, 0x00, 0x03, 0xE8]),
            Response::ReadLong { value: 1000 }
        );
        assert_eq!(
            resp(&[0xE4, 0x04]),
            Response::Exception {
                function: 100,
                code: ExceptionCode::SLAVE_DEVICE_FAILURE
            }
        );
    }

    #[test]
    fn bad_pdus_are_typed_errors_with_the_drives_exception() {
        assert_eq!(Request::decode(&[]), Err(PduError::Empty));
        assert_eq!(
            Request::decode(&[0x10, 0, 0]),
            Err(PduError::UnknownFunction(0x10))
        );
        assert_eq!(
            PduError::UnknownFunction(0x10).exception(),
            ExceptionCode::ILLEGAL_FUNCTION
        );
        let short = Request::decode(&[0x03, 0x21]).unwrap_err();
        assert_eq!(short.exception(), ExceptionCode::ILLEGAL_DATA_VALUE);
        assert_eq!(
            Response::decode(&[0x03, 0x04, 0, 0, 0, 0]),
            Err(PduError::ByteCount(4))
        );
        assert!(Response::decode(&[0x83]).is_err());
        let mut small = [0u8; 2];
        assert_eq!(
            Request::ReadLong {
                start: StartAddress::from_raw(0)
            }
            .encode(&mut small),
            Err(BufferTooSmall { needed: 3 })
        );
    }
}
