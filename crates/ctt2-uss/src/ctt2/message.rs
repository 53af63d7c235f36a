//! CTT2 messages (BU 0255 sections 4.2 and 4.3): the four requests a master sends to the 2nd
//! slave of the double slave and the answers it gets back, with their codes, indices, lengths
//! and error codes.
//!
//! | request | code | index | bytes after the code | OK answer | negative answer |
//! |---|---|---|---|---|---|
//! | standard read | 16 | 0 ID object, 1 diagnosis object | index, length | 80 + data | 144 + error |
//! | NORD read | 18 | 3 PZD, 4 PKW with address, 47 PKW | index, length | 82 + data | 146 + error |
//! | NORD write | 19 | 3, 4, 47 | index, length, data | 83 | 147 + error |
//! | NORD write/read | 29 | 3, 4, 47 | index, read length, write length, data | 93 + data | 157 + error |
//!
//! The negative answer to 29 is **157** (9Dh); the manual prints 177 (erratum E3).
//! [`Response::decode`] accepts 177 as well and marks the answer
//! ([`Response::Error::code_177`]), so a drive whose firmware follows the misprint is still
//! understood and the user can see that it does (erratum E19).
//!
//! Every type here is `Copy` and holds its data inline ([`Data`], at most [`MAX_DATA`] bytes):
//! encode and decode never allocate. Decoding checks everything a double slave checks
//! (section 4.3.5), and [`DecodeError::answer`] is the negative answer the double slave sends
//! for it.

use core::fmt;

use drive_profile::nord::{self, Ctt2MessageType};

/// The message codes (byte 1 of every CTT2 message).
pub mod code {
    /// Standard read request.
    pub const STANDARD_READ: u8 = 16;
    /// NORD read request.
    pub const NORD_READ: u8 = 18;
    /// NORD write request.
    pub const NORD_WRITE: u8 = 19;
    /// NORD write/read request.
    pub const NORD_WRITE_READ: u8 = 29;
    /// Standard read answer OK (request + 40h).
    pub const STANDARD_READ_OK: u8 = 80;
    /// NORD read answer OK.
    pub const NORD_READ_OK: u8 = 82;
    /// NORD write answer OK.
    pub const NORD_WRITE_OK: u8 = 83;
    /// NORD write/read answer OK.
    pub const NORD_WRITE_READ_OK: u8 = 93;
    /// Standard read answer not OK (request + 80h). Also the answer to an unknown request
    /// (error 3, section 4.3.5).
    pub const STANDARD_READ_ERROR: u8 = 144;
    /// NORD read answer not OK.
    pub const NORD_READ_ERROR: u8 = 146;
    /// NORD write answer not OK.
    pub const NORD_WRITE_ERROR: u8 = 147;
    /// NORD write/read answer not OK: 29 + 80h (erratum E3).
    pub const NORD_WRITE_READ_ERROR: u8 = 157;
    /// What the manual prints for the negative write/read answer (erratum E3); decoded as an
    /// alias of [`NORD_WRITE_READ_ERROR`].
    pub const NORD_WRITE_READ_ERROR_PRINTED: u8 = 177;
}

/// The most data bytes any message carries: the 14-byte ID object.
pub const MAX_DATA: usize = 14;

/// The longest request: code, index, read length, write length and 9 data bytes.
pub const MAX_REQUEST: usize = 4 + 9;

/// The longest answer: code and 14 data bytes.
pub const MAX_RESPONSE: usize = 1 + MAX_DATA;

/// The address of the drive in the channels that carry one (PZD, PKW with address): always 1
/// (section 4.3).
pub const DRIVE_ADDRESS: u8 = 1;

/// The request code of a message type.
pub const fn request_code(kind: Ctt2MessageType) -> u8 {
    match kind {
        Ctt2MessageType::StandardRead => code::STANDARD_READ,
        Ctt2MessageType::NordRead => code::NORD_READ,
        Ctt2MessageType::NordWrite => code::NORD_WRITE,
        Ctt2MessageType::NordWriteRead => code::NORD_WRITE_READ,
    }
}

