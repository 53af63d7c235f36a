//! Requests, responses, function codes, exception codes and diagnostic sub-functions.

use core::fmt;

use super::StartAddress;

/// The function codes a Bonfiglioli drive supports (ch. 6.4).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum FunctionCode {
    /// 3: read a 16-bit parameter (one holding register).
    ReadWord,
    /// 6: write a 16-bit parameter (one register).
    WriteWord,
    /// 8: diagnostics (the bus counters).
    Diagnostics,
    /// 100 (0x64): read a 32-bit parameter (Bonfiglioli's own).
    ReadLong,
    /// 101 (0x65): write a 32-bit parameter (Bonfiglioli's own).
    WriteLong,
}

impl FunctionCode {
    /// The code `c`, if the drive supports it.
    pub const fn from_u8(c: u8) -> Option<FunctionCode> {
        match c {
            3 => Some(FunctionCode::ReadWord),
            6 => Some(FunctionCode::WriteWord),
            8 => Some(FunctionCode::Diagnostics),
            100 => Some(FunctionCode::ReadLong),
            101 => Some(FunctionCode::WriteLong),
            _ => None,
        }
    }

    /// The code on the wire.
    pub const fn code(self) -> u8 {
        match self {
            FunctionCode::ReadWord => 3,
            FunctionCode::WriteWord => 6,
            FunctionCode::Diagnostics => 8,
            FunctionCode::ReadLong => 100,
            FunctionCode::WriteLong => 101,
        }
    }

    /// The English name.
    pub const fn name(self) -> &'static str {
        match self {
            FunctionCode::ReadWord => "read 16-bit parameter",
            FunctionCode::WriteWord => "write 16-bit parameter",
            FunctionCode::Diagnostics => "diagnostics",
            FunctionCode::ReadLong => "read 32-bit parameter",
            FunctionCode::WriteLong => "write 32-bit parameter",
        }
    }
}

/// A Modbus exception code (ch. 6.6). The drive sends 1–4; any other value is kept as it came.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ExceptionCode(pub u8);

impl ExceptionCode {
    /// 1: unknown function code or diagnostic sub-function.
    pub const ILLEGAL_FUNCTION: ExceptionCode = ExceptionCode(1);
    /// 2: register count not 1, unknown parameter or wrong data type.
    pub const ILLEGAL_DATA_ADDRESS: ExceptionCode = ExceptionCode(2);
    /// 3: too few or too many bytes, a field not at its fixed value.
    pub const ILLEGAL_DATA_VALUE: ExceptionCode = ExceptionCode(3);
    /// 4: reading or writing the parameter failed; the VABus error register (parameter 11)
    /// says why.
    pub const SLAVE_DEVICE_FAILURE: ExceptionCode = ExceptionCode(4);

    /// The manual's entry for this code, if it has one.
    pub fn meaning(self) -> Option<&'static drive_profile::bonfiglioli::ModbusException> {
        drive_profile::bonfiglioli::modbus_exception(self.0)
    }
}

impl fmt::Display for ExceptionCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.meaning() {
            Some(m) => write!(f, "exception {} ({})", self.0, m.name_en),
            None => write!(f, "exception {} (not a Modbus exception code)", self.0),
        }
    }
}

/// A diagnostic sub-function of function code 8 (ch. 6.4.5).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct DiagSubFunction(pub u16);

impl DiagSubFunction {
    /// 0x0A: clear all counters.
    pub const CLEAR_COUNTERS: DiagSubFunction = DiagSubFunction(0x0A);
    /// 0x0B: valid messages received (any address).
    pub const BUS_MESSAGES: DiagSubFunction = DiagSubFunction(0x0B);
    /// 0x0C: messages with a CRC/LRC, parity, framing or overrun error.
    pub const BUS_COMMUNICATION_ERRORS: DiagSubFunction = DiagSubFunction(0x0C);
    /// 0x0D: exception responses sent.
    pub const BUS_EXCEPTION_ERRORS: DiagSubFunction = DiagSubFunction(0x0D);
    /// 0x0E: messages received for this slave's address.
    pub const SLAVE_MESSAGES: DiagSubFunction = DiagSubFunction(0x0E);
    /// 0x0F: broadcast messages received ("slave no response").
    pub const SLAVE_NO_RESPONSE: DiagSubFunction = DiagSubFunction(0x0F);
    /// 0x10: negative acknowledgements (not used: always 0).
    pub const SLAVE_NAK: DiagSubFunction = DiagSubFunction(0x10);
    /// 0x11: slave busy (not used: always 0).
    pub const SLAVE_BUSY: DiagSubFunction = DiagSubFunction(0x11);
    /// 0x12: messages with a character overrun.
    pub const BUS_CHARACTER_OVERRUN: DiagSubFunction = DiagSubFunction(0x12);