/// The code of the positive answer to a message type (request code + 40h).
pub const fn ok_code(kind: Ctt2MessageType) -> u8 {
    request_code(kind) + 0x40
}

/// The code of the negative answer to a message type (request code + 80h; 157 for 29).
pub const fn error_code(kind: Ctt2MessageType) -> u8 {
    request_code(kind) + 0x80
}

/// The message type a request code stands for.
pub const fn kind_of_request(code: u8) -> Option<Ctt2MessageType> {
    match code {
        code::STANDARD_READ => Some(Ctt2MessageType::StandardRead),
        code::NORD_READ => Some(Ctt2MessageType::NordRead),
        code::NORD_WRITE => Some(Ctt2MessageType::NordWrite),
        code::NORD_WRITE_READ => Some(Ctt2MessageType::NordWriteRead),
        _ => None,
    }
}

/// The objects of the standard read (section 4.3.1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum StandardIndex {
    /// Index 0: the ID object, 14 bytes ([`IdObject`](super::IdObject)).
    Id = 0,
    /// Index 1: the diagnosis object, 3 bytes ([`DiagnosisObject`](super::DiagnosisObject)).
    Diagnosis = 1,
}

impl StandardIndex {
    /// The index byte.
    pub const fn index(self) -> u8 {
        self as u8
    }

    /// The object with index `index`, if the double slave has it.
    pub const fn from_index(index: u8) -> Option<StandardIndex> {
        match index {
            0 => Some(StandardIndex::Id),
            1 => Some(StandardIndex::Diagnosis),
            _ => None,
        }
    }

    /// The object's length: a longer read returns only this much.
    pub const fn max_len(self) -> u8 {
        match self {
            StandardIndex::Id => 14,
            StandardIndex::Diagnosis => 3,
        }
    }
}

/// The channels of the three NORD message types (sections 4.2, 4.3.2 to 4.3.4).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Channel {
    /// Index 3: process data, the drive address then STW and 0–3 setpoints (write) or ZSW and
    /// 0–3 actual values (read): 3, 5, 7 or 9 bytes.
    Pzd = 3,
    /// Index 4: the parameter channel after the drive address, 9 bytes.
    PkwWithAddress = 4,
    /// Index 47: the parameter channel without address, 8 bytes.
    Pkw = 47,
}

impl Channel {
    /// The index byte.
    pub const fn index(self) -> u8 {
        self as u8
    }

    /// The channel with index `index`, if the double slave has it.
    pub const fn from_index(index: u8) -> Option<Channel> {
        match index {
            3 => Some(Channel::Pzd),
            4 => Some(Channel::PkwWithAddress),
            47 => Some(Channel::Pkw),
            _ => None,
        }
    }

    /// The channel's length: a longer read returns only this much.
    pub const fn max_len(self) -> u8 {
        match self {
            Channel::Pzd | Channel::PkwWithAddress => 9,
            Channel::Pkw => 8,
        }
    }

    /// Whether the channel's data start with the drive address (always 1).
    pub const fn has_address(self) -> bool {
        !matches!(self, Channel::Pkw)
    }

    /// Whether `len` data bytes may be written (section 4.3.5: PKW only complete, PZD the
    /// address, STW and whole setpoint words).
    pub const fn write_len_ok(self, len: u8) -> bool {
        match self {
            Channel::Pzd => matches!(len, 3 | 5 | 7 | 9),
            Channel::PkwWithAddress => len == 9,
            Channel::Pkw => len == 8,
        }
    }

    /// Whether this is one of the two parameter channels.
    pub const fn is_pkw(self) -> bool {
        !matches!(self, Channel::Pzd)
    }
}

/// Up to [`MAX_DATA`] bytes held inline: the data of a write or of an answer (the bytes past
/// the length are always 0).
#[derive(Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Data {
    len: u8,
    bytes: [u8; MAX_DATA],
}

impl Data {
    /// No bytes.
    pub const EMPTY: Data = Data {
        len: 0,
        bytes: [0; MAX_DATA],
    };

    /// The data `bytes`; `None` when longer than [`MAX_DATA`].
    #[inline]
    pub fn new(bytes: &[u8]) -> Option<Data> {
        let n = bytes.len();
        if n > MAX_DATA {
            return None;
        }
        let mut d = Data::EMPTY;
        copy_small(&mut d.bytes, bytes);
        d.len = n as u8;
        Some(d)
    }

    /// The first `len` bytes of `bytes` (the rest must be 0, as every caller in this crate
    /// makes them).
    pub(crate) const fn from_array(bytes: [u8; MAX_DATA], len: u8) -> Data {
        Data {
            len: if (len as usize) < MAX_DATA {
                len
            } else {
                MAX_DATA as u8
            },
            bytes,
        }
    }

    /// The bytes.
    #[inline]
    pub fn as_slice(&self) -> &[u8] {
        self.bytes
            .get(..usize::from(self.len))
            .unwrap_or(&self.bytes)
    }

    /// Number of bytes.
    pub const fn len(&self) -> usize {
        self.len as usize
    }

    /// Whether there are none.
    pub const fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The first `n` bytes (all of them if there are fewer).
    pub fn truncated(mut self, n: u8) -> Data {
        self.len = self.len.min(n);
        // Bytes past the length stay 0, so that equal data compare equal.
        if let Some(rest) = self.bytes.get_mut(usize::from(self.len)..) {
            rest.fill(0);
        }
        self
    }
}

impl fmt::Debug for Data {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Data({:02x?})", self.as_slice())
    }
}

/// A CTT2 error code (byte 2 of a negative answer, section 4.3.5).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum ErrorCode {
    /// 1: the index is not implemented (anything but 0/1 for the standard read, 3/4/47 for
    /// the NORD messages).
    InvalidIndex = 1,
    /// 2: the length is not allowed (a write longer than the object, a PKW write that is not
    /// complete, a PZD write without STW or with half a word, a length byte that disagrees with
    /// the bytes present).
    InvalidLength = 2,
    /// 3: the request is not implemented (an unknown code; answered with 144).
    NotImplemented = 3,
    /// 4: busy: the request was not done within the 200 ms window.
    Busy = 4,
    /// 5: the previous request has not been answered yet.
    PreviousPending = 5,
}

impl ErrorCode {
    /// The code byte.
    pub const fn code(self) -> u8 {
        self as u8
    }

    /// The error code `code`, if the manual defines it.
    pub const fn from_code(code: u8) -> Option<ErrorCode> {
        match code {
            1 => Some(ErrorCode::InvalidIndex),
            2 => Some(ErrorCode::InvalidLength),
            3 => Some(ErrorCode::NotImplemented),
            4 => Some(ErrorCode::Busy),
            5 => Some(ErrorCode::PreviousPending),
            _ => None,
        }
    }

    /// The manual's table entry (German and English meaning).
    pub fn info(self) -> Option<&'static nord::Ctt2Error> {
        nord::ctt2_error(self.code())
    }
}

impl fmt::Display for ErrorCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.info() {
            Some(e) => write!(f, "{e}"),
            None => write!(f, "CTT2 error {}", self.code()),
        }
    }
}