    /// The counters 0x0B–0x12 in order.
    pub const COUNTERS: [DiagSubFunction; 8] = [
        Self::BUS_MESSAGES,
        Self::BUS_COMMUNICATION_ERRORS,
        Self::BUS_EXCEPTION_ERRORS,
        Self::SLAVE_MESSAGES,
        Self::SLAVE_NO_RESPONSE,
        Self::SLAVE_NAK,
        Self::SLAVE_BUSY,
        Self::BUS_CHARACTER_OVERRUN,
    ];

    /// Whether the drive supports it (0x0A–0x12).
    pub const fn is_supported(self) -> bool {
        self.0 >= 0x0A && self.0 <= 0x12
    }

    /// What it returns, in English (None outside 0x0A–0x12).
    pub const fn name(self) -> Option<&'static str> {
        Some(match self.0 {
            0x0A => "clear all counters",
            0x0B => "bus messages",
            0x0C => "bus communication errors",
            0x0D => "bus exception errors",
            0x0E => "slave messages",
            0x0F => "slave no response (broadcasts)",
            0x10 => "slave NAK (not used, always 0)",
            0x11 => "slave busy (not used, always 0)",
            0x12 => "bus character overruns",
            _ => return None,
        })
    }
}

/// A request from the master, as decoded: it may still be one the drive refuses (a register
/// count other than 1, an unknown parameter), which the slave answers with an exception.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Request {
    /// FC 3: read a 16-bit parameter; `count` must be 1 (else exception 2).
    ReadWord {
        /// Data set and parameter.
        start: StartAddress,
        /// Register count (always 1 from a correct master).
        count: u16,
    },
    /// FC 6: write a 16-bit parameter.
    WriteWord {
        /// Data set and parameter.
        start: StartAddress,
        /// The value.
        value: u16,
    },
    /// FC 100: read a 32-bit parameter.
    ReadLong {
        /// Data set and parameter.
        start: StartAddress,
    },
    /// FC 101: write a 32-bit parameter.
    WriteLong {
        /// Data set and parameter.
        start: StartAddress,
        /// The value.
        value: u32,
    },
    /// FC 8: a diagnostic sub-function; `data` must be 0 in a request (else exception 3).
    Diagnostics {
        /// The sub-function.
        sub: DiagSubFunction,
        /// The data field.
        data: u16,
    },
}

impl Request {
    /// Its function code.
    pub const fn function(&self) -> FunctionCode {
        match self {
            Request::ReadWord { .. } => FunctionCode::ReadWord,
            Request::WriteWord { .. } => FunctionCode::WriteWord,
            Request::ReadLong { .. } => FunctionCode::ReadLong,
            Request::WriteLong { .. } => FunctionCode::WriteLong,
            Request::Diagnostics { .. } => FunctionCode::Diagnostics,
        }
    }

    /// Whether a broadcast may carry it: writes only (ch. 6.1).
    pub const fn is_write(&self) -> bool {
        matches!(self, Request::WriteWord { .. } | Request::WriteLong { .. })
    }
}

/// A response of the drive.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Response {
    /// FC 3: the 16-bit value (byte count 2).
    ReadWord {
        /// The value.
        value: u16,
    },
    /// FC 6: the request echoed.
    WriteWord {
        /// Data set and parameter.
        start: StartAddress,
        /// The value.
        value: u16,
    },
    /// FC 100: the 32-bit value.
    ReadLong {
        /// The value.
        value: u32,
    },
    /// FC 101: the request echoed.
    WriteLong {
        /// Data set and parameter.
        start: StartAddress,
        /// The value.
        value: u32,
    },
    /// FC 8: the sub-function and its data (a counter, or 0 after clearing).
    Diagnostics {
        /// The sub-function.
        sub: DiagSubFunction,
        /// The counter value.
        data: u16,
    },
    /// The function code with bit 7 set and an exception code (ch. 6.5).
    Exception {
        /// The function code of the request (without bit 7).
        function: u8,
        /// Why.
        code: ExceptionCode,
    },
}

impl Response {
    /// The function code the response answers (bit 7 cleared for an exception).
    pub const fn function_code(&self) -> u8 {
        match self {
            Response::ReadWord { .. } => 3,
            Response::WriteWord { .. } => 6,
            Response::ReadLong { .. } => 100,
            Response::WriteLong { .. } => 101,
            Response::Diagnostics { .. } => 8,
            Response::Exception { function, .. } => *function,
        }
    }
}