/// Why bytes are not a valid CTT2 message. For a request, [`DecodeError::error_code`] is the
/// CTT2 error the double slave answers with and [`DecodeError::answer`] the whole answer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, thiserror::Error)]
#[non_exhaustive]
pub enum DecodeError {
    /// No byte at all.
    #[error("empty message")]
    Empty,
    /// A code that is no request (decoding a request) or no answer (decoding an answer).
    #[error("unknown message code {0}")]
    UnknownCode(u8),
    /// An index the message type does not have.
    #[error("message code {code}: index {index} is not implemented")]
    InvalidIndex {
        /// The message code.
        code: u8,
        /// The index received.
        index: u8,
    },
    /// Fewer bytes than the message's fixed part.
    #[error("message code {code} needs at least {needed} bytes, got {got}")]
    Truncated {
        /// The message code.
        code: u8,
        /// Bytes needed.
        needed: u8,
        /// Bytes present.
        got: u8,
    },
    /// More bytes than the message can have.
    #[error("message code {code} has {got} bytes, at most {max} allowed")]
    TooLong {
        /// The message code.
        code: u8,
        /// The longest the message may be.
        max: u8,
        /// Bytes present (saturated at 255).
        got: u8,
    },
    /// The write length byte disagrees with the data bytes present.
    #[error("message code {code}: write length {declared} but {present} data bytes")]
    LengthMismatch {
        /// The message code.
        code: u8,
        /// The write length byte.
        declared: u8,
        /// Data bytes present (saturated at 255).
        present: u8,
    },
    /// A write length the channel does not allow (PZD: 3, 5, 7, 9; PKW with address: 9; PKW:
    /// 8).
    #[error("message code {code}: {len} bytes cannot be written to index {index}")]
    BadWriteLength {
        /// The message code.
        code: u8,
        /// The channel's index.
        index: u8,
        /// The write length.
        len: u8,
    },
    /// A negative answer with an error code the manual does not define.
    #[error("answer code {code} with unknown error code {error}")]
    UnknownErrorCode {
        /// The answer code.
        code: u8,
        /// The error code received.
        error: u8,
    },
}

impl DecodeError {
    /// The CTT2 error a double slave answers a request with that fails this way.
    pub const fn error_code(&self) -> ErrorCode {
        match self {
            DecodeError::Empty | DecodeError::UnknownCode(_) => ErrorCode::NotImplemented,
            DecodeError::InvalidIndex { .. } => ErrorCode::InvalidIndex,
            DecodeError::Truncated { .. }
            | DecodeError::TooLong { .. }
            | DecodeError::LengthMismatch { .. }
            | DecodeError::BadWriteLength { .. }
            | DecodeError::UnknownErrorCode { .. } => ErrorCode::InvalidLength,
        }
    }

    /// The negative answer a double slave sends for a request that fails this way: the
    /// request type's "not OK" code, or 144 ("Standard Lese-Antwort nicht OK") with error 3
    /// for a code it does not know (section 4.3.5).
    pub const fn answer(&self) -> Response {
        let kind = match self {
            DecodeError::InvalidIndex { code, .. }
            | DecodeError::Truncated { code, .. }
            | DecodeError::TooLong { code, .. }
            | DecodeError::LengthMismatch { code, .. }
            | DecodeError::BadWriteLength { code, .. }
            | DecodeError::UnknownErrorCode { code, .. } => match kind_of_request(*code) {
                Some(k) => k,
                None => Ctt2MessageType::StandardRead,
            },
            DecodeError::Empty | DecodeError::UnknownCode(_) => Ctt2MessageType::StandardRead,
        };
        Response::error(kind, self.error_code())
    }
}

/// Why a message cannot be encoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, thiserror::Error)]
#[non_exhaustive]
pub enum EncodeError {
    /// The output buffer is too small.
    #[error("output buffer of {got} bytes is too small for {needed}")]
    BufferTooSmall {
        /// Bytes needed.
        needed: u8,
        /// Bytes available (saturated at 255).
        got: u8,
    },
    /// A write whose length the channel does not allow (the drive would answer error 2).
    #[error("{len} bytes cannot be written to index {index}")]
    BadWriteLength {
        /// The channel's index.
        index: u8,
        /// The data length.
        len: u8,
    },
    /// A positive answer to a NORD write with data (that answer is the code alone).
    #[error("the answer to a NORD write carries no data ({0} bytes given)")]
    DataOnWriteAnswer(u8),
    /// `code_177` on a negative answer that is not the write/read answer.
    #[error("code 177 exists only as the misprinted write/read answer")]
    Code177NotWriteRead,
}

/// A request from the AS-i master to the double slave.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Request {
    /// Code 16: read `len` bytes of a standard object.
    StandardRead {
        /// The object.
        index: StandardIndex,
        /// Bytes to read (a longer read returns only the object).
        len: u8,
    },
    /// Code 18: read `len` bytes of a channel (PZD: address, ZSW, IW1–IW3; PKW: the answer to
    /// the last order).
    NordRead {
        /// The channel.
        index: Channel,
        /// Bytes to read (a longer read returns only the channel).
        len: u8,
    },
    /// Code 19: write a channel (PZD: address, STW, SW1–SW3; PKW: an order).
    NordWrite {
        /// The channel.
        index: Channel,
        /// The bytes written, with the address where the channel has one.
        data: Data,
    },
    /// Code 29: write a channel and read it back in one message.
    NordWriteRead {
        /// The channel.
        index: Channel,
        /// Bytes to read.
        read_len: u8,
        /// The bytes written.
        data: Data,
    },
}

impl Request {
    /// The message type.
    pub const fn kind(&self) -> Ctt2MessageType {
        match self {
            Request::StandardRead { .. } => Ctt2MessageType::StandardRead,
            Request::NordRead { .. } => Ctt2MessageType::NordRead,
            Request::NordWrite { .. } => Ctt2MessageType::NordWrite,
            Request::NordWriteRead { .. } => Ctt2MessageType::NordWriteRead,
        }
    }

    /// The code byte.
    pub const fn code(&self) -> u8 {
        request_code(self.kind())
    }

    /// The index byte.
    pub const fn index(&self) -> u8 {
        match self {
            Request::StandardRead { index, .. } => index.index(),
            Request::NordRead { index, .. }
            | Request::NordWrite { index, .. }
            | Request::NordWriteRead { index, .. } => index.index(),
        }
    }

    /// The number of bytes [`Request::encode`] writes.
    pub const fn encoded_len(&self) -> usize {
        match self {
            Request::StandardRead { .. } | Request::NordRead { .. } => 3,
            Request::NordWrite { data, .. } => 3 + data.len(),
            Request::NordWriteRead { data, .. } => 4 + data.len(),
        }
    }

    /// Encode to the front of `out`; returns the length. A write must have a length its
    /// channel allows.
    pub fn encode(&self, out: &mut [u8]) -> Result<usize, EncodeError> {
        let n = self.encoded_len();
        let Some(dst) = out.get_mut(..n) else {
            return Err(EncodeError::BufferTooSmall {
                needed: n as u8,
                got: out.len().min(255) as u8,
            });
        };
        let check = |index: Channel, data: &Data| {
            let len = data.len() as u8;
            if index.write_len_ok(len) {
                Ok(len)
            } else {
                Err(EncodeError::BadWriteLength {
                    index: index.index(),
                    len,
                })
            }
        };
        match self {
            Request::StandardRead { index, len } => {
                dst.copy_from_slice(&[code::STANDARD_READ, index.index(), *len]);
            }
            Request::NordRead { index, len } => {
                dst.copy_from_slice(&[code::NORD_READ, index.index(), *len]);
            }
            Request::NordWrite { index, data } => {
                let len = check(*index, data)?;
                let (head, rest) = dst.split_at_mut(3);
                head.copy_from_slice(&[code::NORD_WRITE, index.index(), len]);
                rest.copy_from_slice(data.as_slice());
            }
            Request::NordWriteRead {
                index,
                read_len,
                data,
            } => {
                let len = check(*index, data)?;
                let (head, rest) = dst.split_at_mut(4);
                head.copy_from_slice(&[code::NORD_WRITE_READ, index.index(), *read_len, len]);
                rest.copy_from_slice(data.as_slice());
            }
        }
        Ok(n)
    }

    /// Decode a whole request, checking what the double slave checks (section 4.3.5): the code
    /// (3), the index (1), then the lengths (2).
    pub fn decode(bytes: &[u8]) -> Result<Request, DecodeError> {
        // The well-formed requests, straight; everything else through the checks below, which
        // find the right error.
        match *bytes {
            [code::STANDARD_READ, index, len] => {
                if let Some(index) = StandardIndex::from_index(index) {
                    return Ok(Request::StandardRead { index, len });
                }
            }
            [code::NORD_READ, index, len] => {
                if let Some(index) = Channel::from_index(index) {
                    return Ok(Request::NordRead { index, len });
                }
            }
            [code::NORD_WRITE, index, len, ref data @ ..] => {
                if let Some(index) = Channel::from_index(index)
                    && data.len() == usize::from(len)
                    && index.write_len_ok(len)
                    && let Some(data) = Data::new(data)
                {
                    return Ok(Request::NordWrite { index, data });
                }
            }
            [code::NORD_WRITE_READ, index, read_len, len, ref data @ ..] => {
                if let Some(index) = Channel::from_index(index)
                    && data.len() == usize::from(len)
                    && index.write_len_ok(len)
                    && let Some(data) = Data::new(data)
                {
                    return Ok(Request::NordWriteRead {
                        index,
                        read_len,
                        data,
                    });
                }
            }
            _ => {}
        }
        Self::decode_checked(bytes)
    }

    /// The full checks, in the double slave's order.
    fn decode_checked(bytes: &[u8]) -> Result<Request, DecodeError> {
        let (&code, rest) = bytes.split_first().ok_or(DecodeError::Empty)?;
        let got = sat(bytes.len());
        let kind = kind_of_request(code).ok_or(DecodeError::UnknownCode(code))?;
        let head = if kind == Ctt2MessageType::NordWriteRead {
            4
        } else {
            3
        };
        // The index is checked first: a request for an index that does not exist is error 1
        // even when it is also too short.
        if let Some(&index) = rest.first() {
            let known = match kind {
                Ctt2MessageType::StandardRead => StandardIndex::from_index(index).is_some(),
                _ => Channel::from_index(index).is_some(),
            };
            if !known {
                return Err(DecodeError::InvalidIndex { code, index });
            }
        }
        let (Some(fixed), data) = (bytes.get(..head), bytes.get(head..).unwrap_or(&[])) else {
            return Err(DecodeError::Truncated {
                code,
                needed: head as u8,
                got,
            });
        };
        let &[_, index, len, ..] = fixed else {
            return Err(DecodeError::Truncated {
                code,
                needed: head as u8,
                got,
            });
        };
        let channel =
            || Channel::from_index(index).ok_or(DecodeError::InvalidIndex { code, index });
        let write_data = |declared: u8, index: Channel| {
            if data.len() != usize::from(declared) {
                return Err(DecodeError::LengthMismatch {
                    code,
                    declared,
                    present: sat(data.len()),
                });
            }
            if !index.write_len_ok(declared) {
                return Err(DecodeError::BadWriteLength {
                    code,
                    index: index.index(),
                    len: declared,
                });
            }
            Data::new(data).ok_or(DecodeError::BadWriteLength {
                code,
                index: index.index(),
                len: declared,
            })
        };
        let no_data = || {
            if data.is_empty() {
                Ok(())
            } else {
                Err(DecodeError::TooLong { code, max: 3, got })
            }
        };
        match kind {
            Ctt2MessageType::StandardRead => {
                let index = StandardIndex::from_index(index)
                    .ok_or(DecodeError::InvalidIndex { code, index })?;
                no_data()?;
                Ok(Request::StandardRead { index, len })
            }
            Ctt2MessageType::NordRead => {
                let index = channel()?;
                no_data()?;
                Ok(Request::NordRead { index, len })
            }
            Ctt2MessageType::NordWrite => {
                let index = channel()?;
                let data = write_data(len, index)?;
                Ok(Request::NordWrite { index, data })
            }
            Ctt2MessageType::NordWriteRead => {
                let index = channel()?;
                let declared = fixed.get(3).copied().unwrap_or(0);
                let data = write_data(declared, index)?;
                Ok(Request::NordWriteRead {
                    index,
                    read_len: len,
                    data,
                })
            }
        }
    }
}

/// An answer from the double slave.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Response {
    /// Codes 80, 82, 83, 93: the request was carried out. `data` holds what was read (empty
    /// for a NORD write, whose answer is the code alone and says nothing about whether a
    /// parameter order has been executed).
    Ok {
        /// The message type answered.
        kind: Ctt2MessageType,
        /// The data read.
        data: Data,
    },
    /// Codes 144, 146, 147, 157 (or 177): the request failed with `error`.
    Error {
        /// The message type answered (standard read also for an unknown request).
        kind: Ctt2MessageType,
        /// The error code.
        error: ErrorCode,
        /// The answer came with code 177, the manual's misprint of 157 (errata E3 and E19).
        /// Encode writes 177 again; only valid with [`Ctt2MessageType::NordWriteRead`].
        code_177: bool,
    },
}

impl Response {
    /// A negative answer with the right code (157 for the write/read request).
    pub const fn error(kind: Ctt2MessageType, error: ErrorCode) -> Response {
        Response::Error {
            kind,
            error,
            code_177: false,
        }
    }

    /// The message type answered.
    pub const fn kind(&self) -> Ctt2MessageType {
        match self {
            Response::Ok { kind, .. } | Response::Error { kind, .. } => *kind,
        }
    }

    /// The code byte.
    pub const fn code(&self) -> u8 {
        match self {
            Response::Ok { kind, .. } => ok_code(*kind),
            Response::Error {
                code_177: true,
                kind: Ctt2MessageType::NordWriteRead,
                ..
            } => code::NORD_WRITE_READ_ERROR_PRINTED,
            Response::Error { kind, .. } => error_code(*kind),
        }
    }

    /// The number of bytes [`Response::encode`] writes.
    pub const fn encoded_len(&self) -> usize {
        match self {
            Response::Ok { data, .. } => 1 + data.len(),
            Response::Error { .. } => 2,
        }
    }

    /// Encode to the front of `out`; returns the length.
    pub fn encode(&self, out: &mut [u8]) -> Result<usize, EncodeError> {
        match self {
            Response::Ok {
                kind: Ctt2MessageType::NordWrite,
                data,
            } if !data.is_empty() => return Err(EncodeError::DataOnWriteAnswer(data.len() as u8)),
            Response::Error {
                kind,
                code_177: true,
                ..
            } if !matches!(kind, Ctt2MessageType::NordWriteRead) => {
                return Err(EncodeError::Code177NotWriteRead);
            }
            _ => {}
        }
        let n = self.encoded_len();
        let Some((first, rest)) = out.get_mut(..n).and_then(|d| d.split_first_mut()) else {
            return Err(EncodeError::BufferTooSmall {
                needed: n as u8,
                got: sat(out.len()),
            });
        };
        *first = self.code();
        match self {
            Response::Ok { data, .. } => rest.copy_from_slice(data.as_slice()),
            Response::Error { error, .. } => rest.copy_from_slice(&[error.code()]),
        }
        Ok(n)
    }

    /// Decode a whole answer. 177 is taken as the negative write/read answer (erratum E3),
    /// with [`Response::Error::code_177`] set.
    #[inline]
    pub fn decode(bytes: &[u8]) -> Result<Response, DecodeError> {
        let (&code, rest) = bytes.split_first().ok_or(DecodeError::Empty)?;
        let got = sat(bytes.len());
        let (kind, ok, code_177) = match code {
            code::STANDARD_READ_OK => (Ctt2MessageType::StandardRead, true, false),
            code::NORD_READ_OK => (Ctt2MessageType::NordRead, true, false),
            code::NORD_WRITE_OK => (Ctt2MessageType::NordWrite, true, false),
            code::NORD_WRITE_READ_OK => (Ctt2MessageType::NordWriteRead, true, false),
            code::STANDARD_READ_ERROR => (Ctt2MessageType::StandardRead, false, false),
            code::NORD_READ_ERROR => (Ctt2MessageType::NordRead, false, false),
            code::NORD_WRITE_ERROR => (Ctt2MessageType::NordWrite, false, false),
            code::NORD_WRITE_READ_ERROR => (Ctt2MessageType::NordWriteRead, false, false),
            code::NORD_WRITE_READ_ERROR_PRINTED => (Ctt2MessageType::NordWriteRead, false, true),
            other => return Err(DecodeError::UnknownCode(other)),
        };
        if ok {
            let max = if kind == Ctt2MessageType::NordWrite {
                1
            } else {
                MAX_RESPONSE
            };
            if bytes.len() > max {
                return Err(DecodeError::TooLong {
                    code,
                    max: max as u8,
                    got,
                });
            }
            let data = Data::new(rest).ok_or(DecodeError::TooLong {
                code,
                max: max as u8,
                got,
            })?;
            return Ok(Response::Ok { kind, data });
        }
        match rest {
            [] => Err(DecodeError::Truncated {
                code,
                needed: 2,
                got,
            }),
            [e] => {
                let error = ErrorCode::from_code(*e)
                    .ok_or(DecodeError::UnknownErrorCode { code, error: *e })?;
                Ok(Response::Error {
                    kind,
                    error,
                    code_177,
                })
            }
            _ => Err(DecodeError::TooLong { code, max: 2, got }),
        }
    }
}

/// Copy `src` (at most [`MAX_DATA`] bytes) to the front of `dst`, the rest 0: the bytes are
/// put together in a register from two fixed-size loads that may overlap (the first and the
/// last 8, 4, 2 or 1 bytes) and stored at once, instead of a `memcpy` call of a variable
/// length or piecewise stores that the next read of `dst` would have to wait for.
#[inline]
fn copy_small(dst: &mut [u8; MAX_DATA], src: &[u8]) {
    let n = src.len();
    // The value of the first `K` bytes and of the last `K` bytes, little-endian.
    fn ends<const K: usize>(src: &[u8]) -> (u128, u128) {
        let le = |c: &[u8; K]| {
            c.iter()
                .rev()
                .fold(0u128, |acc, &b| (acc << 8) | u128::from(b))
        };
        (
            src.first_chunk::<K>().map_or(0, le),
            src.last_chunk::<K>().map_or(0, le),
        )
    }
    let (first, last, k) = match n {
        0 => (0, 0, 0),
        1 => {
            let (f, l) = ends::<1>(src);
            (f, l, 1)
        }
        2..=3 => {
            let (f, l) = ends::<2>(src);
            (f, l, 2)
        }
        4..=7 => {
            let (f, l) = ends::<4>(src);
            (f, l, 4)
        }
        _ => {
            let (f, l) = ends::<8>(src);
            (f, l, 8)
        }
    };
    // The last K bytes start at byte n − K.
    let v = first
        | last
            .checked_shl(8 * (n.saturating_sub(k)) as u32)
            .unwrap_or(0);
    if let Some(d) = v.to_le_bytes().first_chunk::<MAX_DATA>() {
        *dst = *d;
    }
}

/// A length as a byte, saturated at 255.
fn sat(n: usize) -> u8 {
    n.min(255) as u8
}

#[cfg(test)]
mod tests {
    #![allow(clippy::indexing_slicing)]

    use super::{Data, MAX_DATA};

    /// Every length 0–14, every byte distinct: the two overlapping loads of `copy_small` put
    /// each byte in its place and leave the rest 0; 15 bytes do not fit.
    #[test]
    fn data_holds_exactly_the_bytes_given() {
        let src: [u8; MAX_DATA + 1] = core::array::from_fn(|i| 0xA0 + i as u8);
        for n in 0..=MAX_DATA {
            let d = Data::new(&src[..n]).expect("fits");
            assert_eq!(d.as_slice(), &src[..n], "{n} bytes");
            assert_eq!(
                d,
                Data::from_array(
                    core::array::from_fn(|i| if i < n { src[i] } else { 0 }),
                    n as u8
                )
            );
        }
        assert_eq!(Data::new(&src), None);
    }
}
